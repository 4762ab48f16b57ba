"""Report sections of the machining stages: stability lobes (with virtual-milling verdicts), the
RCSA tool change and the robot-supported plate."""

from __future__ import annotations

import numpy as np

from rmbench.report.page import Page, label

__all__ = ["lobes_sections", "tool_change_sections", "support_sections"]

_COLORS = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b")


def lobes_sections(page: Page, curves: dict, *, title: str = "Stability lobes", milling=None,
                   note: str = "") -> None:
    """Critical depth of the lowest lobe against spindle speed, one curve per named diagram.

    Parameters
    ----------
    curves : dict of str to Lobes
    milling : sequence of dict, optional
        Virtual-milling verdicts ``{"speed_rpm", "depth_m", "kind"}`` (``stable``, ``hopf``,
        ``flip``, ``runaway``), drawn as markers.
    """
    traces = []
    for i, (name, lb) in enumerate(curves.items()):
        a = np.where(np.isfinite(lb.a_lim), 1e3 * lb.a_lim, np.nan)
        traces.append({"type": "scatter", "mode": "lines", "x": lb.speed_rpm, "y": a,
                       "name": label(f"{name} ({lb.method})"), "line": {"color": _COLORS[i % len(_COLORS)], "width": 2}})
    if milling:
        marks = {"stable": ("circle-open", "#2ca02c"), "hopf": ("x", "#d62728"), "flip": ("diamond", "#9467bd"),
                 "runaway": ("triangle-up", "#000")}
        for kind, (sym, col) in marks.items():
            pts = [r for r in milling if r.get("kind") == kind]
            if pts:
                traces.append({"type": "scatter", "mode": "markers", "name": f"virtual milling: {kind}",
                               "x": [r["speed_rpm"] for r in pts], "y": [1e3 * r["depth_m"] for r in pts],
                               "marker": {"symbol": sym, "color": col, "size": 7}})
    sec = page.section(title, note or "Critical axial depth of the lowest lobe per spindle speed: "
                       "below the curve the cut is stable.")
    sec.figure({"data": traces, "layout": {"height": 460, "xaxis": {"title": {"text": "spindle speed (rpm)"}},
                                           "yaxis": {"title": {"text": "critical depth (mm)"}, "rangemode": "tozero"}}})
    rows = []
    for name, lb in curves.items():
        a = lb.a_lim[np.isfinite(lb.a_lim)]
        if len(a):
            k = int(np.nanargmin(np.where(np.isfinite(lb.a_lim), lb.a_lim, np.inf)))
            rows.append([name, lb.method, len(lb.speed_rpm), 1e3 * a.min(), float(lb.speed_rpm[k]), 1e3 * a.max()])
        else:
            rows.append([name, lb.method, len(lb.speed_rpm), "stable everywhere", "", ""])
    sec.table(["diagram", "method", "speeds", "lowest depth (mm)", "at (rpm)", "highest depth (mm)"], rows)


def _mag(h):
    with np.errstate(divide="ignore"):
        return 20 * np.log10(np.abs(h))


