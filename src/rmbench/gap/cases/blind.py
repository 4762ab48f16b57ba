"""Withheld-effect check: hidden effects injected into the model, diagnosed blind, scored.

Each case draws one hidden effect (three cases in five), two at once (one in five), or one outside
the diagnosis's library (one in five: an extra resonator — a hose package on a spring at a link —,
a tendon coupling two joints, a mass 0.25-0.4 m off a body's origin, or a link that bends about
an axis no joint has, at mid-span: :mod:`.hidden`). The effect is injected into a copy of the
nominal MJCF by plain XML edits of its own (:mod:`.truth`: never the variant code, the calibration's parameters or the
diagnosis's library, which build the candidates), with a magnitude drawn large enough to change
the exact FRF by at least ``VISIBLE_DB`` somewhere. A campaign measures the changed robot commanded by the nominal
robot's inverse kinematics; the data go out to UFF58 and back (so nothing but FRFs, postures and the
test design survives), with the test design as the experimenter believes it (no sensor placement
errors, the nominal robot named); the diagnosis gets only that and the nominal model. A draw
that stays invisible, or that the robot cannot hold its postures with, is drawn again and counted
(``CaseResult.rejected``): a run's rejections are printed, never silent.

Scores: top-1 and top-3 identification of kind and location (strict, and up to the effects the
data cannot tell apart, which the diagnosis reports), the held-out shrink, false attributions on
the out-of-library cases (anything but "unexplained"), both effects of a two-effect case in the
top 3, and the calibration of the confidences.
"""

from __future__ import annotations

import json
import shutil
import tempfile
import time
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from rmbench.errors import RmbenchError
from rmbench.io.strict_json import strict_dumps
from rmbench.robot import Robot, seed_grid
from rmbench.gap.cases.hidden import OUT_KINDS, Hidden, draw_case, inject, scaled, within_library

__all__ = ["Hidden", "CaseResult", "BlindReport", "CaseOptions", "BlindOptions", "draw_case", "inject",
           "run_case", "run_blind", "VISIBLE_DB"]

VISIBLE_DB = 1.0          # the hidden change moves the exact FRF by this much (rms over a band) somewhere


@dataclass(frozen=True)
class CaseResult:
    """One blind case: what was hidden, what the diagnosis said, how it scores."""

    index: int
    method: str
    hidden: tuple
    verdict: str
    ranked: tuple           # (name, confidence) best first
    equivalent: tuple
    shrink: float
    top1: bool
    top3: bool
    top1_class: bool
    top3_class: bool
    pair_in_top3: bool | None
    seconds: dict
    visible_db: float
    scale: float
    rejected: int = 0       # draws rejected before this one (invisible, or postures not held)

    def to_dict(self) -> dict:
        return {"index": self.index, "method": self.method,
                "hidden": [{"kind": h.kind, "location": h.location, "value": h.value} for h in self.hidden],
                "verdict": self.verdict, "ranked": [list(r) for r in self.ranked],
                "equivalent": [list(g) for g in self.equivalent], "shrink": self.shrink,
                "top1": self.top1, "top3": self.top3, "top1_class": self.top1_class,
                "top3_class": self.top3_class, "pair_in_top3": self.pair_in_top3,
                "seconds": self.seconds, "visible_db": self.visible_db, "scale": self.scale,
                "rejected": self.rejected}


@dataclass(frozen=True)
class BlindReport:
    """All cases of a blind run and their summary."""

    cases: tuple
    summary: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        return {"summary": self.summary, "cases": [c.to_dict() for c in self.cases]}


@dataclass(frozen=True)
class CaseOptions:
    """How one blind case is measured and diagnosed (:func:`run_case`).

    Attributes
    ----------
    method : str
        The campaign's simulation: ``"linear"`` or ``"time"``.
    n_postures : int
        Postures of the campaign, drawn from the seed grid.
    workers : int or None
        Processes of the campaign and the diagnosis (None: all cores, 0: none of their own).
    workdir : str, Path or None
        Keep the case's files in ``workdir/case_NNN`` (None: a temporary folder, removed).
    nominal, tool : str
        The robot and tool the diagnosis is given.
    kind : str or None
        ``"one"``, ``"two"`` or ``"out"`` hidden effects (None: drawn).
    """

    method: str = "linear"
    n_postures: int = 16
    workers: int | None = None
    workdir: str | Path | None = None
    nominal: str = "irb6660"
    tool: str = "dummy"
    kind: str | None = None


