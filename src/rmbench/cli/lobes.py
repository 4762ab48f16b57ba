"""``rmbench lobes``: stability lobes of milling from modal data, the simulator, or the benchmark."""

from __future__ import annotations

import sys

import numpy as np

from rmbench.cli._common import add_report_option, load_dataset, print_json, report_path
from rmbench.errors import InputError

__all__ = ["register"]


def register(sub) -> None:
    p = sub.add_parser("lobes", help="stability lobes (FDM, SDM or zero-order) of milling")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--benchmark", action="store_true",
                     help="the published 1-DOF benchmark (2 teeth, 922 Hz, a/D 0.05, down-milling)")
    src.add_argument("--modal", help="modal dataset (netCDF) from `rmbench modal fit`, or a predictor (.npz) "
                                     "from `rmbench predict train` (then --posture, and --tool for a new tool by RCSA)")
    src.add_argument("--robot", help="the simulator's exact modes of a bundled robot (name or MJCF path)")
    p.add_argument("--tool", default=None,
                   help="tool on --robot (default: the robot's own); with a predictor, the target tool put on by RCSA")
    p.add_argument("--reference-tool", default="dummy", help="the tool a predictor was trained with (default dummy)")
    p.add_argument("--spacing-mm", default="33.4,20",
                   help="sensor spacing S of the low and high bands of a predictor's campaign, mm (default 33.4,20)")
    p.add_argument("--posture", help="x,y,theta in mm, mm, degrees (--robot; --modal: a fitted posture)")
    p.add_argument("--index", type=int, default=None, help="posture index in --modal (default 0)")
    p.add_argument("--band", choices=("low", "high", "both", "all"), default=None,
                   help="modes of one band, both bands apart and their lowest envelope (default for "
                        "--modal), or every mode of the simulator below 8 kHz (--robot; its default)")
    p.add_argument("--method", choices=("fdm", "sdm", "zoa"), default="fdm")
    p.add_argument("--steps", type=int, default=20, help="steps per tooth period over the cut (FDM, SDM)")
    p.add_argument("--speeds", default=None,
                   help="first,last,count in rev/min (default 5000,25000,200; robots 5000,20000,200)")
    p.add_argument("--depth-max", type=float, default=None, help="largest depth scanned, mm (default 10)")
    p.add_argument("--depths", type=int, default=100, help="depth grid points (default 100)")
    p.add_argument("--every", type=int, default=None,
                   help="scan every k-th depth before refining each crossing (default 1 for the "
                        "benchmark, 5 for robots: an unstable island thinner than k grid steps may be missed)")
    p.add_argument("--cutting", default=None,
                   help="K_t,K_n (N/mm²),teeth,immersion a/D,down|up (default: the benchmark's, or "
                        "aluminium 6061 slot with 2 teeth: 880,52,2,1,down)")
    p.add_argument("--json", action="store_true",
                   help='print {"speed_rpm": [...], "a_lim_m": [...], "stable_to_m": ...}: a_lim_m null where '
                        'no depth up to stable_to_m (the largest depth searched, m) is unstable')
    p.add_argument("--out", help="figure of the lobes (.png)")
    add_report_option(p, "the lobes (each band and their envelope)")
    p.set_defaults(func=cmd_lobes)


def _cutting(text, default):
    from rmbench.stability import Cutting

    if text is None:
        return default
    parts = [t.strip() for t in text.split(",")]
    if len(parts) != 5 or parts[4] not in ("down", "up"):
        raise InputError(f"--cutting must be K_t,K_n,teeth,immersion,down|up; got {text!r}")
    try:
        k_t, k_n, immersion = float(parts[0]), float(parts[1]), float(parts[3])
        teeth = int(parts[2])
    except ValueError:
        raise InputError(f"--cutting must be numbers K_t,K_n,teeth,immersion then down|up; got {text!r}") from None
    return Cutting(k_t * 1e6, k_n * 1e6, teeth, immersion, parts[4] == "down")


def _grid(text, default: np.ndarray) -> np.ndarray:
    if text is None:
        return default
    try:
        a, b, n = (float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"--speeds must be first,last,count in rev/min; got {text!r}") from None
    if not (a > 0 and b > a and n >= 2):
        raise InputError(f"--speeds needs 0 < first < last and count ≥ 2; got {text!r}")
    return np.linspace(a, b, int(n))


