"""The rejection probability of METHODS.md §7: the per-location p* and the combined P*.

Vocabulary (one location j, its n_j measurements averaged to x̄_j):

* ``mean``: x̄_j, shape (..., dim); ``dim`` = 1 for the scalar test, 3 for the tracker.
* ``sigma_hat``: σ_j / sqrt(n_j), the standard deviation of x̄_j per axis, same shape.
* the candidate error that maximises acceptance is x̄_j clipped to the accuracy level: per axis
  with the directional bounds η_x = η |x̄_x| / ||x̄|| (seed Eq. 24), which reduces to
  clip(x̄, -η, η) in one dimension;
* ``statistic`` R_j = Σ_axes ((x̄ − ê) / σ̂)², so that p*_j = F_χ²(dim)(R_j) (1-D: the
  two-sided normal probability Φ(Z) − Φ(−Z) with Z² = R; 3-D: seed Eq. 26);
* P* = 1 − Π_j (1 − p*_j); H0 (every |e| ≤ η) is rejected when P* > α.

Everything is computed through log(1 − p*) = log of the χ² survival function, which keeps P*
exact when many locations each contribute a p* close to 0 or 1.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import special, stats

__all__ = ["rejection_statistic", "log_acceptance", "p_star", "combined_p_star", "probability",
           "scalar_log_acceptance"]

_LOG2 = math.log(2.0)
_LOG_FLOOR = -1.0e4  # log(1 - p*) below this is p* = 1 to double precision


def rejection_statistic(mean, sigma_hat, eta: float) -> np.ndarray:
    """R = Σ_axes Z² of the acceptance-maximising candidate error.

    Parameters
    ----------
    mean : array_like, shape (..., dim)
        Averaged measured errors x̄ (any unit, the same as ``eta``).
    sigma_hat : array_like, shape (..., dim)
        Standard deviation of each averaged component, same unit, > 0.
    eta : float
        Accuracy level η ≥ 0 on the error magnitude.

    Returns
    -------
    ndarray, shape (...)
        R ≥ 0; zero where ||x̄|| ≤ η.
    """
    mean = np.asarray(mean, float)
    norm = np.linalg.norm(mean, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        shrink = np.where(norm > eta, 1.0 - eta / norm, 0.0)
    z = mean * shrink[..., None] / np.asarray(sigma_hat, float)
    return np.sum(z * z, axis=-1)


def log_acceptance(statistic, dim: int) -> np.ndarray:
    """log(1 − p*) = log of the χ²(dim) survival function at R, floored at -1e4.

    Parameters
    ----------
    statistic : array_like
        R ≥ 0.
    dim : int
        Number of error components (degrees of freedom).
    """
    r = np.asarray(statistic, float)
    root = np.sqrt(r)
    tail = _LOG2 + special.log_ndtr(-root)  # χ²(1): 2 Φ(-sqrt R)
    if dim == 1:
        out = tail
    elif dim == 3:  # sf = 2 Φ(-sqrt R) + sqrt(2R/π) exp(-R/2)
        with np.errstate(divide="ignore"):
            out = np.logaddexp(tail, 0.5 * np.log(2.0 * r / math.pi) - 0.5 * r)
    else:
        out = stats.chi2.logsf(r, dim)
    return np.maximum(out, _LOG_FLOOR)


def p_star(mean, sigma_hat, eta: float) -> np.ndarray:
    """Rejection probability p*_j of each location, shape (...); see :func:`rejection_statistic`."""
    mean = np.asarray(mean, float)
    r = rejection_statistic(mean, sigma_hat, eta)
    return probability(log_acceptance(r, mean.shape[-1]))


def combined_p_star(log_acc) -> float:
    """P* = 1 − Π_j (1 − p*_j) from the per-location log(1 − p*_j)."""
    return float(probability(np.sum(log_acc)))


def probability(log_acc):
    """p = 1 − exp(log(1 − p)), without negative zeros."""
    return -np.expm1(log_acc) + 0.0


def scalar_log_acceptance(mean: float, sigma_hat: float, eta: float) -> tuple[float, float]:
    """(R, log(1 − p*)) of a scalar error: the fast path of the 1-D sequential test."""
    z = (abs(mean) - eta) / sigma_hat
    if z <= 0.0:
        return 0.0, 0.0
    return z * z, max(_LOG2 + float(special.log_ndtr(-z)), _LOG_FLOOR)
