"""Report sections of the proof-mass suppressor: sensitivity curves of uncontrolled against
controlled runs, stroke and force use, time traces, and the controller's frequency response."""

from __future__ import annotations

import numpy as np

from rmbench.report.page import Page

__all__ = ["control_sections"]

_COLORS = {"uncontrolled": "#1f77b4", "controlled": "#d62728"}


def control_sections(page: Page, runs: dict | None = None, *, controller=None, traces: dict | None = None) -> None:
    """Add the suppressor's sections.

    Parameters
    ----------
    runs : dict of str to xarray.Dataset, optional
        ``{"uncontrolled": ds, "controlled": ds}`` as :func:`rmbench.control.sine_sweep` or
        :func:`~rmbench.control.eccentric_test` return them (``sensitivity`` (freq, axis),
        ``stroke_used``, ``force_max``, ``saturated`` per frequency).
    controller : Controller, optional
        Drawn as its frequency response from each measured input to each coil force, with its
        design record.
    traces : dict of str to LoopRecord, optional
        Time traces of closed-loop runs (acceleration, reaction-mass position, coil force).
    """
    if runs:
        _runs(page, runs)
    if traces:
        _traces(page, traces)
    if controller is not None:
        _controller(page, controller)


def _runs(page, runs) -> None:
    first = next(iter(runs.values()))
    axes = [str(a) for a in first.axis.values]
    sec = page.section("Sensitivity: uncontrolled against controlled",
                       "Steady-state acceleration per newton of disturbance at each excitation frequency, "
                       "closed loop in MuJoCo.")
    traces, lay = [], {"height": 320 * len(axes), "grid": {"rows": len(axes), "columns": 1, "pattern": "independent"}}
    for i, a in enumerate(axes):
        ax = "" if i == 0 else str(i + 1)
        for name, ds in runs.items():
            traces.append({"type": "scatter", "mode": "lines+markers", "x": ds.freq.values,
                           "y": np.abs(ds.sensitivity.sel(axis=a).values), "name": f"{name}, {a}",
                           "xaxis": f"x{ax}", "yaxis": f"y{ax}", "marker": {"size": 4},
                           "line": {"color": _COLORS.get(name)}})
        lay[f"yaxis{ax}"] = {"type": "log", "title": {"text": f"{a}: |a/F| (m/s²/N)"}}
        lay[f"xaxis{ax}"] = {"title": {"text": "frequency (Hz)"}}
    sec.figure({"data": traces, "layout": lay})
    use = []
    for name, ds in runs.items():
        if name == "uncontrolled":
            continue                          # no controller: no stroke or force to show
        for var, lab, ax in (("stroke_used", "stroke used (fraction of ±stroke)", ""),
                             ("force_max", "peak coil force (N)", "2"), ("saturated", "samples at the force limit", "3")):
            if var in ds:
                use.append({"type": "scatter", "mode": "lines+markers", "x": ds.freq.values, "y": ds[var].values,
                            "name": f"{name}: {lab}", "xaxis": f"x{ax}", "yaxis": f"y{ax}",
                            "line": {"color": _COLORS.get(name)}, "marker": {"size": 4}})
    sec.figure({"data": use, "layout": {
        "height": 620, "grid": {"rows": 3, "columns": 1, "pattern": "independent"},
        "yaxis": {"title": {"text": "stroke used"}}, "yaxis2": {"title": {"text": "peak force (N)"}},
        "yaxis3": {"title": {"text": "saturated"}}, "xaxis3": {"title": {"text": "frequency (Hz)"}},
        "legend": {"font": {"size": 9}}}})
    rows = [[name, float(np.nanmax(ds.stroke_used)) if "stroke_used" in ds else np.nan,
             float(np.nanmax(ds.force_max)) if "force_max" in ds else np.nan,
             int((~ds.ok.values).sum()) if "ok" in ds else 0] for name, ds in runs.items()]
    sec.table(["run", "largest stroke used", "peak force (N)", "failed runs"], rows)