@dataclass(frozen=True)
class BlindOptions:
    """How a blind run measures its cases and where it runs them (:func:`run_blind`).

    Attributes
    ----------
    method : str
        ``"linear"``, ``"time"``, or ``"mixed"``: a ``time_share`` of time-domain cases.
    time_share : float
    workers : int or None
        Processes of each case run here (None: all cores).
    scheduler : str or None
        Address of an existing dask scheduler whose cluster runs the cases.
    workdir : str, Path or None
        Keep each case's files there (:attr:`CaseOptions.workdir`).
    n_postures : int
        Postures of each case's campaign.
    """

    method: str = "linear"
    time_share: float = 0.25
    workers: int | None = None
    scheduler: str | None = None
    workdir: str | Path | None = None
    n_postures: int = 16


def _campaign_toml(robot_name: str, tool, postures, method: str, seed: int, *, commands_from=None,
                   placement=None, rpm: float = 0.0) -> str:
    rows = ", ".join(f"[{1e3 * p.x:.6g}, {1e3 * p.y:.6g}, {np.degrees(p.theta):.6g}]" for p in postures)
    lines = [f'name = "blind"', f"seed = {seed}", f'method = "{method}"', "[robot]",
             f'name = "{robot_name}"']
    if tool is not None:
        lines.append(f'tool = "{tool}"')
    if rpm:
        lines.append(f"spindle_rpm = {rpm:.6g}")
    if commands_from:
        lines.append(f'commands_from = "{commands_from}"')
    lines += ["[grid]", 'kind = "list"', f"postures = [{rows}]"]
    from rmbench.impact.config import default_bands

    for band, b in default_bands().items():
        lines += [f"[bands.{band}]", f"f_min = {b.f_min}", f"f_max = {b.f_max}",
                  f'sensor = "{b.sensor}"', f"s_1a_mm = {b.s_1a_mm}", f"sample_rate = {b.sample_rate}",
                  f"line_spacing = {b.line_spacing}", f"[bands.{band}.hammer]",
                  f"pulse_ms = {b.hammer.pulse_ms}", f"peak_n = {b.hammer.peak_n}"]
        if placement is not None:
            pe = ", ".join(f"{x:.6g}" for x in placement[band]["position_error_mm"])
            ma = ", ".join(f"{x:.6g}" for x in placement[band]["misalignment_deg"])
            lines += [f"[bands.{band}.placement]", f"position_error_mm = [{pe}]",
                      f"misalignment_deg = [{ma}]"]
    return "\n".join(lines) + "\n"


def _visible_db(nominal: Robot, xml: str, design, placement, rpm, q_cmd) -> float:
    """Largest band-rms change of the exact as-tested FRF (dB) over the given commands."""
    from rmbench.calibrate.design import SensorOffset
    from rmbench.calibrate.modes import as_tested, with_sensors
    from rmbench.impact.sensors import COORDS

    changed = Robot(xml, name="hidden", tool=nominal.tool, spindle_rpm=rpm)
    true = design.with_offsets([SensorOffset(b, c, along=1e-3 * placement[b]["position_error_mm"][i],
                                             angle=np.radians(placement[b]["misalignment_deg"][i]))
                                for b in design.band_names for i, c in enumerate(COORDS)])
    worst = 0.0
    for band in design.band_names:
        b = design.band(band)
        freq = np.linspace(b.f_min, b.f_max, 200)
        r_nom, r_true = with_sensors(nominal, design, band), with_sensors(changed, true, band)
        for q in q_cmd:
            h0 = as_tested(r_nom.at(q), design, band).frf(freq)
            h1 = as_tested(r_true.at(q), true, band).frf(freq)
            worst = max(worst, float(np.sqrt(np.mean((20 * np.log10(np.abs(h1) / np.abs(h0))) ** 2))))
    return worst


