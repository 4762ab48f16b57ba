"""Model variants: what-if edits of a robot's specification, saved as MJCF.

Edits go through mujoco.MjSpec, never hand-copied XML. A variant file is a complete robot (with its
tool, if one was attached) that every command accepts via ``--robot PATH``.

Edit syntax (CLI ``--set``), ``TARGET.FIELD OP VALUE`` with OP one of ``=``, ``*=``, ``+=``:

- joints: ``stiffness``, ``damping``, ``armature``, ``springref`` (``j2_flex.stiffness*=0.8``;
  ``tool_contact_*.stiffness*=2`` changes the tool-holder contact; shell-style wildcards match
  several joints);
- bodies: ``mass`` (``flange.mass+=5``), ``pos`` (``x,y,z`` in m);
- sites: ``pos`` (m) and ``euler`` (``rx,ry,rz`` in degrees, applied after the current orientation);
- position actuators (servos): ``kp`` (N·m/rad or N/m) and ``kv`` (N·m·s/rad or N·s/m)
  (``a2.kp*=0.8``, ``a*.kv*=1.5``). A MuJoCo position actuator has ``gainprm[0] = kp``,
  ``biasprm[1] = −kp`` and ``biasprm[2] = −kv``; both kp entries change together. Every
  actuator a pattern matches must be a position actuator.

Load-dependent joint stiffness (:mod:`rmbench.robot.load_stiffness`) is set with
``make_variant(robot, load_stiffness={"j2_flex": 0.2})``.
"""

from __future__ import annotations

import fnmatch
import re
from dataclasses import dataclass

import mujoco
import numpy as np

from rmbench.errors import InputError, ModelError
from rmbench.robot.load_stiffness import check_load_stiffness, set_load_stiffness
from rmbench.robot.spec import custom_text, move_body

__all__ = ["Edit", "parse_edit", "apply_edit", "add_point_mass", "add_compliant_base", "make_variant", "compile_variant",
           "condensed", "with_tool_masses"]

_EDIT = re.compile(r"^(?P<target>[\w*?\[\]-]+)\.(?P<field>\w+)\s*(?P<op>\*=|\+=|=)\s*(?P<value>.+)$")
_JOINT_FIELDS = {"stiffness", "damping", "armature", "springref"}
_BODY_FIELDS = {"mass", "pos"}
_SITE_FIELDS = {"pos", "euler"}
_ACTUATOR_FIELDS = {"kp", "kv"}


@dataclass(frozen=True)
class Edit:
    """One parsed edit: ``target.field op value``."""

    target: str
    field: str
    op: str
    value: tuple[float, ...]

    def __str__(self) -> str:
        return f"{self.target}.{self.field}{self.op}{','.join(f'{v:g}' for v in self.value)}"


def parse_edit(text: str) -> Edit:
    """Parse ``TARGET.FIELD OP VALUE`` (see module docstring)."""
    m = _EDIT.match(text.strip())
    if m is None:
        raise InputError(f"cannot parse edit {text!r}; expected e.g. j2_flex.stiffness*=0.8")
    try:
        value = tuple(float(v) for v in m["value"].split(","))
    except ValueError:
        raise InputError(f"edit {text!r}: value must be numbers separated by commas") from None
    if not all(np.isfinite(value)):
        raise InputError(f"edit {text!r}: value must be finite")
    return Edit(m["target"], m["field"], m["op"], value)


def apply_edit(spec: mujoco.MjSpec, edit: Edit) -> int:
    """Apply an edit to every matching joint, body, site or actuator; returns how many changed.

    Raises
    ------
    InputError
        For an unknown field, a name that matches nothing, a value of the wrong length, a value
        that leaves a field out of its range, or a servo edit of an actuator that is not a
        position actuator.
    """
    count = 0
    if edit.field in _ACTUATOR_FIELDS:
        for actuator in spec.actuators:
            if fnmatch.fnmatchcase(actuator.name, edit.target):
                _edit_servo(actuator, edit)
                count += 1
    if edit.field in _JOINT_FIELDS:
        for joint in spec.joints:
            if fnmatch.fnmatchcase(joint.name, edit.target):
                _edit_joint(joint, edit)
                count += 1
    if edit.field in _SITE_FIELDS and count == 0:
        for site in spec.sites:
            if fnmatch.fnmatchcase(site.name, edit.target):
                _edit_vector(site, edit, edit.field)
                count += 1
    if edit.field in _BODY_FIELDS and count == 0:
        for body in spec.bodies:
            if fnmatch.fnmatchcase(body.name, edit.target):
                if edit.field == "mass":
                    if not body.explicitinertial:
                        raise InputError(f"edit {edit}: body {body.name!r} has no explicit inertial")
                    body.mass = _combine(body.mass, edit)
                    if body.mass <= 0:
                        raise InputError(f"edit {edit}: mass of {body.name!r} must stay positive")
                else:
                    _edit_vector(body, edit, "pos")
                count += 1
    if edit.field not in _JOINT_FIELDS | _BODY_FIELDS | _SITE_FIELDS | _ACTUATOR_FIELDS:
        raise InputError(f"edit {edit}: unknown field {edit.field!r}; joints take "
                         f"{sorted(_JOINT_FIELDS)}, bodies {sorted(_BODY_FIELDS)}, sites {sorted(_SITE_FIELDS)}, "
                         f"actuators {sorted(_ACTUATOR_FIELDS)}")
    if count == 0 and edit.field in _ACTUATOR_FIELDS:
        raise InputError(f"edit {edit}: no actuator named {edit.target!r}")
    if count == 0:
        raise InputError(f"edit {edit}: no joint, body or site named {edit.target!r} has field {edit.field!r}")
    return count


