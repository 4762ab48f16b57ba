"""Figures of RCSA predictions (matplotlib, imported only when a figure is drawn)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot_tool_change", "plot_support"]


def _save(fig, path) -> Path:
    import matplotlib.pyplot as plt

    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_tool_change(result, path, reference: dict | None = None) -> Path:
    """Predicted against simulated target-tool tip FRFs: the four tip entries, one column per band.

    Parameters
    ----------
    result : CampaignToolChange
    path : str or Path
        Output image.
    reference : dict of str to ndarray, optional
        Per band, the reference tool's measured full tip receptance (n_freq, 4, 4), drawn thin.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from rmbench.rcsa.tool_change import TIP_ENTRIES

    bands = list(result.bands)
    fig, axes = plt.subplots(4, len(bands), figsize=(5.5 * len(bands), 10), squeeze=False, sharex="col")
    for c, band in enumerate(bands):
        tc = result.bands[band]
        for r, ((i, j), label) in enumerate(TIP_ENTRIES):
            ax = axes[r, c]
            if reference is not None and band in reference:
                ax.semilogy(tc.freq, np.abs(reference[band][:, i, j]), color="0.6", lw=0.8,
                            label=f"reference tool ({tc.reference.name}), measured")
            if band in result.truth:
                ax.semilogy(tc.freq, np.abs(result.truth[band][:, i, j]), "k", lw=1.6,
                            label=f"{tc.target.name}, simulated (truth)")
            ax.semilogy(tc.freq, np.abs(tc.t[:, i, j]), "C3--", lw=1.2, label=f"{tc.target.name}, RCSA")
            ax.set_ylabel(f"|H {label}| (m/N)")
            if r == 0:
                ax.set_title(f"{band} band")
            if r == 3:
                ax.set_xlabel("frequency (Hz)")
    axes[0, 0].legend(fontsize=8)
    x, y, t = result.posture_mm_deg
    fig.suptitle(f"Tool change at ({x:.0f} mm, {y:.0f} mm, {t:.0f}°), {result.method} rotations, "
                 f"contact {result.contact_source}")
    return _save(fig, path)


def plot_support(study, path) -> Path:
    """Part alone, robot alone, the simulated assembly and RCSA, and the misplaced-sensor case."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    f = study.freq
    fig, (a, b) = plt.subplots(2, 1, figsize=(9, 8), sharex=True)
    a.semilogy(f, np.abs(study.h_part), color="0.6", lw=1, label="part alone (simulated)")
    a.semilogy(f, np.abs(study.h_robot), "C0", lw=1, label="robot alone, ball X (simulated)")
    a.semilogy(f, np.abs(study.g_sim), "k", lw=1.8, label="assembly (simulated, truth)")
    a.semilogy(f, np.abs(study.g_rcsa), "C3--", lw=1.2, label=f"RCSA Eq. 6, K_x {study.k_x:.3g} N/m")
    a.semilogy(f, np.abs(study.g_rcsa_rigid), "C2:", lw=1.2, label="RCSA Eq. 6, rigid joint")
    a.set_ylabel("|H| at the coupling point (m/N)")
    a.legend(fontsize=8)
    b.semilogy(f, np.abs(study.g_sim_s), "k", lw=1.8, label="assembly at the sensor (simulated)")
    b.semilogy(f, np.abs(study.g_offset), "C1--", lw=1.2,
               label=f"Eq. 6 fed the sensor {1e3 * study.sensor_offset:.0f} mm off the joint")
    b.semilogy(f, np.abs(study.g_rcsa_s), "C3:", lw=1.2, label="Eqs. 12-14, sensor as its own coordinate")
    for fm in study.part_modes[:2]:
        for ax in (a, b):
            ax.axvline(fm, color="0.8", lw=0.8, zorder=0)
    b.set_ylabel("|H| at the sensor (m/N)")
    b.set_xlabel("frequency (Hz)")
    b.legend(fontsize=8)
    fig.suptitle(f"Robot-supported plate: preload {study.preload:.0f} N, contact "
                 f"{1e3 * study.contact:.0f} mm from the left clamp")
    return _save(fig, path)
