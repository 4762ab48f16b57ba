"""The library of candidate model changes: each a small frozen description, one engine for all.

An :class:`Effect` names a kind of unmodelled physics and where it acts (the MJCF name of the joint,
actuator or body it edits, or the sensor it moves), with its parameters and their bounds. Given
parameter values it returns a :class:`Change`: variant edits of the model's specification (the
machinery of :mod:`rmbench.robot.variant`, through ``mujoco.MjSpec``), point masses, a compliant
base, load-dependent joint stiffness, sensor placement errors of the test design, or a spindle
speed. The engine that fits, scores and ranks effects never knows what a parameter means.

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

__all__ = ["Param", "Change", "Effect", "library", "KINDS"]

KINDS = ("joint_stiffness", "joint_damping", "load_dependent_stiffness", "servo_stiffness",
         "tool_contact_stiffness", "spindle_stiffness", "base_compliance", "added_mass",
         "sensor_misplacement", "sensor_misalignment", "non_reciprocity")

_BASE_LATERAL = 1e-9      # one lateral-compliance unit: 1 µm/kN (m/N)
_BASE_TILT = 1e-9         # one tilt-compliance unit: 1 µrad/(kN·m) (rad/(N·m))


@dataclass(frozen=True)
class Param:
    """One parameter of an effect, in the units the user reads.

    Attributes
    ----------
    name : str
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
    edits : tuple of str
        Variant edits (``TARGET.FIELD OP VALUE``, :mod:`rmbench.robot.variant`).
    masses : tuple of (str, float)
        Point masses (kg) added at a site or body.
    base : (float, float) or None
        Compliant foundation (lateral N/m, tilt N·m/rad).
    load_stiffness : tuple of (str, float)
        Load-dependent stiffness coefficients α per joint (1/mrad).
    offsets : tuple of SensorOffset
        Sensor placement errors of the test design.
    spindle_rpm : float
    """

    edits: tuple = ()
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
        return Change(edits=self.edits + other.edits, masses=self.masses + other.masses, base=base,
                      load_stiffness=self.load_stiffness + other.load_stiffness,
                      offsets=self.offsets + other.offsets,
                      spindle_rpm=self.spindle_rpm + other.spindle_rpm)

    @property
    def robot_part(self) -> "Change":
        """The part that edits the robot (everything but the sensor offsets)."""
        return Change(edits=self.edits, masses=self.masses, base=self.base,
                      load_stiffness=self.load_stiffness, spindle_rpm=self.spindle_rpm)

    def is_null(self) -> bool:
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
    targets : tuple of str
        The MJCF elements the change touches (joints of the tool contact, say).
    nominal : tuple of float
        Nominal values the parameters scale (a body's mass, kg), where the kind needs them.
    """

    kind: str
    location: str
    params: tuple
    targets: tuple = field(default=())
    nominal: tuple = field(default=())

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"unknown effect kind {self.kind!r}; one of {', '.join(KINDS)}")

    @property
    def name(self) -> str:
        return f"{self.kind}@{self.location}"

    @property
    def n_params(self) -> int:
        return len(self.params)

    def lower(self) -> np.ndarray:
        return np.array([p.lower for p in self.params])

    def upper(self) -> np.ndarray:
        return np.array([p.upper for p in self.params])

    def steps(self) -> np.ndarray:
        return np.array([p.step for p in self.params])

    def change(self, values) -> Change:
        """The change these parameter values make (``values`` in the parameters' units)."""
        v = np.asarray(values, float)
        k, loc = self.kind, self.location
        if k in ("joint_stiffness", "joint_damping"):
            field_ = "stiffness" if k == "joint_stiffness" else "damping"
            return Change(edits=(f"{loc}.{field_}*={np.exp(v[0]):.12g}",))
        if k == "servo_stiffness":
            return Change(edits=(f"{loc}.kp*={np.exp(v[0]):.12g}",))
        if k == "load_dependent_stiffness":
            return Change(load_stiffness=((loc, float(v[0])),))
        if k in ("tool_contact_stiffness", "spindle_stiffness"):
            trans, rot = self.targets[:2], self.targets[2:]
            edits = tuple(f"{t}.stiffness*={np.exp(v[0]):.12g}" for t in trans)
            edits += tuple(f"{t}.stiffness*={np.exp(v[1]):.12g}" for t in rot)
            return Change(edits=edits)
        if k == "base_compliance" and self.targets:
            c_lat = max(v[0], 0.0) * _BASE_LATERAL
            if c_lat <= 0:
                return Change()
            f = 1 / max(c_lat, 1e-14) / self.nominal[0]
            # the damper keeps its ratio of critical
            return Change(edits=tuple(e for t in self.targets
                                      for e in (f"{t}.stiffness*={f:.12g}", f"{t}.damping*={np.sqrt(f):.12g}")))
        if k == "base_compliance":
            c_lat, c_tilt = max(v[0], 0.0) * _BASE_LATERAL, max(v[1], 0.0) * _BASE_TILT
            if c_lat <= 0 and c_tilt <= 0:
                return Change()
            # a vanishing compliance is a very stiff mount, far above every band
            return Change(base=(1 / max(c_lat, 1e-14), 1 / max(c_tilt, 1e-14)))
        if k == "added_mass":
            return Change(edits=(f"{loc}.mass+={v[0]:.12g}",)) if v[0] != 0 else Change()
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
        if k == "base_compliance" and self.targets:
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
        out.append(Effect("joint_stiffness", j, (Param("ln_factor", ln(0.3), ln(3.0), 0.05, "ln"),)))
    for j in flex:
        out.append(Effect("joint_damping", j, (Param("ln_factor", ln(0.1), ln(10.0), 0.1, "ln"),)))
    for j in flex:
        out.append(Effect("load_dependent_stiffness", j,
                          (Param("alpha", 0.0, 3.0, 0.05, "1/mrad"),)))
    arm = set(robot.arm_joints)
    for act in spec.actuators:
        if act.target in arm and act.trntype == mujoco.mjtTrn.mjTRN_JOINT:
            out.append(Effect("servo_stiffness", act.name,
                              (Param("ln_factor", ln(0.01), ln(10.0), 0.1, "ln"),)))
    contact = [f"tool_contact_{a}" for a in ("x", "y", "rx", "ry")]
    if all(c in joints for c in contact):
        out.append(Effect("tool_contact_stiffness", "tool_contact",
                          (Param("ln_translation", ln(0.2), ln(5.0), 0.05, "ln"),
                           Param("ln_rotation", ln(0.2), ln(5.0), 0.05, "ln")), targets=tuple(contact)))
    bearings = [f"spindle_{a}" for a in ("x", "y", "rx", "ry")]
    if all(b in joints for b in bearings):
        out.append(Effect("spindle_stiffness", "spindle",
                          (Param("ln_radial", ln(0.3), ln(3.0), 0.05, "ln"),
                           Param("ln_tilt", ln(0.3), ln(3.0), 0.05, "ln")), targets=tuple(bearings)))
    if not any(b.name == "base_mount" for b in spec.bodies):
        out.append(Effect("base_compliance", "base",
                          (Param("lateral", 0.0, 200.0, 2.0, "µm/kN"),
                           Param("tilt", 0.0, 200.0, 2.0, "µrad/(kN·m)"))))
    elif all(j in joints for j in ("base_x", "base_y")):
        # a robot already on a foundation (a calibrated one: its tilt is a calibrated parameter):
        # the foundation's lateral compliance, by softening its slides
        k0 = float(spec.joint("base_x").stiffness[0])
        out.append(Effect("base_compliance", "base", (Param("lateral", 0.0, 200.0, 2.0, "µm/kN"),),
                          targets=("base_x", "base_y"), nominal=(k0,)))
    for body in spec.bodies:
        # a foundation's plate is no body a mass is added to (its mass is the foundation's own)
        if body.name and body.explicitinertial and body.mass >= 5.0 \
                and not body.name.startswith(("motor", "base_mount")):
            m0 = float(body.mass)
            out.append(Effect("added_mass", body.name,
                              (Param("mass", -0.5 * m0, 2.0 * m0, 0.02 * m0, "kg"),), nominal=(m0,)))
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