def add_point_mass(spec: mujoco.MjSpec, where: str, mass: float, offset=(0.0, 0.0, 0.0)) -> None:
    """Add a point mass (kg) rigidly at a site or body, optionally offset (m, in its frame)."""
    if not mass > 0:
        raise InputError(f"point mass must be positive, got {mass}")
    site = _find(spec.sites, where)
    body = _find(spec.bodies, where)
    if site is not None:
        parent, pos = site.parent, np.array(site.pos) + _rotate(site.quat, offset)
    elif body is not None:
        parent, pos = body, np.asarray(offset, float)
    else:
        raise InputError(f"no site or body named {where!r} to add a mass to")
    n = sum(1 for b in spec.bodies if b.name.startswith("point_mass"))
    child = parent.add_body(name=f"point_mass{n + 1}", pos=pos)
    # a tiny sphere carrying the mass: MuJoCo's XML writer drops a bare <inertial> at the origin
    child.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.004, 0, 0], mass=mass,
                   contype=0, conaffinity=0, rgba=[1, 0, 1, 1])


def add_compliant_base(spec: mujoco.MjSpec, k_lateral: float, k_tilt: float, *,
                       k_vertical: float | None = None, k_torsion: float | None = None,
                       damping_ratio: float = 0.05, base_mass: float = 1000.0) -> None:
    """Mount the robot on a compliant foundation.

    A base plate (``base_mount``, ``base_mass`` kg) on passive slides x, y, z and hinges about x, y,
    z carries the whole arm. Stiffness in N/m and N·m/rad; each damper is set to ``damping_ratio``
    of critical against the arm's mass (translations) or its mass at 1 m (rotations).
    """
    for name, k in (("k_lateral", k_lateral), ("k_tilt", k_tilt)):
        if not k > 0:
            raise InputError(f"{name} must be positive, got {k}")
    k_vertical = 5 * k_lateral if k_vertical is None else k_vertical
    k_torsion = k_tilt if k_torsion is None else k_torsion
    if _find(spec.bodies, "base_mount") is not None:
        raise InputError("the robot already stands on a compliant base")
    arm = spec.worldbody.first_body()
    if arm is None:
        raise ModelError("the robot has no moving body to mount on a compliant base")
    mass = float(spec.compile().body_subtreemass[1]) + base_mass
    # the plate's inertia explicit (a 1.2 × 1.2 × 0.1 m box), not its geom's: a calibration can
    # then scale its mass in the specification as in the compiled model
    half = np.array([0.6, 0.6, 0.05])
    box = base_mass / 3 * np.array([half[1] ** 2 + half[2] ** 2, half[0] ** 2 + half[2] ** 2,
                                    half[0] ** 2 + half[1] ** 2])
    base = spec.worldbody.add_body(name="base_mount", mass=base_mass, ipos=[0, 0, -0.05],
                                   inertia=box, explicitinertial=True)
    base.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=half, pos=[0, 0, -0.05], mass=0.0,
                  contype=0, conaffinity=0, rgba=[0.4, 0.4, 0.4, 1])
    for name, kind, axis, k, m_eff in (
            ("base_x", mujoco.mjtJoint.mjJNT_SLIDE, (1, 0, 0), k_lateral, mass),
            ("base_y", mujoco.mjtJoint.mjJNT_SLIDE, (0, 1, 0), k_lateral, mass),
            ("base_z", mujoco.mjtJoint.mjJNT_SLIDE, (0, 0, 1), k_vertical, mass),
            ("base_rx", mujoco.mjtJoint.mjJNT_HINGE, (1, 0, 0), k_tilt, mass),
            ("base_ry", mujoco.mjtJoint.mjJNT_HINGE, (0, 1, 0), k_tilt, mass),
            ("base_rz", mujoco.mjtJoint.mjJNT_HINGE, (0, 0, 1), k_torsion, mass)):
        base.add_joint(name=name, type=kind, axis=axis, stiffness=[k, 0, 0],
                       damping=[2 * damping_ratio * np.sqrt(k * m_eff), 0, 0])
    move_body(spec, arm, base)


