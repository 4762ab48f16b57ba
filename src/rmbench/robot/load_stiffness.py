"""Load-dependent joint stiffness: gearboxes that stiffen under the gravity load of a posture.

A robot MJCF may carry, per passive (flexible) joint, a coefficient α ≥ 0::

    <custom><text name="rmbench_load_stiffness" data="j2_flex:0.2 j3_flex:0.1"/></custom>

At a posture, such a joint's linear stiffness is

    k = k0 · (1 + α · |Δ| / Δ0),

with k0 the joint's nominal stiffness in the file, Δ0 = 1 mrad for a hinge (1 mm for a slide),
and Δ the joint's static deflection (its qpos at the deflected static equilibrium under gravity,
relative to its ``springref``) computed with the nominal stiffness k0 at that posture. This is a
secant stiffness set by the gravity load, and the model is quasi-linear: at each posture the joint
is an ordinary linear spring of stiffness k, the robot settles again with it, and small vibrations
about that equilibrium (modes, FRFs, impact tests, time-domain simulation) see k. Settled with
k, the joint deflects less than Δ (about Δ·k0/k); k is not iterated to a fixed point. Large
motions that change the load do not re-stiffen the joint; a new posture does. k is written into
the per-posture MJCF with the writer's 6 significant digits.

:meth:`rmbench.robot.Robot.at` applies it: the operating point's robot is a per-posture copy of
the robot with those stiffnesses written in and the metadata removed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import mujoco
import numpy as np

from rmbench.errors import ModelError

__all__ = ["LOAD_STIFFNESS", "REFERENCE_DEFLECTION", "parse_load_stiffness", "format_load_stiffness",
           "check_load_stiffness", "posture_stiffness", "set_load_stiffness", "stiffened_spec"]

LOAD_STIFFNESS = "rmbench_load_stiffness"
"""Name of the ``<custom><text>`` field holding the coefficients."""

REFERENCE_DEFLECTION = 1e-3
"""Δ0: 1 mrad for a hinge, 1 mm for a slide (rad or m)."""


def parse_load_stiffness(text: str | None, *, source: str = LOAD_STIFFNESS) -> dict[str, float]:
    """Coefficients of a ``rmbench_load_stiffness`` text, ``"JOINT:ALPHA ..."``.

    Parameters
    ----------
    text : str or None
        ``JOINT:ALPHA`` entries separated by white space or commas; None or empty for none.
    source : str
        Where the text comes from, for messages (the metadata field, a CLI option).

    Returns
    -------
    dict of str to float
        α per joint name (dimensionless), in the order given.

    Raises
    ------
    ModelError
        For a malformed entry, a joint named twice, or an α that is negative or not finite.
    """
    coeffs: dict[str, float] = {}
    for entry in (text or "").replace(",", " ").split():
        name, sep, value = entry.partition(":")
        try:
            alpha = float(value)
        except ValueError:
            alpha = None
        if not sep or not name or alpha is None:
            raise ModelError(f"{source}: entry {entry!r} must be JOINT:ALPHA, e.g. j2_flex:0.2")
        if name in coeffs:
            raise ModelError(f"{source}: joint {name!r} is named twice")
        coeffs[name] = _check_alpha(name, alpha, source)
    return coeffs


def format_load_stiffness(coeffs: Mapping[str, float]) -> str:
    """The metadata text of coefficients (inverse of :func:`parse_load_stiffness`)."""
    return " ".join(f"{name}:{_check_alpha(name, alpha)!r}" for name, alpha in coeffs.items())


def check_load_stiffness(model: mujoco.MjModel, coeffs: Mapping[str, float]) -> None:
    """Check that every joint with a coefficient exists, is passive and is a hinge or a slide.

    Parameters
    ----------
    model : mujoco.MjModel
        The robot.
    coeffs : mapping of str to float
        α per joint name.

    Raises
    ------
    ModelError
        Naming the first joint that is unknown, driven by an actuator, not a hinge or slide, or
        whose α is negative or not finite.
    """
    actuated = {int(model.actuator_trnid[a, 0]) for a in range(model.nu)
                if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT}
    for name, alpha in coeffs.items():
        _check_alpha(name, alpha)
        j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if j < 0:
            raise ModelError(f"{LOAD_STIFFNESS}: the robot has no joint {name!r}")
        if j in actuated:
            raise ModelError(f"{LOAD_STIFFNESS}: joint {name!r} is driven by an actuator; "
                             "load-dependent stiffness applies to passive (flexible) joints")
        if model.jnt_type[j] not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            raise ModelError(f"{LOAD_STIFFNESS}: joint {name!r} is not a hinge or a slide")


def posture_stiffness(model: mujoco.MjModel, data: mujoco.MjData, coeffs: Mapping[str, float]) -> dict[str, float]:
    """Secant stiffness of each load-dependent joint at the equilibrium held in ``data``.

    Parameters
    ----------
    model : mujoco.MjModel
        The robot with its nominal stiffnesses k0.
    data : mujoco.MjData
        Its deflected static equilibrium at a posture (nominal stiffness).
    coeffs : mapping of str to float
        α per joint.

    Returns
    -------
    dict of str to float
        ``k0 · (1 + α · |Δ| / Δ0)`` per joint, N·m/rad (hinge) or N/m (slide).
    """
    out = {}
    for name, alpha in coeffs.items():
        j = model.joint(name).id
        adr = model.jnt_qposadr[j]
        deflection = float(data.qpos[adr] - model.qpos_spring[adr])
        out[name] = float(model.jnt_stiffness[j]) * (1.0 + alpha * abs(deflection) / REFERENCE_DEFLECTION)
    return out


def set_load_stiffness(spec: mujoco.MjSpec, coeffs: Mapping[str, float]) -> None:
    """Write coefficients into a spec's metadata, replacing any there; none removes the field."""
    for text in spec.texts:
        if text.name == LOAD_STIFFNESS:
            spec.delete(text)
            break
    if coeffs:
        spec.add_text(name=LOAD_STIFFNESS, data=format_load_stiffness(coeffs))


def stiffened_spec(spec: mujoco.MjSpec, stiffness: Mapping[str, float]) -> mujoco.MjSpec:
    """The spec with joints set to the given stiffness and the load-stiffness metadata removed.

    Parameters
    ----------
    spec : mujoco.MjSpec
        Edited in place (pass a copy).
    stiffness : mapping of str to float
        New linear stiffness per joint, N·m/rad or N/m.

    Returns
    -------
    mujoco.MjSpec
        ``spec`` itself.
    """
    for name, k in stiffness.items():
        joint = spec.joint(name)
        if joint is None:
            raise ModelError(f"cannot set the stiffness of joint {name!r}: the robot has no such joint")
        values = np.array(joint.stiffness, float)
        values[0] = k
        joint.stiffness = values
    set_load_stiffness(spec, {})
    return spec


def _check_alpha(name: str, alpha: float, source: str = LOAD_STIFFNESS) -> float:
    alpha = float(alpha)
    if not math.isfinite(alpha) or alpha < 0:
        raise ModelError(f"{source}: coefficient of joint {name!r} must be finite and >= 0, got {alpha}")
    return alpha
