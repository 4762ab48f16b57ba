"""A tool path planned end to end: reach, critical depths from a predictor, the θ schedule.

::

    from rmbench.path import example, plan_path
    plan = plan_path(robot, predictor, example("pocket"), speed_rpm=15000, depth=3e-3)
    plan.planned.min_margin, plan.fixed.min_margin, plan.gain   # critical depths, m; ratio
    plan.gain_best_fixed                                         # over the best fixed angle
    plan.to_csv("plan.csv")

At low speed, in steel, with the feed along the path's own direction (issue 82)::

    plan = plan_path(robot, predictor, example("contour"), speed_rpm="low", cutting=CUTTINGS["steel"],
                     settings=PlanSettings(feed="path"))

and θ turned while the tool stands at the corners (:mod:`rmbench.path.corners`; the dwell is the
cost)::

    plan = plan_path(..., settings=PlanSettings(feed="path", reorient="corners"))
    plan.reorientation.used, plan.reorientation.dwell     # corner locations, s

The critical depth is evaluated every ``eval_spacing`` of arc length and interpolated linearly
between (the predictor's length scales are hundreds of millimetres; the cutter locations a few
apart), so a 2,000-location pocket costs a few hundred predictions per angle.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rmbench.errors import InputError
from rmbench.io.toolpath import ToolPath
from rmbench.path.corners import REORIENTS, Reorientation, corner_dwell, find_corners
from rmbench.path.margin import ALL_MODES, DepthBand, DepthGrid, depth_band, exact_modes, predicted_modes
from rmbench.path.plan import Schedule, best_fixed_schedule, fixed_schedule, plan_schedule, pointwise_schedule
from rmbench.path.ramps import ramp_moves, solve_ramps
from rmbench.path.reach import Reach, reach_grid
from rmbench.path.settings import CUTTINGS, EXACT_MODES, FEEDS, RANGE_SPEEDS, SPEED_BY, PlanSettings
from rmbench.stability.cutting import ALUMINIUM_6061, Cutting
from rmbench.stability.grids import SPEED_RANGES, speed_grid

__all__ = ["PathPlan", "plan_path", "PlanSettings", "with_band", "CUTTINGS", "FEEDS", "RANGE_SPEEDS", "REORIENTS",
           "EXACT_MODES", "SPEED_BY"]

@dataclass(frozen=True)
class PathPlan:
    """A planned path and its comparisons.

    Attributes
    ----------
    toolpath : ToolPath
        The resampled cutter locations.
    reach : Reach
    depths : DepthGrid
        Predicted critical depths at every location and angle (interpolated between evaluations).
    planned, fixed, pointwise : Schedule
    depth : float
        The axial depth to be cut, m (None: not given).
    speed_rpm : float
    seconds : dict
    hull_distance : ndarray, shape (n,), or None
        How far each planned pose lies outside the predictor's training postures (their standard
        deviations; :meth:`rmbench.predict.PosturePredictor.hull_distance`).
    band : DepthBand or None
        The planned schedule's critical depth with its band at every location (:func:`with_band`;
        interpolated between the evaluated locations), None until computed.
    band_level : float
        The band's central probability.
    speed_scan : dict or None
        Where several speeds were planned: ``speeds_rpm`` and each one's planned smallest critical
        depth ``min_alim`` (m); ``speed_rpm`` is the best of them.
    best_fixed : Schedule or None
        θ held at the best fixed angle at the plan's speed (:func:`rmbench.path.plan.best_fixed_schedule`);
        None in a plan saved before it was kept.
    cutting : Cutting
        The cut the critical depths are of.
    feed : str
        Where the feed runs in that cut (:data:`FEEDS`).
    reorientation : Reorientation or None
        With ``PlanSettings.reorient = "corners"``: the corners found, those the plan turned θ at
        standing, and each one's dwell, s; None: ramps only.
    exact_modes : str
        The modes the exact model sees (``PlanSettings.exact_modes``): in the depths of a plan
        without predictor, and in the milling reference of any plan (:func:`rmbench.path.mill_schedule`).
    f_max : float
        The highest mode frequency ``exact_modes="all"`` keeps, Hz.
    """

    toolpath: ToolPath
    reach: Reach
    depths: DepthGrid
    planned: Schedule
    fixed: Schedule
    pointwise: Schedule
    depth: float | None
    speed_rpm: float
    seconds: dict
    hull_distance: np.ndarray | None = None
    band: DepthBand | None = None
    band_level: float = 0.95
    speed_scan: dict | None = None
    best_fixed: Schedule | None = None
    cutting: Cutting = ALUMINIUM_6061
    feed: str = "x"
    reorientation: Reorientation | None = None
    exact_modes: str = "bands"
    f_max: float = 8000.0

    @property
    def gain(self) -> float:
        """The planned schedule's smallest critical depth over the fixed-θ schedule's."""
        f = self.fixed.min_margin
        return float(self.planned.min_margin / f) if f > 0 else float("inf")

    @property
    def gain_best_fixed(self) -> float:
        """The planned schedule's smallest critical depth over the best fixed angle's (at least 1
        where the plan is feasible: it may hold that angle throughout); NaN where not kept."""
        if self.best_fixed is None:
            return float("nan")
        f = self.best_fixed.min_margin
        return float(self.planned.min_margin / f) if f > 0 else float("inf")

    def at_risk(self, schedule: Schedule | None = None) -> np.ndarray:
        """Indices of the locations whose critical depth along ``schedule`` (default: the plan)
        lies below the depth cut."""
        s = self.planned if schedule is None else schedule
        return np.flatnonzero(s.margin < self.depth) if self.depth is not None else np.zeros(0, int)

    def joint_trajectory(self, schedule: Schedule | None = None) -> np.ndarray:
        """Joint commands along ``schedule`` (default: the plan), rad, shape (n, n_joint)."""
        s = self.planned if schedule is None else schedule
        return s.joints(self.reach.q)

    def joint_motion(self, schedule: Schedule | None = None, *, feed: float = 0.05,
                     turn: float = np.radians(5.0)) -> dict:
        """The largest joint speed (rad/s) over ``schedule``'s cutting moves at the path's feed
        (``feed`` m/s where it programs none), and the largest acceleration (rad/s²) and jerk
        (rad/s³) on its smooth stretches (neighbouring moves turning by less than ``turn``: at a
        corner the path itself changes the joints' velocity at once, whatever θ does); finite
        differences of :meth:`joint_trajectory`, each move starting at the pose it leaves from (a
        standing turn at a corner, :attr:`Schedule.corners`, is the dwell's, not a move's)."""
        s = self.planned if schedule is None else schedule
        q = self.joint_trajectory(s)
        qd = s.departure(self.reach.q)
        tp = self.toolpath
        f = np.where(np.isfinite(tp.feed), tp.feed, feed)
        step = np.diff(tp.xy, axis=0)
        dt = np.hypot(step[:, 0], step[:, 1]) / f[1:]
        cut = tp.cutting[1:] & (dt > 0)
        t = np.where(cut, dt, 1.0)
        v = (q[1:] - qd[:-1]) / t[:, None]
        heading = np.arctan2(step[:, 1], step[:, 0])
        smooth = cut[1:] & cut[:-1] & (np.abs(np.angle(np.exp(1j * np.diff(heading)))) < turn)
        if s.corners is not None and len(s.corners):
            c = np.asarray(s.corners, int)
            smooth[c[c >= 1] - 1] = False       # the feed stops there
        tm = 0.5 * (t[1:] + t[:-1])
        acc = np.diff(v, axis=0) / tm[:, None]
        jerk = np.diff(acc, axis=0) / t[1:-1, None]

        def peak(a, ok):
            return float(np.max(np.abs(a[ok]))) if ok.any() else 0.0

        return {"rate": peak(v, cut), "accel": peak(acc, smooth), "jerk": peak(jerk, smooth[1:] & smooth[:-1])}

    def to_dict(self) -> dict:
        """The plan's figures as strict JSON types (mm and degrees, as the command line prints
        them; a non-finite depth or gain is null)."""
        from rmbench.io.strict_json import jsonable

        out = {"cl_points": len(self.toolpath), "speed_rpm": self.speed_rpm,
               "depth_mm": None if self.depth is None else 1e3 * self.depth,
               "unreachable": [int(i) for i in self.reach.unreachable()],
               "outside_hull": int(np.sum(self.depths.outside_hull[np.arange(len(self.planned.index)),
                                                                   self.planned.index])),
               "hull_distance_max": None if self.hull_distance is None else float(np.max(self.hull_distance)),
               "min_alim_mm": {k: 1e3 * s.min_margin for k, s in
                               (("planned", self.planned), ("fixed", self.fixed), ("pointwise", self.pointwise))},
               "feasible": {k: s.feasible for k, s in
                            (("planned", self.planned), ("fixed", self.fixed), ("pointwise", self.pointwise))},
               "min_alim_gain": self.gain,
               "min_alim_gain_best_fixed": self.gain_best_fixed,
               "best_fixed": None if self.best_fixed is None else {
                   "theta_deg": float(np.degrees(self.best_fixed.theta[0])),
                   "min_alim_mm": 1e3 * self.best_fixed.min_margin, "feasible": self.best_fixed.feasible},
               "cutting": {"k_t_n_mm2": 1e-6 * self.cutting.k_t, "k_n_n_mm2": 1e-6 * self.cutting.k_n,
                           "teeth": int(self.cutting.teeth), "immersion": float(self.cutting.immersion),
                           "down": bool(self.cutting.down)},
               "feed": self.feed,
               "joint_motion": {k: {f"{n}_deg_s{p}": float(np.degrees(v)) for (n, p), v in
                                    zip((("rate", ""), ("accel", "2"), ("jerk", "3")), self.joint_motion(s).values())}
                                for k, s in (("planned", self.planned), ("fixed", self.fixed))},
               "ramps": (int(np.sum(np.diff(self.planned.index) != 0)) if len(self.planned.index) > 1 else 0)
               - (0 if self.planned.corners is None else len(self.planned.corners)),
               "theta_range_deg": [float(np.degrees(self.planned.theta.min())),
                                   float(np.degrees(self.planned.theta.max()))],
               "seconds": self.seconds}
        if self.depth is not None:
            out["at_risk"] = {"planned": len(self.at_risk()), "fixed": len(self.at_risk(self.fixed))}
        if self.reorientation is not None:
            out["reorient"] = self.reorientation.to_dict()
        if self.speed_scan is not None:
            out["speed_scan"] = {"speeds_rpm": self.speed_scan["speeds_rpm"],
                                 "min_alim_mm": [1e3 * v for v in self.speed_scan["min_alim"]]}
        if self.band is not None:
            out["band"] = {"level": self.band_level, "min_lower_mm": 1e3 * float(np.nanmin(self.band.lower)),
                           "min_upper_mm": 1e3 * float(np.nanmin(self.band.upper))}
            if self.depth is not None:
                # locations whose band reaches below the depth cut: chatter there is not ruled out
                out["at_risk"]["planned_band"] = int(np.sum(self.band.lower < self.depth))
        return jsonable(out)

    def summary(self) -> str:
        """A few readable lines (mm and degrees): the locations and speed, each schedule's smallest
        critical depth and the gain, the planned angles, the band and the locations at risk where
        known, and the poses beyond the predictor's training postures."""
        def mm(v):   # -inf: a pose along the schedule cannot be used; inf: stable at any depth
            return f"{1e3 * v:.3f} mm" if np.isfinite(v) else ("unusable" if v < 0 else "unbounded")

        head = f"{len(self.toolpath)} cutter locations at {self.speed_rpm:g} rev/min"
        if self.speed_scan is not None:
            sp = self.speed_scan["speeds_rpm"]
            head += f" (the best of {len(sp)} from {sp[0]:g} to {sp[-1]:g})"
        lines = [head,
                 f"smallest critical depth: planned {mm(self.planned.min_margin)}"
                 f"{'' if self.planned.feasible else ' (NOT feasible)'}, fixed θ = "
                 f"{np.degrees(self.fixed.theta[0]):g}° {mm(self.fixed.min_margin)}"
                 f"{f' (gain {self.gain:.2f}x)' if np.isfinite(self.gain) else ''}, "
                 f"pointwise best {mm(self.pointwise.min_margin)}",
                 f"planned θ between {np.degrees(self.planned.theta.min()):g}° and "
                 f"{np.degrees(self.planned.theta.max()):g}°"]
        if self.best_fixed is not None:
            g = self.gain_best_fixed
            lines.insert(2, f"best fixed θ = {np.degrees(self.best_fixed.theta[0]):g}° "
                            f"{mm(self.best_fixed.min_margin)}{'' if self.best_fixed.feasible else ' (NOT feasible)'}"
                            f"{f' (gain {g:.2f}x)' if np.isfinite(g) else ''}; feed along "
                            f"{'base X' if self.feed == 'x' else 'the path'}")
        if self.reorientation is not None:
            lines.append(self.reorientation.summary())
        if self.band is not None:
            lines.append(f"{100 * self.band_level:g} % band of the planned critical depth: smallest lower bound "
                         f"{mm(float(np.nanmin(self.band.lower)))}")
        if self.depth is not None:
            lines.append(f"locations below the {1e3 * self.depth:g} mm depth: planned {len(self.at_risk())}, "
                         f"fixed {len(self.at_risk(self.fixed))}")
        outside = int(np.sum(self.depths.outside_hull[np.arange(len(self.planned.index)), self.planned.index]))
        if outside:
            far = ("" if self.hull_distance is None else
                   f", up to {float(np.max(self.hull_distance)):.2f} of their standard deviations beyond their hull")
            lines.append(f"{outside} planned poses outside the predictor's training postures{far}")
        return "\n".join(lines)

    def plot(self, ax=None):
        """The critical depth along the path for the planned and the fixed-θ schedules, the band and
        the depth cut where known (:func:`rmbench.path.plot.plot_plan`).

        Drawn on ``ax`` or a new figure's Axes (:func:`rmbench.plotting.axes_or_new`), which it
        returns.
        """
        from rmbench.path.plot import plot_plan

        return plot_plan(self, ax=ax)

    def to_csv(self, path, schedule: Schedule | None = None) -> Path:
        """The schedule and joint trajectory: arc length, location, θ, joints (deg), critical depth (mm)."""
        s = self.planned if schedule is None else schedule
        q = np.degrees(self.joint_trajectory(s))
        arc = self.toolpath.arc_length()
        joints = [f"q{k + 1}_deg" for k in range(q.shape[1])]
        # the band is the planned schedule's: written beside it only
        band = self.band if (self.band is not None and s is self.planned) else None
        extra = ["a_lim_lower_mm", "a_lim_upper_mm"] if band is not None else []
        rows = [",".join(["s_mm", "x_mm", "y_mm", "theta_deg"] + joints + ["a_lim_mm"] + extra + ["cutting"])]

        def mm(v):
            return f"{1e3 * v:.5f}" if np.isfinite(v) else ""

        for i in range(len(s.index)):
            rows.append(",".join([f"{1e3 * arc[i]:.3f}", f"{1e3 * self.toolpath.xy[i, 0]:.3f}",
                                  f"{1e3 * self.toolpath.xy[i, 1]:.3f}", f"{np.degrees(s.theta[i]):.3f}"]
                                 + [f"{v:.5f}" for v in q[i]] + [mm(s.margin[i])]
                                 + ([mm(band.lower[i]), mm(band.upper[i])] if band is not None else [])
                                 + [str(int(self.toolpath.cutting[i]))]))
        path = Path(path)
        tmp = path.with_name(path.name + ".part")
        tmp.write_text("\n".join(rows) + "\n")
        tmp.replace(path)
        return path


