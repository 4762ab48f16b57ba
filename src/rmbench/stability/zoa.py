"""Zero-order approximation (Altintas & Budak 1995) with the full oriented FRF matrix.

The directional matrix is replaced by its time average H₀ (:meth:`Cutting.average_directional`);
at a chatter frequency ω the regenerative loop closes when det(I + a_p (1 − e^{−iωT}) H₀ Φ(iω)) = 0,
Φ the tool tip's 2x2 receptance with its cross terms (common open implementations drop Φ_xy and
Φ_yx). With μ an eigenvalue of H₀ Φ(iω) and Λ = −1/μ = a_p (1 − e^{−iωT}):

    a_lim = Λ_R (1 + κ²) / 2,  κ = Λ_I / Λ_R,  ωT = 2 arccot κ + 2kπ  (k = 0, 1, …),

a real depth needing Λ_R > 0. Each (eigenvalue, k) traces a lobe over ω; the diagram is the lowest
lobe at each speed.
"""

from __future__ import annotations

import numpy as np

from rmbench.stability.cutting import Cutting
from rmbench.stability.structure import Structure

__all__ = ["zoa_lobes", "zoa_limit", "zoa_limits"]


def zoa_lobes(structure: Structure, cutting: Cutting, speeds_rpm: np.ndarray, *, a_max: float = np.inf,
              n_freq: int = 4000, lobes: int = 60) -> np.ndarray:
    """Critical depth of the lowest zero-order lobe at each speed, m (inf: none below ``a_max``)."""
    speeds = np.asarray(speeds_rpm, float)
    f = np.linspace(0.3, 1.6, n_freq) * structure.f_max if len(structure.directions) == 1 else \
        np.geomspace(0.2 * _f_min(structure), 1.6 * structure.f_max, n_freq)
    phi = structure.frf(f)
    k = len(structure.directions)
    h0 = cutting.average_directional()[:k, :k]
    mu = np.linalg.eigvals(h0[None] @ phi)              # (n_freq, k)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = -1 / mu
        kappa = lam.imag / lam.real
        a = lam.real * (1 + kappa**2) / 2
        psi = np.arctan2(1.0, kappa)                    # arccot κ in (0, π)
    ok = (lam.real > 0) & np.isfinite(a)
    out = np.full(len(speeds), np.inf)
    omega = 2 * np.pi * f[:, None]
    for j in range(lobes):
        period = (2 * psi + 2 * np.pi * j) / omega       # (n_freq, k)
        rpm = 60 / (cutting.teeth * period)
        for e in range(k):
            r, d, good = rpm[:, e], a[:, e], ok[:, e]
            seg = good[:-1] & good[1:]
            r0, r1, d0, d1 = r[:-1][seg], r[1:][seg], d[:-1][seg], d[1:][seg]
            if not len(r0):
                continue
            lo_r, hi_r = np.minimum(r0, r1), np.maximum(r0, r1)
            inside = (speeds[:, None] >= lo_r[None]) & (speeds[:, None] <= hi_r[None])
            w = np.where(r1 != r0, (speeds[:, None] - r0[None]) / np.where(r1 != r0, r1 - r0, 1)[None], 0.0)
            val = np.where(inside, d0[None] + w * (d1 - d0)[None], np.inf)
            out = np.minimum(out, val.min(axis=1))
    out[out > a_max] = np.inf
    return out


def _f_min(structure: Structure) -> float:
    w = np.abs(np.linalg.eigvals(structure.A))
    return float(w[w > 0].min() / (2 * np.pi))


def zoa_limit(poles, residues, cutting: Cutting, speed_rpm: float, freq, *, chunk: int = 256) -> np.ndarray:
    """Critical depth of the lowest zero-order lobe at one spindle speed, for many tool tips at once.

    The same method as :func:`zoa_lobes`, vectorised over structures for a path's thousands of
    postures: each tool tip is given by its modes (padded with NaN to a common count), the
    receptance is summed over them on a common frequency grid, the 2x2 eigenvalues are taken in
    closed form, and each lobe ``ωT = 2 arccot κ + 2kπ`` is crossed where ``(ωT − 2 arccot κ)/2π``
    passes an integer between two lines of the grid (the depth interpolated there).

    Parameters
    ----------
    poles : ndarray, shape (n, n_modes), complex, rad/s
        Per tool tip, its poles (Im > 0); NaN for a padding slot.
    residues : ndarray, shape (n, n_modes, 2, 2), complex
        Residue of each mode at the tip in (x, y): ``H(s) = Σ R/(s − λ) + c.c.`` (m/N·rad/s; from
        eigenvector components ``R = φR φLᵀ``, as :meth:`Structure.from_modes`).
    cutting : Cutting
    speed_rpm : float
        Spindle speed, rev/min.
    freq : ndarray, shape (n_freq,), Hz
        The grid the chatter frequency is searched on (from below the lowest mode to above the
        highest; a few thousand lines, log-spaced).

    Returns
    -------
    ndarray, shape (n,), m
        inf where no lobe crosses the speed (stable at any depth by this method).
    """
    return zoa_limits(poles, residues, cutting, [speed_rpm], freq, chunk=chunk)[:, 0]


