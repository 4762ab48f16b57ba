"""The laser-tracker simulator: a "true" robot with hidden error sources, read by a tracker.

The true robot is the nominal rigid arm (:class:`~rmbench.tracker.chain.SerialChain`) plus
error sources drawn from :class:`ErrorDistribution` with the caller's seed:

* joint zero offsets;
* link length and twist errors: every joint placement and the TCP placement is moved by a small
  twist (translation: link lengths and offsets; rotation: twists and axis misalignment);
* joint compliance: each link-side joint deflects by τ/k under gravity, with the true stiffness
  (the MJCF ``<joint>_flex`` stiffness scaled log-normally), true link masses (scaled) and an
  unmodelled payload at the TCP; τ is solved by two fixed-point steps (agrees with MuJoCo's
  deflected equilibrium of the nominal robot to well under 1 µm: a test);
* periodic gear transmission errors: per joint, the first two harmonics of the output revolution,
  A sin(h q + φ).

Each reading adds joint repeatability (motor-side angles perturbed by N(0, σ_v,i²); σ_v,i equal
for all joints and scaled so that the expected ISO 9283 RP at the reference posture is the robot's
rated 0.2 mm) and tracker noise (``ppm`` per metre of range and the ``probe`` uncertainty, both
taken as 2σ bounds, per axis). Readings are in the tracker's frame (tracker head at the origin);
the robot base's place in that frame is unknown to the model and registered by a best fit.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from rmbench.errors import InputError, ModelError
from rmbench.tracker.chain import SerialChain
from rmbench.tracker.repeatability import joint_sigma_for_rp

__all__ = ["ErrorDistribution", "HiddenErrors", "TrackerSpec", "TrackerSimulator", "soft_robot_simulator",
           "nominal_stiffness", "reading_sigma", "reading_covariance", "reference_joints"]


@dataclass(frozen=True)
class ErrorDistribution:
    """Distribution of the hidden error sources (SI units; every draw independent).

    Attributes
    ----------
    offset_sd : float
        Joint zero offsets ~ N(0, offset_sd²), rad.
    length_sd : float
        Placement translation errors per component ~ N(0, length_sd²), m.
    twist_sd : float
        Placement rotation errors per component ~ N(0, twist_sd²), rad.
    tool_sd : float
        TCP (reflector) offset per component ~ N(0, tool_sd²), m.
    stiffness_sd : float
        True stiffness = MJCF stiffness × exp(N(0, stiffness_sd²)).
    mass_sd : float
        True link mass = nominal × (1 + N(0, mass_sd²)).
    payload : tuple of float
        Unmodelled payload at the TCP ~ U(payload[0], payload[1]), kg.
    gear_amplitude : tuple of float
        Amplitude of harmonic h = 1, 2, ... of the output revolution, rad; each joint's amplitude
        is this × U(0.5, 1), its phase U(0, 2π).
    """

    offset_sd: float = math.radians(0.05)
    length_sd: float = 0.5e-3
    twist_sd: float = math.radians(0.05)
    tool_sd: float = 1.0e-3
    stiffness_sd: float = 0.10
    mass_sd: float = 0.05
    payload: tuple = (5.0, 15.0)
    gear_amplitude: tuple = (40e-6, 20e-6)

    def __post_init__(self):
        for name in ("offset_sd", "length_sd", "twist_sd", "tool_sd", "stiffness_sd", "mass_sd"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise InputError(f"{name} must be finite and >= 0, got {v!r}")
        lo, hi = self.payload
        if not (0 <= lo <= hi):
            raise InputError(f"payload must be (low, high) with 0 <= low <= high, got {self.payload!r}")
        if not all(math.isfinite(a) and a >= 0 for a in self.gear_amplitude):
            raise InputError(f"gear_amplitude must be finite and >= 0, got {self.gear_amplitude!r}")


@dataclass(frozen=True)
class HiddenErrors:
    """One draw of the hidden error sources of a robot.

    Attributes
    ----------
    twists : ndarray, shape (n_joint + 1, 6)
        Placement errors of the joints and the TCP (m, rad), see :meth:`SerialChain.perturbed`.
    offsets : ndarray, shape (n_joint,), rad
    stiffness : ndarray, shape (n_joint,), N·m/rad
        True link-side stiffness (inf: rigid).
    mass_scale : ndarray, shape (n_joint,)
    payload_mass : float, kg
    gear_amplitude, gear_phase : ndarray, shape (n_joint, n_harmonic)
        rad and rad; harmonic h is ``A sin(h q + φ)``.
    """

    twists: np.ndarray
    offsets: np.ndarray
    stiffness: np.ndarray
    mass_scale: np.ndarray
    payload_mass: float
    gear_amplitude: np.ndarray
    gear_phase: np.ndarray

    @classmethod
    def draw(cls, n_joint: int, stiffness, rng: np.random.Generator,
             distribution: ErrorDistribution = ErrorDistribution()) -> "HiddenErrors":
        """Draw the error sources of a robot with ``n_joint`` joints and MJCF ``stiffness``."""
        d = distribution
        twists = np.concatenate([rng.normal(0.0, d.length_sd, (n_joint + 1, 3)),
                                 rng.normal(0.0, d.twist_sd, (n_joint + 1, 3))], axis=1)
        twists[-1, :3] = rng.normal(0.0, d.tool_sd, 3)
        twists[-1, 3:] = 0.0  # the reflector is a point: its orientation does not matter
        n_h = len(d.gear_amplitude)
        amp = np.asarray(d.gear_amplitude, float)[None, :] * rng.uniform(0.5, 1.0, (n_joint, n_h))
        return cls(twists=twists, offsets=rng.normal(0.0, d.offset_sd, n_joint),
                   stiffness=np.asarray(stiffness, float) * np.exp(rng.normal(0.0, d.stiffness_sd,
                                                                             n_joint)),
                   mass_scale=1.0 + rng.normal(0.0, d.mass_sd, n_joint),
                   payload_mass=float(rng.uniform(*d.payload)), gear_amplitude=amp,
                   gear_phase=rng.uniform(0.0, 2.0 * np.pi, (n_joint, n_h)))

    def gear_error(self, q) -> np.ndarray:
        """Transmission error of each joint at motor angles ``q`` (..., n_joint), rad."""
        q = np.asarray(q, float)[..., None]
        h = np.arange(1, self.gear_amplitude.shape[1] + 1)
        return np.sum(self.gear_amplitude * np.sin(h * q + self.gear_phase), axis=-1)


@dataclass(frozen=True)
class TrackerSpec:
    """A laser tracker and where it stands.

    Attributes
    ----------
    ppm : float
        Range-dependent accuracy, m per m of range (5 µm/m), taken as a 2σ bound.
    probe : float
        Probe uncertainty, m (±12.5 µm), taken as a 2σ bound.
    position : tuple of float
        Tracker head in the robot base frame, m.
    yaw : float
        Rotation of the tracker frame about base +z, rad.
    """

    ppm: float = 5e-6
    probe: float = 12.5e-6
    position: tuple = (3.5, -1.5, 0.8)
    yaw: float = math.radians(150.0)

    def __post_init__(self):
        if not (self.ppm >= 0 and self.probe >= 0 and (self.ppm > 0 or self.probe > 0)):
            raise InputError(f"ppm and probe must be >= 0, not both zero, got {self.ppm!r}, "
                             f"{self.probe!r}")

    def sigma(self, distance) -> np.ndarray:
        """Standard deviation of one reading per axis at a range (m), same shape, m."""
        d = np.asarray(distance, float)
        return np.sqrt((0.5 * self.ppm * d) ** 2 + (0.5 * self.probe) ** 2)

    def frame(self) -> tuple[np.ndarray, np.ndarray]:
        """(R, t): tracker-frame coordinates of a base-frame point p are R p + t."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]).T
        return rot, -rot @ np.asarray(self.position, float)


