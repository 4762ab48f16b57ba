"""Structural effects of a "real robot", built apart from the diagnosis that looks for them.

Plain ElementTree edits of the real robot's MJCF (no rmbench variant, parameter, calibration or
diagnosis code), or changes to how it is measured: a sensor turned on its mount is applied to the
measured signals (:func:`turned_signals`), a spinning spindle is the speed the campaign runs at
(:attr:`Effect.rpm`).

=========================  ==================  =====================================================
kind                       location            the edit and its drawn size
=========================  ==================  =====================================================
In the diagnosis's library
--------------------------------------------------------------------------------------------------
``base_compliance``        ``base``            a 1000 kg plate sliding along x and y under whatever
                                               the robot stands on: 30-100 µm/kN, 5 % damping
``tool_contact_stiffness`` ``tool_contact``    the tool holder's four contact springs × a factor
                                               log-uniform 3-5, or its inverse
``added_mass``             a distal link       its mass (and rotary inertia) × 1.3-1.6
``sensor_misalignment``    ``BAND:COORD``      a sensor turned 6-12° (either way) about the tool
                                               axis: its signal mixes in the perpendicular one
``non_reciprocity``        ``spindle_spin``    the spindle running at 12,000-24,000 rev/min
Outside it
--------------------------------------------------------------------------------------------------
``hose_resonator``         upper arm, forearm  a 5-15 kg package on a lateral spring, 9-30 Hz, 5 %
``tendon_coupling``        two flex joints     a spring on the difference of their angles, 30-80 %
                                               of the softer one's stiffness
``offset_mass``            forearm, wrist,     an 8-20 kg point mass 0.25-0.4 m off the body's origin
                           flange
=========================  ==================  =====================================================

An effect's :attr:`Effect.size` is the number the bench scores a named size against
(``truth.score``): a foundation's sliding compliance in µm/kN, a holder's stiffness factor, the
kilograms added, a sensor's turn in degrees, the spindle's speed in rev/min.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np

from truth.ordinary import logu, mount_under

__all__ = ["IN_LIBRARY", "OUT_OF_LIBRARY", "Effect", "apply_effect", "draw_effect", "turned_signals"]

IN_LIBRARY = ("base_compliance", "tool_contact_stiffness", "added_mass", "sensor_misalignment", "non_reciprocity")
OUT_OF_LIBRARY = ("hose_resonator", "tendon_coupling", "offset_mass")

_MASS_BODIES = ("upper_arm", "forearm", "wrist", "flange")
_HOLDER = ("tool_contact_x", "tool_contact_y", "tool_contact_rx", "tool_contact_ry")
_COORDS = ("1X", "1Y", "1aX", "1aY")
# a sensor reading along X at its point turned by δ reads cos δ·X + sin δ·Y; one along Y reads
# cos δ·Y − sin δ·X: the perpendicular coordinate at the same point and its sign
_PERPENDICULAR = {"1X": ("1Y", 1.0), "1Y": ("1X", -1.0), "1aX": ("1aY", 1.0), "1aY": ("1aX", -1.0)}
_PAIRS = (("j2_flex", "j3_flex"), ("j4_flex", "j5_flex"), ("j5_flex", "j6_flex"))


@dataclass(frozen=True)
class Effect:
    """One structural effect of a real robot.

    Attributes
    ----------
    kind, location : str
    value : dict
        Its drawn size (SI but for ``rpm`` and ``angle_deg``).
    in_library : bool
    size : float or None
        What a named size is scored against (see the module); None outside the library.
    """

    kind: str
    location: str
    value: dict = field(default_factory=dict)
    in_library: bool = True
    size: float | None = None

    @property
    def name(self) -> str:
        return f"{self.kind}@{self.location}"

    @property
    def rpm(self) -> float:
        """The spindle's speed the campaign runs at, rev/min."""
        return float(self.value["rpm"]) if self.kind == "non_reciprocity" else 0.0

    def to_dict(self) -> dict:
        return {"kind": self.kind, "location": self.location, "value": self.value,
                "in_library": self.in_library, "size": self.size, "name": self.name}


