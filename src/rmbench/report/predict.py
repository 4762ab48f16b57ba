"""Report sections of posture prediction: parameter maps over the workspace with their standard
deviation, and cross-validation (out-of-fold scatter, residuals, learners compared)."""

from __future__ import annotations

import warnings

import numpy as np

from rmbench.report.page import Page, arr

__all__ = ["predictor_sections", "cv_sections"]


def predictor_sections(page: Page, pred, *, thetas_deg=None, n: int = 31) -> None:
    """Predicted modal parameters (mean and standard deviation) over x, y at each θ, with the
    training postures; mode, parameter and θ pickers.

    Parameters
    ----------
    pred : PosturePredictor
        A fitted (or loaded) predictor.
    thetas_deg : sequence of float, optional
        Redundant angles of the maps (default: those of the training postures, at most 7).
    n : int
        Grid lines along x and along y.
    """
    X = pred.X_train_
    if thetas_deg is None:
        th = np.unique(np.round(np.degrees(X[:, 2]), 1))
        thetas_deg = th if len(th) <= 7 else th[np.linspace(0, len(th) - 1, 7).round().astype(int)]
    xs = np.linspace(X[:, 0].min(), X[:, 0].max(), n)
    ys = np.linspace(X[:, 1].min(), X[:, 1].max(), n)
    gx, gy = np.meshgrid(xs, ys)
    P = np.concatenate([np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, np.radians(t))])
                        for t in thetas_deg])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")           # the box's corners lie outside the training hull
        out = pred.predict(P)
    params = [p for p in ("f_n", "zeta") if p in out.param.values]
    scale = {"f_n": 1.0, "zeta": 100.0}
    nt, nm = len(thetas_deg), out.sizes["mode"]
    mean = np.stack([out.modal.sel(param=p).values * scale[p] for p in params])       # (param, P, mode)
    std = np.stack([out.modal_std.sel(param=p).values * scale[p] for p in params])
    shape = (len(params), nt, n * n, nm)
    data = {"x": 1e3 * xs, "y": 1e3 * ys, "thetas": [float(t) for t in thetas_deg],
            "params": [{"f_n": "f_n (Hz)", "zeta": "ζ (%)"}[p] for p in params],
            "modes": [f"mode {int(m)} ({b})" for m, b in zip(out.mode.values, out.mode_band.values)],
            "n": n, "n_mode": nm, "mean": arr(mean.reshape(shape)), "std": arr(std.reshape(shape)),
            "train": {"x": 1e3 * X[:, 0], "y": 1e3 * X[:, 1], "theta": np.round(np.degrees(X[:, 2]), 1).tolist()}}
    sec = page.section(f"Predicted modal parameters ({pred.model})",
                       f"Trained on {len(X)} postures ({len(pred.live_)} parameters) in "
                       f"{pred.train_seconds_:.1f} s. Mean (left) and standard deviation (right) of the "
                       "prediction over x, y at the chosen θ; dots: training postures at that θ.")
    sec.widget(_MAP_MARKUP, data, _MAP_JS)


