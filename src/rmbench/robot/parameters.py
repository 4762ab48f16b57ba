"""The ordinary parameters of a robot model, as data: what model updating fits.

Each :class:`Parameter` names one number of the MJCF (a joint's stiffness or damping, a position
servo's gain, a link's mass or centre of mass, the foundation's tilt compliance, the tool holder's
contact stiffness), where it lives, the scale it is fitted on and its prior range. A
:class:`ParameterSet` is an ordered vector of them over a robot; it writes a vector of values into a
compiled ``MjModel`` (fast: no recompilation, for the hundreds of evaluations of a fit) or into an
``MjSpec`` (to save a calibrated MJCF). Both paths read the same description, so a saved model
is the model that was fitted.

Scales. A parameter is fitted in ``u``: ``u = ln(value / nominal)`` for a log-scaled one (stiffness,
damping, gain, mass: positive, known as a factor), ``u = (value − nominal) / unit`` for a linear one
(a centre-of-mass offset in m, the base's compliance). Its prior range ``[lower, upper]`` is in
``u`` too, and is read as ±2 standard deviations about the nominal (``u = 0``) where that is its
middle.

Groups (``--params``): ``joints`` (gearbox stiffness of each ``*_flex`` joint), ``damping`` (their
damping), ``servo`` (position gain kp of each arm actuator), ``masses`` (mass of each arm link of
5 kg or more, inertia scaled with it), ``com`` (the three components of those links' centres of
mass, in the link's frame), ``base`` (tilt compliance of a foundation the robot is mounted on),
``tool`` (translational and rotational stiffness of the tool-holder contact). The model-form
groups (:data:`OPTIONAL_GROUPS`) are asked for by name only: ``tilt`` (the tilt compliance of
each ``*_flex`` joint's bearing), ``bending`` (the bending compliance of each link 0.5 m or
longer after the first axis's column, lumped in two hinges at mid-length); ``all`` leaves them
out, so that ``--params all`` fits the model it always fitted.

What a parameter edits, and how, is its kind's (:data:`rmbench.robot.kinds.KINDS`): a parameter
is data, and writing it into a model, adding the structure it needs (a foundation, a bearing's
tilt hinges) and its change of the linearised C and K are one registry entry per kind.

Structural parameters (:data:`STRUCTURAL`, ``extra=`` of :func:`parameter_set`) are in no group:
the foundation's lateral compliance, the spindle bearings' radial and tilt stiffness, the tilt
compliance of a joint's bearing (``JOINT.tilt_compliance``), a link's bending compliance
(``LINK.bending_compliance``), any body's mass, and a package on springs at a body, its mass and
tuning (``BODY.resonator_mass``, ``BODY.resonance``: what a localisation tries). A gap diagnosis
adds the ones a candidate effect edits and fits them with no prior
(:meth:`ParameterSet.freed`), beside the ordinary ones: the same description and the same
solver for every parameter.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from rmbench.errors import InputError
from rmbench.robot.compliance import (_WIDE_COMPLIANCE, COMPLIANCE_UNIT, DAMPING_RATIO, RIGID, WIDE_FORM,
                                      bending_child, bending_joints, tilt_joints)
from rmbench.robot.kinds import (_CB_UP, COUNTERBALANCE, KINDS, Kind, _WIDE_LOG, _WIDE_MASS, resonator_body,
                                 resonator_joints)

__all__ = ["GROUPS", "OPTIONAL_GROUPS", "DEFAULT_GROUPS", "STRUCTURAL", "Parameter", "ParameterSet",
           "parameter_set", "parse_groups", "BASE_DAMPING_RATIO"]

GROUPS = ("joints", "damping", "servo", "masses", "com", "base", "tool")
# groups asked for by name only, not in ``all``: adding one there would change what every
# ``--params all`` calibration fits
OPTIONAL_GROUPS = ("tilt", "bending", "counterbalance")
DEFAULT_GROUPS = ("joints", "damping", "servo", "masses")
BASE_DAMPING_RATIO = DAMPING_RATIO     # of the foundation's tilt, against the arm's mass at 1 m
_MIN_LINK_KG = 5.0
# parameters in no group, added by name (``extra=``); also ``BODY.mass`` of any body and
# ``JOINT.tilt_compliance`` of any hinge
STRUCTURAL = ("base.lateral_compliance", "spindle.radial", "spindle.tilt", "tool_contact.translation",
              "tool_contact.rotation")
_TILT = ".tilt_compliance"
_BENDING = ".bending_compliance"
_RESONATOR = (".resonator_mass", ".resonance")     # a package on springs at a body: its mass, its tuning
_DISTAL = "_distal"          # a bent link's distal half: its mass is the link's, split at the nominal


@dataclass(frozen=True)
class Parameter:
    """One ordinary parameter of a robot model.

    The prior mean is the nominal, ``u = 0``.

    Attributes
    ----------
    name : str
        ``TARGET.FIELD``: ``j2_flex.stiffness``, ``a2.kp``, ``upper_arm.mass``, ``upper_arm.com_y``,
        ``base.tilt_compliance``, ``tool_contact.rotation``, ``j2_flex.tilt_compliance``.
    group : str
        One of :data:`GROUPS` or :data:`OPTIONAL_GROUPS`, or ``structural``.
    kind : str
        What it edits and how, a key of :data:`rmbench.robot.kinds.KINDS`: ``stiffness``,
        ``damping``, ``kp``, ``mass``, ``com``, ``base``, ``tilt``.
    targets : tuple of str
        MJCF names of the elements it edits (a joint, several joints, an actuator, a body).
    index : int
        Component of a vector field (the centre of mass: 0, 1, 2); 0 otherwise.
    nominal : float
        Nominal value in SI (N·m/rad, N/m, N·m·s/rad, kg, m, rad/(N·m)).
    log : bool
        Fitted as ``ln(value / nominal)`` (else ``(value − nominal) / unit``).
    unit : float
        SI size of one ``u`` unit of a linear parameter (1 for log ones).
    lower, upper : float
        Prior range in ``u``.
    label : str
        Unit of the displayed value (``N·m/rad``, ``kg``, ``mm``, ``µrad/(kN·m)``).
    scales : tuple of float
        Each target's nominal over :attr:`nominal`, for joints edited together (empty: all 1).
    carried : float
        Mass a compliance (``base``, ``tilt``) carries, kg: its joints' damping is a ratio of
        critical against it at 1 m (:func:`~rmbench.robot.kinds.compliance_damping`); 0 otherwise.
    registry : tuple, optional
        The kinds :attr:`kind` is checked against. None (default): the MJCF edits,
        :data:`~rmbench.robot.kinds.KINDS`. A parameter of a model other than the MJCF names its
        own: names alone (the tracker diagnosis's pose model,
        :data:`rmbench.gap.tracker.sources.SOURCE_KINDS`: no :class:`Kind` to write, free, display
        or resolve it by), or :class:`~rmbench.robot.kinds.Kind` records (a test design's sensor
        placement, :data:`rmbench.calibrate.design.SENSOR_KINDS`: what :class:`ParameterSet` does
        with a parameter, its record says; it writes nothing into the MJCF).
    """

    name: str
    group: str
    kind: str
    targets: tuple
    index: int
    nominal: float
    log: bool
    unit: float
    lower: float
    upper: float
    label: str
    scales: tuple = ()
    carried: float = 0.0
    # the owner's registry, not a global one that another stage would add to: a robot stage that
    # knows nothing of the models above it still checks every kind
    registry: tuple | None = None

    def __post_init__(self):
        kinds = KINDS if self.registry is None else [getattr(k, "name", k) for k in self.registry]
        if self.kind not in kinds:
            raise ValueError(f"unknown parameter kind {self.kind!r} of {self.name}; one of {', '.join(kinds)}")

    @property
    def kind_record(self) -> Kind:
        """What this parameter's kind edits and how (:class:`~rmbench.robot.kinds.Kind`), from its
        registry.

        Raises
        ------
        ValueError
            A kind its registry names without a record (the tracker's pose model)."""
        if self.registry is None:
            return KINDS[self.kind]
        for k in self.registry:
            if isinstance(k, Kind) and k.name == self.kind:
                return k
        raise ValueError(f"{self.name}: its kind {self.kind!r} has no record of how it edits a model")

    @property
    def resolution(self) -> float:
        """The smallest difference that matters, in ``u``: 5 % of a log-scaled value, 5 mm of a
        centre of mass, 2 µrad/(kN·m) of a compliance (its kind's). A parameter the data fix to
        within this (95 % interval) is called identifiable."""
        if self.log:
            return float(np.log(1.05))
        return self.kind_record.resolution / self.unit

    @property
    def sigma(self) -> float:
        """Prior standard deviation in ``u``: a quarter of a range about the nominal, half of one
        the nominal bounds (a half-normal prior: the base is rigid unless the data say otherwise)."""
        if self.lower < 0 < self.upper:
            return (self.upper - self.lower) / 4
        return max(abs(self.lower), abs(self.upper)) / 2

    def target_values(self, u: float) -> list[float]:
        """SI value of each target at ``u``: joints edited together keep their nominal ratios."""
        v = self.value(u)
        return [v * s for s in self.scales] if self.scales else [v] * len(self.targets)

    def value(self, u: float) -> float:
        """SI value at ``u``."""
        return float(self.nominal * np.exp(u)) if self.log else float(self.nominal + self.unit * u)

    def to_u(self, value: float) -> float:
        """``u`` of an SI value."""
        return float(np.log(value / self.nominal)) if self.log else float((value - self.nominal) / self.unit)

    def display(self, value: float) -> float:
        """An SI value in the unit of :attr:`label` (mm for positions, µrad/(kN·m) for a compliance)."""
        return self.kind_record.display(value)


class ParameterSet:
    """An ordered vector of :class:`Parameter` over one robot.

    Parameters
    ----------
    params : sequence of Parameter
    """

    def __init__(self, params):
        self.params = tuple(params)
        names = [p.name for p in self.params]
        if len(set(names)) != len(names):
            raise ValueError("parameter names must be unique")

    def __len__(self) -> int:
        return len(self.params)

    def __iter__(self):
        return iter(self.params)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.params)

    @property
    def groups(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(p.group for p in self.params))

    def freed(self, names) -> "ParameterSet":
        """The same set with the parameters ``names`` given wide bounds (a factor 0.1-10, a mass
        0.5-3 times, a compliance 0-300 units: their kind's): what a fit without their prior may
        need."""
        from dataclasses import replace

        names = set(names)
        unknown = names - set(self.names)
        if unknown:
            raise ValueError(f"no parameters {sorted(unknown)} in the set")
        out = []
        for p in self.params:
            if p.name in names:
                lo, hi = p.kind_record.wide(p)
                p = replace(p, lower=float(min(p.lower, lo)), upper=float(max(p.upper, hi)))
            out.append(p)
        return ParameterSet(out)

    def lower(self) -> np.ndarray:
        return np.array([p.lower for p in self.params])

    def upper(self) -> np.ndarray:
        return np.array([p.upper for p in self.params])

    def sigma(self) -> np.ndarray:
        return np.array([p.sigma for p in self.params])

    def values(self, u) -> np.ndarray:
        """SI values at ``u`` (shape (n,))."""
        return np.array([p.value(x) for p, x in zip(self.params, np.asarray(u, float))])

    def apply_model(self, model: mujoco.MjModel, u) -> None:
        """Write the values at ``u`` into a compiled model, in place (then ``mj_setConst``).

        ``model`` must be compiled from the robot this set describes (its element names and
        nominal values are those the set was built on, as :meth:`robot` gives).
        """
        for p, x in zip(self.params, np.asarray(u, float)):
            p.kind_record.write_model(model, p, x)
        data = mujoco.MjData(model)
        mujoco.mj_setConst(model, data)

    def apply_spec(self, spec: mujoco.MjSpec, u) -> None:
        """Write the values at ``u`` into a specification (to save it as MJCF), in place."""
        for p, x in zip(self.params, np.asarray(u, float)):
            p.kind_record.write_spec(spec, p, x)