def _check_reach(tp: ToolPath, reach: Reach) -> None:
    bad = reach.unreachable()
    if len(bad):
        i = int(bad[0])
        r = float(np.hypot(*tp.xy[i]))
        raise InputError(f"{len(bad)} cutter location(s) unreachable at every angle, the first at line "
                         f"{int(tp.line[i])}: ({1e3 * tp.xy[i, 0]:.1f}, {1e3 * tp.xy[i, 1]:.1f}) mm, "
                         f"{1e3 * r:.0f} mm from the base axis")


def _evaluated(toolpath: ToolPath, eval_spacing: float) -> np.ndarray:
    """Locations at which the critical depth is evaluated: the first, the last, and one every
    ``eval_spacing`` of arc length."""
    arc = toolpath.arc_length()
    marks = np.arange(0.0, arc[-1] + eval_spacing, eval_spacing)
    idx = np.unique(np.concatenate([[0, len(arc) - 1], np.searchsorted(arc, marks).clip(0, len(arc) - 1)]))
    return idx


def plan_path(robot, predictor, toolpath: ToolPath, *, speed_rpm, depth: float | None = None,
              cutting: Cutting = ALUMINIUM_6061, settings: PlanSettings = PlanSettings(),
              progress=None) -> PathPlan:
    """Plan θ(s) along a tool path with the critical depth a posture predictor gives.

    Parameters
    ----------
    robot : rmbench.robot.Robot
        The robot that mills (its inverse kinematics and joint limits).
    predictor : rmbench.predict.PosturePredictor or None
        Trained on this robot with the tool that mills; None: the robot's exact modes
        (:func:`rmbench.path.margin.exact_modes`, the reference plan; no hull distance).
    toolpath : ToolPath
    speed_rpm : float, array_like or str
        Spindle speed, rev/min; several: each is planned and the one whose planned schedule keeps
        the largest smallest critical depth is kept (``PathPlan.speed_scan`` holds them all; the
        tool tip's modes are predicted once, the receptance's eigenvalues computed once for all).
        A name of :data:`rmbench.stability.SPEED_RANGES` (``"low"``: 300-3,000): :data:`RANGE_SPEEDS`
        speeds evenly over it.
    depth : float, optional
        Axial depth to be cut, m (marks the locations at risk).
    cutting : Cutting
        The cut (:data:`CUTTINGS` names a few); default the seed's aluminium slot.
    settings : PlanSettings
        ``settings.feed`` says where the feed runs in the cut at each location, ``settings.reorient``
        whether θ may also turn at corners, the tool standing.

    Raises
    ------
    InputError
        A cutter location no candidate angle reaches (named, with the reach), a speed or depth out
        of range.
    """
    speeds = _check_cut(speed_rpm, depth)
    say = progress or (lambda msg: None)
    t = {"start": time.perf_counter()}
    theta = np.asarray(settings.theta, float)
    # the programmed points first: an unreachable one is named before thousands of locations
    # between are tried
    _check_reach(toolpath, reach_grid(robot, toolpath, theta))
    tp = toolpath.resampled(settings.spacing)
    reach = reach_grid(robot, tp, theta)
    _check_reach(tp, reach)
    t["reach"] = time.perf_counter()
    say(f"{len(tp)} cutter locations reached at {len(theta)} angles")
    at = _evaluated(tp, settings.eval_spacing)
    heading = None if settings.feed == "x" else tp.heading()[at]
    grids = _tip_modes(robot, predictor, tp, reach, at, settings).depths_at(cutting, speeds, heading=heading)
    arc = tp.arc_length()

    def spread(a):
        return np.column_stack([np.interp(arc, arc[at], a[:, j]) for j in range(a.shape[1])])

    t["depths"] = time.perf_counter()
    say(f"critical depths {'predicted' if predictor is not None else 'exact'} at {len(at)} locations x "
        f"{len(theta)} angles"
        + (f" x {len(speeds)} speeds" if len(speeds) > 1 else ""))
    feed = np.where(np.isfinite(tp.feed), tp.feed, settings.default_feed)
    # each move's time at its feed (a rapid's at the cutting feed: slower than it will be, so
    # its joint moves are judged leniently; nothing is cut along it)
    dt = np.diff(arc) / feed[1:]
    max_dq = settings.max_joint_rate * dt
    corners = find_corners(tp, settings.corner_angle) if settings.reorient == "corners" else None
    depths, planned, margin, scan = _best_speed(grids, spread, reach, settings, dt, corners)
    planned = solve_ramps(robot, tp, reach, planned, max_dq)
    turned = None if corners is None else corner_dwell(planned, reach.q, corners, settings.max_joint_rate,
                                                        settings.max_joint_accel, settings.max_joint_jerk)
    fixed = fixed_schedule(margin, theta, settings.fixed_theta, q=reach.q, max_dq=max_dq)
    pointwise = pointwise_schedule(margin, theta)
    best_fixed = best_fixed_schedule(margin, theta, q=reach.q, max_dq=max_dq)
    t["plan"] = time.perf_counter()
    hull = None if predictor is None else predictor.hull_distance(np.column_stack([tp.xy, planned.theta]))
    speed_scan = ({"speeds_rpm": speeds.tolist(), "min_alim": [float(v) for v in scan]} if len(speeds) > 1
                  else None)
    return PathPlan(tp, reach, depths, planned, fixed, pointwise, depth, float(depths.speed_rpm), _stage_seconds(t),
                    hull, speed_scan=speed_scan, best_fixed=best_fixed, cutting=cutting, feed=settings.feed,
                    reorientation=turned, exact_modes=settings.exact_modes, f_max=settings.f_max)


def _tip_modes(robot, predictor, tp: ToolPath, reach: Reach, at: np.ndarray, settings: PlanSettings):
    """The tool tip's modes at the evaluated locations ``at`` (indices into ``tp``) and every
    angle: predicted, or the robot's exact ones at the reach's joint commands (None predictor;
    the bands' or every mode below ``settings.f_max``, ``settings.exact_modes``)."""
    theta = np.asarray(reach.theta, float)
    if predictor is not None:
        return predicted_modes(predictor, tp.xy[at], theta)
    sub = Reach(reach.theta, reach.q[at], reach.ok[at], reach.limit_margin[at], reach.sigma_min[at])
    if settings.exact_modes == "all":
        return exact_modes(robot, tp.xy[at], theta, reach=sub, bands=ALL_MODES, f_max=settings.f_max)
    return exact_modes(robot, tp.xy[at], theta, reach=sub)


def _check_cut(speed_rpm, depth) -> np.ndarray:
    """The spindle speeds to plan at, rev/min, shape (n_speed,), once they and the depth are checked
    (a named range's :data:`RANGE_SPEEDS`)."""
    if isinstance(speed_rpm, str):
        if speed_rpm not in SPEED_RANGES:
            raise InputError(f"no speed range {speed_rpm!r}; one of {', '.join(SPEED_RANGES)}, or speeds in rev/min")
        speed_rpm = speed_grid(speed_rpm, RANGE_SPEEDS)
    try:
        speeds = np.atleast_1d(np.asarray(speed_rpm, float))
    except (TypeError, ValueError):
        raise InputError(f"spindle speeds must be numbers in rev/min, got {speed_rpm!r}") from None
    if speeds.ndim != 1 or not len(speeds) or not np.all(speeds > 0):
        raise InputError(f"spindle speeds must be > 0 rev/min, got {speed_rpm!r}")
    if depth is not None and not depth > 0:
        raise InputError(f"the depth of cut must be > 0 mm, got {1e3 * depth!r}")
    return speeds


