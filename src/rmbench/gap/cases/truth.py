"""The blind cases' hidden effects as plain MJCF edits: the truth a diagnosis is scored on.

Written from the MJCF semantics alone (``xml.etree`` and numpy), never with the code that builds the
diagnosis's candidates or the calibration's parameters (:mod:`rmbench.robot.variant`,
:mod:`rmbench.robot.parameters`, :mod:`rmbench.calibrate`, the gap library), so that a bug shared by
a candidate and the truth it is scored on cannot hide. ``sim_tests/test_truth_independence.py``
checks the imports.

Each function edits ``root`` (the ElementTree element of a whole assembled MJCF, as
:attr:`rmbench.robot.Robot.xml` writes it: every inertial, stiffness, damping and servo gain
explicit on its element) in place, and writes numbers exactly (shortest round-trip text). An
attribute the edit needs but the element lacks (it would come from a default class) is an error,
never a silent zero.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from rmbench.errors import ModelError

__all__ = ["LOAD_STIFFNESS", "parse", "write", "scale_joint", "scale_servo_kp", "body_mass",
           "add_body_mass", "add_load_stiffness", "mount_on_springs", "add_resonator",
           "add_coupling", "attach_mass", "add_bending", "arm_mass"]

LOAD_STIFFNESS = "rmbench_load_stiffness"
"""The ``<custom><text>`` holding ``JOINT:ALPHA`` load-dependent stiffness coefficients
(:mod:`rmbench.robot.load_stiffness` documents the model the robot applies)."""


def parse(xml: str) -> ET.Element:
    """The element tree of an MJCF text (comments dropped)."""
    return ET.fromstring(xml)


def write(root: ET.Element) -> str:
    """The MJCF text of an element tree."""
    return ET.tostring(root, encoding="unicode")


def scale_joint(root: ET.Element, joint: str, field: str, factor: float) -> float:
    """Multiply a joint's ``stiffness`` (N/m or N·m/rad) or ``damping`` (N·s/m or N·m·s/rad) by
    ``factor``; returns the new value."""
    if field not in ("stiffness", "damping"):
        raise ModelError(f"scale_joint: field must be stiffness or damping, got {field!r}")
    values = _numbers(_named(root, "joint", joint), field)
    values[0] *= float(factor)
    if values[0] < 0:
        raise ModelError(f"joint {joint!r}: {field} must stay non-negative, got {values[0]}")
    _named(root, "joint", joint).set(field, _text(values))
    return values[0]


def scale_servo_kp(root: ET.Element, actuator: str, factor: float) -> float:
    """Multiply a position servo's proportional gain kp by ``factor``; returns the new kp.

    A position servo is a ``<general>`` with force ``gainprm[0]·ctrl + biasprm[1]·q +
    biasprm[2]·q̇`` and ``biasprm[1] = −gainprm[0] = −kp``: both entries change.
    """
    element = _named(root, "general", actuator)
    gain, bias = _numbers(element, "gainprm"), _numbers(element, "biasprm")
    if len(bias) < 2 or not gain[0] > 0 or bias[1] != -gain[0]:
        raise ModelError(f"actuator {actuator!r} is not a position servo (biasprm[1] = -gainprm[0])")
    kp = gain[0] * float(factor)
    if not kp > 0:
        raise ModelError(f"actuator {actuator!r}: kp must stay positive, got {kp}")
    gain[0], bias[1] = kp, -kp
    element.set("gainprm", _text(gain))
    element.set("biasprm", _text(bias))
    return kp


def body_mass(root: ET.Element, body: str) -> float:
    """Mass of a body's explicit ``<inertial>``, kg."""
    return _numbers(_inertial(root, body), "mass")[0]


def add_body_mass(root: ET.Element, body: str, dm: float) -> float:
    """Add ``dm`` kg to a body's inertial at its centre of mass, its rotary inertia unchanged (a
    point mass at the centre); returns the new mass."""
    inertial = _inertial(root, body)
    m = _numbers(inertial, "mass")[0] + float(dm)
    if not m > 0:
        raise ModelError(f"body {body!r}: mass must stay positive, got {m}")
    inertial.set("mass", _text([m]))
    return m


