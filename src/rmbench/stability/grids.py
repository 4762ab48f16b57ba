"""The scan grids and the benchmark structure every lobes run starts from, defined once.

Spindle speeds in rev/min (the user's unit; the stability code converts), depths in m.
"""

from __future__ import annotations

import numpy as np

from rmbench.stability.structure import Structure

__all__ = ["SPEED_RANGES", "DEPTH_MAX", "speed_grid", "depth_grid", "benchmark_structure"]

#: rev/min: the benchmark's range (Insperger & Stépán, 5-25 krpm), a milling robot's spindle, and
#: low-speed milling of steel and titanium, where the robot's own modes set the limit (Cordes, Hintze
#: & Altintas 2019; issue 82)
SPEED_RANGES = {"benchmark": (5000.0, 25000.0), "robot": (5000.0, 20000.0), "low": (300.0, 3000.0)}
#: m: the deepest axial depth a lobes scan reaches by default
DEPTH_MAX = 10e-3


def speed_grid(kind: str = "robot", n: int = 200) -> np.ndarray:
    """``n`` spindle speeds evenly over ``kind``'s range (:data:`SPEED_RANGES`), rev/min."""
    lo, hi = SPEED_RANGES[kind]
    return np.linspace(lo, hi, n)


def depth_grid(depth_max: float = DEPTH_MAX, n: int = 100) -> np.ndarray:
    """``n`` axial depths from 0 to ``depth_max`` (m), m."""
    return np.linspace(0.0, depth_max, n)


def benchmark_structure() -> Structure:
    """The 1-DOF benchmark tool tip of the lobes literature: 0.03993 kg, 922 Hz, ζ 1.1 %."""
    return Structure.sdof(0.03993, 922.0, 0.011)
