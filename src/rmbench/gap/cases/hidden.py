"""The hidden effects of a blind case (:mod:`.blind`): what is hidden (:class:`Hidden`), how it is
drawn (:func:`draw_case`: one in-library effect, two, or one outside the library) and injected into
a copy of the nominal MJCF by plain XML edits of :mod:`.truth` (:func:`inject`), magnified
(:func:`scaled`) and kept inside the ranges the diagnosis's library fits (:func:`within_library`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.robot import Robot
from rmbench.gap.cases import truth as edit

__all__ = ["Hidden", "draw_case", "draw_out_of_library", "inject", "scaled", "within_library", "OUT_KINDS"]

_IN_LIBRARY_KINDS = ("joint_stiffness", "joint_damping", "load_dependent_stiffness",
                     "servo_stiffness", "tool_contact_stiffness", "spindle_stiffness",
                     "base_compliance", "added_mass", "sensor_misplacement", "sensor_misalignment",
                     "non_reciprocity")
OUT_KINDS = ("hose_resonator", "tendon_coupling", "offset_mass", "link_bending")
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
    return draw_out_of_library(rng, OUT_KINDS[int(rng.integers(len(OUT_KINDS)))])


def draw_out_of_library(rng: np.random.Generator, kind: str) -> Hidden:
    """One effect outside the diagnosis's library of ``kind`` (of :data:`OUT_KINDS`), its place and
    size drawn from ``rng``: a hose package resonating on the upper arm or forearm (5-15 kg, 9-30 Hz,
    ζ 0.05), a tendon coupling two neighbouring joints (30-80 % of the softer one's stiffness), a
    mass of 8-20 kg 0.25-0.4 m off a body's origin, or a link bending at mid-span (its compliance
    1/3 to 1 of its root joint's)."""
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
    if kind != "link_bending":
        raise ValueError(f"unknown out-of-library kind {kind!r}; one of {', '.join(OUT_KINDS)}")
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


def within_library(h: Hidden) -> bool:
    """Whether ``h``, of a library kind, stays inside the ranges the library fits (see above);
    an effect outside the library always does."""
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


def scaled(h: Hidden, scale: float) -> Hidden:
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