def add_load_stiffness(root: ET.Element, coeffs: dict) -> None:
    """Give joints a load-dependent stiffness: ``JOINT:ALPHA`` entries in the
    ``rmbench_load_stiffness`` text, added to those the robot has (a joint named again takes the
    new α; α = 0 removes the joint's entry)."""
    custom = root.find("custom")
    if custom is None:
        custom = ET.SubElement(root, "custom")
    text = next((t for t in custom.findall("text") if t.get("name") == LOAD_STIFFNESS), None)
    merged = {}
    if text is not None:
        for entry in text.get("data", "").replace(",", " ").split():
            name, _, alpha = entry.partition(":")
            merged[name] = float(alpha)
    for name, alpha in coeffs.items():
        _named(root, "joint", name)
        if not np.isfinite(alpha) or alpha < 0:
            raise ModelError(f"load-dependent stiffness of {name!r} must be finite and >= 0, got {alpha}")
        merged[name] = float(alpha)
    merged = {n: a for n, a in merged.items() if a != 0}
    if text is not None:
        custom.remove(text)
    if merged:
        ET.SubElement(custom, "text", {"name": LOAD_STIFFNESS,
                                       "data": " ".join(f"{n}:{a!r}" for n, a in merged.items())})


def mount_on_springs(root: ET.Element, k_lateral: float, k_tilt: float, *, damping_ratio: float = 0.05,
                     plate_mass: float = 1000.0) -> None:
    """Stand the arm on a compliant foundation: a plate ``base_mount`` free on six springs.

    The plate (``plate_mass`` kg, a 1.2 × 1.2 × 0.1 m box under the world origin) slides along x,
    y (``k_lateral`` N/m) and z (5 ``k_lateral``) and turns about x, y and z (``k_tilt`` N·m/rad),
    joints ``base_x`` ... ``base_rz`` at the origin; each damper is ``damping_ratio`` of critical
    against the mass of arm and plate (for the turns: that mass at 1 m). The arm (the first body
    of the world) moves under the plate unchanged.
    """
    for name, k in (("k_lateral", k_lateral), ("k_tilt", k_tilt)):
        if not k > 0:
            raise ModelError(f"{name} must be positive, got {k}")
    world = root.find("worldbody")
    if any(b.get("name") == "base_mount" for b in root.iter("body")):
        raise ModelError("the robot already stands on a compliant base")
    arm = next((b for b in world if b.tag == "body"), None)
    if arm is None:
        raise ModelError("the robot has no moving body to stand on a compliant base")
    m = arm_mass(arm) + plate_mass
    a, b, c = 1.2, 1.2, 0.1                               # the plate's edges, m
    inertia = plate_mass / 12 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    plate = ET.Element("body", {"name": "base_mount"})
    ET.SubElement(plate, "inertial", {"pos": "0 0 -0.05", "mass": _text([plate_mass]),
                                      "diaginertia": _text(inertia)})
    for name, kind, axis, k in (("base_x", "slide", "1 0 0", k_lateral), ("base_y", "slide", "0 1 0", k_lateral),
                                ("base_z", "slide", "0 0 1", 5 * k_lateral), ("base_rx", "hinge", "1 0 0", k_tilt),
                                ("base_ry", "hinge", "0 1 0", k_tilt), ("base_rz", "hinge", "0 0 1", k_tilt)):
        ET.SubElement(plate, "joint", {"name": name, "type": kind, "pos": "0 0 0", "axis": axis,
                                       "stiffness": _text([k]),
                                       "damping": _text([2 * damping_ratio * np.sqrt(k * m)])})
    ET.SubElement(plate, "geom", {"type": "box", "size": "0.6 0.6 0.05", "pos": "0 0 -0.05", "mass": "0",
                                  "contype": "0", "conaffinity": "0", "rgba": "0.4 0.4 0.4 1"})
    index = list(world).index(arm)
    world.remove(arm)
    plate.append(arm)
    world.insert(index, plate)


def add_resonator(root: ET.Element, link: str, mass: float, f_hz: float, zeta: float, *,
                  pos=(0.1, 0.15, 0.1), axis=(0.0, 1.0, 0.0)) -> None:
    """A hose package on ``link``: a sphere of ``mass`` kg (radius 40 mm) at ``pos`` (m, link
    frame) on a spring along ``axis`` tuned to ``f_hz`` against the link held still, damped
    ``zeta`` of critical. Body ``hose_package``, joint ``hose_slide``."""
    k = mass * (2 * np.pi * f_hz) ** 2
    hose = ET.SubElement(_named(root, "body", link), "body", {"name": "hose_package", "pos": _text(pos)})
    ET.SubElement(hose, "joint", {"name": "hose_slide", "type": "slide", "pos": "0 0 0", "axis": _text(axis),
                                  "stiffness": _text([k]), "damping": _text([2 * zeta * np.sqrt(k * mass)])})
    ET.SubElement(hose, "geom", {"type": "sphere", "size": "0.04", "mass": _text([mass]),
                                 "contype": "0", "conaffinity": "0"})


