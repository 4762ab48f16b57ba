"""Figures of a diagnosis (they read the Diagnosis; nothing is recomputed).

matplotlib is imported only when a figure is drawn.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rmbench.plotting import axes_or_new

__all__ = ["plot_diagnosis", "plot_mode_gaps", "plot_workspace", "plot_effects", "plot_sources", "plot_pose_errors",
           "plot_location"]


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _axes(ax, figsize=(9, 4.5)):
    """``ax``, or the axes of a new figure on the user's own backend (a result's ``.plot()``)."""
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    return plt.subplots(figsize=figsize)[1]


def plot_mode_gaps(where, ax=None, *, title="frequency gap of each tracked mode"):
    """Model-minus-measured frequency (%) of each tracked mode against the posture."""
    ax = axes_or_new(ax, (9, 4.5))
    keys = sorted({(r["band"], r["mode"]) for r in where.records})
    for k, key in enumerate(keys):
        rs = [r for r in where.records if (r["band"], r["mode"]) == key and r["paired"]]
        if not rs:
            continue
        p = [r["posture"] for r in rs]
        df = [100 * r["df"] for r in rs]
        f = np.median([r["f_meas"] for r in rs])
        ax.plot(p, df, "o-" if len(p) < 40 else ".", ms=3, lw=0.7,
                label=f"{key[0]} {f:.4g} Hz", color=f"C{k % 10}")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("posture")
    ax.set_ylabel("f model / f measured − 1 (%)")
    ax.set_title(title)
    ax.legend(fontsize="x-small", ncol=2)
    return ax


def plot_workspace(where, path, *, title="gap over the workspace"):
    """rms z-score of each posture (both bands) on x, y; one panel per θ."""
    plt = _plt()
    per = {}
    for r in where.records:
        key = (r["posture"], r["x"], r["y"], r["theta"])
        per.setdefault(key, []).extend(r["z"].values())
    if not per:
        return None
    keys = list(per)
    thetas = sorted({round(k[3], 6) for k in keys})
    vals = {k: float(np.sqrt(np.mean(np.square(per[k])))) for k in keys}
    vmax = max(vals.values())
    n = len(thetas)
    cols = min(n, 4)
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols + 1.2, 3.2 * rows + 0.6), squeeze=False,
                             constrained_layout=True)
    sc = None
    for i, th in enumerate(thetas):
        ax = axes[i // cols][i % cols]
        ks = [k for k in keys if round(k[3], 6) == th]
        sc = ax.scatter([1e3 * k[1] for k in ks], [1e3 * k[2] for k in ks], c=[vals[k] for k in ks],
                        vmin=0, vmax=vmax, cmap="viridis", s=80)
        ax.set_title(f"θ = {np.degrees(th):.0f}°", fontsize="small")
        ax.margins(0.2)
        ax.set_xlabel("x (mm)", fontsize="small")
        ax.set_ylabel("y (mm)", fontsize="small")
    for j in range(n, rows * cols):
        axes[j // cols][j % cols].axis("off")
    fig.colorbar(sc, ax=axes, shrink=0.8, label="rms z of the modal gap")
    fig.suptitle(title)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def plot_effects(dg, ax=None):
    """Held-out shrink (with its bootstrap interval) and confidence of the ranked effects of an FRF
    diagnosis ``dg`` (a :class:`~rmbench.gap.frf.result.Diagnosis`); returns the Axes."""
    ax = _axes(ax)
    eff = list(dg.effects)[:10]
    y = np.arange(len(eff))[::-1]
    shrink = [100 * e.shrink for e in eff]
    lo = [100 * (e.shrink - e.shrink_interval[0]) for e in eff]
    hi = [100 * (e.shrink_interval[1] - e.shrink) for e in eff]
    ax.barh(y, shrink, xerr=[lo, hi], color=["C2" if e.chosen else "C0" for e in eff], alpha=0.8)
    for yi, e in zip(y, eff):
        ax.text(1, yi, f"{e.name}  (confidence {e.confidence:.2f})", va="center", fontsize="x-small")
    ax.set_yticks([])
    ax.set_xlabel("held-out shrink of the gap (%)")
    ax.set_xlim(0, 105)
    ax.set_title(f"verdict: {dg.verdict}")
    return ax


def _figure(path: Path, draw) -> Path:
    """One 9 x 4.5 in figure drawn by ``draw(ax)``, written to ``path``."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(9, 4.5))
    draw(ax)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def plot_diagnosis(dg, directory) -> list[Path]:
    """Write the diagnosis's figures into ``directory``; returns their paths."""
    d = Path(directory)
    out = []
    out.append(_figure(d / "gap_modes.png", lambda ax: plot_mode_gaps(
        dg.where, ax, title="nominal model: frequency gap of each tracked mode")))
    out.append(plot_workspace(dg.where, d / "gap_workspace.png",
                              title="nominal model: gap over the workspace"))
    if dg.where_after is not None:
        out.append(_figure(d / "gap_modes_after.png", lambda ax: plot_mode_gaps(
            dg.where_after, ax, title="updated model: frequency gap of each tracked mode")))
    if dg.effects:
        out.append(_figure(d / "effects.png", lambda ax: plot_effects(dg, ax)))
    located = (dg.form or {}).get("located")
    if located:
        out.append(plot_location(located, d / "form_location.png"))
    return [p for p in out if p is not None]


