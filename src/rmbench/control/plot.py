"""Figures of the suppression tests (seed Figs. 7, 9, 12 analogues). Plotting only."""

from __future__ import annotations

import numpy as np

__all__ = ["plot_sensitivity"]


def plot_sensitivity(curves: dict, path, *, title: str = "", ylabel: str = "acceleration sensitivity, m/s²/N"):
    """Write |sensitivity| curves, one panel per axis.

    Parameters
    ----------
    curves : dict
        ``{label: xarray.Dataset}`` with ``sensitivity`` (freq, axis), as the experiments return,
        or ``{label: (freq, {axis: complex array})}`` for linear predictions.
    path : str or Path
        PNG file.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def series(obj):
        if isinstance(obj, tuple):
            return obj
        return obj.freq.values, {str(a): obj.sensitivity.sel(axis=a).values for a in obj.axis.values}

    data = {k: series(v) for k, v in curves.items()}
    axes = list(next(iter(data.values()))[1])
    fig, ax = plt.subplots(len(axes), 1, figsize=(7, 3.2 * len(axes)), squeeze=False)
    for i, a in enumerate(axes):
        for label, (f, s) in data.items():
            if a in s:
                ax[i, 0].semilogy(f, np.abs(s[a]), ".-" if len(f) < 200 else "-", label=label)
        ax[i, 0].set_title(f"{a}")
        ax[i, 0].set_xlabel("frequency, Hz")
        ax[i, 0].set_ylabel(ylabel)
        ax[i, 0].grid(True, which="both", alpha=0.3)
        ax[i, 0].legend(fontsize=8)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
