"""Figures of the posture predictors (matplotlib, imported only when a figure is drawn).

* :func:`plot_cv` — out-of-fold predicted against fitted natural frequencies and damping ratios per
  mode, and the residuals, like the seed's Figs. 16-21;
* :func:`plot_maps` — a predicted parameter over the workspace (x, y) at each redundant angle;
* :func:`plot_postures` — a predictor's training postures over the workspace.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rmbench.plotting import axes_or_new

__all__ = ["plot_cv", "plot_maps", "plot_postures"]


def plot_postures(X, *, ax=None, title: str = ""):
    """Postures ``X`` (n, 3: x, y in m, θ in rad) as points over x, y (mm), coloured by θ (degrees).

    Draws on ``ax`` (default: a new figure's) and returns it.
    """
    ax = axes_or_new(ax, (5, 4))
    X = np.asarray(X, float)
    pts = ax.scatter(1e3 * X[:, 0], 1e3 * X[:, 1], c=np.degrees(X[:, 2]), s=12, cmap="viridis")
    ax.figure.colorbar(pts, ax=ax, label="θ (°)")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(title)
    return ax


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_cv(ts, cv, path, params=("f_n", "zeta")) -> Path:
    """Predicted (out of fold) against fitted values, one panel per parameter kind, and residuals.

    Parameters
    ----------
    ts : TrainingSet
    cv : CVScores
        With ``predictions`` (out-of-fold).
    """
    plt = _plt()
    fig, axes = plt.subplots(2, len(params), figsize=(5.5 * len(params), 8), squeeze=False)
    for c, prm in enumerate(params):
        cols = [j for j, t in enumerate(ts.tasks) if t.endswith(f":{prm}")]
        ax, res = axes[0, c], axes[1, c]
        for j in cols:
            y, p = ts.Y[:, j], cv.predictions[:, j]
            ok = np.isfinite(y) & np.isfinite(p)
            if not ok.any():
                continue
            scale = np.abs(y[ok]).mean()
            label = f"{ts.tasks[j].split(':')[0]} (R² {cv.r2_mean[j]:.3f})"
            ax.plot(y[ok] / scale, p[ok] / scale, ".", ms=4, label=label)
            res.plot(np.flatnonzero(ok), 100 * (p[ok] - y[ok]) / scale, ".", ms=4)
        lim = ax.get_xlim()
        ax.plot(lim, lim, "k-", lw=0.8)
        ax.set_xlabel(f"fitted {prm} / mean of its mode")
        ax.set_ylabel(f"predicted {prm} / mean of its mode")
        ax.set_title(f"{cv.learner}, {cv.split} split: {prm}")
        ax.legend(fontsize=7, ncol=2)
        res.axhline(0, color="k", lw=0.8)
        res.set_xlabel("posture")
        res.set_ylabel("residual, % of the mode's mean")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def plot_maps(predictor, path, *, mode: int = 0, param: str = "f_n", thetas_deg=(-60, 0, 60),
              n: int = 41) -> Path:
    """A predicted parameter (and its standard deviation as contours) over x, y per θ."""
    plt = _plt()
    X = predictor.X_train_
    xs = np.linspace(X[:, 0].min(), X[:, 0].max(), n)
    ys = np.linspace(X[:, 1].min(), X[:, 1].max(), n)
    gx, gy = np.meshgrid(xs, ys)
    fig, axes = plt.subplots(1, len(thetas_deg), figsize=(4.6 * len(thetas_deg), 4), squeeze=False)
    k = list(predictor.modes_).index(mode)
    for ax, th in zip(axes[0], thetas_deg):
        P = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, np.radians(th))])
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")          # edges of the box are on the hull
            out = predictor.predict(P)
        v = out.modal.sel(param=param).values[:, k].reshape(gx.shape)
        s = out.modal_std.sel(param=param).values[:, k].reshape(gx.shape)
        im = ax.pcolormesh(1e3 * gx, 1e3 * gy, v, shading="auto")
        if np.all(np.isfinite(s)) and np.ptp(s) > 0:
            cs = ax.contour(1e3 * gx, 1e3 * gy, s, colors="w", linewidths=0.7)
            ax.clabel(cs, fontsize=6)
        ax.plot(1e3 * X[:, 0], 1e3 * X[:, 1], "k.", ms=3)
        ax.set_title(f"mode {mode} {param}, θ = {th:g}° (contours: std)")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        fig.colorbar(im, ax=ax)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
