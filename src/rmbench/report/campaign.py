"""Report sections of an impact campaign and of its modal fit.

The FRF matrix of every posture travels in the page compactly (log magnitude in 0.01 dB and phase
in 0.01° as 16-bit integers, coherence as 8-bit, each spectrum as differences along frequency,
gzip-compressed); the page draws one posture at a time when the picker changes, so a 112-posture campaign opens as fast as a one-posture one. Fitted FRFs
are rebuilt in the page from the modes (Eq. 15), a few numbers per mode instead of a matrix.
"""

from __future__ import annotations

import json

import numpy as np

from rmbench.report.page import Page, arr, label, packed

__all__ = ["campaign_sections", "modal_sections", "stabilisation_section", "dataset_meta", "posture_labels"]

COORDS = ("1X", "1Y", "1aX", "1aY")
_NAN_I2 = -32768
_NAN_U1 = 255


def posture_labels(ds) -> list[str]:
    """``"i: (x mm, y mm, θ°)"`` per posture, flagged where the posture failed."""
    out = []
    for i in range(ds.sizes["posture"]):
        x, y, t = (float(ds[c].values[i]) for c in ("x", "y", "theta"))
        bad = "ok" in ds.coords and not bool(ds.ok.values[i])
        out.append(f"{i}: ({1e3 * x:.0f}, {1e3 * y:.0f}, {np.degrees(t):.0f}°)" + (" FAILED" if bad else ""))
    return out


def dataset_meta(ds, path=None) -> dict:
    """Run metadata from a dataset's attributes (config, versions, seed, timings)."""
    a = ds.attrs
    meta = {}
    if path is not None:
        meta["file"] = str(path)
    for k in ("kind", "created", "rmbench_version", "robot", "tool", "seed", "method", "table_z",
              "sensor_spacing_low", "sensor_spacing_high", "receptance_from", "upstream", "fit_seconds"):
        if k in a and str(a[k]) != "":
            meta[k] = a[k]
    if "seconds" in ds:
        s = ds.seconds.values
        meta["simulation time"] = f"{np.nansum(s):.1f} s over {len(s)} postures ({np.nanmean(s):.1f} s each)"
    if "software" in a:
        try:
            meta["software"] = json.loads(a["software"])
        except (TypeError, ValueError):
            meta["software"] = str(a["software"])
    if "config" in a and str(a["config"]):
        meta["config"] = str(a["config"])
    return meta


def _db(h) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.round(100 * 20 * np.log10(np.abs(h)))
    bad = ~np.isfinite(d)
    d = np.clip(np.where(bad, 0, d), -32767, 32767)       # ±327 dB: any receptance fits
    d[bad] = _NAN_I2                                        # the marker after the clip
    return d.astype(np.int16)


def check_campaign(ds) -> None:
    """One-line errors for a dataset that lacks what a campaign report reads (DATA.md names)."""
    from rmbench.errors import InputError

    for name in ("posture", "freq", "out", "inp"):
        if name not in ds.dims:
            raise InputError(f"not a campaign dataset: no {name!r} dimension")
    for name in ("x", "y", "theta"):
        if name not in ds.coords and name not in ds:
            raise InputError(f"not a campaign dataset: no posture coordinate {name!r}")
    missing = [c for c in COORDS if c not in ds.out.values or c not in ds.inp.values]
    if missing:
        raise InputError(f"the FRF matrix lacks the coordinates {', '.join(missing)} (needs {', '.join(COORDS)})")


def _deg(h) -> np.ndarray:
    d = np.round(100 * np.degrees(np.angle(h)))
    d[~np.isfinite(h)] = _NAN_I2
    return d.astype(np.int16)


