"""Compliances a model parameter adds and sets: a foundation's, a joint bearing's tilt, a link's bending.

A compliance (kinds ``base``, ``tilt``, ``bending`` of :data:`rmbench.robot.kinds.KINDS`) is the
inverse stiffness of its joints, 0 rigid (:data:`RIGID`); their damping follows the stiffness at
:data:`DAMPING_RATIO` of critical against the mass the parameter carries at 1 m
(:attr:`Parameter.carried`). Each adds its joints to a model rigid at the nominal: the robot on a
foundation, two hinges after a joint (:func:`tilt_joints`), or a link split at mid-length on two
hinges (:func:`bending_joints`).
"""

from __future__ import annotations

import mujoco
import numpy as np

from rmbench.errors import InputError

__all__ = ["RIGID", "COMPLIANCE_UNIT", "DAMPING_RATIO", "WIDE_FORM", "MIN_BENDING_LENGTH", "compliance_damping",
           "tilt_joints", "bending_joints", "bending_child"]

RIGID = 1e14                  # N/m or N·m/rad: a joint this stiff is rigid in every band
COMPLIANCE_UNIT = 1e-9        # 1 µrad/(kN·m) in rad/(N·m) (1 µm/kN in m/N)
DAMPING_RATIO = 0.05          # of a compliance's joints, against the mass it carries at 1 m
_WIDE_COMPLIANCE = 300.0                    # a freed compliance: rigid to 300 units
# a form group's compliance, rigid to this many units: what robots of the class reach (a link
# of EI 1.7 MN·m², 0.9 m long, turns its end by 260 units; a slender one, or a bearing worn
# loose, several times that)
WIDE_FORM = {"tilt": 1000.0, "bending": 2000.0}
MIN_BENDING_LENGTH = 0.5      # m: a shorter link's bending is its joints' tilt


def compliance_damping(k: float, carried: float) -> float:
    """Damping (N·m·s/rad or N·s/m) of a compliance's joint of stiffness ``k``: :data:`DAMPING_RATIO`
    of critical against ``carried`` kg at 1 m (at least 1 kg)."""
    return 2 * DAMPING_RATIO * np.sqrt(k * max(carried, 1.0))


def tilt_joints(joint: str) -> tuple[str, str]:
    """Names of the two hinges that tilt the bearing of ``joint`` (kind ``tilt``)."""
    return f"{joint}_tilt_u", f"{joint}_tilt_v"


def bending_joints(link: str) -> tuple[str, str]:
    """Names of the two hinges that bend ``link`` at mid-length (kind ``bending``)."""
    return f"{link}_bend_u", f"{link}_bend_v"


def bending_child(spec, link: str):
    """The body at the distal end of ``link`` in ``spec`` (its one child body), or None where the
    link has no single child at least :data:`MIN_BENDING_LENGTH` from its origin."""
    body = spec.body(link)
    if body is None:
        return None
    children = list(body.bodies)
    if len(children) != 1 or np.linalg.norm(children[0].pos) < MIN_BENDING_LENGTH:
        return None
    return children[0]


# --- what a compliance writes --------------------------------------------------------------------

def _stiffness_of(compliance: float) -> float:
    return 1 / max(compliance, 1 / RIGID)


def _compliance_model(model, p, x) -> None:
    k = _stiffness_of(p.value(x))
    for t in p.targets:
        j = model.joint(t).id
        model.jnt_stiffness[j] = k
        model.dof_damping[model.jnt_dofadr[j]] = compliance_damping(k, p.carried)


def _compliance_spec(spec, p, x) -> None:
    k = _stiffness_of(p.value(x))
    for t in p.targets:
        j = spec.joint(t)
        j.stiffness = [k, 0, 0]
        j.damping = [compliance_damping(k, p.carried), 0, 0]


def _compliance_read(model, p) -> float:
    k = float(model.jnt_stiffness[model.joint(p.targets[0]).id])
    return 0.0 if k >= RIGID / 2 else 1 / k


def _compliance_perturb(model, dofs, p, u_old, u_new, C, K) -> None:
    k0, k1 = (_stiffness_of(p.value(x)) for x in (u_old, u_new))
    for t in p.targets:
        d = dofs.index(t)
        K[d, d] += k1 - k0
        C[d, d] += compliance_damping(k1, p.carried) - compliance_damping(k0, p.carried)


def _compliance_wide(p) -> tuple:
    return -p.nominal / p.unit, WIDE_FORM.get(p.kind, _WIDE_COMPLIANCE) - p.nominal / p.unit


def _compliance_gross(p) -> list:
    return [p.lower + f * (p.upper - p.lower) for f in (0.0, 0.2, 0.5)]


def _per_unit(value: float) -> float:
    return value / COMPLIANCE_UNIT


# --- the joints a compliance adds ------------------------------------------------------------------