def compile_variant(spec, robot, load_stiffness=None) -> mujoco.MjModel:
    """Write ``load_stiffness`` (``{joint: α}``, 1/mrad, over the robot's own coefficients) into a
    variant's ``spec`` and compile it, checking the coefficients against the compiled model.

    Raises
    ------
    InputError
        For a variant that does not compile, or a load-stiffness coefficient of an unknown or
        actuated joint, or a negative α.
    """
    if load_stiffness:
        coeffs = {**robot.load_stiffness, **load_stiffness}
        set_load_stiffness(spec, {name: alpha for name, alpha in coeffs.items() if alpha != 0})
    try:
        model = spec.compile()
    except ValueError as err:
        raise InputError(f"the variant does not compile: {str(err).splitlines()[0]}") from None
    if load_stiffness:
        check_load_stiffness(model, load_stiffness)
    return model


def make_variant(robot, edits=(), *, masses=(), compliant_base=None, load_stiffness=None) -> str:
    """MJCF text of a variant of ``robot`` (a :class:`~rmbench.robot.Robot`).

    The variant keeps the robot's load-dependent stiffness coefficients, if any.

    Parameters
    ----------
    edits : sequence of str or Edit
    masses : sequence of (where, mass_kg, offset_m)
    compliant_base : (k_lateral N/m, k_tilt N·m/rad) or None
    load_stiffness : mapping of str to float, optional
        α ≥ 0 per passive joint (:mod:`rmbench.robot.load_stiffness`), added to or replacing
        the robot's own coefficients; α = 0 makes a joint's stiffness constant again.

    Raises
    ------
    InputError
        For a bad edit, mass or base, or a variant that does not compile.
    ModelError
        For a load-stiffness coefficient of an unknown or actuated joint, or a negative α.
    """
    from rmbench.robot.spec import set_custom_text, spec_to_xml

    spec = robot.spec
    log = []
    for e in edits:
        e = parse_edit(e) if isinstance(e, str) else e
        apply_edit(spec, e)
        log.append(str(e))
    for where, mass, offset in masses:
        add_point_mass(spec, where, mass, offset)
        log.append(f"mass {mass:g} kg at {where}")
    if compliant_base is not None:
        add_compliant_base(spec, *compliant_base)
        log.append(f"compliant base {compliant_base}")
    if load_stiffness:
        log.append("load stiffness " + " ".join(f"{n}:{a:g}" for n, a in load_stiffness.items()))
    compile_variant(spec, robot, load_stiffness)
    previous = custom_text(spec, "rmbench_variant")
    set_custom_text(spec, "rmbench_variant", "; ".join(([previous] if previous else []) + log))
    return spec_to_xml(spec)


def _find(elements, name):
    for e in elements:
        if e.name == name:
            return e
    return None


def _combine(old, edit: Edit):
    v = edit.value[0]
    return {"=": v, "*=": old * v, "+=": old + v}[edit.op]


def _edit_joint(joint, edit: Edit) -> None:
    if len(edit.value) != 1:
        raise InputError(f"edit {edit}: joint fields take one number")
    if edit.field in ("stiffness", "damping"):
        arr = np.array(getattr(joint, edit.field), float)
        arr[0] = _combine(arr[0], edit)
        if arr[0] < 0:
            raise InputError(f"edit {edit}: {edit.field} of {joint.name!r} must stay non-negative")
        setattr(joint, edit.field, arr)
    else:
        new = _combine(getattr(joint, edit.field), edit)
        if edit.field == "armature" and new < 0:
            raise InputError(f"edit {edit}: armature must stay non-negative")
        setattr(joint, edit.field, new)


def _edit_servo(actuator, edit: Edit) -> None:
    if len(edit.value) != 1:
        raise InputError(f"edit {edit}: servo fields take one number")
    gain = np.array(actuator.gainprm, float)
    bias = np.array(actuator.biasprm, float)
    if not _is_position_servo(actuator, gain, bias):
        raise InputError(f"edit {edit}: actuator {actuator.name!r} is not a position actuator "
                         "(kp and kv edit position servos)")
    if edit.field == "kp":
        kp = _combine(gain[0], edit)
        if not kp > 0:
            raise InputError(f"edit {edit}: kp of {actuator.name!r} must stay positive")
        gain[0], bias[1] = kp, -kp
    else:
        kv = _combine(-bias[2], edit)
        if kv < 0:
            raise InputError(f"edit {edit}: kv of {actuator.name!r} must stay non-negative")
        bias[2] = -kv
    actuator.gainprm = gain
    actuator.biasprm = bias


