"""A posture grid in an arm's own reachable workspace, found automatically.

The seed's grid (x 1300-1900 mm, y ±300 mm, θ ±60°, the tool vertical above a table 0.45 m high)
suits a 1.9 m-reach milling robot, not a UR10 or a Panda. For any arm the same (x, y, θ)
parameterisation is kept, scaled to the arm: with R the chain length from the shoulder (second axis)
to the tool tip, the grid is 4 × 4 postures over a square 0.3 R wide, times 7 redundant angles, the
way the seed's grid is 4 × 4 × 7 over 0.6 m. Its centre line (distance x_c from the base axis) and
the table height z are searched over x_c ∈ R·{0.40 … 0.70} and z ∈ z_shoulder + R·{−0.6 … 0.2}
(z ≥ 0: the table is not below the mounting plane); the first pair, ranked by the worst margin over a
coarse subset, whose every posture (and the three validation postures) the inverse kinematics reaches
on one branch with ≥ 5° from every joint limit and σ_min of the Jacobian ≥ 0.05 (the checks the
stand-ins' grids pass) is taken. If no pair holds θ ±60°, the angle range shrinks (±40°, ±20°).

The IK seed of the branch (elbow and wrist configuration) is chosen at each candidate's centre from
random restarts: the solution with the largest worst-case margin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.errors import ModelError, UnreachablePosture
from rmbench.robot.posture import Posture

__all__ = ["WorkspaceGrid", "find_workspace_grid", "MIN_LIMIT_MARGIN", "MIN_SIGMA"]

MIN_LIMIT_MARGIN = np.radians(5.0)   # rad, from every joint limit
MIN_SIGMA = 0.05                     # smallest singular value of the 6 x n tool-tip Jacobian


@dataclass(frozen=True)
class WorkspaceGrid:
    """A posture grid for an arm.

    Attributes
    ----------
    table_z : float
        Height of the tool tip above the base frame's origin, m.
    x, y : ndarray, shape (4,)
        Grid lines, m.
    theta : ndarray, shape (n_theta,)
        Redundant angles, rad.
    validation : tuple of Posture
        Three postures inside the grid's hull, placed as the seed's are in its grid.
    ik_seed : ndarray, shape (n_arm,)
        Joint angles (rad) of the branch every posture is solved on.
    worst_margin : float
        Smallest distance to a joint limit over the grid, rad.
    worst_sigma : float
        Smallest σ_min of the Jacobian over the grid.
    reach : float
        Chain length R from the shoulder to the tool tip, m.
    """

    table_z: float
    x: np.ndarray
    y: np.ndarray
    theta: np.ndarray
    validation: tuple[Posture, ...]
    ik_seed: np.ndarray
    worst_margin: float
    worst_sigma: float
    reach: float

    def postures(self) -> list[Posture]:
        """All grid postures, x slowest and θ fastest (the seed's order)."""
        return [Posture(float(x), float(y), float(t)) for x in self.x for y in self.y for t in self.theta]


def _reach(robot) -> tuple[float, float]:
    """Chain length from the second axis to the tool tip at q = 0, and the second axis' height (m)."""
    kin = robot.kinematics
    import pinocchio as pin

    q = kin.full_q(np.zeros(len(robot.arm_joints)))
    pin.framesForwardKinematics(kin.model, kin.data, q)
    ids = [kin.model.getJointId(n) for n in robot.arm_joints]
    pts = [kin.data.oMi[i].translation for i in ids[1:]] + [kin.data.oMf[kin.frame_id].translation]
    return float(sum(np.linalg.norm(b - a) for a, b in zip(pts[:-1], pts[1:]))), float(pts[0][2])


def _solve(robot, posture):
    try:
        sol = robot.ik(posture)
    except UnreachablePosture:
        return None
    return sol


def _score(robot, postures) -> float:
    """Worst of (limit margin / 5°, σ_min / 0.05) over the postures; < 1 fails, -inf if unreachable."""
    worst = np.inf
    for p in postures:
        sol = _solve(robot, p)
        if sol is None:
            return -np.inf
        worst = min(worst, sol.limit_margin / MIN_LIMIT_MARGIN, sol.sigma_min / MIN_SIGMA)
    return worst


def _branch_seed(robot, centre: Posture, rng, n_restarts: int) -> np.ndarray | None:
    """The IK solution at ``centre`` with the largest margin, from random restarts."""
    kin = robot.kinematics
    lo, hi = robot.limits[:, 0], robot.limits[:, 1]
    best, best_score = None, -np.inf
    target = robot.target(centre)
    for _ in range(n_restarts):
        start = lo + (hi - lo) * (0.15 + 0.7 * rng.random(len(lo)))
        try:
            sol = kin.solve(target, [start])
        except UnreachablePosture:
            continue
        score = min(sol.limit_margin / MIN_LIMIT_MARGIN, sol.sigma_min / MIN_SIGMA)
        if score > best_score:
            best, best_score = sol.q, score
    return best


def find_workspace_grid(robot, *, n_restarts: int = 40, seed: int = 0) -> WorkspaceGrid:
    """Search a reachable 4 × 4 × 7 grid for ``robot`` (a :class:`~rmbench.robot.Robot` with its tool;
    its table height and IK seed are left as they were).

    Raises
    ------
    ModelError
        When no table height, grid position and angle range keeps every posture reachable with
        margin.
    """
    rng = np.random.default_rng(seed)
    reach, z_shoulder = _reach(robot)
    half = 0.15 * reach
    original = robot.ik_seed, robot.table_z   # searched by setting them; restored on return
    candidates = []
    for zf in (-0.3, -0.45, -0.15, -0.6, 0.0, 0.2):
        z = z_shoulder + zf * reach
        if z < 0:
            continue
        for xf in (0.55, 0.45, 0.65, 0.40, 0.70):
            candidates.append((z, xf * reach))
    try:
        for theta_max in (60.0, 40.0, 20.0):
            theta = np.radians(np.linspace(-theta_max, theta_max, 7))
            ranked = []
            for z, xc in candidates:
                robot.table_z = z
                seed_q = _branch_seed(robot, Posture(xc, 0.0, 0.0), rng, n_restarts)
                if seed_q is None:
                    continue
                robot.ik_seed = seed_q
                coarse = [Posture(xc + dx, dy, t) for dx in (-half, half) for dy in (-half, half)
                          for t in (theta[0], theta[-1])] + [Posture(xc, 0.0, t) for t in theta[[0, 3, 6]]]
                s = _score(robot, coarse)
                if s >= 1.0:
                    ranked.append((s, z, xc, seed_q))
            for s, z, xc, seed_q in sorted(ranked, key=lambda r: -r[0]):
                robot.table_z, robot.ik_seed = z, seed_q
                grid = _grid(robot, z, xc, half, theta, seed_q, reach)
                if grid is not None:
                    return grid
    finally:
        robot.ik_seed, robot.table_z = original
    raise ModelError(f"no reachable posture grid found for {robot.name}: no table height and grid position "
                     f"keeps 4 x 4 postures over {2 * half * 1000:.0f} mm with the tool vertical within the "
                     "joint limits (5 deg margin) and away from singularities")


def _grid(robot, z, xc, half, theta, seed_q, reach) -> WorkspaceGrid | None:
    x = xc + np.linspace(-half, half, 4)
    y = np.linspace(-half, half, 4)
    # the seed's validation postures sit at 5/6 of the x span and 2/3 of the y half-span
    xv, yv = x[0] + 5 / 6 * (x[-1] - x[0]), 2 / 3 * half
    validation = (Posture(xv, -yv, 0.0), Posture(xv, yv, 0.0), Posture(xv, yv, float(theta[-1])))
    margins, sigmas = [], []
    for p in [Posture(a, b, t) for a in x for b in y for t in theta] + list(validation):
        sol = _solve(robot, p)
        if sol is None or sol.limit_margin < MIN_LIMIT_MARGIN or sol.sigma_min < MIN_SIGMA:
            return None
        margins.append(sol.limit_margin)
        sigmas.append(sol.sigma_min)
    return WorkspaceGrid(table_z=z, x=x, y=y, theta=theta, validation=validation, ik_seed=np.array(seed_q),
                         worst_margin=float(min(margins)), worst_sigma=float(min(sigmas)), reach=reach)
