"""The library of candidate model changes: each a small frozen description, one engine for all.

An :class:`Effect` names a kind of unmodelled physics and where it acts (the MJCF name of the joint,
actuator or body it edits, or the sensor it moves), with its search axes (:class:`Param`: the
values' names, bounds and steps in the units a user reads). Where its values move ordinary model
parameters (a joint's stiffness, a servo's gain, the tool holder's contact, a calibrated
foundation's lateral compliance) the effect holds those as
:class:`~rmbench.robot.parameters.Parameter` records (:attr:`Effect.parameters`), and a
:class:`Change` carries them with their values: the kinds registry (:data:`rmbench.robot.kinds.KINDS`)
writes them into the model and gives their matrix perturbation, as it does for a calibration.
What the registry has no kind for stays a typed field of the change: a mass added at a body's
centre of mass (its inertia kept, unlike the ``mass`` kind's), a new compliant foundation (its
vertical and torsional springs set from the lateral and tilt ones), load-dependent joint stiffness,
sensor placement errors of the test design, a spindle speed. The engine that fits, scores and
ranks effects never knows what a parameter means.

Kinds (METHODS.md §11 lists the sensitivity tools the engine uses):

=========================== =============== ===========================================================
kind                        location        parameters
=========================== =============== ===========================================================
``joint_stiffness``         ``jN_flex``      ln of the stiffness factor
``joint_damping``           ``jN_flex``      ln of the damping factor
``load_dependent_stiffness`` ``jN_flex``     α: stiffness × (1 + α |Δ| / 1 mrad), Δ the gravity deflection
``servo_stiffness``         ``aN``          ln of the position gain factor
``tool_contact_stiffness``  ``tool_contact`` ln factors of the translational and rotational contact
``spindle_stiffness``       ``spindle``     ln factors of the bearings' radial and tilt stiffness
``base_compliance``         ``base``        lateral (µm/kN) and tilt (µrad/kN·m) compliance of the foundation
``added_mass``              body name       mass added to the body, kg (negative: a lighter body)
``sensor_misplacement``     ``BAND:COORD``  sensor position error along the tool, mm
``sensor_misalignment``     ``BAND:COORD``  sensor direction error about the tool axis, degrees
``non_reciprocity``         ``spindle_spin`` spindle speed, rev/min (gyroscopic coupling)
=========================== =============== ===========================================================
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rmbench.calibrate.design import SensorOffset
from rmbench.impact.sensors import COORDS
from rmbench.robot.kinds import COMPLIANCE_UNIT, DAMPING_RATIO
from rmbench.robot.parameters import Parameter

__all__ = ["Param", "Change", "Effect", "library", "KINDS"]

#: The effect kinds the library knows (the table above), in the library's order.
KINDS = ("joint_stiffness", "joint_damping", "load_dependent_stiffness", "servo_stiffness",
         "tool_contact_stiffness", "spindle_stiffness", "base_compliance", "added_mass",
         "sensor_misplacement", "sensor_misalignment", "non_reciprocity")

_BASE_LATERAL = COMPLIANCE_UNIT   # one lateral-compliance unit: 1 µm/kN (m/N)
_BASE_TILT = COMPLIANCE_UNIT      # one tilt-compliance unit: 1 µrad/(kN·m) (rad/(N·m))


@dataclass(frozen=True)
class Param:
    """One search axis of an effect, in the units the user reads (what the model parameter it
    moves is, and how, is the effect's :attr:`Effect.parameters`).

    Attributes
    ----------
    name : str
        As results name the value (``ln_factor``, ``lateral``, ``mass``).
    lower, upper : float
        Bounds of the fit.
    step : float
        Typical small change (finite-difference step of the screening).
    unit : str
    """

    name: str
    lower: float
    upper: float
    step: float
    unit: str

    def __post_init__(self):
        if not self.lower < self.upper or not self.step > 0:
            raise ValueError(f"parameter {self.name!r}: need lower < upper and step > 0")


@dataclass(frozen=True)
class Change:
    """A change of the model and of the test design, as data.

    Attributes
    ----------
    values : tuple of (Parameter, float)
        Model parameters and their values ``u`` (:meth:`Parameter.value`: a log factor, or a
        compliance's offset in its units), written by their kinds (:data:`rmbench.robot.kinds.KINDS`);
        each parameter once.
    masses : tuple of (str, float)
        Mass added to a body at its centre of mass (its inertia kept), kg; negative: a lighter body.
    base : (float, float) or None
        A new compliant foundation (lateral N/m, tilt N·m/rad).
    load_stiffness : tuple of (str, float)
        Load-dependent stiffness coefficients α per joint (1/mrad).
    offsets : tuple of SensorOffset
        Sensor placement errors of the test design.
    spindle_rpm : float
    """

    values: tuple = ()
    masses: tuple = ()
    base: tuple | None = None
    load_stiffness: tuple = ()
    offsets: tuple = ()
    spindle_rpm: float = 0.0

    def __add__(self, other: "Change") -> "Change":
        if self.base is not None and other.base is not None:
            base = (1 / (1 / self.base[0] + 1 / other.base[0]), 1 / (1 / self.base[1] + 1 / other.base[1]))
        else:
            base = self.base if self.base is not None else other.base
        # one parameter in both adds in u: a log parameter's factors multiply (a step on top of a
        # fitted value, as the search's Jacobian takes it), a linear one's offsets add
        values = dict(self.values)
        for p, u in other.values:
            values[p] = values.get(p, 0.0) + u
        return Change(values=tuple(values.items()), masses=self.masses + other.masses, base=base,
                      load_stiffness=self.load_stiffness + other.load_stiffness,
                      offsets=self.offsets + other.offsets,
                      spindle_rpm=self.spindle_rpm + other.spindle_rpm)

    @property
    def robot_part(self) -> "Change":
        """The part that edits the robot (everything but the sensor offsets)."""
        return Change(values=self.values, masses=self.masses, base=self.base,
                      load_stiffness=self.load_stiffness, spindle_rpm=self.spindle_rpm)

    def is_null(self) -> bool:
        """Whether the change changes nothing: equal to ``Change()`` (no values, masses, base,
        load stiffness or sensor offsets, spindle at 0 rev/min)."""
        return self == Change()


@dataclass(frozen=True)
class Effect:
    """A candidate unmodelled effect: its kind, where it acts and its parameters.

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    location : str
        MJCF name of the joint, actuator or body edited, ``BAND:COORD`` for a sensor, or
        ``tool_contact``, ``spindle``, ``base``.
    params : tuple of Param
        The search axes, in the user's units.
    parameters : tuple of Parameter
        The model parameters its values move, one per value (joint stiffness, damping and servo
        gain: ``u`` is the value, a log factor; the tool contact and spindle: one per axis; a
        calibrated foundation: its lateral compliance); empty for a kind the registry has no kind
        for (see the module's docstring).
    """

    kind: str
    location: str
    params: tuple
    parameters: tuple = field(default=())

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"unknown effect kind {self.kind!r}; one of {', '.join(KINDS)}")

    @property
    def name(self) -> str:
        """``kind@location``."""
        return f"{self.kind}@{self.location}"

    @property
    def n_params(self) -> int:
        """Search axes (:attr:`params`)."""
        return len(self.params)

    def lower(self) -> np.ndarray:
        """Lower bounds of the search axes, shape (n_params,), each in its :attr:`Param.unit`."""
        return np.array([p.lower for p in self.params])

    def upper(self) -> np.ndarray:
        """Upper bounds of the search axes, shape (n_params,), each in its :attr:`Param.unit`."""
        return np.array([p.upper for p in self.params])

    def steps(self) -> np.ndarray:
        """Screening steps of the search axes, shape (n_params,), each in its :attr:`Param.unit`."""
        return np.array([p.step for p in self.params])

    def change(self, values) -> Change:
        """The change these parameter values make (``values`` in the parameters' units)."""
        v = np.asarray(values, float)
        k, loc = self.kind, self.location
        if k in ("joint_stiffness", "joint_damping", "servo_stiffness", "tool_contact_stiffness",
                 "spindle_stiffness"):
            # the values are the parameters' own log factors
            return Change(values=tuple((p, float(x)) for p, x in zip(self.parameters, v)))
        if k == "load_dependent_stiffness":
            return Change(load_stiffness=((loc, float(v[0])),))
        if k == "base_compliance" and self.parameters:
            if v[0] <= 0:
                return Change()
            p = self.parameters[0]
            return Change(values=((p, p.to_u(v[0] * _BASE_LATERAL)),))
        if k == "base_compliance":
            c_lat, c_tilt = max(v[0], 0.0) * _BASE_LATERAL, max(v[1], 0.0) * _BASE_TILT
            if c_lat <= 0 and c_tilt <= 0:
                return Change()
            # a vanishing compliance is a very stiff mount, far above every band
            return Change(base=(1 / max(c_lat, 1e-14), 1 / max(c_tilt, 1e-14)))
        if k == "added_mass":
            return Change(masses=((loc, float(v[0])),)) if v[0] != 0 else Change()
        if k in ("sensor_misplacement", "sensor_misalignment"):
            band, coord = loc.split(":")
            if k == "sensor_misplacement":
                return Change(offsets=(SensorOffset(band, coord, along=1e-3 * v[0]),))
            return Change(offsets=(SensorOffset(band, coord, angle=np.radians(v[0])),))
        if k == "non_reciprocity":
            return Change(spindle_rpm=float(v[0]))
        raise AssertionError(k)  # pragma: no cover - KINDS is checked in __post_init__

    def describe(self, values) -> str:
        """What the values mean, in words: ``j2_flex stiffness × 0.83``."""
        v = np.asarray(values, float)
        k, loc = self.kind, self.location
        if k in ("joint_stiffness", "joint_damping", "servo_stiffness"):
            what = {"joint_stiffness": "stiffness", "joint_damping": "damping",
                    "servo_stiffness": "servo gain"}[k]
            return f"{loc} {what} × {np.exp(v[0]):.3g}"
        if k == "load_dependent_stiffness":
            return f"{loc} stiffness × (1 + {v[0]:.3g} |deflection| / 1 mrad)"
        if k == "tool_contact_stiffness":
            return f"tool contact stiffness × {np.exp(v[0]):.3g} (translation), × {np.exp(v[1]):.3g} (rotation)"
        if k == "spindle_stiffness":
            return f"spindle bearing stiffness × {np.exp(v[0]):.3g} (radial), × {np.exp(v[1]):.3g} (tilt)"
        if k == "base_compliance" and self.parameters:
            return f"foundation {v[0]:.3g} µm/kN lateral"
        if k == "base_compliance":
            return f"compliant base: {v[0]:.3g} µm/kN lateral, {v[1]:.3g} µrad/(kN·m) tilt"
        if k == "added_mass":
            return f"{loc} mass {v[0]:+.3g} kg"
        if k == "sensor_misplacement":
            return f"sensor {loc} {v[0]:+.3g} mm along the tool"
        if k == "sensor_misalignment":
            return f"sensor {loc} turned {v[0]:+.3g}° about the tool axis"
        return f"spindle at {v[0]:.4g} rev/min"

    def params_dict(self, values) -> dict:
        """``{param name: value}`` in the parameters' units."""
        return {p.name: float(x) for p, x in zip(self.params, np.asarray(values, float))}


def library(robot, design) -> list[Effect]:
    """Every candidate effect for a robot (a :class:`~rmbench.robot.Robot`) under a test design.

    Locations come from the model itself: its passive flexible joints (``*_flex``), its position
    servos on arm joints, its tool contact and spindle bearing joints, its arm bodies with an
    explicit inertial, the test design's sensors per band, and its spindle (if it can spin).
    """
    import mujoco

    spec = robot.spec
    joints = {j.name: j for j in spec.joints}
    ln = np.log
    out: list[Effect] = []
    flex = [j for j in joints if j.endswith("_flex")]
    for j in flex:
        axes = (Param("ln_factor", ln(0.3), ln(3.0), 0.05, "ln"),)
        out.append(Effect("joint_stiffness", j, axes,
                          _factors("stiffness", axes, [(f"{j}.stiffness", (j,), [joints[j].stiffness[0]])],
                                   "N·m/rad")))
    for j in flex:
        axes = (Param("ln_factor", ln(0.1), ln(10.0), 0.1, "ln"),)
        out.append(Effect("joint_damping", j, axes,
                          _factors("damping", axes, [(f"{j}.damping", (j,), [joints[j].damping[0]])], "N·m·s/rad")))
    for j in flex:
        out.append(Effect("load_dependent_stiffness", j,
                          (Param("alpha", 0.0, 3.0, 0.05, "1/mrad"),)))
    arm = set(robot.arm_joints)
    for act in spec.actuators:
        if act.target in arm and act.trntype == mujoco.mjtTrn.mjTRN_JOINT:
            axes = (Param("ln_factor", ln(0.01), ln(10.0), 0.1, "ln"),)
            out.append(Effect("servo_stiffness", act.name, axes,
                              _factors("kp", axes, [(f"{act.name}.kp", (act.name,), [act.gainprm[0]])], "N·m/rad")))
    contact = [f"tool_contact_{a}" for a in ("x", "y", "rx", "ry")]
    if all(c in joints for c in contact):
        axes = (Param("ln_translation", ln(0.2), ln(5.0), 0.05, "ln"),
                Param("ln_rotation", ln(0.2), ln(5.0), 0.05, "ln"))
        rows = [(f"tool_contact.{n}", ts, [joints[t].stiffness[0] for t in ts])
                for n, ts in (("translation", contact[:2]), ("rotation", contact[2:]))]
        out.append(Effect("tool_contact_stiffness", "tool_contact", axes,
                          _factors("stiffness", axes, rows, ("N/m", "N·m/rad"))))
    bearings = [f"spindle_{a}" for a in ("x", "y", "rx", "ry")]
    if all(b in joints for b in bearings):
        axes = (Param("ln_radial", ln(0.3), ln(3.0), 0.05, "ln"), Param("ln_tilt", ln(0.3), ln(3.0), 0.05, "ln"))
        rows = [(f"spindle.{n}", ts, [joints[t].stiffness[0] for t in ts])
                for n, ts in (("radial", bearings[:2]), ("tilt", bearings[2:]))]
        out.append(Effect("spindle_stiffness", "spindle", axes,
                          _factors("stiffness", axes, rows, ("N/m", "N·m/rad"))))
    if not any(b.name == "base_mount" for b in spec.bodies):
        out.append(Effect("base_compliance", "base",
                          (Param("lateral", 0.0, 200.0, 2.0, "µm/kN"),
                           Param("tilt", 0.0, 200.0, 2.0, "µrad/(kN·m)"))))
    elif all(j in joints for j in ("base_x", "base_y")):
        # a robot already on a foundation (a calibrated one: its tilt is a calibrated parameter):
        # the foundation's lateral compliance, by softening its slides
        axes = (Param("lateral", 0.0, 200.0, 2.0, "µm/kN"),)
        out.append(Effect("base_compliance", "base", axes, (_foundation_lateral(joints["base_x"], axes[0]),)))
    for body in spec.bodies:
        # a foundation's plate is no body a mass is added to (its mass is the foundation's own)
        if body.name and body.explicitinertial and body.mass >= 5.0 \
                and not body.name.startswith(("motor", "base_mount")):
            m0 = float(body.mass)
            out.append(Effect("added_mass", body.name,
                              (Param("mass", -0.5 * m0, 2.0 * m0, 0.02 * m0, "kg"),)))
    for band in design.band_names:
        for c in COORDS:
            out.append(Effect("sensor_misplacement", f"{band}:{c}",
                              (Param("along", -10.0, 10.0, 0.5, "mm"),)))
    for band in design.band_names:
        for c in COORDS:
            out.append(Effect("sensor_misalignment", f"{band}:{c}",
                              (Param("angle", -15.0, 15.0, 0.5, "deg"),)))
    if "spindle_spin" in joints:
        out.append(Effect("non_reciprocity", "spindle_spin",
                          (Param("rpm", 0.0, 30000.0, 1000.0, "rev/min"),)))
    return out


def _factors(kind: str, axes, rows, labels) -> tuple:
    """Log-scaled model parameters of ``kind``, one per search axis (the axis's value is the
    parameter's ``u``, its bounds the parameter's): ``rows`` gives each one's name, MJCF targets and
    their nominal values (SI; edited together, they keep their ratios), ``labels`` their units
    (one for all, or one each)."""
    labels = (labels,) * len(axes) if isinstance(labels, str) else labels
    out = []
    for axis, (name, where, nominals), label in zip(axes, rows, labels):
        where = tuple(where)
        k0 = float(nominals[0])
        scales = tuple(float(n) / k0 for n in nominals) if len(where) > 1 else ()
        out.append(Parameter(name, "structural", kind, where, 0, k0, True, 1.0, float(axis.lower),
                             float(axis.upper), label, scales=scales))
    return tuple(out)


def _foundation_lateral(slide, axis: Param) -> Parameter:
    """The lateral compliance of a foundation the robot stands on (``base_x``, ``base_y``, whose
    spec joint ``slide`` is the first), in µm/kN. Its ``carried`` mass is the one the slides'
    present damping is :data:`~rmbench.robot.kinds.DAMPING_RATIO` of critical against, so a softer
    foundation's dampers keep their ratio of critical."""
    k0, d0 = float(slide.stiffness[0]), float(slide.damping[0])
    c0 = 1 / k0
    return Parameter("base.lateral_compliance", "structural", "base", ("base_x", "base_y"), 0, c0, False,
                     COMPLIANCE_UNIT, axis.lower - c0 / COMPLIANCE_UNIT, axis.upper - c0 / COMPLIANCE_UNIT,
                     axis.unit, carried=(d0 / (2 * DAMPING_RATIO)) ** 2 / k0)
