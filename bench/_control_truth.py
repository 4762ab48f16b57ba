""""Real" MH180s for the scheduled-control bench: the suppression robot's nominal MJCF with every
ordinary parameter drawn as the calibration bench draws them (joint stiffness × log-uniform 0.6-1.6,
damping × 0.5-2, servo gains × 0.8-1.25, link masses ± 10 % with their inertia, centres of mass
± 2 cm and up to 0.15 m sideways on two links, a compliant foundation on half of them).

Built by plain XML edits, not by any rmbench parameter code, so the controller's design chain
cannot share a mistake with the truth it is scored on.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from _calibrate_truth import LATERAL, LINKS, _fmt, _logu, _nums, _subtree_mass


def draw_mh180(nominal_xml: str, rng: np.random.Generator, *, base: bool) -> tuple[str, dict]:
    """The MJCF of one "real" MH180 with its suppressor, and its drawn values (SI)."""
    root = ET.fromstring(nominal_xml)
    truth = {}
    joints = {j.get("name"): j for j in root.iter("joint")}
    bodies = {b.get("name"): b for b in root.iter("body")}
    for name, j in joints.items():
        if name.endswith("_flex"):
            for attr, lo, hi in (("stiffness", 0.6, 1.6), ("damping", 0.5, 2.0)):
                v = float(j.get(attr)) * _logu(rng, lo, hi)
                j.set(attr, f"{v:.9g}")
                truth[f"{name}.{attr}"] = v
    for act in root.iter("general"):  # the arm's position servos as the assembled MJCF writes them
        if act.get("joint", "") in {f"j{i}" for i in range(1, 7)}:
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
        truth[f"{name}.com"] = pos.tolist()
    truth["base.tilt_compliance"] = 0.0
    if base:
        c = float(rng.uniform(20, 100)) * 1e-9  # rad/(N·m)
        world = root.find("worldbody")
        arm = next(b for b in world if b.tag == "body")
        k = 1 / c
        damping = 2 * 0.05 * np.sqrt(k * (_subtree_mass(arm) + 1000.0))
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
