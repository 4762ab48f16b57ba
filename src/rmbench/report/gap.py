"""Report sections of a sim-to-real gap diagnosis: the verdict, the ranked effects with their
held-out evidence, gap maps over the workspace, and before/after overlays.

The sections are built from the diagnosis's document (:func:`diagnosis_document`): from the
result itself (a :class:`~rmbench.gap.frf.result.Diagnosis` or
:class:`~rmbench.gap.tracker.diagnosis.TrackerDiagnosis`), or from the folder it saved
(:func:`read_diagnosis`: ``diagnosis.json`` and its CSV tables; parsed, never evaluated). Both are
the result's own JSON form and per-mode tables, drawn by one path."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from rmbench.errors import InputError
from rmbench.report.page import Page, arr, label

__all__ = ["gap_sections", "read_diagnosis", "diagnosis_document", "form_section"]


def diagnosis_document(dg) -> dict:
    """The document :func:`read_diagnosis` reads from a saved folder, from the result ``dg`` (a
    :class:`~rmbench.gap.frf.result.Diagnosis` or a
    :class:`~rmbench.gap.tracker.diagnosis.TrackerDiagnosis`): its JSON form, with ``kind`` and,
    for FRFs, the per-mode tables ``modes`` and ``modes_after``."""
    from rmbench.gap.frf.files import mode_rows
    from rmbench.gap.frf.result import Diagnosis
    from rmbench.gap.jsonable import jsonable
    from rmbench.gap.tracker.diagnosis import TrackerDiagnosis

    if isinstance(dg, TrackerDiagnosis):
        return {**dg.to_dict(), "kind": "tracker"}
    if not isinstance(dg, Diagnosis):
        raise TypeError(f"a Diagnosis, TrackerDiagnosis or a diagnosis folder expected, got {type(dg).__name__}")
    doc = {**jsonable(dg.to_dict()), "kind": "frf", "modes": mode_rows(dg.where)}
    if dg.where_after is not None:
        doc["modes_after"] = mode_rows(dg.where_after)
    return doc


def read_diagnosis(directory) -> dict:
    """``diagnosis.json`` of a saved diagnosis folder, with ``kind`` (``"frf"`` or ``"tracker"``)
    and the per-mode tables (``modes``, ``modes_after``) as lists of dicts when present."""
    d = Path(directory)
    f = d / "diagnosis.json"
    if not f.is_file():
        raise InputError(f"{d}: no diagnosis.json (not a folder written by 'rmbench gap diagnose')")
    try:
        doc = json.loads(f.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError) as err:
        raise InputError(f"{f}: not valid JSON ({err})") from None
    if not isinstance(doc, dict) or "verdict" not in doc or "effects" not in doc:
        raise InputError(f"{f}: not a gap diagnosis (no verdict or effects)")
    where = doc.get("where") or {}
    doc["kind"] = "tracker" if "bins" in where else "frf"
    for name, key in (("gap_modes.csv", "modes"), ("gap_modes_after.csv", "modes_after")):
        p = d / name
        if p.is_file():
            with open(p, newline="", encoding="utf-8") as fh:
                doc[key] = list(csv.DictReader(fh))
    return doc


def gap_sections(page: Page, diagnosis) -> None:
    """Add a diagnosis's sections (FRF or tracker): ``diagnosis`` the result itself (a
    :class:`~rmbench.gap.frf.result.Diagnosis` or
    :class:`~rmbench.gap.tracker.diagnosis.TrackerDiagnosis`) or the folder it saved."""
    if isinstance(diagnosis, (str, Path)):
        doc, where = read_diagnosis(diagnosis), str(diagnosis)
    else:
        doc, where = diagnosis_document(diagnosis), "the diagnosis"
    try:
        (_frf if doc["kind"] == "frf" else _tracker)(page, doc)
    except (KeyError, TypeError, ValueError, AttributeError) as err:
        raise InputError(f"{where}: malformed diagnosis ({type(err).__name__}: {err})") from None


def _num(v, default=np.nan) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return default


def _effects_figure(sec, effects, key_before, key_after, ylabel, scale=1.0) -> None:
    top = effects[:12]
    names = [label(e["name"]) + (" *" if e.get("chosen") else "") for e in top]
    sec.figure({"data": [
        {"type": "bar", "x": names, "y": [scale * _num(e["heldout_before"].get(key_before)) for e in top],
         "name": "nominal model", "marker": {"color": "#999"}},
        {"type": "bar", "x": names, "y": [scale * _num(e["heldout_after"].get(key_after)) for e in top],
         "name": "with the effect", "marker": {"color": "#d62728"}}],
        "layout": {"height": 400, "barmode": "group", "yaxis": {"title": {"text": ylabel}},
                   "xaxis": {"tickangle": -30, "automargin": True}}},
        caption="Held-out postures only (never used to fit the effect); * marks the chosen model's effects.")


def _frf(page, doc) -> None:
    w = doc.get("where") or {}
    sec = page.section(f"Gap diagnosis: {doc['verdict']}",
                       str(w.get("localisation", "")) or str(w.get("describe", "")))
    eff = doc["effects"]
    rows = [[i + 1, e["name"], "yes" if e.get("chosen") else "", e.get("description", ""),
             _num(e.get("confidence")), 100 * _num(e.get("shrink")),
             " … ".join(f"{100 * _num(v):.0f}" for v in (e.get("shrink_interval") or [])),
             _num(e["heldout_before"].get("gap")), _num(e["heldout_after"].get("gap")),
             100 * _num(e["heldout_after"].get("f_err")), _num(e["heldout_after"].get("frf_db"))]
            for i, e in enumerate(eff)]
    sec.table(["rank", "effect", "chosen", "description", "confidence", "shrink (%)", "95 % interval (%)",
               "gap before", "gap after", "f error after (%)", "FRF error after (dB)"], rows,
              caption="Held-out gap: rms normalised residual of the paired modes on postures the fits never saw.")
    if eff:
        _effects_figure(sec, eff, "gap", "gap", "held-out gap (rms normalised residual)")
    if doc.get("equivalent"):
        sec.text("Indistinguishable on these data: " + "; ".join(" = ".join(g) for g in doc["equivalent"]))
    for n in doc.get("notes", []):
        sec.text(str(n))
    if (doc.get("form") or {}).get("located"):
        form_section(page, doc["form"])
    if doc.get("modes"):
        _mode_maps(page, doc["modes"], doc.get("modes_after"))


def form_section(page: Page, form: dict) -> None:
    """Where a "model form" gap lies, on the robot seen from the side: its links grey, each
    place's joint (a dot) or link (a thick segment) red by the share of the held-out gap it removes.
    ``form``: :meth:`rmbench.calibrate.form.FormCheck.to_dict` with ``located``
    (:meth:`rmbench.gap.frf.locate.Localisation.to_dict`)."""
    located = form["located"]
    sec = page.section("Model form: where the gap lies", str(located.get("summary", "")))
    traces = [{"type": "scatter", "mode": "lines", "x": [x0, x1], "y": [z0, z1], "showlegend": False,
               "hoverinfo": "skip", "line": {"color": "#aaa", "width": 5}} for x0, z0, x1, z1 in located.get("links", [])]
    places = located.get("places", [])[:6]
    best = max([_num(p.get("shrink"), 0.0) for p in places] + [1e-12])
    for p in places[::-1]:
        pts = np.asarray(p.get("at") or [], float).reshape(-1, 2)
        if not len(pts):
            continue
        share = max(_num(p.get("shrink"), 0.0), 0.0) / best
        colour = f"rgba(214, 39, 40, {0.2 + 0.8 * share:.2f})"
        text = f"{p['where']}: {p['acts_like']}, removes {100 * _num(p.get('shrink')):.0f} % of the held-out gap"
        traces.append({"type": "scatter", "mode": "markers" if len(pts) == 1 else "lines", "name": str(p["where"]),
                       "x": pts[:, 0].tolist(), "y": pts[:, 1].tolist(), "text": [text] * len(pts),
                       "hoverinfo": "text", "marker": {"size": 10 + 14 * share, "color": colour},
                       "line": {"color": colour, "width": 4 + 10 * share}})
    sec.figure({"data": traces, "layout": {"height": 420, "xaxis": {"title": {"text": "x (m)"}},
                                           "yaxis": {"title": {"text": "z (m)"}, "scaleanchor": "x"}}},
               caption=(f"The calibrated model at the zero posture, from the side. Held-out frequencies: χ² "
                        f"{_num(form.get('chi2')):.4g} on {form.get('n')} modes, p {_num(form.get('p')):.2g}."))


def _mode_table(rows):
    """(postures, mode keys, x, y, θ) and a lookup of each row by (posture, mode key)."""
    keys = list(dict.fromkeys(f"{label(r['band'])}:{label(r['mode'])}" for r in rows))
    post = sorted({int(r["posture"]) for r in rows})
    pos = {int(r["posture"]): (float(r["x"]), float(r["y"]), float(r["theta"])) for r in rows}
    return post, keys, pos, {(int(r["posture"]), f"{label(r['band'])}:{label(r['mode'])}"): r for r in rows}


def _mode_maps(page, rows, after) -> None:
    post, keys, pos, look = _mode_table(rows)
    fields = {"df": ("frequency gap (model/measured − 1, %)", 100.0), "dzeta": ("damping gap (%)", 100.0),
              "dscale": ("amplitude gap (%)", 100.0), "mac": ("MAC of the residues", 1.0),
              "z_f": ("frequency gap / its uncertainty", 1.0)}
    vals = {k: np.array([[_num(look[(p, m)].get(k)) * s if (p, m) in look else np.nan for m in keys] for p in post])
            for k, (_, s) in fields.items()}
    data = {"x": [1e3 * pos[p][0] for p in post], "y": [1e3 * pos[p][1] for p in post],
            "theta": [round(float(np.degrees(pos[p][2])), 1) for p in post],
            "modes": [f"mode {k}" for k in keys], "n_mode": len(keys),
            "fields": {k: {"label": lab, "v": arr(vals[k])} for k, (lab, _) in fields.items()}}
    from rmbench.report.campaign import _MAP_JS, _MAP_MARKUP

    sec = page.section("Gap over the workspace", "The nominal model's gap of each tracked mode at each "
                                                 "measured posture (x, y per redundant angle θ).")
    sec.widget(_MAP_MARKUP, data, _MAP_JS)
    sec2 = page.section("Before and after", "Natural frequency of each tracked mode per posture: measured, "
                        "nominal model" + (", updated model (the chosen effects added)" if after else "") + ".")
    look_after = _mode_table(after)[3] if after else {}
    traces, lay = [], {"height": 260 * ((len(keys) + 1) // 2),
                       "grid": {"rows": (len(keys) + 1) // 2, "columns": 2, "pattern": "independent"},
                       "annotations": [], "legend": {"orientation": "h", "y": -0.03}}
    for j, m in enumerate(keys):
        ax = "" if j == 0 else str(j + 1)
        first = j == 0
        series = [("measured", look, "f_meas", {"color": "black"}, "markers"),
                  ("nominal model", look, "f_model", {"color": "#999"}, "lines+markers")]
        if after:
            series.append(("updated model", look_after, "f_model", {"color": "#d62728"}, "lines+markers"))
        for name, tab, col, style, mode in series:
            y = [_num(tab[(p, m)].get(col)) if (p, m) in tab else None for p in post]
            traces.append({"type": "scatter", "mode": mode, "x": post, "y": y, "name": name, "legendgroup": name,
                           "showlegend": first, "xaxis": f"x{ax}", "yaxis": f"y{ax}",
                           "marker": {"size": 5, **style}, "line": {"width": 1, **style}})
        lay["annotations"].append({"text": f"mode {m}", "xref": f"x{ax} domain", "yref": f"y{ax} domain",
                                   "x": 0.5, "y": 1.1, "showarrow": False, "font": {"size": 10}})
        lay[f"yaxis{ax}"] = {"title": {"text": "f (Hz)", "font": {"size": 9}}}
    sec2.figure({"data": traces, "layout": lay}, caption="x axis: posture index.")


def _tracker(page, doc) -> None:
    w = doc.get("where") or {}
    b, a = doc.get("heldout_before") or {}, doc.get("heldout_after") or {}
    sec = page.section(f"Tracker gap diagnosis: {doc['verdict']}",
                       f"{doc.get('n_readings', '')} readings; held-out rms {1e3 * _num(b.get('rms')):.3f} → "
                       f"{1e3 * _num(a.get('rms')):.3f} mm, max {1e3 * _num(b.get('max')):.3f} → "
                       f"{1e3 * _num(a.get('max')):.3f} mm; the readings' noise {1e3 * _num(w.get('noise_rms')):.3f} mm rms.")
    eff = doc["effects"]
    sec.table(["rank", "source", "chosen", "description", "share of the error (%)", "confidence",
               "held-out rms after (mm)", "held-out max after (mm)"],
              [[i + 1, e["name"], "yes" if e.get("chosen") else "", e.get("description", ""),
                100 * _num(e.get("share")), _num(e.get("confidence")), 1e3 * _num(e["heldout_after"].get("rms")),
                1e3 * _num(e["heldout_after"].get("max"))] for i, e in enumerate(eff)])
    if eff:
        _effects_figure(sec, eff, "rms", "rms", "held-out rms position error (mm)", scale=1e3)
    bins = w.get("bins") or {}
    if bins:
        traces = []
        for name, v in bins.items():
            e = np.asarray(v["edges"], float)
            traces.append({"type": "scatter", "mode": "lines+markers", "x": np.degrees(0.5 * (e[1:] + e[:-1])),
                           "y": 1e3 * np.asarray(v["rms"], float), "name": label(name)})
        page.section("Where: error over each joint's range").figure({"data": traces, "layout": {
            "height": 380, "xaxis": {"title": {"text": "joint angle (°)"}},
            "yaxis": {"title": {"text": "rms position error (mm)"}}}},
            caption="Nominal model's rms error of the readings binned by each joint's angle.")
    ex = w.get("explains") or {}
    if ex:
        top = sorted(ex.items(), key=lambda kv: -_num(kv[1], 0))[:20]
        page.section("Where: what the error correlates with").figure({"data": [
            {"type": "bar", "x": [label(k) for k, _ in top], "y": [100 * _num(v) for _, v in top]}],
            "layout": {"height": 360, "yaxis": {"title": {"text": "share of the error explained (%)"}},
                       "xaxis": {"tickangle": -40}}})
