"""Exact modal parameters in the seed's parameterisation (METHODS.md §2, DATA.md).

Per mode: natural frequency, damping ratio, and the right and left eigenvectors at the four
measurement coordinates ``1X, 1Y, 1aX, 1aY``, scaled so that φL's ``1aY`` element is 1. That leaves
16 real numbers per mode, named as in DATA.md's ``param`` dimension.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ModeTable", "PARAMS", "mode_table"]

#: The 16 real parameters of a mode, DATA.md's ``param`` order: natural frequency ``f_n`` (Hz),
#: damping ratio ``zeta`` (dimensionless), then the real and imaginary parts of φL at 1X, 1aX, 1Y
#: (dimensionless; φL at 1aY is fixed at 1) and of φR at 1X, 1aX, 1Y, 1aY (s/kg).
PARAMS = ("f_n", "zeta",
          "phiL_1X_re", "phiL_1X_im", "phiL_1aX_re", "phiL_1aX_im", "phiL_1Y_re", "phiL_1Y_im",
          "phiR_1X_re", "phiR_1X_im", "phiR_1aX_re", "phiR_1aX_im", "phiR_1Y_re", "phiR_1Y_im",
          "phiR_1aY_re", "phiR_1aY_im")
_COORDS = ("1X", "1Y", "1aX", "1aY")
_REF = 3  # φL is normalised on its 1aY element


@dataclass(frozen=True)
class ModeTable:
    """Modes of one band at one posture.

    Attributes
    ----------
    band : str
    f_n : ndarray, shape (n_modes,), Hz
    zeta : ndarray, shape (n_modes,)
    phi_r : ndarray, shape (n_modes, 4), complex, s/kg
        Right eigenvectors at ``1X, 1Y, 1aX, 1aY`` (they carry the units).
    phi_l : ndarray, shape (n_modes, 4), complex
        Left eigenvectors at the same coordinates, ``phi_l[:, 3] == 1``.
    peak : ndarray, shape (n_modes,), m/N
        Largest contribution of each mode to the band's receptance matrix.
    """

    band: str
    f_n: np.ndarray
    zeta: np.ndarray
    phi_r: np.ndarray
    phi_l: np.ndarray
    peak: np.ndarray

    def __post_init__(self):
        n = len(self.f_n)
        if self.phi_r.shape != (n, 4) or self.phi_l.shape != (n, 4):
            raise ValueError("phi_r and phi_l must have shape (n_modes, 4)")

    def __len__(self) -> int:
        return len(self.f_n)

    @property
    def poles(self) -> np.ndarray:
        """λ = −ζω_n + iω_n√(1−ζ²), rad/s, shape (n_modes,)."""
        wn = 2 * np.pi * self.f_n
        return -self.zeta * wn + 1j * wn * np.sqrt(1 - self.zeta**2)

    def params(self) -> np.ndarray:
        """The 16 real parameters per mode in DATA.md order, shape (n_modes, 16)."""
        cols = [self.f_n, self.zeta]
        for vec, idx in ((self.phi_l, (0, 2, 1)), (self.phi_r, (0, 2, 1, 3))):
            for i in idx:
                cols += [vec[:, i].real, vec[:, i].imag]
        return np.column_stack(cols) if len(self) else np.zeros((0, 16))

    def frf(self, freq: np.ndarray) -> np.ndarray:
        """Receptance synthesised from these modes (Eq. 15), m/N, shape (n_freq, 4, 4)."""
        s = 2j * np.pi * np.asarray(freq, float)[:, None]
        lam = self.poles
        g, gc = 1 / (s - lam), 1 / (s - lam.conj())
        return (np.einsum("fm,mo,mi->foi", g, self.phi_r, self.phi_l)
                + np.einsum("fm,mo,mi->foi", gc, self.phi_r.conj(), self.phi_l.conj()))

    def to_dict(self) -> list[dict]:
        """JSON-ready list: ``{"f_n", "zeta", "phiL": {coord: [re, im]}, "phiR": {...}}`` per mode."""
        out = []
        for r in range(len(self)):
            out.append({
                "f_n": float(self.f_n[r]), "zeta": float(self.zeta[r]), "band": self.band,
                "phiL": {c: [float(self.phi_l[r, i].real), float(self.phi_l[r, i].imag)]
                         for i, c in enumerate(_COORDS)},
                "phiR": {c: [float(self.phi_r[r, i].real), float(self.phi_r[r, i].imag)]
                         for i, c in enumerate(_COORDS)},
            })
        return out


def mode_table(modes, out: np.ndarray, inp: np.ndarray, band, *, threshold: float = 0.01,
               n_lines: int = 2000) -> ModeTable:
    """Modes of ``modes`` (a ComplexModes) visible in ``band`` at coordinates ``out``/``inp``.

    Parameters
    ----------
    out, inp : ndarray, shape (4, n_dof)
        Coordinate maps of ``1X, 1Y, 1aX, 1aY`` for responses and forces.
    band : Band
    threshold : float
        A mode is kept when its peak contribution exceeds this fraction of the band's peak.
    """
    f = modes.f_n
    r = out @ modes.phi_r  # (4, n_modes)
    lt = inp @ modes.phi_l
    residue_peak = np.abs(np.einsum("om,im->moi", r, lt)).reshape(len(f), -1).max(axis=1)
    peak = residue_peak / np.maximum(np.abs(modes.poles.real), 1e-300)
    freq = np.linspace(band.f_min, band.f_max, n_lines)
    band_peak = np.abs(modes.frf(freq, out, inp)).max()
    keep = (f >= band.f_min) & (f <= band.f_max) & (peak > threshold * band_peak) & ~modes.real_pole
    ref = lt[_REF, keep]
    phi_r = (r[:, keep] * ref).T
    phi_l = (lt[:, keep] / ref).T
    return ModeTable(band=band.name, f_n=f[keep], zeta=modes.zeta[keep], phi_r=phi_r,
                     phi_l=phi_l, peak=peak[keep])
