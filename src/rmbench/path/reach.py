"""Where the robot can hold the tool along a path: inverse kinematics over (cutter location, θ).

Every cutter location of the workpiece plane is a posture once the redundant angle θ (the tool's
turn about its own axis, METHODS.md §5) is chosen. For each θ of a grid the joint commands are
followed along the path, each solution warm-started from the previous location's, so that a
column of the grid stays on one inverse-kinematics branch; where the warm start fails the robot's
own seeds are tried (:meth:`rmbench.robot.Robot.ik`). Each solution carries its distance to the
joint limits and to a singularity (the Jacobian's smallest singular value).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.errors import UnreachablePosture
from rmbench.io.toolpath import ToolPath
from rmbench.robot.posture import Posture

__all__ = ["Reach", "reach_grid"]


@dataclass(frozen=True)
class Reach:
    """Joint commands over the (location, θ) grid.

    Attributes
    ----------
    theta : ndarray, shape (m,), rad
    q : ndarray, shape (n, m, n_joint), rad
        NaN where the pose cannot be reached.
    ok : ndarray of bool, shape (n, m)
        Reached, inside the joint limits with ``limit_margin`` to spare and away from singularities
        (``sigma_min`` at least ``min_sigma``).
    limit_margin : ndarray, shape (n, m), rad
        Smallest distance of a joint to its limit (NaN where unreached).
    sigma_min : ndarray, shape (n, m)
        Smallest singular value of the Jacobian (position rows in m/rad; NaN where unreached).
    """

    theta: np.ndarray
    q: np.ndarray
    ok: np.ndarray
    limit_margin: np.ndarray
    sigma_min: np.ndarray

    def unreachable(self) -> np.ndarray:
        """Indices of the locations no θ of the grid reaches, shape (k,)."""
        return np.flatnonzero(~self.ok.any(axis=1))


def reach_grid(robot, toolpath: ToolPath, theta, *, min_margin: float = np.radians(2.0),
               min_sigma: float = 1e-3, workers: int | None = None, progress=None) -> Reach:
    """Inverse kinematics of every cutter location at every θ.

    Parameters
    ----------
    robot : rmbench.robot.Robot
    toolpath : ToolPath
        Cutter locations on the robot's workpiece plane (the posture grid's plane).
    theta : array_like, shape (m,), rad
    min_margin : float
        Joint-limit margin a usable pose keeps, rad.
    min_sigma : float
        Smallest singular value of the Jacobian a usable pose keeps (distance from singularities).
    workers : int, optional
        Processes the angles are shared among (each follows its own columns; the solutions do not
        depend on the count); default this process's share of the cores
        (:func:`rmbench.threads.default_workers`), 0 or 1 in this process.
    progress : callable, optional
        ``progress(i)`` after each location (in this process only).
    """
    from rmbench.threads import default_workers

    theta = np.asarray(theta, float)
    n = min(default_workers() if workers is None else int(workers), len(theta))
    if n > 1 and progress is None:
        parts = _in_processes(robot, toolpath, theta, n)
        if parts is not None:
            q, margin, sigma = (np.concatenate(v, axis=1) for v in zip(*parts))
            return _reach(theta, q, margin, sigma, min_margin, min_sigma)
    return _reach(theta, *_columns(robot, toolpath, theta, progress), min_margin, min_sigma)


def _reach(theta, q, margin, sigma, min_margin, min_sigma) -> Reach:
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(margin) & (margin >= min_margin) & (sigma >= min_sigma)
    return Reach(theta, q, ok, margin, sigma)


def _columns(robot, toolpath: ToolPath, theta: np.ndarray, progress=None):
    """Joint commands, limit margins and σ_min along the path for each θ, each column warm-started
    from its previous location."""
    n, m, k = len(toolpath), len(theta), len(robot.arm_joints)
    q = np.full((n, m, k), np.nan)
    margin = np.full((n, m), np.nan)
    sigma = np.full((n, m), np.nan)
    kin = robot.kinematics
    for i, (x, y) in enumerate(toolpath.xy):
        for j, th in enumerate(theta):
            posture = Posture(float(x), float(y), float(th))
            sol = None
            if i and np.isfinite(q[i - 1, j, 0]):
                try:      # the previous location's branch
                    sol = kin.solve(robot.target(posture), [q[i - 1, j]])
                except UnreachablePosture:
                    sol = None
            if sol is None:
                try:
                    sol = robot.ik(posture)
                except UnreachablePosture:
                    continue
            q[i, j], margin[i, j], sigma[i, j] = sol.q, sol.limit_margin, sol.sigma_min
        if progress is not None:
            progress(i)
    return q, margin, sigma


def _in_processes(robot, toolpath: ToolPath, theta: np.ndarray, n: int):
    """:func:`_columns` of ``n`` blocks of angles in forked processes (the robot is not picklable;
    a fork inherits it), in order; None where the processes cannot be started (the caller then
    solves here)."""
    import multiprocessing as mp

    from rmbench.threads import worker_init

    def work(cols, conn):
        try:
            worker_init()
            conn.send(("ok", _columns(robot, toolpath, theta[cols])))
        except BaseException as e:     # noqa: BLE001 - reported to the parent, which raises it
            conn.send(("error", f"{type(e).__name__}: {e}"))
        finally:
            conn.close()

    ctx = mp.get_context("fork")
    blocks = np.array_split(np.arange(len(theta)), n)
    procs = []
    try:
        for cols in blocks:
            here, there = ctx.Pipe(duplex=False)
            proc = ctx.Process(target=work, args=(cols, there), daemon=True)
            proc.start()
            there.close()
            procs.append((proc, here))
    except OSError:            # no memory to fork: solve here
        for proc, _ in procs:
            proc.kill()
        return None
    out = []
    try:
        for proc, here in procs:
            status, value = here.recv()
            if status != "ok":
                raise RuntimeError(f"inverse kinematics in a worker process failed: {value}")
            out.append(value)
    finally:
        for proc, here in procs:
            here.close()
            proc.join(timeout=10)
            if proc.is_alive():
                proc.kill()
    return out
