"""Poly-reference least-squares complex-frequency estimator (pLSCF, "PolyMAX").

A right matrix-fraction model in the z-domain, ``H(z) = B(z) A(z)^-1`` with real matrix coefficients
and ``z = exp(i ω Δt)``, ``Δt = 1 / (2 f_max)``, fitted by linear least squares through the reduced
normal equations (Peeters et al. 2004). The numerator is eliminated output by output, so one set of
products at the highest order serves every lower order (the basis is nested). The poles are the
eigenvalues of the denominator's companion matrix; its eigenvectors carry the participation vectors
(the input side of the mode, i.e. φL up to scale).

Vocabulary: ``freq`` in Hz, ``omega`` and poles in rad/s.
"""

from dataclasses import dataclass
from typing import Literal

import numpy as np

__all__ = ["PolyMaxOrder", "plscf"]


@dataclass(frozen=True)
class PolyMaxOrder:
    """Poles of one pLSCF model order.

    Attributes
    ----------
    order : int
        Polynomial order ``p`` of the denominator (``p * n_in`` poles in all).
    poles : ndarray, shape (n_poles,), complex, rad/s
        Poles with ``Im > 0`` (one per conjugate pair), sorted by frequency.
    participation : ndarray, shape (n_poles, n_in), complex
        Participation vector of each pole (unit norm).
    """

    order: int
    poles: np.ndarray
    participation: np.ndarray

    def __post_init__(self):
        if self.participation.shape[0] != self.poles.shape[0]:
            raise ValueError("poles and participation must have the same length")


def plscf(freq: np.ndarray, H: np.ndarray, orders, *, weights: np.ndarray | None = None,
          basis: Literal["real", "shifted", "auto"] = "auto") -> list[PolyMaxOrder]:
    """Poles of ``H`` at each model order in ``orders`` (pLSCF).

    Parameters
    ----------
    freq : ndarray, shape (n_freq,), Hz
        Uniformly spaced, positive, increasing frequency lines.
    H : ndarray, shape (n_freq, n_out, n_in), complex, m/N
        FRF matrix (rows: responses, columns: excitations, the references).
    orders : sequence of int
        Model orders ``p >= 1`` to estimate.
    weights : ndarray, shape (n_freq, n_out), optional
        Real weight of each output at each line (default: each output scaled by ``1 / rms``).
    basis : {"real", "shifted", "auto"}
        ``"real"``: real coefficients, ``z = exp(i ω Δt)``, ``Δt = 1 / (2 f_max)`` (classic
        PolyMAX; poles in conjugate pairs). ``"shifted"``: complex coefficients on the band
        mapped around its centre ``ω_c``, ``z = exp(i (ω − ω_c) Δt)``, ``Δt = 0.8 π / (ω_max −
        ω_c)``, so that a band far from 0 Hz uses most of the unit circle instead of a sliver
        near Nyquist. ``"auto"``: ``"shifted"`` when ``f_min > f_max / 4``.

    Returns
    -------
    list of PolyMaxOrder
        One per order, in the order given.
    """
    freq = np.asarray(freq, float)
    n_f, n_out, n_in = H.shape
    orders = [int(p) for p in orders]
    p_max = max(orders)
    if basis == "auto":
        basis = "shifted" if freq[0] > freq[-1] / 4 else "real"
    omega = 2 * np.pi * freq
    if basis == "real":
        centre, dt = 0.0, np.pi / omega[-1]
        part = np.real
    else:
        centre = 0.5 * (omega[0] + omega[-1])
        dt = 0.8 * np.pi / (omega[-1] - centre)
        part = _identity
    if weights is None:
        rms = np.sqrt(np.mean(np.abs(H) ** 2, axis=(0, 2)))
        weights = np.broadcast_to(1.0 / np.where(rms > 0, rms, 1.0), (n_f, n_out))
    omega_basis = np.exp(1j * (omega - centre)[:, None] * dt * np.arange(p_max + 1))
    n_b = p_max + 1
    R, S, T = [], [], []
    for o in range(n_out):
        w = weights[:, o]
        X = w[:, None] * omega_basis
        Y = -(w[:, None, None] * omega_basis[:, :, None] * H[:, o, None, :]).reshape(n_f, n_b * n_in)
        R.append(part(X.conj().T @ X))
        S.append(part(X.conj().T @ Y))
        T.append(part(Y.conj().T @ Y))
    out = []
    for p in orders:
        nb, ny = p + 1, (p + 1) * n_in
        M = np.zeros((ny, ny), T[0].dtype)
        for o in range(n_out):
            Ro, So = R[o][:nb, :nb], S[o][:nb, :ny]
            M += T[o][:ny, :ny] - So.conj().T @ np.linalg.solve(Ro, So)
        pn = p * n_in
        try:
            alpha = -np.linalg.solve(M[:pn, :pn], M[:pn, pn:])  # A_0..A_{p-1} stacked, A_p = I
        except np.linalg.LinAlgError:
            alpha = -np.linalg.lstsq(M[:pn, :pn], M[:pn, pn:], rcond=None)[0]
        out.append(_poles_of(alpha, p, n_in, dt, centre))
    return out


def _poles_of(alpha: np.ndarray, p: int, n_in: int, dt: float, centre: float) -> PolyMaxOrder:
    """Companion-matrix eigen-decomposition of the denominator ``A(z) = Σ A_j z^j``, ``A_p = I``.

    The left null vectors ``w`` of ``A(z_r)`` (``A(z_r)^T w = 0``) are the participation vectors;
    with the state ``[w; z w; ...; z^(p-1) w]`` the companion matrix has ``-A_j^T`` in its last
    block row.
    """
    pn = p * n_in
    C = np.zeros((pn, pn), alpha.dtype)
    if p > 1:
        C[: pn - n_in, n_in:] = np.eye(pn - n_in)
    for j in range(p):
        C[pn - n_in:, j * n_in:(j + 1) * n_in] = -alpha[j * n_in:(j + 1) * n_in, :].T
    z = np.linalg.eigvals(C)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = 1j * centre + np.log(z.astype(complex)) / dt
    keep = np.isfinite(lam) & (np.abs(z) > 0)
    if centre == 0.0:
        keep &= lam.imag > 0
    lam, z = lam[keep], z[keep]
    # participation: left null vector of A(z_r), A(z) = Σ A_j z^j + I z^p (4x4 SVD per pole)
    Az = np.eye(n_in) * (z**p)[:, None, None]
    for j in range(p):
        Az = Az + alpha[j * n_in:(j + 1) * n_in, :][None] * (z**j)[:, None, None]
    _, _, Vh = np.linalg.svd(np.swapaxes(Az, 1, 2))
    L = Vh[:, -1, :].conj()
    norm = np.linalg.norm(L, axis=1, keepdims=True)
    L = L / np.where(norm > 0, norm, 1.0)
    order = np.argsort(lam.imag)
    return PolyMaxOrder(order=p, poles=lam[order], participation=L[order])


def _identity(a):
    return a