def run_case(index: int, seed: int, options: CaseOptions = CaseOptions(), **changes) -> CaseResult:
    """Draw, inject, measure, export and import, diagnose and score one blind case.

    ``options`` (:class:`CaseOptions`), with any of its fields changed by keyword
    (``run_case(0, 1, method="time", n_postures=4)``)."""
    from rmbench.calibrate.design import TestDesign

    opt = replace(options, **changes)
    t0 = time.perf_counter()
    rng = np.random.default_rng([seed, index])
    grid = seed_grid()
    postures = [grid[i] for i in sorted(rng.choice(len(grid), opt.n_postures, replace=False))]
    robot = Robot.load(opt.nominal, tool=opt.tool)
    believed = _campaign_toml(opt.nominal, opt.tool, postures, opt.method, seed)
    design = TestDesign.from_text(believed)
    q_cmd = [robot.ik(p).q for p in postures]
    probe = q_cmd[::4]
    hidden, scale, rejected = _visible_draw(rng, robot, design, probe, opt.kind, index)
    xml, placement, rpm = inject(robot, hidden)
    try:
        vis = _visible_db(robot, xml, design, placement, rpm, probe)
    except RmbenchError:                 # two effects together the robot cannot hold
        vis = float("nan")
    own = Path(tempfile.mkdtemp(prefix="rmbench_blind_")) if opt.workdir is None else Path(opt.workdir) / f"case_{index:03d}"
    own.mkdir(parents=True, exist_ok=True)
    try:
        variant = own / "hidden.xml"
        variant.write_text(xml)
        true_toml = _campaign_toml(str(variant), None, postures, opt.method, seed, commands_from=opt.nominal,
                                   placement=placement, rpm=rpm)
        back, t1 = _measured(own, true_toml, believed, opt.workers)
        dg = _diagnosed(robot, back, opt.workers)
        t2 = time.perf_counter()
    finally:
        if opt.workdir is None:
            shutil.rmtree(own, ignore_errors=True)
    if isinstance(dg, RmbenchError):
        # a diagnosis that stops is a wrong answer, not the end of the run
        return CaseResult(index=index, method=opt.method, hidden=hidden, verdict=f"error: {dg}",
                          ranked=(), equivalent=(), shrink=0.0, top1=False, top3=False,
                          top1_class=False, top3_class=False,
                          pair_in_top3=False if len(hidden) == 2 else None,
                          seconds={"campaign": round(t1 - t0, 2)}, visible_db=float(vis),
                          scale=scale, rejected=rejected)
    return replace(_score(index, opt.method, hidden, dg, {"campaign": round(t1 - t0, 2), "diagnose": round(t2 - t1, 2)},
                          vis, scale), rejected=rejected)


def _visible_draw(rng, robot: Robot, design, probe, kind, index: int) -> tuple:
    """The hidden effects of a case, each magnified until it changes the FRF visibly on its own:
    a faint draw is magnified, one that stays invisible (load-dependent stiffness of an axis
    gravity does not load), that the robot cannot hold its postures with, or that leaves the
    library's ranges is drawn again, and counted. Returns ``(hidden, scale, rejected)``."""
    for rejected in range(20):
        hidden = draw_case(rng, kind)
        scales = []
        for h in hidden:
            scale = 1.0
            for _ in range(5):
                xml, placement, rpm = inject(robot, (h,), scale)
                try:
                    seen = _visible_db(robot, xml, design, placement, rpm, probe)
                except RmbenchError:     # a robot that cannot hold its postures is no test case
                    scale = None
                    break
                if seen >= VISIBLE_DB:
                    break
                scale *= 1.6
            else:
                scale = None
            scales.append(scale)
        if all(sc is not None and within_library(scaled(h, sc)) for h, sc in zip(hidden, scales)):
            break
    else:
        raise RmbenchError(f"blind case {index}: no visible, holdable draw in 20")
    return tuple(scaled(h, sc) for h, sc in zip(hidden, scales)), float(max(scales)), rejected


