"""The redundant angle along a path: the schedule θ(s) that keeps the most margin to chatter.

Given a margin over the (location, θ) grid (a critical depth, or its distance to the depth cut;
larger is safer; ``-inf`` where a pose cannot be used), a schedule picks one θ per location. Moves
between neighbouring locations are limited: every joint by at most ``max_dq`` (the joint-rate limit
times the time between locations; an inverse-kinematics branch flip is a jump far beyond it). A
change of θ by ``d`` grid steps (``|d| <= max_step``) is a *ramp* spread over ``ramp`` moves along a
cycloidal profile ``f(τ) = τ - sin(2πτ)/2π``, whose speed and acceleration start and end at zero:
a θ step taken within one move at full feed sets the joints moving at tens of degrees a second
from rest, which the servos cannot follow without throwing the tool off its path. Given the moves'
times, a ramp whose redundancy motion exceeds the joint acceleration or jerk limit is not planned.
Along a ramp the margin counted is the smaller of its two angles' (the interpolated critical depth
between them is never below it).

At given *corner* locations ``c`` (``corners``; :mod:`rmbench.path.corners` finds them where the
feed heading turns) θ may also turn by any number of grid steps while the tool stands: it arrives
at ``c`` at angle ``j`` (its margin there counted, the cut into the corner), turns standing to any
angle ``k`` joined to ``j`` by usable poses on one inverse-kinematics branch at ``c`` (neighbouring
grid angles' joint commands within half a radian), and cuts the move out of the corner at ``k``
(allowed there). The schedules without such turns remain allowed, so the bottleneck never falls.

Among the schedules that respect the limits, the plan

1. maximises the smallest margin along the path (a bottleneck path: dynamic programming with
   ``V_s(k) = min(m_s(k), max(V_{s-1}(k), V_{s-r}(k - d) ∧ ramp))`` over allowed holds and ramps),
   then
2. among those that reach it, maximises the summed margin less a small cost per θ step (a second
   pass with every pose below the bottleneck masked), so that the schedule is not needlessly
   restless where the bottleneck lies elsewhere. With corners the second pass is lexicographic:
   among the schedules that keep the bottleneck, first the least total dwell (each standing
   turn's rest-to-rest time, :func:`rmbench.path.corners.dwell_time`, from the grid's joint
   commands at the corner; without joint commands or limits, the grid steps turned), then the
   largest summed margin. A standing turn is thus taken only where the smallest margin needs
   it, and then the shortest that does: a tool standing at a corner rubs the wall it has cut,
   which no gain in the summed depth pays for. Nor is any turn taken unless the turns raise the
   bottleneck by ``min_turn_gain`` (5 %) over the ramps-only schedule's.

The fixed-θ schedule (one θ throughout), the best fixed angle (the grid angle whose smallest
margin along the path is the largest) and the pointwise best (each location's best θ, moves
unchecked) are the comparisons.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from rmbench.errors import InputError

__all__ = ["Schedule", "plan_schedule", "fixed_schedule", "best_fixed_schedule", "pointwise_schedule",
           "ramp_profile"]


@dataclass(frozen=True)
class Schedule:
    """One θ per location.

    Attributes
    ----------
    index : ndarray of int, shape (n,)
        θ grid index per location (along a ramp: the angle it leaves).
    theta : ndarray, shape (n,), rad
    margin : ndarray, shape (n,)
        The margin along the schedule (along a ramp: interpolated between its two angles).
    feasible : bool
        Every pose usable and every move within the limits.
    kind : str
        ``"planned"``, ``"fixed"``, ``"best fixed"`` or ``"pointwise"``.
    to : ndarray of int, shape (n,), optional
        Along a ramp, the grid index it runs to (elsewhere ``index``); None: no ramps.
    frac : ndarray, shape (n,), optional
        How far along its ramp each location lies, 0-1 (the cycloidal profile; 0 off ramps).
    q : ndarray, shape (n, n_joint), rad, optional
        Joint commands where they are not the grid's (solved at the ramps' angles); None: the grid's.
    corners : ndarray of int, shape (u,), optional
        Locations at which θ turns while the tool stands: it arrives at ``index[c]`` and leaves at
        ``index[c + 1]``; None: none (ramps only).
    """

    index: np.ndarray
    theta: np.ndarray
    margin: np.ndarray
    feasible: bool
    kind: str
    to: np.ndarray | None = None
    frac: np.ndarray | None = None
    q: np.ndarray | None = None
    corners: np.ndarray | None = None

    @property
    def min_margin(self) -> float:
        """The smallest margin along the schedule, in the margin's unit (m for a critical depth)."""
        return float(np.min(self.margin))

    @property
    def ramping(self) -> np.ndarray:
        """Which locations lie inside a ramp between two grid angles, bool shape (n,)."""
        if self.to is None:
            return np.zeros(len(self.index), bool)
        return (self.to != self.index) & (self.frac > 0)

    def on(self, grid) -> np.ndarray:
        """A quantity over the (location, θ) grid read along the schedule, shape (n,) + trailing:
        interpolated linearly in θ along ramps."""
        grid = np.asarray(grid)
        n = np.arange(len(self.index))
        a = grid[n, self.index]
        if self.to is None:
            return a
        w = self.frac.reshape((-1,) + (1,) * (a.ndim - 1))
        b = grid[n, self.to]
        return np.where(w > 0, a + w * (b - a), a)

    def joints(self, q_grid) -> np.ndarray:
        """Joint commands along the schedule, rad, shape (n, n_joint): :attr:`q` where solved,
        else the grid's."""
        return np.asarray(self.q) if self.q is not None else np.asarray(q_grid)[np.arange(len(self.index)), self.index]

    def departure(self, q_grid) -> np.ndarray:
        """Joint commands at which each location is left, rad, shape (n, n_joint): :meth:`joints`,
        except at the :attr:`corners`, left at the angle the standing turn ends at (the grid's)."""
        q = self.joints(q_grid)
        if self.corners is None or not len(self.corners):
            return q
        c = np.asarray(self.corners, int)
        q = np.array(q, float)
        q[c] = np.asarray(q_grid)[c, self.index[c + 1]]
        return q


