"""Report sections of a planned tool path: the path coloured by its critical depth, θ and the
critical depth along it for the planned, fixed-θ and pointwise-best schedules; per segment between
the path's corners, the angle, the speed, the limit and its band, and the cuts made."""

from __future__ import annotations

import numpy as np

from rmbench.report.page import Page

__all__ = ["path_sections", "segment_rows", "segments_section"]

_COLORS = {"planned": "#1f77b4", "fixed": "#d62728", "pointwise": "#7f7f7f"}


def _mm(a) -> list:
    a = np.asarray(a, float)
    return np.where(np.isfinite(a), 1e3 * a, np.nan)


def path_sections(page: Page, plan, milling: dict | None = None) -> None:
    """The sections of one :class:`rmbench.path.PathPlan` and, where given, the virtual milling
    along its schedules (``{schedule: PathMilling}``); nothing is recomputed."""
    tp = plan.toolpath
    s_mm = 1e3 * tp.arc_length()
    schedules = {"planned": plan.planned, "fixed": plan.fixed, "pointwise": plan.pointwise}
    sec = page.section("Tool path and its critical depth",
                       f"{len(tp)} cutter locations at {plan.speed_rpm:g} rev/min, coloured by the critical depth "
                       "along the planned schedule (mm); crosses: locations whose depth lies below the depth cut.")
    traces = [{"type": "scatter", "mode": "markers", "x": 1e3 * tp.xy[:, 0], "y": 1e3 * tp.xy[:, 1],
               "name": "planned", "marker": {"size": 4, "color": _mm(plan.planned.margin), "colorscale": "Viridis",
                                            "colorbar": {"title": {"text": "a_lim (mm)"}}}}]
    risk = plan.at_risk()
    if len(risk):
        traces.append({"type": "scatter", "mode": "markers", "x": 1e3 * tp.xy[risk, 0], "y": 1e3 * tp.xy[risk, 1],
                       "name": "at risk", "marker": {"symbol": "x", "color": "#d62728", "size": 7}})
    sec.figure({"data": traces, "layout": {"height": 480, "xaxis": {"title": {"text": "x (mm)"}},
                                           "yaxis": {"title": {"text": "y (mm)"}, "scaleanchor": "x"}}})
    sec = page.section("Tool path in 3-D", "The cutter locations in space (mm; z as programmed, 0 where it "
                       "never was; the tool axis vertical), coloured by the critical depth along the planned schedule (mm); crosses: at risk. "
                       "Drag to turn.")
    xyz = 1e3 * np.column_stack([tp.xy, np.nan_to_num(tp.z)])          # z never programmed: drawn at 0
    traces = [{"type": "scatter3d", "mode": "markers", "x": xyz[:, 0], "y": xyz[:, 1], "z": xyz[:, 2],
               "name": "planned", "marker": {"size": 2.5, "color": _mm(plan.planned.margin), "colorscale": "Viridis",
                                            "colorbar": {"title": {"text": "a_lim (mm)"}}}}]
    if len(risk):
        traces.append({"type": "scatter3d", "mode": "markers", "x": xyz[risk, 0], "y": xyz[risk, 1],
                       "z": xyz[risk, 2], "name": "at risk",
                       "marker": {"symbol": "x", "color": "#d62728", "size": 4}})
    span = np.ptp(xyz[:, :2], axis=0)
    span = span / max(span.max(), 1e-9)
    sec.figure({"data": traces, "layout": {
        "height": 520, "scene": {"xaxis": {"title": {"text": "x (mm)"}}, "yaxis": {"title": {"text": "y (mm)"}},
                                 "zaxis": {"title": {"text": "z (mm)"}}, "aspectmode": "manual",
                                 "aspectratio": {"x": max(span[0], 0.05), "y": max(span[1], 0.05), "z": 0.3}}}})
    sec = page.section("Redundant angle along the path", "θ per cutter location for each schedule.")
    sec.figure({"data": [{"type": "scatter", "mode": "lines", "x": s_mm, "y": np.degrees(s.theta), "name": k,
                          "line": {"color": _COLORS[k], "width": 1.5}} for k, s in schedules.items()],
                "layout": {"height": 360, "xaxis": {"title": {"text": "arc length (mm)"}},
                           "yaxis": {"title": {"text": "θ (deg)"}}}})
    traces = []
    if plan.band is not None:
        # the planned depth's band: its upper edge, then the lower one filled up to it
        level = f"{100 * plan.band_level:.0f} % band"
        traces += [{"type": "scatter", "mode": "lines", "x": s_mm, "y": _mm(plan.band.upper), "name": level,
                    "line": {"width": 0}, "showlegend": False, "hoverinfo": "skip"},
                   {"type": "scatter", "mode": "lines", "x": s_mm, "y": _mm(plan.band.lower), "name": level,
                    "fill": "tonexty", "fillcolor": "rgba(31,119,180,0.2)", "line": {"width": 0}}]
    traces += [{"type": "scatter", "mode": "lines", "x": s_mm, "y": _mm(s.margin), "name": k,
                "line": {"color": _COLORS[k], "width": 1.5}} for k, s in schedules.items()]
    if plan.depth is not None:
        traces.append({"type": "scatter", "mode": "lines", "x": [s_mm[0], s_mm[-1]], "y": [1e3 * plan.depth] * 2,
                       "name": "depth cut", "line": {"color": "#000", "dash": "dash"}})
    sec = page.section("Critical depth along the path", "The predicted critical depth along each schedule"
                       + ("; shaded, the planned schedule's band (draws of the predictor's calibrated deviations)."
                          if plan.band is not None else "."))
    sec.figure({"data": traces, "layout": {"height": 380, "xaxis": {"title": {"text": "arc length (mm)"}},
                                           "yaxis": {"title": {"text": "critical depth (mm)"}, "rangemode": "tozero"}}})
    rows = [[k, 1e3 * s.min_margin, float(np.degrees(s.theta.min())), float(np.degrees(s.theta.max())),
             "yes" if s.feasible else "no", len(plan.at_risk(s)) if plan.depth is not None else ""]
            for k, s in schedules.items()]
    sec.table(["schedule", "smallest critical depth (mm)", "θ min (deg)", "θ max (deg)", "within joint rates",
               "locations at risk"], rows)
    if milling:
        _milling_section(page, plan, milling)


