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
``tool`` (translational and rotational stiffness of the tool-holder contact).

Structural parameters (:data:`STRUCTURAL`, ``extra=`` of :func:`parameter_set`) are in no group:
the foundation's lateral compliance, the spindle bearings' radial and tilt stiffness, and any
body's mass. A gap diagnosis adds the ones a candidate effect edits and fits them with no prior
(:meth:`ParameterSet.freed`), beside the ordinary ones: the same description and the same
solver for every parameter.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from rmbench.errors import InputError

__all__ = ["GROUPS", "DEFAULT_GROUPS", "STRUCTURAL", "Parameter", "ParameterSet", "parameter_set",
           "parse_groups", "BASE_DAMPING_RATIO"]

GROUPS = ("joints", "damping", "servo", "masses", "com", "base", "tool")
DEFAULT_GROUPS = ("joints", "damping", "servo", "masses")
BASE_DAMPING_RATIO = 0.05     # of the foundation's tilt, against the arm's mass at 1 m
_RIGID = 1e14                 # N/m or N·m/rad: a mount this stiff is rigid in every band
_BASE_UNIT = 1e-9             # 1 µrad/(kN·m) in rad/(N·m)
_MIN_LINK_KG = 5.0
# parameters in no group, added by name (``extra=``); also ``BODY.mass`` of any body
STRUCTURAL = ("base.lateral_compliance", "spindle.radial", "spindle.tilt", "tool_contact.translation",
              "tool_contact.rotation")
_WIDE_LOG = (np.log(0.1), np.log(10.0))     # a freed factor: a tenth to ten times the nominal
_WIDE_MASS = (np.log(0.5), np.log(3.0))     # a freed mass: half to three times


@dataclass(frozen=True)
class Parameter:
    """One ordinary parameter of a robot model.

    The prior mean is the nominal, ``u = 0``.

    Attributes
    ----------
    name : str
        ``TARGET.FIELD``: ``j2_flex.stiffness``, ``a2.kp``, ``upper_arm.mass``, ``upper_arm.com_y``,
        ``base.tilt_compliance``, ``tool_contact.rotation``.
    group : str
        One of :data:`GROUPS`.
    kind : str
        What it edits: ``stiffness``, ``damping``, ``kp``, ``mass``, ``com``, ``base``.
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

    @property
    def resolution(self) -> float:
        """The smallest difference that matters, in ``u``: 5 % of a log-scaled value, 5 mm of a
        centre of mass, 2 µrad/(kN·m) of the base's compliance. A parameter the data fix to within
        this (95 % interval) is called identifiable."""
        if self.log:
            return float(np.log(1.05))
        if self.kind == "com":
            return 0.005 / self.unit
        return 2 * _BASE_UNIT / self.unit

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
        """An SI value in the unit of :attr:`label` (mm for positions, µrad/(kN·m) for the base)."""
        if self.kind == "com":
            return 1e3 * value
        if self.kind == "base":
            return value / _BASE_UNIT
        return value


class ParameterSet:
    """An ordered vector of :class:`Parameter` over one robot.

    Parameters
    ----------
    params : sequence of Parameter
    base_mass : float
        Mass carried by the foundation's tilt (arm and base plate), kg; sets the base damping.
    """

    def __init__(self, params, *, base_mass: float = 0.0):
        self.params = tuple(params)
        names = [p.name for p in self.params]
        if len(set(names)) != len(names):
            raise ValueError("parameter names must be unique")
        self.base_mass = float(base_mass)

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
        0.5-3 times, a foundation 0-300 units): what a fit without their prior may need."""
        from dataclasses import replace

        names = set(names)
        unknown = names - set(self.names)
        if unknown:
            raise ValueError(f"no parameters {sorted(unknown)} in the set")
        out = []
        for p in self.params:
            if p.name in names:
                if p.kind == "base":
                    lo, hi = min(p.lower, -p.nominal / p.unit), max(p.upper, 300.0 - p.nominal / p.unit)
                else:
                    lo, hi = _WIDE_MASS if p.kind == "mass" else _WIDE_LOG
                    lo, hi = min(p.lower, lo), max(p.upper, hi)
                p = replace(p, lower=float(lo), upper=float(hi))
            out.append(p)
        return ParameterSet(out, base_mass=self.base_mass)

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
            v = p.value(x)
            if p.kind == "stiffness":
                for t, vt in zip(p.targets, p.target_values(x)):
                    model.jnt_stiffness[model.joint(t).id] = vt
            elif p.kind == "damping":
                for t, vt in zip(p.targets, p.target_values(x)):
                    model.dof_damping[model.jnt_dofadr[model.joint(t).id]] = vt
            elif p.kind == "kp":
                a = model.actuator(p.targets[0]).id
                model.actuator_gainprm[a, 0] = v
                model.actuator_biasprm[a, 1] = -v
            elif p.kind == "mass":
                b = model.body(p.targets[0]).id
                model.body_inertia[b] *= v / model.body_mass[b]
                model.body_mass[b] = v
            elif p.kind == "com":
                model.body_ipos[model.body(p.targets[0]).id, p.index] = v
            elif p.kind == "base":
                k = _base_stiffness(v)
                for t in p.targets:
                    j = model.joint(t).id
                    model.jnt_stiffness[j] = k
                    model.dof_damping[model.jnt_dofadr[j]] = self.base_damping(k)
        data = mujoco.MjData(model)
        mujoco.mj_setConst(model, data)

    def apply_spec(self, spec: mujoco.MjSpec, u) -> None:
        """Write the values at ``u`` into a specification (to save it as MJCF), in place."""
        for p, x in zip(self.params, np.asarray(u, float)):
            v = p.value(x)
            if p.kind in ("stiffness", "damping"):
                for t, vt in zip(p.targets, p.target_values(x)):
                    j = spec.joint(t)
                    arr = np.array(getattr(j, p.kind), float)
                    arr[0] = vt
                    setattr(j, p.kind, arr)
            elif p.kind == "kp":
                act = spec.actuator(p.targets[0])
                gain, bias = np.array(act.gainprm, float), np.array(act.biasprm, float)
                gain[0], bias[1] = v, -v
                act.gainprm, act.biasprm = gain, bias
            elif p.kind == "mass":
                body = spec.body(p.targets[0])
                if not body.explicitinertial:
                    _make_inertial_explicit(spec, body)
                scale = v / body.mass
                body.mass = v
                if body.fullinertia is not None and np.any(np.isfinite(body.fullinertia)) and \
                        np.any(np.array(body.fullinertia)[:3] > 0):
                    body.fullinertia = np.array(body.fullinertia) * scale
                body.inertia = np.array(body.inertia) * scale
            elif p.kind == "com":
                body = spec.body(p.targets[0])
                pos = np.array(body.ipos, float)
                pos[p.index] = v
                body.ipos = pos
            elif p.kind == "base":
                k = _base_stiffness(v)
                for t in p.targets:
                    j = spec.joint(t)
                    j.stiffness = [k, 0, 0]
                    j.damping = [self.base_damping(k), 0, 0]

    def base_damping(self, k: float) -> float:
        """Damping (N·m·s/rad) of a base tilt of stiffness ``k`` (N·m/rad): :data:`BASE_DAMPING_RATIO`
        of critical against :attr:`base_mass` at 1 m."""
        return 2 * BASE_DAMPING_RATIO * np.sqrt(k * max(self.base_mass, 1.0))