def zoa_limits(poles, residues, cutting: Cutting, speeds_rpm, freq, *, chunk: int = 256) -> np.ndarray:
    """:func:`zoa_limit` at several spindle speeds, shape (n, n_speeds), m: the receptance and its
    eigenvalues are the speeds' common part and are computed once."""
    poles = np.asarray(poles, complex)
    residues = np.asarray(residues, complex)
    freq = np.asarray(freq, float)
    speeds = np.atleast_1d(np.asarray(speeds_rpm, float))
    h0 = cutting.average_directional()
    omega = 2 * np.pi * freq
    out = np.full((len(poles), len(speeds)), np.inf)
    for a0 in range(0, len(poles), chunk):
        sl = slice(a0, a0 + chunk)
        lam_m = poles[sl]
        good = np.isfinite(lam_m)
        lam_m = np.where(good, lam_m, -1.0 + 1.0j)
        res = np.where(good[..., None, None], np.nan_to_num(residues[sl]), 0.0)
        s = 1j * omega
        w1 = 1.0 / (s[None, :, None] - lam_m[:, None, :])
        w2 = 1.0 / (s[None, :, None] - lam_m.conj()[:, None, :])
        phi = np.einsum("pfm,pmij->pfij", w1, res) + np.einsum("pfm,pmij->pfij", w2, res.conj())
        g = _left_multiply(h0, phi)
        tr = g[..., 0, 0] + g[..., 1, 1]
        det = g[..., 0, 0] * g[..., 1, 1] - g[..., 0, 1] * g[..., 1, 0]
        root = np.sqrt(tr * tr / 4 - det)
        for mu in (tr / 2 + root, tr / 2 - root):
            with np.errstate(divide="ignore", invalid="ignore"):
                lam = -1.0 / mu
                kappa = lam.imag / lam.real
                depth = lam.real * (1 + kappa ** 2) / 2
                psi = np.arctan2(1.0, kappa)
            ok = (lam.real > 0) & np.isfinite(depth)
            for j, speed in enumerate(speeds):
                tooth = 60.0 / (cutting.teeth * float(speed))
                u = (omega[None] * tooth - 2 * psi) / (2 * np.pi)
                k0, k1 = np.floor(u[:, :-1]), np.floor(u[:, 1:])
                cross = ok[:, :-1] & ok[:, 1:] & (k0 != k1) & (np.maximum(k0, k1) >= 0)
                # the integer crossed, and the fraction of the step where u reaches it
                k = np.maximum(k0, k1)
                du = u[:, 1:] - u[:, :-1]
                t = np.where(cross & (du != 0), (k - u[:, :-1]) / np.where(du != 0, du, 1.0), 0.0)
                val = np.where(cross, depth[:, :-1] + t * (depth[:, 1:] - depth[:, :-1]), np.inf)
                out[sl, j] = np.minimum(out[sl, j], val.min(axis=1))
    return out


def _left_multiply(h0: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """``h0 @ phi`` for a stack of 2x2 receptances ``phi`` (..., 2, 2), complex, and one real 2x2
    ``h0``: as one matrix product over the stack's columns rather than one per 2x2, at a third of
    the time (each entry the same two-term sum through the same BLAS: bit for bit the per-matrix
    products over the planner's and the depth band's calls, checked)."""
    cols = np.moveaxis(phi, -2, 0).reshape(2, -1)                 # (2, n·2): row k holds phi[..., k, :]
    return np.moveaxis((h0.astype(complex) @ cols).reshape((2,) + phi.shape[:-2] + (2,)), 0, -2)
