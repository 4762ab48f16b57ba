"""Where a band's fit may be missing a pole, and where a new pole's fit starts.

:func:`scan_missing` screens a (frequency, damping) grid of candidate poles by linear algebra
alone (the model-order selection's add move, :mod:`rmbench.modal._select`); :func:`distinct`
keeps the candidates that are not already poles; :func:`left_of` and :func:`split_left` give a
new pole's starting φL from the LSFD residues (:func:`lsfd_scaled`). Poles in rad/s (scaled
units where the problem is scaled), frequencies in Hz.
"""

from __future__ import annotations

import numpy as np
from scipy.special import fdtrc

from rmbench.modal import mdof

__all__ = ["scan_missing", "MissingScan", "distinct", "lsfd_scaled", "split_left", "left_of", "SCAN_ZETA"]

SCAN_ZETA = (0.005, 0.015, 0.04, 0.1, 0.2)   # damping ratios of the scan's candidate poles


def scan_missing(freq, H, W, lam, residuals, grid, zetas=SCAN_ZETA):
    """The poles on a (frequency, damping) grid whose LSFD column pair best explains the error.

    With the current poles ``lam`` (rad/s) fixed, the data are projected off their LSFD basis;
    each candidate's two real basis columns are projected the same way, and the candidate whose
    columns capture the most of the remaining (per-FRF weighted) error wins. Linear algebra only.
    One call of :class:`MissingScan` (which keeps what does not depend on ``lam`` for the next).

    Parameters
    ----------
    freq : ndarray, shape (n_freq,), Hz
    H : ndarray, shape (n_freq, 4, 4), complex
    W : ndarray, shape (n_freq, 4, 4)
    lam : ndarray, complex, rad/s
    residuals : bool
    grid : ndarray, Hz
        Candidate natural frequencies.

    Returns
    -------
    list of (pole, p_value)
        The best candidate (complex, rad/s) below the band, inside it and above it (where the
        grid reaches), with the p-value of its F-test (linear model, one complex residue per
        FRF), most significant first.
    """
    return MissingScan(freq, H, W, residuals, zetas)(lam, grid)


def _basis(omega, poles):
    """The two complex LSFD columns of each pole, ``(g + gc, i (g − gc))``, each (n_freq, n)."""
    g = 1 / (1j * omega[:, None] - poles)
    gc = 1 / (1j * omega[:, None] - poles.conj())
    return g + gc, 1j * (g - gc)