def _fit_modes(fit, n_posture: int) -> dict | None:
    """Poles and mode vectors of a modal fit, flattened (posture, mode, 18) for the page."""
    if fit is None:
        return None
    from rmbench.modal.campaign_fit import mode_vectors

    prm = fit.modal.values
    rows = np.full((n_posture, fit.sizes["mode"], 18), np.nan)
    for p in range(min(n_posture, fit.sizes["posture"])):
        for m in range(fit.sizes["mode"]):
            f, z = prm[p, m, :2]
            if not (np.isfinite(f) and np.isfinite(z)):
                continue
            r, l = mode_vectors(fit, p, m)
            wn = 2 * np.pi * f
            lam = -z * wn + 1j * wn * np.sqrt(1 - z**2)
            rows[p, m] = np.concatenate([[lam.real, lam.imag], np.column_stack([r.real, r.imag]).ravel(),
                                         np.column_stack([l.real, l.imag]).ravel()])
    return {"modes": fit.sizes["mode"], "data": arr(rows, "f8")}


def campaign_sections(page: Page, ds, *, fit=None, start: int = 0) -> None:
    """Add the FRF matrix (posture and band pickers; measured, exact and fitted), the accuracy
    against ground truth where the data carry it, and the posture table.

    Parameters
    ----------
    page : Page
    ds : xarray.Dataset
        A campaign (DATA.md): ``H`` and optionally ``H_exact``, ``coherence``.
    fit : xarray.Dataset, optional
        Its modal fit, drawn as the fitted FRFs (Eq. 15 from the fitted modes).
    start : int
        Posture the picker shows first.
    """
    check_campaign(ds)
    n_p = ds.sizes["posture"]

    def matrix(name):                  # (posture, freq, out, inp) in COORDS order
        return ds[name].transpose("posture", "freq", "out", "inp").sel(out=list(COORDS), inp=list(COORDS)).values

    H = matrix("H")
    n_f = ds.sizes["freq"]

    def spectra(a, dtype="i2"):             # (posture, freq, out, inp) -> rows of (posture, out, inp)
        return packed(np.moveaxis(a, 1, -1), dtype, row=n_f)

    data = {"labels": posture_labels(ds), "n_posture": n_p, "n_freq": n_f, "start": int(start),
            "freq": arr(ds.freq.values), "coords": list(COORDS), "mag": spectra(_db(H)),
            "phase": spectra(_deg(H)), "bands": {}}
    band = ds.band.values if "band" in ds.coords else np.array(["all"] * ds.sizes["freq"])
    for b in dict.fromkeys(band):
        idx = np.flatnonzero(band == b)
        data["bands"][str(b)] = [int(idx[0]), int(idx[-1]) + 1]
    if "H_exact" in ds:
        data["mag_exact"] = spectra(_db(matrix("H_exact")))
    if "coherence" in ds:
        c = matrix("coherence")
        q = np.round(250 * np.clip(c, 0, 1))
        q[~np.isfinite(c)] = _NAN_U1
        data["coh"] = spectra(q.astype(np.uint8), "u1")
    data["fit"] = _fit_modes(fit, n_p)
    sec = page.section("FRF matrix",
                       "Receptance |H| of the 4 x 4 matrix (rows: response, columns: hammer) per posture "
                       "and band: measured" + (", exact (the simulator's linearisation, as tested)"
                                               if "H_exact" in ds else "")
                       + (", fitted (rebuilt from the fitted modes)" if fit is not None else "")
                       + ". Pick an entry for its phase and coherence.")
    sec.widget(_FRF_MARKUP, data, _FRF_JS)
    if "H_exact" in ds:
        _accuracy(page, ds, H, matrix("H_exact"), band)
    rows = []
    for i in range(n_p):
        r = [i, f"{1e3 * float(ds.x.values[i]):.1f}", f"{1e3 * float(ds.y.values[i]):.1f}",
             f"{np.degrees(float(ds.theta.values[i])):.1f}",
             "yes" if "ok" not in ds.coords or bool(ds.ok.values[i]) else "no",
             str(ds.reason.values[i]) if "reason" in ds.coords else ""]
        if "seconds" in ds:
            r.append(float(ds.seconds.values[i]))
        rows.append(r)
    cols = ["posture", "x (mm)", "y (mm)", "θ (°)", "ok", "reason"] + (["seconds"] if "seconds" in ds else [])
    page.section("Postures").table(cols, rows)


