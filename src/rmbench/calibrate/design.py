"""The test design of measured FRF data: bands, sensors, hits — and nothing else.

A diagnosis compares a model with measurements taken under a test design; the model must be put
under the same design (sensor masses on the tool, sensor positions and directions, hit points),
so the design is read from the data's configuration (or a campaign TOML the user gives). It never
carries how the data were made: the robot's name or file, the random seed, the simulation method,
the noise levels are dropped on reading.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

from rmbench.errors import InputError
from rmbench.impact.config import CampaignConfig, parse_config
from rmbench.impact.sensors import COORDS, SensorSet, sensor_set
from rmbench.robot.kinds import Kind
from rmbench.robot.model import Band
from rmbench.robot.parameters import Parameter

__all__ = ["TestDesign", "SensorOffset", "SENSOR_KINDS", "sensor_parameter", "sensor_offsets"]


def _nothing(target, p, x) -> None:
    """A test design's parameter writes nothing into the robot's MJCF."""


# A sensor's placement as a calibration parameter: it changes what the model's modes look like at
# the sensors, not the modes (:class:`rmbench.calibrate.model.ModalModel` reads it through the
# design). Linear in ``u``: along the tool in mm, about its axis in degrees; a freed one may move
# 30 mm or 20° (the gap search's sensor effects stop at 10 mm and 15°).
SENSOR_KINDS = (
    Kind("sensor_along", _nothing, _nothing, display=lambda v: 1e3 * v, resolution=1e-3,
         wide=lambda p: (-30.0, 30.0), gross=lambda p: [0.0]),
    Kind("sensor_angle", _nothing, _nothing, display=np.degrees, resolution=float(np.radians(0.1)),
         wide=lambda p: (-20.0, 20.0), gross=lambda p: [0.0]),
)
_SENSOR_FIELDS = {"along": ("sensor_along", 1e-3, "mm"), "angle": ("sensor_angle", float(np.radians(1.0)), "deg")}


def sensor_parameter(name: str) -> Parameter:
    """The placement error of one sensor as a parameter: ``sensor.BAND:COORD.along`` (m, fitted in
    mm) or ``sensor.BAND:COORD.angle`` (rad, fitted in degrees), nominal 0 (the design as read).

    Raises
    ------
    InputError
        A name of another form, or an unknown coordinate.
    """
    parts = name.split(".")
    if len(parts) != 3 or parts[0] != "sensor" or parts[2] not in _SENSOR_FIELDS or parts[1].count(":") != 1:
        raise InputError(f"not a sensor parameter: {name!r} (sensor.BAND:COORD.along or .angle)")
    band, coord = parts[1].split(":")
    SensorOffset(band, coord)           # checks the coordinate
    kind, unit, label = _SENSOR_FIELDS[parts[2]]
    lo, hi = next(k for k in SENSOR_KINDS if k.name == kind).wide(None)
    return Parameter(name, "design", kind, (band, coord), 0, 0.0, False, unit, lo, hi, label,
                     registry=SENSOR_KINDS)


def sensor_offsets(params, u) -> tuple:
    """The :class:`SensorOffset` of each sensor parameter in ``params`` at ``u`` (the others skipped)."""
    out = []
    for p, x in zip(params, np.asarray(u, float)):
        if p.kind == "sensor_along":
            out.append(SensorOffset(p.targets[0], p.targets[1], along=p.value(x)))
        elif p.kind == "sensor_angle":
            out.append(SensorOffset(p.targets[0], p.targets[1], angle=p.value(x)))
    return tuple(out)


@dataclass(frozen=True)
class SensorOffset:
    """A placement error of one sensor: along the tool (m) and about its axis (rad)."""

    band: str
    coord: str
    along: float = 0.0
    angle: float = 0.0

    def __post_init__(self):
        if self.coord not in COORDS:
            raise InputError(f"unknown sensor coordinate {self.coord!r}; use {', '.join(COORDS)}")


@dataclass(frozen=True)
class TestDesign:
    """Bands, sensors and hits of an impact test (SI inside).

    Attributes
    ----------
    config : rmbench.impact.CampaignConfig
        The campaign configuration with everything but the test design neutralised (robot
        ``irb6660`` placeholder, seed 0, method ``linear``, noise scale 1).
    offsets : tuple of SensorOffset
        Sensor placement errors assumed on top of the configuration's (a candidate effect).
    """

    __test__ = False   # not a pytest test class, whatever its name

    config: CampaignConfig
    offsets: tuple = field(default=())

    @classmethod
    def from_config(cls, cfg: CampaignConfig) -> "TestDesign":
        """The design part of a campaign configuration (robot, seed, method and noise dropped)."""
        data = cfg.model_dump()
        data.update(name="test design", seed=0, method="linear", noise_scale=1.0)
        data["robot"] = {"name": "irb6660", "tool": None, "spindle_rpm": 0.0}
        data["grid"] = {"kind": "validation"}
        return cls(CampaignConfig.model_validate(data))

    @classmethod
    def from_text(cls, text: str, *, source: str = "config") -> "TestDesign":
        """From a campaign TOML text or the JSON a dataset stores in its ``config`` attribute."""
        text = text.strip()
        if text.startswith("{"):
            try:
                cfg = CampaignConfig.model_validate(json.loads(text))
            except (ValueError, TypeError) as err:
                raise InputError(f"{source}: not a valid campaign configuration: "
                                 f"{str(err).splitlines()[0]}") from None
        else:
            cfg = parse_config(text, source=source)
        return cls.from_config(cfg)

    @classmethod
    def of_dataset(cls, ds, test: str | None = None) -> "TestDesign":
        """The design of a dataset: from ``test`` (TOML text) if given, else its ``config``."""
        if test is not None:
            return cls.from_text(test, source="--test")
        text = ds.attrs.get("config")
        if not text:
            raise InputError("the data carry no test design (no 'config' attribute): give the "
                             "campaign TOML it was measured with (--test CONFIG)")
        return cls.from_text(str(text), source="the data's config")

    @property
    def band_names(self) -> tuple[str, ...]:
        """The design's bands, in the configuration's order."""
        return tuple(self.config.bands)

    def band(self, name: str) -> Band:
        """The band ``name`` as a :class:`~rmbench.robot.model.Band`: its frequency range (Hz) and
        the distance of point 1a up the tool from the tip (m; the configuration's mm converted)."""
        b = self.config.bands[name]
        return Band(name, b.f_min, b.f_max, 1e-3 * b.s_1a_mm)

    def hit_points(self) -> tuple[str, ...]:
        """The coordinates hit with the hammer, of ``1X, 1Y, 1aX, 1aY``, in the configuration's order."""
        return tuple(self.config.hits.points)

    def sensors(self, band: str) -> SensorSet:
        """The band's sensors (calibrated), placement errors and offsets included."""
        s = sensor_set(self.config.bands[band], self.config, None)
        along, angle = s.s_up.copy(), s.angle.copy()
        for o in self.offsets:
            if o.band == band:
                i = COORDS.index(o.coord)
                along[i] = max(0.0, along[i] + o.along)
                angle[i] += o.angle
        if not self.offsets:
            return s
        return SensorSet(kind=s.kind, s_up=along, angle=angle, cross_axis=s.cross_axis,
                         mass=s.mass, noise=s.noise, resolution=s.resolution,
                         full_range=s.full_range, highpass=s.highpass, gain=s.gain)

    def with_offsets(self, offsets) -> "TestDesign":
        """The design with the sensor placement errors ``offsets`` (:class:`SensorOffset`) assumed
        on top of its own."""
        return TestDesign(self.config, tuple(self.offsets) + tuple(offsets))

    def averages(self) -> int:
        """Hits per hit point averaged into each measured FRF."""
        return int(self.config.hits.averages)

    def direction_scatter(self) -> dict:
        """Per band, the hammer's direction scatter in the XY plane, rad."""
        return {b: float(np.radians(c.hammer.direction_scatter_deg))
                for b, c in self.config.bands.items()}

    def lines(self, band: str) -> np.ndarray:
        """The band's frequency lines, Hz, shape (n_freq,): the multiples of its line spacing
        inside [f_min, f_max]."""
        from rmbench.impact.measure import band_lines

        return band_lines(self.config.bands[band])