def parse_groups(text: str | None) -> tuple[str, ...]:
    """``"joints,damping"`` → ``("joints", "damping")``; None or ``"default"`` gives the default
    groups, ``"all"`` every group of :data:`GROUPS` (those of :data:`OPTIONAL_GROUPS` by name only).

    Raises
    ------
    InputError
        Naming the unknown group.
    """
    if text is None or text.strip() in ("", "default"):
        return DEFAULT_GROUPS
    if text.strip() == "all":
        return GROUPS
    out = tuple(g.strip() for g in text.split(",") if g.strip())
    bad = [g for g in out if g not in GROUPS + OPTIONAL_GROUPS]
    if bad:
        raise InputError(f"unknown parameter group {bad[0]!r}; groups are {', '.join(GROUPS + OPTIONAL_GROUPS)}")
    return tuple(dict.fromkeys(out))


def parameter_set(robot, groups=DEFAULT_GROUPS, extra=()) -> tuple["object", ParameterSet]:
    """The robot to calibrate and its parameters in the chosen groups.

    Parameters
    ----------
    robot : Robot
        The nominal robot (with its tool).
    groups : sequence of str
        Of :data:`GROUPS` and :data:`OPTIONAL_GROUPS`.
    extra : sequence of str
        Further parameters by name, appended after the groups' (one a group already holds is not
        repeated): :data:`STRUCTURAL`, ``BODY.mass``, ``JOINT.tilt_compliance``,
        ``LINK.bending_compliance``, ``BODY.resonator_mass`` or ``BODY.resonance``.
        ``base.lateral_compliance`` mounts the robot on a foundation as the ``base`` group does.

    Returns
    -------
    robot : Robot
        ``robot`` itself, or a copy with the structure the parameters' kinds need
        (:attr:`~rmbench.robot.kinds.Kind.structure`): with the ``base`` group, mounted on a
        foundation; with a bearing's tilt compliance, two tilt hinges after its joint; each rigid at
        the nominal (zero compliance) and softened by the set. A robot that has the structure
        already (a calibrated one, ``calibrated.xml``) keeps it: the compliance it has is the
        parameter's nominal, so a calibrated model can be calibrated again on new data.
    params : ParameterSet

    Raises
    ------
    InputError
        An unknown group, or a group the robot has nothing of (no ``*_flex`` joints, no tool
        contact), or a foundation without equal tilt joints ``base_rx``/``base_ry``.
    """
    groups = parse_groups(",".join(groups)) if not isinstance(groups, str) else parse_groups(groups)
    extra = tuple(dict.fromkeys(extra))
    robot = _with_structure(robot, _structures(robot, groups, extra))
    m = robot.model
    names = _Names.of(robot)
    out: list[Parameter] = []
    for g in groups:
        out += _group(g, m, names)
    have = {p.name for p in out}
    for name in extra:
        if name not in have:
            out.append(_structural(robot, name))
    if not out:
        raise InputError(f"the robot has no parameters in the groups {', '.join(groups)}")
    for g in groups:
        if not any(p.group == g for p in out):
            raise InputError(f"the robot has no parameters in the group {g!r}")
    return robot, ParameterSet(out)