def _accuracy(page, ds, H, He, band) -> None:
    """Measured against exact: a workspace map of the error per θ and its spread per entry."""
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.abs(np.abs(H) / np.abs(He) - 1)
    sec = page.section("Accuracy against ground truth",
                       "|measured / exact − 1| of the magnitude per posture: median over all lines and "
                       "entries, and at each entry's largest exact peak per band.")
    n = len(rel)
    med, peak = np.full(n, np.nan), np.full(n, np.nan)
    for i in range(n):                                   # a failed posture has no FRF: NaN stays
        r = rel[i].ravel()
        if np.isfinite(r).any():
            med[i] = np.nanmedian(r)
        for b in dict.fromkeys(band):
            a = np.abs(He[i, band == b]).reshape(-1, 16)
            ok = np.isfinite(a).all(axis=0) & np.isfinite(rel[i, band == b].reshape(-1, 16)).all(axis=0)
            if ok.any() and len(a):
                k = np.argmax(a[:, ok], axis=0)             # each entry's largest exact peak
                at = rel[i, band == b].reshape(-1, 16)[:, ok][k, np.arange(ok.sum())]
                peak[i] = np.fmax(peak[i], at.max())
    if not np.isfinite(med).any():
        sec.text("No posture has both measured and exact FRFs.")
        return
    x, y, th = 1e3 * ds.x.values, 1e3 * ds.y.values, np.round(np.degrees(ds.theta.values), 1)
    thetas = sorted(set(th.tolist()))
    traces, lay = [], {"grid": {"rows": 1, "columns": len(thetas), "pattern": "independent"},
                       "annotations": [], "height": 340, "showlegend": False}
    for j, t in enumerate(thetas):
        s = th == t
        ax = "" if j == 0 else str(j + 1)
        traces.append({"type": "scatter", "mode": "markers", "x": x[s], "y": y[s], "xaxis": f"x{ax}",
                       "yaxis": f"y{ax}", "marker": {"size": 11, "color": 100 * med[s], "colorscale": "Viridis",
                                                     "cmin": 0, "cmax": float(np.nanmax(100 * med)) or 1.0,
                                                     "showscale": j == len(thetas) - 1,
                                                     "colorbar": {"title": {"text": "median %"}}},
                       "text": [f"posture {i}" for i in np.flatnonzero(s)],
                       "hovertemplate": "%{text}<br>x %{x:.0f} mm, y %{y:.0f} mm<br>%{marker.color:.3f} %<extra></extra>"})
        lay[f"xaxis{ax}"] = {"title": {"text": f"x (mm), θ = {t:g}°"}}
    lay["yaxis"] = {"title": {"text": "y (mm)"}}
    sec.figure({"data": traces, "layout": lay})
    sec.figure({"data": [{"type": "bar", "x": list(range(len(med))), "y": 100 * med, "name": "median"},
                         {"type": "scatter", "mode": "markers", "x": list(range(len(med))), "y": 100 * peak,
                          "name": "worst entry at its peak"}],
                "layout": {"height": 300, "xaxis": {"title": {"text": "posture"}},
                           "yaxis": {"title": {"text": "|measured/exact − 1| (%)"}, "type": "log"}}})
    sec.text(f"Over all postures: median {100 * np.nanmedian(med):.3f} %, worst posture median "
             f"{100 * np.nanmax(med):.3f} %, worst entry at its peak {100 * np.nanmax(peak):.3f} %.")


