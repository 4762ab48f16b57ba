"""Figures of a modal fit: stabilisation diagram and measured vs fitted FRF matrix of one band
(:func:`plot_fit`, :func:`plot_stabilisation`), a campaign's natural frequencies over its postures
(:func:`plot_campaign_frequencies`).

matplotlib is imported only when a figure is drawn.
"""

from __future__ import annotations

import numpy as np
from rmbench.plotting import axes_or_new

__all__ = ["plot_fit", "plot_stabilisation", "plot_campaign_frequencies"]

COORDS = ("1X", "1Y", "1aX", "1aY")


def plot_fit(fit, freq, H, stabilization_path, frf_path) -> None:
    """Write the stabilisation diagram and the measured vs fitted 4x4 receptance of one band.

    Parameters
    ----------
    fit : ModalFit
        A fitted estimator.
    freq : ndarray, shape (n_freq,), Hz
    H : ndarray, shape (n_freq, 4, 4), complex, m/N
        The measured receptance the fit was made on.
    stabilization_path, frf_path : path-like
        PNG files to write.
    """
    plt = _plt()
    fig, ax = plt.subplots(figsize=(10, 6))
    plot_stabilisation(fit, ax, freq=freq, H=H)
    fig.tight_layout()
    fig.savefig(stabilization_path, dpi=90)
    plt.close(fig)

    model = fit.predict(freq)
    fig, axes = plt.subplots(8, 4, figsize=(15, 17), sharex=True)
    for i, o in enumerate(COORDS):
        for j, c in enumerate(COORDS):
            ax_m, ax_p = axes[2 * i, j], axes[2 * i + 1, j]
            ax_m.semilogy(freq, np.abs(H[:, i, j]), ".", ms=1.5, label="measured")
            ax_m.semilogy(freq, np.abs(model[:, i, j]), "-", lw=0.8, label="fitted")
            ax_p.plot(freq, np.degrees(np.angle(H[:, i, j])), ".", ms=1.5)
            ax_p.plot(freq, np.degrees(np.angle(model[:, i, j])), "-", lw=0.8)
            ax_m.set_title(f"{o} / {c}  NMSE {100 * fit.nmse_[i, j]:.2f} %", fontsize=8)
            for ax in (ax_m, ax_p):
                ax.tick_params(labelsize=6)
            ax_p.set_ylim(-190, 190)
    axes[0, 0].legend(fontsize=6)
    for ax in axes[-1]:
        ax.set_xlabel("frequency (Hz)", fontsize=8)
    fig.suptitle("Receptance (m/N) and phase (deg): measured vs MDOF fit")
    fig.tight_layout()
    fig.savefig(frf_path, dpi=90)
    plt.close(fig)


def plot_stabilisation(fit, ax=None, *, freq=None, H=None):
    """One band's stabilisation diagram with the fitted modes (dashed), titled with the verdict.

    Parameters
    ----------
    fit : ModalFit
        A fitted estimator.
    ax : matplotlib Axes, optional
        Where to draw (default: a new figure's).
    freq : ndarray, shape (n_freq,), Hz, optional
    H : ndarray, shape (n_freq, 4, 4), complex, m/N, optional
        The measured receptance, drawn under the diagram as the sum of its magnitudes.

    Returns
    -------
    matplotlib Axes
    """
    ax = axes_or_new(ax, (10, 6))
    fit.stabilization_.plot(ax, freq=freq, H=H)
    # the fitted modes: the diagram's clusters after the information criterion merged, added or
    # removed poles
    for i, f in enumerate(fit.f_n_):
        ax.axvline(f, color="C2", ls="--", lw=1.0, label="fitted mode" if i == 0 else None)
    ax.legend(loc="upper left", fontsize="small")
    verdict = "fit ok" if fit.fit_ok_ else "needs a look"
    ax.set_title(f"Stabilisation diagram: {fit.n_modes_} modes at "
                 f"{', '.join(f'{f:.2f}' for f in fit.f_n_)} Hz ({verdict})")
    return ax


def plot_campaign_frequencies(modal, *, ax=None):
    """A campaign's fitted natural frequencies (Hz, log scale) against the posture index, one
    series per tracked mode; postures where a band fit needs a look are shaded.

    Parameters
    ----------
    modal : xarray.Dataset
        :func:`~rmbench.modal.campaign_fit.fit_campaign`'s dataset.
    ax : matplotlib Axes, optional
        Where to draw (:func:`rmbench.plotting.axes_or_new`); returned.
    """
    ax = axes_or_new(ax, (8, 4.5))
    f = modal["modal"].sel(param="f_n").values          # (posture, mode), Hz
    posture = np.arange(f.shape[0])
    for m in range(f.shape[1]):
        ax.plot(posture, f[:, m], ".-", ms=3, lw=0.6, label=f"mode {m} ({modal.mode_band.values[m]})")
    for p in np.flatnonzero(~np.asarray(modal.fit_ok.values, bool).all(axis=1)):
        ax.axvspan(p - 0.5, p + 0.5, color="0.9", zorder=0)
    ax.set_yscale("log")
    ax.set_xlabel("posture")
    ax.set_ylabel("natural frequency (Hz)")
    ax.set_title("Fitted modes over the postures (shaded: a band fit needs a look)")
    if f.shape[1] <= 20:
        ax.legend(fontsize="x-small", ncol=2)
    return ax


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