def tool_change_sections(page: Page, result, *, reference: dict | None = None) -> None:
    """Predicted (RCSA) against simulated target-tool tip FRFs, the four tip entries per band,
    and the peak errors.

    Parameters
    ----------
    result : CampaignToolChange
    reference : dict of str to ndarray, optional
        Per band, the reference tool's measured full tip receptance (n_freq, 4, 4).
    """
    from rmbench.rcsa.tool_change import TIP_ENTRIES

    x, y, t = result.posture_mm_deg
    sec = page.section(f"RCSA tool change at ({x:.0f} mm, {y:.0f} mm, {t:.0f}°)",
                       f"Target-tool tip receptance predicted by Eq. 4 ({result.method} rotations, contact "
                       f"{result.contact_source}) against the simulated robot carrying the target tool.")
    bands = list(result.bands)
    traces, lay = [], {"height": 900, "grid": {"rows": 4, "columns": len(bands), "pattern": "independent"},
                       "annotations": [], "legend": {"orientation": "h", "y": -0.05}}
    for c, band in enumerate(bands):
        tc = result.bands[band]
        for r, ((i, j), entry) in enumerate(TIP_ENTRIES):
            k = r * len(bands) + c + 1
            ax = "" if k == 1 else str(k)
            first = k == 1
            common = {"xaxis": f"x{ax}", "yaxis": f"y{ax}", "mode": "lines", "type": "scatter"}
            if reference is not None and band in reference:
                traces.append({**common, "x": tc.freq, "y": _mag(reference[band][:, i, j]), "legendgroup": "r",
                               "showlegend": first, "name": label(f"reference tool ({tc.reference.name}), measured"),
                               "line": {"color": "#999", "width": 1}})
            if band in result.truth:
                traces.append({**common, "x": tc.freq, "y": _mag(result.truth[band][:, i, j]), "legendgroup": "t",
                               "showlegend": first, "name": label(f"{tc.target.name}, simulated (truth)"),
                               "line": {"color": "black", "width": 2}})
            traces.append({**common, "x": tc.freq, "y": _mag(tc.t[:, i, j]), "legendgroup": "p", "showlegend": first,
                           "name": label(f"{tc.target.name}, RCSA"), "line": {"color": "#d62728", "dash": "dash", "width": 1.5}})
            lay[f"yaxis{ax}"] = {"title": {"text": f"{entry} (dB)", "font": {"size": 10}}}
            if r == 0:
                lay["annotations"].append({"text": f"{band} band", "xref": f"x{ax} domain", "yref": f"y{ax} domain",
                                           "x": 0.5, "y": 1.12, "showarrow": False})
            if r == 3:
                lay[f"xaxis{ax}"] = {"title": {"text": "frequency (Hz)"}}
    sec.figure({"data": traces, "layout": lay}, caption="|H| in dB re 1 m/N.")
    if result.peaks:
        sec.table(["entry", "true peak (Hz)", "amplitude error (%)", "frequency error (%)"],
                  [[p.entry, p.f_true, 100 * p.amp_err, 100 * p.freq_err] for p in result.peaks])


def support_sections(page: Page, study) -> None:
    """The robot-supported plate: part alone, robot alone, simulated assembly, RCSA (Eq. 6 with
    the contact and rigid), and the misplaced-sensor case against Eqs. 12-14."""
    f = study.freq
    d = study.to_dict()
    sec = page.section("Robot-supported thin-walled plate",
                       f"Preload {study.preload:.0f} N, contact {1e3 * study.contact:.0f} mm from the left clamp; "
                       f"assembled low mode {d['low_mode_sim_hz']:.2f} Hz simulated, {d['low_mode_rcsa_hz']:.2f} Hz "
                       "by RCSA; peak reductions (simulated/RCSA) "
                       + ", ".join(f"{100 * a:.2f}/{100 * b:.2f} %" for a, b in zip(d["reduction_sim"], d["reduction_rcsa"])) + ".")
    top = [("part alone (simulated)", study.h_part, {"color": "#999", "width": 1}),
           ("robot alone, ball X (simulated)", study.h_robot, {"color": "#1f77b4", "width": 1}),
           ("assembly (simulated, truth)", study.g_sim, {"color": "black", "width": 2}),
           (f"RCSA Eq. 6, K_x {study.k_x:.3g} N/m", study.g_rcsa, {"color": "#d62728", "dash": "dash"}),
           ("RCSA Eq. 6, rigid joint", study.g_rcsa_rigid, {"color": "#2ca02c", "dash": "dot"})]
    bot = [("assembly at the sensor (simulated)", study.g_sim_s, {"color": "black", "width": 2}),
           (f"Eq. 6 fed the sensor {1e3 * study.sensor_offset:.0f} mm off the joint", study.g_offset,
            {"color": "#ff7f0e", "dash": "dash"}),
           ("Eqs. 12-14, sensor as its own coordinate", study.g_rcsa_s, {"color": "#d62728", "dash": "dot"})]
    traces = [{"type": "scatter", "mode": "lines", "x": f, "y": _mag(h), "name": n, "line": ln}
              for n, h, ln in top]
    traces += [{"type": "scatter", "mode": "lines", "x": f, "y": _mag(h), "name": n, "line": ln,
                "xaxis": "x2", "yaxis": "y2"} for n, h, ln in bot]
    sec.figure({"data": traces, "layout": {
        "height": 720, "grid": {"rows": 2, "columns": 1, "pattern": "independent"},
        "yaxis": {"title": {"text": "|H| at the coupling point (dB)"}},
        "yaxis2": {"title": {"text": "|H| at the sensor (dB)"}}, "xaxis2": {"title": {"text": "frequency (Hz)"}},
        "shapes": [{"type": "line", "x0": fm, "x1": fm, "yref": "paper", "y0": 0, "y1": 1,
                    "line": {"color": "#ccc", "width": 1}} for fm in study.part_modes[:2]]}})
