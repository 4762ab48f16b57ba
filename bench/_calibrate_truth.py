""""Real robots" for the calibration bench: the nominal MJCF with every ordinary parameter drawn.

The truth is made by editing the MJCF text (ElementTree), not by rmbench's parameter or variant
code, so that a bug shared by the calibration's model and the truth's construction cannot hide.
Returned with it are the true values in the calibration's parameter names (SI), for scoring.

Draws (each independent):
- every ``*_flex`` joint: stiffness × log-uniform 0.6-1.6, damping × log-uniform 0.5-2;
- every arm servo: kp × log-uniform 0.8-1.25;
- every link of 5 kg or more: mass (and its inertia) × uniform 0.9-1.1; its centre of mass moved
  ±20 mm in each component, and on two links drawn at random by up to ±0.15 m sideways (y);
- the tool-holder contact: translational and rotational stiffness × log-uniform 0.8-1.25;
- on half of the robots, a foundation that tilts: hinges about x and y under the arm, compliance
  uniform 20-100 µrad/(kN·m), 5 % damping, a 1000 kg plate.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

LINKS = ("carousel", "lower_arm", "upper_arm", "forearm", "wrist", "flange")
LATERAL = ("lower_arm", "upper_arm", "forearm", "flange")


def _logu(rng, lo, hi):
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _nums(text):
    return [float(v) for v in text.split()]


def _fmt(values):
    return " ".join(f"{v:.9g}" for v in values)


def draw_truth(nominal_xml: str, rng: np.random.Generator, *, base: bool) -> tuple[str, dict]:
    """The MJCF of one "real robot" and its true parameter values (SI, calibration names)."""
    root = ET.fromstring(nominal_xml)
    truth = {}
    joints = {j.get("name"): j for j in root.iter("joint")}
    bodies = {b.get("name"): b for b in root.iter("body")}
    for name, j in joints.items():
        if name.endswith("_flex"):
            k = float(j.get("stiffness").split()[0]) * _logu(rng, 0.6, 1.6)
            c = float(j.get("damping").split()[0]) * _logu(rng, 0.5, 2.0)
            j.set("stiffness", f"{k:.9g}")
            j.set("damping", f"{c:.9g}")
            truth[f"{name}.stiffness"], truth[f"{name}.damping"] = k, c
    for act in root.iter("general"):
        if act.get("joint", "").startswith("j") and act.get("joint") in joints and act.get("name") != "a_spin":
            gain, bias = _nums(act.get("gainprm")), _nums(act.get("biasprm"))
            kp = gain[0] * _logu(rng, 0.8, 1.25)
            gain[0], bias[1] = kp, -kp
            act.set("gainprm", _fmt(gain))
            act.set("biasprm", _fmt(bias))
            truth[f"{act.get('name')}.kp"] = kp
    sideways = set(rng.choice(LATERAL, 2, replace=False).tolist())
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
        truth[f"{name}.mass"] = m
        for i, axis in enumerate("xyz"):
            truth[f"{name}.com_{axis}"] = float(pos[i])
    k_ratio = {}
    for which, names in (("translation", ("tool_contact_x", "tool_contact_y")),
                         ("rotation", ("tool_contact_rx", "tool_contact_ry"))):
        f = _logu(rng, 0.8, 1.25)
        for n in names:
            k = float(joints[n].get("stiffness").split()[0]) * f
            joints[n].set("stiffness", f"{k:.9g}")
            k_ratio.setdefault(which, k)
        truth[f"tool_contact.{which}"] = k_ratio[which]
    truth["base.tilt_compliance"] = 0.0
    if base:
        c = float(rng.uniform(20, 100)) * 1e-9
        world = root.find("worldbody")
        arm = next(b for b in world if b.tag == "body")
        arm_mass = _subtree_mass(arm)
        k = 1 / c
        damping = 2 * 0.05 * np.sqrt(k * (arm_mass + 1000.0))
        mount = ET.Element("body", {"name": "foundation"})
        ET.SubElement(mount, "inertial", {"pos": "0 0 -0.05", "mass": "1000", "diaginertia": "120.8 120.8 240"})
        for axis, vec in (("x", "1 0 0"), ("y", "0 1 0")):
            ET.SubElement(mount, "joint", {"name": f"foundation_r{axis}", "axis": vec,
                                           "stiffness": f"{k:.9g}", "damping": f"{damping:.9g}"})
        index = list(world).index(arm)
        world.remove(arm)
        mount.append(arm)
        world.insert(index, mount)
        truth["base.tilt_compliance"] = c
    return ET.tostring(root, encoding="unicode"), truth


def _subtree_mass(body) -> float:
    total = 0.0
    for b in body.iter("body"):
        inertial = b.find("inertial")
        if inertial is not None:
            total += float(inertial.get("mass"))
        for g in b.findall("geom"):
            if g.get("mass"):
                total += float(g.get("mass"))
    return total