def _structures(robot, groups, extra) -> list:
    """``(kind, where)`` of each structure the parameters need (a foundation, a bearing's tilt)."""
    out = []
    if "base" in groups or "base.lateral_compliance" in extra:
        out.append(("base", "base_mount"))
    tilted = list(_Names.of(robot).flex) if "tilt" in groups else []
    tilted += [n[:-len(_TILT)] for n in extra if n.endswith(_TILT)]
    bent = list(_Names.of(robot).bending) if "bending" in groups else []
    bent += [n[:-len(_BENDING)] for n in extra if n.endswith(_BENDING)]
    out += [("tilt", j) for j in dict.fromkeys(tilted)] + [("bending", b) for b in dict.fromkeys(bent)]
    if "counterbalance" in groups:
        out.append(("spring", robot.arm_joints[1]))
    rings = [n.rsplit(".", 1)[0] for n in extra if n.endswith(_RESONATOR)]
    return out + [("resonator", b) for b in dict.fromkeys(rings)]


def _with_structure(robot, structures):
    """``robot``, or a copy with the structures ``(kind, where)`` its parameters need added."""
    from rmbench.robot.model import Robot
    from rmbench.robot.spec import spec_to_xml

    spec = robot.spec
    added = [KINDS[kind].structure(spec, where) for kind, where in structures]
    if not any(added):
        return robot
    return Robot(spec_to_xml(spec), name=robot.name, tool=robot.tool, spindle_rpm=robot.spindle_rpm, spec=spec)


