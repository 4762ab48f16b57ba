"""The ordinary spread of a "real robot": plain MJCF edits (ElementTree) that draw it from its
nominal, shared by the FRF, calibration and control benches' truth (:mod:`truth.robot`,
:mod:`truth.control`, :mod:`truth.structural`). No rmbench parameter or variant code is used, so a
bug shared by a method's model and the truth it is scored on cannot hide.

Each function edits ``root`` (an ElementTree element of the whole MJCF) in place, draws from ``rng``
in a fixed order and returns what it drew (SI).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

__all__ = ["LINKS", "LATERAL", "logu", "draw_flex_joints", "draw_servos", "draw_links", "mount_on_foundation",
           "mount_under", "subtree_mass", "draw_ordinary"]

LINKS = ("carousel", "lower_arm", "upper_arm", "forearm", "wrist", "flange")
LATERAL = ("lower_arm", "upper_arm", "forearm", "flange")


def logu(rng, lo, hi):
    """A draw log-uniform between ``lo`` and ``hi``."""
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _nums(text):
    return [float(v) for v in text.split()]


def _fmt(values):
    return " ".join(f"{v:.9g}" for v in values)


def draw_flex_joints(root, rng) -> dict:
    """Every ``*_flex`` joint: stiffness × log-uniform 0.6-1.6, damping × log-uniform 0.5-2.
    Returns ``{"<joint>.stiffness": k, "<joint>.damping": c}``."""
    truth = {}
    for j in root.iter("joint"):
        name = j.get("name")
        if name and name.endswith("_flex"):
            k = float(j.get("stiffness").split()[0]) * logu(rng, 0.6, 1.6)
            c = float(j.get("damping").split()[0]) * logu(rng, 0.5, 2.0)
            j.set("stiffness", f"{k:.9g}")
            j.set("damping", f"{c:.9g}")
            truth[f"{name}.stiffness"], truth[f"{name}.damping"] = k, c
    return truth


def draw_servos(root, rng, is_servo) -> dict:
    """The arm's position servos (the ``general`` actuators, as the assembled MJCF writes them, for
    which ``is_servo(element)`` holds): kp × log-uniform 0.8-1.25. Returns ``{"<actuator>.kp": kp}``."""
    truth = {}
    for act in root.iter("general"):
        if is_servo(act):
            gain, bias = _nums(act.get("gainprm")), _nums(act.get("biasprm"))
            kp = gain[0] * logu(rng, 0.8, 1.25)
            gain[0], bias[1] = kp, -kp
            act.set("gainprm", _fmt(gain))
            act.set("biasprm", _fmt(bias))
            truth[f"{act.get('name')}.kp"] = kp
    return truth


def draw_links(root, rng) -> dict:
    """Every link of :data:`LINKS`: mass (and its inertia) × uniform 0.9-1.1; its centre of mass
    moved ±20 mm in each component, and on two links of :data:`LATERAL` drawn at random by up to
    ±0.15 m sideways (y). Returns ``{link: (mass kg, centre of mass (3,) m)}``."""
    bodies = {b.get("name"): b for b in root.iter("body")}
    sideways = set(rng.choice(LATERAL, 2, replace=False).tolist())
    out = {}
    for name in LINKS:
        inertial = bodies[name].find("inertial")
        f = float(rng.uniform(0.9, 1.1))
        m = float(inertial.get("mass")) * f
        inertial.set("mass", f"{m:.9g}")
        inertial.set("diaginertia", _fmt(np.array(_nums(inertial.get("diaginertia"))) * f))
        pos = np.array(_nums(inertial.get("pos"))) + rng.uniform(-0.02, 0.02, 3)
        if name in sideways:
            pos[1] = float(rng.uniform(-0.15, 0.15))
        inertial.set("pos", _fmt(pos))
        out[name] = (m, pos)
    return out


def mount_on_foundation(root, rng) -> float:
    """Put the arm on a foundation that tilts: hinges about x and y under it, compliance uniform
    20-100 µrad/(kN·m) (:func:`mount_under`). Returns the compliance, rad/(N·m)."""
    c = float(rng.uniform(20, 100)) * 1e-9
    mount_under(root, "foundation", "foundation_r", "hinge", c)
    return c


def mount_under(root, name: str, joint: str, kind: str, c: float) -> None:
    """Put whatever the robot stands on onto a 1000 kg plate ``name`` held by two joints
    ``<joint>x`` and ``<joint>y`` of ``kind`` ("hinge": tilting about x and y, compliance ``c``
    rad/(N·m); "slide": sliding along them, ``c`` m/N), 5 % damping against arm and plate."""
    world = root.find("worldbody")
    arm = next(b for b in world if b.tag == "body")
    k = 1 / c
    damping = 2 * 0.05 * np.sqrt(k * (subtree_mass(arm) + 1000.0))
    mount = ET.Element("body", {"name": name})
    ET.SubElement(mount, "inertial", {"pos": "0 0 -0.05", "mass": "1000", "diaginertia": "120.8 120.8 240"})
    for axis, vec in (("x", "1 0 0"), ("y", "0 1 0")):
        attrs = {"name": f"{joint}{axis}"} | ({"type": "slide"} if kind == "slide" else {})
        ET.SubElement(mount, "joint", attrs | {"axis": vec, "stiffness": f"{k:.9g}", "damping": f"{damping:.9g}"})
    index = list(world).index(arm)
    world.remove(arm)
    mount.append(arm)
    world.insert(index, mount)


def subtree_mass(body) -> float:
    """Mass of a body and everything below it (inertials and geom masses), kg."""
    total = 0.0
    for b in body.iter("body"):
        inertial = b.find("inertial")
        if inertial is not None:
            total += float(inertial.get("mass"))
        for g in b.findall("geom"):
            if g.get("mass"):
                total += float(g.get("mass"))
    return total


def draw_ordinary(root, rng) -> dict:
    """Every ordinary parameter a calibration fits, drawn in place in this order: the ``*_flex``
    joints (:func:`draw_flex_joints`), the arm's servos (:func:`draw_servos`), the links
    (:func:`draw_links`) and the tool holder's contact (translational and rotational stiffness ×
    log-uniform 0.8-1.25 each). Returns the true values by the calibration's parameter names (SI)."""
    joints = {j.get("name"): j for j in root.iter("joint")}
    truth = draw_flex_joints(root, rng)
    truth.update(draw_servos(root, rng, lambda act: act.get("joint", "").startswith("j")
                             and act.get("joint") in joints and act.get("name") != "a_spin"))
    for name, (m, pos) in draw_links(root, rng).items():
        truth[f"{name}.mass"] = m
        for i, axis in enumerate("xyz"):
            truth[f"{name}.com_{axis}"] = float(pos[i])
    for which, names in (("translation", ("tool_contact_x", "tool_contact_y")),
                         ("rotation", ("tool_contact_rx", "tool_contact_ry"))):
        f = logu(rng, 0.8, 1.25)
        drawn = [float(joints[n].get("stiffness").split()[0]) * f for n in names]
        for n, k in zip(names, drawn):
            joints[n].set("stiffness", f"{k:.9g}")
        truth[f"tool_contact.{which}"] = drawn[0]
    return truth
