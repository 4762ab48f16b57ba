"""Figure of a calibration's estimates (matplotlib, imported only when a figure is drawn)."""

from __future__ import annotations

import numpy as np
from rmbench.plotting import axes_or_new

__all__ = ["plot_estimates"]

_STYLE = {"identifiable": dict(color="C0", mfc="C0", label="identifiable"),
          "weak": dict(color="C1", mfc="none", label="weakly identifiable"),
          "not identifiable": dict(color="0.55", mfc="none", label="not identifiable")}


def plot_estimates(params, ax=None):
    """Each parameter's estimate and 95 % interval over its nominal, one row a parameter, the
    identifiable ones filled; a line at 1 (the nominal).

    A parameter whose nominal is zero (an offset, a rigid foundation's compliance) has no ratio: it
    is left out of the axes and named with its value in a note below them.

    Parameters
    ----------
    params : sequence of ParameterEstimate
        A calibration's estimates (:attr:`Calibration.params`).
    ax : matplotlib Axes, optional
        Where to draw (:func:`rmbench.plotting.axes_or_new`); returned.
    """
    ax = axes_or_new(ax, (7, 0.3 * len(params) + 1.5))
    drawn = [p for p in params if p.nominal != 0]
    ratio = np.array([p.value / p.nominal for p in drawn]).reshape(-1)
    ends = np.array([sorted((p.interval[0] / p.nominal, p.interval[1] / p.nominal)) for p in drawn]).reshape(-1, 2)
    rows = np.arange(len(drawn))[::-1]          # the first parameter at the top
    for kind, style in _STYLE.items():
        pick = np.array([p.identifiability == kind for p in drawn], bool)
        if pick.any():
            ax.errorbar(ratio[pick], rows[pick], xerr=np.abs(ends[pick] - ratio[pick, None]).T, fmt="o",
                        capsize=2, ms=5, **style)
    ax.axvline(1.0, color="k", lw=0.8)
    if len(drawn) and np.all(ends > 0) and ends.max() > 3 * ends.min():
        # a log factor's interval is symmetric on a log axis; ticks at powers of two
        from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

        ax.set_xscale("log")
        ax.xaxis.set_major_locator(LogLocator(base=2))
        ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
        ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_yticks(rows, [p.name for p in drawn], fontsize="small")
    ax.set_xlabel("estimate / nominal (95 % interval)")
    left = [p for p in params if p.nominal == 0]
    if left:
        ax.annotate("nominal 0: " + "; ".join(f"{p.name} {p.value:.3g} [{p.interval[0]:.3g}, {p.interval[1]:.3g}]"
                                              f" {p.unit}" for p in left),
                    xy=(0, 0), xycoords="axes fraction", xytext=(0, -32), textcoords="offset points",
                    fontsize="x-small", va="top")
    if len(drawn):
        ax.legend(loc="best", fontsize="small")
    return ax