def modal_sections(page: Page, fit, ds=None, *, stab_posture: int = 0) -> None:
    """Add the modal parameters over the workspace (mode and parameter pickers), a table of the
    tracked modes with their errors against ground truth where known, and the stabilisation
    diagram of one posture (when the campaign ``ds`` is given: the fit is repeated there).
    """
    prm = fit.modal.values
    n_p, n_m = prm.shape[:2]
    band = fit.mode_band.values if "mode_band" in fit.coords else np.array([""] * n_m)
    fields = {"f_n": ("f_n (Hz)", prm[:, :, 0]), "zeta": ("ζ (%)", 100 * prm[:, :, 1])}
    if "f_err" in fit:
        fields["f_err"] = ("f error vs exact (%)", 100 * fit.f_err.values)
        fields["zeta_err"] = ("ζ error vs exact (%)", 100 * fit.zeta_err.values)
    if "mac_phiR" in fit:
        fields["mac_phiR"] = ("MAC φR vs exact", fit.mac_phiR.values)
    data = {"x": 1e3 * fit.x.values, "y": 1e3 * fit.y.values,
            "theta": np.round(np.degrees(fit.theta.values), 1).tolist(),
            "modes": [f"mode {int(m)} ({b})" for m, b in zip(fit.mode.values, band)],
            "fields": {k: {"label": lab, "v": arr(v)} for k, (lab, v) in fields.items()},
            "n_mode": n_m}
    sec = page.section("Modal parameters over the workspace",
                       "Each fitted mode's parameters at the tested postures (x, y per redundant angle θ)"
                       + (", and their errors against the exact modes" if "f_err" in fit else "") + ".")
    sec.widget(_MAP_MARKUP, data, _MAP_JS)
    rows = []
    for m in range(n_m):
        f = prm[:, m, 0]
        row = [int(fit.mode.values[m]), str(band[m]), int(np.isfinite(f).sum()), np.nanmean(f) if np.isfinite(f).any() else np.nan,
               np.nanmin(f) if np.isfinite(f).any() else np.nan, np.nanmax(f) if np.isfinite(f).any() else np.nan,
               100 * np.nanmean(prm[:, m, 1]) if np.isfinite(f).any() else np.nan]
        if "f_err" in fit:
            e = np.abs(fit.f_err.values[:, m])
            row += [100 * np.nanmax(e) if np.isfinite(e).any() else np.nan,
                    100 * np.nanmax(np.abs(fit.zeta_err.values[:, m])) if np.isfinite(e).any() else np.nan]
        rows.append(row)
    cols = ["mode", "band", "found at", "mean f_n (Hz)", "min f_n", "max f_n", "mean ζ (%)"]
    if "f_err" in fit:
        cols += ["max |f error| (%)", "max |ζ error| (%)"]
    sec.table(cols, rows, caption=f"{n_p} postures; a mode missing at a posture was not found there.")
    if "fit_ok" in fit:
        bad = [(p, str(b), str(fit.fit_reason.values[p, i])) for p in range(n_p)
               for i, b in enumerate(fit.fit_band.values) if not bool(fit.fit_ok.values[p, i])]
        if bad:
            page.section("Fits that need a look").table(["posture", "band", "reason"], bad)
    if ds is not None:
        stabilisation_section(page, ds, stab_posture)