def _motion_words(milling: dict) -> str:
    if not any(m.moving for m in milling.values()):
        return "holding each posture"
    if not all(m.moving for m in milling.values()):
        return "moving along the path at its feed for " + ", ".join(k for k, m in milling.items() if m.moving) + \
            " (the others holding each posture)"
    held = sum(int(np.sum(~m.moved)) for m in milling.values() if m.moved is not None)
    return "moving along the path at its feed" + (
        f" ({held} cuts on a stretch between sharp corners shorter than a cut held their posture)" if held else "")


def _milling_section(page: Page, plan, milling: dict) -> None:
    s_mm = 1e3 * plan.toolpath.arc_length()
    sec = page.section("Virtual milling along the path",
                       "Each cut in the simulator at the plan's joint commands and the depth cut, the robot "
                       + _motion_words(milling)
                       + ": the tool tip's peak-to-peak vibration over the cut's last third (µm); filled: "
                       "chatter, open: stable.")
    traces = []
    for k, m in milling.items():
        amp = np.full(len(m.index), np.nan) if m.amplitude is None else 1e6 * np.asarray(m.amplitude, float)
        traces.append({"type": "scatter", "mode": "markers", "x": s_mm[m.index], "y": amp, "name": k,
                       "marker": {"color": _COLORS.get(k, "#000"), "size": 9,
                                  "symbol": ["circle" if c else "circle-open" for c in m.chatter]}})
    sec.figure({"data": traces, "layout": {"height": 360, "xaxis": {"title": {"text": "arc length (mm)"}},
                                           "yaxis": {"title": {"text": "vibration, peak to peak (µm)"},
                                                     "type": "log"}}})
    rows = []
    for k, m in milling.items():
        d = m.summary()
        rows.append([k, d["cuts"], d["depth_mm"], d["chatter"], d["expected_chatter"], d["decided"],
                     "" if d["agreement"] is None else f"{100 * d['agreement']:.0f} %", d["inside_band"]])
    sec.table(["schedule", "cuts", "depth (mm)", "chatter", "expected", "clear of ±10 %", "as planned",
               "inside ±10 %"], rows)