class MissingScan:
    """:func:`scan_missing` on one band's data, called as ``scan(lam, grid)``.

    The model-order selection scans the same band many times with other current poles; the
    weighted data and each grid's candidate columns (the bulk of a scan) do not depend on them,
    so they are computed once: the two grids last used are kept (the grid changes only when a
    side of the band fills with out-of-band poles).
    """

    KEEP = 2   # grids whose candidate columns are kept (some 28 MB each on 1200 lines)

    def __init__(self, freq, H, W, residuals, zetas=SCAN_ZETA):
        self.freq = freq
        self.omega = 2 * np.pi * freq
        self.residuals = residuals
        self.zetas = zetas
        level = W.mean(axis=0).ravel()  # per-FRF weights (the pointwise coherence part is ignored)
        b = H.reshape(len(freq), -1) * level
        self.b = np.concatenate([b.real, b.imag])
        self._grids = {}

    def _candidates(self, grid):
        """Candidate poles (rad/s), their frequencies (Hz) and their real columns
        (2 n_freq, n_cand, 2) on ``grid`` (Hz)."""
        key = np.asarray(grid, float).tobytes()
        if key not in self._grids:
            z = np.asarray(self.zetas)
            wn = 2 * np.pi * np.repeat(np.asarray(grid, float), len(z))
            zz = np.tile(z, len(grid))
            cand = -zz * wn + 1j * wn * np.sqrt(1 - zz**2)
            c1, c2 = _basis(self.omega, cand)
            C = np.stack([np.concatenate([c1.real, c1.imag]),
                          np.concatenate([c2.real, c2.imag])], -1)
            f_cand = np.repeat(np.asarray(grid, float), len(z))
            if len(self._grids) >= self.KEEP:
                del self._grids[next(iter(self._grids))]
            self._grids[key] = (cand, f_cand, C)
        return self._grids[key]

    def __call__(self, lam, grid):
        """:func:`scan_missing` with the current poles ``lam`` (rad/s) on ``grid`` (Hz)."""
        freq, b = self.freq, self.b
        cols = list(_basis(self.omega, np.asarray(lam, complex)))
        if self.residuals:
            cols.append(mdof.residual_basis(self.omega))
        A = np.concatenate(cols, axis=1)
        A = np.concatenate([A.real, A.imag])
        Q, _ = np.linalg.qr(A / np.linalg.norm(A, axis=0))
        r0 = b - Q @ (Q.T @ b)
        cand, f_cand, C = self._candidates(grid)
        # projected off the current basis as matrix products (BLAS): (2 n_f, n_cand · 2)
        Cf = C.reshape(len(C), -1)
        Cf = Cf - Q @ (Q.T @ Cf)
        C = Cf.reshape(C.shape)                                           # (2 n_f, n_cand, 2)
        g00, g01, g11 = (C[..., 0] ** 2).sum(0), (C[..., 0] * C[..., 1]).sum(0), (C[..., 1] ** 2).sum(0)
        P = (Cf.T @ r0).reshape(len(cand), 2, -1)                        # (n_cand, 2, n_entries)
        # each candidate's 2 x 2 normal equations in closed form (Cramer)
        det = g00 * g11 - g01**2 + 1e-300
        s0 = (g11[:, None] * P[:, 0] - g01[:, None] * P[:, 1]) / det[:, None]
        s1 = (g00[:, None] * P[:, 1] - g01[:, None] * P[:, 0]) / det[:, None]
        gain = (P[:, 0] * s0 + P[:, 1] * s1).sum(-1)
        n_e = b.shape[1]
        dof = b.size - n_e * (Q.shape[1] + 2)
        rss = float(np.sum(r0**2))
        out = []
        # the best candidate below the band, inside it and above it: a strong in-band candidate
        # that fails must not hide the tail of a mode beyond the band
        for part in (f_cand < freq[0], (f_cand >= freq[0]) & (f_cand <= freq[-1]), f_cand > freq[-1]):
            if not part.any():
                continue
            best = int(np.flatnonzero(part)[np.argmax(gain[part])])
            rest = rss - gain[best]
            F = (gain[best] / (2 * n_e)) / (rest / dof) if rest > 0 else np.inf
            out.append((cand[best], float(fdtrc(2 * n_e, dof, F))))
        out.sort(key=lambda t: t[1])
        return out


def distinct(cands, lam, rel=0.5):
    """Candidate poles not within ``rel`` of their own decay rate of ``lam`` or of each other."""
    out = []
    for c in cands:
        near = [p for p in list(lam) + out if abs(p - c) <= rel * abs(c.real)]
        if not near:
            out.append(c)
    return out


def lsfd_scaled(problem, lam):
    """LSFD residues of poles ``lam`` on the problem's scaled data (unweighted)."""
    freq = problem.omega / (2 * np.pi)
    return mdof.lsfd(freq, problem.H, lam, residuals=problem.residuals)


def split_left(res):
    """φL of the rank-one split ``R_r ≈ φR φLᵀ`` (leading right singular vector), its largest
    element 1."""
    n = len(res)
    phi_l = np.empty((n, res.shape[2]), complex)
    for r in range(n):
        _, _, Vh = np.linalg.svd(res[r])
        v = Vh[0]
        phi_l[r] = v / v[np.argmax(np.abs(v))]
    return phi_l


def left_of(problem, lam, c):
    """Starting φL of a new pole ``c`` from the LSFD residues with the current poles."""
    res, _, _ = lsfd_scaled(problem, np.append(lam, c))
    return split_left(res[-1:])