def _measured(own: Path, true_toml: str, believed: str, workers):
    """The campaign of the hidden robot (``true_toml``) run into ``own``, the postures it could
    not hold dropped, the test design replaced by the ``believed`` one, out to UFF58 and back; and
    the time the campaign ended (:func:`time.perf_counter`)."""
    from rmbench.impact import open_campaign, parse_config, run_campaign
    from rmbench.io import read_uff58, write_uff58

    data = own / "measured.nc"
    if data.exists():
        data.unlink()
    run_campaign(parse_config(true_toml), data, toml=true_toml, workers=workers, progress=False)
    t1 = time.perf_counter()
    ds = open_campaign(data)
    if "ok" in ds.coords and not ds.ok.values.all():
        # a real test has no record of postures its robot could not hold
        ds = ds.isel(posture=np.flatnonzero(ds.ok.values))
    ds.attrs.clear()
    ds.attrs["config"] = believed          # the test design as the experimenter believes it
    uff = own / "uff"
    if uff.exists():
        shutil.rmtree(uff)
    write_uff58(ds[["H"]], uff)
    return read_uff58(uff), t1


def _diagnosed(robot: Robot, back, workers):
    """The FRF diagnosis of the measured data ``back``, or the :class:`RmbenchError` that
    stopped it."""
    from rmbench.gap.frf.diagnosis import diagnose

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            if back.sizes["posture"] < 2:
                raise RmbenchError("the hidden robot held fewer than 2 of the postures")
            return diagnose(robot, back, workers=workers)
        except RmbenchError as err:
            return err


def _score(index, method, hidden, dg, seconds, vis, scale) -> CaseResult:
    names = [e.name for e in dg.effects]
    groups = [set(g) for g in dg.equivalent]

    def same(a, b):
        return a == b or any(a in g and b in g for g in groups)

    in_lib = all(h.in_library for h in hidden)
    truth = [h.name for h in hidden]
    reported = names if dg.verdict == "explained" else []
    top1 = bool(in_lib and reported and reported[0] in truth)
    top3 = bool(in_lib and any(n in truth for n in names[:3]))
    top1_class = bool(in_lib and reported and any(same(reported[0], t) for t in truth))
    top3_class = bool(in_lib and any(same(n, t) for n in names[:3] for t in truth))
    pair = None
    if len(hidden) == 2:
        pair = all(any(same(n, t) for n in names[:3]) for t in truth)
    chosen = [e for e in dg.effects if e.chosen]
    shrink = chosen[0].shrink if chosen else (dg.effects[0].shrink if dg.effects else 0.0)
    return CaseResult(index=index, method=method, hidden=tuple(hidden), verdict=dg.verdict,
                      ranked=tuple((e.name, round(e.confidence, 4)) for e in dg.effects[:5]),
                      equivalent=dg.equivalent, shrink=float(shrink), top1=top1, top3=top3,
                      top1_class=top1_class, top3_class=top3_class, pair_in_top3=pair,
                      seconds={**seconds, **{f"diagnose_{k}": v for k, v in dg.seconds.items()}},
                      visible_db=float(vis), scale=float(scale))


def summarise(cases) -> dict:
    """The blind run's figures (see the module docstring)."""
    one = [c for c in cases if len(c.hidden) == 1 and c.hidden[0].in_library]
    two = [c for c in cases if len(c.hidden) == 2]
    out = [c for c in cases if not c.hidden[0].in_library]
    inlib = one + two
    frac = (lambda xs: float(np.mean(xs)) if len(xs) else float("nan"))
    cal = []
    records = []
    for c in inlib:
        truth = [h.name for h in c.hidden]
        for name, conf in c.ranked[:3]:
            records.append((conf, name in truth or any(name in g and t in g for g in map(set, c.equivalent)
                                                        for t in truth)))
    edges = np.array([0, 0.2, 0.4, 0.6, 0.8, 1.0 + 1e-9])
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = [ok for conf, ok in records if lo <= conf < hi]
        confs = [conf for conf, _ in records if lo <= conf < hi]
        cal.append({"bin": [float(lo), float(min(hi, 1.0))], "n": len(sel),
                    "mean_confidence": frac(confs), "fraction_right": frac(sel)})
    return {"cases": len(cases), "time_domain": sum(c.method == "time" for c in cases),
            "single": len(one), "pairs": len(two), "out_of_library": len(out),
            "top1": frac([c.top1 for c in one]), "top3": frac([c.top3 for c in one]),
            "top1_class": frac([c.top1_class for c in one]), "top3_class": frac([c.top3_class for c in one]),
            "median_shrink": float(np.median([c.shrink for c in inlib])) if inlib else float("nan"),
            "false_attribution": frac([c.verdict != "unexplained" for c in out]),
            "pair_recall": frac([bool(c.pair_in_top3) for c in two]),
            "explained_in_library": frac([c.verdict == "explained" for c in inlib]),
            "rejected": int(sum(c.rejected for c in cases)),
            "out_kinds": {k: sum(c.hidden[0].kind == k for c in out) for k in OUT_KINDS},
            "calibration": cal}


