"""Where a plot is drawn: the caller's matplotlib Axes, or a new figure's.

Every result's ``plot(ax=None)`` and every ``plot_*`` function of the stages draws on what
:func:`axes_or_new` returns and returns it, so a figure of several panels is composed by passing each
panel's Axes, and a quick look needs none. matplotlib is imported only when a figure is made.
"""

from __future__ import annotations

__all__ = ["axes_or_new"]


def axes_or_new(ax=None, figsize: tuple[float, float] | None = None):
    """``ax`` itself, or the Axes of a new figure ``figsize`` (width, height) inches in size
    (matplotlib's default size where None) when ``ax`` is None."""
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    return plt.subplots(figsize=figsize)[1]
