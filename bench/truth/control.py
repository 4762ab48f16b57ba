""""Real" MH180s for the scheduled-control bench: the suppression robot's nominal MJCF with every
ordinary parameter drawn as the calibration bench draws them (joint stiffness × log-uniform 0.6-1.6,
damping × 0.5-2, servo gains × 0.8-1.25, link masses ± 10 % with their inertia, centres of mass
± 2 cm and up to 0.15 m sideways on two links, a compliant foundation on half of them), and, with
:func:`draw_mh180_form`, model-form errors of :mod:`truth.form` on top (bearing tilt, link bending,
counterbalance, cable bundle, hardening gear, skewed foundation).

Built by plain XML edits (:mod:`truth.ordinary`), not by any rmbench parameter code, so the
controller's design chain cannot share a mistake with the truth it is scored on.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from truth.form import apply_form, draw_form
from truth.ordinary import draw_flex_joints, draw_links, draw_servos, mount_on_foundation

__all__ = ["ARM", "draw_mh180", "draw_mh180_form"]

ARM = {f"j{i}" for i in range(1, 7)}


def draw_mh180(nominal_xml: str, rng: np.random.Generator, *, base: bool) -> tuple[str, dict]:
    """The MJCF of one "real" MH180 with its suppressor, and its drawn values (SI)."""
    root = ET.fromstring(nominal_xml)
    truth = draw_flex_joints(root, rng)
    truth.update(draw_servos(root, rng, lambda act: act.get("joint", "") in ARM))
    for name, (m, pos) in draw_links(root, rng).items():
        truth[f"{name}.mass"] = m
        truth[f"{name}.com"] = pos.tolist()
    truth["base.tilt_compliance"] = mount_on_foundation(root, rng) if base else 0.0
    return ET.tostring(root, encoding="unicode"), truth


def draw_mh180_form(nominal_xml: str, rng: np.random.Generator, *, base: bool, kinds) -> tuple[str, dict]:
    """:func:`draw_mh180`, then one form error of each of ``kinds`` (:func:`truth.form.draw_form`,
    its ranges unscaled) made in the MJCF; the drawn errors are in ``truth["form"]``."""
    xml, truth = draw_mh180(nominal_xml, rng, base=base)
    root = ET.fromstring(xml)
    errors = [draw_form(rng, kind) for kind in kinds]
    for e in errors:
        apply_form(root, e)
    truth["form"] = [e.to_dict() for e in errors]
    return ET.tostring(root, encoding="unicode"), truth
