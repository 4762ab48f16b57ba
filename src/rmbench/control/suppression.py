"""A suppression test as the seed ran it: the same test uncontrolled and then controlled, and the
reduction of each controlled mode (seed Figs. 9 and 12; ``rmbench control run``).

:func:`suppression_test` chooses what the seed's figures need: the frequencies (a coarse grid from
2 Hz, dense across the modes the controller was designed for), the disturbed axis (the controller's
first for a sine sweep, every controlled axis the eccentric mass shakes) and the mode each axis's
reduction is read at (the design's, else the uncontrolled peak). Frequencies in Hz, forces in N,
sensitivities in m/s²/N.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from rmbench.control.controller import Controller
from rmbench.control.experiments import eccentric_test, excitation_frequencies, reduction_at, sine_sweep
from rmbench.errors import InputError
from rmbench.plotting import axes_or_new

__all__ = ["SUPPRESSION_TESTS", "SuppressionTest", "suppression_test", "suppression_frequencies"]

SUPPRESSION_TESTS = ("sweep", "eccentric")
"""``sweep``: a sine on one axis's disturbance coil; ``eccentric``: the spindle's eccentric mass."""


@dataclass(frozen=True)
class SuppressionTest:
    """One test run uncontrolled and controlled, and the reduction at each controlled axis's mode.

    Attributes
    ----------
    test : str
        ``"sweep"`` or ``"eccentric"`` (:data:`SUPPRESSION_TESTS`).
    uncontrolled, controlled : xarray.Dataset
        The runs as :func:`~rmbench.control.experiments.sine_sweep` or
        :func:`~rmbench.control.experiments.eccentric_test` return them (``sensitivity`` over
        (freq, axis), m/s²/N; per-frequency stroke, force and failure columns).
    axes : tuple of str
        The axes the reductions are read on.
    mode_hz : tuple of float
        Each axis's mode, Hz.
    reduction : tuple of float
        Each axis's reduction, ``1 − controlled peak / uncontrolled peak`` of |sensitivity| near its
        mode (:func:`~rmbench.control.experiments.reduction_at`).
    """

    test: str
    uncontrolled: xr.Dataset
    controlled: xr.Dataset
    axes: tuple[str, ...]
    mode_hz: tuple[float, ...]
    reduction: tuple[float, ...]

    def __post_init__(self):
        if self.test not in SUPPRESSION_TESTS:
            raise InputError(f"unknown suppression test {self.test!r}; use {', '.join(SUPPRESSION_TESTS)}")
        if not len(self.axes) == len(self.mode_hz) == len(self.reduction):
            raise InputError(f"{len(self.axes)} axes, {len(self.mode_hz)} modes and {len(self.reduction)} "
                             "reductions: one each per axis")

    @property
    def runs(self) -> dict:
        """``{"uncontrolled": Dataset, "controlled": Dataset}``, as the plots and report take them."""
        return {"uncontrolled": self.uncontrolled, "controlled": self.controlled}

    def effort(self) -> dict:
        """The controlled runs' use of the suppressor: the largest stroke used (fraction of ±stroke),
        peak force (N) and fraction of samples saturated over the frequencies (NaN where every run
        failed), and the counts of failed runs and of runs that hit an end stop."""
        c = self.controlled
        return {"stroke_used_max": float(np.nanmax(c.stroke_used)), "force_max": float(np.nanmax(c.force_max)),
                "saturated_max": float(np.nanmax(c.saturated)), "failed_runs": int((~c.ok.values).sum()),
                "end_stop_runs": int((c.end_stop.values > 0).sum())}

    def to_dict(self) -> dict:
        """Test name, each axis's mode (Hz) and reduction (fraction), and :meth:`effort`, as strict JSON
        values (NaN as None); the ``rmbench control run --json`` record."""
        from rmbench.io.strict_json import jsonable

        return jsonable({"test": self.test,
                         "axes": {a: {"mode_hz": f, "reduction": r}
                                  for a, f, r in zip(self.axes, self.mode_hz, self.reduction)},
                         **self.effort()})

    def summary(self) -> str:
        """Each axis's reduction (%) at its mode (Hz), then the stroke (% of ±stroke) and peak force
        (N) the controller used and the runs at an end stop or failed."""
        e = self.effort()
        lines = [f"{a}: reduction {100 * r:.1f} % at the {f:.2f} Hz mode"
                 for a, f, r in zip(self.axes, self.mode_hz, self.reduction)]
        lines.append(f"stroke used {100 * e['stroke_used_max']:.0f} % of ±stroke, peak force "
                     f"{e['force_max']:.1f} N, runs at an end stop {e['end_stop_runs']}, failed runs "
                     f"{e['failed_runs']}")
        return "\n".join(lines)

    def to_dataset(self) -> xr.Dataset:
        """Both runs on a ``case`` dimension (``uncontrolled``, ``controlled``), without the
        failure texts (netCDF-ready)."""
        both = xr.concat([self.uncontrolled.drop_vars("reason"), self.controlled.drop_vars("reason")], dim="case")
        return both.assign_coords(case=["uncontrolled", "controlled"])

    def plot(self, ax=None):
        """|sensitivity| over frequency, uncontrolled and controlled, for each of :attr:`axes`, each
        mode marked.

        Drawn on ``ax`` or a new figure's Axes (:func:`rmbench.plotting.axes_or_new`), which it
        returns.
        """
        ax = axes_or_new(ax, (7, 3.5))
        for name, ds in self.runs.items():
            for a in self.axes:
                f = ds.freq.values
                ax.semilogy(f, np.abs(ds.sensitivity.sel(axis=a).values), ".-" if len(f) < 200 else "-",
                            label=f"{a}, {name}")
        for f0 in self.mode_hz:
            ax.axvline(f0, color="0.6", lw=0.8, ls=":")
        ax.set_xlabel("frequency, Hz")
        ax.set_ylabel("acceleration sensitivity, m/s²/N")
        ax.set_title(f"{self.test}: " + ", ".join(f"{a} {100 * r:.1f} %" for a, r in zip(self.axes, self.reduction)))
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        return ax


def suppression_frequencies(op, controller: Controller, test: str = "sweep") -> np.ndarray:
    """The test's default frequencies, Hz: 1 Hz steps from 2 Hz to 30 Hz (sweep) or 20 Hz (eccentric
    mass), and a fine grid across each mode the controller was designed for (``meta["mode_hz"]``),
    its damping that of ``op``'s nearest linear mode (:func:`~rmbench.control.experiments.excitation_frequencies`)."""
    _check_test(test)
    modes = op.linear.modes()
    near = [(f, float(modes.zeta[np.argmin(np.abs(modes.f_n - f))])) for f in controller.meta.get("mode_hz", [])]
    return excitation_frequencies(near, 2.0, 20.0 if test == "eccentric" else 30.0)