def cv_sections(page: Page, ts, cvs) -> None:
    """Cross-validation of one or more learners on the same training set.

    Parameters
    ----------
    ts : TrainingSet
    cvs : sequence of CVScores
        With out-of-fold ``predictions``.
    """
    sec = page.section("Cross-validation",
                       "Out-of-fold predictions against the fitted values (each posture predicted by the "
                       "model that did not see it), normalised by the mode's mean; residuals per posture; "
                       "R² per parameter (accuracy) and its spread over folds (robustness).")
    kinds = [k for k in ("f_n", "zeta") if any(t.endswith(f":{k}") for t in ts.tasks)]
    rows, traces_cmp = [], []
    for cv in cvs:
        ok = np.isfinite(cv.r2_mean)
        rows.append([cv.learner, cv.split, int(ok.sum()), float(np.mean(cv.r2_mean[ok])) if ok.any() else np.nan,
                     float(np.median(cv.r2_mean[ok])) if ok.any() else np.nan,
                     float(np.mean(cv.r2_std[ok])) if ok.any() else np.nan, len(cv.skipped)])
        traces_cmp.append({"type": "box", "y": cv.r2_mean[ok], "name": f"{cv.learner} ({cv.split})",
                           "boxpoints": "all", "jitter": 0.4, "pointpos": 0, "marker": {"size": 3}})
    sec.table(["learner", "split", "parameters scored", "mean R²", "median R²", "mean R² spread (std)",
               "skipped"], rows)
    if len(cvs) > 0:
        sec.figure({"data": traces_cmp, "layout": {"height": 380, "showlegend": False,
                                                   "yaxis": {"title": {"text": "R² per parameter"}}}})
    for cv in cvs:
        traces, lay = [], {"height": 700, "grid": {"rows": 2, "columns": len(kinds), "pattern": "independent"},
                           "title": {"text": f"{cv.learner}, {cv.split} split"}, "showlegend": True,
                           "legend": {"font": {"size": 9}}}
        for c, k in enumerate(kinds):
            top, bot = ("" if c == 0 else str(c + 1)), str(len(kinds) + c + 1)
            lo, hi = np.inf, -np.inf
            for j, t in enumerate(ts.tasks):
                if not t.endswith(f":{k}"):
                    continue
                y, p = ts.Y[:, j], cv.predictions[:, j] if cv.predictions is not None else np.full(len(ts.Y), np.nan)
                ok = np.isfinite(y) & np.isfinite(p)
                if not ok.any():
                    continue
                s = np.abs(y[ok]).mean()
                a, b = y[ok] / s, p[ok] / s
                lo, hi = min(lo, a.min(), b.min()), max(hi, a.max(), b.max())
                name = f"{t.split(':')[0]} {k} (R² {cv.r2_mean[j]:.3f})"
                traces.append({"type": "scatter", "mode": "markers", "x": a, "y": b, "name": name,
                               "legendgroup": t, "xaxis": f"x{top}", "yaxis": f"y{top}", "marker": {"size": 5}})
                traces.append({"type": "scatter", "mode": "markers", "x": np.flatnonzero(ok).astype(float),
                               "y": 100 * (b - a), "name": name, "legendgroup": t, "showlegend": False,
                               "xaxis": f"x{bot}", "yaxis": f"y{bot}", "marker": {"size": 4}})
            if np.isfinite(lo):
                traces.append({"type": "scatter", "mode": "lines", "x": [lo, hi], "y": [lo, hi], "showlegend": False,
                               "xaxis": f"x{top}", "yaxis": f"y{top}", "line": {"color": "black", "width": 1}})
            lay[f"xaxis{top}"] = {"title": {"text": f"fitted {k} / mode mean"}}
            lay[f"yaxis{top}"] = {"title": {"text": f"predicted {k} / mode mean"}}
            lay[f"xaxis{bot}"] = {"title": {"text": "posture"}}
            lay[f"yaxis{bot}"] = {"title": {"text": "residual (% of mode mean)"}}
        sec.figure({"data": traces, "layout": lay})


_MAP_MARKUP = """
<div class="rm-controls">mode <select id="ID-mode"></select> parameter <select id="ID-param"></select>
θ <select id="ID-theta"></select></div><div id="ID-map" class="rm-dyn" style="min-height:420px"></div>
"""

_MAP_JS = r"""
var $ = function (s) { return document.getElementById(ID + '-' + s); };
var mean = rm.decode(DATA.mean), std = rm.decode(DATA.std), n = DATA.n, M = DATA.n_mode, T = DATA.thetas.length;
var x = Array.from(rm.decode(DATA.x)), y = Array.from(rm.decode(DATA.y));
var tx = rm.decode(DATA.train.x), ty = rm.decode(DATA.train.y);
DATA.modes.forEach(function (l, i) { $('mode').add(new Option(l, i)); });
DATA.params.forEach(function (l, i) { $('param').add(new Option(l, i)); });
DATA.thetas.forEach(function (t, i) { $('theta').add(new Option(t + '°', i)); });
function grid(a, p, t, m) {
  var z = [];
  for (var r = 0; r < n; r++) { var row = [];
    for (var c = 0; c < n; c++) { var v = a[((p * T + t) * n * n + r * n + c) * M + m]; row.push(isNaN(v) ? null : v); }
    z.push(row); }
  return z;
}
function draw() {
  var m = +$('mode').value, p = +$('param').value, t = +$('theta').value, th = DATA.thetas[t], px = [], py = [];
  for (var i = 0; i < tx.length; i++) if (DATA.train.theta[i] === th) { px.push(tx[i]); py.push(ty[i]); }
  var lab = DATA.params[p];
  var tr = [{type: 'heatmap', x: x, y: y, z: grid(mean, p, t, m), colorscale: 'Viridis', colorbar: {x: 0.45, title: {text: lab}}},
            {type: 'heatmap', x: x, y: y, z: grid(std, p, t, m), colorscale: 'Magma', xaxis: 'x2', yaxis: 'y2',
             colorbar: {title: {text: 'std'}}},
            {type: 'scatter', mode: 'markers', x: px, y: py, marker: {color: 'white', size: 7, line: {color: 'black', width: 1}},
             name: 'trained', showlegend: false},
            {type: 'scatter', mode: 'markers', x: px, y: py, xaxis: 'x2', yaxis: 'y2',
             marker: {color: 'white', size: 7, line: {color: 'black', width: 1}}, showlegend: false}];
  var lay = {height: 420, grid: {rows: 1, columns: 2, pattern: 'independent'},
             title: {text: DATA.modes[m] + ', ' + lab + ' at θ = ' + th + '°', font: {size: 13}},
             xaxis: {title: {text: 'x (mm)'}}, yaxis: {title: {text: 'y (mm)'}}, xaxis2: {title: {text: 'x (mm)'}}};
  return rm.plot($('map'), tr, lay);
}
['mode', 'param', 'theta'].forEach(function (s) { $(s).addEventListener('change', draw); });
return draw();
"""