def ramp_profile(moves: int) -> np.ndarray:
    """Fractions of a ramp of ``moves`` moves at its locations, shape (moves + 1,): cycloidal
    (zero speed and acceleration at both ends), 0 to 1."""
    t = np.arange(moves + 1) / moves
    return t - np.sin(2 * np.pi * t) / (2 * np.pi)


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


def _shift(a: np.ndarray, d: int, fill) -> np.ndarray:
    """``a[..., k - d]`` at column ``k`` (``fill`` where ``k - d`` is off the grid)."""
    out = np.full_like(a, fill)
    m = a.shape[-1]
    if d >= 0:
        out[..., d:] = a[..., :m - d]
    else:
        out[..., :m + d] = a[..., -d:]
    return out


@dataclass(frozen=True)
class _Moves:
    """The allowed moves: ``hold[s, k]`` (location s - 1 to s at angle k) and, per θ step ``d``,
    ``ramp[d][s, k]`` (the ramp from ``k - d`` at location ``s - r`` to ``k`` at ``s``), with
    the ramp's smallest margin and summed mean margin over its inner locations."""

    hold: np.ndarray
    ramp: dict
    low: dict
    inner: dict


def _moves(margin, q, max_step, max_dq, r, dt, max_ddq, max_dddq) -> _Moves:
    n, m = margin.shape
    finite = np.isfinite(margin)
    hold = np.ones((n, m), bool)
    if q is not None and max_dq is not None and n > 1:
        with np.errstate(invalid="ignore"):
            step = np.max(np.abs(np.diff(q, axis=0)), axis=2)
        hold[1:] = np.isfinite(step) & (step <= max_dq[:, None])
    f = ramp_profile(r)
    ramp, low, inner = {}, {}, {}
    for d in [d for a in range(1, max_step + 1) for d in (a, -a)]:
        if d >= m or -d >= m or n <= r:
            continue
        ok = np.zeros((n, m), bool)
        both = np.minimum(_shift(margin, d, -np.inf), margin)        # both angles' smaller margin
        mean = 0.5 * (_shift(np.where(finite, margin, 0.0), d, 0.0) + np.where(finite, margin, 0.0))
        lo = np.full((n, m), np.inf)
        sm = np.zeros((n, m))
        if r > 1:
            win = np.lib.stride_tricks.sliding_window_view(both, r - 1, axis=0)   # rows i..i+r-2
            lo[r:] = win[1:n - r + 1].min(axis=-1)
            sm[r:] = np.lib.stride_tricks.sliding_window_view(mean, r - 1, axis=0)[1:n - r + 1].sum(axis=-1)
        ends = np.isfinite(_shift(margin, d, -np.inf))[:n - r] & finite[r:]
        ok[r:] = ends & (lo[r:] > -np.inf)
        if q is not None and max_dq is not None:
            ok[r:] &= _ramp_fits(q, d, r, f, max_dq, dt, max_ddq, max_dddq)
        ramp[d], low[d], inner[d] = ok, lo, sm
    return _Moves(hold, ramp, low, inner)