def _is_position_servo(actuator, gain: np.ndarray, bias: np.ndarray) -> bool:
    """MuJoCo's ``<position>``: fixed gain kp, affine bias ``−kp·length − kv·velocity``."""
    return (actuator.gaintype == mujoco.mjtGain.mjGAIN_FIXED and actuator.biastype == mujoco.mjtBias.mjBIAS_AFFINE
            and actuator.dyntype != mujoco.mjtDyn.mjDYN_INTEGRATOR
            and gain[0] > 0 and bias[0] == 0 and bias[1] == -gain[0])


def _edit_vector(element, edit: Edit, field: str) -> None:
    if len(edit.value) != 3:
        raise InputError(f"edit {edit}: {field} takes three numbers x,y,z")
    v = np.array(edit.value)
    if field == "pos":
        old = np.array(element.pos, float)
        element.pos = {"=": v, "+=": old + v, "*=": old * v}[edit.op]
        return
    if edit.op == "*=":
        raise InputError(f"edit {edit}: euler takes = or +=")
    q = np.zeros(4)
    mujoco.mju_euler2Quat(q, np.radians(v), "xyz")
    if edit.op == "+=":
        out = np.zeros(4)
        mujoco.mju_mulQuat(out, np.array(element.quat, float), q)
        q = out
    element.quat = q


def _rotate(quat, vec) -> np.ndarray:
    out = np.zeros(3)
    mujoco.mju_rotVecQuat(out, np.asarray(vec, float), np.asarray(quat, float))
    return out


def condensed(robot, prefixes=("spindle_", "tool_"), *, keep=()):
    """The robot with the freedoms of joints named ``prefixes*`` removed (welded rigid).

    For long simulations: stiff freedoms (the spindle, holder and tool: 0.8-60 kHz) bound the
    stable time step, while well below their modes they act as static springs, whose compliance
    the caller adds back. Joints named in ``keep`` stay even if a prefix matches (a spinning
    rotor's ``spindle_spin``: it is no stiff freedom, and its gyroscopic coupling acts on the
    arm's modes). Returns a :class:`~rmbench.robot.Robot` of the same name and tool, which keeps
    the load-dependent stiffness of the joints it keeps, and the spindle speed if the rotor's
    joint is kept.
    """
    from rmbench.robot.model import Robot
    from rmbench.robot.spec import spec_to_xml

    spec = robot.spec
    doomed = [j for j in spec.joints if j.name.startswith(prefixes) and j.name not in keep]
    names = {j.name for j in doomed}
    set_load_stiffness(spec, {j: a for j, a in robot.load_stiffness.items() if j not in names})
    for act in list(spec.actuators):
        if act.target in names:
            spec.delete(act)
    for j in doomed:
        spec.delete(j)
    spin_kept = "spindle_spin" not in names
    return Robot(spec_to_xml(spec), name=robot.name, tool=robot.tool,
                 spindle_rpm=robot.spindle_rpm if spin_kept else 0.0, spec=spec)


def with_tool_masses(robot, masses):
    """The robot with point masses (sensors) on the tool.

    Parameters
    ----------
    masses : sequence of (s_up, mass)
        Distance up the tool axis from the tip (m) and mass (kg) of each point mass.

    Returns
    -------
    Robot
        Same name, tool and spindle speed, and the robot's load-dependent stiffness, if any.
    """
    from rmbench.robot.model import Robot, tool_point
    from rmbench.robot.spec import spec_to_xml

    spec = robot.spec
    model = robot.model
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    sid = model.site(robot.tcp).id
    for k, (s_up, mass) in enumerate(masses):
        if mass <= 0:
            continue
        point, body = tool_point(model, data, sid, s_up)
        local = data.xmat[body].reshape(3, 3).T @ (point - data.xpos[body])
        parent = spec.body(model.body(body).name)
        child = parent.add_body(name=f"sensor_mass{k + 1}", pos=local)
        child.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.002, 0, 0], mass=mass,
                       contype=0, conaffinity=0, rgba=[0, 0.8, 0, 1])
    return Robot(spec_to_xml(spec), name=robot.name, tool=robot.tool,
                 spindle_rpm=robot.spindle_rpm, spec=spec)