def _structures(args) -> tuple[dict, str]:
    from rmbench.stability import Structure

    band = args.band or ("both" if args.modal else "all")
    if band == "all" and args.modal:
        raise InputError("--band all needs --robot (a modal dataset holds the bands' modes only)")
    bands = ("low", "high") if band == "both" else (band,)
    if args.modal and str(args.modal).endswith(".npz"):
        return _predicted(args, bands), f"predictor {args.modal} at {args.posture}, tool {args.tool or args.reference_tool}"
    if args.modal:
        ds = load_dataset(args.modal, "modal dataset")
        if "modal" not in ds:
            raise InputError(f"{args.modal}: no modal parameters (run `rmbench modal fit` first)")
        index = args.index or 0
        if args.posture:
            from rmbench.rcsa.tool_change import posture_index
            from rmbench.robot import parse_posture

            index = posture_index(ds, parse_posture(args.posture))
        if not 0 <= index < ds.sizes["posture"]:
            raise InputError(f"posture index {index} outside 0..{ds.sizes['posture'] - 1}")
        present = set(str(b) for b in ds["mode_band"].values)
        return ({b: Structure.from_modal(ds, index, band=b) for b in bands if b in present},
                f"{args.modal}, posture {index}")
    from rmbench.robot import Robot, parse_posture

    robot = Robot.load(args.robot, tool=args.tool)
    posture = parse_posture(args.posture or "1800,200,0")
    op = robot.at(posture)
    if band == "all":
        return ({"all": Structure.from_operating_point(op)},
                f"{robot.name} with {robot.tool} at {posture.label()} (every mode below 8 kHz)")
    out = {}
    for b in bands:
        table = op.modes(b)
        if len(table) == 0:
            raise InputError(f"no mode of {robot.name} in the {b} band at {posture.label()}")
        out[b] = Structure.from_mode_table(table)
    return out, f"{robot.name} with {robot.tool} at {posture.label()} (exact modes)"


def _predicted(args, bands) -> dict:
    """Target-tool structures per band from a predictor: predict, rebuild, RCSA, fit (path.chain)."""
    import warnings

    from rmbench.impact import default_lines
    from rmbench.predict import PosturePredictor
    from rmbench.rcsa.tool_change import tool_geometry
    from rmbench.robot import parse_posture
    from rmbench.path.chain import predicted_tool_structures

    if not args.posture:
        raise InputError("a predictor needs --posture")
    try:
        s_low, s_high = (1e-3 * float(v) for v in args.spacing_mm.split(","))
    except ValueError:
        raise InputError(f"--spacing-mm must be two numbers (low, high band), got {args.spacing_mm!r}") from None
    pred = PosturePredictor.load(args.modal)
    p = parse_posture(args.posture)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = pred.predict([[p.x, p.y, p.theta]])
    for w in caught:   # on stderr: stdout is the diagram (or its JSON) alone
        print(f"rmbench: warning: {w.message}", file=sys.stderr)
    grid = default_lines()
    lines = {"low": (grid["low"], s_low), "high": (grid["high"], s_high)}
    ref = tool_geometry(args.reference_tool)
    tgt = tool_geometry(args.tool) if args.tool else ref
    _, _, structures = predicted_tool_structures(out, {b: lines[b] for b in bands}, ref, tgt)
    return structures