def stabilisation_section(page: Page, ds, p: int) -> None:
    """The stabilisation diagram of each band of posture ``p`` (the band is refitted here); a
    failed posture gives way to the first one that was measured, a band that cannot be fitted
    to a note."""
    import warnings

    from rmbench.errors import RmbenchError
    from rmbench.modal import ModalFit, ModalFitWarning

    measured = [i for i in range(ds.sizes["posture"]) if np.isfinite(ds.H.values[i]).any()]
    if not measured:
        page.section("Stabilisation diagrams").text("No posture of the campaign has a measured FRF.")
        return
    if p not in measured:
        p = measured[0]
    band_of = ds.band.values if "band" in ds.coords else np.array(["all"] * ds.sizes["freq"])
    ds = ds.assign_coords(band=("freq", band_of))

    sec = page.section(f"Stabilisation diagrams, posture {posture_labels(ds)[p]}",
                       "Poles of the pLSCF estimator at each model order (grey: not stable, blue: stable "
                       "in frequency, damping and participation, red: counted for a selected mode) over "
                       "Σ|H| of the band.")
    for b in dict.fromkeys(ds.band.values):
        sel = ds.band.values == b
        dims = ("posture", "freq", "out", "inp")
        freq, h = ds.freq.values[sel], ds.H.transpose(*dims).values[p][sel]
        coh = ds.coherence.transpose(*dims).values[p][sel] if "coherence" in ds else None
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ModalFitWarning)
                mf = ModalFit().fit(freq, h, coherence=coh)
        except (RmbenchError, ValueError, np.linalg.LinAlgError) as err:
            sec.text(f"{b} band: no stabilisation diagram ({err}).")
            continue
        st = mf.stabilization_
        f, o = st.freq, st.order
        groups = [("pole", ~st.stable, {"symbol": "circle-open", "color": "#999", "size": 5}),
                  ("stable", st.stable & (st.cluster < 0), {"symbol": "cross-thin-open", "color": "#1f77b4", "size": 7}),
                  ("selected cluster", st.cluster >= 0, {"symbol": "x-thin-open", "color": "#d62728", "size": 7})]
        traces = [{"type": "scatter", "mode": "markers", "x": f[s], "y": o[s].astype(float), "name": n,
                   "marker": {**mk, "line": {"width": 1.5, "color": mk["color"]}}} for n, s, mk in groups]
        traces.append({"type": "scatter", "mode": "lines", "x": freq, "y": np.abs(h).sum(axis=(1, 2)),
                       "yaxis": "y2", "name": "Σ|H|", "line": {"color": "black", "width": 1}})
        shapes = [{"type": "line", "x0": v, "x1": v, "yref": "paper", "y0": 0, "y1": 1,
                   "line": {"color": "#2ca02c", "dash": "dash", "width": 1}} for v in mf.f_n_]
        sec.figure({"data": traces, "layout": {
            "height": 380, "title": {"text": f"{label(b)} band: {mf.n_modes_} modes at "
                                             + ", ".join(f"{v:.2f}" for v in mf.f_n_) + " Hz"},
            "xaxis": {"title": {"text": "frequency (Hz)"}}, "yaxis": {"title": {"text": "model order"}},
            "yaxis2": {"overlaying": "y", "side": "right", "type": "log", "title": {"text": "Σ|H| (m/N)"}},
            "shapes": shapes, "legend": {"orientation": "h", "y": -0.2}}})


_FRF_MARKUP = """
<div class="rm-controls">posture <select id="ID-posture"></select>
band <select id="ID-band"></select> entry <select id="ID-entry"></select></div>
<div id="ID-matrix" class="rm-dyn" style="min-height:760px"></div>
<div id="ID-detail" class="rm-dyn" style="min-height:520px"></div>
"""

