"""Gaussian-process regression of the modal parameters over the posture (METHODS.md §5), in
gpytorch, float64.

The model of ``m`` tasks (intrinsic coregionalisation)::

    cov(y_ij, y_kl) = K_t(x_i, x_k) K_c[j, l] + δ_ik δ_jl σ_j²

with an ARD squared-exponential posture kernel ``K_t = exp(−½ Σ_d (x_d − x'_d)² / ℓ_d²)`` shared by
the tasks, a free task covariance ``K_c = B Bᵀ + diag(v)`` (``B`` of ``rank`` columns: rank m is the
seed's free-form ``L Lᵀ``, a smaller rank the low-rank variant), one noise variance per task and a
constant mean per task, on standardised inputs and outputs. Hyperparameters maximise the log
marginal likelihood (L-BFGS from two starting length scales, the better kept). The single-task GP
(STGP: ``σ_f² K_t`` + noise) is the case m = 1.

For m > 1 the likelihood of the Kronecker-plus-diagonal covariance is evaluated through the
eigendecompositions of the two factors after whitening by the task noises (Rakitsch et al. 2013):
O(n³ + m³), so the model of all parameters costs about as much as one task. This is the algebra of
linear_operator's ``KroneckerProductAddedDiagLinearOperator``, written out in torch (:func:`icm_nll`,
gpytorch's constraints and parametrisation) because that operator diagonalises both factors twice
per evaluation, once for the solve and once for the log-determinant, which doubled the training
time; a test holds :func:`icm_nll` equal to gpytorch's ``ExactMarginalLogLikelihood`` of the same
model. The single-task GP (m = 1) is gpytorch's exact GP written the same way (:func:`single_nll`:
a Cholesky factor and the gradient in closed form, cheaper than gpytorch's operators and
autograd; a test holds its L-BFGS steps equal to gpytorch's). Kronecker inference
needs every task at every training posture: a posture where any task of a model is NaN is left out
of that model (``dropped_``). Predictions come from
:class:`~rmbench.predict.posterior.KronPosterior` (numpy, same algebra).

A covariance that is not positive definite is retried with more jitter and reported
(``retries_``, ``jitter_added_``), never silent; the Kronecker likelihood clamps the factors'
eigenvalues at zero, so its covariance (≥ the noise) cannot fail that way.
"""

from __future__ import annotations

import functools
import warnings

import numpy as np

from rmbench.errors import InputError, RmbenchError
from rmbench.predict.data import constant_tasks
from rmbench.predict.posterior import KronPosterior, loo_residuals

__all__ = ["MTGP", "STGP", "fit_icm", "icm_nll", "single_nll"]

# Noise variance floor in standardised units (σ_n ≥ 0.1 % of a task's spread): the modal fit's own
# scatter is above it for every parameter, and it keeps K_c ⊗ K_t + D well conditioned.
_NOISE_FLOOR = 1e-6
# Length scales in standardised input units: an input the parameter does not depend on drives its
# length scale up without bound (exp overflow, NaN); 100 spreads already mean "flat".
_LENGTHSCALE_BOUNDS = (1e-2, 1e2)