@dataclass(frozen=True)
class _Names:
    """What a robot has to calibrate: its flexible joints, its arm's position servos and its links
    (bodies of explicit inertia and at least :data:`_MIN_LINK_KG`, motors, spindle, tool and
    foundation left out)."""

    joints: tuple
    flex: tuple
    servos: tuple
    links: tuple
    bending: tuple = ()

    @classmethod
    def of(cls, robot) -> "_Names":
        m, spec = robot.model, robot.spec
        joints = tuple(m.joint(j).name for j in range(m.njnt))
        arm = set(robot.arm_joints)
        servos = tuple(m.actuator(a).name for a in range(m.nu)
                       if m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT
                       and m.joint(int(m.actuator_trnid[a, 0])).name in arm and m.actuator_gainprm[a, 0] > 0)
        links = tuple(b.name for b in spec.bodies
                      if b.name and b.explicitinertial and b.mass >= _MIN_LINK_KG and not b.name.startswith("motor")
                      and not b.name.startswith(("spindle", "tool_", "base_mount")) and not b.name.endswith(_DISTAL))
        # the links that bend: long ones, but not the first (a column on the first axis, whose
        # compliance is its bearing's tilt)
        first = m.body(int(m.jnt_bodyid[m.joint(robot.arm_joints[0]).id])).name
        bending = tuple(b for b in links if b not in _descendants_up_to(spec, first, 2) and (
            bending_child(spec, b) is not None or f"{bending_joints(b)[0]}" in joints))
        return cls(joints, tuple(j for j in joints if j.endswith("_flex")), servos, links, bending)


