"""Re-orienting the redundant angle at a path's corners, the tool standing (issue 82).

Along a straight stretch θ changes by cycloidal ramps of one grid step over tens of millimetres
(:mod:`rmbench.path.plan`): the joints must follow the feed without throwing the tool off its
path. Where the feed heading turns, a real machine decelerates into the corner anyway. With
``PlanSettings.reorient = "corners"`` the plan may use that: at a corner the feed stops, θ turns
by any number of grid steps while the tool stands (at the joints' rate, acceleration and jerk
limits, rest to rest), then the cut resumes at the new angle. The feed-aligned critical depth
turns with the heading, so the angle that suits one side seldom suits the next.

A *corner* is a run of consecutive cutter locations at which the path turns (the heading out of a
location differs from the heading into it by more than :data:`TURNING`: an arc drawn as short
chords turns at each of them) whose turns add up to more than the threshold
(``PlanSettings.corner_angle``, default 30°); the tool stands at the run's middle location. A
raster's pass end (two right angles a step-over apart) is two corners.

The cost: the *dwell*, the time the tool stands at each corner, reported per corner and in total
(:func:`dwell_time`: the largest joint move of the turn, rest to rest at the limits, every joint
synchronised to it). A standing tool rubs the wall it has cut: heat, wear and a dwell mark. No
chip is cut while it stands (no feed), so the critical depths of the angles swept between are not
counted: the cut into the corner is at the angle it arrives at, the cut out of it at the new one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.io.toolpath import ToolPath

__all__ = ["REORIENTS", "TURNING", "Reorientation", "find_corners", "dwell_time", "corner_dwell"]

#: how the plan changes θ (``PlanSettings.reorient``): ``"ramps"`` cycloidal ramps of one grid step
#: while cutting (every earlier plan), ``"corners"`` also any turn while the tool stands at a corner
REORIENTS = ("ramps", "corners")
#: smallest turn from one move to the next that counts a location as part of a corner, rad (0.5°)
TURNING = np.radians(0.5)
#: the largest joint change between neighbouring grid angles of one continuous inverse-kinematics
#: branch, rad (the planner's own bound, :func:`rmbench.path.ramps.ramp_moves`)
BRANCH_JUMP = 0.5


@dataclass(frozen=True)
class Reorientation:
    """Where the planned schedule turned θ standing, and what it cost.

    Attributes
    ----------
    candidates : ndarray of int, shape (k,)
        The path's corner locations (:func:`find_corners`).
    used : ndarray of int, shape (u,)
        The corners at which the planned schedule turns θ (a subset of ``candidates``).
    turn : ndarray, shape (u,), rad
        θ's change at each used corner.
    dwell : ndarray, shape (u,), s
        The time the tool stands at each used corner (:func:`dwell_time`).
    """

    candidates: np.ndarray
    used: np.ndarray
    turn: np.ndarray
    dwell: np.ndarray

    @property
    def total_dwell(self) -> float:
        """The time the tool stands at corners along the plan, s."""
        return float(np.sum(self.dwell))

    def to_dict(self) -> dict:
        """Strict-JSON figures (degrees, seconds)."""
        return {"mode": "corners", "corners": int(len(self.candidates)), "corners_used": [int(c) for c in self.used],
                "turn_deg": [float(v) for v in np.degrees(self.turn)], "dwell_s": [float(v) for v in self.dwell],
                "dwell_total_s": self.total_dwell}

    def summary(self) -> str:
        """One line: the corners used of those found, θ's largest turn and the dwell."""
        big = f", up to {float(np.max(np.abs(np.degrees(self.turn)))):.0f}°" if len(self.turn) else ""
        return (f"θ turned standing at {len(self.used)} of {len(self.candidates)} corners{big}: dwell "
                f"{self.total_dwell:.2f} s in all (the tool rubs while it stands)")


def find_corners(toolpath: ToolPath, angle: float) -> np.ndarray:
    """The corner locations of ``toolpath`` (module docstring), int shape (k,), increasing, each in
    1 .. n - 2: the middle of each run of turning locations whose turns add up to more than
    ``angle`` (rad)."""
    n = len(toolpath)
    if n < 3:
        return np.zeros(0, int)
    h = toolpath.heading()
    turn = np.abs(np.angle(np.exp(1j * (h[2:] - h[1:-1]))))      # at locations 1 .. n - 2
    turning = turn > TURNING
    out = []
    i = 0
    while i < len(turn):
        if not turning[i]:
            i += 1
            continue
        j = i
        while j < len(turn) and turning[j]:
            j += 1
        if np.sum(turn[i:j]) > angle:
            out.append(1 + (i + j - 1) // 2)
        i = j
    return np.asarray(out, int)


def dwell_time(dq, rate: float, accel: float, jerk: float) -> np.ndarray:
    """The shortest rest-to-rest time of a joint move of ``dq`` (rad, any shape; its magnitude)
    within the joint rate (rad/s), acceleration (rad/s²) and jerk (rad/s³) limits: the
    jerk-limited (S-curve) profile, cruising at ``rate`` where the move is long enough, s."""
    d = np.abs(np.asarray(dq, float))
    a = min(accel, np.sqrt(rate * jerk))               # the acceleration reached before the rate
    t_acc = rate / a + a / jerk                         # from rest to the rate
    cruise = d >= rate * t_acc
    # no cruise, the acceleration limit reached: d = vp²/a + vp·a/j for the peak speed vp
    vp = 0.5 * a * (np.sqrt((a / jerk) ** 2 + 4 * d / a) - a / jerk)
    reach_a = vp >= a * a / jerk
    t = np.where(cruise, d / rate + t_acc,
                 np.where(reach_a, 2 * (vp / a + a / jerk), 4 * np.cbrt(d / (2 * jerk))))
    return np.where(d > 0, t, 0.0)


def corner_dwell(schedule, q_grid, candidates, rate: float, accel: float, jerk: float) -> Reorientation:
    """The :class:`Reorientation` of a planned ``schedule`` (:class:`rmbench.path.plan.Schedule`)
    over the grid's joint commands ``q_grid`` (rad, shape (n, m, n_joint)): at each corner it
    turns at, θ's change and the dwell of its largest joint move (from the schedule's joint
    commands there to the grid's at the angle it leaves at)."""
    used = np.zeros(0, int) if schedule.corners is None else np.asarray(schedule.corners, int)
    q = np.asarray(q_grid, float)
    arrive = schedule.joints(q)[used]
    leave = q[used, schedule.index[used + 1]]
    move = np.max(np.abs(leave - arrive), axis=1) if len(used) else np.zeros(0)
    turn = schedule.theta[used + 1] - schedule.theta[used]
    return Reorientation(np.asarray(candidates, int), used, turn, dwell_time(move, rate, accel, jerk))
