"""The planner's θ ramps fitted to the joints: how many moves one takes, and its poses solved.

A θ change of one grid step is spread over a cycloidal ramp (:func:`rmbench.path.plan.ramp_profile`)
of ``PlanSettings.ramp_length``, lengthened until the joints' acceleration and jerk limits hold
(:func:`ramp_moves`); the plan reads the poses along it linear in θ between the grid's, and
:func:`solve_ramps` solves them exactly.
"""

from __future__ import annotations

import numpy as np

from rmbench.io.toolpath import ToolPath
from rmbench.path.plan import Schedule
from rmbench.path.reach import Reach

__all__ = ["ramp_moves", "solve_ramps"]


def ramp_moves(settings, reach: Reach, dt: np.ndarray) -> int:
    """Moves per θ ramp: ``settings.ramp_length``, lengthened until the largest joint change between
    neighbouring grid angles along the path fits the acceleration and jerk limits on a cycloid
    (peak acceleration 2π Δq / T², jerk 4π² Δq / T³), so that a coarse angle grid is not locked
    to one angle."""
    r = settings.ramp_moves
    if r == 1 and settings.ramp_length == 0 or len(reach.theta) < 2 or not len(dt):
        return r
    with np.errstate(invalid="ignore"):
        d = np.max(np.abs(np.diff(reach.q, axis=1)), axis=2)
    d = d[np.isfinite(d) & (d < 0.5)]          # beyond half a radian: another branch, never ramped to
    if not len(d) or d.max() == 0:
        return r
    dq = float(d.max())
    t = max(np.sqrt(2 * np.pi * dq / settings.max_joint_accel), np.cbrt(4 * np.pi ** 2 * dq / settings.max_joint_jerk))
    step = float(np.median(dt[dt > 0])) if np.any(dt > 0) else 0.0
    return max(r, int(np.ceil(t / step))) if step > 0 else r


def solve_ramps(robot, tp: ToolPath, reach: Reach, schedule: Schedule, max_dq: np.ndarray) -> Schedule:
    """The schedule with its joint commands solved at the ramps' angles (each warm-started from
    the grid's commands interpolated in θ, which stay on the grid's branch); unchanged without
    ramps. A ramp pose that does not solve, or that leaves the joint limits, or a solved move
    beyond the joint rate (``max_dq`` per move, rad; the plan checked the grid's interpolation)
    makes it infeasible (a move starts at the pose it leaves from: a standing turn at a corner is
    no move)."""
    import dataclasses

    from rmbench.errors import UnreachablePosture
    from rmbench.robot.posture import Posture

    ramping = schedule.ramping
    if not ramping.any():
        return schedule
    q = schedule.joints(reach.q).copy()
    seed = schedule.on(reach.q)
    feasible = schedule.feasible
    for i in np.flatnonzero(ramping):
        posture = Posture(float(tp.xy[i, 0]), float(tp.xy[i, 1]), float(schedule.theta[i]))
        try:
            sol = robot.kinematics.solve(robot.target(posture), [seed[i]])
        except UnreachablePosture:
            feasible, q[i] = False, seed[i]
            continue
        q[i] = sol.q
        feasible &= bool(sol.limit_margin >= 0)
    qd = dataclasses.replace(schedule, q=q).departure(reach.q)
    moves = np.max(np.abs(q[1:] - qd[:-1]), axis=1)
    feasible &= bool(np.all(moves <= max_dq + 1e-9))
    return dataclasses.replace(schedule, q=q, feasible=feasible)