def _group(g: str, m, names: _Names) -> list:
    """The parameters of group ``g`` (of :data:`GROUPS` and :data:`OPTIONAL_GROUPS`) of the model
    ``m``."""
    ln = np.log
    if g == "joints":
        return [Parameter(f"{j}.stiffness", g, "stiffness", (j,), 0, float(m.jnt_stiffness[m.joint(j).id]),
                          True, 1.0, ln(0.4), ln(2.5), "N·m/rad") for j in names.flex]
    if g == "damping":
        damping = [(j, float(m.dof_damping[m.jnt_dofadr[m.joint(j).id]])) for j in names.flex]
        return [Parameter(f"{j}.damping", g, "damping", (j,), 0, c, True, 1.0, ln(0.25), ln(4.0), "N·m·s/rad")
                for j, c in damping if c > 0]
    if g == "servo":
        return [Parameter(f"{a}.kp", g, "kp", (a,), 0, float(m.actuator(a).gainprm[0]), True, 1.0,
                          ln(0.25), ln(4.0), "N·m/rad") for a in names.servos]
    if g == "masses":
        return [Parameter(f"{b}.mass", g, "mass", (b,), 0, float(m.body(b).mass[0]), True, 1.0,
                          ln(0.8), ln(1.25), "kg") for b in names.links]
    if g == "com":
        return [Parameter(f"{b}.com_{axis}", g, "com", (b,), i, float(m.body(b).ipos[i]), False, 0.01,
                          -25.0, 25.0, "mm") for b in names.links for i, axis in enumerate("xyz")]
    if g == "base":
        return [_compliance("base.tilt_compliance", g, "base", ("base_rx", "base_ry"), _base_tilt(m),
                            _carried(m, "base_mount"), "µrad/(kN·m)")]
    if g == "tilt":
        return [_tilt(f"{j}{_TILT}", g, m) for j in names.flex]
    if g == "bending":
        return [_bending(f"{b}{_BENDING}", g, m) for b in names.bending]
    if g == "counterbalance":
        return _counterbalance(g, m)
    # the tool group
    contact = [f"tool_contact_{a}" for a in ("x", "y", "rx", "ry")]
    if not all(c in names.joints for c in contact):
        raise InputError("the robot has no tool-holder contact joints (tool_contact_x, _y, _rx, _ry) "
                         "for the tool group")
    out = []
    for name, joints in (("translation", contact[:2]), ("rotation", contact[2:])):
        ks = [float(m.jnt_stiffness[m.joint(j).id]) for j in joints]
        out.append(Parameter(f"tool_contact.{name}", g, "stiffness", tuple(joints), 0, ks[0], True, 1.0,
                             ln(0.4), ln(2.5), "N/m" if name == "translation" else "N·m/rad",
                             scales=tuple(k / ks[0] for k in ks)))
    return out


