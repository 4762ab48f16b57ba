"""Virtual milling along a planned path: does the cut chatter where the plan says it will?

At locations sampled along a schedule the simulator mills at the depth to be cut
(:func:`rmbench.stability.milling.mill`: every mode of the MuJoCo model, the regenerative force in
the time domain) with the robot moving along the path: its servos follow the schedule's joint
commands at the path's feed through the cutter locations around the sampled one (a cut of
``periods`` tooth periods covers ``feed × duration`` of path, centred on it where the path allows),
with the deflected equilibria of those locations as the reference the vibration is measured from
(less what the same motion does with no cut). A moving cut stays on the smooth stretch of path it
lies on (shifted along it where the location is near a sharp corner): a verdict is about steady
cutting, and a machine turning a sharp corner at full feed would strike the arm, a transient no
chatter test should read. Where the stretch is shorter than a cut (a raster's stepover) the cut
holds the posture, and is counted so (``moved``). ``moving=False`` holds every sampled posture
instead (in the fraction of a second a verdict takes the arm moves millimetres, where its modes
change over hundreds: the two agree on straight passes); only the moving robot shows what the
schedule's θ changes do to the cut.

A location is *decided* when the depth lies more than ``band`` (10 %) from the plan's predicted
critical depth there: the plan then says "stable" or "chatter", and the cut agrees or not. The
locations inside the band are counted, not scored. The exact model's critical depth at each pose
(zero-order method, the impact bands' modes) comes alongside, to tell a prediction's error from
the zero-order method's.

A plan whose feed runs along the path (``PlanSettings.feed == "path"``) is milled so: each cut
feeds along the path's own direction (:meth:`rmbench.io.ToolPath.heading`), the moving cut's heading
following the locations it runs through (:class:`rmbench.stability.milling.Motion`'s ``heading``),
as the plan's critical depths turned the modes to it. A plan fed along base X is milled along base
X, as every plan before headings.

A schedule that turns θ standing at corners (``PlanSettings.reorient == "corners"``,
:attr:`rmbench.path.plan.Schedule.corners`) is milled as the machine runs it: the feed stops at
each such corner, so no moving cut runs through one (:func:`cut_stretch`): the cut before it ends
there at the angle it arrives at, the one after starts there at the angle the turn ends at.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError
from rmbench.path.margin import ALL_MODES, N_FREQ, _all_tip_modes, _freq
from rmbench.stability.cutting import Cutting
from rmbench.stability.frame import to_cut_frame
from rmbench.stability.milling import Motion, mill
from rmbench.stability.zoa import zoa_limit

__all__ = ["PathMilling", "mill_schedule", "sample_locations", "smooth_stretch", "cut_window", "cut_stretch"]


@dataclass(frozen=True)
class PathMilling:
    """Cuts milled along one schedule of a plan.

    Attributes
    ----------
    schedule : str
        ``planned``, ``fixed`` or ``pointwise``.
    index : ndarray of int, shape (k,)
        Cutter locations milled.
    theta : ndarray, shape (k,), rad
    depth : float
        Axial depth cut, m.
    speed_rpm : float
    predicted : ndarray, shape (k,), m
        The plan's critical depth at each pose.
    exact : ndarray, shape (k,), m
        The exact model's (zero-order method; the bands' modes, or every mode below the plan's
        ``f_max`` where it saw them all, ``PathPlan.exact_modes``; in the cut's frame where the
        feed runs along the path).
    chatter : ndarray of bool, shape (k,)
    kind : tuple of str
        The milling verdict per cut (``stable``, ``hopf``, ``flip``, ``runaway``).
    band : float
        Relative half-width around the predicted depth inside which a cut is not scored.
    amplitude : ndarray, shape (k,), m, or None
        Peak-to-peak tool-tip vibration over each cut's last third.
    moving : bool
        The cuts were asked to move along the path (else each held its sampled posture).
    moved : ndarray of bool, shape (k,), or None
        Which cuts moved (a cut on a smooth stretch shorter than itself holds its posture).
    heading : ndarray, shape (k,), rad, or None
        The feed direction at each milled location in the base XY plane (a plan fed along the
        path); None: every cut fed along base X.
    """

    schedule: str
    index: np.ndarray
    theta: np.ndarray
    depth: float
    speed_rpm: float
    predicted: np.ndarray
    exact: np.ndarray
    chatter: np.ndarray
    kind: tuple
    band: float = 0.1
    amplitude: np.ndarray | None = None
    moving: bool = False
    moved: np.ndarray | None = None
    heading: np.ndarray | None = None

    @property
    def decided(self) -> np.ndarray:
        """Cuts whose depth lies outside ±``band`` of the predicted critical depth, shape (k,)."""
        return np.abs(self.depth / self.predicted - 1) > self.band

    @property
    def expected(self) -> np.ndarray:
        """Whether the plan expects chatter (depth above its critical depth), shape (k,)."""
        return self.depth > self.predicted

    @property
    def agreement(self) -> float | None:
        """Share of decided cuts whose verdict is the plan's (None: none decided)."""
        d = self.decided
        return float(np.mean(self.chatter[d] == self.expected[d])) if d.any() else None

    def summary(self) -> dict:
        """The cuts' tally as plain JSON types: the schedule, the number of cuts, the depth
        (``depth_mm``, mm) and speed (``speed_rpm``, rev/min), whether the cuts were asked to move
        and how many held their posture, how many were decided and how many fell inside the band,
        the share of decided cuts agreeing with the plan (``agreement``) and with the exact model's
        critical depth (``exact_agreement``; both None when none was decided, dimensionless
        otherwise), and the counts of cuts that chattered and that the plan expected to."""
        d = self.decided
        return {"schedule": self.schedule, "cuts": len(self.index), "depth_mm": 1e3 * self.depth,
                "speed_rpm": self.speed_rpm, "moving": self.moving,
                "held_cuts": int(len(self.index) - (0 if self.moved is None else np.sum(self.moved))),
                "decided": int(d.sum()), "inside_band": int((~d).sum()),
                "agreement": self.agreement, "chatter": int(self.chatter.sum()),
                "expected_chatter": int(self.expected.sum()),
                "exact_agreement": (float(np.mean(self.chatter[d] == (self.depth > self.exact[d])))
                                    if d.any() else None)}


