"""A planned path saved to one ``.npz`` and read back: what ``rmbench path mill`` mills.

Arrays and JSON metadata, no pickle (:mod:`rmbench.io.npz_file`). A plan saved before the best
fixed angle, the cut and the feed direction were kept reads back without the first, with the
aluminium slot and the feed along base X: what every plan was made with then.
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

from rmbench.errors import InputError
from rmbench.io.npz_file import read_npz, write_npz
from rmbench.io.toolpath import ToolPath
from rmbench.path.margin import DepthBand, DepthGrid
from rmbench.path.plan import Schedule
from rmbench.path.planner import PathPlan
from rmbench.path.reach import Reach
from rmbench.stability.cutting import ALUMINIUM_6061, Cutting

__all__ = ["save_plan", "load_plan"]

_FORMAT = "rmbench path plan 1"
_SCHEDULES = ("planned", "fixed", "pointwise", "best_fixed")


def save_plan(plan: PathPlan, path, *, robot: str = "", tool: str | None = None, predictor: str = "") -> Path:
    """Write a plan to one ``.npz`` (arrays and JSON metadata, no pickle), atomically: what
    :func:`load_plan` (and ``rmbench path mill``) reads back. ``robot``, ``tool`` and ``predictor``
    name what it was planned with."""
    tp, r, d = plan.toolpath, plan.reach, plan.depths
    arrays = {"tp/xy": tp.xy, "tp/z": tp.z, "tp/feed": tp.feed, "tp/rpm": tp.rpm, "tp/cutting": tp.cutting,
              "tp/line": tp.line, "reach/theta": r.theta, "reach/q": r.q, "reach/ok": r.ok,
              "reach/limit_margin": r.limit_margin, "reach/sigma_min": r.sigma_min, "depths/a_lim": d.a_lim,
              "depths/outside_hull": d.outside_hull}
    arrays |= {f"depths/band/{b}": v for b, v in d.by_band.items()}
    kept = [k for k in _SCHEDULES if getattr(plan, k) is not None]
    for k in kept:
        sch = getattr(plan, k)
        arrays |= {f"{k}/index": sch.index, f"{k}/theta": sch.theta, f"{k}/margin": sch.margin}
        arrays |= {f"{k}/{f}": getattr(sch, f) for f in ("to", "frac", "q", "corners") if getattr(sch, f) is not None}
    if plan.hull_distance is not None:
        arrays["hull_distance"] = plan.hull_distance
    if plan.band is not None:
        arrays |= {"band/lower": plan.band.lower, "band/upper": plan.band.upper}
    meta = {"format": _FORMAT, "robot": robot, "tool": tool, "predictor": predictor, "source": tp.source,
            "speed_rpm": plan.speed_rpm, "depth": plan.depth, "seconds": plan.seconds,
            "depths_speed_rpm": d.speed_rpm, "bands": list(d.by_band),
            "feasible": {k: bool(getattr(plan, k).feasible) for k in kept},
            "band": None if plan.band is None else {"scale": plan.band.scale, "n": plan.band.n_calibration,
                                                    "level": plan.band_level},
            "speed_scan": plan.speed_scan, "cutting": asdict(plan.cutting), "feed": plan.feed,
            "exact_modes": plan.exact_modes, "f_max": plan.f_max}
    return write_npz(path, meta, arrays)


def load_plan(path) -> tuple[PathPlan, dict]:
    """A plan saved by :func:`save_plan`, and its metadata (``robot``, ``tool``, ``predictor``).

    Raises
    ------
    InputError
        The file is missing or not a saved plan.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"plan not found: {path}")
    try:
        meta, a = read_npz(path, _FORMAT)
        tp = ToolPath(a["tp/xy"], a["tp/z"], a["tp/feed"], a["tp/rpm"], a["tp/cutting"].astype(bool),
                      a["tp/line"].astype(int), str(meta.get("source", "")))
        reach = Reach(a["reach/theta"], a["reach/q"], a["reach/ok"].astype(bool), a["reach/limit_margin"],
                      a["reach/sigma_min"])
        depths = DepthGrid(a["depths/a_lim"], {b: a[f"depths/band/{b}"] for b in meta["bands"]},
                           a["depths/outside_hull"].astype(bool), float(meta["depths_speed_rpm"]))
        sch = {k: Schedule(a[f"{k}/index"].astype(int), a[f"{k}/theta"], a[f"{k}/margin"], bool(meta["feasible"][k]),
                           "best fixed" if k == "best_fixed" else k,
                           a[f"{k}/to"].astype(int) if f"{k}/to" in a else None, a.get(f"{k}/frac"), a.get(f"{k}/q"),
                           a[f"{k}/corners"].astype(int) if f"{k}/corners" in a else None)
               for k in _SCHEDULES if k in meta["feasible"]}
        band, level = None, 0.95
        if meta.get("band"):
            band = DepthBand(sch["planned"].margin, a["band/lower"], a["band/upper"], float(meta["band"]["scale"]),
                             int(meta["band"]["n"]))
            level = float(meta["band"]["level"])
        cutting = Cutting(**meta["cutting"]) if meta.get("cutting") else ALUMINIUM_6061
        plan = PathPlan(tp, reach, depths, sch["planned"], sch["fixed"], sch["pointwise"], meta["depth"],
                        float(meta["speed_rpm"]), meta["seconds"], a.get("hull_distance"), band, level,
                        meta.get("speed_scan"), sch.get("best_fixed"), cutting, str(meta.get("feed", "x")),
                        exact_modes=str(meta.get("exact_modes", "bands")), f_max=float(meta.get("f_max", 8000.0)))
    except (ValueError, KeyError, TypeError):
        raise InputError(f"{path} is not a saved path plan (write one with: rmbench path plan ... --out DIR)") from None
    return plan, meta
