"""Figures of campaign data (matplotlib is imported when a figure is drawn)."""

from __future__ import annotations

import numpy as np
from rmbench.plotting import axes_or_new

__all__ = ["plot_frf_matrix", "plot_campaign_summary"]


def plot_frf_matrix(ds, index: int, path, *, band: str | None = None) -> None:
    """Measured vs exact 4x4 receptance of one posture: magnitude, phase and coherence.

    Parameters
    ----------
    ds : xarray.Dataset
        Campaign dataset (DATA.md layout); ``H_exact`` is drawn where present.
    index : int
        Posture position in the dataset.
    band : str, optional
        ``"low"`` or ``"high"``; both when None (one figure row per response).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    p = ds.isel(posture=index)
    if band is not None:
        p = p.sel(freq=p.band == band)
    freq = p.freq.values
    labels = list(p.out.values)
    fig, axes = plt.subplots(8, 4, figsize=(15, 17), sharex=True)
    for i, o in enumerate(labels):
        for j, c in enumerate(labels):
            h = p.H.values[:, i, j]
            ax_m, ax_p = axes[2 * i, j], axes[2 * i + 1, j]
            ax_m.semilogy(freq, np.abs(h), ".", ms=1.5, label="measured (H1)")
            if "H_exact" in p:
                he = p.H_exact.values[:, i, j]
                ax_m.semilogy(freq, np.abs(he), "-", lw=0.8, label="exact as tested")
                ax_p.plot(freq, np.degrees(np.angle(he)), "-", lw=0.8)
            ax_p.plot(freq, np.degrees(np.angle(h)), ".", ms=1.5)
            ax_c = ax_m.twinx()
            ax_c.plot(freq, p.coherence.values[:, i, j], color="0.6", lw=0.5)
            ax_c.set_ylim(0, 1.05)
            ax_c.tick_params(labelsize=6)
            ax_m.set_title(f"{o} / {c}", fontsize=8)
            ax_m.tick_params(labelsize=6)
            ax_p.tick_params(labelsize=6)
            ax_p.set_ylim(-190, 190)
    axes[0, 0].legend(fontsize=6)
    for ax in axes[-1]:
        ax.set_xlabel("frequency (Hz)", fontsize=8)
    x, y, t = float(p.x) * 1e3, float(p.y) * 1e3, np.degrees(float(p.theta))
    fig.suptitle(f"Receptance (m/N) and phase (deg), posture {x:g}, {y:g} mm, {t:g} deg; grey: coherence")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_campaign_summary(summary, ax=None):
    """Wall time per posture of a campaign run (s), bars of the measured postures in blue and of
    the failed ones in red.

    Parameters
    ----------
    summary : CampaignSummary
    ax : matplotlib Axes, optional
        Where to draw (:func:`rmbench.plotting.axes_or_new`); returned.
    """
    ax = axes_or_new(ax, (7, 3))
    index = np.arange(summary.n_postures)
    ok = np.asarray(summary.ok, bool)
    ax.bar(index[ok], summary.seconds[ok], color="tab:blue", label="measured")
    if not ok.all():
        ax.bar(index[~ok], summary.seconds[~ok], color="tab:red", label="failed")
    ax.set_xlabel("posture")
    ax.set_ylabel("wall time (s)")
    ax.set_title(f"{summary.n_ok} of {summary.n_postures} postures measured, {summary.steps_total} steps")
    ax.legend(fontsize=8)
    return ax
