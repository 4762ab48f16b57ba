"""ISO 9283 pose repeatability RP, and the joint repeatability that produces a given RP.

RP = l̄ + 3 S_l, where l_j is the distance of the j-th attained position from the barycentre of
the attained positions. For positions scattered as N(0, Σ), this module takes the expectation over
infinitely many cycles: l̄ = E||x|| and S_l = sqrt(tr Σ − (E||x||)²), with E||x|| from
sqrt(r) = (4π)^(-1/2) ∫ (1 − exp(−s r)) s^(-3/2) ds and E exp(−s||x||²) = Π_i (1 + 2 s λ_i)^(-1/2)
(λ_i the eigenvalues of Σ): one quadrature, no sampling noise.
"""

from __future__ import annotations

import numpy as np
from scipy import integrate

from rmbench.errors import InputError

__all__ = ["iso9283_rp", "joint_sigma_for_rp"]


def iso9283_rp(covariance) -> float:
    """Expected ISO 9283 repeatability RP of positions distributed as N(0, Σ).

    Parameters
    ----------
    covariance : array_like, shape (3, 3), m²
        Positive semi-definite covariance of the attained position.

    Returns
    -------
    float
        RP, m.
    """
    cov = np.asarray(covariance, float)
    if cov.shape != (3, 3) or not np.all(np.isfinite(cov)):
        raise InputError(f"covariance must be a finite 3 x 3 matrix, got shape {cov.shape}")
    lam = np.clip(np.linalg.eigvalsh(0.5 * (cov + cov.T)), 0.0, None)
    top = float(lam.max())
    if top == 0.0:
        return 0.0
    mean = np.sqrt(top) * _mean_norm(lam / top)
    sd = float(np.sqrt(max(lam.sum() - mean * mean, 0.0)))
    return mean + 3.0 * sd


def joint_sigma_for_rp(jacobian, rp: float, weights=None) -> np.ndarray:
    """Per-joint repeatability σ_v (rad) giving a target RP at a posture.

    σ_v,i = s · w_i with the scale s chosen so that the position covariance
    J diag(σ_v²) Jᵀ has the expected RP ``rp`` (RP is proportional to s).

    Parameters
    ----------
    jacobian : array_like, shape (3, n_joint), m/rad
        Position Jacobian at the reference posture.
    rp : float
        Target repeatability, m (> 0).
    weights : array_like, shape (n_joint,), optional
        Relative σ of the joints (default all equal).

    Returns
    -------
    ndarray, shape (n_joint,), rad
    """
    jac = np.asarray(jacobian, float)
    if jac.ndim != 2 or jac.shape[0] != 3:
        raise InputError(f"jacobian must have shape (3, n_joint), got {jac.shape}")
    if not (np.isfinite(rp) and rp > 0):
        raise InputError(f"rp must be finite and > 0, got {rp!r}")
    w = np.ones(jac.shape[1]) if weights is None else np.asarray(weights, float)
    if w.shape != (jac.shape[1],) or not np.all(w >= 0) or not np.any(w > 0):
        raise InputError(f"weights must be {jac.shape[1]} non-negative values, not all zero")
    unit = iso9283_rp(jac @ np.diag(w * w) @ jac.T)
    if unit <= 0:
        raise InputError("the Jacobian maps the weighted joints to no motion: RP is zero")
    return w * (rp / unit)


def _mean_norm(lam: np.ndarray) -> float:
    """E||x|| for x ~ N(0, diag(lam)), max(lam) = 1 (integrated over t = log s)."""
    def integrand(t):
        s = np.exp(t)
        return -np.expm1(-0.5 * np.sum(np.log1p(2.0 * s * lam))) / np.sqrt(s)

    value = integrate.quad(integrand, -60.0, 60.0, limit=200, epsabs=0.0, epsrel=1e-11)[0]
    return value / (2.0 * np.sqrt(np.pi))