_FRF_JS = r"""
var F = DATA.n_freq, C = DATA.coords, freq = rm.decode(DATA.freq);
var mag = rm.decode(DATA.mag), ph = rm.decode(DATA.phase);
var ex = DATA.mag_exact ? rm.decode(DATA.mag_exact) : null, coh = DATA.coh ? rm.decode(DATA.coh) : null;
var fit = DATA.fit ? rm.decode(DATA.fit.data) : null, M = DATA.fit ? DATA.fit.modes : 0;
var $ = function (s) { return document.getElementById(ID + '-' + s); };
DATA.labels.forEach(function (l, i) { $('posture').add(new Option(l, i)); });
$('posture').value = DATA.start;
Object.keys(DATA.bands).forEach(function (b) { $('band').add(new Option(b, b)); });
C.forEach(function (o, i) { C.forEach(function (c, j) { $('entry').add(new Option(o + ' / ' + c, 4 * i + j)); }); });
function col(a, p, r, k, scale, nan) {
  var out = new Array(r[1] - r[0]);
  var o = (p * 16 + k) * F;
  for (var f = r[0]; f < r[1]; f++) { var v = a[o + f]; out[f - r[0]] = v === nan ? null : v * scale; }
  return out;
}
function synth(p, r, k) {          // Eq. 15 from the fitted poles and vectors of posture p
  var o = k >> 2, i = k & 3, mg = [], pa = [];
  for (var f = r[0]; f < r[1]; f++) {
    var w = 2 * Math.PI * freq[f], re = 0, im = 0, any = false;
    for (var m = 0; m < M; m++) {
      var b = (p * M + m) * 18; if (isNaN(fit[b])) continue; any = true;
      var lr = fit[b], li = fit[b + 1];
      var rr = fit[b + 2 + 2 * o], ri = fit[b + 3 + 2 * o], qr = fit[b + 10 + 2 * i], qi = fit[b + 11 + 2 * i];
      var nr = rr * qr - ri * qi, ni = rr * qi + ri * qr;          // phiR phiL
      var dr = -lr, d1 = w - li, d2 = w + li, a1 = dr * dr + d1 * d1, a2 = dr * dr + d2 * d2;
      // n / (iw - lam) + conj(n) / (iw - conj(lam))
      re += (nr * dr + ni * d1) / a1 + (nr * dr - ni * d2) / a2;
      im += (ni * dr - nr * d1) / a1 + (-ni * dr - nr * d2) / a2;
    }
    mg.push(any ? 20 * Math.log10(Math.hypot(re, im)) : null); pa.push(any ? Math.atan2(im, re) * 180 / Math.PI : null);
  }
  return {mag: mg, phase: pa};
}
function draw() {
  var p = +$('posture').value, r = DATA.bands[$('band').value], k = +$('entry').value;
  var x = Array.from(freq.subarray(r[0], r[1])), tr = [], lay = {height: 760, showlegend: true,
      grid: {rows: 4, columns: 4, pattern: 'independent'}, annotations: [], legend: {orientation: 'h', y: -0.06}};
  for (var e = 0; e < 16; e++) {
    var ax = e === 0 ? '' : String(e + 1), first = e === 0;
    tr.push({x: x, y: col(mag, p, r, e, 0.01, -32768), xaxis: 'x' + ax, yaxis: 'y' + ax, name: 'measured',
             legendgroup: 'm', showlegend: first, line: {color: '#1f77b4', width: 1}});
    if (ex) tr.push({x: x, y: col(ex, p, r, e, 0.01, -32768), xaxis: 'x' + ax, yaxis: 'y' + ax, name: 'exact',
                     legendgroup: 'e', showlegend: first, line: {color: '#d62728', width: 1, dash: 'dot'}});
    if (fit) tr.push({x: x, y: synth(p, r, e).mag, xaxis: 'x' + ax, yaxis: 'y' + ax, name: 'fitted',
                      legendgroup: 'f', showlegend: first, line: {color: '#2ca02c', width: 1, dash: 'dash'}});
    lay['xaxis' + ax] = {tickfont: {size: 9}}; lay['yaxis' + ax] = {tickfont: {size: 9}};
    lay.annotations.push({text: C[e >> 2] + ' / ' + C[e & 3], xref: 'x' + ax + ' domain', yref: 'y' + ax + ' domain',
                          x: 0.5, y: 1.08, showarrow: false, font: {size: 10}});
  }
  lay.title = {text: '|H| (dB re 1 m/N) against frequency (Hz): ' + DATA.labels[p], font: {size: 13}};
  var d = [{x: x, y: col(mag, p, r, k, 0.01, -32768), name: 'measured |H|', line: {color: '#1f77b4'}},
           {x: x, y: col(ph, p, r, k, 0.01, -32768), name: 'measured phase', yaxis: 'y2', line: {color: '#1f77b4'}}];
  if (ex) d.push({x: x, y: col(ex, p, r, k, 0.01, -32768), name: 'exact |H|', line: {color: '#d62728', dash: 'dot'}});
  if (fit) { var s = synth(p, r, k);
    d.push({x: x, y: s.mag, name: 'fitted |H|', line: {color: '#2ca02c', dash: 'dash'}});
    d.push({x: x, y: s.phase, name: 'fitted phase', yaxis: 'y2', line: {color: '#2ca02c', dash: 'dash'}}); }
  if (coh) d.push({x: x, y: col(coh, p, r, k, 1 / 250, 255), name: 'coherence', yaxis: 'y3', line: {color: '#555'}});
  var dl = {height: 520, title: {text: C[k >> 2] + ' / ' + C[k & 3] + ', ' + DATA.labels[p], font: {size: 13}},
            xaxis: {title: {text: 'frequency (Hz)'}, anchor: 'y3'},
            yaxis: {domain: [0.52, 1], title: {text: '|H| (dB re 1 m/N)'}},
            yaxis2: {domain: [0.24, 0.48], title: {text: 'phase (°)'}, range: [-185, 185]},
            yaxis3: {domain: [0, 0.2], title: {text: 'coherence'}, range: [0, 1.05]}};
  d.forEach(function (t) { t.xaxis = 'x'; });
  return Promise.all([rm.plot($('matrix'), tr, lay), rm.plot($('detail'), d, dl)]);
}
['posture', 'band', 'entry'].forEach(function (s) { $(s).addEventListener('change', draw); });
return draw();
"""

