"""What each kind of model parameter edits: one registry entry per kind.

A :class:`~rmbench.robot.parameters.Parameter` says *which* number it is (name, targets, nominal,
scale, prior); its kind says *how* that number reaches a model. :data:`KINDS` maps each kind to a
frozen :class:`Kind` holding the few functions that do it:

===============  ==========================================================  ===========  ==========
kind             edits                                                       structure    C, K only
===============  ==========================================================  ===========  ==========
``stiffness``    a joint's stiffness (several joints in fixed ratios)        --           yes
``damping``      a joint's damping                                           --           yes
``kp``           a position servo's gain (its gain and bias together)        --           yes
``mass``         a body's mass, its inertia scaled with it                   --           no
``com``          one component of a body's centre of mass                    --           no
``base``         a foundation's compliance (its tilt or lateral joints)      foundation   yes
``tilt``         a joint bearing's tilt compliance (two hinges after it)     two hinges   yes
``bending``      a link's bending compliance (its distal half on two hinges)  half, hinges yes
``spring``       a counterbalance spring's stiffness (a tendon's)            the spring   no
``foot``         where a counterbalance spring's foot sits about the axis    the spring   no
``head``         how far up the link a counterbalance spring's head sits    the spring   no
``preload``      a counterbalance spring's compression at the zero posture  the spring   no
``resonator``    the mass of a package on springs at a body (its tuning kept) the package  no
``resonance``    that package's frequency against the body held still        the package  yes
===============  ==========================================================  ===========  ==========

A compliance (``base``, ``tilt``, ``bending``) is the inverse stiffness of its joints, 0 rigid
(:data:`RIGID`); their damping follows the stiffness at :data:`DAMPING_RATIO` of critical
against the mass the parameter carries at 1 m (:attr:`Parameter.carried`). The joints they add
and what they write are :mod:`rmbench.robot.compliance`'s (its public names are importable here
too).

A counterbalance (``spring``, ``preload``) is a spatial tendon from the carousel behind the
second axis to the lower arm above it (:func:`counterbalance_geometry`), a linear spring absent at
the nominal (stiffness 0): pushing the arm up, it adds a stiffness about the axis that follows the
posture (its lever arm changes with the angle, and its preload acts through the geometry).

A resonator (``resonator``, ``resonance``) is a package on three equal slide springs at a body's
centre of mass (:func:`resonator_joints`), damped :data:`RESONATOR_ZETA` of critical: a hose, a
cable chain, a valve pack, anything that rings on its own. Absent at the nominal, it is a
:data:`RESONATOR_MASS` kg package tuned to :data:`RESONATOR_ABSENT_HZ`, far above every band.

Only the kinds whose change enters the linearisation through C and K alone have a matrix
perturbation (:attr:`Kind.perturb`): a mass or a centre of mass moves the equilibrium and the
gravity stiffness, so a model with a new one must be settled again.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import mujoco
import numpy as np

from rmbench.errors import InputError
from rmbench.robot.compliance import (_COMPLIANCE, COMPLIANCE_UNIT, DAMPING_RATIO, RIGID, WIDE_FORM,
                                      _add_bearing_tilt, _add_foundation, _add_link_bending, bending_child,
                                      bending_joints, compliance_damping, tilt_joints)

__all__ = ["Kind", "KINDS", "RIGID", "COMPLIANCE_UNIT", "DAMPING_RATIO", "WIDE_FORM", "compliance_damping",
           "tilt_joints", "bending_joints", "bending_child", "COUNTERBALANCE", "counterbalance_geometry",
           "RESONATOR_ZETA", "RESONATOR_MASS", "RESONATOR_ABSENT_HZ", "resonator_body", "resonator_joints"]

_WIDE_LOG = (np.log(0.1), np.log(10.0))     # a freed factor: a tenth to ten times the nominal
_WIDE_MASS = (np.log(0.5), np.log(3.0))     # a freed mass: half to three times
COUNTERBALANCE = "counterbalance"     # the counterbalance spring's tendon
_CB_BEHIND = 0.35             # m: the spring's foot behind the second axis, on the carousel
_CB_UP = 0.35                 # m: its head up the lower arm from the axis
RESONATOR_ZETA = 0.05         # a package's damping, of critical (a hose's rubber, a cable chain)
RESONATOR_MASS = 0.01         # kg: an absent package's mass (a body with joints needs one)
RESONATOR_ABSENT_HZ = 1e5     # an absent package's tuning: far above every band, it moves in no mode


@dataclass(frozen=True)
class Kind:
    """How parameters of one kind edit a robot model.

    Each function takes the parameter ``p`` and its value in ``u`` (``p.value(x)`` in SI).

    Attributes
    ----------
    name : str
        The kind, as :attr:`Parameter.kind` names it.
    write_model : callable ``(model, p, x) -> None``
        Write the value into a compiled ``MjModel``, in place (the caller runs ``mj_setConst``).
    write_spec : callable ``(spec, p, x) -> None``
        Write the value into an ``MjSpec``, in place: compiled, it is the model ``write_model``
        gives.
    structure : callable ``(spec, where) -> bool``, optional
        Add to an ``MjSpec`` the elements a parameter of this kind at ``where`` edits (the
        foundation, a bearing's tilt hinges), rigid at the nominal; False if the spec has them
        already (they are kept: their state is the nominal). None: the kind edits what is there.
    perturb : callable ``(model, dofs, p, u_old, u_new, C, K) -> None``, optional
        Add to the linearised C and K (shape (n_dof, n_dof), rows named by ``dofs``), in place,
        what moving ``p`` from ``u_old`` to ``u_new`` changes, at the same settled state. None for
        a kind that moves the equilibrium (mass, centre of mass).
    display : callable ``float -> float``
        An SI value in the unit of :attr:`Parameter.label`.
    resolution : float or None
        Of a linearly scaled parameter, the smallest difference that matters, SI (None: log-scaled,
        5 %).
    wide : callable ``p -> (lower, upper)``
        A freed parameter's range in ``u`` (:meth:`ParameterSet.freed`), before its prior's range
        is added to it.
    gross : callable ``p -> list of float``
        A freed parameter's trial sizes in ``u`` (the nominal and a structural fault's gross
        sizes) for a fit's start.
    read_model : callable ``(model, p) -> float``, optional
        The SI value ``p`` has in a compiled model (of a joint group, its first target's over
        its scale): where a perturbation starts from a model whose value is not the parameter's
        own (a joint a posture's load has stiffened). None: not read.
    """

    name: str
    write_model: Callable
    write_spec: Callable
    structure: Callable | None = None
    perturb: Callable | None = None
    display: Callable = lambda value: value
    resolution: float | None = None
    wide: Callable = lambda p: _WIDE_LOG
    gross: Callable = lambda p: [0.0, float(np.log(1 / 3)), float(np.log(3.0))]
    read_model: Callable | None = None


def resonator_body(body: str) -> str:
    """Name of the package body of a resonator at ``body`` (kinds ``resonator``, ``resonance``)."""
    return f"{body}_resonator"


def resonator_joints(body: str) -> tuple[str, str, str]:
    """Names of the three slides a resonator's package at ``body`` rides on."""
    return tuple(f"{body}_resonator_{a}" for a in "xyz")


# --- joints' stiffness and damping ---------------------------------------------------------------

def _stiffness_model(model, p, x) -> None:
    for t, v in zip(p.targets, p.target_values(x)):
        model.jnt_stiffness[model.joint(t).id] = v


def _damping_model(model, p, x) -> None:
    for t, v in zip(p.targets, p.target_values(x)):
        model.dof_damping[model.jnt_dofadr[model.joint(t).id]] = v


def _joint_spec(field: str) -> Callable:
    def write(spec, p, x) -> None:
        for t, v in zip(p.targets, p.target_values(x)):
            j = spec.joint(t)
            arr = np.array(getattr(j, field), float)
            arr[0] = v
            setattr(j, field, arr)
    return write


def _first_target(value: float, p) -> float:
    """A joint group's parameter value from its first target's (they keep their nominal ratios)."""
    return value / p.scales[0] if p.scales else value


def _stiffness_read(model, p) -> float:
    return _first_target(float(model.jnt_stiffness[model.joint(p.targets[0]).id]), p)


def _damping_read(model, p) -> float:
    return _first_target(float(model.dof_damping[model.jnt_dofadr[model.joint(p.targets[0]).id]]), p)


def _diagonal(matrix: str) -> Callable:
    """Perturbation of joints' stiffness (``"K"``) or damping (``"C"``): their diagonal entries."""
    def perturb(model, dofs, p, u_old, u_new, C, K) -> None:
        m = K if matrix == "K" else C
        for t, a, c in zip(p.targets, p.target_values(u_old), p.target_values(u_new)):
            m[dofs.index(t), dofs.index(t)] += c - a
    return perturb


# --- servo gain ----------------------------------------------------------------------------------

def _kp_model(model, p, x) -> None:
    v = p.value(x)
    a = model.actuator(p.targets[0]).id
    model.actuator_gainprm[a, 0] = v
    model.actuator_biasprm[a, 1] = -v


def _kp_spec(spec, p, x) -> None:
    v = p.value(x)
    act = spec.actuator(p.targets[0])
    gain, bias = np.array(act.gainprm, float), np.array(act.biasprm, float)
    gain[0], bias[1] = v, -v
    act.gainprm, act.biasprm = gain, bias


def _kp_read(model, p) -> float:
    return float(model.actuator_gainprm[model.actuator(p.targets[0]).id, 0])


def _kp_perturb(model, dofs, p, u_old, u_new, C, K) -> None:
    for t, a, c in zip(p.targets, p.target_values(u_old), p.target_values(u_new)):
        d = dofs.index(model.joint(int(model.actuator(t).trnid[0])).name)
        K[d, d] += c - a


# --- mass and centre of mass ---------------------------------------------------------------------

def _mass_model(model, p, x) -> None:
    v = p.value(x)
    b = model.body(p.targets[0]).id
    model.body_inertia[b] *= v / model.body_mass[b]
    model.body_mass[b] = v


def _mass_spec(spec, p, x) -> None:
    v = p.value(x)
    body = spec.body(p.targets[0])
    if not body.explicitinertial:
        _make_inertial_explicit(spec, body)
    scale = v / body.mass
    body.mass = v
    if body.fullinertia is not None and np.any(np.isfinite(body.fullinertia)) and \
            np.any(np.array(body.fullinertia)[:3] > 0):
        body.fullinertia = np.array(body.fullinertia) * scale
    body.inertia = np.array(body.inertia) * scale


def _make_inertial_explicit(spec: mujoco.MjSpec, body) -> None:
    """Give ``body`` the inertia its geoms imply, explicitly: a mass set on a body whose inertia
    comes from its geoms would not reach the compiled model (an older model's foundation plate)."""
    b = spec.compile().body(body.name)
    body.mass = float(b.mass[0])
    body.ipos, body.iquat, body.inertia = b.ipos.copy(), b.iquat.copy(), b.inertia.copy()
    body.explicitinertial = True


def _com_model(model, p, x) -> None:
    model.body_ipos[model.body(p.targets[0]).id, p.index] = p.value(x)


def _com_spec(spec, p, x) -> None:
    body = spec.body(p.targets[0])
    pos = np.array(body.ipos, float)
    pos[p.index] = p.value(x)
    body.ipos = pos


def counterbalance_geometry(spec, joint: str) -> tuple:
    """``(foot_body, foot, head_body, head)``: where a counterbalance of the hinge ``joint`` (the
    second axis, lifting the lower arm) is mounted, each point in its body's frame, m. The foot on
    the body the joint's motor hangs from, :data:`_CB_BEHIND` behind the axis (away from the
    arm's reach, −x); the head on the link the joint drives, :data:`_CB_UP` along it. A real
    robot's mounts differ: the spring's stiffness and preload, fitted, take up most of it."""
    j = spec.joint(joint)
    if j is None or j.type != mujoco.mjtJoint.mjJNT_HINGE:
        raise InputError(f"the robot has no hinge joint {joint!r} for a counterbalance")
    motor = j.parent
    links = list(motor.bodies)
    if motor.parent is None or len(links) != 1:
        raise InputError(f"{joint}'s body has no single link after it to mount a counterbalance on")
    link = links[0]
    child = bending_child(spec, link.name)
    along = np.array([0.0, 0.0, 1.0]) if child is None else np.asarray(child.pos, float)
    foot = _foot(np.asarray(motor.pos, float) + np.asarray(j.pos, float), 0.0)
    return motor.parent, foot, link, _CB_UP * along / np.linalg.norm(along)


def _add_counterbalance(spec, joint: str) -> bool:
    """The counterbalance spring of ``joint`` (:func:`counterbalance_geometry`): two sites and a
    spatial tendon between them, of stiffness 0 (absent) and its spring length its length at the
    zero posture."""
    if any(t.name == COUNTERBALANCE for t in spec.tendons):
        return False
    foot_body, foot, head_body, head = counterbalance_geometry(spec, joint)
    foot_body.add_site(name=f"{COUNTERBALANCE}_foot", pos=foot)
    head_body.add_site(name=f"{COUNTERBALANCE}_head", pos=head)
    t = spec.add_tendon(name=COUNTERBALANCE, stiffness=[0.0, 0.0, 0.0])
    t.wrap_site(f"{COUNTERBALANCE}_foot")
    t.wrap_site(f"{COUNTERBALANCE}_head")
    return True


def _spring_model(model, p, x) -> None:
    model.tendon_stiffness[model.tendon(p.targets[0]).id] = p.value(x)


def _spring_spec(spec, p, x) -> None:
    _tendon(spec, p).stiffness = [p.value(x), 0.0, 0.0]


def _preload_model(model, p, x) -> None:
    t = model.tendon(p.targets[0]).id
    model.tendon_lengthspring[t] = _zero_length(model) + p.value(x)


def _preload_spec(spec, p, x) -> None:
    _tendon(spec, p).springlength = [_zero_length(spec.compile()) + p.value(x)] * 2


def _zero_length(model) -> float:
    """Length of the counterbalance at the zero posture (every joint at its reference), m, with
    its mounts where the model has them now (the foot's angle written before)."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    foot, head = (data.site_xpos[model.site(f"{COUNTERBALANCE}_{end}").id] for end in ("foot", "head"))
    return float(np.linalg.norm(head - foot))


def _foot(axis_point, angle: float) -> np.ndarray:
    """The counterbalance's foot on a circle of :data:`_CB_BEHIND` about the second axis, in the
    plane the arm swings in: behind it at ``angle`` 0, below it at +90° (rad)."""
    return np.asarray(axis_point, float) + _CB_BEHIND * np.array([-np.cos(angle), 0.0, -np.sin(angle)])


def _foot_model(model, p, x) -> None:
    j = model.joint(p.targets[1]).id
    axis_point = model.body_pos[model.jnt_bodyid[j]] + model.jnt_pos[j]
    model.site_pos[model.site(p.targets[0]).id] = _foot(axis_point, p.value(x))


def _head_model(model, p, x) -> None:
    i = model.site(p.targets[0]).id
    model.site_pos[i] = model.site_pos[i] / np.linalg.norm(model.site_pos[i]) * p.value(x)


def _head_spec(spec, p, x) -> None:
    site = spec.site(p.targets[0])
    pos = np.asarray(site.pos, float)
    site.pos = pos / np.linalg.norm(pos) * p.value(x)


def _foot_spec(spec, p, x) -> None:
    j = spec.joint(p.targets[1])
    spec.site(p.targets[0]).pos = _foot(np.asarray(j.parent.pos, float) + np.asarray(j.pos, float), p.value(x))


def _tendon(spec, p):
    for t in spec.tendons:
        if t.name == p.targets[0]:
            return t
    raise InputError(f"the robot has no tendon {p.targets[0]!r} for {p.name}")


# --- a resonator: a package on springs ----------------------------------------------------------

def _add_resonator(spec, body: str) -> bool:
    """A package at the centre of mass of ``body`` on three slides along the body's axes
    (:func:`resonator_joints`), absent: :data:`RESONATOR_MASS` kg, taken from the link's, tuned
    to :data:`RESONATOR_ABSENT_HZ`."""
    name = resonator_body(body)
    if spec.body(name) is not None:
        return False
    parent = spec.body(body)
    if parent is None:
        raise InputError(f"the robot has no body {body!r} for a resonator")
    pos = spec.compile().body(body).ipos.copy()
    if not parent.explicitinertial:
        _make_inertial_explicit(spec, parent)
    parent.mass = float(parent.mass) - RESONATOR_MASS    # at the link's centre: its mass and centre kept
    package = parent.add_body(name=name, pos=pos)
    package.explicitinertial = True
    package.mass, package.ipos, package.iquat = RESONATOR_MASS, np.zeros(3), np.array([1.0, 0, 0, 0])
    package.inertia = _package_inertia(RESONATOR_MASS)
    k, c = _tuned(RESONATOR_MASS, RESONATOR_ABSENT_HZ)
    for joint, axis in zip(resonator_joints(body), np.eye(3)):
        package.add_joint(name=joint, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis, pos=np.zeros(3),
                          stiffness=[k, 0, 0], damping=[c, 0, 0])
    return True


def _package_inertia(mass: float) -> np.ndarray:
    # a 4 cm sphere: the package's own rotation rings far above the bands
    return np.full(3, 0.4 * mass * 0.04 ** 2)


def _tuned(mass: float, f_hz: float) -> tuple[float, float]:
    """Stiffness (N/m) and damping (N·s/m) of a package of ``mass`` kg ringing at ``f_hz``."""
    w = 2 * np.pi * f_hz
    return mass * w * w, 2 * RESONATOR_ZETA * mass * w


def _resonator_model(model, p, x) -> None:
    b = model.body(p.targets[0]).id
    m_old, m = float(model.body_mass[b]), p.value(x)
    model.body_mass[b], model.body_inertia[b] = m, _package_inertia(m)
    for t in p.targets[1:]:     # stiffness and damping with the mass: the tuning kept
        j = model.joint(t).id
        model.jnt_stiffness[j] *= m / m_old
        model.dof_damping[model.jnt_dofadr[j]] *= m / m_old


def _resonator_spec(spec, p, x) -> None:
    body = spec.body(p.targets[0])
    m_old, m = float(body.mass), p.value(x)
    body.mass, body.inertia = m, _package_inertia(m)
    for t in p.targets[1:]:
        j = spec.joint(t)
        j.stiffness = [j.stiffness[0] * m / m_old, 0, 0]
        j.damping = [j.damping[0] * m / m_old, 0, 0]


def _resonance_model(model, p, x) -> None:
    k, c = _tuned(float(model.body_mass[model.body(p.targets[0]).id]), p.value(x))
    for t in p.targets[1:]:
        j = model.joint(t).id
        model.jnt_stiffness[j], model.dof_damping[model.jnt_dofadr[j]] = k, c


def _resonance_spec(spec, p, x) -> None:
    k, c = _tuned(float(spec.body(p.targets[0]).mass), p.value(x))
    for t in p.targets[1:]:
        j = spec.joint(t)
        j.stiffness, j.damping = [k, 0, 0], [c, 0, 0]


def _resonance_perturb(model, dofs, p, u_old, u_new, C, K) -> None:
    m = float(model.body_mass[model.body(p.targets[0]).id])
    (k0, c0), (k1, c1) = (_tuned(m, p.value(x)) for x in (u_old, u_new))
    for t in p.targets[1:]:
        d = dofs.index(t)
        K[d, d] += k1 - k0
        C[d, d] += c1 - c0



KINDS: dict[str, Kind] = {k.name: k for k in (
    Kind("stiffness", _stiffness_model, _joint_spec("stiffness"), perturb=_diagonal("K"), read_model=_stiffness_read),
    Kind("damping", _damping_model, _joint_spec("damping"), perturb=_diagonal("C"), read_model=_damping_read),
    Kind("kp", _kp_model, _kp_spec, perturb=_kp_perturb, read_model=_kp_read),
    Kind("mass", _mass_model, _mass_spec, wide=lambda p: _WIDE_MASS,
         gross=lambda p: [0.0, float(np.log(0.7)), float(np.log(1.5))]),
    Kind("com", _com_model, _com_spec, display=lambda value: 1e3 * value, resolution=0.005),
    Kind("base", structure=_add_foundation, **_COMPLIANCE),
    Kind("tilt", structure=_add_bearing_tilt, **_COMPLIANCE),
    Kind("bending", structure=_add_link_bending, **_COMPLIANCE),
    Kind("spring", _spring_model, _spring_spec, structure=_add_counterbalance,
         display=lambda value: value / 1e6, resolution=1e5, wide=lambda p: (0.0, 200.0),
         gross=lambda p: [0.0, 20.0, 60.0]),
    Kind("foot", _foot_model, _foot_spec, structure=_add_counterbalance,
         display=np.degrees, resolution=np.radians(2.0), wide=lambda p: (p.lower, p.upper),
         gross=lambda p: [0.0, -30.0, 30.0]),
    Kind("head", _head_model, _head_spec, structure=_add_counterbalance,
         display=lambda value: 1e3 * value, resolution=0.01, wide=lambda p: (p.lower, p.upper),
         gross=lambda p: [0.0, -0.1 / p.unit, 0.15 / p.unit]),
    Kind("preload", _preload_model, _preload_spec, structure=_add_counterbalance,
         display=lambda value: 1e3 * value, resolution=5e-4, wide=lambda p: (0.0, 60.0),
         gross=lambda p: [0.0, 5.0, 20.0]),
    Kind("resonator", _resonator_model, _resonator_spec, structure=_add_resonator, resolution=0.5,
         wide=lambda p: (0.0, 40.0), gross=lambda p: [0.0, 5.0, 15.0]),
    Kind("resonance", _resonance_model, _resonance_spec, structure=_add_resonator, perturb=_resonance_perturb,
         wide=lambda p: (p.lower, p.upper), gross=lambda p: [p.lower, 0.5 * (p.lower + p.upper), p.upper]),
)}
