"""Declarative campaign configuration (TOML), validated before anything runs.

The file uses the user's units (mm, degrees, ms, g) and is converted to SI once, here. Every key is
checked: unknown keys, negative averages, a band beyond a sensor's range, an empty grid are errors
that name the key and the value.

Example (see ``configs/seed_full.toml``)::

    seed = 7
    method = "time"
    [robot]
    name = "irb6660"              # or a variant's MJCF path
    tool = "dummy"
    # commands_from = "irb6660"   # command the variant with the nominal robot's IK
    [grid]
    kind = "seed"                 # seed | validation | product | list
    [hits]
    averages = 3
    [bands.low]
    f_min = 4.0
    f_max = 40.0
"""

from __future__ import annotations

import hashlib
import math
import tomllib
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from rmbench.errors import InputError

__all__ = ["CampaignConfig", "BandConfig", "HammerConfig", "LaserConfig", "AccelerometerConfig",
           "HitConfig", "GridConfig", "RobotConfig", "load_config", "parse_config", "bundled_configs",
           "default_bands"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class RobotConfig(_Strict):
    """The robot under test.

    ``name`` is a bundled robot or an MJCF path (e.g. a saved variant carrying its tool; then
    ``tool`` names that tool or is left out). ``commands_from``, when set, is the nominal robot
    (bundled name or MJCF path, with the campaign's tool) whose rigid-body inverse kinematics
    gives each posture's joint commands, as a real controller that only knows its nominal model
    would; the robot under test is then settled at those commands. Unset, the robot's own
    inverse kinematics commands it.
    """

    name: str = "irb6660"
    tool: str | None = "dummy"
    spindle_rpm: float = 0.0
    commands_from: str | None = None


class GridConfig(_Strict):
    """Postures: the seed's 112, the robot's own grid (``robot``: the seed's for the stand-ins, the
    workspace grid of a robot built from a URDF), its 3 validation postures, a product of axes, or
    a list."""

    kind: Literal["seed", "robot", "validation", "product", "list"] = "seed"
    x_mm: list[float] = []
    y_mm: list[float] = []
    theta_deg: list[float] = []
    postures: list[tuple[float, float, float]] = []  # (x mm, y mm, θ deg)

    @model_validator(mode="after")
    def _check(self):
        if self.kind == "product" and not (self.x_mm and self.y_mm and self.theta_deg):
            raise ValueError("grid kind 'product' needs non-empty x_mm, y_mm and theta_deg")
        if self.kind == "list" and not self.postures:
            raise ValueError("grid kind 'list' needs a non-empty postures list")
        return self


class HammerConfig(_Strict):
    """An impact hammer with one tip: half-sine pulse and hit-to-hit scatter."""

    pulse_ms: float = Field(gt=0)
    peak_n: float = Field(gt=0)
    force_scatter: float = Field(0.10, ge=0, lt=1)  # relative std of the peak force
    location_scatter_mm: float = Field(0.2, ge=0)  # std along the tool axis
    direction_scatter_deg: float = Field(0.2, ge=0)  # std in the XY plane
    double_hit_probability: float = Field(0.0, ge=0, le=1)
    double_hit_delay_ms: float = Field(1.5, gt=0)
    double_hit_ratio: float = Field(0.3, ge=0, le=1)
    load_cell_noise_n: float = Field(0.03, ge=0)  # rms, PCB 086C03 class
    calibration_error: float = Field(0.0, ge=0, lt=0.5)  # relative std of the sensitivity


class LaserConfig(_Strict):
    """Laser displacement sensor, KEYENCE LK-H025 class."""

    range_mm: float = Field(5.0, gt=0)  # ± measuring range about the reference distance
    resolution_um: float = Field(0.02, ge=0)
    noise_um: float = Field(0.1, ge=0)  # rms at the used sampling rate
    max_rate_hz: float = Field(392e3, gt=0)
    calibration_error: float = Field(0.0, ge=0, lt=0.5)


class AccelerometerConfig(_Strict):
    """Miniature accelerometer, PCB 352C23 class."""

    mass_g: float = Field(0.2, ge=0)
    range_g: float = Field(1000.0, gt=0)
    noise_g: float = Field(0.008, ge=0)  # broadband rms
    highpass_hz: float = Field(1.0, ge=0)  # first-order low-frequency roll-off
    upper_hz: float = Field(10e3, gt=0)  # upper end of the ±5 % range
    cross_axis: float = Field(0.02, ge=0, lt=0.2)  # transverse sensitivity ratio
    calibration_error: float = Field(0.0, ge=0, lt=0.5)


class SensorPlacement(_Strict):
    """Deterministic placement errors of the four sensors (1X, 1Y, 1aX, 1aY)."""

    position_error_mm: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)  # along the tool
    misalignment_deg: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)  # about the tool axis


class BandConfig(_Strict):
    """One measurement band."""

    f_min: float = Field(gt=0)
    f_max: float = Field(gt=0)
    sensor: Literal["laser", "accelerometer"]
    s_1a_mm: float = Field(gt=0)
    sample_rate: float = Field(gt=0)  # DAQ rate, Hz
    line_spacing: float = Field(gt=0)  # Hz; the record length is 1/line_spacing
    hammer: HammerConfig
    decay: float = Field(1e-4, gt=0, lt=0.1)  # simulate until the slowest mode has decayed to this
    exp_window: float = Field(1.0, gt=0, le=1)  # exponential window: value at the record's end
    # auto: RK4 (error (ω dt)⁴); semi-implicit Euler costs one evaluation a step but errs ~ω dt/2
    integrator: Literal["auto", "euler", "rk4"] = "auto"
    placement: SensorPlacement = SensorPlacement()

    @model_validator(mode="after")
    def _check(self):
        if self.f_max <= self.f_min:
            raise ValueError(f"f_max ({self.f_max}) must exceed f_min ({self.f_min})")
        if self.sample_rate < 2.56 * self.f_max:
            raise ValueError(f"sample_rate {self.sample_rate} Hz is below 2.56 x f_max ({2.56 * self.f_max:g} Hz)")
        if self.line_spacing > (self.f_max - self.f_min) / 10:
            raise ValueError(f"line_spacing {self.line_spacing} Hz leaves fewer than 10 lines in the band")
        return self