@functools.lru_cache(maxsize=None)
def _torch():
    """torch and gpytorch, imported without linear_operator's notice about torch.jit.script (its
    own business, not the user's)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*torch.jit.script.*is deprecated")
        import gpytorch
        import torch
    return torch, gpytorch


class MTGP:
    """Kronecker multi-task GP regression.

    Parameters
    ----------
    rank : int, optional
        Columns of ``B`` in ``K_c = B Bᵀ + diag(v)``; default: the number of tasks (free form).
    iterations : int
        L-BFGS iterations.
    seed : int

    Attributes
    ----------
    lengthscales_ : ndarray, shape (3,)
        ARD length scales in the inputs' units.
    task_covariance_ : ndarray, shape (m, m)
        ``K_c`` in the tasks' units (squared).
    noise_ : ndarray, shape (m,)
        Noise standard deviation per task, in the tasks' units.
    dropped_ : int
        Training postures left out because some task was NaN there.
    retries_ : int
        Fits retried with jitter on the covariance's diagonal; ``jitter_added_`` the largest added.
    loo_scale_ : ndarray, shape (m,)
        Root mean square of the leave-one-posture-out residuals in units of their predicted
        standard deviations (:func:`~rmbench.predict.posterior.loo_residuals`): the factor that
        calibrates the predicted standard deviations (1 where a task is constant or unlearnt).
    y_fit_, loo_mu_, loo_sd_ : ndarray, shape (n_fit, n_varying)
        At each training posture used (``posterior_.X``), the varying tasks' data, their
        leave-one-posture-out means and predictive standard deviations, in the tasks' units: what
        ``predict(..., source="data" | "loo")`` returns there.
    """

    def __init__(self, rank: int | None = None, iterations: int = 100, seed: int = 0):
        self.rank, self.iterations, self.seed = rank, int(iterations), int(seed)

    def fit(self, X, Y) -> "MTGP":
        """Maximise the marginal likelihood of one Kronecker model of all columns of ``Y``; returns
        ``self``, fitted (the attributes above). :class:`~rmbench.errors.InputError` when fewer
        than three postures have every task.

        Parameters
        ----------
        X : ndarray, shape (n_postures, 3)
            Training postures: x, y (m), θ (rad); standardised per column before the fit.
        Y : ndarray, shape (n_postures, m) or (n_postures,)
            The tasks' values, each in its own units. A posture where any task is NaN is left out
            (``dropped_``); a task without spread is kept as its constant, not learnt.
        """
        prep = self._prepare(X, Y)
        if prep is not None:
            Xs, Ys, rank = prep
            self._set(Xs, Ys, fit_icm(Xs, Ys[None], rank, iterations=self.iterations,
                                      seed=self.seed), 0)
        return self

    def _prepare(self, X, Y):
        """Drop incomplete rows and constant tasks, standardise; None when no task varies."""
        X, Y = np.asarray(X, float), np.asarray(Y, float)
        if Y.ndim == 1:
            Y = Y[:, None]
        rows = np.all(np.isfinite(Y), axis=1)
        self.dropped_ = int((~rows).sum())
        self.rows_ = rows
        self.retries_, self.jitter_added_ = 0, 0.0
        X, Y = X[rows], Y[rows]
        self.n_tasks_ = Y.shape[1]
        if len(Y) < 3:   # not even a constant can be learnt: say so rather than predict NaN
            raise InputError(f"{len(Y)} postures have every task of this model: a multi-task GP needs three "
                             "(modes found at some postures only; try mtgp-grouped or stgp)")
        # a task without spread (φL's reference element, fixed at 1) is that constant, not a GP task
        self.varying_ = np.flatnonzero(~constant_tasks(Y)) if len(Y) else np.arange(0)
        self.constant_ = Y[0].copy() if len(Y) else np.full(self.n_tasks_, np.nan)
        self.posterior_ = None
        self.loo_scale_ = np.ones(self.n_tasks_)
        Y = Y[:, self.varying_]
        n, m = Y.shape
        if m == 0:
            return None
        self.x_mean_, x_sd = X.mean(axis=0), X.std(axis=0)
        self.x_scale_ = np.where(x_sd > 0, x_sd, 1.0)
        self.y_mean_, y_sd = Y.mean(axis=0), Y.std(axis=0)
        self.y_scale_ = np.where(y_sd > 0, y_sd, 1.0)
        rank = m if self.rank is None else int(min(max(self.rank, 1), m))
        return (X - self.x_mean_) / self.x_scale_, (Y - self.y_mean_) / self.y_scale_, rank

    def _set(self, Xs, Ys, fitted: dict, b: int) -> None:
        """Take the ``b``-th model of a (batched) :func:`fit_icm` result."""
        ls, Kc, noise, mean = (fitted[k][b] for k in ("lengthscales", "Kc", "noise", "mean"))
        self.retries_, self.jitter_added_ = fitted["retries"], fitted["jitter_added"]
        self.posterior_ = KronPosterior.build(Xs, Ys, ls, Kc, noise, mean)
        r, sd = loo_residuals(Xs, Ys, ls, Kc, noise, mean)
        self.loo_scale_ = np.ones(self.n_tasks_)
        self.loo_scale_[self.varying_] = np.sqrt(np.mean((r / sd) ** 2, axis=0))
        self.y_fit_ = Ys * self.y_scale_ + self.y_mean_
        self.loo_mu_ = (Ys - r) * self.y_scale_ + self.y_mean_
        self.loo_sd_ = sd * self.y_scale_
        self.lengthscales_ = ls * self.x_scale_
        self.task_covariance_ = Kc * np.outer(self.y_scale_, self.y_scale_)
        self.noise_ = np.sqrt(noise) * self.y_scale_

    def std_scale(self) -> np.ndarray:
        """Per task, the factor that calibrates the predicted standard deviations (``loo_scale_``)."""
        return np.asarray(getattr(self, "loo_scale_", np.ones(self.n_tasks_)), float)

    def predict(self, X, return_std: bool = False, *, source: str = "posterior"):
        """Mean, shape (n, m), and with ``return_std`` the latent standard deviation.

        ``source`` "loo": at a posture the model was trained on, the mean and predictive standard
        deviation with that posture left out (elsewhere the posterior's); "data": the training
        data there (standard deviation 0), NaN elsewhere.
        """
        if source not in ("posterior", "loo", "data"):
            raise InputError(f"source must be 'posterior', 'loo' or 'data', not {source!r}")
        X = np.atleast_2d(np.asarray(X, float))
        mu = np.tile(self.constant_, (len(X), 1))
        sd = np.zeros_like(mu)
        if self.posterior_ is not None:
            v = self.varying_
            Xs = (X - self.x_mean_) / self.x_scale_
            out = self.posterior_.predict(Xs, return_std)
            if return_std:
                mu[:, v], sd[:, v] = out[0] * self.y_scale_ + self.y_mean_, out[1] * self.y_scale_
            else:
                mu[:, v] = out * self.y_scale_ + self.y_mean_
            if source != "posterior":
                row, at = self._training_rows(Xs)
                if source == "data":
                    mu[:, v], sd[:, v] = np.nan, 0.0
                    mu[np.ix_(row, v)] = self.y_fit_[at]
                else:
                    mu[np.ix_(row, v)], sd[np.ix_(row, v)] = self.loo_mu_[at], self.loo_sd_[at]
        return (mu, sd) if return_std else mu

    def _training_rows(self, Xs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rows of standardised postures ``Xs`` that are training postures, and which."""
        if not hasattr(self, "loo_mu_"):
            raise InputError("this model was saved before leave-one-out means were kept: retrain it")
        d = np.abs(Xs[:, None, :] - self.posterior_.X[None]).max(axis=-1)     # (n, n_fit)
        at = d.argmin(axis=1)
        row = np.flatnonzero(d[np.arange(len(Xs)), at] < 1e-9)
        return row, at[row]


class STGP(MTGP):
    """Single-task GP: :class:`MTGP` of one task; ``fit(X, y)`` with ``y`` of shape (n,), and
    ``predict`` returns shape (n,).

    Attributes
    ----------
    lengthscales_ : ndarray, shape (3,)
        ARD length scales in the inputs' units.
    noise_ : float
        Noise standard deviation σ_n in the target's units.
    """

    def __init__(self, iterations: int = 100, seed: int = 0):
        super().__init__(rank=1, iterations=iterations, seed=seed)

    def fit(self, X, y) -> "STGP":
        """Fit the GP of one task: ``X`` of shape (n_postures, 3), x, y (m) and θ (rad); ``y`` of
        shape (n_postures,) in the task's units, NaN postures left out. Returns ``self``; an
        :class:`~rmbench.errors.InputError` when ``y`` is not 1-D or has fewer than three finite values."""
        y = np.asarray(y, float)
        if y.ndim != 1:
            raise InputError(f"STGP fits one task: y must have shape (n,), not {y.shape}")
        super().fit(X, y[:, None])
        if self.posterior_ is not None:
            self.noise_ = float(self.noise_[0])
        return self

    def predict(self, X, return_std: bool = False, *, source: str = "posterior"):
        """Mean at postures ``X`` of shape (n_query, 3) (x, y in m, θ in rad), shape (n_query,)
        in the task's units, and with ``return_std`` the latent standard deviation (same shape and
        units); ``source`` as :meth:`MTGP.predict`'s."""
        out = super().predict(X, return_std, source=source)
        return (out[0][:, 0], out[1][:, 0]) if return_std else out[:, 0]



def fit_icm(Xs: np.ndarray, Ys: np.ndarray, rank: int, *, iterations: int = 100, seed: int = 0,
            lengthscale_starts=(1.0, 0.3)) -> dict:
    """Hyperparameters of a batch of ICM models by maximum marginal likelihood: gpytorch's model
    (:func:`_fit_batch`), its likelihood in closed form (:func:`_fit_batch_kron`).

    Parameters
    ----------
    Xs : ndarray, shape (n, d)
        Standardised inputs, shared by the batch.
    Ys : ndarray, shape (B, n, m)
        Standardised targets of ``B`` independent models of ``m`` tasks each.
    rank : int
        Columns of ``B`` in ``K_c = B Bᵀ + diag(v)``.
    lengthscale_starts : sequence of float
        Starting length scales (standardised units); each model keeps its best start.

    Returns
    -------
    dict
        ``lengthscales`` (B, d), ``Kc`` (B, m, m), ``noise`` (B, m) variances, ``mean`` (B, m),
        ``nll`` (B,) per datum, ``retries`` and ``jitter_added`` (numerical trouble, reported).
    """
    torch, gpytorch = _torch()
    from linear_operator.utils.errors import NanError, NotPSDError

    B, n, m = Ys.shape
    best, retries, jitter_added = None, 0, 0.0
    for start, ls0 in enumerate(lengthscale_starts):
        torch.manual_seed(seed + start)
        for jitter in (0.0, 1e-8, 1e-6, 1e-4):
            try:
                # gpytorch's model (_fit_batch) with its likelihood in closed form: one task by a
                # Cholesky factor, several by the Kronecker eigendecompositions (gpytorch's own
                # operators cost 1.6x as much for one task and 3.5x for several); a covariance
                # that is not numerically positive definite is retried with jitter on its
                # diagonal, as gpytorch retries its Cholesky factorisation
                out = _fit_batch_kron(torch, gpytorch, Xs, Ys, rank, ls0, iterations, jitter=jitter)
                jitter_added = max(jitter_added, jitter)
                break
            except (NotPSDError, NanError):
                retries += 1
        else:
            continue
        if best is None:
            best = out
        else:
            better = out["nll"] < best["nll"]
            for k in best:
                best[k][better] = out[k][better]
    if best is None:
        raise RmbenchError("the multi-task GP fit failed at every jitter (covariance not "
                           "positive definite)")
    return best | {"retries": retries, "jitter_added": jitter_added}


def _batched_icm_kernel(gpytorch):
    """gpytorch's MultitaskKernel, except that a kernel with its own batch shape keeps its task
    covariance's batch: MultitaskKernel.forward repeats it over the inputs' batch dimensions
    (gpytorch 1.15), which multiplies the batch (B → B²) when kernel and inputs are both batched."""
    from linear_operator import to_linear_operator
    from linear_operator.operators import KroneckerProductLinearOperator

    class _Kernel(gpytorch.kernels.MultitaskKernel):
        def forward(self, x1, x2, diag=False, last_dim_is_batch=False, **params):
            covar_i = self.task_covar_module.covar_matrix
            covar_i = covar_i.expand(*x1.shape[:-2], *covar_i.shape[-2:])
            covar_x = to_linear_operator(self.data_covar_module.forward(x1, x2, **params))
            res = KroneckerProductLinearOperator(covar_x, covar_i)
            return res.diagonal(dim1=-1, dim2=-2) if diag else res

    return _Kernel


def _fit_batch(torch, gpytorch, Xs, Ys, rank, ls0, iterations) -> dict:
    """gpytorch's own ICM model of the batch, fitted by L-BFGS: the reference that the closed form
    (:func:`_fit_batch_kron`, what :func:`fit_icm` runs) is tested against step for step."""
    from linear_operator.utils.errors import NotPSDError

    B, n, m = Ys.shape
    _BatchedICMKernel = _batched_icm_kernel(gpytorch)
    batch = torch.Size([B])
    tx = torch.as_tensor(np.broadcast_to(Xs, (B,) + Xs.shape).copy(), dtype=torch.float64)
    ty = torch.as_tensor(Ys, dtype=torch.float64)

    class _ICM(gpytorch.models.ExactGP):
        def __init__(self, x, y, lik):
            super().__init__(x, y, lik)
            self.mean_module = gpytorch.means.MultitaskMean(
                gpytorch.means.ConstantMean(batch_shape=batch), num_tasks=m)
            self.covar_module = _BatchedICMKernel(
                gpytorch.kernels.RBFKernel(ard_num_dims=x.shape[-1], batch_shape=batch,
                                           lengthscale_constraint=gpytorch.constraints.Interval(
                                               *_LENGTHSCALE_BOUNDS)),
                num_tasks=m, rank=rank, batch_shape=batch)

        def forward(self, x):
            return gpytorch.distributions.MultitaskMultivariateNormal(self.mean_module(x),
                                                                      self.covar_module(x))

    lik = gpytorch.likelihoods.MultitaskGaussianLikelihood(
        num_tasks=m, rank=0, batch_shape=batch, has_global_noise=False,
        noise_constraint=gpytorch.constraints.GreaterThan(_NOISE_FLOOR)).double()
    model = _ICM(tx, ty, lik).double()
    model.covar_module.data_covar_module.lengthscale = torch.full((B, 1, Xs.shape[1]), ls0,
                                                                  dtype=torch.float64)
    task = model.covar_module.task_covar_module
    task.covar_factor.data = torch.as_tensor(_start_factors(Ys, rank), dtype=torch.float64)
    task.var = torch.full((B, m), _VAR0, dtype=torch.float64)
    lik.task_noises = torch.full((B, m), _NOISE0, dtype=torch.float64)
    model.train()
    lik.train()
    mll = gpytorch.mlls.ExactMarginalLogLikelihood(lik, model)
    opt = torch.optim.LBFGS(model.parameters(), lr=0.5, max_iter=iterations,
                            line_search_fn="strong_wolfe")

    def closure():
        opt.zero_grad()
        loss = -mll(model(tx), ty).sum()   # the models are independent: the sum separates
        loss.backward()
        return loss

    opt.step(closure)
    with torch.no_grad():
        nll = -mll(model(tx), ty).reshape(B).numpy().copy()
        out = {"lengthscales": model.covar_module.data_covar_module.lengthscale.reshape(B, -1).numpy().copy(),
               "Kc": task.covar_matrix.to_dense().reshape(B, m, m).numpy().copy(),
               "noise": lik.task_noises.reshape(B, m).numpy().copy(),
               "mean": torch.stack([mm.constant.reshape(B) for mm in model.mean_module.base_means],
                                   dim=-1).numpy().copy()}
    nll[~np.isfinite(nll)] = np.inf
    if not np.isfinite(nll).any():
        raise NotPSDError("non-finite marginal likelihood")
    return out | {"nll": nll}


# starting task variances (diag v of K_c) and noise variances, standardised units
_VAR0, _NOISE0 = 1e-3, 1e-2


def _start_factors(Ys: np.ndarray, rank: int) -> np.ndarray:
    """K_c starts at the tasks' empirical correlation (scaled below the unit variance so that the
    noise has room), its leading ``rank`` eigenpairs in B; shape (B, m, rank)."""
    B, _, m = Ys.shape
    factors = np.empty((B, m, rank))
    for b in range(B):
        corr = np.nan_to_num(np.corrcoef(Ys[b].T), nan=0.0) if m > 1 else np.ones((1, 1))
        w, v = np.linalg.eigh(0.9 * np.atleast_2d(corr))
        top = np.argsort(w)[::-1][:rank]
        factors[b] = v[:, top] * np.sqrt(np.maximum(w[top], 1e-6))
    return factors


def _constraints(gpytorch):
    """gpytorch's constraints of the model's hyperparameters: length scale, task variance v,
    noise variance (those of ``RBFKernel``, ``IndexKernel`` and the likelihood in ``_fit_batch``)."""
    c = gpytorch.constraints
    return c.Interval(*_LENGTHSCALE_BOUNDS), c.Positive(), c.GreaterThan(_NOISE_FLOOR)


def _rbf(torch, x, lengthscale):
    """The squared-exponential kernel of standardised inputs ``x`` (n, d) at the batch's length
    scales (B, d): shape (B, n, n)."""
    z = x[None] / lengthscale[:, None, :]                                   # (B, n, d)
    sq = (z**2).sum(-1)
    d2 = (sq[:, :, None] + sq[:, None, :] - 2 * z @ z.transpose(-1, -2)).clamp_min(0)
    return torch.exp(-0.5 * d2)


def single_nll(torch, x, y, lengthscale, factor, var, noise, mean):
    """:func:`icm_nll` of one-task models (``m = 1``), through a Cholesky factor of
    ``K = k_c K_t + σ² I`` (k_c = B Bᵀ + var, a scalar), as gpytorch factorises a covariance this
    small, with the gradient in closed form (:func:`_single_gp`). Raises linear_operator's
    ``NotPSDError`` where ``K`` is not numerically positive definite (:func:`fit_icm` then retries).
    """
    n = y.shape[1]
    k_c = (factor**2).sum((-1, -2)) + var[:, 0]                             # (B,)
    half = _single_gp(torch).apply(x, y[..., 0], lengthscale, k_c, noise[:, 0], mean[:, 0])
    return (half + 0.5 * n * np.log(2 * np.pi)) / n


@functools.lru_cache(maxsize=None)
def _single_gp(torch):
    """``½ (rᵀ K⁻¹ r + log|K|)`` of a batch of one-task GPs, ``K = k_c K_t + σ² I`` with the
    squared-exponential ``K_t`` of inputs ``x`` (n, d) at length scales ℓ (B, d), ``r = y − mean``,
    as a torch autograd function of (ℓ, k_c, σ², mean) with its gradient in closed form::

        G = ½ (K⁻¹ − α αᵀ),  α = K⁻¹ r
        ∂/∂k_c = Σ G∘K_t,  ∂/∂σ² = tr G,  ∂/∂ℓ_d = k_c/ℓ_d³ Σ G∘K_t∘Δx_d²,  ∂/∂mean = −Σ α

    Autograd through the factorisation and the kernel's (B, n, n) intermediates cost four times
    the factorisation; here the backward pass is one inverse from the factor and three contractions.
    """
    from linear_operator.utils.errors import NotPSDError

    class SingleGP(torch.autograd.Function):
        @staticmethod
        def forward(ctx, x, y, ls, k_c, noise, mean):
            d2 = ((x[:, None, :] - x[None, :, :]) ** 2).permute(2, 0, 1)      # (d, n, n)
            k_t = torch.exp(-0.5 * torch.einsum("dij,bd->bij", d2, ls**-2))
            K = k_c[:, None, None] * k_t
            K.diagonal(dim1=-2, dim2=-1).add_(noise[:, None])
            L, info = torch.linalg.cholesky_ex(K)
            if bool((info != 0).any()):
                raise NotPSDError("covariance not positive definite")
            r = y - mean[:, None]
            alpha = torch.cholesky_solve(r[..., None], L)[..., 0]
            ctx.save_for_backward(d2, k_t, L, alpha, ls, k_c)
            logdet = 2 * torch.log(torch.diagonal(L, dim1=-2, dim2=-1)).sum(-1)
            return 0.5 * ((r * alpha).sum(-1) + logdet)

        @staticmethod
        def backward(ctx, g):
            d2, k_t, L, alpha, ls, k_c = ctx.saved_tensors
            G = torch.cholesky_inverse(L)
            G.sub_(alpha[:, :, None] * alpha[:, None, :]).mul_(0.5)
            d_noise = G.diagonal(dim1=-2, dim2=-1).sum(-1)
            G.mul_(k_t)
            d_kc = G.sum((-1, -2))
            d_ls = k_c[:, None] * torch.einsum("bij,dij->bd", G, d2) / ls**3
            return None, None, g[:, None] * d_ls, g * d_kc, g * d_noise, -g * alpha.sum(-1)

    return SingleGP


def icm_nll(torch, x, y, lengthscale, factor, var, noise, mean):
    """Negative log marginal likelihood per datum of a batch of ICM models (torch, differentiable).

    Parameters
    ----------
    x : tensor, shape (n, d)
        Standardised inputs, shared by the batch.
    y : tensor, shape (B, n, m)
    lengthscale : tensor, shape (B, d)
    factor : tensor, shape (B, m, r)
        ``B`` of ``K_c = B Bᵀ + diag(var)``.
    var, noise, mean : tensor, shape (B, m)

    Returns
    -------
    tensor, shape (B,): ``−log p(y) / (n m)``, as gpytorch's ``ExactMarginalLogLikelihood``.

    Notes
    -----
    With ``D = diag(noise)``, ``K_t = U_t S_t U_tᵀ`` and ``D^-½ K_c D^-½ = U_c S_c U_cᵀ``, the
    covariance ``K_t ⊗ K_c + I ⊗ D`` has the log-determinant ``n log|D| + Σ log(S_t ⊗ S_c + 1)`` and
    the quadratic form ``Σ (U_tᵀ R U_c)² / (S_t ⊗ S_c + 1)`` of the whitened residuals
    ``R = (y − mean) D^-½``: one eigendecomposition of each factor.
    """
    _, n, m = y.shape
    k_t = _rbf(torch, x, lengthscale)
    w = noise.rsqrt()
    k_c = (factor @ factor.transpose(-1, -2) + torch.diag_embed(var)) * w[:, :, None] * w[:, None, :]
    r = (y - mean[:, None, :]) * w[:, None, :]
    half = _kron_quad_logdet(torch).apply(k_t, k_c, r)
    return (half + 0.5 * n * torch.log(noise).sum(-1) + 0.5 * n * m * np.log(2 * np.pi)) / (n * m)


@functools.lru_cache(maxsize=None)
def _kron_quad_logdet(torch):
    """``½ (vec(R)ᵀ K⁻¹ vec(R) + log|K|)`` of ``K = K_t ⊗ K_c + I`` as a torch autograd function
    of (K_t, K_c, R), each batched, its gradient in closed form from the eigendecompositions::

        ∂/∂K_t = ½ (U_t diag(Σ_a s_c,a / Λ_ia) U_tᵀ − A K_c Aᵀ),   A = U_t (Z / Λ) U_cᵀ
        ∂/∂K_c = ½ (U_c diag(Σ_i s_t,i / Λ_ia) U_cᵀ − Aᵀ K_t A),   ∂/∂R = A

    (Z = U_tᵀ R U_c, Λ = s_t s_cᵀ + 1). Autograd through ``eigh`` would cost more than the
    eigendecomposition itself and divides by differences of eigenvalues, which a smooth kernel's
    many near-zero eigenvalues make tiny.
    """

    class KronQuadLogdet(torch.autograd.Function):
        @staticmethod
        def forward(ctx, k_t, k_c, r):
            s_t, u_t = torch.linalg.eigh(k_t)
            s_c, u_c = torch.linalg.eigh(k_c)
            s_t, s_c = s_t.clamp_min(0), s_c.clamp_min(0)
            lam = s_t[..., :, None] * s_c[..., None, :] + 1.0                # (B, n, m)
            zl = (u_t.transpose(-1, -2) @ r @ u_c) / lam
            a = u_t @ zl @ u_c.transpose(-1, -2)
            ctx.save_for_backward(k_t, k_c, s_t, u_t, s_c, u_c, lam, a)
            return 0.5 * ((r * a).sum((-1, -2)) + torch.log(lam).sum((-1, -2)))

        @staticmethod
        def backward(ctx, g):
            k_t, k_c, s_t, u_t, s_c, u_c, lam, a = ctx.saved_tensors
            g = g[:, None, None]
            d_t = ((s_c[..., None, :] / lam).sum(-1))[..., None, :] * u_t @ u_t.transpose(-1, -2)
            d_c = ((s_t[..., :, None] / lam).sum(-2))[..., None, :] * u_c @ u_c.transpose(-1, -2)
            g_t = 0.5 * (d_t - a @ k_c @ a.transpose(-1, -2))
            g_c = 0.5 * (d_c - a.transpose(-1, -2) @ k_t @ a)
            return g * g_t, g * g_c, g * a

    return KronQuadLogdet


def _fit_batch_kron(torch, gpytorch, Xs, Ys, rank, ls0, iterations, *, jitter: float = 0.0) -> dict:
    """:func:`_fit_batch` through :func:`icm_nll` (:func:`single_nll` for one task): the same
    hyperparameters, constraints, starts and optimiser as the gpytorch model; ``jitter`` is added
    to the noise variances (in the likelihood and in the noise returned, which the posterior uses)."""
    B, _, m = Ys.shape
    objective = single_nll if m == 1 else icm_nll
    c_ls, c_var, c_noise = _constraints(gpytorch)
    f64 = dict(dtype=torch.float64)
    x, y = torch.as_tensor(Xs, **f64), torch.as_tensor(Ys, **f64)
    raw = [c_ls.inverse_transform(torch.full((B, Xs.shape[1]), float(ls0), **f64)),
           torch.as_tensor(_start_factors(Ys, rank), **f64),
           c_var.inverse_transform(torch.full((B, m), _VAR0, **f64)),
           c_noise.inverse_transform(torch.full((B, m), _NOISE0, **f64)),
           torch.zeros((B, m), **f64)]
    for t in raw:
        t.requires_grad_(True)

    def nll():
        return objective(torch, x, y, c_ls.transform(raw[0]), raw[1], c_var.transform(raw[2]),
                         c_noise.transform(raw[3]) + jitter, raw[4])

    opt = torch.optim.LBFGS(raw, lr=0.5, max_iter=iterations, line_search_fn="strong_wolfe")

    def closure():
        opt.zero_grad()
        loss = nll().sum()          # the models are independent: the sum separates
        loss.backward()
        return loss

    opt.step(closure)
    with torch.no_grad():
        per_model = nll().numpy().copy()
        out = {"lengthscales": c_ls.transform(raw[0]).numpy().copy(),
               "Kc": (raw[1] @ raw[1].transpose(-1, -2)
                      + torch.diag_embed(c_var.transform(raw[2]))).numpy().copy(),
               "noise": (c_noise.transform(raw[3]) + jitter).numpy().copy(),
               "mean": raw[4].detach().numpy().copy()}
    per_model[~np.isfinite(per_model)] = np.inf
    if not np.isfinite(per_model).any():
        from linear_operator.utils.errors import NotPSDError

        raise NotPSDError("non-finite marginal likelihood")
    return out | {"nll": per_model}
