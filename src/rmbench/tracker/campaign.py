"""A simulated laser-tracker campaign on a virtual robot: configuration, the model under test, readings.

:class:`CampaignConfig` holds what a TOML file may set (SI units). :meth:`TrackerCampaign.build`
draws the true robot, measures the identification set (199 quasi-random configurations, as in the
seed), calibrates the model under test on it, and offers the measurement of model errors at new
configurations, each reading's σ (joint repeatability through the model's Jacobian plus tracker
noise, METHODS.md §7), the best-fit frame re-registration and the noise-free true error.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

import numpy as np

from rmbench.errors import InputError
from rmbench.io.tracker_csv import TrackerReadings
from rmbench.tracker.calibration import CalibratedModel, GeometricCalibration
from rmbench.tracker.registration import FrameRefit
from rmbench.tracker.sampling import sobol_points
from rmbench.tracker.simulator import (ErrorDistribution, TrackerSimulator, TrackerSpec,
                                       nominal_stiffness)

__all__ = ["CampaignConfig", "TrackerCampaign", "MH180_JOINT_BOX", "MH180_CALIBRATION_BOX"]

MH180_JOINT_BOX = (tuple(math.radians(v) for v in (-45, -20, -30, -60, 30, -60)),
                   tuple(math.radians(v) for v in (45, 40, 30, 60, 120, 60)))
"""Joint ranges of the campaigns (rad): J1 ±45°, J2 −20..40°, J3 ±30°, J4 ±60°, J5 30..120°,
J6 ±60°: a machining region in front of the robot, clear of the wrist singularity (J5 = 0)."""

MH180_CALIBRATION_BOX = (tuple(math.radians(v) for v in (-90, -30, -60, -150, 30, -150)),
                         tuple(math.radians(v) for v in (90, 60, 60, 150, 120, 150)))
"""Joint ranges of a calibration campaign (rad): J1 ±90°, J2 −30..60°, J3 ±60°, J4 ±150°,
J5 30..120°, J6 ±150°. Each joint sweeps as far as the cell allows, as kinematic calibration
does: over the machining region's ±30-60° a gear error once per output revolution, a sin(q + φ),
is nearly a zero offset plus a slope, which the joint's offset and compliance take up
(``bench/gap_tracker.py --spread-box`` measures both boxes)."""


@dataclass(frozen=True)
class CampaignConfig:
    """Settings of a simulated tracker campaign (a TOML file sets any of them; SI units).

    Attributes
    ----------
    robot : str
        Bundled robot name or MJCF path.
    seed : int
        Seeds the true robot, the configurations and every reading.
    n_identification : int
        Configurations measured to calibrate the model under test (0: the nominal model).
    n_validation : int
        New quasi-random configurations measured by the campaign.
    repeats : int
        Readings per validation configuration (``rmbench tracker run``).
    joint_lower, joint_upper : tuple of float
        Joint ranges of all configurations, rad.
    repeatability : float
        Rated ISO 9283 RP of the robot, m.
    identify_compliance : bool
        Whether the calibration identifies a stiffness factor per joint (default: the model uses
        the nominal MJCF stiffness, as taken from a data sheet).
    tracker : TrackerSpec
    errors : ErrorDistribution
    """

    robot: str = "mh180"
    seed: int = 0
    n_identification: int = 199
    n_validation: int = 50
    repeats: int = 1
    joint_lower: tuple = MH180_JOINT_BOX[0]
    joint_upper: tuple = MH180_JOINT_BOX[1]
    repeatability: float = 0.2e-3
    identify_compliance: bool = False
    tracker: TrackerSpec = field(default_factory=TrackerSpec)
    errors: ErrorDistribution = field(default_factory=ErrorDistribution)

    def __post_init__(self):
        for name in ("n_validation", "repeats"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise InputError(f"{name} must be an integer >= 1, got {v!r}")
        n = self.n_identification
        if isinstance(n, bool) or not isinstance(n, int) or n < 0:
            raise InputError(f"n_identification must be an integer >= 0, got {n!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise InputError(f"seed must be an integer >= 0, got {self.seed!r}")
        lo, hi = np.asarray(self.joint_lower, float), np.asarray(self.joint_upper, float)
        if lo.shape != hi.shape or lo.ndim != 1 or not np.all(lo < hi):
            raise InputError(f"joint_lower and joint_upper must be equal-length lists with "
                             f"lower < upper, got {self.joint_lower!r} and {self.joint_upper!r}")
        if not (math.isfinite(self.repeatability) and self.repeatability > 0):
            raise InputError(f"repeatability must be finite and > 0 (m), got {self.repeatability!r}")

    @classmethod
    def from_toml(cls, path) -> "CampaignConfig":
        """Read a TOML file: top-level keys as the attributes; ``[tracker]`` and ``[errors]``
        tables set :class:`TrackerSpec` and :class:`ErrorDistribution` fields.

        Raises
        ------
        rmbench.errors.InputError
            Missing or malformed file, unknown key, bad value.
        """
        path = Path(path)
        if not path.is_file():
            raise InputError(f"config file {str(path)!r} not found")
        try:
            data = tomllib.loads(path.read_text())
        except tomllib.TOMLDecodeError as err:
            raise InputError(f"{path}: not valid TOML: {err}") from None
        return cls.from_dict(data, where=str(path))

    @classmethod
    def from_dict(cls, data: dict, *, where: str = "config") -> "CampaignConfig":
        """Build from a plain dict (as read from TOML); unknown keys are errors."""
        data = dict(data)
        sub = {"tracker": TrackerSpec, "errors": ErrorDistribution}
        kwargs = {}
        for key, kind in sub.items():
            if key in data:
                table = data.pop(key)
                if isinstance(table, kind):
                    kwargs[key] = table
                elif isinstance(table, dict):
                    kwargs[key] = _construct(kind, table, f"{where} [{key}]")
                else:
                    raise InputError(f"{where}: [{key}] must be a table")
        kwargs.update(data)
        for key in ("joint_lower", "joint_upper"):
            if key in kwargs:
                kwargs[key] = tuple(kwargs[key])
        return _construct(cls, kwargs, where)


class TrackerCampaign:
    """A true robot, its tracker and the calibrated model under test.

    Use :meth:`build`. Attributes: ``config``, ``robot``, ``simulator`` (TrackerSimulator),
    ``calibration`` (fitted GeometricCalibration or None), ``model`` (CalibratedModel),
    ``q_identification`` (n_identification, n_joint) and ``q_validation`` (n_validation,
    n_joint), rad.
    """

    def __init__(self, config, robot, simulator, calibration, model, q_identification,
                 q_validation, streams):
        self.config = config
        self.robot = robot
        self.simulator = simulator
        self.calibration = calibration
        self.model = model
        self.q_identification = q_identification
        self.q_validation = q_validation
        self._streams = streams

    @classmethod
    def build(cls, config: CampaignConfig = CampaignConfig(), *, robot=None) -> "TrackerCampaign":
        """Draw the true robot, take the identification readings and calibrate the model.

        Parameters
        ----------
        config : CampaignConfig
        robot : rmbench.robot.Robot, optional
            Already loaded robot (else ``config.robot`` is loaded).
        """
        from rmbench.robot import Robot

        robot = robot if robot is not None else Robot.load(config.robot)
        seeds = np.random.SeedSequence(config.seed).spawn(4)
        hidden_rng, config_rng, ident_rng = (np.random.default_rng(s) for s in seeds[:3])
        sim = TrackerSimulator.from_robot(robot, hidden_rng, distribution=config.errors,
                                          tracker=config.tracker,
                                          repeatability=config.repeatability)
        if len(config.joint_lower) != sim.nominal.n_joint:
            raise InputError(f"joint_lower needs {sim.nominal.n_joint} values for {robot.name}, "
                             f"got {len(config.joint_lower)}")
        q = sobol_points(config.n_identification + config.n_validation, config.joint_lower,
                         config.joint_upper, config_rng)
        q_id, q_val = q[:config.n_identification], q[config.n_identification:]
        stiffness = nominal_stiffness(robot)
        if config.n_identification:
            cal = GeometricCalibration(sim.nominal, stiffness,
                                       identify_compliance=config.identify_compliance)
            cal.fit(q_id, sim.measure(q_id, ident_rng))
            model = cal.model_
        else:  # the nominal model, registered to the tracker by a best fit of the first readings
            cal = None
            model = _nominal_model(sim, stiffness, q_val, ident_rng)
        return cls(config, robot, sim, cal, model, q_id, q_val, seeds[3])

    def rng(self, *key: int) -> np.random.Generator:
        """An independent generator for one use of the campaign (same key, same stream)."""
        return np.random.default_rng(np.random.SeedSequence(self._streams.entropy,
                                                            spawn_key=(99,) + tuple(key)))

    def sigma(self, q) -> np.ndarray:
        """Standard deviation of one reading per axis at configurations q, shape (n, 3), m.

        σ²_axis = Σ_i (∂x_axis/∂q_i)² σ_v,i² + σ²_tracker(range), with the model's Jacobian.
        """
        jac = self.model.jacobian(q)
        rep = np.sum((jac * self.simulator.joint_sigma) ** 2, axis=-1)
        rng = np.linalg.norm(self.model.position(q), axis=-1)
        return np.sqrt(rep + self.simulator.tracker.sigma(rng)[..., None] ** 2)

    def error_meter(self, rng: np.random.Generator):
        """``measure(q) -> error``: one reading minus the model's prediction, shape (3,), m."""
        def measure(qj):
            return self.simulator.measure(qj, rng) - self.model.position(qj)
        return measure

    def frame_refit(self, q) -> FrameRefit:
        """Best-fit base and tool re-registration at configurations ``q``, shape (n_loc, n_joint),
        rad (``correct`` hook): a :class:`FrameRefit` over the model's TCP poses there, weighted by
        :meth:`sigma` (m); called as ``correct(index, errors)``, ``index`` counts ``q``'s rows."""
        p, r = self.model.pose(q)
        return FrameRefit(p, r, self.sigma(q))

    def true_error(self, q) -> np.ndarray:
        """Noise-free model error (true minus model) at q, shape (..., 3), m."""
        return self.simulator.true_position(q) - self.model.position(q)

    def identification_errors(self) -> np.ndarray:
        """Measured error magnitude on the identification set, shape (n_identification,), m."""
        if self.calibration is None:
            return np.zeros(0)
        return np.linalg.norm(self.calibration.residuals_, axis=1)

    def identification_summary(self) -> dict:
        """``{"n", "mean", "max"}`` of :meth:`identification_errors` (m; mean and max None when
        the model under test was not calibrated)."""
        e = self.identification_errors()
        return {"n": len(e), "mean": float(e.mean()) if len(e) else None,
                "max": float(e.max()) if len(e) else None}

    def readings(self, rng: np.random.Generator, *, repeats: int | None = None) -> TrackerReadings:
        """Readings at the validation configurations, ``repeats`` per configuration."""
        reps = self.config.repeats if repeats is None else repeats
        loc = np.repeat(np.arange(len(self.q_validation)), reps)
        q = self.q_validation[loc]
        c = self.config
        comments = (f"rmbench tracker campaign: robot {self.robot.name}, seed {c.seed}, "
                    f"{c.n_identification} identification configurations",
                    "units: joint angles rad, positions m (tracker frame); nominal = model under test",
                    f"repeatability RP {c.repeatability:g} m, tracker {c.tracker.ppm:g} m/m + "
                    f"{c.tracker.probe:g} m (2 sigma)")
        return TrackerReadings(loc, tuple(self.robot.arm_joints), q, self.simulator.measure(q, rng),
                               self.model.position(q), self.sigma(q), comments)


def _nominal_model(sim, stiffness, q, rng) -> CalibratedModel:
    """The nominal arm (with nominal compliance) placed in the tracker frame by a rigid best fit."""
    from rmbench.tracker.registration import kabsch

    model = CalibratedModel(sim.nominal, np.zeros(sim.nominal.n_joint), 1.0 / stiffness,
                            np.eye(3), np.zeros(3))
    rot, t = kabsch(model.position(q), sim.measure(q, rng))
    return replace(model, base_rotation=rot, base_translation=t)


def _construct(kind, values: dict, where: str):
    names = {f.name for f in fields(kind) if f.init}
    unknown = sorted(set(values) - names)
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(unknown)}; known: "
                         f"{', '.join(sorted(names))}")
    values = {k: tuple(v) if isinstance(v, list) else v for k, v in values.items()}
    try:
        return kind(**values)
    except TypeError as err:
        raise InputError(f"{where}: {err}") from None
