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
from rmbench.robot.model import Band

__all__ = ["TestDesign", "SensorOffset"]


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
    __test__ = False   # not a pytest test class, whatever its name
    """Bands, sensors and hits of an impact test (SI inside).

    Attributes
    ----------
    config : CampaignConfig
        The campaign configuration with everything but the test design neutralised (robot
        ``irb6660`` placeholder, seed 0, method ``linear``, noise scale 1).
    offsets : tuple of SensorOffset
        Sensor placement errors assumed on top of the configuration's (a candidate effect).
    """

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
        return tuple(self.config.bands)

    def band(self, name: str) -> Band:
        b = self.config.bands[name]
        return Band(name, b.f_min, b.f_max, 1e-3 * b.s_1a_mm)

    def hit_points(self) -> tuple[str, ...]:
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
        return TestDesign(self.config, tuple(self.offsets) + tuple(offsets))

    def averages(self) -> int:
        return int(self.config.hits.averages)

    def direction_scatter(self) -> dict:
        """Per band, the hammer's direction scatter in the XY plane, rad."""
        return {b: float(np.radians(c.hammer.direction_scatter_deg))
                for b, c in self.config.bands.items()}

    def lines(self, band: str) -> np.ndarray:
        from rmbench.impact.measure import band_lines

        return band_lines(self.config.bands[band])
