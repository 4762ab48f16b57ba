"""``rmbench path plan``: the redundant angle along a tool path, chosen to keep the most margin to chatter."""

from __future__ import annotations

import sys
from pathlib import Path

from rmbench.cli._common import add_report_option, command_group, print_json, report_path
from rmbench.errors import InputError

__all__ = ["register"]


def register(sub) -> None:
    g = command_group(sub, "path", "machining along a tool path: the redundant angle that keeps the most margin to chatter")
    p = g.add_parser("plan", help="choose θ along a tool path from a trained posture predictor")
    p.add_argument("toolpath", help="cutter-location CSV or G-code file, or a bundled example: pocket, contour")
    p.add_argument("--predictor", required=True, help="posture predictor (.npz from 'rmbench predict train')")
    speed = p.add_mutually_exclusive_group(required=True)
    speed.add_argument("--speed", type=float, metavar="RPM", help="spindle speed, rev/min")
    speed.add_argument("--speed-range", metavar="A,B",
                       help="plan at every --speed-step from A to B rev/min and keep the speed whose plan keeps the "
                            "largest smallest critical depth")
    speed.add_argument("--speeds", metavar="LIST|RANGE",
                       help="plan at each of these spindle speeds and keep the best, as --speed-range: rev/min "
                            "comma-separated (300,600,1200), or a named range spread over 10 speeds (low: 300-3,000 "
                            "rev/min for steel and titanium; robot: 5,000-20,000)")
    p.add_argument("--speed-step", type=float, default=500.0, metavar="RPM", help="step of --speed-range (default 500)")
    p.add_argument("--cutting", default="aluminium", metavar="NAME",
                   help="the cut: aluminium (6061 slot, 2 teeth; the default), steel (C45, 6 teeth at half "
                        "immersion) or titanium (Ti-6Al-4V, 4 teeth at half immersion)")
    p.add_argument("--feed", default="x", metavar="x|path",
                   help="where the feed runs in the cut: x along base X everywhere (the default), path along "
                        "the path's own direction at each location")
    p.add_argument("--reorient", default="ramps", metavar="ramps|corners",
                   help="how θ changes: ramps of one angle step while cutting (the default), or also any turn at a "
                        "corner (the heading turning by more than 30°), the feed stopped and the tool standing while "
                        "the joints move at their limits (the dwell is reported: a standing tool rubs)")
    p.add_argument("--speed-by", default="depth", metavar="depth|removal",
                   help="among several speeds keep the one with the largest smallest critical depth (the default) "
                        "or with the largest removal rate (that depth times the speed)")
    p.add_argument("--min-turn-gain", type=float, default=5.0, metavar="PCT",
                   help="with --reorient corners: the least rise of the smallest critical depth over ramps alone "
                        "that standing turns must buy, else none is taken, %% (default 5)")
    p.add_argument("--exact-modes", default="bands", metavar="bands|all",
                   help="the exact model --mill compares with: the measured bands' modes (the default) or every "
                        "mode of the linearised robot below 8 kHz, the tool's included (those the milling sees)")
    p.add_argument("--depth", type=float, default=None, metavar="MM", help="axial depth of cut, mm (marks the locations at risk)")
    p.add_argument("--robot", default="irb6660", help="the robot that mills: bundled name or MJCF path (default irb6660)")
    p.add_argument("--tool", default=None, help="its tool (default: the robot's own; the predictor's tool is the one that mills)")
    p.add_argument("--theta-range", default="-60,60", metavar="A,B", help="candidate redundant angles, degrees (default -60,60; write --theta-range=-40,40)")
    p.add_argument("--theta-step", type=float, default=5.0, metavar="DEG", help="angle grid step, degrees (default 5)")
    p.add_argument("--fixed-theta", type=float, default=0.0, metavar="DEG", help="the fixed-angle comparison, degrees (default 0)")
    p.add_argument("--spacing", type=float, default=5.0, metavar="MM", help="cutter-location spacing, mm (default 5)")
    p.add_argument("--max-joint-rate", type=float, default=60.0, metavar="DEG_S",
                   help="largest joint speed while cutting, deg/s (default 60)")
    p.add_argument("--ramp", type=float, default=50.0, metavar="MM",
                   help="path length over which θ moves from one grid angle to the next, mm (default 50; 0: within one move)")
    p.add_argument("--max-joint-accel", type=float, default=57.3, metavar="DEG_S2",
                   help="largest joint acceleration a θ ramp may add, deg/s² (default 57.3, 1 rad/s²)")
    p.add_argument("--band-draws", type=int, default=64, metavar="N",
                   help="draws of the predictor's calibrated deviations for the 95 %% band of the critical depth "
                        "along the plan (default 64; 0: no band)")
    p.add_argument("--mill", type=int, default=0, metavar="N",
                   help="check the plan by virtual milling at --depth at N locations of the planned and of the "
                        "fixed-angle schedule (a few seconds a cut)")
    p.add_argument("--out", default=None, help="directory for plan.csv, fixed.csv, plan.json and plan.npz (what path mill reads)")
    p.add_argument("--json", action="store_true", help="print the plan's summary as JSON")
    add_report_option(p, "the path coloured by its critical depth, θ and the depth along it")
    p.set_defaults(func=cmd_plan)
    m = g.add_parser("mill", help="mill a saved plan in the simulator: does it chatter where the plan says?")
    m.add_argument("plan_dir", help="a directory written by 'rmbench path plan --out DIR' (its plan.npz)")
    m.add_argument("--depth", type=float, required=True, metavar="MM", help="axial depth of cut, mm")
    m.add_argument("--schedule", default="planned", choices=("planned", "fixed", "pointwise"),
                   help="which schedule to mill (default planned)")
    m.add_argument("-n", type=int, default=10, metavar="N", help="locations milled, evenly spaced along the path (default 10)")
    m.add_argument("--robot", default=None, help="the robot that mills (default: the plan's; a 'real' robot checks the plan against it)")
    m.add_argument("--tool", default=None, help="its tool (default: the plan's)")
    how = m.add_mutually_exclusive_group()
    how.add_argument("--moving", dest="moving", action="store_true", default=True,
                     help="move the robot along the path at its feed through each cut (the default)")
    how.add_argument("--held", dest="moving", action="store_false",
                     help="hold each sampled posture instead of moving through it")
    m.add_argument("--json", action="store_true", help="print the cuts' summary as JSON")
    add_report_option(m, "the plan and the cuts' vibration along the path")
    m.set_defaults(func=cmd_mill)