def _add_foundation(spec, where: str) -> bool:
    """The robot on a foundation (:func:`~rmbench.robot.variant.add_compliant_base`), rigid."""
    from rmbench.robot.variant import add_compliant_base

    if any(b.name == "base_mount" for b in spec.bodies):
        return False
    add_compliant_base(spec, RIGID, RIGID)
    return True


def _add_bearing_tilt(spec, joint: str) -> bool:
    """Two hinges appended to the body of the hinge ``joint``, after it (between the joint and its
    link), through its position and about the two axes perpendicular to its axis: the bearing's
    tilt, rigid and damped as :func:`compliance_damping` against the link and all it carries."""
    u_name, v_name = tilt_joints(joint)
    if spec.joint(u_name) is not None:
        return False
    j = spec.joint(joint)
    if j is None or j.type != mujoco.mjtJoint.mjJNT_HINGE:
        raise InputError(f"the robot has no hinge joint {joint!r} for {joint}.tilt_compliance")
    axis = np.asarray(j.axis, float) / np.linalg.norm(j.axis)
    e = np.eye(3)[int(np.argmin(np.abs(axis)))]
    u = e - (e @ axis) * axis
    u /= np.linalg.norm(u)
    body = j.parent
    carried = float(spec.compile().body(body.name).subtreemass[0])
    c = compliance_damping(RIGID, carried)
    for name, ax in ((u_name, u), (v_name, np.cross(u, axis))):
        body.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=ax, pos=np.array(j.pos, float),
                       stiffness=[RIGID, 0, 0], damping=[c, 0, 0])
    return True


def _add_link_bending(spec, link: str) -> bool:
    """``link`` split at mid-length, its distal half a body of its own (``LINK_distal``) on two
    hinges about the two axes perpendicular to the link, carrying the link's distal child and all
    after it: the link's bending, lumped. The two halves share the link's mass equally and keep its
    centre of mass and inertia (:func:`_split_inertia`); the hinges are rigid and damped as
    :func:`compliance_damping` against what the distal half carries."""
    u_name, v_name = bending_joints(link)
    if spec.joint(u_name) is not None:
        return False
    child = bending_child(spec, link)
    if child is None:
        raise InputError(f"the robot has no link {link!r} with one child body at least "
                         f"{MIN_BENDING_LENGTH} m along it for {link}.bending_compliance")
    compiled = spec.compile()
    body = spec.body(link)
    along = np.asarray(child.pos, float)
    d = along / np.linalg.norm(along)
    proximal, distal = _split_inertia(compiled.body(link), d, np.linalg.norm(along), along / 2)
    body.explicitinertial = True
    body.mass, body.ipos, body.iquat, body.inertia = proximal
    half = spec.body(link).add_body(name=f"{link}_distal", pos=along / 2)
    half.explicitinertial = True
    half.mass, half.ipos, half.iquat, half.inertia = distal
    e = np.eye(3)[int(np.argmin(np.abs(d)))]
    u = e - (e @ d) * d
    u /= np.linalg.norm(u)
    carried = float(compiled.body(child.name).subtreemass[0]) + distal[0]
    c = compliance_damping(RIGID, carried)
    for name, ax in ((u_name, u), (v_name, np.cross(d, u))):
        half.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=ax, pos=np.zeros(3),
                       stiffness=[RIGID, 0, 0], damping=[c, 0, 0])
    from rmbench.robot.spec import move_body

    move_body(spec, child, half, np.asarray(child.pos, float) - along / 2)
    return True


def _split_inertia(b, d: np.ndarray, length: float, mid: np.ndarray) -> tuple:
    """``(mass, ipos, iquat, inertia)`` of a link's proximal half (in the link's frame) and of its
    distal half (in a frame at ``mid``): half the mass each, their centres a quarter length either
    side of the link's along ``d``, their inertias what is left of the link's once the two offsets'
    share is taken out (a uniform bar's split exactly), so that together they are the link."""
    m, c = float(b.mass[0]), np.asarray(b.ipos, float)
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, np.asarray(b.iquat, float))
    rot = rot.reshape(3, 3)
    inertia = rot @ np.diag(np.asarray(b.inertia, float)) @ rot.T
    offset = length / 4
    each = inertia / 2 - (m / 2) * offset ** 2 * (np.eye(3) - np.outer(d, d))
    if np.linalg.eigvalsh(each).min() <= 0:      # a link too compact to part: both halves at its centre
        offset, each = 0.0, inertia / 2
    principal, axes = np.linalg.eigh(each)
    if np.linalg.det(axes) < 0:
        axes[:, 0] *= -1
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, axes.ravel())
    return (m / 2, c - offset * d, quat, principal), (m / 2, c + offset * d - mid, quat.copy(), principal.copy())


# the Kind fields every compliance kind shares (rmbench.robot.kinds.KINDS)
_COMPLIANCE = dict(write_model=_compliance_model, write_spec=_compliance_spec, perturb=_compliance_perturb,
                   display=_per_unit, resolution=2 * COMPLIANCE_UNIT, wide=_compliance_wide,
                   gross=_compliance_gross, read_model=_compliance_read)
