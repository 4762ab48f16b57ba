"""Sensors of an impact test: where they sit, what they read, how they load and how they err.

Four uniaxial sensors read the coordinates ``1X, 1Y, 1aX, 1aY`` (base X and Y at the tool tip 1
and at point 1a). Deterministic effects, which the as-tested ground truth includes: position along
the tool and misalignment about the tool axis (both configurable, to study misplacement), an
accelerometer's cross-axis (transverse) sensitivity and its mass on the tool. Random effects, which
only the measurement has: noise, resolution, and calibration (sensitivity) errors.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SensorSet", "sensor_set", "G0"]

G0 = 9.80665  # m/s² per g
COORDS = ("1X", "1Y", "1aX", "1aY")


@dataclass(frozen=True)
class SensorSet:
    """The four sensors of one band, SI units.

    Attributes
    ----------
    kind : {"laser", "accelerometer"}
    s_up : ndarray, shape (4,)
        Actual distance of each sensor up the tool from the tip, m.
    angle : ndarray, shape (4,)
        Actual direction of each sensor's axis in the base XY plane, rad from +X.
    cross_axis : float
        Transverse sensitivity (reads this fraction of the in-plane perpendicular motion).
    mass : float
        Mass of each sensor on the tool, kg (0 for lasers).
    noise : float
        Noise rms, m (laser) or m/s² (accelerometer).
    resolution : float
        Quantisation step, same units (0: none).
    full_range : float
        ± range, same units.
    highpass : float
        First-order low-frequency corner, Hz (0: none).
    gain : ndarray, shape (4,)
        Actual sensitivity over nominal (calibration error), 1 when calibrated.
    """

    kind: str
    s_up: np.ndarray
    angle: np.ndarray
    cross_axis: float
    mass: float
    noise: float
    resolution: float
    full_range: float
    highpass: float
    gain: np.ndarray

    def directions(self) -> np.ndarray:
        """Reading direction of each sensor in base coordinates, shape (4, 3), cross-axis included."""
        c, s = np.cos(self.angle), np.sin(self.angle)
        axis = np.stack([c, s, np.zeros(4)], axis=1)
        perp = np.stack([-s, c, np.zeros(4)], axis=1)
        return axis + self.cross_axis * perp

    def reading_rows(self, op) -> np.ndarray:
        """Rows mapping generalised displacements to the readings, shape (4, n_dof)."""
        d = self.directions()
        return np.array([d[i] @ op.point_jacobian(op.robot.tcp, self.s_up[i]) for i in range(4)])

    def tool_masses(self) -> list[tuple[float, float]]:
        """(s_up, mass) of each sensor, for the as-tested model."""
        return [(float(s), self.mass) for s in self.s_up] if self.mass > 0 else []


def nominal_point(coord: str, s_1a: float) -> tuple[float, float]:
    """(s_up m, angle rad) of a nominal coordinate."""
    s = 0.0 if coord in ("1X", "1Y") else s_1a
    return s, (0.0 if coord.endswith("X") else np.pi / 2)


def sensor_set(band_cfg, cfg, rng: np.random.Generator | None) -> SensorSet:
    """The sensors of a band from the campaign config (file units), with drawn calibration errors.

    ``rng`` draws the calibration errors once per campaign; None gives calibrated sensors.
    """
    s_1a = 1e-3 * band_cfg.s_1a_mm
    place = band_cfg.placement
    s_up, angle = [], []
    for i, c in enumerate(COORDS):
        s, a = nominal_point(c, s_1a)
        s_up.append(max(0.0, s + 1e-3 * place.position_error_mm[i]))
        angle.append(a + np.radians(place.misalignment_deg[i]))
    scale = cfg.noise_scale
    if band_cfg.sensor == "laser":
        sens = cfg.laser
        noise, res, rng_ = 1e-6 * sens.noise_um, 1e-6 * sens.resolution_um, 1e-3 * sens.range_mm
        cross, mass, hp = 0.0, 0.0, 0.0
    else:
        sens = cfg.accelerometer
        noise, res, rng_ = G0 * sens.noise_g, 0.0, G0 * sens.range_g
        cross, mass, hp = sens.cross_axis, 1e-3 * sens.mass_g, sens.highpass_hz
    gain = np.ones(4)
    if rng is not None and sens.calibration_error > 0:
        gain = 1 + sens.calibration_error * rng.standard_normal(4)
    return SensorSet(kind=band_cfg.sensor, s_up=np.array(s_up), angle=np.array(angle),
                     cross_axis=cross, mass=mass, noise=noise * scale, resolution=res * (scale > 0),
                     full_range=rng_, highpass=hp, gain=gain)
