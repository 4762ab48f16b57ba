"""One "real robot" for the FRF benches: the nominal MJCF with every ordinary parameter drawn and
model-form errors added, by plain ElementTree edits.

The ordinary spread is the calibration's parameters, drawn as :mod:`truth.ordinary` draws them
(gearbox stiffness and damping, servo gains, link masses and centres of mass, the tool holder's
contact). The foundation of half the robots tilts like the model's, but is a slab of its own
mass (500-3000 kg where the model's plate is 1000 kg) and damping (2-8 % where the model's is 5 %).
Form errors (:mod:`truth.form`) are drawn kind by kind, each with probability ``p_form``.

:func:`draw_truth` is the in-model benches' robot (``bench/calibrate.py``, ``calibrate_design.py``,
``identify_speed.py``): the ordinary spread alone, and on half of them the model's own tilting
foundation (a 1000 kg plate, 5 % damping, compliance uniform 20-100 µrad/(kN·m)), so that every
drawn value is one the calibration fits.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from truth.form import FORM_KINDS, FormError, apply_form, draw_form
from truth.ordinary import draw_ordinary, logu, mount_on_foundation, subtree_mass

__all__ = ["RealRobot", "draw_real_robot", "draw_truth"]


@dataclass(frozen=True)
class RealRobot:
    """A drawn real robot.

    Attributes
    ----------
    xml : str
        Its MJCF.
    ordinary : dict
        True values of the calibration's parameters, SI, by the calibration's names
        (``j2_flex.stiffness``, ``a2.kp``, ``forearm.mass``, ``forearm.com_y``,
        ``tool_contact.translation``, ``base.tilt_compliance``: None where a skewed foundation
        replaced the tilting one).
    form : tuple of FormError
        Its model-form errors.
    foundation : dict
        The tilting foundation's mass (kg) and damping ratio; empty on a rigid floor.
    """

    xml: str
    ordinary: dict
    form: tuple
    foundation: dict

    def to_dict(self) -> dict:
        return {"ordinary": self.ordinary, "form": [e.to_dict() for e in self.form],
                "foundation": self.foundation}


def draw_real_robot(nominal_xml: str, rng: np.random.Generator, *, base: bool, p_form: float = 0.5,
                    kinds=FORM_KINDS, scale: float = 1.0) -> RealRobot:
    """A real robot drawn from the nominal MJCF.

    Parameters
    ----------
    base : bool
        On a tilting foundation.
    p_form : float
        Probability of each form kind of ``kinds`` (0: the spread alone).
    scale : float
        Of the form errors' sizes (:func:`truth.form.draw_form`).
    """
    root = ET.fromstring(nominal_xml)
    ordinary = draw_ordinary(root, rng)
    foundation = {}
    if base:
        foundation = _tilting_foundation(root, rng)
        ordinary["base.tilt_compliance"] = foundation.pop("compliance")
    else:
        ordinary["base.tilt_compliance"] = 0.0
    drawn = [k for k in kinds if rng.random() < p_form]
    form = tuple(draw_form(rng, k, scale=scale) for k in drawn)
    for e in form:
        apply_form(root, e)
    if any(e.kind == "foundation_skew" for e in form):
        # the skewed foundation replaced the tilting one: no isotropic tilt compliance is true
        ordinary["base.tilt_compliance"], foundation = None, {}
    return RealRobot(ET.tostring(root, encoding="unicode"), ordinary, form, foundation)


def draw_truth(nominal_xml: str, rng: np.random.Generator, *, base: bool) -> tuple[str, dict]:
    """The MJCF of one in-model "real robot" (the ordinary spread, the model's tilting foundation
    where ``base``) and its true parameter values (SI, calibration names)."""
    root = ET.fromstring(nominal_xml)
    truth = draw_ordinary(root, rng)
    truth["base.tilt_compliance"] = mount_on_foundation(root, rng) if base else 0.0
    return ET.tostring(root, encoding="unicode"), truth


def _tilting_foundation(root: ET.Element, rng) -> dict:
    """The arm on a slab that tilts about x and y: compliance uniform 20-100 µrad/(kN·m), mass
    log-uniform 500-3000 kg, damping 2-8 % of critical against the arm and slab at 1 m."""
    c = float(rng.uniform(20, 100)) * 1e-9
    m = logu(rng, 500.0, 3000.0)
    zeta = float(rng.uniform(0.02, 0.08))
    world = root.find("worldbody")
    arm = next(b for b in world if b.tag == "body")
    k = 1 / c
    slab = ET.Element("body", {"name": "foundation"})
    # a 2 m square slab, 0.3 m thick
    ET.SubElement(slab, "inertial", {"pos": "0 0 -0.15", "mass": f"{m:.9g}",
                                     "diaginertia": f"{m * 4.09 / 12:.9g} {m * 4.09 / 12:.9g} {m * 8 / 12:.9g}"})
    damping = 2 * zeta * np.sqrt(k * (subtree_mass(arm) + m))
    for axis, vec in (("x", "1 0 0"), ("y", "0 1 0")):
        ET.SubElement(slab, "joint", {"name": f"foundation_r{axis}", "axis": vec, "stiffness": f"{k:.9g}",
                                      "damping": f"{damping:.9g}"})
    index = list(world).index(arm)
    world.remove(arm)
    slab.append(arm)
    world.insert(index, slab)
    return {"compliance": c, "mass": m, "damping_ratio": zeta}
