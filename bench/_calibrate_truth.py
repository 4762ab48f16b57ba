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

from _truth_edits import draw_ordinary, logu, mount_on_foundation, mount_under


def draw_truth(nominal_xml: str, rng: np.random.Generator, *, base: bool) -> tuple[str, dict]:
    """The MJCF of one "real robot" and its true parameter values (SI, calibration names)."""
    root = ET.fromstring(nominal_xml)
    truth = draw_ordinary(root, rng)
    truth["base.tilt_compliance"] = mount_on_foundation(root, rng) if base else 0.0
    return ET.tostring(root, encoding="unicode"), truth


# -- structural effects on top of the spread (the gap half of the bench) -------------------------
# In-library kinds the calibrated diagnosis searches (beyond the ordinary spread where a group
# covers the kind: a tool holder 3-5 times off, a body 30-60 % heavier than its data sheet), and
# out-of-library ones near them. Injected by rmbench.gap.cases.blind.inject (plain MJCF edits,
# rmbench.gap.cases.truth: never the variant code or the diagnosis's library), but for the
# foundation, which slides here (text edits below).
IN_LIBRARY = ("base_compliance", "tool_contact_stiffness", "added_mass", "sensor_misalignment",
              "non_reciprocity")
OUT_OF_LIBRARY = ("hose_resonator", "tendon_coupling", "offset_mass")
_MASS_BODIES = ("upper_arm", "forearm", "wrist", "flange")


def draw_structural(rng: np.random.Generator, in_library: bool):
    """One structural effect (:class:`rmbench.gap.cases.blind.Hidden`); out of library, the blind
    cases' draws (:func:`rmbench.gap.cases.hidden.draw_out_of_library`) of three of their kinds."""
    from rmbench.gap.cases.blind import Hidden
    from rmbench.gap.cases.hidden import draw_out_of_library

    def factor(lo, hi):
        f = logu(rng, lo, hi)
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
    return draw_out_of_library(rng, OUT_OF_LIBRARY[int(rng.integers(len(OUT_OF_LIBRARY)))])


def scaled_structural(hidden, factor: float):
    """``hidden`` with its size times ``factor``: a foundation's compliance, a body's added
    fraction, a sensor's angle, the spindle's speed, a hose's or an off-origin mass, a tendon's
    coupling; a tool holder's stiffness factor raised to ``factor`` (its size is a ratio)."""
    from rmbench.gap.cases.blind import Hidden

    v = dict(hidden.value)
    key = {"base_compliance": "lateral", "added_mass": "fraction", "sensor_misalignment": "angle_deg",
           "non_reciprocity": "rpm", "hose_resonator": "mass", "tendon_coupling": "fraction",
           "offset_mass": "mass"}.get(hidden.kind)
    if hidden.kind == "tool_contact_stiffness":
        v = {k: float(x) ** factor for k, x in v.items()}
    else:
        v[key] = float(v[key]) * factor
    return Hidden(hidden.kind, hidden.location, v)


def inject_structural(xml: str, hidden):
    """The spread robot's MJCF with the structural effect, the sensors' placement errors per
    band and the spindle speed it is measured at."""
    from rmbench.gap.cases.blind import inject
    from rmbench.robot import Robot

    if hidden.kind == "base_compliance":
        return _lateral_base(xml, hidden.value["lateral"] * 1e-9), \
            {b: {"position_error_mm": [0.0] * 4, "misalignment_deg": [0.0] * 4} for b in ("low", "high")}, 0.0
    return inject(Robot(xml, name="truth", tool="dummy"), (hidden,))


def _lateral_base(xml: str, c: float) -> str:
    """A foundation that slides sideways (x and y) with compliance ``c`` (m/N), 5 % damping, a
    1000 kg plate, under whatever the robot already stands on (text edits)."""
    root = ET.fromstring(xml)
    mount_under(root, "slab", "slab_", "slide", c)
    return ET.tostring(root, encoding="unicode")