def sample_locations(n_locations: int, n: int) -> np.ndarray:
    """``n`` cutter locations evenly spaced along a path of ``n_locations`` (its ends included)."""
    if n < 1:
        raise InputError(f"at least one location must be milled, got {n}")
    return np.unique(np.linspace(0, n_locations - 1, min(n, n_locations)).round().astype(int))


def _exact_limit(op, cutting: Cutting, speed_rpm: float, bands, heading: float | None = None,
                 f_max: float | None = None) -> float:
    """The exact model's critical depth at a pose, m: the lowest of its bands', or with ``f_max``
    (Hz) that of every mode below it in one receptance (:func:`rmbench.path.margin.exact_modes`'s
    ``"all"``); the modes turned into the cut's frame where the feed runs along ``heading``
    (rad; None: base X), as the plan's depths were."""
    if f_max is not None:
        tables = [_all_tip_modes(op, f_max)]
    else:
        tables = [(t.poles, t.phi_r[:, :2, None] * t.phi_l[:, None, :2]) for t in map(op.modes, bands)]
    per = []
    for p, r in tables:
        poles, res = np.asarray(p)[None], np.asarray(r)[None]
        if heading is not None:
            res = to_cut_frame(res, np.array([heading]))
        per.append(float(zoa_limit(poles, res, cutting, speed_rpm, _freq(poles, N_FREQ))[0]))
    return min(per)


def smooth_stretch(xy: np.ndarray, k: int, tol: float = np.radians(20.0), cutting=None) -> tuple[int, int]:
    """The smooth stretch of cutting path through a cutter location: where a moving cut may run.

    Consecutive cutting moves turning by less than ``tol`` each form a stretch: an arc of a few
    of the spacings' radius continues it; a raster's right-angle corner, a rapid or a plunge (a
    move of no length in the plane) ends it. Where ``k`` is a corner, the longer of its two.

    Parameters
    ----------
    xy : ndarray, shape (n, 2), m
        Cutter locations in the workpiece plane (``ToolPath.xy``).
    k : int
        The location, 0 to n − 1.
    tol : float
        Largest turn between consecutive moves, rad.
    cutting : ndarray of bool, shape (n,), optional
        Whether the move to each location cuts (``ToolPath.cutting``; default: every move).

    Returns
    -------
    (int, int)
        The stretch's first and last location; ``(k, k)`` where no cutting move touches ``k``.
    """
    d = np.diff(xy, axis=0)
    length = np.hypot(d[:, 0], d[:, 1])
    if cutting is not None:
        length = np.where(np.asarray(cutting, bool)[1:], length, 0.0)      # a rapid is no cut
    ang = np.arctan2(d[:, 1], d[:, 0])

    def smooth(i, j):
        return length[i] > 1e-9 and length[j] > 1e-9 and abs(np.angle(np.exp(1j * (ang[i] - ang[j])))) < tol

    best = (k, k)
    for j in (k - 1, k):
        if not 0 <= j < len(ang) or length[j] <= 1e-9:
            continue
        a, b = j, j
        while a > 0 and smooth(a - 1, a):
            a -= 1
        while b < len(ang) - 1 and smooth(b + 1, b):
            b += 1
        if length[a:b + 1].sum() > length[best[0]:best[1]].sum():
            best = (a, b + 1)
    return best


def cut_window(arc: np.ndarray, k: int, travel: float, stretch: tuple[int, int]) -> tuple[float, int, int] | None:
    """The stretch of path a moving cut around a cutter location covers.

    Centred on location ``k``, shifted along its smooth ``stretch`` (:func:`smooth_stretch`) near
    the stretch's ends, so that the cut never turns a corner.

    Parameters
    ----------
    arc : ndarray, shape (n,), m
        Arc length at each cutter location, increasing (``ToolPath.arc_length()``).
    k : int
        The location the cut is about.
    travel : float
        Path the cut covers, m (feed × the cut's duration).
    stretch : (int, int)
        First and last location of the smooth stretch through ``k``.

    Returns
    -------
    (float, int, int) or None
        ``(start, a, b)``: the arc length where the cut starts, m, and the first and last cutter
        location of the motion (those at or beyond the cut's ends, so that the motion spans it);
        None where the stretch is shorter than the cut (the cut then holds its posture).
    """
    s0, s1 = stretch
    if arc[s1] - arc[s0] < travel:
        return None
    start = min(max(arc[k] - travel / 2, arc[s0]), arc[s1] - travel)
    a = max(int(np.searchsorted(arc, start, side="right")) - 1, s0)
    b = min(int(np.searchsorted(arc, start + travel, side="left")), s1)
    return float(start), a, max(b, a + 1)


def cut_stretch(tp, k: int, corners=None) -> tuple[int, int]:
    """Where a moving cut about cutter location ``k`` of ``tp`` (a ToolPath) may run: its smooth
    stretch (:func:`smooth_stretch`) ended at the corners where the tool stands (``corners``,
    location indices; None or empty: unchanged). A corner's own location belongs to the cut into
    it (the stretch through the location before); the cut out of it starts there."""
    c = np.zeros(0, int) if corners is None else np.asarray(corners, int)
    s0, s1 = smooth_stretch(tp.xy, k - 1 if k in c and k > 0 else k, cutting=tp.cutting)
    if len(c[c < k]):
        s0 = max(s0, int(c[c < k].max()))
    if len(c[c >= k]):
        s1 = min(s1, int(c[c >= k].min()))
    return s0, s1


def mill_schedule(robot, plan, *, depth: float, schedule: str = "planned", cutting: Cutting | None = None,
                  locations=None, n: int = 40, periods: int = 90, band: float = 0.1,
                  bands=("low", "high"), moving: bool = True, feed: float = 0.05,
                  progress=None) -> PathMilling:
    """Mill at sampled locations of one of a plan's schedules.

    A plan fed along the path (``plan.feed == "path"``) is milled with each cut's feed along the
    path's direction there (module notes); ``PathMilling.heading`` records it. A schedule with
    standing turns is cut between its corners, never through one (:func:`cut_stretch`).

    Parameters
    ----------
    robot : rmbench.robot.Robot
        The robot (and tool) the plan was made for, or a "real" one to check the plan against.
    plan : PathPlan
    depth : float
        Axial depth of cut, m.
    schedule : str
        ``planned``, ``fixed`` or ``pointwise``.
    cutting : Cutting, optional
        Default: the plan's (``plan.cutting``; aluminium 6061 slot where it has none).
    locations : array_like of int, optional
        Cutter locations to mill (default: ``n`` evenly spaced, :func:`sample_locations`).
    periods : int
        Tooth periods per cut (:func:`rmbench.stability.milling.mill`).
    band : float
        Cuts within this relative distance of the predicted critical depth are not scored.
    moving : bool
        Move the robot along the path during each cut (the default; module notes); False: hold
        each sampled posture.
    feed : float
        Feed, m/s, where the path programs none (the planner's default).
    progress : callable, optional
        Called with each finished cut's position (0-based).
    """
    from rmbench.stability.cutting import ALUMINIUM_6061

    _check_cut(schedule, feed, depth)
    cutting = getattr(plan, "cutting", ALUMINIUM_6061) if cutting is None else cutting
    s = getattr(plan, schedule)
    idx = (sample_locations(len(s.index), n) if locations is None
           else np.asarray(locations, int))
    if np.any((idx < 0) | (idx >= len(s.index))):
        raise InputError(f"cutter locations must lie in 0-{len(s.index) - 1}")
    joints = s.joints(plan.reach.q)
    stand = (s.corners, s.departure(plan.reach.q)) if getattr(s, "corners", None) is not None else None
    q = joints[idx]
    predicted = s.on(plan.depths.a_lim)[idx]
    exact, chatter, kind, amplitude = np.empty(len(idx)), np.empty(len(idx), bool), [], np.empty(len(idx))
    moved = np.zeros(len(idx), bool)
    tp = plan.toolpath
    arc = tp.arc_length()
    speed = np.where(np.isfinite(tp.feed), tp.feed, feed)
    duration = periods * 60.0 / (cutting.teeth * plan.speed_rpm)
    # the cut's feed direction at every location: the path's own where the plan fed along it
    heading = tp.heading() if getattr(plan, "feed", "x") == "path" else None
    fed = None if heading is None else np.empty(len(idx))
    f_max = getattr(plan, "f_max", None) if getattr(plan, "exact_modes", "bands") == ALL_MODES else None
    for k in range(len(idx)):
        op = robot.at(q[k])
        loc = int(idx[k])
        exact[k] = _exact_limit(op, cutting, plan.speed_rpm, bands, None if heading is None else float(heading[loc]),
                                f_max)
        motion, first = (_moving_cut(robot, op, loc, joints, tp, arc, speed[loc], duration, heading, stand) if moving
                         else (None, op))
        moved[k] = motion is not None
        if fed is not None:     # a held cut feeds along its location's heading, a moving one along the motion's
            fed[k] = heading[loc] if motion is None else np.angle(np.exp(1j * motion.headings([duration / 2])[0]))
        run = mill(first, cutting, plan.speed_rpm, depth, periods=periods, motion=motion,
                   heading=0.0 if fed is None or motion is not None else float(fed[k]))
        chatter[k], amplitude[k] = run.chatter, run.amplitude
        kind.append(run.kind)
        if progress is not None:
            progress(k)
    return PathMilling(schedule, idx, s.theta[idx], float(depth), plan.speed_rpm, predicted, exact, chatter,
                       tuple(kind), float(band), amplitude, bool(moving), moved, fed)


def _check_cut(schedule: str, feed: float, depth: float) -> None:
    """:func:`mill_schedule`'s schedule name, feed (m/s) and depth (m), else one-line InputError."""
    if schedule not in ("planned", "fixed", "pointwise"):
        raise InputError(f"unknown schedule {schedule!r}; use planned, fixed or pointwise")
    if not feed > 0:
        raise InputError(f"the feed must be > 0 m/s, got {feed!r}")
    if not depth > 0:
        raise InputError(f"the depth of cut must be > 0 mm, got {1e3 * depth!r}")


def _moving_cut(robot, op, loc: int, joints: np.ndarray, tp, arc: np.ndarray, speed: float, duration: float,
                heading, stand=None) -> tuple:
    """The motion of a cut about cutter location ``loc`` along its smooth stretch and the operating
    point nearest its start: ``(Motion, op)``, or ``(None, op)`` where the stretch is shorter than
    the cut (it then holds ``op``, the location's own). ``speed`` is the feed there, m/s,
    ``duration`` the cut's, s; ``heading`` (rad, shape (n,): ``ToolPath.heading``, or None for a
    feed along base X) gives the motion's feed direction at each of its locations. ``stand``: the
    schedule's standing corners and its joint commands on leaving each location
    (:meth:`rmbench.path.plan.Schedule.departure`; None: no standing turns): the cut stays between
    the corners, and one starting at a corner starts at the angle the turn there ends at."""
    corners, depart = (None, joints) if stand is None else stand
    window = cut_window(arc, loc, speed * duration, cut_stretch(tp, loc, corners))
    if window is None:
        return None, op
    start, a, b = window
    ops = [op if j == loc else robot.at(depart[j] if j == a else joints[j]) for j in range(a, b + 1)]
    knots = None
    if heading is not None:
        # a location's heading is that of the move into it: the motion leaves its first location
        # along the move to the next, inside the stretch (the move into it may be the corner's other side)
        knots = heading[a:b + 1].copy()
        knots[0] = knots[1]
    # the clock starts with the cut, between locations a and a + 1
    motion = Motion.through(ops, (arc[a:b + 1] - start) / speed, knots)
    return motion, ops[int(np.argmin(np.abs(arc[a:b + 1] - start)))]
