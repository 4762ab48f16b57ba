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

__all__ = ["zoa_lobes"]


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