def _traces(page, traces) -> None:
    sec = page.section("Time traces", "Acceleration at the accelerometer, reaction-mass position and "
                                      "coil force, one controller sample per point.")
    data = []
    for name, rec in traces.items():
        t = rec.t
        step = max(1, len(t) // 4000)             # at most ~4000 points a trace: the page stays light
        col = _COLORS.get(name)
        for j, a in enumerate(rec.axes):
            data.append({"type": "scatter", "mode": "lines", "x": t[::step], "y": rec.acc[::step, j],
                         "name": f"{name}: acceleration {a}", "line": {"color": col, "width": 1}})
        for j in range(rec.pos.shape[1]):
            data.append({"type": "scatter", "mode": "lines", "x": t[::step], "y": 1e3 * rec.pos[::step, j],
                         "name": f"{name}: mass position {j}", "xaxis": "x2", "yaxis": "y2",
                         "line": {"color": col, "width": 1}})
            data.append({"type": "scatter", "mode": "lines", "x": t[::step], "y": rec.force[::step, j],
                         "name": f"{name}: coil force {j}", "xaxis": "x3", "yaxis": "y3",
                         "line": {"color": col, "width": 1}})
    sec.figure({"data": data, "layout": {
        "height": 700, "grid": {"rows": 3, "columns": 1, "pattern": "independent"},
        "yaxis": {"title": {"text": "acceleration (m/s²)"}}, "yaxis2": {"title": {"text": "position (mm)"}},
        "yaxis3": {"title": {"text": "force (N)"}}, "xaxis3": {"title": {"text": "time (s)"}},
        "legend": {"font": {"size": 9}}}})


def _controller(page, k) -> None:
    meta = k.meta or {}
    sec = page.section(f"Controller: {', '.join(k.axes)}, order {k.order}",
                       "Frequency response of K(s) from each measured signal to each coil force.")
    modes = meta.get("mode_hz", [])
    f = np.logspace(np.log10(max(0.2, 0.1 * min(modes) if modes else 0.5)),
                    np.log10(max(200.0, 10 * max(modes) if modes else 200.0)), 600)
    H = k.frf(f)                                               # (freq, n, 2n)
    inputs = [f"acceleration {a} (N per m/s²)" for a in k.axes] + [f"mass position {a} (N/m)" for a in k.axes]
    data, palette = [], ("#1f77b4", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2")
    for o in range(H.shape[1]):
        for i in range(H.shape[2]):
            name = f"{inputs[i]} → force {k.axes[o]}"
            line = {"color": palette[(o * H.shape[2] + i) % len(palette)]}
            data.append({"type": "scatter", "mode": "lines", "x": f, "y": 20 * np.log10(np.abs(H[:, o, i]) + 1e-300),
                         "name": name, "legendgroup": name, "line": line})
            data.append({"type": "scatter", "mode": "lines", "x": f, "y": np.degrees(np.angle(H[:, o, i])),
                         "name": name, "legendgroup": name, "showlegend": False, "xaxis": "x2", "yaxis": "y2",
                         "line": line})
    shapes = [{"type": "line", "x0": m, "x1": m, "yref": "paper", "y0": 0, "y1": 1,
               "line": {"color": "#999", "dash": "dot"}} for m in modes]
    sec.figure({"data": data, "layout": {
        "height": 560, "grid": {"rows": 2, "columns": 1, "pattern": "independent"}, "shapes": shapes,
        "xaxis": {"type": "log"}, "xaxis2": {"type": "log", "title": {"text": "frequency (Hz)"}},
        "yaxis": {"title": {"text": "|K| (dB)"}}, "yaxis2": {"title": {"text": "phase (°)"}}}})
    if meta:
        import json

        sec.code(json.dumps(meta, indent=1, default=str), summary="design record")