def add_coupling(root: ET.Element, joints, fraction: float) -> float:
    """A spring on the difference of two joints' angles (a fixed tendon ``coupling``, lengths
    ``q0 − q1``, relaxed at zero), of stiffness ``fraction`` of the softer joint's; returns it."""
    first, second = joints
    k = fraction * min(_numbers(_named(root, "joint", j), "stiffness")[0] for j in (first, second))
    tendons = root.find("tendon")
    if tendons is None:
        tendons = ET.SubElement(root, "tendon")
    fixed = ET.SubElement(tendons, "fixed", {"name": "coupling", "stiffness": _text([k]), "springlength": "0"})
    ET.SubElement(fixed, "joint", {"joint": first, "coef": "1"})
    ET.SubElement(fixed, "joint", {"joint": second, "coef": "-1"})
    return k


def attach_mass(root: ET.Element, body: str, mass: float, offset=(0.0, 0.0, 0.0)) -> str:
    """A point mass (a 4 mm sphere of ``mass`` kg) fixed to ``body`` at ``offset`` (m, body
    frame); returns its body's name, ``point_massN``."""
    if not mass > 0:
        raise ModelError(f"point mass must be positive, got {mass}")
    n = sum(1 for b in root.iter("body") if (b.get("name") or "").startswith("point_mass"))
    name = f"point_mass{n + 1}"
    child = ET.SubElement(_named(root, "body", body), "body", {"name": name, "pos": _text(offset)})
    ET.SubElement(child, "geom", {"type": "sphere", "size": "0.004", "mass": _text([mass]),
                                  "contype": "0", "conaffinity": "0", "rgba": "1 0 1 1"})
    return name


def add_bending(root: ET.Element, link: str, root_joint: str, pos, axis, compliance_ratio: float) -> str:
    """A hinge ``<link>_bending`` in ``link`` at ``pos`` about ``axis`` (link frame), after the
    link's own joints, whose stiffness and damping are the root joint's over ``compliance_ratio``
    (its compliance that ratio of the root joint's); returns the hinge's name."""
    source = _named(root, "joint", root_joint)
    k = _numbers(source, "stiffness")[0] / compliance_ratio
    c = _numbers(source, "damping")[0] / compliance_ratio
    body = _named(root, "body", link)
    name = f"{link}_bending"
    hinge = ET.Element("joint", {"name": name, "type": "hinge", "pos": _text(pos), "axis": _text(axis),
                                 "stiffness": _text([k]), "damping": _text([c])})
    children = list(body)
    last = max((i for i, e in enumerate(children) if e.tag == "joint"), default=-1)
    body.insert(last + 1, hinge)
    return name


def arm_mass(body: ET.Element) -> float:
    """Mass of a body and everything on it, kg: each body's explicit ``<inertial>``, else the
    explicit masses of its geoms (as MuJoCo reads a body's mass)."""
    total = 0.0
    for b in body.iter("body"):
        inertial = b.find("inertial")
        if inertial is not None:
            total += _numbers(inertial, "mass")[0]
            continue
        for g in b.findall("geom"):
            if g.get("mass") is None:
                raise ModelError(f"body {b.get('name')!r}: a geom without an explicit mass")
            total += float(g.get("mass"))
    return total


def _named(root: ET.Element, tag: str, name: str) -> ET.Element:
    found = [e for e in root.iter(tag) if e.get("name") == name]
    if len(found) != 1:
        raise ModelError(f"the robot has {len(found)} <{tag}> named {name!r}, not one")
    return found[0]


def _inertial(root: ET.Element, body: str) -> ET.Element:
    inertial = _named(root, "body", body).find("inertial")
    if inertial is None:
        raise ModelError(f"body {body!r} has no explicit <inertial>")
    return inertial


def _numbers(element: ET.Element, attr: str) -> list[float]:
    text = element.get(attr)
    if text is None:
        raise ModelError(f"<{element.tag} name={element.get('name')!r}> has no explicit {attr}")
    return [float(v) for v in text.split()]


def _text(values) -> str:
    return " ".join(repr(float(v)) for v in values)
