"""The regularised least-squares problem every calibration solves, whatever its data.

A calibration is a maximum a posteriori fit: data residuals ``r(x)``, each already divided by its
standard error, and a Gaussian prior about zero on each parameter with standard deviation
``σ_i`` (infinite: no prior, e.g. a freed structural size or a tracker's registration)::

    minimise  |r(x)|² + Σ (x_i / σ_i)²   subject to  lower ≤ x ≤ upper

The prior is Tikhonov regularisation toward the nominal, its weight set by the stated tolerances
rather than tuned per case. It is solved by a bounded trust-region Gauss-Newton (scipy's
``least_squares``, ``trf``) with the prior as extra rows. The FRF calibration
(:func:`rmbench.calibrate.calibrate`, modal and FRF residuals, x in prior standard deviations)
and the tracker calibration (:mod:`rmbench.gap.tracker.diagnosis`, pose residuals, x in SI) both use it, and
both read their account from :func:`posterior` and :func:`identifiability`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from threadpoolctl import threadpool_limits

__all__ = ["IDENTIFIABLE", "WEAK", "Bounds", "SolverOptions", "Solution", "Posterior", "solve", "huber", "posterior",
           "identifiability"]

IDENTIFIABLE = 0.3     # posterior over reference standard deviation below this: identifiable
WEAK = 0.7             # below this: weakly identifiable


@dataclass(frozen=True)
class Bounds:
    """Bounds on x, ``lower ≤ x ≤ upper``.

    Attributes
    ----------
    lower, upper : array_like, shape (k,), or None
        In x's units; None: unbounded on that side.
    """

    lower: np.ndarray | None = None
    upper: np.ndarray | None = None

    def arrays(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """``(lower, upper)`` as float arrays of length ``k`` (±inf where unbounded)."""
        lo = np.full(k, -np.inf) if self.lower is None else np.asarray(self.lower, float)
        hi = np.full(k, np.inf) if self.upper is None else np.asarray(self.upper, float)
        return lo, hi


@dataclass(frozen=True)
class SolverOptions:
    """When the solver stops, and how it scales x (scipy's ``least_squares`` options).

    Attributes
    ----------
    max_nfev : int
        Most residual evaluations.
    x_scale : float, array_like or "jac"
        scipy's variable scaling: 1 where x is already in comparable units (prior standard
        deviations), ``"jac"`` where it is in SI of different sizes.
    xtol, ftol, gtol : float
        scipy's tolerances on the step, the cost's change and the gradient.
    robust : float or None
        Huber's threshold on the data residuals, in standard errors (None: least squares): a
        residual beyond it costs ``2c|r| − c²`` instead of ``r²``, so one gross error (a biased
        measured mode) pulls the fit as one at the threshold does, not in proportion to its size.
        The prior's rows stay squared.
    """

    max_nfev: int = 16
    x_scale: float | str | np.ndarray = 1.0
    xtol: float = 1e-4
    ftol: float = 1e-6
    gtol: float = 1e-8
    robust: float | None = None

    def __post_init__(self):
        if int(self.max_nfev) < 1:
            raise ValueError(f"max_nfev must be at least 1, got {self.max_nfev}")


@dataclass(frozen=True)
class Solution:
    """A solved calibration problem.

    Attributes
    ----------
    x : ndarray, shape (k,)
    chi2 : float
        The data part of the objective at ``x``, ``|r(x)|²``.
    chi2_prior : float
        The prior's part, ``Σ (x_i/σ_i)²`` over the parameters with a prior.
    nfev : int
        Residual evaluations.
    at_limit : bool
        The solver stopped at ``max_nfev`` rather than converging.
    """

    x: np.ndarray
    chi2: float
    chi2_prior: float
    nfev: int
    at_limit: bool


@dataclass(frozen=True)
class Posterior:
    """The Gauss-Newton posterior at a solution.

    Attributes
    ----------
    cov : ndarray, shape (k, k)
        Covariance of x, scaled by the reduced χ² where that exceeds 1 (a model that does not
        reach the data's noise: an unmodelled effect widens the intervals).
    ratio : ndarray, shape (k,)
        Posterior standard deviation from the data and the prior alone (unscaled) over each
        parameter's reference standard deviation: near 1 the data add nothing to the prior,
        near 0 they fix the parameter.
    scale : float
        The factor applied to ``cov`` (≥ 1).
    """

    cov: np.ndarray
    ratio: np.ndarray
    scale: float

    @property
    def sd(self) -> np.ndarray:
        return np.sqrt(np.clip(np.diag(self.cov), 0, None))


def _weights(prior_sd) -> np.ndarray:
    sd = np.asarray(prior_sd, float)
    return np.where(np.isfinite(sd), 1.0 / np.where(np.isfinite(sd), sd, 1.0), 0.0)


def solve(residuals, jacobian, x0, *, prior_sd, bounds: Bounds = Bounds(),
          options: SolverOptions = SolverOptions()) -> Solution:
    """Minimise ``|r(x)|² + Σ (x_i/σ_i)²`` within bounds.

    Parameters
    ----------
    residuals : callable
        ``residuals(x) -> r``, shape (n,), each divided by its standard error.
    jacobian : callable
        ``jacobian(x) -> J``, shape (n, k), ``∂r/∂x``.
    x0 : array_like, shape (k,)
        The start (inside the bounds).
    prior_sd : array_like, shape (k,)
        The prior's standard deviation per parameter, in x's units; ``inf`` for none.
    bounds : Bounds
        Bounds on x (default none).
    options : SolverOptions
        Most evaluations, scaling and tolerances.
    """
    x0 = np.asarray(x0, float)
    w = _weights(prior_sd)
    k = len(x0) if np.any(w) else 0          # the prior's rows; none where no parameter has one

    c = options.robust
    last = {}

    def data(x):
        # scipy asks for the Jacobian at the point whose residuals it has just had
        if last.get("x") is None or not np.array_equal(last["x"], x):
            last["x"], last["r"] = np.array(x, float), residuals(x)
        return last["r"]

    def fun(x):
        r = data(x) if c is None else huber(data(x), c)[0]
        return np.concatenate([r, w * x]) if k else r

    def jac(x):
        j = jacobian(x)
        if c is not None:
            j = huber(data(x), c)[1][:, None] * j
        return np.vstack([j, np.diag(w)]) if k else j

    lo, hi = bounds.arrays(len(x0))
    # one BLAS thread: the solver's matrices are a few hundred by a few dozen, where a second
    # thread only waits (a 528 x 24 SVD: 0.5 ms on one thread, 200 ms on two beside other work)
    with threadpool_limits(limits=1, user_api="blas"):
        sol = least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf", x_scale=options.x_scale,
                            max_nfev=options.max_nfev, xtol=options.xtol, ftol=options.ftol, gtol=options.gtol)
    r = sol.fun[:len(sol.fun) - k] if c is None else data(sol.x)   # the data rows, as they are
    return Solution(x=sol.x, chi2=float(r @ r), chi2_prior=float(np.sum((w * sol.x) ** 2)),
                    nfev=int(sol.nfev), at_limit=sol.status == 0)


def huber(r, c: float) -> tuple[np.ndarray, np.ndarray]:
    """Residuals whose squares are Huber's loss, and their derivative over the residuals'.

    ``r̃ = r`` where ``|r| ≤ c``, else ``sign(r) √(2c|r| − c²)`` (so ``r̃² = 2c|r| − c²``); the
    derivative ``dr̃/dr`` is 1, or ``c / |r̃|`` (shapes those of ``r``)."""
    r = np.asarray(r, float)
    a = np.abs(r)
    out = np.where(a <= c, r, np.sign(r) * np.sqrt(np.maximum(2 * c * a - c * c, 0.0)))
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.where(a <= c, 1.0, c / np.abs(out))
    return out, d


def posterior(jac, precision, chi2: float, n: int, *, reference=None) -> Posterior:
    """The Gauss-Newton posterior ``(JᵀJ + diag(precision))⁻¹`` at a solution.

    Parameters
    ----------
    jac : ndarray, shape (n, k)
        ``∂r/∂x`` of the data residuals at the solution.
    precision : array_like, shape (k,)
        The prior's precision per parameter (``1/σ²``; 0 for none, e.g. a registration that the
        data always fix; a tiny one keeps an undetermined freed parameter finite).
    chi2 : float
        The data χ² at the solution; ``n`` residuals.
    reference : array_like, shape (k,), optional
        The standard deviation each parameter's posterior is compared with for its
        identifiability (default 1: x already in prior standard deviations).
    """
    jac = np.asarray(jac, float)
    k = jac.shape[1]
    info = jac.T @ jac + np.diag(np.asarray(precision, float))
    cov = np.linalg.pinv(info)
    ref = np.ones(k) if reference is None else np.asarray(reference, float)
    ratio = np.sqrt(np.clip(np.diag(cov), 0, None)) / ref
    scale = max(1.0, chi2 / max(n - k, 1))
    return Posterior(cov=cov * scale, ratio=ratio, scale=scale)


def identifiability(ratio: float, resolved: bool = True) -> str:
    """``"identifiable"`` where the data carry most of what is known of a parameter (posterior
    below 0.3 of its reference) and fix it to the resolution that matters (``resolved``);
    ``"weak"`` where they narrow it noticeably (below 0.7); else ``"not identifiable"``: the
    data leave it at its prior."""
    if ratio < IDENTIFIABLE and resolved:
        return "identifiable"
    return "weak" if ratio < WEAK else "not identifiable"