def _structural(robot, name: str) -> Parameter:
    """A parameter in no group (:data:`STRUCTURAL`, ``BODY.mass``, ``JOINT.tilt_compliance``,
    ``LINK.bending_compliance``, a resonator's), its prior range the freed one."""
    m = robot.model
    joints = [m.joint(j).name for j in range(m.njnt)]

    def pair(prefix, axes, field, label):
        targets = tuple(f"{prefix}_{a}" for a in axes)
        if not all(t in joints for t in targets):
            raise InputError(f"the robot has no joints {', '.join(targets)} for {name}")
        ks = [float(m.jnt_stiffness[m.joint(t).id]) for t in targets]
        return Parameter(name, "structural", "stiffness", targets, 0, ks[0], True, 1.0, *_WIDE_LOG, label,
                         scales=tuple(k / ks[0] for k in ks))

    if name == "base.lateral_compliance":
        if not all(t in joints for t in ("base_x", "base_y")):
            raise InputError("the robot's base has no lateral slides (base_x, base_y) for "
                             "base.lateral_compliance")
        return _compliance(name, "structural", "base", ("base_x", "base_y"),
                           _compliance_of(float(m.jnt_stiffness[m.joint("base_x").id])),
                           _carried(m, "base_mount"), "µm/kN")
    if name.endswith(_TILT):
        return _tilt(name, "structural", m)
    if name.endswith(_BENDING):
        return _bending(name, "structural", m)
    if name.endswith(_RESONATOR):
        return _resonator(name, m)
    if name in ("spindle.radial", "spindle.tilt"):
        return pair("spindle", ("x", "y") if name.endswith("radial") else ("rx", "ry"), "stiffness",
                    "N/m" if name.endswith("radial") else "N·m/rad")
    if name in ("tool_contact.translation", "tool_contact.rotation"):
        return pair("tool_contact", ("x", "y") if name.endswith("translation") else ("rx", "ry"), "stiffness",
                    "N/m" if name.endswith("translation") else "N·m/rad")
    if name.endswith(".mass"):
        body = name[:-len(".mass")]
        if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body) < 0:
            raise InputError(f"the robot has no body {body!r} for {name}")
        return Parameter(name, "structural", "mass", (body,), 0, float(m.body(body).mass[0]), True, 1.0,
                         *_WIDE_MASS, "kg")
    raise InputError(f"unknown structural parameter {name!r}; one of {', '.join(STRUCTURAL)}, BODY.mass, "
                     f"JOINT{_TILT}, LINK{_BENDING}, BODY{_RESONATOR[0]} or BODY{_RESONATOR[1]}")


_RESONANCE_HZ = (2.0, 200.0)     # a package's tuning, freed: what rings in a robot's low band and above


def _resonator(name: str, m) -> Parameter:
    """The mass (kg, from absent to 40 kg) or the tuning (Hz, log-scaled, 2-200 Hz freed) of a
    package on springs at a body (``BODY.resonator_mass``, ``BODY.resonance``): a hose, a cable
    chain (:func:`~rmbench.robot.kinds.resonator_joints`)."""
    body, field = name.rsplit(".", 1)
    targets = (resonator_body(body),) + resonator_joints(body)
    mass = float(m.body(targets[0]).mass[0])
    if field == "resonator_mass":
        return Parameter(name, "structural", "resonator", targets, 0, mass, False, 1.0, 0.0, 40.0 - mass, "kg")
    k = float(m.jnt_stiffness[m.joint(targets[1]).id])
    f = float(np.sqrt(k / mass) / (2 * np.pi))
    return Parameter(name, "structural", "resonance", targets, 0, f, True, 1.0,
                     float(np.log(_RESONANCE_HZ[0] / f)), max(0.0, float(np.log(_RESONANCE_HZ[1] / f))), "Hz")


def _compliance(name, group, kind, targets, c0: float, carried: float, label: str) -> Parameter:
    """A compliance of nominal ``c0`` (rad/(N·m) or m/N) in units of :data:`COMPLIANCE_UNIT`, its
    prior half-normal from rigid to the freed range's end."""
    u0 = c0 / COMPLIANCE_UNIT
    return Parameter(name, group, kind, targets, 0, c0, False, COMPLIANCE_UNIT, -u0,
                     WIDE_FORM.get(kind, _WIDE_COMPLIANCE) - u0, label, carried=carried)


def _tilt(name: str, group: str, m) -> Parameter:
    """The tilt compliance of the bearing of the joint ``name`` is of (``JOINT.tilt_compliance``):
    about the two axes perpendicular to the joint's, both alike."""
    joint = name[:-len(_TILT)]
    targets = tilt_joints(joint)
    ks = [float(m.jnt_stiffness[m.joint(t).id]) for t in targets]
    if not np.isclose(ks[0], ks[1], rtol=1e-6):
        raise InputError(f"the bearing of {joint} tilts unequally about {targets[0]} and {targets[1]}")
    return _compliance(name, group, "tilt", targets, _compliance_of(ks[0]),
                       _carried(m, m.body(int(m.jnt_bodyid[m.joint(targets[0]).id])).name), "µrad/(kN·m)")