def _theta(args):
    import numpy as np

    try:
        a, b = (float(v) for v in args.theta_range.split(","))
    except ValueError:
        raise InputError(f"--theta-range must be A,B in degrees, got {args.theta_range!r}") from None
    if not (b > a and args.theta_step > 0):
        raise InputError("--theta-range needs A < B and --theta-step > 0")
    return np.radians(np.arange(a, b + 1e-9, args.theta_step))


def _speeds(args):
    import numpy as np

    from rmbench.stability import SPEED_RANGES

    if args.speed is not None:
        return args.speed
    if args.speeds is not None:
        if args.speeds in SPEED_RANGES:
            return args.speeds          # the planner spreads a named range
        try:
            return [float(v) for v in args.speeds.split(",")]
        except ValueError:
            raise InputError(f"--speeds must be rev/min comma-separated or one of {', '.join(SPEED_RANGES)}, "
                             f"got {args.speeds!r}") from None
    try:
        a, b = (float(v) for v in args.speed_range.split(","))
    except ValueError:
        raise InputError(f"--speed-range must be A,B in rev/min, got {args.speed_range!r}") from None
    if not (0 < a < b and args.speed_step > 0):
        raise InputError("--speed-range needs 0 < A < B and --speed-step > 0")
    speeds = np.arange(a, b + 1e-6, args.speed_step)
    if len(speeds) > 200:
        raise InputError(f"--speed-range with --speed-step {args.speed_step:g} gives {len(speeds)} speeds; at most 200")
    return speeds


def _settings(args):
    """The planner's settings from the options (mm and degrees to m and rad; it checks them)."""
    import numpy as np

    from rmbench.path import EXACT_MODES, FEEDS, REORIENTS, SPEED_BY, PlanSettings

    if args.feed not in FEEDS:
        raise InputError(f"--feed must be {' or '.join(FEEDS)}, got {args.feed!r}")
    if args.reorient not in REORIENTS:
        raise InputError(f"--reorient must be {' or '.join(REORIENTS)}, got {args.reorient!r}")
    if args.exact_modes not in EXACT_MODES:
        raise InputError(f"--exact-modes must be {' or '.join(EXACT_MODES)}, got {args.exact_modes!r}")
    if args.speed_by not in SPEED_BY:
        raise InputError(f"--speed-by must be {' or '.join(SPEED_BY)}, got {args.speed_by!r}")
    if not args.min_turn_gain >= 0:
        raise InputError(f"--min-turn-gain must be a percentage >= 0, got {args.min_turn_gain!r}")
    return PlanSettings(theta=tuple(_theta(args)), fixed_theta=float(np.radians(args.fixed_theta)),
                        spacing=1e-3 * args.spacing, max_joint_rate=float(np.radians(args.max_joint_rate)),
                        ramp_length=1e-3 * args.ramp, max_joint_accel=float(np.radians(args.max_joint_accel)),
                        feed=args.feed, reorient=args.reorient, min_turn_gain=1e-2 * args.min_turn_gain,
                        exact_modes=args.exact_modes, speed_by=args.speed_by)


