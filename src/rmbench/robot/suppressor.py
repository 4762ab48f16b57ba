"""The MH180 stand-in with its proof-mass suppressor: reference posture and its axes.

"Tangential" is base Y (perpendicular to the arm's vertical plane at the reference posture),
"axial" base Z (the spindle axis, vertical there), "radial" base X.
"""

from __future__ import annotations

import numpy as np

from rmbench.robot.model import OperatingPoint, Robot
from rmbench.robot.spec import custom_numeric

__all__ = ["AXES", "reference_q", "reference_point", "reference_modes"]

AXES = {"tangential": "Y", "axial": "Z", "radial": "X"}


def reference_q(robot: Robot) -> np.ndarray:
    """Arm joint commands of the robot's reference posture, rad, shape (n_arm,)."""
    q = custom_numeric(robot.spec, "rmbench_reference_q")
    if q is None:
        raise ValueError(f"robot {robot.name!r} declares no reference posture")
    return q


def reference_point(robot: Robot | None = None) -> OperatingPoint:
    """The MH180 stand-in at its reference posture (arm stretched out, spindle axis vertical)."""
    robot = robot if robot is not None else Robot.load("mh180")
    return robot.at(reference_q(robot))


def reference_modes(op: OperatingPoint | None = None, site: str = "acc") -> dict:
    """First tangential and axial modes at the suppressor, and their cross coupling.

    Returns
    -------
    dict
        ``tangential_hz``, ``axial_hz`` (Hz); ``cross_tangential`` = |H_zy|/|H_yy| at the
        tangential mode and ``cross_axial`` = |H_yz|/|H_zz| at the axial mode (receptances at
        ``site``, base directions).
    """
    op = op if op is not None else reference_point()
    coords = (f"{site}:Y", f"{site}:Z")
    t = op.coordinate_map(coords)
    modes = op.linear.modes()
    r, lt = t @ modes.phi_r, t @ modes.phi_l
    direct = np.abs(r * lt) / np.abs(modes.poles.real)  # (2, n_modes) peak of the direct FRFs
    visible = (modes.f_n > 1.0) & ~modes.real_pole & (direct.max(0) > 0.01 * direct.max())
    tang = np.flatnonzero(visible & (direct[0] > direct[1]))[0]
    axial = np.flatnonzero(visible & (direct[1] > direct[0]))[0]
    f_t, f_a = modes.f_n[tang], modes.f_n[axial]
    h = op.frf(np.array([f_t, f_a]), coords)
    return {"tangential_hz": float(f_t), "axial_hz": float(f_a),
            "cross_tangential": float(abs(h[0, 1, 0]) / abs(h[0, 0, 0])),
            "cross_axial": float(abs(h[1, 0, 1]) / abs(h[1, 1, 1]))}