def run_blind(cases: int, seed: int, options: BlindOptions = BlindOptions(), *, progress=None,
              start: int = 0, out=None, **changes) -> BlindReport:
    """Run ``cases`` blind cases as ``options`` (:class:`BlindOptions`) say, with any of its fields
    changed by keyword (``run_blind(2, 5, method="linear", n_postures=4)``). With ``out`` (a
    JSON-lines path) each finished case is appended to it, and the cases it already holds are not
    run again: a killed run resumes. ``progress(case)`` is called after each case run here.

    Without ``scheduler`` the cases run one after the other, each on ``workers`` processes
    (default: all cores); with the address of an existing dask scheduler they are tasks of its
    cluster, each in one single-threaded worker, and are written as they finish: the lines of a
    run here but for the seconds, bit for bit where this process is single-threaded too (as the
    benches run it, ``OMP_NUM_THREADS=1``; with more BLAS threads the last digits may differ)."""
    from functools import partial

    from rmbench.parallel import map_cases

    opt = replace(options, **changes)
    out = Path(out) if out is not None else None
    results = _written(out)
    n_time = int(round(opt.time_share * cases)) if opt.method == "mixed" else (cases if opt.method == "time" else 0)
    todo = [(i, "time" if (i - start) < n_time else "linear") for i in range(start, start + cases)
            if i not in results]
    # on a cluster a case is one worker's: single-threaded inside (no worker processes of its own)
    case = CaseOptions(n_postures=opt.n_postures, workers=opt.workers if opt.scheduler is None else 0,
                       workdir=opt.workdir)
    for (i, _), result in map_cases(partial(_run_one, seed=seed, options=case), todo, workers=1,
                                    scheduler=opt.scheduler):
        results[i] = result
        if out is not None:
            with open(out, "a") as fh:
                fh.write(dumps(result) + "\n")
        if progress is not None:
            progress(result)
    ordered = tuple(results[i] for i in sorted(results) if start <= i < start + cases)
    return BlindReport(cases=ordered, summary=summarise(ordered))


def case_from_dict(d: dict) -> CaseResult:
    """A CaseResult back from :meth:`CaseResult.to_dict` (resuming a run from its JSON lines)."""
    hidden = tuple(Hidden(h["kind"], h["location"], h["value"]) for h in d["hidden"])
    return CaseResult(index=d["index"], method=d["method"], hidden=hidden, verdict=d["verdict"],
                      ranked=tuple(tuple(r) for r in d["ranked"]),
                      equivalent=tuple(tuple(g) for g in d["equivalent"]), shrink=d["shrink"],
                      top1=d["top1"], top3=d["top3"], top1_class=d["top1_class"],
                      top3_class=d["top3_class"], pair_in_top3=d["pair_in_top3"],
                      seconds=d["seconds"], scale=d["scale"], rejected=int(d.get("rejected", 0)),
                      visible_db=float("nan") if d["visible_db"] is None else d["visible_db"])


def dumps(case: CaseResult) -> str:
    """One JSON line of ``case``, strict JSON: a visibility the robot could not be probed for
    (NaN) is null."""
    return strict_dumps(case.to_dict())


def _written(out: Path | None) -> dict:
    """``{index: CaseResult}`` of the cases the JSON lines ``out`` already hold (none without)."""
    results = {}
    if out is not None and out.is_file():
        for line in out.read_text().splitlines():
            if line.strip():
                case = case_from_dict(json.loads(line))
                results[case.index] = case
    return results


def _run_one(case: tuple, *, seed: int, options: CaseOptions) -> CaseResult:
    """:func:`run_case` of ``(index, method)``: one task of :func:`run_blind`."""
    index, method = case
    return run_case(index, seed, options, method=method)