def _cutting(args):
    """The named cut of ``--cutting``."""
    from rmbench.path import CUTTINGS

    if args.cutting not in CUTTINGS:
        raise InputError(f"--cutting must be one of {', '.join(CUTTINGS)}, got {args.cutting!r}")
    return CUTTINGS[args.cutting]


def cmd_plan(args) -> int:
    from rmbench.io.toolpath import read_toolpath
    from rmbench.path import EXAMPLES, example, plan_path, with_band
    from rmbench.predict import PosturePredictor
    from rmbench.robot import Robot

    report = report_path(args)
    if args.band_draws < 0 or args.band_draws == 1:
        raise InputError(f"--band-draws must be 0 (no band) or at least 2, got {args.band_draws}")
    if args.mill < 0 or (args.mill and args.depth is None):
        raise InputError("--mill N needs N >= 0 and a --depth to cut")
    settings, cutting, speeds = _settings(args), _cutting(args), _speeds(args)
    tp = example(args.toolpath) if args.toolpath in EXAMPLES else read_toolpath(args.toolpath)
    predictor = PosturePredictor.load(args.predictor)
    robot = Robot.load(args.robot, tool=args.tool)
    out = Path(args.out) if args.out else None
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
    say = (lambda msg: None) if args.json else (lambda msg: print(f"  {msg}", file=sys.stderr))
    plan = plan_path(robot, predictor, tp, speed_rpm=speeds, cutting=cutting,
                     depth=None if args.depth is None else 1e-3 * args.depth, settings=settings, progress=say)
    if args.band_draws:
        say(f"the critical depth's 95 % band along the plan from {args.band_draws} draws")
        plan = with_band(plan, predictor, eval_spacing=settings.eval_spacing, draws=args.band_draws)
    summary = plan.to_dict()
    milled = {}
    if args.mill:
        from rmbench.path import mill_schedule

        summary["milling"] = {}
        for sched in ("planned", "fixed"):
            say(f"milling {args.mill} locations of the {sched} schedule at {args.depth:g} mm")
            milled[sched] = mill_schedule(robot, plan, depth=1e-3 * args.depth, schedule=sched, n=args.mill)
            summary["milling"][sched] = milled[sched].summary()
    if out is not None:
        summary["files"] = _write_plan(out, plan, summary, args)
    if report is not None:
        from rmbench.report import Page
        from rmbench.report.path import path_sections

        page = Page(f"Tool path plan of {args.toolpath}", {"predictor": args.predictor, "robot": args.robot,
                                                          "speed (rev/min)": plan.speed_rpm, "cutting": args.cutting,
                                                          "feed along": args.feed})
        path_sections(page, plan, milled)
        page.write(report)
        summary["report"] = str(report)
    if args.json:
        print_json(summary)
        return 0
    _print_plan(plan, summary, args)
    if out is not None:
        print(f"wrote {out}: plan.csv, fixed.csv, plan.json, plan.npz (rmbench path mill {out} --depth MM)")
    if report is not None:
        print(f"wrote {report}")
    return 0


def _write_plan(out: Path, plan, summary: dict, args) -> list:
    """plan.csv, fixed.csv, plan.npz and plan.json (``summary``) in ``out``; their paths."""
    from rmbench.io.strict_json import strict_dumps
    from rmbench.path import save_plan

    plan.to_csv(out / "plan.csv")
    plan.to_csv(out / "fixed.csv", plan.fixed)
    save_plan(plan, out / "plan.npz", robot=args.robot, tool=args.tool, predictor=str(args.predictor))
    tmp = out / "plan.json.part"
    tmp.write_text(strict_dumps(summary) + "\n")
    tmp.replace(out / "plan.json")
    return [str(out / f) for f in ("plan.csv", "fixed.csv", "plan.json", "plan.npz")]


