"""Tool-path planning (issue 40): the redundant angle along the bundled pocket, planned from a
posture predictor, against θ held fixed and against a plan from the exact model.

1. A predictor trained on the seed's 112-posture grid: single-task GPs on the stand-in's exact
   modes there (``rmbench.impact.dataset.exact_modes_dataset``: the simulator's truth, no campaign;
   a campaign's fitted modes add the measurement's error on top).
2. The bundled pocket at 5 mm spacing (1,921 cutter locations), 37 angles from −60° to 60°; the
   plan timed as the user waits for it (``plan_path``: reach, predicted depths every 20 mm of arc,
   schedule).
3. The exact model's critical depths on the same evaluation grid (``exact_modes``), at each of a
   few spindle speeds: the exact plan, and the predicted plan's schedule scored on the exact depths.
4. Predicted against exact critical depth at every evaluated pose: p95 relative error.

5. The 95 % band of the predicted depth along the predicted plan (64 draws from the predictor's
   standard deviations, calibrated by leave-one-posture-out: ``depth_band``) and how often it covers
   the exact depth, at the evaluated locations, at the speed with the largest exact gain; beside it
   the conformal band (``conformal=True``: the draws' spread scaled by the training postures'
   left-out depths).
6. Virtual milling along the plan (``mill_schedule``, the robot moving along the path at the
   pocket's feed through each cut) at the first speed, where the impact bands'
   modes limit (above ~12 krpm the tool on its holder, outside the bands, does): ``--mill`` evenly
   spaced locations of the planned and of the fixed-θ schedule, each cut at three depths along the
   whole path (0.8 times the smallest predicted critical depth of the two schedules, their median,
   1.2 times the largest). Scored on the cuts whose depth lies more than 10 % from the plan's
   predicted depth there (the others counted): chatter where the plan says it, stable where not.

Last line: ``{"cl_points", "plan_s", "min_alim_gain", "exact_min_alim_gain", "mill_agreement",
"alim_pred_err_p95", "alim_band_coverage", "alim_band_coverage_conformal"}`` (gains at the speed with
the largest exact gain of those tried; every speed's figures are printed).

usage: python bench/path.py [--speeds 9000,12000,15000,18000] [--quick] | tee bench/results/path.txt
"""

from __future__ import annotations

import argparse
import json
import os
import time
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmbench.impact.dataset import exact_modes_dataset  # noqa: E402
from rmbench.errors import InputError  # noqa: E402
from rmbench.path import (PlanSettings, depth_band, example, exact_modes, fixed_schedule, mill_schedule, plan_path,  # noqa: E402
                          plan_schedule, predicted_modes)
from rmbench.path.planner import _evaluated  # noqa: E402
from rmbench.predict import PosturePredictor  # noqa: E402
from rmbench.robot import Robot, seed_grid  # noqa: E402
from rmbench.stability import ALUMINIUM_6061  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speeds", default="9000,12000,15000,18000", help="spindle speeds, rev/min")
    ap.add_argument("--quick", action="store_true",
                    help="a smoke run: the contour at 40 mm, 5 angles, 12 training postures (figures not comparable)")
    ap.add_argument("--mill", type=int, default=30, help="locations milled per schedule (0: none)")
    args = ap.parse_args()
    speeds = [float(s) for s in args.speeds.split(",")]
    robot = Robot.load("irb6660", tool="dummy")
    t0 = time.perf_counter()
    grid = seed_grid()
    if args.quick:
        from rmbench.robot import Posture

        grid = [Posture.from_mm_deg(x, y, t) for x in (1350, 1850) for y in (-250, 250) for t in (-40, 0, 40)]
    pred = PosturePredictor("stgp").fit(exact_modes_dataset(robot, grid))
    print(f"1. predictor: single-task GPs on the exact modes of {len(grid)} postures (the seed grid: 112), "
          f"{time.perf_counter() - t0:.0f} s")
    settings = PlanSettings(theta=tuple(np.radians(np.linspace(-60.0, 60.0, 37))))
    tp0 = example("pocket")
    if args.quick:
        settings = PlanSettings(theta=tuple(np.radians(np.linspace(-40.0, 40.0, 5))), spacing=40e-3,
                                eval_spacing=80e-3)
        tp0 = example("contour")
    t0 = time.perf_counter()
    plan = plan_path(robot, pred, tp0, speed_rpm=speeds[0], settings=settings)
    plan_s = time.perf_counter() - t0
    tp, reach = plan.toolpath, plan.reach
    print(f"2. pocket: {len(tp)} cutter locations x {len(reach.theta)} angles planned in {plan_s:.1f} s "
          f"({plan.seconds})")
    summary = plan.to_dict()
    motion = {k: {n: round(v, 2) for n, v in m.items()} for k, m in summary["joint_motion"].items()}
    print(f"   {summary['ramps']} θ ramps; feasible {summary['feasible']}; joints (deg/s, deg/s², deg/s³): {motion}")
    at = _evaluated(tp, settings.eval_spacing)
    t0 = time.perf_counter()
    sub = type(reach)(reach.theta, reach.q[at], reach.ok[at], reach.limit_margin[at], reach.sigma_min[at])
    ex_modes = exact_modes(robot, tp.xy[at], reach.theta, reach=sub)
    pr_modes = predicted_modes(pred, tp.xy[at], reach.theta)
    print(f"3. exact modes at {len(at)} evaluated locations x {len(reach.theta)} angles: "
          f"{time.perf_counter() - t0:.0f} s")
    arc = tp.arc_length()

    def spread(a):
        return np.column_stack([np.interp(arc, arc[at], a[:, j]) for j in range(a.shape[1])])

    feed = np.where(np.isfinite(tp.feed), tp.feed, settings.default_feed)
    dt = np.diff(arc) / feed[1:]
    max_dq = settings.max_joint_rate * dt
    limits = dict(q=reach.q, max_step=1, max_dq=max_dq, ramp=settings.ramp_moves, dt=dt,
                  max_ddq=settings.max_joint_accel, max_dddq=settings.max_joint_jerk)
    rows, errs = [], []
    for sp in speeds:
        ex = ex_modes.depths(ALUMINIUM_6061, sp).a_lim
        pr = pr_modes.depths(ALUMINIUM_6061, sp).a_lim
        ok = np.isfinite(ex) & np.isfinite(pr)
        err = np.abs(pr[ok] / ex[ok] - 1)
        errs.append(err)
        m_ex = np.where(reach.ok, spread(np.where(np.isfinite(ex), ex, np.nan)), -np.inf)
        m_pr = np.where(reach.ok, spread(pr), -np.inf)
        m_ex = np.where(np.isnan(m_ex), -np.inf, m_ex)
        planned = plan_schedule(m_pr, reach.theta, **limits)
        fixed = fixed_schedule(m_pr, reach.theta, 0.0)
        ex_plan = plan_schedule(m_ex, reach.theta, **limits)
        ex_fixed = fixed_schedule(m_ex, reach.theta, 0.0)
        on_exact = planned.on(m_ex).min()
        row = {"speed_rpm": sp, "schedule": planned, "ex": ex,
               "pred_gain": planned.min_margin / fixed.min_margin,
               "exact_gain": ex_plan.min_margin / ex_fixed.min_margin,
               "pred_plan_on_exact_gain": on_exact / ex_fixed.min_margin,
               "exact_fixed_min_mm": 1e3 * ex_fixed.min_margin, "exact_plan_min_mm": 1e3 * ex_plan.min_margin,
               "pred_plan_min_mm": 1e3 * planned.min_margin, "err_p95": float(np.percentile(err, 95)),
               "err_median": float(np.median(err))}
        rows.append(row)
        print(f"   {sp:7.0f} rev/min: fixed θ=0 exact min {row['exact_fixed_min_mm']:.3f} mm; exact plan "
              f"{row['exact_plan_min_mm']:.3f} mm (gain {row['exact_gain']:.2f}x); predicted plan "
              f"{row['pred_plan_min_mm']:.3f} mm predicted, gain {row['pred_gain']:.2f}x predicted, "
              f"{row['pred_plan_on_exact_gain']:.2f}x on the exact depths; depth error p95 "
              f"{100 * row['err_p95']:.1f} %, median {100 * row['err_median']:.2f} %")
    best = max(rows, key=lambda r: r["exact_gain"])
    all_err = np.concatenate(errs)
    sched = best["schedule"]
    j, to = sched.index[at], (sched.index if sched.to is None else sched.to)[at]
    w = np.zeros(len(at)) if sched.frac is None else sched.frac[at]
    k = np.arange(len(at))
    a = best["ex"][k, j]
    exact_on = a + w * (best["ex"][k, to] - a)          # along a ramp: interpolated in θ, as the plan's
    ok = np.isfinite(exact_on)
    coverage = {}
    for conformal in (False, True):
        t0 = time.perf_counter()
        try:
            band = depth_band(pred, tp.xy[at], sched.theta[at], ALUMINIUM_6061, best["speed_rpm"], draws=64,
                              conformal=conformal)
        except InputError as e:           # --quick's 12 postures are too few for a conformal band
            print(f"5. {'conformal' if conformal else 'sampled'} band: {e}")
            coverage[conformal] = None
            continue
        lo, hi = band.lower, band.upper
        covered = (exact_on[ok] >= lo[ok]) & (exact_on[ok] <= hi[ok])
        coverage[conformal] = float(np.mean(covered))
        half = (hi - lo) / (hi + lo)
        print(f"5. {'conformal' if conformal else 'sampled'} band along the plan at {best['speed_rpm']:.0f} rev/min "
              f"({time.perf_counter() - t0:.0f} s{f', factor {band.scale:.2f} from {band.n_calibration} postures' if conformal else ''}): "
              f"half-width median {100 * np.median(half):.2f} %, p90 {100 * np.percentile(half, 90):.2f} %; "
              f"covers the exact depth at {covered.sum()} of {ok.sum()} locations")
    agreement = None
    if args.mill:
        t0 = time.perf_counter()
        along = {k: getattr(plan, k).margin for k in ("planned", "fixed")}
        lo_d = 0.8 * min(v.min() for v in along.values())
        hi_d = 1.2 * max(v.max() for v in along.values())
        mid_d = float(np.median(np.concatenate(list(along.values()))))
        decided, right = 0, 0
        for sched in ("planned", "fixed"):
            for depth in (lo_d, mid_d, hi_d):
                cuts = mill_schedule(robot, plan, depth=depth, schedule=sched, n=args.mill, moving=True)
                d = cuts.decided
                decided += int(d.sum())
                right += int(np.sum(cuts.chatter[d] == cuts.expected[d]))
                print(f"6. {sched:7s} {1e3 * depth:.3f} mm at {plan.speed_rpm:.0f} rev/min: {cuts.summary()}", flush=True)
        agreement = right / decided if decided else None
        print(f"   milled {6 * args.mill} cuts in {time.perf_counter() - t0:.0f} s; decided {decided}, "
              f"as planned {right}")
    line = {"cl_points": len(tp), "plan_s": round(plan_s, 1), "min_alim_gain": best["pred_plan_on_exact_gain"],
            "exact_min_alim_gain": best["exact_gain"], "mill_agreement": agreement,
            "alim_pred_err_p95": float(np.percentile(all_err, 95)), "alim_band_coverage": coverage[False],
            "alim_band_coverage_conformal": coverage[True]}
    print(json.dumps(line))


if __name__ == "__main__":
    main()
