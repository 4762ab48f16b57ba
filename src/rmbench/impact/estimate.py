"""FRF estimation from impact records: windows, the H1 estimator and the ordinary coherence.

Records are averaged per excitation coordinate: for hits k = 1..n on one input,

    H1 = Σ_k Y_k conj(F_k) / Σ_k |F_k|²,    γ² = |Σ_k Y_k conj(F_k)|² / (Σ_k |F_k|² Σ_k |Y_k|²).
"""

from __future__ import annotations

import numpy as np

__all__ = ["force_window", "exponential_window", "SpectralSums", "h1"]


def force_window(n: int, fs: float, length: float, taper: float = 0.1) -> np.ndarray:
    """Force window: 1 over the pulse, a half-cosine taper, then 0, shape (n,).

    Parameters
    ----------
    length : float
        Duration kept at full weight, s (the pulse plus a margin).
    taper : float
        Taper length as a fraction of ``length``.
    """
    t = np.arange(n) / fs
    w = np.zeros(n)
    w[t <= length] = 1.0
    ramp = (t > length) & (t <= length * (1 + taper))
    w[ramp] = 0.5 * (1 + np.cos(np.pi * (t[ramp] - length) / (taper * length)))
    return w


def exponential_window(n: int, end_value: float) -> np.ndarray:
    """Exponential window exp(−t/τ) falling to ``end_value`` at the record's end, shape (n,).

    Its added damping is σ = −ln(end_value)/T (1/s): a mode's damping ratio reads
    ζ + σ/ω_n after windowing.
    """
    if end_value >= 1.0:
        return np.ones(n)
    return np.exp(np.log(end_value) * np.arange(n) / n)


class SpectralSums:
    """Running auto- and cross-spectra of one excitation coordinate's hits.

    Parameters
    ----------
    n_lines, n_out : int
    """

    def __init__(self, n_lines: int, n_out: int):
        self.sff = np.zeros(n_lines)
        self.syf = np.zeros((n_lines, n_out), complex)
        self.syy = np.zeros((n_lines, n_out))
        self.count = 0

    def add(self, f: np.ndarray, y: np.ndarray) -> None:
        """Add one hit: force spectrum ``f`` (n_lines,), response spectra ``y`` (n_lines, n_out)."""
        self.sff += np.abs(f) ** 2
        self.syf += y * f.conj()[:, None]
        self.syy += np.abs(y) ** 2
        self.count += 1


def h1(sums: SpectralSums) -> tuple[np.ndarray, np.ndarray]:
    """H1 estimate and coherence from accumulated spectra.

    Returns
    -------
    h : ndarray, shape (n_lines, n_out), complex
        Response over force (units of the records).
    coherence : ndarray, shape (n_lines, n_out)
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        h = sums.syf / sums.sff[:, None]
        coh = np.abs(sums.syf) ** 2 / (sums.sff[:, None] * sums.syy)
    return h, np.nan_to_num(coh, nan=0.0)
