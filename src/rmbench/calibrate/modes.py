"""The modes of a model as a test sees them: at the test design's sensors and hit points.

A model's complex modes (:class:`~rmbench.robot.linear.ComplexModes`) read at a test's sensors
(position, direction, cross-axis sensitivity) and excited at its hit points give the modal
parameters a test of that model would find: frequencies, dampings and residue matrices
``φR φLᵀ`` (4 sensors × 4 hits), with each mode's share of the band's peak and whether it lies
clear of the band's edges. Calibration and gap diagnosis compare measured modes with these.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ModelModes", "modes_seen"]

_EXTEND = 1.25        # model modes this far outside a band may pair with measured ones
_EDGE = 1.02         # a mode this close to a band edge may be fitted as an out-of-band term
_VISIBLE = 0.002      # model modes below this share of the band's peak are ignored


@dataclass(frozen=True)
class ModelModes:
    """Modes of a model at one posture in one band, as the test design sees them.

    Attributes
    ----------
    f_n : ndarray, shape (n,), Hz
    zeta : ndarray, shape (n,)
    residue : ndarray, shape (n, 4, 4), complex, m/(N·s)
        ``φR φLᵀ`` of each mode at the design's sensors (rows) and hit points (columns).
    peak : ndarray, shape (n,)
        Peak of the mode's contribution as a share of the band's peak receptance.
    inside : ndarray of bool, shape (n,)
        Whether the mode lies inside the band (2 % clear of its edges), where a test must see it;
        modes beyond the edges show only as the out-of-band terms of a fit.
    band_peak : float
        The band's peak receptance, m/N, that ``peak`` is a share of (NaN where not known).
    """

    f_n: np.ndarray
    zeta: np.ndarray
    residue: np.ndarray
    peak: np.ndarray
    inside: np.ndarray
    band_peak: float = np.nan

    def __len__(self) -> int:
        return len(self.f_n)



def modes_seen(cm, out, inp, b, band_peak: float | None = None) -> ModelModes:
    """The modes of ``cm`` a test of band ``b`` sees at rows ``out`` (sensors), ``inp`` (hits).

    ``band_peak`` (m/N) is the band's peak receptance, where known (the same model a small step
    away: a sensitivity's stepped modes); by default it is found on the band's lines.
    """
    r = out @ cm.phi_r                      # (4, n)
    lt = inp @ cm.phi_l
    f = cm.f_n
    resid = np.einsum("om,im->moi", r, lt)  # (n, 4, 4)
    peak = np.abs(resid).reshape(len(f), -1).max(axis=1) / np.maximum(np.abs(cm.poles.real), 1e-300)
    # the band's peak receptance: on a coarse grid, and at each in-band mode (a light mode's
    # peak falls between grid lines)
    if band_peak is None:
        in_band = (f >= b.f_min) & (f <= b.f_max) & ~cm.real_pole
        lines = np.concatenate([np.linspace(b.f_min, b.f_max, 60), f[in_band]])
        band_peak = float(np.abs(cm.frf(lines, out, inp)).max())
    keep = ((f >= b.f_min / _EXTEND) & (f <= b.f_max * _EXTEND) & ~cm.real_pole
            & (peak >= _VISIBLE * band_peak))
    inside = (f >= b.f_min * _EDGE) & (f <= b.f_max / _EDGE)
    return ModelModes(f_n=f[keep], zeta=cm.zeta[keep], residue=resid[keep],
                      peak=peak[keep] / band_peak, inside=inside[keep], band_peak=band_peak)