@dataclass(frozen=True)
class TrackerSimulator:
    """A true robot measured by a laser tracker.

    Attributes
    ----------
    nominal : SerialChain
        The rigid arm as designed (what a model starts from).
    true_chain : SerialChain
        Perturbed geometry, true masses and payload.
    hidden : HiddenErrors
    tracker : TrackerSpec
    joint_sigma : ndarray, shape (n_joint,), rad
        Joint repeatability σ_v,i.
    """

    nominal: SerialChain
    true_chain: SerialChain
    hidden: HiddenErrors
    tracker: TrackerSpec
    joint_sigma: np.ndarray
    _frame: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "_frame", self.tracker.frame())

    @classmethod
    def from_robot(cls, robot, rng: np.random.Generator, *,
                   distribution: ErrorDistribution = ErrorDistribution(),
                   tracker: TrackerSpec = TrackerSpec(), repeatability: float = 0.2e-3,
                   reference_q=None) -> "TrackerSimulator":
        """Draw a true robot for an :class:`rmbench.robot.Robot`.

        Parameters
        ----------
        robot : rmbench.robot.Robot
        rng : numpy.random.Generator
            Draws the hidden errors.
        distribution : ErrorDistribution
        tracker : TrackerSpec
        repeatability : float
            Rated ISO 9283 RP at ``reference_q``, m (MH180: 0.2 mm).
        reference_q : array_like, shape (n_joint,), optional
            Posture of the RP rating, rad (default: the robot's reference posture, else zeros).
        """
        nominal = SerialChain.from_kinematics(robot.kinematics, robot.arm_joints)
        hidden = HiddenErrors.draw(nominal.n_joint, nominal_stiffness(robot), rng, distribution)
        true_chain = (nominal.perturbed(hidden.twists).with_mass_scale(hidden.mass_scale)
                      .with_payload(hidden.payload_mass, nominal.tool_translation))
        if reference_q is None:
            reference_q = reference_joints(robot, nominal.n_joint)
        sigma = joint_sigma_for_rp(nominal.jacobian(np.asarray(reference_q, float)), repeatability)
        return cls(nominal, true_chain, hidden, tracker, sigma)

    @property
    def base_in_tracker(self) -> tuple[np.ndarray, np.ndarray]:
        """(R, t) of the robot base in the tracker frame (hidden from the model)."""
        return self._frame

    def link_angles(self, q, joint_noise=None) -> np.ndarray:
        """Link-side joint angles reached for commands ``q`` (..., n_joint), rad."""
        qm = np.asarray(q, float) if joint_noise is None else np.asarray(q, float) + joint_noise
        ql = qm + self.hidden.offsets + self.hidden.gear_error(qm)
        deflection = np.zeros_like(ql)
        for _ in range(2):
            deflection = self.true_chain.gravity_torque(ql + deflection) / self.hidden.stiffness
        return ql + deflection

    def true_position(self, q) -> np.ndarray:
        """Noise-free TCP position in the tracker frame, shape (..., 3), m."""
        rot, t = self._frame
        return self.true_chain.position(self.link_angles(q)) @ rot.T + t

    def measure(self, q, rng: np.random.Generator) -> np.ndarray:
        """One tracker reading per configuration, shape (..., 3), m (repeatability + noise)."""
        q = np.asarray(q, float)
        v = rng.normal(size=q.shape) * self.joint_sigma
        rot, t = self._frame
        p = self.true_chain.position(self.link_angles(q, v)) @ rot.T + t
        noise = rng.normal(size=p.shape) * self.tracker.sigma(np.linalg.norm(p, axis=-1))[..., None]
        return p + noise


