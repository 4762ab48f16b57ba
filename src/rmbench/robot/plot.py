"""Figures of the exact ground truth (matplotlib is imported when a figure is drawn)."""

from __future__ import annotations

import numpy as np

__all__ = ["plot_tip_frfs"]


def plot_tip_frfs(curves, path, *, title: str = "Exact tool-tip receptance") -> None:
    """Magnitude and phase of the tool-tip FRFs ``1X/1X``, ``1Y/1Y`` and ``1X/1Y``.

    Parameters
    ----------
    curves : sequence of (label, freq, frf)
        ``freq`` in Hz, shape (n,); ``frf`` in m/N, shape (n, 4, 4) in coordinates 1X, 1Y, 1aX, 1aY.
    path : str or Path
        PNG file to write.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    entries = (((0, 0), "H 1X/1X"), ((1, 1), "H 1Y/1Y"), ((0, 1), "H 1X/1Y"))
    fig, axes = plt.subplots(2, 3, figsize=(13, 6.5), sharex="col")
    for label, freq, h in curves:
        for col, ((i, j), name) in enumerate(entries):
            axes[0, col].semilogy(freq, np.abs(h[:, i, j]), label=label, lw=1)
            axes[1, col].plot(freq, np.degrees(np.angle(h[:, i, j])), lw=1)
            axes[0, col].set_title(name)
    for ax in axes[0]:
        ax.set_ylabel("|H| (m/N)")
        ax.grid(True, which="both", alpha=0.3)
    for ax in axes[1]:
        ax.set_ylabel("phase (deg)")
        ax.set_xlabel("frequency (Hz)")
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