def plot_location(located: dict, path) -> Path:
    """Where a "model form" gap lies, drawn on the robot: its links at the zero posture seen from
    the side (x-z, m), the joint or link of each place shaded by the share of the held-out gap it
    removes; beside it the places ranked. ``located``:
    :meth:`rmbench.gap.frf.locate.Localisation.to_dict`."""
    plt = _plt()
    fig, (side, bars) = plt.subplots(1, 2, figsize=(10, 4.5), gridspec_kw={"width_ratios": [1, 1.3]})
    for x0, z0, x1, z1 in located.get("links", []):
        side.plot([x0, x1], [z0, z1], color="0.6", lw=3, solid_capstyle="round")
    places = located["places"][:6]
    best = max((p["shrink"] for p in places), default=0.0)
    for p in places[::-1]:
        share = max(p["shrink"], 0.0) / best if best > 0 else 0.0
        colour = plt.cm.Reds(0.25 + 0.75 * share)
        pts = np.asarray(p.get("at") or [], float).reshape(-1, 2)
        if len(pts) == 1:
            side.plot(pts[:, 0], pts[:, 1], "o", ms=9 + 10 * share, color=colour, mec="k")
        elif len(pts) == 2:
            side.plot(pts[:, 0], pts[:, 1], color=colour, lw=4 + 6 * share, solid_capstyle="round")
    top = places[0] if places else None
    found = top is not None and located.get("found")
    side.set_title(f"model form: localised at {top['where']}" if found else "model form: no single joint or link",
                   fontsize="medium")
    side.set_aspect("equal")
    side.set_xlabel("x (m)")
    side.set_ylabel("z (m)")
    y = np.arange(len(places))[::-1]
    bars.barh(y, [100 * p["shrink"] for p in places], color="C3", alpha=0.8)
    for yi, p in zip(y, places):
        bars.text(1, yi, f"{p['where']}: {p['acts_like'].split(' (')[0]}", va="center", fontsize="x-small")
    bars.set_yticks([])
    bars.set_xlabel("held-out gap removed (%)")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return Path(path)


def plot_sources(dg, ax=None, *, n: int = 8):
    """A tracker diagnosis ``dg`` (a :class:`~rmbench.gap.tracker.diagnosis.TrackerDiagnosis`):
    the held-out rms pose error with each of the ``n`` best-ranked sources (the chosen model for a
    chosen source, green, with its share of the error; the source alone otherwise, grey), against
    the nominal's and the chosen model's, each with its 95 % bootstrap interval (shaded), and the
    readings' noise. Returns the Axes."""
    ax = _axes(ax)
    shown = list(dg.sources[:n])
    y = np.arange(len(shown))
    ax.barh(y, [1e3 * s.heldout_after["rms"] for s in shown], color=["C2" if s.chosen else "C7" for s in shown])
    for yi, s in zip(y, shown):
        if s.chosen:
            ax.text(0, yi, f" {100 * s.share:.0f} % of the error", va="center", fontsize=7)
    for h, colour, name in ((dg.heldout_before, "C3", "nominal"), (dg.heldout_after, "C2", "chosen model")):
        rms = 1e3 * h["rms"]
        ax.axvline(rms, color=colour, lw=1, label=f"{name} {rms:.3f} mm")
        if h.get("rms_interval"):
            ax.axvspan(*(1e3 * np.asarray(h["rms_interval"])), color=colour, alpha=0.15)
    ax.axvline(1e3 * dg.where.noise_rms, color="k", lw=0.6, ls="--", label="noise")
    ax.set_yticks(y, [s.name for s in shown], fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel("held-out rms pose error (mm)")
    ax.set_title(f"{dg.verdict}: chosen (green), alone (grey)")
    ax.legend(fontsize=7)
    return ax


def plot_pose_errors(dg, path) -> Path:
    """A tracker diagnosis: the nominal pose error over each joint's angle and over the workspace,
    and the held-out rms and largest error before and after each ranked source."""
    plt = _plt()
    fig, (a0, a1, a2) = plt.subplots(1, 3, figsize=(15, 4.5))
    w = dg.where
    for k, (name, (edges, rms)) in enumerate((n, b) for n, b in w.bins.items() if not n.startswith("tcp_")):
        mid = 0.5 * (edges[1:] + edges[:-1])
        a0.plot(np.degrees(mid), 1e3 * rms, "o-", ms=3, label=name, color=f"C{k % 10}")
    a0.axhline(1e3 * w.noise_rms, color="k", lw=0.6, ls="--", label="noise")
    a0.set_xlabel("joint angle (deg)")
    a0.set_ylabel("rms pose error (mm)")
    a0.set_title("nominal model, by joint angle")
    a0.legend(fontsize=7)
    for k, axis in enumerate("xyz"):
        edges, rms = w.bins[f"tcp_{axis}"]
        mid = 0.5 * (edges[1:] + edges[:-1])
        a1.plot(1e3 * mid, 1e3 * rms, "o-", ms=3, label=f"TCP {axis}", color=f"C{k}")
    a1.axhline(1e3 * w.noise_rms, color="k", lw=0.6, ls="--")
    a1.set_xlabel("TCP position in the base frame (mm)")
    a1.set_ylabel("rms pose error (mm)")
    a1.set_title("nominal model, over the workspace")
    a1.legend(fontsize=7)
    plot_sources(dg, a2)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