def _base_stiffness(compliance: float) -> float:
    return 1 / max(compliance, 1 / _RIGID)


def parse_groups(text: str | None) -> tuple[str, ...]:
    """``"joints,damping"`` → ``("joints", "damping")``; None or ``"default"`` gives the default
    groups, ``"all"`` every group.

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
    bad = [g for g in out if g not in GROUPS]
    if bad:
        raise InputError(f"unknown parameter group {bad[0]!r}; groups are {', '.join(GROUPS)}")
    return tuple(dict.fromkeys(out))


def parameter_set(robot, groups=DEFAULT_GROUPS, extra=()) -> tuple["object", ParameterSet]:
    """The robot to calibrate and its parameters in the chosen groups.

    Parameters
    ----------
    robot : Robot
        The nominal robot (with its tool).
    groups : sequence of str
        Of :data:`GROUPS`.
    extra : sequence of str
        Further parameters by name, appended after the groups' (one a group already holds is not
        repeated): :data:`STRUCTURAL` or ``BODY.mass``. ``base.lateral_compliance`` mounts the
        robot on a foundation as the ``base`` group does.

    Returns
    -------
    robot : Robot
        ``robot`` itself, or, with the ``base`` group, a copy mounted on a foundation that is
        rigid at the nominal (zero tilt compliance) and whose tilt the set can soften. A robot
        already on a foundation (a calibrated one, ``calibrated.xml``) keeps it: the tilt it has
        is the parameter's nominal, so a calibrated model can be calibrated again on new data.
    params : ParameterSet

    Raises
    ------
    InputError
        An unknown group, or a group the robot has nothing of (no ``*_flex`` joints, no tool
        contact), or a foundation without equal tilt joints ``base_rx``/``base_ry``.
    """
    groups = parse_groups(",".join(groups)) if not isinstance(groups, str) else parse_groups(groups)
    extra = tuple(dict.fromkeys(extra))
    base_mass = 0.0
    base_c0 = 0.0
    if "base" in groups or "base.lateral_compliance" in extra:
        robot, base_c0 = _on_foundation(robot, "base.lateral_compliance" in extra)
        base_mass = float(robot.model.body_subtreemass[robot.model.body("base_mount").id])
    m = robot.model
    names = _Names.of(robot)
    out: list[Parameter] = []
    for g in groups:
        out += _group(g, m, names, base_c0)
    have = {p.name for p in out}
    for name in extra:
        if name not in have:
            out.append(_structural(robot, name))
    if not out:
        raise InputError(f"the robot has no parameters in the groups {', '.join(groups)}")
    for g in groups:
        if not any(p.group == g for p in out):
            raise InputError(f"the robot has no parameters in the group {g!r}")
    return robot, ParameterSet(out, base_mass=base_mass)


def _make_inertial_explicit(spec: mujoco.MjSpec, body) -> None:
    """Give ``body`` the inertia its geoms imply, explicitly: a mass set on a body whose inertia
    comes from its geoms would not reach the compiled model (an older model's foundation plate)."""
    b = spec.compile().body(body.name)
    body.mass = float(b.mass[0])
    body.ipos, body.iquat, body.inertia = b.ipos.copy(), b.iquat.copy(), b.inertia.copy()
    body.explicitinertial = True


def _on_foundation(robot, lateral: bool):
    """``(robot, c0)``: the robot on a foundation whose tilt the base group calibrates, and that
    tilt's nominal compliance c0, rad/(N·m).

    A robot already on one (a calibrated one) keeps it, its tilt the nominal; any other is mounted
    on a copy of a foundation rigid at the nominal (c0 = 0). ``lateral``: the set will also soften
    the foundation's lateral slides.
    """
    from rmbench.robot.model import Robot
    from rmbench.robot.spec import spec_to_xml
    from rmbench.robot.variant import add_compliant_base

    if not any(b.name == "base_mount" for b in robot.spec.bodies):
        spec = robot.spec
        add_compliant_base(spec, _RIGID, _RIGID)
        return Robot(spec_to_xml(spec), name=robot.name, tool=robot.tool, spindle_rpm=robot.spindle_rpm,
                     spec=spec), 0.0
    m0 = robot.model
    names = [m0.joint(j).name for j in range(m0.njnt)]
    if not all(t in names for t in ("base_rx", "base_ry")):
        raise InputError("the robot already stands on a base without tilt joints (base_rx, "
                         "base_ry); calibrate it without the base group")
    k_rx, k_ry = (float(m0.jnt_stiffness[m0.joint(t).id]) for t in ("base_rx", "base_ry"))
    if not np.isclose(k_rx, k_ry, rtol=1e-6):
        raise InputError("the robot's base tilts unequally about x and y; calibrate it without "
                         "the base group")
    if lateral and not all(t in names for t in ("base_x", "base_y")):
        raise InputError("the robot's base has no lateral slides (base_x, base_y) for "
                         "base.lateral_compliance")
    return robot, (0.0 if k_rx >= _RIGID / 2 else 1 / k_rx)


@dataclass(frozen=True)
class _Names:
    """What a robot has to calibrate: its flexible joints, its arm's position servos and its links
    (bodies of explicit inertia and at least :data:`_MIN_LINK_KG`, motors, spindle, tool and
    foundation left out)."""

    joints: tuple
    flex: tuple
    servos: tuple
    links: tuple

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
                      and not b.name.startswith(("spindle", "tool_", "base_mount")))
        return cls(joints, tuple(j for j in joints if j.endswith("_flex")), servos, links)


def _group(g: str, m, names: _Names, base_c0: float) -> list:
    """The parameters of group ``g`` (of :data:`GROUPS`) of the model ``m``."""
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
        c0 = base_c0 / _BASE_UNIT
        return [Parameter("base.tilt_compliance", g, "base", ("base_rx", "base_ry"), 0, base_c0, False,
                          _BASE_UNIT, -c0, 300.0 - c0, "µrad/(kN·m)")]
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
    """A parameter in no group (:data:`STRUCTURAL`, ``BODY.mass``), its prior range the freed one."""
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
        k = float(m.jnt_stiffness[m.joint("base_x").id])
        c0 = 0.0 if k >= _RIGID / 2 else 1 / k
        return Parameter(name, "structural", "base", ("base_x", "base_y"), 0, c0, False, _BASE_UNIT,
                         -c0 / _BASE_UNIT, 300.0 - c0 / _BASE_UNIT, "µm/kN")
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
    raise InputError(f"unknown structural parameter {name!r}; one of {', '.join(STRUCTURAL)} or BODY.mass")
