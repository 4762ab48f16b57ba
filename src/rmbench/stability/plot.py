"""Figures of stability lobes (matplotlib, imported only when a figure is drawn)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rmbench.plotting import axes_or_new

__all__ = ["plot_lobes", "draw_lobes"]


def plot_lobes(diagrams: dict, path, *, title: str = "", points=None) -> Path:
    """Critical depth against spindle speed for each named diagram; optional milling points.

    Parameters
    ----------
    diagrams : dict of str to Lobes
    points : tuple (speed_rpm, depth_m, chatter bool), optional
        Virtual milling results drawn as stable (o) and chatter (x) markers.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.5))
    draw_lobes(diagrams, ax, title=title, points=points)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def draw_lobes(diagrams: dict, ax=None, *, title: str = "", points=None):
    """Critical depth (mm) against spindle speed (rev/min) for each named diagram on ``ax`` (the
    one named ``"envelope"`` bold black), with optional milling points.

    Parameters
    ----------
    diagrams : dict of str to Lobes
    ax : matplotlib Axes, optional
        Where to draw (default: a new figure's).
    points : tuple (speed_rpm, depth_m, chatter bool), optional
        Virtual milling results drawn as stable (o) and chatter (x) markers.

    Returns
    -------
    matplotlib Axes
    """
    ax = axes_or_new(ax, (8, 4.5))
    for k, (name, d) in enumerate(diagrams.items()):
        a = np.where(np.isfinite(d.a_lim), d.a_lim, np.nan)
        ax.plot(d.speed_rpm, 1e3 * a, color="k" if name == "envelope" else f"C{k}",
                lw=2 if name == "envelope" else 1.2, label=f"{name} ({d.method})")
    if points is not None:
        s, dep, chat = (np.asarray(v) for v in points)
        ax.plot(s[~chat], 1e3 * dep[~chat], "o", mfc="none", color="C2", label="milled: stable")
        ax.plot(s[chat], 1e3 * dep[chat], "x", color="C3", label="milled: chatter")
    ax.set_xlabel("spindle speed (rev/min)")
    ax.set_ylabel("critical depth of cut (mm)")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=8)
    ax.set_title(title)
    return ax
