"""Figures of the invalidation results (matplotlib is imported when a figure is drawn, Agg backend).

* :func:`plot_invalidation`: measured error per location, re-measured locations marked (seed Fig. 7);
* :func:`plot_accuracy_vs_noise`: identified accuracy of every method against noise (seed Fig. 4);
* :func:`plot_accuracy_vs_measurements`: identified accuracy against the number of measurements
  (seed Fig. 5).

Each returns the matplotlib figure and writes a PNG when given a path.
"""

from __future__ import annotations

import numpy as np

__all__ = ["plot_invalidation", "plot_accuracy_vs_noise", "plot_accuracy_vs_measurements"]

_LABELS = {"largest_error": "Largest Error", "outlier_rejection": "Outlier Rejection",
           "mean_error": "Mean Error", "model_invalidation": "Model Invalidation"}


def plot_invalidation(result, path=None, *, scale: float = 1.0, unit: str = ""):
    """Error magnitude of every measurement per location, in the order explored (seed Fig. 7).

    Parameters
    ----------
    result : InvalidationResult
    path : str or Path, optional
        PNG to write.
    scale : float
        Factor applied to errors for display (1e3: m to mm).
    unit : str
        Unit label of the scaled errors.
    """
    plt = _pyplot()
    mag = np.abs(result.measurements) if result.measurements.ndim == 1 else \
        np.linalg.norm(result.measurements, axis=1)
    order = list(dict.fromkeys(result.index.tolist()))  # locations in the order first measured
    rank = {j: k + 1 for k, j in enumerate(order)}
    x = np.array([rank[j] for j in result.index])
    again = np.isin(result.index, result.remeasured)
    fig, ax = plt.subplots(figsize=(9, 4.5))
    ax.plot(x[~again], scale * mag[~again], "o", ms=4, color="tab:blue", label="measured once")
    ax.plot(x[again], scale * mag[again], "x", ms=7, color="tab:red", label="re-measured location")
    mean = np.linalg.norm(result.mean[order], axis=1)
    ax.plot(np.arange(1, len(order) + 1), scale * mean, "_", ms=12, color="k", label="location mean")
    ax.axhline(scale * result.eta, color="tab:green", lw=1.5,
               label=f"η = {scale * result.eta:.4g} {unit}".rstrip())
    ax.set_xlabel("location (order explored)")
    ax.set_ylabel(f"error magnitude{' (' + unit + ')' if unit else ''}")
    ax.set_title(f"Invalidation test: {result.verdict}, P* = {result.p_star:.3f} (α = {result.alpha}), "
                 f"{result.n_measurements} measurements")
    ax.legend(fontsize=8, loc="best")
    return _finish(fig, path)


def plot_accuracy_vs_noise(table, path=None):
    """Identified accuracy (mean over seeds) of each method against the noise level (seed Fig. 4).

    Parameters
    ----------
    table : rmbench.tracker.benchmark.Table1
    path : str or Path, optional
    """
    plt = _pyplot()
    mean = table.mean()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for m in mean.estimator.values:
        ax.plot(mean.noise, mean.sel(estimator=m), "o-", ms=3, label=_LABELS.get(str(m), str(m)))
    ax.axhline(table.true_accuracy, color="k", ls="--", lw=1, label="true accuracy")
    ax.set_xlabel("measurement noise σ")
    ax.set_ylabel("identified accuracy")
    ax.set_title(f"Identified accuracy vs noise (mean of {table.accuracy.sizes['seed']} seeds)")
    ax.legend(fontsize=8)
    return _finish(fig, path)


def plot_accuracy_vs_measurements(accuracy, path=None, *, true_accuracy: float | None = None):
    """Identified accuracy against the number of measurements allowed (seed Fig. 5).

    Parameters
    ----------
    accuracy : xarray.DataArray, dims (estimator, budget, seed)
        From :func:`rmbench.tracker.benchmark.accuracy_vs_measurements`.
    path : str or Path, optional
    true_accuracy : float, optional
        Drawn as a reference line.
    """
    plt = _pyplot()
    mean = accuracy.mean("seed")
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for m in mean.estimator.values:
        ax.plot(mean.budget, mean.sel(estimator=m), "o-", ms=3, label=_LABELS.get(str(m), str(m)))
    if true_accuracy is not None:
        ax.axhline(true_accuracy, color="k", ls="--", lw=1, label="true accuracy")
    ax.set_xlabel("number of measurements")
    ax.set_ylabel("identified accuracy")
    noise = accuracy.attrs.get("noise")
    ax.set_title("Identified accuracy vs measurements" + (f" (noise σ = {noise:g})" if noise else ""))
    ax.legend(fontsize=8)
    return _finish(fig, path)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _finish(fig, path):
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig
