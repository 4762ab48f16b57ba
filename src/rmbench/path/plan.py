"""The redundant angle along a path: the schedule θ(s) that keeps the most margin to chatter.

Given a margin over the (location, θ) grid (a critical depth, or its distance to the depth cut;
larger is safer; ``-inf`` where a pose cannot be used), a schedule picks one θ per location. Moves
between neighbouring locations are limited: θ by at most ``max_step`` grid steps, every joint by at
most ``max_dq`` (the joint-rate limit times the time between locations; an inverse-kinematics
branch flip is a jump far beyond it). Among the schedules that respect them, the plan

1. maximises the smallest margin along the path (a bottleneck path: dynamic programming with
   ``V_s(k) = min(m_s(k), max_j V_{s-1}(j))`` over allowed moves ``j → k``), then
2. among those that reach it, maximises the summed margin less a small cost per θ step (a second
   pass with every pose below the bottleneck masked), so that the schedule is not needlessly
   restless where the bottleneck lies elsewhere.

The fixed-θ schedule (one θ throughout) and the pointwise best (each location's best θ, moves
unchecked) are the comparisons.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError

__all__ = ["Schedule", "plan_schedule", "fixed_schedule", "pointwise_schedule"]


@dataclass(frozen=True)
class Schedule:
    """One θ per location.

    Attributes
    ----------
    index : ndarray of int, shape (n,)
        θ grid index per location.
    theta : ndarray, shape (n,), rad
    margin : ndarray, shape (n,)
        The margin along the schedule.
    feasible : bool
        Every pose usable and every move within the limits.
    kind : str
        ``"planned"``, ``"fixed"`` or ``"pointwise"``.
    """

    index: np.ndarray
    theta: np.ndarray
    margin: np.ndarray
    feasible: bool
    kind: str

    @property
    def min_margin(self) -> float:
        return float(np.min(self.margin))


def _allowed(q, s: int, max_step: int, max_dq, m: int) -> np.ndarray:
    """Moves from location ``s - 1`` (rows j) to ``s`` (columns k), shape (m, m); ``max_dq`` per
    move (shape (n - 1,))."""
    j, k = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
    ok = np.abs(k - j) <= max_step
    if q is not None and max_dq is not None:
        with np.errstate(invalid="ignore"):
            dq = np.nanmax(np.abs(q[s][None, :, :] - q[s - 1][:, None, :]), axis=2)
        ok &= np.isfinite(dq) & (dq <= max_dq[s - 1])
    return ok


def _per_move(max_dq, n: int):
    if max_dq is None:
        return None
    out = np.broadcast_to(np.asarray(max_dq, float), (max(n - 1, 0),))
    if np.any(~(out >= 0)):
        raise InputError("the largest joint move must be >= 0 rad")
    return out


def _check(margin, theta, q) -> tuple[np.ndarray, np.ndarray]:
    margin = np.asarray(margin, float)
    theta = np.asarray(theta, float)
    if margin.ndim != 2 or margin.shape[1] != len(theta) or margin.shape[0] < 1:
        raise InputError(f"the margin must be (locations, {len(theta)} angles), got shape {margin.shape}")
    if np.any(np.isnan(margin)):
        raise InputError("the margin has NaN entries: mark unusable poses with -inf")
    if q is not None and np.shape(q)[:2] != margin.shape:
        raise InputError(f"the joint grid must be (locations, angles, joints) = {margin.shape} + (n,)")
    return margin, theta


def plan_schedule(margin, theta, *, q=None, max_step: int = 1, max_dq=None,
                  step_cost: float = 1e-3) -> Schedule:
    """The maximin schedule of the module docstring.

    Parameters
    ----------
    margin : array_like, shape (n, m)
        Margin per location and θ (larger is safer; ``-inf``: unusable).
    theta : array_like, shape (m,), rad
    q : array_like, shape (n, m, n_joint), rad, optional
        Joint commands per pose, for the joint-step limit.
    max_step : int
        Largest θ move between neighbouring locations, in grid steps.
    max_dq : float or array_like of shape (n - 1,), optional
        Largest joint move between neighbouring locations, rad, one for all moves or one per move
        (the joint rate times each move's time; needs ``q``).
    step_cost : float
        Cost of one θ grid step in the second pass, in units of the margin's spread (a tie-breaker).

    Returns
    -------
    Schedule
        ``feasible`` False where no schedule keeps every pose usable (the bottleneck is -inf).
    """
    margin, theta = _check(margin, theta, q)
    q = None if q is None else np.asarray(q, float)
    n, m = margin.shape
    max_dq = _per_move(max_dq, n)
    allowed = [None] + [_allowed(q, s, max_step, max_dq, m) for s in range(1, n)]
    # pass 1: the bottleneck value
    v = margin[0].copy()
    for s in range(1, n):
        best_in = np.max(np.where(allowed[s], v[:, None], -np.inf), axis=0)
        v = np.minimum(margin[s], best_in)
    bottleneck = float(np.max(v))
    if not np.isfinite(bottleneck):
        return _fallback(margin, theta, q, max_step, max_dq)
    # pass 2: the largest sum at or above the bottleneck, θ steps costed
    finite = margin[np.isfinite(margin)]
    scale = float(np.ptp(finite)) or 1.0
    usable = margin >= bottleneck - 1e-12 * max(abs(bottleneck), 1.0)
    gain = np.where(usable, margin / scale, -np.inf)
    j, k = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
    cost = step_cost * np.abs(k - j)
    w = gain[0].copy()
    back = np.zeros((n, m), int)
    for s in range(1, n):
        cand = np.where(allowed[s], w[:, None] - cost, -np.inf)
        back[s] = np.argmax(cand, axis=0)
        w = gain[s] + cand[back[s], np.arange(m)]
    idx = np.empty(n, int)
    idx[-1] = int(np.argmax(w))
    for s in range(n - 1, 0, -1):
        idx[s - 1] = back[s, idx[s]]
    return Schedule(idx, theta[idx], margin[np.arange(n), idx], True, "planned")


def _fallback(margin, theta, q, max_step, max_dq) -> Schedule:
    """No feasible schedule: the pointwise best, flagged infeasible."""
    s = pointwise_schedule(margin, theta)
    return Schedule(s.index, s.theta, s.margin, False, "planned")


def fixed_schedule(margin, theta, value: float, *, q=None, max_dq=None) -> Schedule:
    """θ held at the grid angle nearest ``value`` (rad) throughout."""
    margin, theta = _check(margin, theta, q)
    j = int(np.argmin(np.abs(theta - value)))
    n = margin.shape[0]
    idx = np.full(n, j)
    feasible = bool(np.all(np.isfinite(margin[:, j])))
    max_dq = _per_move(max_dq, n)
    if feasible and q is not None and max_dq is not None and n > 1:
        feasible = bool(np.all(np.max(np.abs(np.diff(np.asarray(q, float)[:, j], axis=0)), axis=1) <= max_dq))
    return Schedule(idx, theta[idx], margin[:, j], feasible, "fixed")


def pointwise_schedule(margin, theta) -> Schedule:
    """Each location's best θ, moves unchecked (an upper bound no smooth schedule can beat)."""
    margin, theta = _check(margin, theta, None)
    idx = np.argmax(margin, axis=1)
    got = margin[np.arange(len(idx)), idx]
    return Schedule(idx, theta[idx], got, bool(np.all(np.isfinite(got))), "pointwise")
