"""A robot drawn off its data sheet: random what-if edits (:mod:`rmbench.robot.variant`) of its
gearbox stiffness and damping and its link masses, for a 'real' robot whose differences from the
model the calibration is not told.

    edits = drawn_edits(np.random.default_rng(2026))
    xml = make_variant(Robot.load("irb6660", tool="dummy"), edits)
"""

from __future__ import annotations

import numpy as np

__all__ = ["drawn_edits"]

_JOINTS = tuple(f"j{k}_flex" for k in range(1, 7))
_BODIES = ("lower_arm", "upper_arm", "forearm", "flange")


def drawn_edits(rng: np.random.Generator, *, joints=_JOINTS, bodies=_BODIES, stiffness=(0.7, 1.4),
                damping=(0.6, 1.7), mass=(0.92, 1.08)) -> list[str]:
    """Edits (``--set`` syntax) that scale each joint's stiffness and damping and each body's
    mass by a random factor.

    The stiffness and damping factors are drawn log-uniform between their bounds (a gearbox as
    likely twice as stiff as half as stiff), the mass factors uniform; each factor is written
    with four decimals. Draws are taken in this order, one number each: every joint's stiffness,
    every joint's damping, every body's mass, so a seed gives the same robot.

    Parameters
    ----------
    rng : numpy.random.Generator
    joints : sequence of str
        Joints edited (default the IRB6660 stand-in's ``j1_flex`` ... ``j6_flex``).
    bodies : sequence of str
        Bodies whose mass is edited (default its lower arm, upper arm, forearm and flange).
    stiffness, damping, mass : (float, float)
        Bounds of each factor (ratios to the nominal).

    Returns
    -------
    list of str
        ``JOINT.stiffness*=F`` per joint, then ``JOINT.damping*=F`` per joint, then
        ``BODY.mass*=F`` per body.
    """
    edits = [f"{j}.stiffness*={np.exp(rng.uniform(np.log(stiffness[0]), np.log(stiffness[1]))):.4f}" for j in joints]
    edits += [f"{j}.damping*={np.exp(rng.uniform(np.log(damping[0]), np.log(damping[1]))):.4f}" for j in joints]
    edits += [f"{b}.mass*={rng.uniform(mass[0], mass[1]):.4f}" for b in bodies]
    return edits