def draw_effect(rng: np.random.Generator, *, in_library: bool) -> Effect:
    """One effect of a kind drawn uniformly from the library's (``in_library``) or the others,
    its place and size drawn as the module states. Its :attr:`Effect.size` is filled in by
    :func:`apply_effect` where it depends on the robot (a holder's factor, a link's mass)."""
    if not in_library:
        kind = OUT_OF_LIBRARY[int(rng.integers(len(OUT_OF_LIBRARY)))]
        if kind == "hose_resonator":
            link = ("upper_arm", "forearm")[int(rng.integers(2))]
            return Effect(kind, link, {"mass": float(rng.uniform(5, 15)), "f_hz": float(rng.uniform(9, 30)),
                                       "zeta": 0.05}, False)
        if kind == "tendon_coupling":
            pair = _PAIRS[int(rng.integers(len(_PAIRS)))]
            return Effect(kind, "+".join(pair), {"fraction": float(rng.uniform(0.3, 0.8))}, False)
        body = ("forearm", "wrist", "flange")[int(rng.integers(3))]
        offset = rng.uniform(-1, 1, 3)
        offset *= float(rng.uniform(0.25, 0.4)) / np.linalg.norm(offset)
        return Effect(kind, body, {"mass": float(rng.uniform(8, 20)), "offset_m": offset.tolist()}, False)
    kind = IN_LIBRARY[int(rng.integers(len(IN_LIBRARY)))]
    if kind == "base_compliance":
        lateral = float(rng.uniform(30, 100))
        return Effect(kind, "base", {"lateral_um_per_kN": lateral}, True, lateral)
    if kind == "tool_contact_stiffness":
        f = logu(rng, 3.0, 5.0)
        return Effect(kind, "tool_contact", {"factor": f if rng.random() < 0.5 else 1 / f})
    if kind == "added_mass":
        body = _MASS_BODIES[int(rng.integers(len(_MASS_BODIES)))]
        return Effect(kind, body, {"fraction": float(rng.uniform(0.3, 0.6))})
    if kind == "sensor_misalignment":
        band = "low" if rng.random() < 0.5 else "high"
        coord = _COORDS[int(rng.integers(4))]
        angle = float(rng.choice([-1, 1]) * rng.uniform(6, 12))
        return Effect(kind, f"{band}:{coord}", {"angle_deg": angle}, True, angle)
    rpm = float(rng.uniform(12000, 24000))
    return Effect(kind, "spindle_spin", {"rpm": rpm}, True, rpm)


def apply_effect(root: ET.Element, effect: Effect, nominal: ET.Element) -> Effect:
    """Make ``effect``'s edit of the real robot ``root`` in place; returns the effect with its
    :attr:`~Effect.size` against the ``nominal`` MJCF's values (a holder's stiffness factor over
    the nominal's, spread included; the kilograms a body carries over the nominal's)."""
    v = effect.value
    if effect.kind == "base_compliance":
        mount_under(root, "slab", "slab_", "slide", v["lateral_um_per_kN"] * 1e-9)
    elif effect.kind == "tool_contact_stiffness":
        for name in _HOLDER:
            joint = _named(root, "joint", name)
            joint.set("stiffness", f"{float(joint.get('stiffness')) * v['factor']:.9g}")
        size = float(_named(root, "joint", _HOLDER[0]).get("stiffness")) / float(
            _named(nominal, "joint", _HOLDER[0]).get("stiffness"))
        return Effect(effect.kind, effect.location, v, True, size)
    elif effect.kind == "added_mass":
        inertial = _named(root, "body", effect.location).find("inertial")
        factor = 1.0 + v["fraction"]
        inertial.set("mass", f"{float(inertial.get('mass')) * factor:.9g}")
        for attr in ("diaginertia", "fullinertia"):
            if inertial.get(attr):
                inertial.set(attr, " ".join(f"{float(x) * factor:.9g}" for x in inertial.get(attr).split()))
        size = float(inertial.get("mass")) - float(_named(nominal, "body", effect.location).find("inertial").get("mass"))
        return Effect(effect.kind, effect.location, v, True, size)
    elif effect.kind == "hose_resonator":
        _resonator(_named(root, "body", effect.location), v["mass"], v["f_hz"], v["zeta"])
    elif effect.kind == "tendon_coupling":
        _coupling(root, effect.location.split("+"), v["fraction"])
    elif effect.kind == "offset_mass":
        body = ET.SubElement(_named(root, "body", effect.location), "body",
                             {"name": "offset_mass", "pos": " ".join(f"{x:.9g}" for x in v["offset_m"])})
        ET.SubElement(body, "inertial", {"pos": "0 0 0", "mass": f"{v['mass']:.9g}",
                                         "diaginertia": "1e-4 1e-4 1e-4"})
    return effect


