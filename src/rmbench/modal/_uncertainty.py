"""How well a band's fit knows its parameters: the covariance of the fit's variables, carried to
the user's φL normalisation and to the 16 reported parameters' standard errors, and the MAC loss
that the eigenvectors' standard errors allow (used by :class:`~rmbench.modal.ModalFit`).

The fit's variables are those of :func:`rmbench.modal.mdof._pack`: per mode the pole (σ, ω_d),
φR (real parts, then imaginary), φL without its fixed element (likewise), then the residual terms;
all in scaled units (frequency by ``ws``, receptance by ``hs``).
"""

from __future__ import annotations

import numpy as np

from rmbench.modal import mdof

__all__ = ["covariance", "renormalisation", "parameters", "mac_losses"]

_PHI_L_IDX = (0, 2, 1)      # coordinate index of the φL entries of PARAM_NAMES
_PHI_R_IDX = (0, 2, 1, 3)   # coordinate index of the φR entries


def covariance(J, r):
    """``σ² (JᵀJ)⁻¹`` with ``σ²`` the residual variance (pseudo-inverse, column-scaled eigh).

    The eigen-decomposition of the scaled normal matrix costs a fraction of an SVD of the tall
    ``J``; scaling the columns to unit norm first keeps its conditioning that of ``J`` squared
    only within the parameters' own spread, well inside double precision here.
    """
    m, n = J.shape
    sigma2 = float(r @ r) / max(m - n, 1)
    d = np.linalg.norm(J, axis=0)
    d = np.where(d > 0, d, 1.0)
    Js = J / d
    w, V = np.linalg.eigh(Js.T @ Js)
    inv = np.where(w > w[-1] * 1e-24, 1 / np.where(w > 0, w, 1.0), 0.0)
    return sigma2 * ((V * inv) @ V.T) / np.outer(d, d)


def renormalisation(phi_r, phi_l, refs_from, refs_to, n_x: int) -> np.ndarray:
    """``∂x_to/∂x_from``, shape (n_x, n_x): the fit's variables (:func:`mdof._pack`) normalised
    with ``φL[refs_from] = 1`` (``phi_r``, ``phi_l`` in that normalisation, (n, 4)) against those
    normalised with ``φL[refs_to] = 1``.

    Per mode, with ``p = φL[to]``: ``φR' = p φR`` and ``φL' = φL / p`` (so ``φL'[from] = 1/p``);
    the poles and the residual terms are unchanged. A complex derivative ``d`` acts on
    ``(Re z, Im z)`` as ``[[Re d, −Im d], [Im d, Re d]]``.
    """
    T = np.eye(n_x)
    n_out, n_in = phi_r.shape[1], phi_l.shape[1]
    lo = 2 + 2 * n_out                          # first φL variable of a mode's block

    def put(b, row, col, d):
        # rows (Re, Im) of output `row`, columns (Re, Im) of input `col`, each an offset of
        # its kind's real part; imaginary parts follow at +n (φR) or +n_in - 1 (φL)
        (ri, rj), (ci, cj) = row, col
        T[b + ri, b + ci] = d.real
        T[b + ri, b + cj] = -d.imag
        T[b + rj, b + ci] = d.imag
        T[b + rj, b + cj] = d.real

    for m, (s, u) in enumerate(zip(refs_from, refs_to)):
        if s == u:
            continue                             # p = 1: the identity
        b = mdof.N_PER_MODE * m
        free_s = [k for k in range(n_in) if k != s]
        free_u = [k for k in range(n_in) if k != u]
        nf = n_in - 1

        def col_l(k):
            q = free_s.index(k)
            return (lo + q, lo + nf + q)

        p = complex(phi_l[m, u])
        T[b + 2:b + mdof.N_PER_MODE, b + 2:b + mdof.N_PER_MODE] = 0.0
        for j in range(n_out):
            row = (2 + j, 2 + n_out + j)
            put(b, row, row, p)
            put(b, row, col_l(u), complex(phi_r[m, j]))
        for q, k in enumerate(free_u):
            row = (lo + q, lo + nf + q)
            if k == s:                           # φL'[from] = 1 / p
                put(b, row, col_l(u), -1 / p**2)
            else:
                put(b, row, col_l(k), 1 / p)
                put(b, row, col_l(u), -complex(phi_l[m, k]) / p**2)
    return T


def parameters(lam, phi_r, phi_l, cov, refs, flip, ws, hs):
    """Parameters in PARAM_NAMES order and their standard errors (delta method)."""
    n = len(lam)
    params = np.zeros((n, 16))
    std = np.zeros((n, 16))
    var = np.diag(cov)
    for r in range(n):
        b = 16 * r
        sig, wd = lam[r].real, lam[r].imag
        mag = abs(lam[r])
        params[r, 0] = mag / (2 * np.pi)
        params[r, 1] = -sig / mag
        # (σ, ω_d) in scaled units; conjugating flips the sign of ω_d only
        # d(f_n, ζ)/d(σ', ω') with σ = ws σ', ω_d = ws ω' (scaled fit variables)
        g = ws * np.array([[sig / (2 * np.pi * mag), wd / (2 * np.pi * mag)],
                           [-(wd**2) / mag**3, sig * wd / mag**3]])
        if flip[r]:
            g[:, 1] *= -1
        c2 = cov[b:b + 2, b:b + 2]
        std[r, :2] = np.sqrt(np.maximum(np.diag(g @ c2 @ g.T), 0))
        free = [i for i in range(4) if i != refs[r]]
        for t, i in enumerate(_PHI_L_IDX):
            params[r, 2 + 2 * t] = phi_l[r, i].real
            params[r, 3 + 2 * t] = phi_l[r, i].imag
            if i in free:
                q = free.index(i)
                std[r, 2 + 2 * t] = np.sqrt(max(var[b + 10 + q], 0))
                std[r, 3 + 2 * t] = np.sqrt(max(var[b + 13 + q], 0))
        for t, i in enumerate(_PHI_R_IDX):
            params[r, 8 + 2 * t] = phi_r[r, i].real
            params[r, 9 + 2 * t] = phi_r[r, i].imag
            std[r, 8 + 2 * t] = np.sqrt(max(var[b + 2 + i], 0)) * hs * ws
            std[r, 9 + 2 * t] = np.sqrt(max(var[b + 6 + i], 0)) * hs * ws
    return params, std


def mac_losses(cov, sol):
    """``1 − MAC`` that the standard errors of φR and of φL allow, the larger, per mode.

    For a small error ``δ`` of a vector ``φ``, ``1 − MAC ≈ |δ⊥|² / |φ|²``; its mean is at most
    ``Σ var / |φ|²``, taken in the fit's own normalisation (φL's largest element fixed), where it
    does not carry the uncertainty of a scale that MAC ignores.
    """
    var = np.diag(cov)
    out = np.empty(sol.n)
    for r in range(sol.n):
        b = mdof.N_PER_MODE * r
        v_r = var[b + 2:b + 10].sum()
        v_l = var[b + 10:b + 16].sum()
        out[r] = max(v_r / np.sum(np.abs(sol.phi_r[r]) ** 2),
                     v_l / np.sum(np.abs(sol.phi_l[r]) ** 2))
    return out