class HitConfig(_Strict):
    """Which coordinates are hit, and how often."""

    points: list[Literal["1X", "1Y", "1aX", "1aY"]] = ["1X", "1Y", "1aX", "1aY"]
    averages: int = Field(3, ge=1)

    @model_validator(mode="after")
    def _check(self):
        if len(set(self.points)) != len(self.points):
            raise ValueError("hits.points lists a coordinate twice")
        return self


def default_bands() -> dict[str, BandConfig]:
    """The two measurement bands of a campaign (METHODS.md §2): ``low`` 4-40 Hz with a laser
    sensor and a soft hammer tip, ``high`` 600-1400 Hz with an accelerometer."""
    return {
        "low": BandConfig(f_min=4.0, f_max=40.0, sensor="laser", s_1a_mm=33.4, sample_rate=1024.0,
                          line_spacing=0.125, hammer=HammerConfig(pulse_ms=8.0, peak_n=300.0)),
        "high": BandConfig(f_min=600.0, f_max=1400.0, sensor="accelerometer", s_1a_mm=20.0,
                           sample_rate=12800.0, line_spacing=2.0,
                           hammer=HammerConfig(pulse_ms=0.6, peak_n=400.0)),
    }


class CampaignConfig(_Strict):
    """A whole virtual impact campaign, in the file's units (see :func:`load_config`)."""

    name: str = "campaign"
    seed: int = 0
    method: Literal["time", "linear"] = "time"
    robot: RobotConfig = RobotConfig()
    grid: GridConfig = GridConfig()
    hits: HitConfig = HitConfig()
    bands: dict[Literal["low", "high"], BandConfig] = Field(default_factory=default_bands)
    laser: LaserConfig = LaserConfig()
    accelerometer: AccelerometerConfig = AccelerometerConfig()
    noise_scale: float = Field(1.0, ge=0)  # scales every noise level at once (0: noise-free)

    @model_validator(mode="after")
    def _check(self):
        if not self.bands:
            raise ValueError("at least one band is needed")
        for name, band in self.bands.items():
            if band.sensor == "laser" and band.sample_rate > self.laser.max_rate_hz:
                raise ValueError(f"bands.{name}.sample_rate {band.sample_rate:g} Hz exceeds the laser's "
                                 f"{self.laser.max_rate_hz:g} Hz")
            if band.sensor == "accelerometer" and band.f_max > self.accelerometer.upper_hz:
                raise ValueError(f"bands.{name}.f_max {band.f_max:g} Hz is beyond the accelerometer's "
                                 f"range (upper {self.accelerometer.upper_hz:g} Hz)")
            if band.sensor == "accelerometer" and band.f_min < 5 * self.accelerometer.highpass_hz:
                raise ValueError(f"bands.{name}.f_min {band.f_min:g} Hz is inside the accelerometer's "
                                 f"low-frequency roll-off ({self.accelerometer.highpass_hz:g} Hz)")
        return self

    @property
    def digest(self) -> str:
        """Hash of the validated configuration, to tie partial results to it."""
        return hashlib.sha256(self.model_dump_json().encode()).hexdigest()[:16]

    def with_overrides(self, **changes) -> "CampaignConfig":
        """A copy with fields replaced, validated again.

        Top-level fields by name (``method="linear"``), fields of ``[robot]`` prefixed with
        ``robot_`` (``robot_name="variant.xml"``, ``robot_commands_from="irb6660"``).
        """
        data = self.model_dump()
        for key, value in changes.items():
            if key.startswith("robot_"):
                data["robot"][key.removeprefix("robot_")] = value
            else:
                data[key] = value
        try:
            return CampaignConfig.model_validate(data)
        except ValidationError as err:
            return _raise(_first_error("override", err))


def parse_config(text: str, *, source: str = "config") -> CampaignConfig:
    """Parse and validate TOML text; any problem raises :class:`InputError` naming the key."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"{source}: not valid TOML: {err}") from None
    try:
        return CampaignConfig.model_validate(raw)
    except ValidationError as err:
        return _raise(_first_error(source, err))


def load_config(path: str | Path) -> CampaignConfig:
    """Read a campaign TOML file, or a bundled config by name (``seed_full``, ``demo``)."""
    path = Path(path)
    if not path.suffix and path.parent == Path(".") and (Path(__file__).parent / "configs" / f"{path}.toml").is_file():
        path = Path(__file__).parent / "configs" / f"{path}.toml"
    if not path.is_file():
        raise InputError(f"config file not found: {path}")
    return parse_config(path.read_text(), source=str(path))


def bundled_configs() -> dict[str, Path]:
    """The example configs shipped with rmbench."""
    return {p.stem: p for p in sorted((Path(__file__).parent / "configs").glob("*.toml"))}


def _first_error(source: str, err: ValidationError) -> str:
    """One line naming the first invalid key and what is wrong with it."""
    first = err.errors()[0]
    where = ".".join(str(p) for p in first["loc"]) or "(top level)"
    msg = first["msg"].removeprefix("Value error, ")
    if first["type"] == "extra_forbidden":
        msg = "unknown key"
    return f"{source}: {where}: {msg}"


def _raise(msg):
    raise InputError(msg)


def _finite(x: float) -> bool:
    return math.isfinite(x)
