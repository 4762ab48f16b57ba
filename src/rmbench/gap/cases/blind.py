"""Withheld-effect check: hidden effects injected into the model, diagnosed blind, scored.

Each case draws one hidden effect (three cases in five), two at once (one in five), or one outside
the diagnosis's library (one in five: an extra resonator — a hose package on a spring at a link —,
a tendon coupling two joints, a mass 0.25-0.4 m off a body's origin, or a link that bends about
an axis no joint has, at mid-span). The effect is injected into a copy of the nominal MJCF by plain
XML edits of its own (:mod:`.truth`: never the variant code, the calibration's parameters or the
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
from rmbench.gap.cases import truth as edit

__all__ = ["Hidden", "CaseResult", "BlindReport", "draw_case", "inject", "run_case", "run_blind",
           "VISIBLE_DB"]

VISIBLE_DB = 1.0          # the hidden change moves the exact FRF by this much (rms over a band) somewhere
_IN_LIBRARY_KINDS = ("joint_stiffness", "joint_damping", "load_dependent_stiffness",
                     "servo_stiffness", "tool_contact_stiffness", "spindle_stiffness",
                     "base_compliance", "added_mass", "sensor_misplacement", "sensor_misalignment",
                     "non_reciprocity")
_OUT_KINDS = ("hose_resonator", "tendon_coupling", "offset_mass", "link_bending")
# a link bending at mid-span about an axis none of its joints has, against the stiffness of
# the flexible joint at its root: (its flex joint, the point, the axis, in the link's frame)
_BENDING = {"lower_arm": ("j2_flex", (0.0, 0.0, 0.35), (1.0, 0.0, 0.0)),
            "forearm": ("j4_flex", (0.45, 0.0, 0.0), (0.0, 0.0, 1.0))}
_FLEX = ("j1_flex", "j2_flex", "j3_flex", "j4_flex", "j5_flex", "j6_flex")
_BODIES = ("lower_arm", "upper_arm", "forearm", "wrist", "flange", "spindle_rotor")
_SENSORS = ("1X", "1Y", "1aX", "1aY")
_TEST_KINDS = ("sensor_misplacement", "sensor_misalignment", "non_reciprocity")   # change the test, not the robot
# joint-name prefix and the value keys of its (x, y) and (rx, ry) stiffness
_PAIRS = {"tool_contact_stiffness": ("tool_contact", ("translation", "rotation")),
          "spindle_stiffness": ("spindle", ("radial", "tilt"))}


@dataclass(frozen=True)
class Hidden:
    """One hidden effect: what was injected, where, how much.

    Attributes
    ----------
    kind : str
        A library kind, or ``hose_resonator``, ``tendon_coupling``, ``offset_mass``,
        ``link_bending`` (outside the library).
    location : str
        In the diagnosis's naming (MJCF name, ``BAND:COORD``, ``tool_contact``, ...).
    value : dict
        The injected magnitude(s), in the units of the kind.
    """

    kind: str
    location: str
    value: dict

    @property
    def in_library(self) -> bool:
        return self.kind in _IN_LIBRARY_KINDS

    @property
    def name(self) -> str:
        return f"{self.kind}@{self.location}"


def draw_case(rng: np.random.Generator, kind: str | None = None) -> tuple[Hidden, ...]:
    """The hidden effect(s) of one case: one (3 in 5), two (1 in 5), or one out of the library."""
    if kind is None:
        u = rng.random()
        kind = "one" if u < 0.6 else ("two" if u < 0.8 else "out")
    if kind == "out":
        return (_draw_out(rng),)
    first = _draw_in(rng)
    if kind == "one":
        return (first,)
    while True:
        second = _draw_in(rng)
        if second.kind != first.kind or second.location != first.location:
            return (first, second)


def _sign(rng):
    return 1.0 if rng.random() < 0.5 else -1.0


def _factor(rng, lo, hi):
    """A factor log-uniform in [lo, hi] or in [1/hi, 1/lo]."""
    f = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
    return f if rng.random() < 0.5 else 1 / f


def _draw_in(rng) -> Hidden:
    kind = _IN_LIBRARY_KINDS[int(rng.integers(len(_IN_LIBRARY_KINDS)))]
    if kind in ("joint_stiffness", "joint_damping", "load_dependent_stiffness"):
        loc = _FLEX[int(rng.integers(len(_FLEX)))]
        if kind == "joint_stiffness":
            return Hidden(kind, loc, {"factor": _factor(rng, 1.2, 1.6)})
        if kind == "joint_damping":
            return Hidden(kind, loc, {"factor": _factor(rng, 1.8, 3.5)})
        return Hidden(kind, loc, {"alpha": float(rng.uniform(0.15, 0.6))})
    if kind == "servo_stiffness":
        return Hidden(kind, f"a{int(rng.integers(1, 7))}", {"factor": _factor(rng, 4.0, 10.0)})
    if kind == "tool_contact_stiffness":
        return Hidden(kind, "tool_contact", {"translation": _factor(rng, 1.5, 3.0),
                                             "rotation": _factor(rng, 1.5, 3.0)})
    if kind == "spindle_stiffness":
        return Hidden(kind, "spindle", {"radial": _factor(rng, 1.2, 1.6), "tilt": _factor(rng, 1.2, 1.6)})
    if kind == "base_compliance":
        return Hidden(kind, "base", {"lateral": float(rng.uniform(20, 80)),
                                     "tilt": float(rng.uniform(20, 80))})
    if kind == "added_mass":
        body = _BODIES[int(rng.integers(len(_BODIES)))]
        return Hidden(kind, body, {"fraction": float(rng.uniform(0.1, 0.4)) * (1 if rng.random() < 0.7 else -0.6)})
    if kind == "sensor_misplacement":
        band = "low" if rng.random() < 0.5 else "high"
        return Hidden(kind, f"{band}:{_SENSORS[int(rng.integers(4))]}",
                      {"along_mm": _sign(rng) * float(rng.uniform(3, 8))})
    if kind == "sensor_misalignment":
        band = "low" if rng.random() < 0.5 else "high"
        return Hidden(kind, f"{band}:{_SENSORS[int(rng.integers(4))]}",
                      {"angle_deg": _sign(rng) * float(rng.uniform(4, 12))})
    return Hidden("non_reciprocity", "spindle_spin", {"rpm": float(rng.uniform(8000, 24000))})


def _draw_out(rng) -> Hidden:
    kind = _OUT_KINDS[int(rng.integers(len(_OUT_KINDS)))]
    if kind == "hose_resonator":
        link = ("upper_arm", "forearm")[int(rng.integers(2))]
        return Hidden(kind, link, {"mass": float(rng.uniform(5, 15)), "f_hz": float(rng.uniform(9, 30)),
                                   "zeta": 0.05})
    if kind == "tendon_coupling":
        pair = [("j2_flex", "j3_flex"), ("j4_flex", "j5_flex"), ("j5_flex", "j6_flex")][int(rng.integers(3))]
        return Hidden(kind, "+".join(pair), {"fraction": float(rng.uniform(0.3, 0.8))})
    if kind == "offset_mass":
        # off the body's origin: the library's added mass keeps the body's centre and inertia
        body = ("forearm", "wrist", "flange")[int(rng.integers(3))]
        offset = rng.uniform(-1, 1, 3)
        offset *= float(rng.uniform(0.25, 0.4)) / np.linalg.norm(offset)
        return Hidden(kind, body, {"mass": float(rng.uniform(8, 20)), "offset_m": offset.tolist()})
    link = ("lower_arm", "forearm")[int(rng.integers(2))]
    # the bending compliance over the root joint's: 1/3 to 1 (a bending stiffness 1-3 times it)
    return Hidden(kind, link, {"compliance_ratio": float(rng.uniform(1 / 3, 1.0))})


def inject(robot: Robot, hidden, scale: float = 1.0) -> tuple[str, dict, float]:
    """The hidden effects in a copy of the robot, by plain MJCF edits (:mod:`.truth`).

    Parameters
    ----------
    scale : float
        Magnifies every effect (1: as drawn); used to make a faint draw visible.

    Returns
    -------
    xml : str
        The changed robot's MJCF (the robot's own text when only the test changes).
    placement : dict
        Per band ``{"position_error_mm": [4], "misalignment_deg": [4]}`` of the sensors.
    spindle_rpm : float
    """
    root = edit.parse(robot.xml)
    placement = {b: {"position_error_mm": [0.0] * 4, "misalignment_deg": [0.0] * 4} for b in ("low", "high")}
    rpm = 0.0
    edited, base = False, None

    def factor(f):
        return float(np.exp(scale * np.log(f)))

    for h in hidden:
        v = h.value
        edited = edited or h.kind not in _TEST_KINDS
        if h.kind in ("joint_stiffness", "joint_damping"):
            edit.scale_joint(root, h.location, h.kind.removeprefix("joint_"), factor(v["factor"]))
        elif h.kind == "load_dependent_stiffness":
            edit.add_load_stiffness(root, {h.location: scale * v["alpha"]})
        elif h.kind == "servo_stiffness":
            edit.scale_servo_kp(root, h.location, factor(v["factor"]))
        elif h.kind in ("tool_contact_stiffness", "spindle_stiffness"):
            prefix, (move, turn) = _PAIRS[h.kind]
            for axis, key in (("x", move), ("y", move), ("rx", turn), ("ry", turn)):
                edit.scale_joint(root, f"{prefix}_{axis}", "stiffness", factor(v[key]))
        elif h.kind == "base_compliance":
            # last, on the arm as changed: its dampers are set against the arm's mass
            base = (1 / (scale * v["lateral"] * 1e-9), 1 / (scale * v["tilt"] * 1e-9))
        elif h.kind == "added_mass":
            edit.add_body_mass(root, h.location, scale * v["fraction"] * edit.body_mass(root, h.location))
        elif h.kind in ("sensor_misplacement", "sensor_misalignment"):
            band, coord = h.location.split(":")
            i = _SENSORS.index(coord)
            if h.kind == "sensor_misplacement":
                placement[band]["position_error_mm"][i] += scale * v["along_mm"]
            else:
                placement[band]["misalignment_deg"][i] += scale * v["angle_deg"]
        elif h.kind == "non_reciprocity":
            rpm += scale * v["rpm"]
        elif h.kind == "hose_resonator":
            edit.add_resonator(root, h.location, v["mass"], v["f_hz"] * (scale ** 0.25), v["zeta"])
        elif h.kind == "tendon_coupling":
            edit.add_coupling(root, h.location.split("+"), scale * v["fraction"])
        elif h.kind == "offset_mass":
            edit.attach_mass(root, h.location, scale * v["mass"], v["offset_m"])
        elif h.kind == "link_bending":
            root_joint, pos, axis = _BENDING[h.location]
            edit.add_bending(root, h.location, root_joint, pos, axis, scale * v["compliance_ratio"])
        else:  # pragma: no cover - draw_case draws known kinds only
            raise ValueError(h.kind)
    if base is not None:
        edit.mount_on_springs(root, *base)
    return (edit.write(root) if edited else robot.xml), placement, rpm


# the ranges the diagnosis's library fits (rmbench.gap.frf.effects.library): a hidden effect of a
# library kind stays inside them, else it would be out of the library in all but name
_LIBRARY_RANGE = {"factor": {"joint_stiffness": (0.3, 3.0), "joint_damping": (0.1, 10.0),
                             "servo_stiffness": (0.01, 10.0)},
                  "alpha": (0.0, 3.0), "translation": (0.2, 5.0), "rotation": (0.2, 5.0),
                  "radial": (0.3, 3.0), "tilt": (0.3, 3.0), "lateral": (0.0, 200.0),
                  "fraction": (-0.5, 2.0), "along_mm": (-10.0, 10.0), "angle_deg": (-15.0, 15.0),
                  "rpm": (0.0, 30000.0)}


def _within_library(h: Hidden) -> bool:
    if not h.in_library:
        return True
    for key, x in h.value.items():
        rng = _LIBRARY_RANGE.get(key)
        if isinstance(rng, dict):
            rng = rng.get(h.kind)
        if h.kind == "base_compliance" and key == "tilt":
            rng = (0.0, 200.0)
        if rng is not None and not rng[0] <= x <= rng[1]:
            return False
    return True


def _scaled(h: Hidden, scale: float) -> Hidden:
    """The hidden effect with its magnitude magnified as :func:`inject` does with ``scale``."""
    if scale == 1.0:
        return h
    v = dict(h.value)
    for key, x in v.items():
        if key in ("factor", "translation", "rotation", "radial", "tilt") and h.kind != "base_compliance":
            v[key] = float(np.exp(scale * np.log(x)))
        elif key == "f_hz":
            v[key] = x * scale ** 0.25
        elif key == "offset_m":
            continue
        elif key not in ("zeta", "mass") or h.kind != "hose_resonator":
            v[key] = scale * x
    return Hidden(h.kind, h.location, v)


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
    from rmbench.impact.measure import hammer_rows
    from rmbench.impact.sensors import COORDS
    from rmbench.robot.variant import with_tool_masses

    changed = Robot(xml, name="hidden", tool=nominal.tool, spindle_rpm=rpm)
    true = design.with_offsets([SensorOffset(b, c, along=1e-3 * placement[b]["position_error_mm"][i],
                                             angle=np.radians(placement[b]["misalignment_deg"][i]))
                                for b in design.band_names for i, c in enumerate(COORDS)])
    worst = 0.0
    for band in design.band_names:
        b = design.band(band)
        freq = np.linspace(b.f_min, b.f_max, 200)
        s_nom, s_true = design.sensors(band), true.sensors(band)
        r_nom = with_tool_masses(nominal, s_nom.tool_masses()) if s_nom.mass > 0 else nominal
        r_true = with_tool_masses(changed, s_true.tool_masses()) if s_true.mass > 0 else changed
        for q in q_cmd:
            op0, op1 = r_nom.at(q), r_true.at(q)
            h0 = op0.linear.modes().frf(freq, s_nom.reading_rows(op0), hammer_rows(op0, COORDS, b.s_1a))
            h1 = op1.linear.modes().frf(freq, s_true.reading_rows(op1), hammer_rows(op1, COORDS, b.s_1a))
            worst = max(worst, float(np.sqrt(np.mean((20 * np.log10(np.abs(h1) / np.abs(h0))) ** 2))))
    return worst


def run_case(index: int, seed: int, method: str = "linear", *, n_postures: int = 16,
             workers: int | None = None, workdir: str | Path | None = None,
             nominal: str = "irb6660", tool: str = "dummy", kind: str | None = None) -> CaseResult:
    """Draw, inject, measure, export and import, diagnose and score one blind case."""
    from rmbench.calibrate.design import TestDesign
    from rmbench.gap.frf.diagnosis import diagnose
    from rmbench.impact import open_campaign, parse_config, run_campaign
    from rmbench.io import read_uff58, write_uff58

    t0 = time.perf_counter()
    rng = np.random.default_rng([seed, index])
    grid = seed_grid()
    postures = [grid[i] for i in sorted(rng.choice(len(grid), n_postures, replace=False))]
    robot = Robot.load(nominal, tool=tool)
    believed = _campaign_toml(nominal, tool, postures, method, seed)
    design = TestDesign.from_text(believed)
    q_cmd = [robot.ik(p).q for p in postures]
    probe = q_cmd[::4]
    # every hidden effect must change the FRF visibly on its own: a faint draw is magnified,
    # one that stays invisible (load-dependent stiffness of an axis gravity does not load) is
    # drawn again, and counted
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
        if all(sc is not None and _within_library(_scaled(h, sc)) for h, sc in zip(hidden, scales)):
            break
    else:
        raise RmbenchError(f"blind case {index}: no visible, holdable draw in 20")
    hidden = tuple(_scaled(h, sc) for h, sc in zip(hidden, scales))
    scale = float(max(scales))
    xml, placement, rpm = inject(robot, hidden)
    try:
        vis = _visible_db(robot, xml, design, placement, rpm, probe)
    except RmbenchError:                 # two effects together the robot cannot hold
        vis = float("nan")
    own = Path(tempfile.mkdtemp(prefix="rmbench_blind_")) if workdir is None else Path(workdir) / f"case_{index:03d}"
    own.mkdir(parents=True, exist_ok=True)
    try:
        variant = own / "hidden.xml"
        variant.write_text(xml)
        true_toml = _campaign_toml(str(variant), None, postures, method, seed, commands_from=nominal,
                                   placement=placement, rpm=rpm)
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
        back = read_uff58(uff)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                if back.sizes["posture"] < 2:
                    raise RmbenchError("the hidden robot held fewer than 2 of the postures")
                dg = diagnose(robot, back, workers=workers)
            except RmbenchError as err:
                # a diagnosis that stops is a wrong answer, not the end of the run
                return CaseResult(index=index, method=method, hidden=hidden, verdict=f"error: {err}",
                                  ranked=(), equivalent=(), shrink=0.0, top1=False, top3=False,
                                  top1_class=False, top3_class=False,
                                  pair_in_top3=False if len(hidden) == 2 else None,
                                  seconds={"campaign": round(t1 - t0, 2)}, visible_db=float(vis),
                                  scale=float(max(scales)), rejected=rejected)
        t2 = time.perf_counter()
    finally:
        if workdir is None:
            shutil.rmtree(own, ignore_errors=True)
    return replace(_score(index, method, hidden, dg, {"campaign": round(t1 - t0, 2), "diagnose": round(t2 - t1, 2)},
                          vis, scale), rejected=rejected)


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
            "out_kinds": {k: sum(c.hidden[0].kind == k for c in out) for k in _OUT_KINDS},
            "calibration": cal}


def run_blind(cases: int, seed: int, *, method: str = "linear", time_share: float = 0.25,
              workers: int | None = None, scheduler: str | None = None, workdir=None, progress=None,
              start: int = 0, out=None, n_postures: int = 16) -> BlindReport:
    """Run ``cases`` blind cases (``method`` "linear", "time", or "mixed": a ``time_share`` of
    time-domain cases). With ``out`` (a JSON-lines path) each finished case is appended to it, and
    the cases it already holds are not run again: a killed run resumes. ``progress(case)`` is
    called after each case run here.

    Without ``scheduler`` the cases run one after the other, each on ``workers`` processes
    (default: all cores); with the address of an existing dask scheduler they are tasks of its
    cluster, each in one single-threaded worker, and are written as they finish: the lines of a
    run here but for the seconds, bit for bit where this process is single-threaded too (as the
    benches run it, ``OMP_NUM_THREADS=1``; with more BLAS threads the last digits may differ).
    ``n_postures``: each case's campaign."""
    from functools import partial

    from rmbench.parallel import map_cases

    results = {}
    out = Path(out) if out is not None else None
    if out is not None and out.is_file():
        for line in out.read_text().splitlines():
            if line.strip():
                case = case_from_dict(json.loads(line))
                results[case.index] = case
    n_time = int(round(time_share * cases)) if method == "mixed" else (cases if method == "time" else 0)
    todo = [(i, "time" if (i - start) < n_time else "linear") for i in range(start, start + cases)
            if i not in results]
    # on a cluster a case is one worker's: single-threaded inside (no worker processes of its own)
    one = partial(_run_one, seed=seed, workers=workers if scheduler is None else 0, workdir=workdir,
                  n_postures=n_postures)
    for (i, _), case in map_cases(one, todo, workers=1, scheduler=scheduler):
        results[i] = case
        if out is not None:
            with open(out, "a") as fh:
                fh.write(dumps(case) + "\n")
        if progress is not None:
            progress(case)
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


def _run_one(case: tuple, *, seed: int, workers, workdir, n_postures: int) -> CaseResult:
    """:func:`run_case` of ``(index, method)``: one task of :func:`run_blind`."""
    index, method = case
    return run_case(index, seed, method, n_postures=n_postures, workers=workers, workdir=workdir)
