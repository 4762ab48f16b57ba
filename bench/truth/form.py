"""Model-form errors of a "real robot": physics the calibrated model has no parameter for.

Every real robot differs from its model in form as well as in parameter values. Each kind here is
one such difference, made by plain ElementTree edits of the MJCF (no rmbench parameter, variant,
calibration or diagnosis code), drawn at a random size and place:

======================  ==============================  ====================================================
kind                    location                        what the edit adds
======================  ==============================  ====================================================
``bearing_tilt``        ``j1``, ``j2``, ``j3``          two hinges normal to the joint's axis at its
                                                        bearing, compliance c (rad/(N·m))
``bending_link``        ``lower_arm``, ``forearm``      the link split at mid-length, its distal half on two
                                                        bending hinges, compliance c (rad/(N·m))
``counterbalance``      ``j2``                          a spring (spatial tendon) from the carousel to the
                                                        lower arm: stiffness k (N/m), preload F (N); its
                                                        stiffness about j2 follows the posture
``cable_bundle``        ``lower_arm``, ``forearm``      three masses along the link on their own lateral
                                                        springs: total mass m (kg), resonances f (Hz)
``gear_nonlinear``      ``j2``, ``j3``                  a second gear spring that engages beyond a backlash
                                                        δ (rad): ratio r of the gear's stiffness; the
                                                        stiffness follows the gravity load
``foundation_skew``     ``base``                        a foundation whose sliding and tilting compliances
                                                        differ along axes at an angle θ to the robot's, of
                                                        its own mass (replaces a foundation drawn before)
======================  ==============================  ====================================================

Not a kind: a rotor inertia unlike the data sheet's. The stiff position servo holds the motor side
(kp 3-80 MN·m/rad against 4-150 kg·m² of armature), so the motor-side modes lie at 100-150 Hz,
between the tested bands (4-40 Hz, 600-1400 Hz): twice or half the armature moves no mode in
them by 0.01 % (measured at three postures).

:func:`draw_form` draws one error of a kind; :func:`apply_form` makes its edit. The sizes are
drawn from ranges stated per kind (:data:`RANGES`), scaled by the bench's ``scale``; the bench,
not this module, decides which robots get which kinds.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np

__all__ = ["FORM_KINDS", "RANGES", "FormError", "draw_form", "median_form", "apply_form"]

FORM_KINDS = ("bearing_tilt", "bending_link", "counterbalance", "cable_bundle", "gear_nonlinear",
              "foundation_skew")

RANGES = {
    # a main axis's cross-roller bearing: 7-50 GN·m/rad against the gearbox's 1-4 MN·m/rad
    "bearing_tilt": {"compliance": (20e-9, 150e-9)},
    # a link's bending at mid-length, lumped: 2.5-20 MN·m/rad (a 0.9 m tube of EI 1.7 MN·m² turns
    # its end by L/EI = 260 µrad/(kN·m))
    "bending_link": {"compliance": (50e-9, 400e-9)},
    # a gas-spring counterbalance: 0.5-5 MN/m, preload 2-20 kN
    "counterbalance": {"stiffness": (5e5, 5e6), "preload": (2e3, 20e3)},
    # dress pack and hoses along a link: 3-15 kg, lateral resonances 10-40 Hz, 5-15 % damping
    "cable_bundle": {"mass": (3.0, 15.0), "frequency": (10.0, 40.0), "damping_ratio": (0.05, 0.15)},
    # a hardening gear: a second spring 0.1-0.5 times the first beyond a backlash of 0.3-2 mrad
    "gear_nonlinear": {"ratio": (0.1, 0.5), "backlash": (0.3e-3, 2e-3)},
    # a foundation: sliding 3-30 µm/kN and tilting 20-100 µrad/(kN·m) per axis, 500-3000 kg,
    # 2-8 % damping, axes at 0-90° to the robot's
    "foundation_skew": {"lateral": (3e-9, 30e-9), "tilt": (20e-9, 100e-9), "mass": (500.0, 3000.0),
                        "damping_ratio": (0.02, 0.08), "angle": (0.0, np.pi / 2)},
}

_TILT_BODIES = {"j1": "carousel", "j2": "lower_arm", "j3": "upper_arm"}
# a link's distal child and the link's direction in its own frame
_LINKS = {"lower_arm": ("motor3", (0.0, 0.0, 1.0)), "forearm": ("motor5", (1.0, 0.0, 0.0))}
_GEARS = {"j2": "j2_flex", "j3": "j3_flex"}
_LOSS = 3e-4        # s: a hinge's damping over its stiffness (3 % of critical near 30 Hz)
# the bodies a foundation of the bench's is made of (the spread's tilting one, a sliding one, this)
_FOUNDATIONS = ("foundation", "slab", "foundation_skew")


@dataclass(frozen=True)
class FormError:
    """One model-form error of a real robot.

    Attributes
    ----------
    kind : str
        One of :data:`FORM_KINDS`.
    location : str
        Where it acts (a joint, a link, ``base``; several joints joined by ``+``).
    size : dict
        Its drawn values, SI (``compliance`` rad/(N·m), ``stiffness`` N/m, ``mass`` kg, ...).
    """

    kind: str
    location: str
    size: dict = field(default_factory=dict)

    @property
    def name(self) -> str:
        return f"{self.kind}@{self.location}"

    def to_dict(self) -> dict:
        return {"kind": self.kind, "location": self.location,
                "size": {k: (list(v) if isinstance(v, (list, tuple)) else float(v)) for k, v in self.size.items()}}


def _logu(rng, lo, hi) -> float:
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def draw_form(rng: np.random.Generator, kind: str, *, scale: float = 1.0) -> FormError:
    """One form error of ``kind`` at a place and size drawn from ``rng`` (its compliance, stiffness
    or mass drawn in :data:`RANGES`, times ``scale``; a factor's logarithm times ``scale``)."""
    r = RANGES[kind]
    pick = (lambda options: options[int(rng.integers(len(options)))])
    if kind == "bearing_tilt":
        return FormError(kind, pick(tuple(_TILT_BODIES)), {"compliance": scale * _logu(rng, *r["compliance"])})
    if kind == "bending_link":
        return FormError(kind, pick(tuple(_LINKS)), {"compliance": scale * _logu(rng, *r["compliance"])})
    if kind == "counterbalance":
        return FormError(kind, "j2", {"stiffness": scale * _logu(rng, *r["stiffness"]),
                                      "preload": scale * float(rng.uniform(*r["preload"]))})
    if kind == "cable_bundle":
        return FormError(kind, pick(tuple(_LINKS)),
                         {"mass": scale * float(rng.uniform(*r["mass"])),
                          "frequency": [_logu(rng, *r["frequency"]) for _ in range(3)],
                          "damping_ratio": float(rng.uniform(*r["damping_ratio"]))})
    if kind == "gear_nonlinear":
        return FormError(kind, pick(tuple(_GEARS)), {"ratio": scale * float(rng.uniform(*r["ratio"])),
                                                     "backlash": float(rng.uniform(*r["backlash"]))})
    if kind == "foundation_skew":
        return FormError(kind, "base", {"lateral": [scale * _logu(rng, *r["lateral"]) for _ in range(2)],
                                        "tilt": [scale * _logu(rng, *r["tilt"]) for _ in range(2)],
                                        "mass": _logu(rng, *r["mass"]),
                                        "damping_ratio": float(rng.uniform(*r["damping_ratio"])),
                                        "angle": float(rng.uniform(*r["angle"]))})
    raise ValueError(f"unknown form kind {kind!r}; one of {', '.join(FORM_KINDS)}")


# the sizes :func:`draw_form`'s ``scale`` multiplies, per kind
SCALED = {"bearing_tilt": ("compliance",), "bending_link": ("compliance",), "counterbalance": ("stiffness", "preload"),
          "cable_bundle": ("mass",), "gear_nonlinear": ("ratio",), "foundation_skew": ("lateral", "tilt")}


def median_form(kind: str, location: str | None = None, *, scale: float = 1.0) -> FormError:
    """The error of ``kind`` at the middle of its ranges (geometric for sizes, arithmetic for a
    damping ratio, a backlash or an angle), at ``location`` (default: the first place it can act),
    with the sizes :func:`draw_form` scales (:data:`SCALED`) times ``scale``."""
    places = {"bearing_tilt": tuple(_TILT_BODIES), "bending_link": tuple(_LINKS), "counterbalance": ("j2",),
              "cable_bundle": tuple(_LINKS), "gear_nonlinear": tuple(_GEARS), "foundation_skew": ("base",)}
    if kind not in places:
        raise ValueError(f"unknown form kind {kind!r}; one of {', '.join(FORM_KINDS)}")
    arithmetic = ("damping_ratio", "backlash", "angle", "ratio", "preload")
    size = {k: float(np.mean(r) if k in arithmetic else np.sqrt(r[0] * r[1])) for k, r in RANGES[kind].items()}
    if kind == "cable_bundle":
        size["frequency"] = [size["frequency"]] * 3
    if kind == "foundation_skew":
        size["lateral"], size["tilt"] = [size["lateral"]] * 2, [size["tilt"]] * 2
    for k in SCALED[kind]:
        size[k] = [scale * v for v in size[k]] if isinstance(size[k], list) else scale * size[k]
    return FormError(kind, location or places[kind][0], size)


def apply_form(root: ET.Element, error: FormError) -> None:
    """Make ``error``'s edit in the MJCF ``root`` (an ElementTree element of the whole model), in
    place."""
    k, loc, s = error.kind, error.location, error.size
    bodies = {b.get("name"): b for b in root.iter("body")}
    if k == "bearing_tilt":
        link = bodies[_TILT_BODIES[loc]]
        axis = _axis(link.find("joint"))
        _hinges(link, f"{loc}_tilt", _normals(axis), 1.0 / s["compliance"], first=True)
    elif k == "bending_link":
        _bend(bodies[loc], loc, 1.0 / s["compliance"])
    elif k == "counterbalance":
        _counterbalance(root, bodies, s["stiffness"], s["preload"])
    elif k == "cable_bundle":
        _bundle(bodies[loc], loc, s["mass"], s["frequency"], s["damping_ratio"])
    elif k == "gear_nonlinear":
        _second_gear(root, _GEARS[loc], s["ratio"], s["backlash"])
    elif k == "foundation_skew":
        _skewed_foundation(root, s)
    else:
        raise ValueError(f"unknown form kind {k!r}; one of {', '.join(FORM_KINDS)}")


# -- the edits ------------------------------------------------------------------------------------
def _nums(text: str | None, default=(0.0, 0.0, 0.0)) -> np.ndarray:
    return np.array([float(v) for v in text.split()]) if text else np.array(default, float)


def _fmt(values) -> str:
    return " ".join(f"{float(v):.9g}" for v in values)


def _axis(joint: ET.Element) -> np.ndarray:
    a = _nums(joint.get("axis"), (0.0, 0.0, 1.0))
    return a / np.linalg.norm(a)


def _normals(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors normal to ``axis`` and to each other."""
    e = np.eye(3)[int(np.argmin(np.abs(axis)))]
    u = np.cross(axis, e)
    u /= np.linalg.norm(u)
    return u, np.cross(axis, u)


def _hinges(body: ET.Element, stem: str, axes, k: float, *, first: bool = False) -> None:
    """Two hinges ``<stem>_a``, ``<stem>_b`` about ``axes`` at the body's origin, stiffness ``k``
    (N·m/rad), damped in proportion (:data:`_LOSS`); before the body's own joints where ``first``."""
    at = 0
    if first:
        at = next((i for i, c in enumerate(body) if c.tag == "joint"), len(body))
    elif body.find("inertial") is not None:
        at = list(body).index(body.find("inertial")) + 1
    for i, (suffix, a) in enumerate(zip("ab", axes)):
        body.insert(at + i, ET.Element("joint", {"name": f"{stem}_{suffix}", "axis": _fmt(a),
                                                 "stiffness": f"{k:.9g}", "damping": f"{_LOSS * k:.9g}"}))


def _bend(link: ET.Element, name: str, k: float) -> None:
    """The link's distal child moved onto a body at mid-length held by two bending hinges."""
    child_name, direction = _LINKS[name]
    child = next(b for b in link.findall("body") if b.get("name") == child_name)
    end = _nums(child.get("pos"))
    mid = 0.5 * end
    distal = ET.Element("body", {"name": f"{name}_distal", "pos": _fmt(mid)})
    ET.SubElement(distal, "inertial", {"pos": "0 0 0", "mass": "0.5", "diaginertia": "0.001 0.001 0.001"})
    _hinges(distal, f"{name}_bend", _normals(np.array(direction)), k)
    link.remove(child)
    child.set("pos", _fmt(end - mid))
    distal.append(child)
    link.append(distal)


def _counterbalance(root: ET.Element, bodies: dict, k: float, preload: float) -> None:
    """A spring from a point behind and above j2 on the carousel to the lower arm, stretched by
    ``preload / k`` at the arm's zero posture."""
    j2 = _nums(bodies["motor2"].get("pos"))
    a = j2 + np.array([-0.4, 0.0, 0.3])          # on the carousel, in its frame (j2 in it at motor2's place)
    b = np.array([-0.1, 0.0, 0.4])               # on the lower arm, in its frame (its origin on j2)
    ET.SubElement(bodies["carousel"], "site", {"name": "counterbalance_a", "pos": _fmt(a)})
    ET.SubElement(bodies["lower_arm"], "site", {"name": "counterbalance_b", "pos": _fmt(b)})
    length = float(np.linalg.norm(j2 + b - a))
    tendon = root.find("tendon")
    if tendon is None:
        tendon = ET.SubElement(root, "tendon")
    spring = ET.SubElement(tendon, "spatial", {"name": "counterbalance", "stiffness": f"{k:.9g}",
                                               "springlength": f"{length - preload / k:.9g}",
                                               "damping": f"{_LOSS * k:.9g}"})
    ET.SubElement(spring, "site", {"site": "counterbalance_a"})
    ET.SubElement(spring, "site", {"site": "counterbalance_b"})


def _bundle(link: ET.Element, name: str, mass: float, freqs, zeta: float) -> None:
    """Three equal masses at a quarter, half and three quarters of the link, 0.15 m to its side,
    each on two lateral springs tuned to its resonance."""
    child_name, direction = _LINKS[name]
    child = next(b for b in link.iter("body") if b.get("name") == child_name)
    # the link's length: to its distal child, wherever a bending split moved it
    parent_pos = np.zeros(3) if child in list(link) else _nums(next(
        b for b in link.findall("body") if child in list(b)).get("pos"))
    length = float(np.linalg.norm(parent_pos + _nums(child.get("pos"))))
    d = np.array(direction)
    side, up = _normals(d)
    m = mass / 3
    for i, (frac, f) in enumerate(zip((0.25, 0.5, 0.75), freqs)):
        k = m * (2 * np.pi * f) ** 2
        body = ET.SubElement(link, "body", {"name": f"{name}_bundle_{i}", "pos": _fmt(frac * length * d + 0.15 * side)})
        ET.SubElement(body, "inertial", {"pos": "0 0 0", "mass": f"{m:.9g}",
                                         "diaginertia": _fmt([1e-3 * m] * 3)})
        for suffix, a in zip("ab", (side, up)):
            ET.SubElement(body, "joint", {"name": f"{name}_bundle_{i}{suffix}", "type": "slide", "axis": _fmt(a),
                                          "stiffness": f"{k:.9g}", "damping": f"{2 * zeta * np.sqrt(k * m):.9g}"})


def _second_gear(root: ET.Element, joint: str, ratio: float, backlash: float) -> None:
    """A fixed tendon on the gear's joint with ``ratio`` times its stiffness, slack within
    ±``backlash`` rad (MuJoCo's spring dead band)."""
    k = float(next(j for j in root.iter("joint") if j.get("name") == joint).get("stiffness").split()[0])
    tendon = root.find("tendon")
    if tendon is None:
        tendon = ET.SubElement(root, "tendon")
    fixed = ET.SubElement(tendon, "fixed", {"name": f"{joint}_second_gear", "stiffness": f"{ratio * k:.9g}",
                                            "springlength": f"{-backlash:.9g} {backlash:.9g}"})
    ET.SubElement(fixed, "joint", {"joint": joint, "coef": "1"})


def _skewed_foundation(root: ET.Element, s: dict) -> None:
    """The arm on a slab of its own mass, sliding and tilting along axes at ``angle`` to the
    robot's, with a compliance each; any foundation drawn before it is removed."""
    world = root.find("worldbody")
    arm = next(b for b in world if b.tag == "body")
    while arm.get("name") in _FOUNDATIONS:     # a foundation drawn before: taken away
        inner = next(b for b in arm if b.tag == "body")
        index = list(world).index(arm)
        world.remove(arm)
        world.insert(index, inner)
        arm = inner
    m = s["mass"]
    c, sn = np.cos(s["angle"]), np.sin(s["angle"])
    u, v = np.array([c, sn, 0.0]), np.array([-sn, c, 0.0])
    carried = m + _subtree_mass(arm)
    slab = ET.Element("body", {"name": "foundation_skew"})
    # a 2 m square slab 0.3 m thick of that mass
    ET.SubElement(slab, "inertial", {"pos": "0 0 -0.15", "mass": f"{m:.9g}",
                                     "diaginertia": _fmt([m * (4 + 0.09) / 12, m * (4 + 0.09) / 12, m * 8 / 12])})
    # the damping ratio against the mass carried (at 1 m for the tilt: kg·m²)
    for name, kind, axis, comp in (("skew_u", "slide", u, s["lateral"][0]), ("skew_v", "slide", v, s["lateral"][1]),
                                   ("skew_ru", "hinge", u, s["tilt"][0]), ("skew_rv", "hinge", v, s["tilt"][1])):
        k = 1.0 / comp
        ET.SubElement(slab, "joint", {"name": name, "type": kind, "axis": _fmt(axis), "stiffness": f"{k:.9g}",
                                      "damping": f"{2 * s['damping_ratio'] * np.sqrt(k * carried):.9g}"})
    index = list(world).index(arm)
    world.remove(arm)
    slab.append(arm)
    world.insert(index, slab)


def _subtree_mass(body: ET.Element) -> float:
    total = 0.0
    for b in body.iter("body"):
        inertial = b.find("inertial")
        if inertial is not None:
            total += float(inertial.get("mass"))
    return total
