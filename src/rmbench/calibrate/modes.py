"""The modes of a model as a test sees them: at the test design's sensors and hit points.

A model's complex modes (:class:`~rmbench.robot.linear.ComplexModes`) read at a test's sensors
(position, direction, cross-axis sensitivity) and excited at its hit points give the modal
parameters a test of that model would find: frequencies, dampings and residue matrices
``φR φLᵀ`` (4 sensors × 4 hits), with each mode's share of the band's peak and whether it lies
clear of the band's edges. Calibration and gap diagnosis compare measured modes with these.

The reading is one engine for both: :func:`with_sensors` puts a band's sensor masses on the robot
that is tested, :func:`as_tested` reads an operating point's modes (or a perturbation of them) at
the design's sensors and hit points, and :class:`AsTested` gives the modes a test would find and
the exact receptance as tested. The calibration's :class:`~rmbench.calibrate.model.ModalModel`
(a parametrised robot) and the gap diagnosis's ``ModelBench`` (a robot changed by candidate
effects) differ only in the robot they settle.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from rmbench.impact.measure import hammer_rows
from rmbench.impact.sensors import COORDS
from rmbench.robot.variant import with_tool_masses

__all__ = ["ModelModes", "modes_seen", "AsTested", "as_tested", "with_sensors"]

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


@dataclass(frozen=True)
class AsTested:
    """A model's complex modes at one posture in one band, with the rows a test reads them by.

    Attributes
    ----------
    cm : ComplexModes
        The operating point's modes (:meth:`~rmbench.robot.linear.LinearModel.modes`), or a
        perturbation of them.
    out : ndarray, shape (4, n_dof)
        The design's sensor readings (:meth:`~rmbench.impact.sensors.SensorSet.reading_rows`).
    inp : ndarray, shape (4, n_dof)
        Its hit points (:func:`~rmbench.impact.measure.hammer_rows`).
    band : Band
        The design's band (f_min, f_max in Hz, s_1a in m).
    """

    cm: object
    out: np.ndarray
    inp: np.ndarray
    band: object

    def modes(self, band_peak: float | None = None) -> ModelModes:
        """The modes a test of the band sees (:func:`modes_seen`)."""
        return modes_seen(self.cm, self.out, self.inp, self.band, band_peak)

    def frf(self, freq) -> np.ndarray:
        """Exact receptance as tested at ``freq`` (Hz), m/N, shape (n_freq, 4, 4)."""
        return self.cm.frf(np.asarray(freq, float), self.out, self.inp)

    def response(self, freq=None, band_peak: float | None = None) -> tuple:
        """:meth:`modes` and, with ``freq``, :meth:`frf` (None without)."""
        return self.modes(band_peak), (None if freq is None else self.frf(freq))

    def with_modes(self, cm) -> "AsTested":
        """The same test reading other modes ``cm`` of the same model (a perturbation's)."""
        return replace(self, cm=cm)


def with_sensors(robot, design, band: str):
    """``robot`` as tested in ``band``: the design's sensor masses on its tool (``robot`` itself
    where the band's sensors add none)."""
    masses = design.sensors(band).tool_masses()
    return with_tool_masses(robot, masses) if masses else robot


def as_tested(op, design, band: str, cm=None) -> AsTested:
    """The modes of operating point ``op`` (or ``cm``, a perturbation of them) as ``design``
    tests them in ``band``: read at its sensors, excited at its hit points."""
    b = design.band(band)
    return AsTested(op.linear.modes() if cm is None else cm, design.sensors(band).reading_rows(op),
                    hammer_rows(op, COORDS, b.s_1a), b)


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