def turned_signals(ds, effect: Effect):
    """The measured FRFs ``ds`` (``H`` over posture, freq, out, inp; ``band`` per line) with a turned
    sensor's signal as it reads: in its band, its output cos δ·own + sin δ·perpendicular (the
    other coordinate at its point, :data:`_PERPENDICULAR`); ``ds`` itself for any other effect."""
    if effect.kind != "sensor_misalignment":
        return ds
    band, coord = effect.location.split(":")
    other, sign = _PERPENDICULAR[coord]
    d = np.radians(effect.value["angle_deg"])
    out = ds.copy(deep=True)
    lines = np.asarray(ds["band"].values == band)
    own = ds.H.sel(out=coord).values[:, lines]
    perp = ds.H.sel(out=other).values[:, lines]
    i = list(ds.out.values).index(coord)
    h = out.H.values
    h[:, lines, i] = np.cos(d) * own + sign * np.sin(d) * perp
    out["H"] = (ds.H.dims, h)
    return out


def _named(root: ET.Element, tag: str, name: str) -> ET.Element:
    found = next((e for e in root.iter(tag) if e.get("name") == name), None)
    if found is None:
        raise ValueError(f"no {tag} named {name!r} in the robot")
    return found


def _resonator(link: ET.Element, mass: float, f_hz: float, zeta: float) -> None:
    """A package of ``mass`` kg 0.15 m off the link's axis on a lateral spring tuned to ``f_hz``
    against the link held still, ``zeta`` of critical."""
    k = mass * (2 * np.pi * f_hz) ** 2
    body = ET.SubElement(link, "body", {"name": "hose", "pos": "0.1 0.15 0.1"})
    ET.SubElement(body, "joint", {"name": "hose_y", "type": "slide", "axis": "0 1 0", "stiffness": f"{k:.9g}",
                                  "damping": f"{2 * zeta * np.sqrt(k * mass):.9g}"})
    r = 0.04
    i = 0.4 * mass * r * r
    ET.SubElement(body, "inertial", {"pos": "0 0 0", "mass": f"{mass:.9g}", "diaginertia": f"{i:.9g} {i:.9g} {i:.9g}"})


def _coupling(root: ET.Element, joints, fraction: float) -> None:
    """A fixed tendon on ``q0 − q1`` relaxed at zero, ``fraction`` of the softer joint's stiffness."""
    k = fraction * min(float(_named(root, "joint", j).get("stiffness").split()[0]) for j in joints)
    tendons = root.find("tendon")
    if tendons is None:
        tendons = ET.SubElement(root, "tendon")
    fixed = ET.SubElement(tendons, "fixed", {"name": "coupling", "stiffness": f"{k:.9g}", "springlength": "0"})
    for j, coef in zip(joints, ("1", "-1")):
        ET.SubElement(fixed, "joint", {"joint": j, "coef": coef})