def _ramp_fits(q, d, r, f, max_dq, dt, max_ddq, max_dddq) -> np.ndarray:
    """Whether each ramp of ``r`` moves from angle ``k - d`` to ``k``, ending at location
    ``s = r .. n - 1``, keeps every joint move within ``max_dq`` and its redundancy motion within
    the acceleration and jerk limits, shape (n - r, m). The poses along a ramp are taken linear
    in θ between the grid's (the check; the plan solves them exactly)."""
    n, m, _ = q.shape
    qa = np.moveaxis(_shift(np.moveaxis(q, 2, 0), d, np.nan), 0, 2)        # q at k - d
    rows = np.arange(n - r)[:, None] + np.arange(r + 1)[None, :]              # (S, r + 1)
    a, b = qa[rows], q[rows]                                                  # (S, r + 1, m, J)
    delta = b - a
    pose = a + f[None, :, None, None] * delta
    with np.errstate(invalid="ignore"):
        move = np.max(np.abs(np.diff(pose, axis=1)), axis=3)                 # (S, r, m)
        ok = np.all(np.isfinite(move) & (move <= max_dq[rows[:, :r]][:, :, None]), axis=1)
    if dt is None or (max_ddq is None and max_dddq is None):
        return ok
    # the redundancy motion alone (the path's own accelerations are not the plan's to choose):
    # at rest before and after the ramp
    c = f[None, :, None, None] * delta
    t = dt[rows[:, :r]][:, :, None, None]
    v = np.diff(c, axis=1) / t                                                # (S, r, m, J)
    zero = np.zeros_like(v[:, :1])
    v = np.concatenate([zero, v, zero], axis=1)
    tm = np.concatenate([t[:, :1], 0.5 * (t[:, 1:] + t[:, :-1]), t[:, -1:]], axis=1)
    acc = np.diff(v, axis=1) / tm                                             # (S, r + 1, m, J)
    with np.errstate(invalid="ignore"):
        if max_ddq is not None:
            ok &= np.all(np.max(np.abs(acc), axis=3) <= max_ddq, axis=1)
        if max_dddq is not None:
            jerk = np.diff(acc, axis=1) / t
            ok &= np.all(np.max(np.abs(jerk), axis=3) <= max_dddq, axis=1)
    return ok


def _corner_turns(margin, q, corners, hold) -> dict:
    """The standing turns allowed at each corner location ``c``, keyed by the location after it:
    ``{c + 1: ok}``, ``ok[j, k]`` (bool, shape (m, m)) where the tool, arrived at ``c`` at angle
    ``j``, may turn to ``k != j`` and cut the move out at ``k`` (allowed there): every grid angle
    from ``j`` to ``k`` usable at ``c`` and neighbouring ones' joint commands within
    :data:`rmbench.path.corners.BRANCH_JUMP` (one continuous branch)."""
    from rmbench.path.corners import BRANCH_JUMP

    n, m = margin.shape
    c = np.unique(np.asarray(corners, int).ravel())
    if len(c) and (c[0] < 0 or c[-1] > n - 2):
        raise InputError(f"corner locations must lie in 0 .. {n - 2}, got {c[0]} .. {c[-1]}")
    out = {}
    for s in c:
        usable = np.isfinite(margin[s])
        link = usable[:-1] & usable[1:]
        if q is not None:
            with np.errstate(invalid="ignore"):
                step = np.max(np.abs(np.diff(q[s], axis=0)), axis=1)
            link &= np.isfinite(step) & (step <= BRANCH_JUMP)
        part = np.concatenate([[0], np.cumsum(~link)])        # which continuous stretch each angle is on
        ok = (part[:, None] == part[None, :]) & usable[:, None] & usable[None, :] & hold[s + 1][None, :]
        np.fill_diagonal(ok, False)
        out[int(s) + 1] = ok
    return out