def suppression_test(op, controller: Controller, test: str = "sweep", freqs=None, *, axis: str | None = None,
                     amplitude: float = 20.0, workers: int | None = None, scheduler: str | None = None,
                     progress: bool = False) -> SuppressionTest:
    """Run ``test`` at ``op`` uncontrolled and with ``controller``; the reduction at each axis's mode.

    Parameters
    ----------
    op : OperatingPoint
    controller : Controller
    test : str
        ``"sweep"``: a sine of ``amplitude`` N on ``axis``'s disturbance coil (default the
        controller's first axis); ``"eccentric"``: the eccentric mass, every controlled axis read.
    freqs : array_like, optional
        Excitation frequencies or spindle speeds, Hz (default :func:`suppression_frequencies`).
    workers, scheduler, progress
        As :func:`~rmbench.control.experiments.sine_sweep` takes them.

    Returns
    -------
    SuppressionTest
        The reduction is read at the controller's design mode of each axis (``meta["mode_hz"]``),
        else at the uncontrolled run's peak.
    """
    _check_test(test)
    freqs = suppression_frequencies(op, controller, test) if freqs is None else np.asarray(freqs, float)
    kw = dict(workers=workers, scheduler=scheduler, progress=progress)
    if test == "sweep":
        axis = axis or controller.axes[0]
        if axis not in controller.axes:
            raise InputError(f"axis {axis!r}: the controller drives {', '.join(controller.axes)}")
        open_ = sine_sweep(op, None, axis, freqs, amplitude=amplitude, **kw)
        closed = sine_sweep(op, controller, axis, freqs, amplitude=amplitude, **kw)
        axes = (axis,)
    else:
        open_ = eccentric_test(op, None, freqs, **kw)
        closed = eccentric_test(op, controller, freqs, **kw)
        axes = tuple(str(a) for a in closed.axis.values if a in controller.axes)
    mode_hz = controller.meta.get("mode_hz", [])
    modes = tuple(mode_hz[list(controller.axes).index(a)] if mode_hz
                  else float(freqs[np.argmax(np.abs(open_.sensitivity.sel(axis=a)))]) for a in axes)
    return SuppressionTest(test, open_, closed, axes, modes,
                           tuple(reduction_at(open_, closed, a, f0) for a, f0 in zip(axes, modes)))


def _check_test(test: str) -> None:
    if test not in SUPPRESSION_TESTS:
        raise InputError(f"unknown suppression test {test!r}; use {', '.join(SUPPRESSION_TESTS)}")