SEGMENT_COLUMNS = ["segment", "arc length (mm)", "θ (deg)", "speed (rev/min)", "smallest critical depth (mm)",
                   "band's lower edge (mm)", "best fixed angle's smallest (mm)", "cuts: chatter / expected"]


def _segments(plan) -> list:
    """Location ranges ``(first, last)`` between the path's corners (a corner's location closes the
    segment it is reached by: θ arrives there at the incoming segment's angle); one segment where
    the plan found no corners."""
    turn = plan.reorientation
    cut = (turn.candidates if turn is not None else
           plan.planned.corners if plan.planned.corners is not None else np.zeros(0, int))
    ends = [int(c) for c in np.asarray(cut, int)] + [len(plan.toolpath) - 1]
    out, first = [], 0
    for last in ends:
        if last >= first:
            out.append((first, last))
            first = last + 1
    return out


def segment_rows(plan, milling: dict | None = None) -> list:
    """One row per segment of the plan (:data:`SEGMENT_COLUMNS`; mm, degrees, rev/min): its arc
    length, the planned θ's range, the spindle speed, the planned schedule's smallest critical depth
    and its band's lower edge ("" without a band), the best fixed angle's smallest there ("" where
    not kept), and per milled schedule the cuts in it that chattered and that the plan expected to."""
    arc = 1e3 * plan.toolpath.arc_length()
    rows = []
    for k, (a, b) in enumerate(_segments(plan)):
        th = np.degrees(plan.planned.theta[a:b + 1])
        lo, hi = float(th.min()), float(th.max())
        cuts = []
        for name, m in (milling or {}).items():
            inside = (m.index >= a) & (m.index <= b)
            if inside.any():
                cuts.append(f"{name} {int(m.chatter[inside].sum())} / {int(m.expected[inside].sum())} "
                            f"of {int(inside.sum())}")
        rows.append([k + 1, f"{arc[a]:.0f}-{arc[b]:.0f}", f"{lo:.0f}" if lo == hi else f"{lo:.0f} to {hi:.0f}",
                     f"{plan.speed_rpm:g}", 1e3 * float(plan.planned.margin[a:b + 1].min()),
                     "" if plan.band is None else 1e3 * float(np.nanmin(plan.band.lower[a:b + 1])),
                     "" if plan.best_fixed is None else 1e3 * float(plan.best_fixed.margin[a:b + 1].min()),
                     "; ".join(cuts) or "none"])
    return rows


def segments_section(page: Page, plan, milling: dict | None = None) -> None:
    """A table of the plan per segment between its corners (:func:`segment_rows`), with the speeds
    it was chosen among, the corners θ turned at standing, and the dwell."""
    intro = f"At {plan.speed_rpm:g} rev/min"
    if plan.speed_scan is not None:
        intro += (" (the best of " + ", ".join(f"{v:g}" for v in plan.speed_scan["speeds_rpm"])
                  + " rev/min, whose planned smallest critical depths are "
                  + ", ".join(f"{1e3 * v:.3f}" for v in plan.speed_scan["min_alim"]) + " mm)")
    intro += f"; feed along {'base X' if plan.feed == 'x' else 'the path'}."
    if plan.reorientation is not None:
        intro += " " + plan.reorientation.summary() + "."
    if plan.band is None:
        intro += " No band: the critical depths are the exact model's."
    sec = page.section("The plan per segment", intro)
    sec.table(SEGMENT_COLUMNS, segment_rows(plan, milling))