def plan_schedule(margin, theta, *, q=None, max_step: int = 1, max_dq=None, step_cost: float = 1e-3,
                  ramp: int = 1, dt=None, max_ddq: float | None = None, max_dddq: float | None = None,
                  corners=None, max_rate: float | None = None, min_turn_gain: float = 0.05) -> Schedule:
    """The maximin schedule of the module docstring.

    Parameters
    ----------
    margin : array_like, shape (n, m)
        Margin per location and θ (larger is safer; ``-inf``: unusable).
    theta : array_like, shape (m,), rad
    q : array_like, shape (n, m, n_joint), rad, optional
        Joint commands per pose, for the joint limits.
    max_step : int
        Largest θ change of one ramp, in grid steps.
    max_dq : float or array_like of shape (n - 1,), optional
        Largest joint move between neighbouring locations, rad, one for all moves or one per move
        (the joint rate times each move's time; needs ``q``).
    step_cost : float
        Cost of one θ grid step in the second pass, in units of the margin's spread (a tie-breaker).
    ramp : int
        Moves a θ change is spread over (1: from one location to the next).
    dt : float or array_like of shape (n - 1,), optional
        Each move's time, s (for the acceleration and jerk limits).
    max_ddq, max_dddq : float, optional
        Largest joint acceleration (rad/s²) and jerk (rad/s³) of a ramp's redundancy motion (needs
        ``q``, ``max_dq`` and ``dt``).
    corners : array_like of int, optional
        Locations (0 .. n - 2) at which θ may also turn by any number of grid steps while the tool
        stands (the module docstring); None: ramps only (and the schedule's ``corners`` None).
    max_rate : float, optional
        Largest joint speed of a standing turn, rad/s: with ``q``, ``max_ddq`` and ``max_dddq`` it
        times each turn's dwell, the second pass's first criterion (else the grid steps turned).
    min_turn_gain : float
        The least relative rise of the bottleneck over the ramps-only schedule's that standing
        turns must buy, else none is taken (default 5 %): a standing tool rubs the wall it has
        cut, and a rise smaller than the critical depth's own few-percent error buys nothing real.

    Returns
    -------
    Schedule
        ``feasible`` False where no schedule keeps every pose usable (the bottleneck is -inf).
    """
    margin, theta = _check(margin, theta, q)
    q = None if q is None else np.asarray(q, float)
    n = margin.shape[0]
    if int(ramp) != ramp or ramp < 1:
        raise InputError(f"a ramp takes a whole number of moves >= 1, got {ramp!r}")
    if not min_turn_gain >= 0:
        raise InputError(f"min_turn_gain must be a fraction >= 0, got {min_turn_gain!r}")
    r = int(ramp)
    max_dq = _per_move(max_dq, n)
    dt = None if dt is None else _per_move(dt, n)
    mv = _moves(margin, q, max(int(max_step), 0), max_dq, r, dt, max_ddq, max_dddq)
    turns = None if corners is None else _corner_turns(margin, q, corners, mv.hold)
    bottleneck = _bottleneck(margin, mv, r, turns)
    if turns:
        plain = _bottleneck(margin, mv, r)
        if np.isfinite(plain) and bottleneck < plain + min_turn_gain * abs(plain):
            turns, bottleneck = {}, plain
    if not np.isfinite(bottleneck):
        return _fallback(margin, theta)
    dwell = None if turns is None else _turn_dwell(q, turns, (max_rate, max_ddq, max_dddq))
    w, back, src, p = _best_sum(margin, mv, r, bottleneck, step_cost, turns, dwell)
    idx, to, frac, used = _trace_back(w, back, r, src, p)
    th = theta[idx] + frac * (theta[to] - theta[idx])
    rows = np.arange(n)
    got = np.where(frac > 0, margin[rows, idx] + frac * (margin[rows, to] - margin[rows, idx]), margin[rows, idx])
    ramps = bool(np.any(frac > 0))
    return Schedule(idx, th, got, True, "planned", to if ramps else None, frac if ramps else None,
                    corners=None if corners is None else used)