def soft_robot_simulator(robot, rng: np.random.Generator, *, softer=(0.75, 0.85),
                         reflector=(1.2e-3, -1.4e-3, 0.6e-3)) -> TrackerSimulator:
    """A robot off its data sheet in the ordinary parameters a calibration fits, and in nothing
    else: every joint's stiffness its MJCF one times a factor drawn uniform in ``softer``, and the
    reflector displaced from the modelled TCP by ``reflector``; geometry, masses, payload and
    gears exact.

    Parameters
    ----------
    robot : rmbench.robot.Robot
    rng : numpy.random.Generator
        Draws (after :meth:`TrackerSimulator.from_robot`'s draws) one factor per arm joint.
    softer : (float, float)
        Bounds of the stiffness factors (ratios to the nominal; 0.75-0.85: 15-25 % softer).
    reflector : (float, float, float)
        The reflector's offset from the modelled TCP (the TCP placement's translation,
        :meth:`SerialChain.perturbed`), m.
    """
    exact = ErrorDistribution(offset_sd=0.0, length_sd=0.0, twist_sd=0.0, tool_sd=0.0, stiffness_sd=0.0,
                              mass_sd=0.0, payload=(0.0, 0.0), gear_amplitude=(0.0, 0.0))
    sim = TrackerSimulator.from_robot(robot, rng, distribution=exact)
    twists = sim.hidden.twists.copy()
    twists[-1, :3] = reflector
    hidden = dataclasses.replace(sim.hidden, twists=twists,
                                 stiffness=nominal_stiffness(robot) * rng.uniform(*softer, len(robot.arm_joints)))
    return dataclasses.replace(sim, hidden=hidden, true_chain=sim.nominal.perturbed(twists))


