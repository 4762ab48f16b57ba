"""Figure of a path plan (matplotlib, imported only when a figure is drawn)."""

from __future__ import annotations

import numpy as np
from rmbench.plotting import axes_or_new

__all__ = ["plot_plan"]


def plot_plan(plan, ax=None):
    """Critical depth (mm) against arc length (mm) along the planned and the fixed-θ schedules, the
    planned one's band shaded where computed and the depth to be cut as a horizontal line.

    Parameters
    ----------
    plan : PathPlan
    ax : matplotlib Axes, optional
        Where to draw (:func:`rmbench.plotting.axes_or_new`); returned.
    """
    ax = axes_or_new(ax, (8, 3.5))
    s = 1e3 * plan.toolpath.arc_length()

    def mm(a):
        return 1e3 * np.where(np.isfinite(a), a, np.nan)

    if plan.band is not None:
        ax.fill_between(s, mm(plan.band.lower), mm(plan.band.upper), color="C0", alpha=0.25,
                        label=f"planned, {100 * plan.band_level:g} % band")
    ax.plot(s, mm(plan.planned.margin), color="C0", label="planned")
    ax.plot(s, mm(plan.fixed.margin), color="C1", lw=1.0,
            label=f"fixed θ = {np.degrees(plan.fixed.theta[0]):g}°")
    if plan.depth is not None:
        ax.axhline(1e3 * plan.depth, color="k", ls="--", lw=0.8, label="depth cut")
    ax.set_xlabel("arc length (mm)")
    ax.set_ylabel("critical depth of cut (mm)")
    ax.set_ylim(bottom=0)
    ax.set_title(f"{plan.speed_rpm:g} rev/min")
    ax.legend(fontsize=8)
    return ax