_MAP_MARKUP = """
<div class="rm-controls">mode <select id="ID-mode"></select> quantity <select id="ID-field"></select></div>
<div id="ID-map" class="rm-dyn" style="min-height:360px"></div>
"""

_MAP_JS = r"""
var $ = function (s) { return document.getElementById(ID + '-' + s); };
var th = DATA.theta, thetas = Array.from(new Set(th)).sort(function (a, b) { return a - b; });
var x = rm.decode(DATA.x), y = rm.decode(DATA.y), N = th.length, vals = {};
DATA.modes.forEach(function (l, i) { $('mode').add(new Option(l, i)); });
Object.keys(DATA.fields).forEach(function (k) { $('field').add(new Option(DATA.fields[k].label, k)); vals[k] = rm.decode(DATA.fields[k].v); });
function draw() {
  var m = +$('mode').value, k = $('field').value, v = vals[k], lo = Infinity, hi = -Infinity;
  for (var i = 0; i < N; i++) { var q = v[i * DATA.n_mode + m]; if (!isNaN(q)) { lo = Math.min(lo, q); hi = Math.max(hi, q); } }
  var tr = [], lay = {height: 360, showlegend: false, grid: {rows: 1, columns: thetas.length, pattern: 'independent'},
                      title: {text: DATA.modes[m] + ': ' + DATA.fields[k].label, font: {size: 13}}};
  thetas.forEach(function (t, j) {
    var ax = j === 0 ? '' : String(j + 1), xs = [], ys = [], cs = [], tx = [];
    for (var i = 0; i < N; i++) if (th[i] === t) { var q = v[i * DATA.n_mode + m];
      xs.push(x[i]); ys.push(y[i]); cs.push(isNaN(q) ? null : q); tx.push('posture ' + i + (isNaN(q) ? ': not found' : '')); }
    tr.push({type: 'scatter', mode: 'markers', x: xs, y: ys, text: tx, xaxis: 'x' + ax, yaxis: 'y' + ax,
             hovertemplate: '%{text}<br>x %{x:.0f} mm, y %{y:.0f} mm<br>%{marker.color:.5g}<extra></extra>',
             marker: {size: 12, color: cs, colorscale: 'Viridis', cmin: lo, cmax: hi, showscale: j === thetas.length - 1,
                      line: {width: 1, color: '#333'}}});
    lay['xaxis' + ax] = {title: {text: 'x (mm), θ = ' + t + '°'}};
  });
  lay.yaxis = {title: {text: 'y (mm)'}};
  return rm.plot($('map'), tr, lay);
}
$('mode').addEventListener('change', draw); $('field').addEventListener('change', draw);
return draw();
"""