def cmd_lobes(args) -> int:
    from rmbench.stability import (ALUMINIUM_6061, BENCHMARK, DEPTH_MAX, benchmark_structure, depth_grid, lobes,
                                   lowest_envelope, speed_grid)

    if args.steps < 2:
        raise InputError(f"--steps must be at least 2, got {args.steps}")
    if args.benchmark:
        structures, what = {"benchmark": benchmark_structure()}, "benchmark (1 DOF, 922 Hz)"
        cutting = _cutting(args.cutting, BENCHMARK)
        speeds = _grid(args.speeds, speed_grid("benchmark"))
    else:
        structures, what = _structures(args)
        if not structures:
            raise InputError("the data have no mode in the requested band")
        cutting = _cutting(args.cutting, ALUMINIUM_6061)
        speeds = _grid(args.speeds, speed_grid("robot"))
    depth_max = 1e-3 * args.depth_max if args.depth_max is not None else DEPTH_MAX
    if not depth_max > 0 or args.depths < 2:
        raise InputError("--depth-max must be positive and --depths at least 2")
    depths = depth_grid(depth_max, args.depths)
    every = args.every if args.every is not None else (1 if args.benchmark else 5)
    if every < 1:
        raise InputError(f"--every must be at least 1, got {every}")
    report = report_path(args)
    per_band = {b: lobes(s, cutting, speeds, depths, method=args.method, steps=args.steps, every=every)
                for b, s in structures.items()}
    env = lowest_envelope(*per_band.values()) if len(per_band) > 1 else next(iter(per_band.values()))
    if args.out:
        from rmbench.stability.plot import plot_lobes

        plot_lobes({**({"envelope": env} if len(per_band) > 1 else {}), **per_band}, args.out, title=what)
    if report:
        from rmbench.report import Page
        from rmbench.report.machining import lobes_sections

        page = Page(f"Stability lobes: {what}", {"method": args.method, "cutting": str(cutting),
                                                 "speeds (rpm)": f"{speeds[0]:.0f}-{speeds[-1]:.0f}, {len(speeds)}",
                                                 "depths (mm)": f"0-{1e3 * depth_max:g}, {len(depths)}"})
        lobes_sections(page, {**({"envelope": env} if len(per_band) > 1 else {}), **per_band}, title=what)
        page.write(report)
    if args.json:
        d = env.to_dict()
        d["bands"] = {b: l.to_dict()["a_lim_m"] for b, l in per_band.items()} if len(per_band) > 1 else None
        d["stable_to_m"] = depth_max   # what a null a_lim_m means: stable at every depth searched
        print_json(d)
        return 0
    print(f"{what}: {args.method.upper()} lobes, {len(speeds)} speeds {speeds[0]:.0f}-{speeds[-1]:.0f} rev/min, "
          f"depths to {1e3 * depth_max:g} mm")
    ext = env.extremes()
    if ext is not None:
        print(f"  lowest critical depth {1e3 * ext[1]:.3f} mm at {ext[0]:.0f} rev/min; largest {1e3 * ext[2]:.3f} mm")
    else:
        print("  no unstable depth in the range")
    for v, a in zip(*env.table()):
        print(f"  {v:8.0f} rev/min  a_lim {'> range' if not np.isfinite(a) else f'{1e3 * a:7.3f} mm'}")
    if args.out:
        print(f"wrote {args.out}")
    if report:
        print(f"wrote {report}")
    return 0


def register_mill(sub) -> None:
    p = sub.add_parser("mill", help="virtual milling in MuJoCo on a grid of speeds and depths; chatter verdicts")
    p.add_argument("--robot", default="irb6660", help="bundled robot name or MJCF path (default irb6660)")
    p.add_argument("--tool", default="endmill", help="tool (default endmill)")
    p.add_argument("--posture", default="1800,200,0", help="x,y,theta in mm, mm, degrees")
    p.add_argument("--speeds", required=True, help="spindle speeds in rev/min, comma-separated")
    p.add_argument("--depths", required=True, help="axial depths in mm, comma-separated")
    p.add_argument("--cutting", default=None, help="K_t,K_n (N/mm²),teeth,immersion,down|up (default Al 6061 slot)")
    p.add_argument("--periods", type=int, default=90, help="tooth periods per cut (default 90)")
    p.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    p.add_argument("--out", help="results as JSON lines; rerunning with the same file resumes")
    p.add_argument("--json", action="store_true",
                   help="print the runs as JSON (a runaway cut's metric and growth are null: unbounded)")
    p.set_defaults(func=cmd_mill)


def _numbers(text, what, scale=1.0):
    try:
        vals = [scale * float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise InputError(f"--{what} must be comma-separated numbers, got {text!r}") from None
    if not vals or any(not (v > 0 and np.isfinite(v)) for v in vals):
        raise InputError(f"--{what} must be positive numbers, got {text!r}")
    return np.array(vals)


def cmd_mill(args) -> int:
    from rmbench.robot import parse_posture
    from rmbench.stability import ALUMINIUM_6061
    from rmbench.stability.milling import mill_grid

    speeds = _numbers(args.speeds, "speeds")
    depths = _numbers(args.depths, "depths", 1e-3)
    if args.periods < 12:
        raise InputError(f"--periods must be at least 12, got {args.periods}")
    if args.workers < 1:
        raise InputError(f"--workers must be at least 1, got {args.workers}")
    cutting = _cutting(args.cutting, ALUMINIUM_6061)
    runs = mill_grid(args.robot, args.tool, parse_posture(args.posture), cutting, speeds, depths,
                     workers=args.workers, out=args.out, progress=not args.json, periods=args.periods)
    if args.json:
        print_json([r.to_dict() for r in runs])
        return 0
    print(f"{'rev/min':>8} {'depth mm':>9} {'verdict':>8} {'growth':>7} {'off-harm.':>9} {'p-p um':>8}")
    for r in runs:
        print(f"{r.rpm:>8.0f} {1e3 * r.depth:>9.3f} {r.kind:>8} {r.growth:>7.2f} {r.off_harmonic:>9.2f} "
              f"{1e6 * r.amplitude:>8.1f}")
    if args.out:
        print(f"wrote {args.out}")
    return 0
