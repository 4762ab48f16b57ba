"""Postures of the suppression robot for control studies: joint commands, and postures where the
targeted mode has moved by a given ratio (for robustness checks)."""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from rmbench.control.plant import robot_plant
from rmbench.errors import InputError

__all__ = ["posture_for_mode_ratio"]


def posture_for_mode_ratio(robot, q_ref, ratio: float, *, axis: str = "tangential", joint: int = 1,
                           span_deg: float = 30.0, tol_deg: float = 0.05) -> np.ndarray:
    """Arm joint commands (rad) where ``axis``'s mode is ``ratio`` times its frequency at ``q_ref``.

    Moves one joint (default J2: the arm's reach, which sets the inertia the mode swings) from
    ``q_ref`` within ``±span_deg`` and solves for the frequency ratio by Brent's method.
    """
    q_ref = np.asarray(q_ref, float)

    def f_at(dq):
        q = q_ref.copy()
        q[joint] += np.radians(dq)
        return robot_plant(robot.at(q), (axis,)).mode_hz[0]

    f0 = f_at(0.0)
    g = lambda dq: f_at(dq) / f0 - ratio  # noqa: E731
    lo, hi = -span_deg, span_deg
    if g(lo) * g(hi) > 0:
        raise InputError(f"no posture within ±{span_deg:g}° of J{joint + 1} moves the {axis} mode by "
                         f"a factor {ratio:g}")
    dq = brentq(g, lo, hi, xtol=tol_deg)
    q = q_ref.copy()
    q[joint] += np.radians(dq)
    return q
