"""Anti-windup for a discrete state-space controller: the observer (Åström–Rundqwist) form.

The controller ``x⁺ = A x + B y, u = C x + D y`` runs as an observer of its own output when the
actuator limits it: with ``u_sat`` the force the limit lets through,

    x⁺ = A x + B y + L (u_sat − u)    =    (A − L C) x + (B − L D) y + L u_sat,

so its state follows the force actually applied instead of integrating a command the coil never
delivered. Without saturation ``u_sat = u`` and the controller is unchanged; under saturation its
dynamics are ``A − L C``, which this gain keeps stable.

The gain is the steady-state Kalman predictor gain for the controller seen as a system driven by
unknown measurements (entering through ``B``) and observed through its output ``u``: ``P`` solves
the discrete Riccati equation with process covariance ``B W Bᵀ`` and output covariance ``ρ I``,
``L = A P Cᵀ (C P Cᵀ + ρ I)⁻¹``. ``W`` scales each measurement channel by the inverse square of its
peak gain to the force (so accelerations in m/s² and positions in m weigh alike, in N); ``A − L C``
is then stable whenever the controller's poles are (or are detectable through ``C``), and its
poles do not depend on the state coordinates. ``ρ`` = 1 N² balances the two: as ρ → 0 the poles of
``A − L C`` go to the controller's zeros (Hanus' conditioning, ``L = B D⁻¹`` for a square ``D``,
which here is 1 × 2 and not invertible, and whose zeros may lie near or outside the unit circle),
as ρ → ∞ back to its own poles (no anti-windup).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_discrete_are

__all__ = ["observer_gain", "RHO"]

RHO = 1.0
"""Output covariance of the anti-windup observer, N², against measurement channels scaled to 1 N
of peak force each."""

_N_FREQ = 256  # unit-circle points for the channels' peak gains


def _channel_peaks(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray) -> np.ndarray:
    """Peak over frequency of each input channel's gain to the outputs (2-norm), shape (n_in,)."""
    z = np.exp(1j * np.linspace(0.0, np.pi, _N_FREQ))
    eye = np.eye(A.shape[0])
    peaks = np.abs(D).max(axis=0) if D.size else np.zeros(B.shape[1])
    for zi in z:
        H = C @ np.linalg.solve(zi * eye - A, B) + D
        peaks = np.maximum(peaks, np.linalg.norm(H, axis=0))
    return peaks


def observer_gain(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, rho: float = RHO) -> np.ndarray:
    """The anti-windup gain ``L``, shape (n_k, n_out), of a discrete controller ``(A, B, C, D)``
    (shapes (n_k, n_k), (n_k, n_in), (n_out, n_k), (n_out, n_in)); zeros for a static controller
    or one whose measurements do not reach its state."""
    n_k, n_out = A.shape[0], C.shape[0]
    if n_k == 0:
        return np.zeros((0, n_out))
    peaks = _channel_peaks(A, B, C, D)
    w = np.where(peaks > 0, 1.0 / np.where(peaks > 0, peaks, 1.0) ** 2, 0.0)
    Q = (B * w) @ B.T
    if not np.any(Q):
        return np.zeros((n_k, n_out))
    Q = 0.5 * (Q + Q.T)
    R = rho * np.eye(n_out)
    P = solve_discrete_are(A.T, C.T, Q, R)
    return A @ P @ C.T @ np.linalg.inv(C @ P @ C.T + R)