def _bottleneck(margin: np.ndarray, mv: _Moves, r: int, turns: dict | None = None) -> float:
    """Pass 1: the largest smallest margin any schedule of allowed holds, ramps of ``r`` moves and
    standing turns (``turns``, :func:`_corner_turns`) keeps along the path (-inf: none keeps every
    pose usable)."""
    n, m = margin.shape
    v = np.full((n, m), -np.inf)
    v[0] = margin[0]
    for s in range(1, n):
        best = np.where(mv.hold[s], v[s - 1], -np.inf)
        if s >= r:
            for d, ok in mv.ramp.items():
                came = np.minimum(_shift(v[s - r], d, -np.inf), mv.low[d][s])
                best = np.maximum(best, np.where(ok[s], came, -np.inf))
        if turns and s in turns:
            # arrived at the corner s - 1 at j (its margin there counted), turned standing to k
            best = np.maximum(best, np.max(np.where(turns[s], v[s - 1][:, None], -np.inf), axis=0))
        v[s] = np.minimum(margin[s], best)
    return float(np.max(v[-1]))


def _turn_dwell(q, turns: dict, limits) -> dict:
    """Each standing turn's cost in the second pass, keyed as ``turns``: ``cost[j, k]`` the dwell
    of the turn from ``j`` to ``k`` at the corner, s (its largest joint move between the grid's
    commands, rest to rest at ``limits`` = (rate rad/s, acceleration rad/s², jerk rad/s³)), or
    the grid steps ``|k - j|`` where the joint commands or a limit are not given."""
    from rmbench.path.corners import dwell_time

    out = {}
    for s, ok in turns.items():
        m = ok.shape[0]
        if q is None or any(v is None for v in limits):
            out[s] = np.abs(np.arange(m)[None, :] - np.arange(m)[:, None]).astype(float)
            continue
        qc = q[s - 1]
        with np.errstate(invalid="ignore"):
            move = np.max(np.abs(qc[None, :, :] - qc[:, None, :]), axis=2)
        out[s] = dwell_time(np.nan_to_num(move, nan=0.0), *limits)
    return out


#: dwell totals closer than this are equal in the second pass's first criterion, s
_DWELL_TIE = 1e-9


def _better(cw, cp, bw, bp) -> np.ndarray:
    """Where candidate (summed value ``cw``, dwell ``cp``) beats the best so far (``bw``, ``bp``):
    by the value alone without dwells (``bp`` None), else the least dwell first."""
    if bp is None:
        return cw > bw
    cp = np.where(np.isfinite(cw), cp, np.inf)
    return (cp < bp - _DWELL_TIE) | ((cp <= bp + _DWELL_TIE) & (cw > bw))


def _best_sum(margin: np.ndarray, mv: _Moves, r: int, bottleneck: float, step_cost: float,
              turns: dict | None = None, dwell: dict | None = None):
    """Pass 2: over the schedules that keep at least ``bottleneck``, the largest summed margin
    (in units of its spread) less ``step_cost`` per θ step (standing turns' too); with standing
    ``turns`` first the least total ``dwell`` (:func:`_turn_dwell`), then that sum.

    Returns the best value ending at each (location, angle), shape (n, m), how each was reached,
    int shape (n, m): 0 held from the location before (or turned standing), ``d`` a ramp of ``d``
    steps that ended there, the angle a standing turn came from, int shape (n, m) (-1: none), and
    the dwell so far, shape (n, m), s (inf: unreachable; None without turns)."""
    n, m = margin.shape
    finite = margin[np.isfinite(margin)]
    scale = float(np.ptp(finite)) or 1.0
    floor = bottleneck - 1e-12 * max(abs(bottleneck), 1.0)
    gain = np.where(margin >= floor, margin / scale, -np.inf)
    w = np.full((n, m), -np.inf)
    w[0] = gain[0]
    p = None if not turns else np.full((n, m), np.inf)
    if p is not None:
        p[0] = np.where(np.isfinite(w[0]), 0.0, np.inf)
    back = np.zeros((n, m), int)
    src = np.full((n, m), -1)
    for s in range(1, n):
        best = np.where(mv.hold[s], w[s - 1], -np.inf)
        bp = None if p is None else np.where(mv.hold[s], p[s - 1], np.inf)
        came_by = np.zeros(m, int)
        if s >= r:
            for d, ok in mv.ramp.items():
                usable = ok[s] & (mv.low[d][s] >= floor)
                cand = np.where(usable, _shift(w[s - r], d, -np.inf) + mv.inner[d][s] / scale - step_cost * abs(d),
                                -np.inf)
                cp = None if p is None else _shift(p[s - r], d, np.inf)
                better = _better(cand, cp, best, bp)
                best = np.where(better, cand, best)
                bp = None if p is None else np.where(better, cp, bp)
                came_by = np.where(better, d, came_by)
        if turns and s in turns:
            k = np.arange(m)
            cand = np.where(turns[s], w[s - 1][:, None] - step_cost * np.abs(k[None, :] - k[:, None]), -np.inf)
            cp = np.where(np.isfinite(cand), p[s - 1][:, None] + dwell[s], np.inf)
            # per angle turned to, the least dwell and, among those, the largest value
            j = np.argmax(np.where(cp <= cp.min(axis=0) + _DWELL_TIE, cand, -np.inf), axis=0)
            better = _better(cand[j, k], cp[j, k], best, bp)
            best = np.where(better, cand[j, k], best)
            bp = np.where(better, cp[j, k], bp)
            came_by = np.where(better, 0, came_by)
            src[s] = np.where(better, j, -1)
        back[s] = came_by
        w[s] = gain[s] + best
        if p is not None:
            p[s] = np.where(np.isfinite(w[s]), bp, np.inf)
    return w, back, src, p


