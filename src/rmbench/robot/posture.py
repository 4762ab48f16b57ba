"""Postures (x, y, θ) and the seed's posture grids, METHODS.md §5.

A posture is the tool-tip position in the base XY plane at the robot's table height, the tool axis
perpendicular to that plane (pointing down), and θ the redundant angle about the tool axis,
right-handed about base +Z. Inside rmbench postures are in m and rad; the CLI takes mm and degrees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError

__all__ = ["Posture", "seed_grid", "validation_postures", "parse_posture"]


@dataclass(frozen=True)
class Posture:
    """A commanded posture.

    Attributes
    ----------
    x, y : float
        Tool-tip position in the robot base frame, m.
    theta : float
        Redundant angle about the tool axis, rad (0: the tool frame's x axis along base +X).
    """

    x: float
    y: float
    theta: float = 0.0

    def __post_init__(self):
        for name in ("x", "y", "theta"):
            if not math.isfinite(getattr(self, name)):
                raise InputError(f"posture {name} must be finite, got {getattr(self, name)}")

    @classmethod
    def from_mm_deg(cls, x_mm: float, y_mm: float, theta_deg: float = 0.0) -> "Posture":
        """Build from the user-interface units: mm, mm, degrees."""
        return cls(x_mm / 1000.0, y_mm / 1000.0, math.radians(theta_deg))

    def as_mm_deg(self) -> tuple[float, float, float]:
        """(x mm, y mm, θ degrees)."""
        return self.x * 1000.0, self.y * 1000.0, math.degrees(self.theta)

    def label(self) -> str:
        """Short text such as ``1800,-200,0`` (mm, mm, degrees)."""
        x, y, t = self.as_mm_deg()
        return f"{x:g},{y:g},{t:g}"


def parse_posture(text: str) -> Posture:
    """Parse ``"x,y,theta"`` in mm, mm, degrees (θ optional, default 0)."""
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) not in (2, 3):
        raise InputError(f"posture must be 'x,y[,theta]' in mm and degrees, got {text!r}")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise InputError(f"posture must be numbers 'x,y[,theta]' in mm and degrees, got {text!r}") from None
    return Posture.from_mm_deg(*values)


def seed_grid() -> list[Posture]:
    """The seed's 112 training postures: X 1300-1900 mm, Y ±300 mm, θ −60…60° (x fastest last)."""
    xs = (1300, 1500, 1700, 1900)
    ys = (-300, -100, 100, 300)
    thetas = (-60, -40, -20, 0, 20, 40, 60)
    return [Posture.from_mm_deg(x, y, t) for x in xs for y in ys for t in thetas]


def validation_postures() -> list[Posture]:
    """The seed's three validation postures."""
    return [Posture.from_mm_deg(1800, -200, 0), Posture.from_mm_deg(1800, 200, 0),
            Posture.from_mm_deg(1800, 200, 60)]


def rz(theta: float) -> np.ndarray:
    """Rotation about +Z by θ (rad), shape (3, 3)."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