def _best_speed(grids, spread, reach: Reach, settings: PlanSettings, dt: np.ndarray, corners=None):
    """Plan at each speed's critical depths (``grids``, spread from the evaluated locations to all
    by ``spread``) and keep the speed whose planned schedule keeps the largest smallest depth, or
    that depth times the speed (``settings.speed_by``; θ may also turn standing at ``corners``,
    location indices; None: ramps only).

    Returns its depths (DepthGrid), planned schedule, margin over (location, θ) (-inf where not
    reached) and every speed's planned smallest depth, m."""
    theta = np.asarray(settings.theta, float)
    max_dq = settings.max_joint_rate * dt
    ramp = ramp_moves(settings, reach, dt)
    best, scan = None, []
    for coarse in grids:
        depths = DepthGrid(spread(coarse.a_lim), {b: spread(v) for b, v in coarse.by_band.items()},
                           spread(coarse.outside_hull.astype(float)) > 0, coarse.speed_rpm)
        margin = np.where(reach.ok, depths.a_lim, -np.inf)
        planned = plan_schedule(margin, theta, q=reach.q, max_step=1, max_dq=max_dq, ramp=ramp,
                                dt=dt, max_ddq=settings.max_joint_accel, max_dddq=settings.max_joint_jerk,
                                corners=corners, max_rate=settings.max_joint_rate,
                                min_turn_gain=settings.min_turn_gain)
        scan.append(planned.min_margin)
        # the removal rate at the schedule's smallest depth: proportional to depth x speed
        value = planned.min_margin * (coarse.speed_rpm if settings.speed_by == "removal" else 1.0)
        if best is None or value > best[3]:
            best = (depths, planned, margin, value)
    return (*best[:3], scan)


