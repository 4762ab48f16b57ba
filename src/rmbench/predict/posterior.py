"""The posterior of a Kronecker-structured Gaussian process, in numpy (METHODS.md §5).

Model of ``m`` tasks observed at the same ``n`` inputs (standardised units)::

    cov(y_ij, y_kl) = K_t[i, k] K_c[j, l] + δ_ik δ_jl d_j

``K_t`` the ARD squared-exponential kernel of the inputs (unit variance), ``K_c`` the task covariance
and ``d`` the per-task noise variances. A single-task GP is the case ``m = 1`` (``K_c = σ_f²``). With
``S = diag(√d)``, ``S⁻¹ K_c S⁻¹ = Q_c Λ_c Q_cᵀ`` and ``K_t = Q_t Λ_t Q_tᵀ`` every solve, determinant
and predictive variance goes through the two eigendecompositions: O(n³ + m³), never the nm × nm
matrix (Rakitsch et al. 2013, "It is all in the noise"; gpytorch's Kronecker operators do the same
while fitting). Hyperparameters come from :mod:`rmbench.predict.gp`; this module only evaluates, so a
trained predictor is a handful of arrays (no pickle) and one prediction costs microseconds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["KronPosterior", "loo_residuals", "rbf"]


def rbf(A: np.ndarray, B: np.ndarray, lengthscales: np.ndarray) -> np.ndarray:
    """``exp(−½ Σ_d ((a_d − b_d)/ℓ_d)²)``, shape (len(A), len(B))."""
    a, b = A / lengthscales, B / lengthscales
    d2 = (a**2).sum(1)[:, None] + (b**2).sum(1)[None, :] - 2 * a @ b.T
    return np.exp(-0.5 * np.maximum(d2, 0.0))


@dataclass(frozen=True)
class KronPosterior:
    """Posterior of the Kronecker model, from its hyperparameters and data.

    Attributes
    ----------
    X : ndarray, shape (n, d)
        Training inputs, standardised.
    lengthscales : ndarray, shape (d,)
        ARD length scales in standardised input units.
    Kc : ndarray, shape (m, m)
        Task covariance (standardised outputs).
    noise : ndarray, shape (m,)
        Per-task noise variances (standardised outputs).
    mean : ndarray, shape (m,)
        Per-task prior means (standardised outputs).
    W : ndarray, shape (n, m)
        ``A K_c`` with ``A`` the solution of the covariance system: mean = k(x*, X) W + mean.
    G : ndarray, shape (n, m)
        ``1 / (λ_t λ_cᵀ + 1)``.
    Qt : ndarray, shape (n, n)
    P2 : ndarray, shape (m, m)
        ``(S Q_c Λ_c)²`` elementwise.
    """

    X: np.ndarray
    lengthscales: np.ndarray
    Kc: np.ndarray
    noise: np.ndarray
    mean: np.ndarray
    W: np.ndarray
    G: np.ndarray
    Qt: np.ndarray
    P2: np.ndarray
    log_likelihood: float

    @classmethod
    def build(cls, X, Y, lengthscales, Kc, noise, mean) -> "KronPosterior":
        """Solve the model on training data ``Y`` (n, m), standardised, no NaN."""
        X, Y = np.asarray(X, float), np.asarray(Y, float)
        lengthscales = np.asarray(lengthscales, float)
        Kc = np.atleast_2d(np.asarray(Kc, float))
        noise, mean = np.atleast_1d(np.asarray(noise, float)), np.atleast_1d(np.asarray(mean, float))
        n, m = Y.shape
        s = np.sqrt(noise)
        lam_t, Qt = np.linalg.eigh(rbf(X, X, lengthscales))
        lam_c, Qc = np.linalg.eigh(Kc / np.outer(s, s))
        lam_t, lam_c = np.maximum(lam_t, 0.0), np.maximum(lam_c, 0.0)  # round-off below zero
        G = 1.0 / (np.outer(lam_t, lam_c) + 1.0)
        R = Y - mean
        C = (Qt.T @ (R / s) @ Qc) * G
        A = (Qt @ C @ Qc.T) / s
        logdet = n * np.log(noise).sum() - np.log(G).sum()
        loglik = -0.5 * (np.sum(R * A) + logdet + n * m * np.log(2 * np.pi))
        P2 = (s[:, None] * Qc * lam_c) ** 2
        return cls(X, lengthscales, Kc, noise, mean, A @ Kc, G, Qt, P2, float(loglik))

    def predict(self, Xs: np.ndarray, return_std: bool = False):
        """Mean, shape (n*, m), and with ``return_std`` the latent standard deviation, same shape."""
        k = rbf(np.atleast_2d(np.asarray(Xs, float)), self.X, self.lengthscales)
        mu = k @ self.W + self.mean
        if not return_std:
            return mu
        u2 = (k @ self.Qt) ** 2                                     # (n*, n)
        var = np.diag(self.Kc)[None, :] - (u2 @ self.G) @ self.P2.T
        return mu, np.sqrt(np.maximum(var, 0.0))

    def arrays(self) -> dict:
        """The arrays that rebuild this posterior (see :meth:`from_arrays`)."""
        return {k: getattr(self, k) for k in ("X", "lengthscales", "Kc", "noise", "mean", "W", "G",
                                              "Qt", "P2")} | {"log_likelihood": np.array(self.log_likelihood)}

    @classmethod
    def from_arrays(cls, a: dict) -> "KronPosterior":
        return cls(**{k: np.asarray(a[k], float) for k in ("X", "lengthscales", "Kc", "noise", "mean",
                                                           "W", "G", "Qt", "P2")},
                   log_likelihood=float(a["log_likelihood"]))


def loo_residuals(X, Y, lengthscales, Kc, noise, mean) -> tuple[np.ndarray, np.ndarray]:
    """Leave-one-input-out residuals of the Kronecker model with fixed hyperparameters, and their
    predictive standard deviations: all ``m`` tasks at an input left out together.

    The block form of Rasmussen & Williams (2006, §5.4.2): with ``α = Σ⁻¹ (y − mean)`` and
    ``B_i`` the ``m × m`` diagonal block of ``Σ⁻¹`` at input ``i``, the residual is
    ``B_i⁻¹ α_i`` and its covariance ``B_i⁻¹`` (noise included), exactly as a refit without the
    input would give; ``B_i = S⁻¹ Q_c diag(g_i) Q_cᵀ S⁻¹`` with ``g = (Q_t ∘ Q_t) G``, so no
    ``nm × nm`` matrix is formed.

    Parameters
    ----------
    X : ndarray, shape (n, d)
    Y : ndarray, shape (n, m)
        Training data in the model's (standardised) units.

    Returns
    -------
    residual, sd : ndarray, shape (n, m)
        ``y_i − μ₋ᵢ`` and the predictive standard deviation of ``y_i`` without it.
    """
    X, Y = np.asarray(X, float), np.asarray(Y, float)
    Kc = np.atleast_2d(np.asarray(Kc, float))
    noise, mean = np.atleast_1d(np.asarray(noise, float)), np.atleast_1d(np.asarray(mean, float))
    s = np.sqrt(noise)
    lam_t, Qt = np.linalg.eigh(rbf(X, X, np.asarray(lengthscales, float)))
    lam_c, Qc = np.linalg.eigh(Kc / np.outer(s, s))
    G = 1.0 / (np.outer(np.maximum(lam_t, 0.0), np.maximum(lam_c, 0.0)) + 1.0)
    alpha = (Qt @ ((Qt.T @ ((Y - mean) / s) @ Qc) * G) @ Qc.T) / s        # Σ⁻¹ (y − mean)
    g = (Qt ** 2) @ G                                                       # (n, m)
    residual = (((alpha * s) @ Qc) / g) @ Qc.T * s
    var = (1.0 / g) @ ((s[:, None] * Qc) ** 2).T
    return residual, np.sqrt(var)