def _trace_back(w: np.ndarray, back: np.ndarray, r: int, src: np.ndarray, p: np.ndarray | None = None):
    """The best schedule of :func:`_best_sum` from its last location back (ending where the dwell
    ``p`` is least, then ``w`` largest): per location the grid index it leaves, the one a ramp
    runs to (elsewhere the same) and how far along its ramp it lies (the cycloidal profile; 0 off
    ramps), each shape (n,), and the locations it turns at standing (``src``), int shape (u,),
    increasing."""
    n = len(w)
    idx, to, frac = np.empty(n, int), np.empty(n, int), np.zeros(n)
    last = w[-1] if p is None else np.where(p[-1] <= np.min(p[-1]) + _DWELL_TIE, w[-1], -np.inf)
    s, k = n - 1, int(np.argmax(last))
    idx[s], to[s] = k, k
    f = ramp_profile(r)
    used = []
    while s > 0:
        if src[s, k] >= 0:
            used.append(s - 1)
            s, k = s - 1, int(src[s, k])
            idx[s], to[s] = k, k
            continue
        d = int(back[s, k])
        if d == 0:
            s -= 1
            idx[s], to[s] = k, k
            continue
        j = k - d
        idx[s - r + 1:s], to[s - r + 1:s], frac[s - r + 1:s] = j, k, f[1:r]
        s -= r
        k = j
        idx[s], to[s] = k, k
    return idx, to, frac, np.asarray(used[::-1], int)


def _fallback(margin, theta) -> Schedule:
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


def best_fixed_schedule(margin, theta, *, q=None, max_dq=None) -> Schedule:
    """θ held at the best fixed angle: the grid angle whose smallest margin along the path is the
    largest, among the angles that can be held (every pose usable and every joint move within
    ``max_dq``, rad, as :func:`fixed_schedule` checks them; where none can, among all, flagged
    infeasible). Ties go to the lowest angle.

    A plan under the same joint limits may hold any of these angles, so it keeps at least this
    margin: the gain over it is what changing θ along the path buys, where the gain over one
    given angle also counts what choosing the angle once buys.

    Parameters
    ----------
    margin : array_like, shape (n, m)
    theta : array_like, shape (m,), rad
    q : array_like, shape (n, m, n_joint), rad, optional
    max_dq : float or array_like of shape (n - 1,), optional
        Largest joint move between neighbouring locations, rad (needs ``q``).
    """
    margin, theta = _check(margin, theta, q)
    every = [fixed_schedule(margin, theta, t, q=q, max_dq=max_dq) for t in theta]
    pool = [s for s in every if s.feasible] or every
    return replace(max(pool, key=lambda s: s.min_margin), kind="best fixed")


def pointwise_schedule(margin, theta) -> Schedule:
    """Each location's best θ, moves unchecked (an upper bound no smooth schedule can beat)."""
    margin, theta = _check(margin, theta, None)
    idx = np.argmax(margin, axis=1)
    got = margin[np.arange(len(idx)), idx]
    return Schedule(idx, theta[idx], got, bool(np.all(np.isfinite(got))), "pointwise")
