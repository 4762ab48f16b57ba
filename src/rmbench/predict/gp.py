"""Single-task Gaussian process (STGP, METHODS.md §5), in gpytorch, float64.

One exact GP per task: ARD squared-exponential kernel ``σ_f² exp(−½ Σ_d w_d (x_d − x'_d)²)``,
Gaussian noise σ_n², hyperparameters by maximising the log marginal likelihood (L-BFGS from a few
starts), on standardised inputs and outputs. A covariance that is not positive definite is retried
with more jitter and counted in ``retries_``, never silent.
"""

from __future__ import annotations

import warnings

import numpy as np

from rmbench.errors import RmbenchError

__all__ = ["STGP"]


def _torch():
    """torch and gpytorch, imported without linear_operator's notice about torch.jit.script (its
    own business, not the user's)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*torch.jit.script.*is deprecated")
        import gpytorch
        import torch
    return torch, gpytorch


class STGP:
    """Exact single-task GP regression.

    Parameters
    ----------
    iterations : int
        L-BFGS iterations per start.
    starts : int
        Starts of the hyperparameter search (length scales 1, 0.3, 3 × the inputs' spread...).
    seed : int
        Seeds torch for reproducible fits.

    Attributes
    ----------
    lengthscales_ : ndarray, shape (n_inputs,)
        ARD length scales in the inputs' units (1/√w_d).
    noise_ : float
        Noise standard deviation σ_n in the targets' units.
    retries_ : int
        Fits retried with more jitter.
    jitter_added_ : float
        Largest jitter linear_operator added to a covariance's diagonal during the fit (0: none).
    """

    def __init__(self, iterations: int = 60, starts: int = 2, seed: int = 0):
        self.iterations, self.starts, self.seed = int(iterations), int(starts), int(seed)

    def fit(self, X, y) -> "STGP":
        torch, gpytorch = _torch()

        X = np.asarray(X, float)
        y = np.asarray(y, float)
        self.x_mean_, x_sd = X.mean(axis=0), X.std(axis=0)
        self.x_scale_ = np.where(x_sd > 0, x_sd, 1.0)
        self.y_mean_, y_sd = y.mean(), y.std()
        self.y_scale_ = y_sd if y_sd > 0 else 1.0
        tx = torch.as_tensor((X - self.x_mean_) / self.x_scale_, dtype=torch.float64)
        ty = torch.as_tensor((y - self.y_mean_) / self.y_scale_, dtype=torch.float64)
        torch.manual_seed(self.seed)
        best, self.retries_, self.jitter_added_ = None, 0, 0.0
        for start in range(max(self.starts, 1)):
            for jitter in (1e-8, 1e-6, 1e-4):
                try:
                    # linear_operator adds jitter itself when a Cholesky fails, with a warning:
                    # the largest it added is kept in jitter_added_, for the caller to report
                    with warnings.catch_warnings(record=True) as caught, \
                            gpytorch.settings.cholesky_jitter(double_value=jitter):
                        warnings.simplefilter("always", gpytorch.utils.warnings.NumericalWarning)
                        model, lik, loss = self._fit_once(tx, ty, 0.3 * 3.0 ** start)
                    self.jitter_added_ = max([self.jitter_added_] + _jitters(caught))
                    break
                except (gpytorch.utils.errors.NotPSDError, RuntimeError):
                    self.retries_ += 1
            else:
                continue
            if best is None or loss < best[2]:
                best = (model, lik, loss)
        if best is None:
            raise RmbenchError("the Gaussian process fit failed at every jitter (covariance not "
                               "positive definite)")
        self.model_, self.likelihood_, _ = best
        self.model_.eval()
        self.likelihood_.eval()
        k = self.model_.covar_module
        self.lengthscales_ = k.base_kernel.lengthscale.detach().numpy().ravel() * self.x_scale_
        self.noise_ = float(np.sqrt(self.likelihood_.noise.item())) * self.y_scale_
        return self

    def _fit_once(self, tx, ty, lengthscale: float):
        torch, gpytorch = _torch()

        class _GP(gpytorch.models.ExactGP):
            def __init__(self, x, y, lik):
                super().__init__(x, y, lik)
                self.mean_module = gpytorch.means.ConstantMean()
                self.covar_module = gpytorch.kernels.ScaleKernel(
                    gpytorch.kernels.RBFKernel(ard_num_dims=x.shape[1]))

            def forward(self, x):
                return gpytorch.distributions.MultivariateNormal(self.mean_module(x),
                                                                 self.covar_module(x))

        lik = gpytorch.likelihoods.GaussianLikelihood(
            noise_constraint=gpytorch.constraints.GreaterThan(1e-8)).double()
        model = _GP(tx, ty, lik).double()
        model.covar_module.base_kernel.lengthscale = torch.full((1, tx.shape[1]), lengthscale,
                                                                dtype=torch.float64)
        lik.noise = 1e-2
        model.train()
        lik.train()
        mll = gpytorch.mlls.ExactMarginalLogLikelihood(lik, model)
        opt = torch.optim.LBFGS(model.parameters(), lr=0.5, max_iter=self.iterations,
                                line_search_fn="strong_wolfe")

        def closure():
            opt.zero_grad()
            loss = -mll(model(tx), ty)
            loss.backward()
            return loss

        opt.step(closure)
        with torch.no_grad():
            loss = float(-mll(model(tx), ty))
        if not np.isfinite(loss):
            raise RuntimeError("non-finite marginal likelihood")
        return model, lik, loss

    def predict(self, X, return_std: bool = False):
        """Predictive mean (n,) and, with ``return_std``, standard deviation of the latent function."""
        torch, gpytorch = _torch()

        tx = torch.as_tensor((np.asarray(X, float) - self.x_mean_) / self.x_scale_, dtype=torch.float64)
        with torch.no_grad(), gpytorch.settings.fast_pred_var(False):
            post = self.model_(tx)
            mean = post.mean.numpy() * self.y_scale_ + self.y_mean_
            if not return_std:
                return mean
            return mean, np.sqrt(post.variance.clamp_min(0).numpy()) * self.y_scale_


def _jitters(caught) -> list:
    """The jitters named in linear_operator's 'added jitter of X to the diagonal' warnings."""
    import re

    out = []
    for w in caught:
        m = re.search(r"added jitter of ([0-9.eE+-]+)", str(w.message))
        if m:
            out.append(float(m.group(1)))
    return out
