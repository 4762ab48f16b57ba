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


# -- structural effects on top of the spread (the gap half of the bench) -------------------------
# In-library kinds the calibrated diagnosis searches (beyond the ordinary spread where a group
# covers the kind: a tool holder 3-5 times off, a body 30-60 % heavier than its data sheet), and
# out-of-library ones near them. Injected by rmbench.gap.cases.blind.inject (the variant primitives and
# MjSpec edits of its own, never the diagnosis's library) plus an off-origin mass written here.
IN_LIBRARY = ("base_compliance", "tool_contact_stiffness", "added_mass", "sensor_misalignment",
              "non_reciprocity")
OUT_OF_LIBRARY = ("hose_resonator", "tendon_coupling", "offset_mass")
_MASS_BODIES = ("upper_arm", "forearm", "wrist", "flange")


def draw_structural(rng: np.random.Generator, in_library: bool):
    """One structural effect (:class:`rmbench.gap.cases.blind.Hidden`)."""
    from rmbench.gap.cases.blind import Hidden

    def factor(lo, hi):
        f = _logu(rng, lo, hi)
        return f if rng.random() < 0.5 else 1 / f

    if in_library:
        kind = IN_LIBRARY[int(rng.integers(len(IN_LIBRARY)))]
        if kind == "base_compliance":       # lateral: the calibrated base tilts only
            return Hidden(kind, "base", {"lateral": float(rng.uniform(30, 100)), "tilt": 0.0})
        if kind == "tool_contact_stiffness":
            f = factor(3.0, 5.0)
            return Hidden(kind, "tool_contact", {"translation": f, "rotation": f})
        if kind == "added_mass":
            body = _MASS_BODIES[int(rng.integers(len(_MASS_BODIES)))]
            return Hidden(kind, body, {"fraction": float(rng.uniform(0.3, 0.6))})
        if kind == "sensor_misalignment":
            band = "low" if rng.random() < 0.5 else "high"
            coord = ("1X", "1Y", "1aX", "1aY")[int(rng.integers(4))]
            return Hidden(kind, f"{band}:{coord}", {"angle_deg": float(rng.choice([-1, 1]) * rng.uniform(6, 12))})
        return Hidden(kind, "spindle_spin", {"rpm": float(rng.uniform(12000, 24000))})
    kind = OUT_OF_LIBRARY[int(rng.integers(len(OUT_OF_LIBRARY)))]
    if kind == "hose_resonator":
        link = ("upper_arm", "forearm")[int(rng.integers(2))]
        return Hidden(kind, link, {"mass": float(rng.uniform(5, 15)), "f_hz": float(rng.uniform(9, 30)),
                                   "zeta": 0.05})
    if kind == "tendon_coupling":
        pair = [("j2_flex", "j3_flex"), ("j4_flex", "j5_flex"), ("j5_flex", "j6_flex")][int(rng.integers(3))]
        return Hidden(kind, "+".join(pair), {"fraction": float(rng.uniform(0.3, 0.8))})
    body = ("forearm", "wrist", "flange")[int(rng.integers(3))]
    offset = rng.uniform(-1, 1, 3)
    offset *= float(rng.uniform(0.25, 0.4)) / np.linalg.norm(offset)
    return Hidden("offset_mass", body, {"mass": float(rng.uniform(8, 20)), "offset_m": offset.tolist()})


def inject_structural(xml: str, hidden):
    """The spread robot's MJCF with the structural effect, the sensors' placement errors per
    band and the spindle speed it is measured at."""
    from rmbench.gap.cases.blind import inject
    from rmbench.robot import Robot
    from rmbench.robot.spec import spec_to_xml
    from rmbench.robot.variant import add_point_mass

    robot = Robot(xml, name="truth", tool="dummy")
    if hidden.kind == "offset_mass":
        spec = robot.spec
        add_point_mass(spec, hidden.location, hidden.value["mass"], hidden.value["offset_m"])
        none = {b: {"position_error_mm": [0.0] * 4, "misalignment_deg": [0.0] * 4} for b in ("low", "high")}
        return spec_to_xml(spec), none, 0.0
    if hidden.kind == "base_compliance":
        return _lateral_base(xml, hidden.value["lateral"] * 1e-9), \
            {b: {"position_error_mm": [0.0] * 4, "misalignment_deg": [0.0] * 4} for b in ("low", "high")}, 0.0
    return inject(robot, (hidden,))


def _lateral_base(xml: str, c: float) -> str:
    """A foundation that slides sideways (x and y) with compliance ``c`` (m/N), 5 % damping, a
    1000 kg plate, under whatever the robot already stands on (text edits)."""
    root = ET.fromstring(xml)
    world = root.find("worldbody")
    arm = next(b for b in world if b.tag == "body")
    k = 1 / c
    damping = 2 * 0.05 * np.sqrt(k * (_subtree_mass(arm) + 1000.0))
    mount = ET.Element("body", {"name": "slab"})
    ET.SubElement(mount, "inertial", {"pos": "0 0 -0.05", "mass": "1000", "diaginertia": "120.8 120.8 240"})
    for axis, vec in (("x", "1 0 0"), ("y", "0 1 0")):
        ET.SubElement(mount, "joint", {"name": f"slab_{axis}", "type": "slide", "axis": vec,
                                       "stiffness": f"{k:.9g}", "damping": f"{damping:.9g}"})
    index = list(world).index(arm)
    world.remove(arm)
    mount.append(arm)
    world.insert(index, mount)
    return ET.tostring(root, encoding="unicode")