def _stage_seconds(t: dict) -> dict:
    """Seconds each stage took from the times its end was reached (``perf_counter``, in order,
    the first the start), and their total."""
    keys = list(t)
    return {k: round(t[k] - t[keys[i - 1]], 3) for i, k in enumerate(keys) if i} | {
        "total": round(t[keys[-1]] - t[keys[0]], 3)}


def with_band(plan: PathPlan, predictor, *, cutting: Cutting | None = None, eval_spacing: float = 20e-3,
              draws: int = 64, level: float = 0.95, seed: int = 0) -> PathPlan:
    """The plan with its critical depth's band along the planned schedule (:func:`depth_band`:
    draws of the predictor's leave-one-out-calibrated standard deviations), evaluated every
    ``eval_spacing`` (m) of arc length and interpolated between, as the depths are; its seconds under
    ``plan.seconds["band"]``. The cut is ``plan.cutting`` unless ``cutting`` is given, the feed
    along the path where ``plan.feed`` is ``"path"``."""
    import dataclasses

    t0 = time.perf_counter()
    tp, s = plan.toolpath, plan.planned
    at = _evaluated(tp, eval_spacing)
    cutting = plan.cutting if cutting is None else cutting
    heading = None if plan.feed == "x" else tp.heading()[at]
    b = depth_band(predictor, tp.xy[at], s.theta[at], cutting, plan.speed_rpm, draws=draws, level=level, seed=seed,
                   heading=heading)
    arc = tp.arc_length()
    # the band's width relative to its depth, interpolated, about the plan's own depth at each
    # location: between evaluations the schedule's θ need not be its neighbours'
    with np.errstate(divide="ignore", invalid="ignore"):
        down, up = (np.interp(arc, arc[at], np.nan_to_num(np.log(v / b.a_lim), nan=0.0, posinf=0.0, neginf=-np.inf))
                    for v in (b.lower, b.upper))
    band = DepthBand(s.margin, s.margin * np.exp(down), s.margin * np.exp(up), b.scale, b.n_calibration)
    seconds = plan.seconds | {"band": round(time.perf_counter() - t0, 3)}
    return dataclasses.replace(plan, band=band, band_level=level, seconds=seconds)