def _print_plan(plan, summary: dict, args) -> None:
    """The plan's lines (mm and degrees); the depths that may be non-finite from the plan itself."""
    if plan.speed_scan is not None:
        speeds, best = plan.speed_scan["speeds_rpm"], plan.speed_scan["min_alim"]
        print(f"best speed of {len(speeds)} from {speeds[0]:g} to {speeds[-1]:g} rev/min: "
              f"{plan.speed_rpm:g} rev/min (planned smallest critical depth {1e3 * max(best):.3f} mm; "
              f"worst speed {1e3 * min(best):.3f} mm)")
    print(f"{summary['cl_points']} cutter locations at {plan.speed_rpm:g} rev/min; smallest critical depth "
          f"planned {1e3 * plan.planned.min_margin:.3f} mm, fixed θ = {args.fixed_theta:g}° "
          f"{1e3 * plan.fixed.min_margin:.3f} mm (gain {plan.gain:.2f}x), pointwise best "
          f"{1e3 * plan.pointwise.min_margin:.3f} mm")
    best = summary["best_fixed"]
    gain = summary["min_alim_gain_best_fixed"]
    print(f"best fixed θ = {best['theta_deg']:g}° {plan.best_fixed.min_margin * 1e3:.3f} mm"
          f"{'' if best['feasible'] else ' (NOT feasible)'}"
          f"{'' if gain is None else f' (gain {gain:.2f}x)'}; {args.cutting} cut, feed along "
          f"{'base X' if args.feed == 'x' else 'the path'}")
    lo, hi = summary["theta_range_deg"]
    print(f"planned θ between {lo:g}° and {hi:g}°; {'feasible' if summary['feasible']['planned'] else 'NOT feasible'} "
          f"within {args.max_joint_rate:g} deg/s per joint")
    if plan.reorientation is not None:
        print(plan.reorientation.summary())
    if "band" in summary:
        print(f"95 % band of the planned critical depth: smallest lower bound {summary['band']['min_lower_mm']:.3f} mm")
    if "at_risk" in summary:
        band = (f" ({summary['at_risk']['planned_band']} with the band below it)"
                if "planned_band" in summary["at_risk"] else "")
        print(f"locations below the {args.depth:g} mm depth: planned {summary['at_risk']['planned']}{band}, "
              f"fixed {summary['at_risk']['fixed']}")
    for sched, m in summary.get("milling", {}).items():
        agree = "no cut clear of the ±10 % band" if m["agreement"] is None else f"{100 * m['agreement']:.0f} % as planned"
        print(f"milled {sched}: {m['chatter']} of {m['cuts']} cuts chatter ({m['expected_chatter']} expected); "
              f"{m['decided']} clear of the predicted depth's ±10 %: {agree}; {m['inside_band']} inside it")
    if summary["outside_hull"]:
        print(f"warning: {summary['outside_hull']} planned poses lie outside the predictor's training postures, up "
              f"to {summary['hull_distance_max']:.2f} of their standard deviations beyond their hull: the "
              "predictor extrapolates there", file=sys.stderr)


def cmd_mill(args) -> int:
    import numpy as np

    from rmbench.path import load_plan, mill_schedule
    from rmbench.robot import Robot

    report = report_path(args)
    if not args.depth > 0:
        raise InputError(f"--depth must be > 0 mm, got {args.depth!r}")
    if args.n < 1:
        raise InputError(f"-n must be at least 1, got {args.n}")
    plan, meta = load_plan(Path(args.plan_dir) / "plan.npz" if Path(args.plan_dir).is_dir() else args.plan_dir)
    robot = Robot.load(args.robot or meta.get("robot") or "irb6660",
                       tool=args.tool if args.tool is not None else meta.get("tool"))
    say = (lambda msg: None) if args.json else (lambda msg: print(f"  {msg}", file=sys.stderr))
    say(f"milling {args.n} locations of the {args.schedule} schedule at {args.depth:g} mm, "
        f"{plan.speed_rpm:g} rev/min, the robot {'moving along the path' if args.moving else 'holding each posture'}")
    cuts = mill_schedule(robot, plan, depth=1e-3 * args.depth, schedule=args.schedule, n=args.n,
                         moving=args.moving, progress=lambda k: say(f"cut {k + 1} of {min(args.n, len(plan.toolpath))}"))
    summary = cuts.summary() | {"cuts_at": [{"location": int(i), "theta_deg": float(t), "predicted_mm": 1e3 * float(a),
                                             "exact_mm": 1e3 * float(e), "chatter": bool(c), "kind": k,
                                             "vibration_um": 1e6 * float(v), "moved": bool(mv)}
                                            for i, t, a, e, c, k, v, mv in zip(cuts.index, np.degrees(cuts.theta), cuts.predicted,
                                                                               cuts.exact, cuts.chatter, cuts.kind, cuts.amplitude,
                                                                               cuts.moved)]}
    if report is not None:
        from rmbench.report import Page
        from rmbench.report.path import path_sections

        page = Page(f"Virtual milling of the plan in {args.plan_dir}", {"robot": robot.name, "depth (mm)": args.depth,
                                                                        "speed (rev/min)": plan.speed_rpm})
        path_sections(page, plan, {args.schedule: cuts})
        page.write(report)
        summary["report"] = str(report)
    if args.json:
        print_json(summary)
        return 0
    agree = "none clear of it" if summary["agreement"] is None else f"{100 * summary['agreement']:.0f} % as planned"
    print(f"{summary['cuts']} cuts of the {args.schedule} schedule at {args.depth:g} mm: {summary['chatter']} chatter "
          f"({summary['expected_chatter']} expected); {summary['decided']} clear of the predicted depth's ±10 %: {agree}; "
          f"{summary['inside_band']} inside it")
    if report is not None:
        print(f"wrote {report}")
    return 0