def _bending(name: str, group: str, m) -> Parameter:
    """The bending compliance of the link ``name`` is of (``LINK.bending_compliance``): about the
    two axes perpendicular to the link, both alike."""
    targets = bending_joints(name[:-len(_BENDING)])
    ks = [float(m.jnt_stiffness[m.joint(t).id]) for t in targets]
    if not np.isclose(ks[0], ks[1], rtol=1e-6):
        raise InputError(f"{name[:-len(_BENDING)]} bends unequally about {targets[0]} and {targets[1]}")
    return _compliance(name, group, "bending", targets, _compliance_of(ks[0]),
                       _carried(m, m.body(int(m.jnt_bodyid[m.joint(targets[0]).id])).name), "µrad/(kN·m)")


def _counterbalance(group: str, m) -> list:
    """A counterbalance on the second axis (:func:`~rmbench.robot.kinds.counterbalance_geometry`),
    absent at the nominal: its stiffness, 0-20 MN/m in units of 0.1 MN/m, where its foot sits on
    a circle about the axis (±60° from behind it, in degrees), how far up the link its head sits
    (0.1-0.6 m, in mm about 0.35 m) and its compression at the zero
    posture, 0-60 mm (a gas spring of 0.5-5 MN/m carries 2-20 kN: 1-40 mm); half-normal priors
    from zero over those ranges, a normal one for the angle."""
    if COUNTERBALANCE not in [m.tendon(t).name for t in range(m.ntendon)]:
        raise InputError("the robot has no counterbalance tendon for the counterbalance group")
    # the axis it balances: the joint of the body that carries the link its head is on
    motor = int(m.body_parentid[m.site_bodyid[m.site(f"{COUNTERBALANCE}_head").id]])
    joint = m.joint(int(m.body_jntadr[motor])).name
    return [Parameter("counterbalance.stiffness", group, "spring", (COUNTERBALANCE,), 0, 0.0, False,
                      1e5, 0.0, 200.0, "MN/m"),
            # before the preload: its compression is taken from the spring's length with the foot
            # where this puts it
            Parameter("counterbalance.foot_angle", group, "foot", (f"{COUNTERBALANCE}_foot", joint), 0, 0.0,
                      False, np.radians(1.0), -60.0, 60.0, "°"),
            Parameter("counterbalance.head", group, "head", (f"{COUNTERBALANCE}_head",), 0, _CB_UP, False,
                      1e-3, -250.0, 250.0, "mm"),
            Parameter("counterbalance.preload", group, "preload", (COUNTERBALANCE,), 0, 0.0, False,
                      1e-3, 0.0, 60.0, "mm")]


def _descendants_up_to(spec, body: str, depth: int) -> set:
    """``body`` and its descendants down to ``depth`` generations (a motor body and its link)."""
    out, level = {body}, [spec.body(body)]
    for _ in range(depth):
        level = [c for b in level for c in b.bodies]
        out |= {c.name for c in level}
    return out


def _base_tilt(m) -> float:
    """The foundation's tilt compliance, rad/(N·m), checked: equal about x and y."""
    names = [m.joint(j).name for j in range(m.njnt)]
    if not all(t in names for t in ("base_rx", "base_ry")):
        raise InputError("the robot already stands on a base without tilt joints (base_rx, "
                         "base_ry); calibrate it without the base group")
    k_rx, k_ry = (float(m.jnt_stiffness[m.joint(t).id]) for t in ("base_rx", "base_ry"))
    if not np.isclose(k_rx, k_ry, rtol=1e-6):
        raise InputError("the robot's base tilts unequally about x and y; calibrate it without "
                         "the base group")
    return _compliance_of(k_rx)


def _compliance_of(k: float) -> float:
    """The compliance of a joint of stiffness ``k``: 0 if it is rigid (:data:`RIGID`)."""
    return 0.0 if k >= RIGID / 2 else 1 / k


def _carried(m, body: str) -> float:
    """Mass (kg) of ``body`` and all it carries."""
    return float(m.body_subtreemass[m.body(body).id])