def nominal_stiffness(robot) -> np.ndarray:
    """Link-side stiffness of each arm joint from its MJCF ``<joint>_flex`` (inf if none), N·m/rad."""
    model = robot.model
    out = []
    for name in robot.arm_joints:
        try:
            k = float(model.joint(name + "_flex").stiffness[0])
        except KeyError:
            k = math.inf
        if not k > 0:
            raise ModelError(f"joint {name + '_flex'!r} has stiffness {k}, expected > 0")
        out.append(k)
    return np.array(out)


def reading_covariance(robot, q, measured, *, repeatability: float = 0.2e-3,
                       tracker: TrackerSpec = TrackerSpec()) -> np.ndarray:
    """Covariance of each reading in the robot's base frame, shape (n, 3, 3), m²: a robot of
    rated ISO 9283 RP
    ``repeatability`` (m) at its reference posture, through the nominal Jacobian at commands ``q``
    (n, n_joint), rad — one joint's scatter moves the TCP along one direction, so the axes are
    correlated — plus the tracker's noise at the range of the readings ``measured`` (n, 3), m."""
    chain = SerialChain.from_kinematics(robot.kinematics, robot.arm_joints)
    sv = joint_sigma_for_rp(chain.jacobian(reference_joints(robot, chain.n_joint)), repeatability)
    jac = chain.jacobian(np.asarray(q, float)) * sv
    noise = tracker.sigma(np.linalg.norm(np.asarray(measured, float), axis=-1))
    return jac @ np.swapaxes(jac, -1, -2) + noise[..., None, None] ** 2 * np.eye(3)


def reading_sigma(robot, q, measured, *, repeatability: float = 0.2e-3,
                  tracker: TrackerSpec = TrackerSpec()) -> np.ndarray:
    """σ of each reading per axis of the base frame, shape (n, 3), m (the diagonal of
    :func:`reading_covariance`)."""
    cov = reading_covariance(robot, q, measured, repeatability=repeatability, tracker=tracker)
    return np.sqrt(np.diagonal(cov, axis1=-2, axis2=-1))


def reference_joints(robot, n: int) -> np.ndarray:
    """The robot's reference joint commands (its MJCF's ``rmbench_reference_q``), else zeros, rad,
    shape (n,)."""
    from rmbench.robot.spec import custom_numeric

    ref = custom_numeric(robot.spec, "rmbench_reference_q")
    return np.zeros(n) if ref is None else np.asarray(ref, float)
