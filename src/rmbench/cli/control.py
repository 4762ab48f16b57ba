"""``rmbench control``: design H∞ proof-mass controllers, run them closed loop, tuning runs.

Joint angles on the command line are in degrees; files and JSON are SI (N, m, m/s², Hz).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rmbench.cli._common import (add_report_option, add_robot_options, command_group, load_robot, print_json,
                                 report_path, resolve_posture)
from rmbench.errors import InputError

__all__ = ["register"]

# --material: the stability stage's cuts (rmbench.stability) by name
CUTS = {"steel": "STEEL_C45", "titanium": "TI6AL4V", "aluminium": "ALUMINIUM_6061"}


def register(sub) -> None:
    csub = command_group(sub, "control", "H-infinity proof-mass vibration suppression (METHODS.md §8)")

    d = csub.add_parser("design", help="design a controller and save it (npz + JSON metadata)")
    _robot(d)
    d.add_argument("--axes", default="tangential", help="comma-separated: tangential, axial, radial")
    d.add_argument("--mimo", action="store_true", help="one joint design of all axes (default: one SISO loop per axis)")
    d.add_argument("--modified", action="store_true",
                   help="take out the controller's resonance/anti-resonance pair at the mode (seed)")
    d.add_argument("--plant", choices=("exact", "measured"), default="exact",
                   help="plant from the exact linearisation, or from a simulated shaker FRF measurement (SISO)")
    d.add_argument("--order", type=int, default=None, help="controller states after balanced truncation "
                                                          "(default 12, plus 8 per further axis of a MIMO design)")
    d.add_argument("--set", default=None, metavar="NAME=VALUE,...",
                   help="weights to change, e.g. k_a=60,zeta_w=0.3 (rmbench.control.Weights)")
    d.add_argument("--schedule", default=None, metavar="GRID.toml",
                   help="design one controller per posture of this grid (see rmbench.control.grid), blended "
                        "on the posture; the plants come from --from, else from --robot's linearisation")
    d.add_argument("--from", dest="campaign", default=None, metavar="CAMPAIGN.nc",
                   help="with --schedule: the shaker campaign of 'rmbench control measure' (no robot model read)")
    d.add_argument("--robust", type=int, default=0, metavar="N",
                   help="with --from: also certify the sampled loop on N plants drawn from each posture's fit "
                        "(its parameter covariance; 59 draws bound P(unstable) by 5 %% at 95 %% confidence)")
    d.add_argument("--out", required=True, help="controller file (.npz)")
    d.add_argument("--json", action="store_true")
    d.set_defaults(func=cmd_design)

    ms = csub.add_parser("measure", help="shaker tests at every posture of a schedule grid (the design's campaign)")
    _robot(ms)
    ms.add_argument("--schedule", required=True, metavar="GRID.toml", help="grid file, or a bundled grid's name")
    ms.add_argument("--seed", type=int, default=0, help="seed of the random forces and sensor noise")
    ms.add_argument("--out", required=True, metavar="CAMPAIGN.nc")
    ms.add_argument("--json", action="store_true")
    ms.set_defaults(func=cmd_measure)

    r = csub.add_parser("run", help="run a controller closed loop in MuJoCo (sine sweep or eccentric mass)")
    r.add_argument("controller", help="controller file from 'rmbench control design'")
    _robot(r)
    r.add_argument("--test", choices=("sweep", "eccentric"), default="sweep")
    r.add_argument("--trajectory", default=None, metavar="TRAJ.csv",
                   help="move the arm along this joint trajectory (t_s, q1_deg ... columns; or move_j2j3, bundled) "
                        "under a random force on the first axis's disturbance coil, uncontrolled and controlled "
                        "(a schedule needs one)")
    r.add_argument("--force-rms", type=float, default=10.0, help="--trajectory: random force, N rms (default 10)")
    r.add_argument("--disturbance", choices=("random", "eccentric", "milling"), default="random",
                   help="--trajectory: what shakes the moving arm: the random force (default), the spindle's "
                        "eccentric mass at --rpm, or a rigid tool's cutting force (--material, --rpm, --depth) "
                        "on the first axis's disturbance coil")
    r.add_argument("--rpm", type=float, default=None, help="eccentric, milling: spindle speed, rev/min")
    r.add_argument("--material", choices=tuple(CUTS), default="steel",
                   help="milling: the cut (steel: C45, 6 teeth at half immersion; titanium: Ti-6Al-4V, 4 teeth "
                        "at half immersion; aluminium: 6061, 2-tooth slot); default steel")
    r.add_argument("--depth", type=float, default=None, help="milling: axial depth of cut, mm")
    r.add_argument("--feed-per-tooth", type=float, default=0.05, help="milling: mm (default 0.05)")
    r.add_argument("--runout", type=float, default=0.0,
                   help="milling: one tooth's radial runout, µm (default 0): a force line at the spindle speed")
    r.add_argument("--force-component", choices=("feed", "normal"), default="feed",
                   help="milling: the cutting force's component the coil applies (default feed)")
    r.add_argument("--axis", default=None, help="sweep: the disturbed axis (default the controller's first)")
    r.add_argument("--amplitude", type=float, default=20.0, help="sweep: sine amplitude, N (default 20)")
    r.add_argument("--freqs", default=None, metavar="F1,F2,...",
                   help="excitation frequencies or spindle speeds, Hz (default: 2-20 Hz, dense at the modes)")
    r.add_argument("--workers", type=int, default=None,
                   help="local worker processes (default: all cores; 0 runs here)")
    r.add_argument("--scheduler", default=None, help="address of an existing dask scheduler")
    r.add_argument("--plot", default=None, metavar="PNG", help="uncontrolled vs controlled sensitivity")
    r.add_argument("--out", default=None, metavar="NC", help="write both runs as netCDF")
    r.add_argument("--json", action="store_true")
    add_report_option(r, "sensitivity, stroke and force use, time traces at the mode and the controller")
    r.set_defaults(func=cmd_run)

    t = csub.add_parser("tune", help="tuning run: weights x postures from a TOML file, in parallel")
    t.add_argument("config", help="TOML file (see rmbench.control.tune)")
    t.add_argument("--workers", type=int, default=None)
    t.add_argument("--scheduler", default=None)
    t.add_argument("--out", default=None, metavar="NC", help="write the table as netCDF")
    t.add_argument("--json", action="store_true")
    t.set_defaults(func=cmd_tune)


def _robot(p):
    add_robot_options(p)
    p.set_defaults(robot="mh180")


def _operating_point(args):
    robot = load_robot(args)
    q = resolve_posture(robot, args)
    if not isinstance(q, np.ndarray):
        q = robot.ik(q).q
    return robot.at(q)


def _weights(spec):
    from rmbench.control import Weights

    if not spec:
        return Weights()
    changes = {}
    for item in spec.split(","):
        name, _, value = item.partition("=")
        try:
            changes[name.strip()] = float(value)
        except ValueError:
            raise InputError(f"--set: {item!r} is not NAME=NUMBER") from None
    return Weights().with_(**changes)


def cmd_design(args) -> int:
    from rmbench.control import Controller
    from rmbench.control.axes import design_axes

    if args.schedule or args.campaign:
        return _design_schedule(args)
    if args.robust:
        raise InputError("--robust certifies a schedule designed from a campaign: give --schedule and --from")

    weights = _weights(args.set)
    op = _operating_point(args)
    d = design_axes(op, args.axes, weights, mimo=args.mimo, plant=args.plant, order=args.order,
                    modified=args.modified)
    c = d.controller
    ctrl = Controller(c.axes, c.A, c.B, c.C, c.D, dict(c.meta, robot=args.robot))
    ctrl.save(args.out)
    gammas, modes = list(d.gammas), list(d.mode_hz)
    summary = {"out": str(args.out), "axes": list(ctrl.axes), "structure": d.structure, "order": ctrl.order,
               "gamma": gammas, "mode_hz": modes, "modified": args.modified, "plant": args.plant}
    if args.json:
        print_json(summary)
    else:
        print(f"{d.structure} controller for {', '.join(ctrl.axes)}: order {ctrl.order}, gamma "
              f"{', '.join(f'{g:.3g}' for g in gammas)}, modes {', '.join(f'{f:.2f}' for f in modes)} Hz")
        print(f"wrote {args.out}")
    return 0


def _design_schedule(args) -> int:
    import time
    from dataclasses import replace

    from rmbench.control.grid import load_schedule_grid, plants_from_campaign, plants_from_model
    from rmbench.control.schedule import certify, design_schedule

    if not args.schedule:
        raise InputError("--from needs --schedule GRID.toml (the grid the campaign was measured on)")
    if args.robust < 0:
        raise InputError(f"--robust takes a number of draws >= 0, got {args.robust}")
    if args.robust and not args.campaign:
        raise InputError("--robust needs --from CAMPAIGN.nc: the draws come from the measured fits' covariance")
    grid = load_schedule_grid(args.schedule)
    robot = load_robot(argparse_robot(args, grid))
    t0 = time.perf_counter()
    if args.campaign:
        from rmbench.impact.dataset import open_campaign

        measured, plants = plants_from_campaign(open_campaign(args.campaign))
        if measured.joints != grid.joints or measured.axes != grid.axes:
            raise InputError(f"{args.campaign} was measured on another grid or axes ({dict(measured.joints)}, "
                             f"{list(measured.axes)}) than {args.schedule}")
        source = str(args.campaign)
    else:
        plants = plants_from_model(robot, grid)
        source = f"model {args.robot}"
    idx, g, hold, q_ref = grid.resolve(robot)
    reach, span = grid.limits(robot)
    sch = design_schedule(plants, g, idx, q_ref, hold=hold, weights=_weights(args.set), order=args.order,
                          mimo=grid.mimo, progress=None if args.json else _dots(len(plants)), reach=reach, span=span)
    from rmbench.control.closed_loop import Hardware

    # certified on the loop the hardware runs (2 kHz, its delay, hold and amplifier), not the continuous one
    cert = certify(sch, plants, hardware=Hardware())
    robust = _robust(args, sch, plants, Hardware())
    seconds = time.perf_counter() - t0
    sch = replace(sch, meta=dict(sch.meta, source=source, robot=args.robot, certificate=cert.headline(),
                                 **({} if robust is None else {"robust_certificate": robust.headline()})))
    sch.save(args.out)
    modes = [c.meta["mode_hz"] for c in sch.controllers]
    summary = {"out": str(args.out), "axes": list(sch.axes), "structure": sch.meta["structure"],
               "joints": list(grid.joints), "grid_shape": list(sch.shape), "source": source,
               "mode_hz": modes, "gamma": [c.meta["gamma"] for c in sch.controllers],
               "certificate": sch.meta["certificate"], "seconds": seconds,
               "reach_deg": grid.reach, "span_deg": grid.span,
               "robust_certificate": None if robust is None else robust.to_dict()}
    if args.json:
        print_json(summary)
    else:
        print(f"\n{sch.meta['structure']} schedule over {' x '.join(str(n) for n in sch.shape)} postures of "
              f"{', '.join(grid.joints)} from {source}: modes " +
              ", ".join(f"{a} {lo:.2f}-{hi:.2f} Hz" for a, (lo, hi) in zip(sch.axes, sch.mode_range()))
              + f" ({seconds:.1f} s)")
        c = sch.meta["certificate"]
        print(f"certificate of the sampled loop (2 kHz, delay, hold, amplifier) on the design plants ({c['points']} "
              f"postures, grid and between): {'stable' if c['stable'] else 'UNSTABLE'}, largest spectral radius "
              f"{c['max_spectral_radius']:.6f}, smallest loop margin {c['min_margin']:.3f}")
        if grid.reach is not None or grid.span is not None:
            print("vouches for: " + ("any posture past the grid (its edge held)" if grid.reach is None
                                      else f"{grid.reach:g} deg beyond the grid")
                  + ("" if grid.span is None else "; " + ", ".join(f"{j} +-{v:g} deg" for j, v in grid.span.items())
                     + " (other joints at the schedule's posture)") + "; other postures are refused")
        if robust is not None:
            print(robust.summary())
        print(f"wrote {args.out}")
    return 0 if cert.stable and (robust is None or robust.stable) else 1


def _robust(args, sch, plants, hardware):
    """The schedule's robust certificate over ``args.robust`` draws of each grid posture's fit, or
    None where not asked for."""
    if not args.robust:
        return None
    from rmbench.control.robust import certify_schedule_robust, measured_modes

    modes = [measured_modes(p) for p in plants]
    return certify_schedule_robust(sch, [m[0] for m in modes], modes[0][1], hardware, draws=args.robust)


def argparse_robot(args, grid):
    """``args`` with the grid's robot where the command line left the default."""
    if args.robot == "mh180" and grid.robot != "mh180":
        args.robot = grid.robot
    return args


def _dots(n):
    import sys

    def tick(i):
        sys.stderr.write(f"\rdesigning {i + 1}/{n}")
        sys.stderr.flush()
    return tick


def cmd_measure(args) -> int:
    import sys

    from rmbench.control.grid import load_schedule_grid, measure_campaign
    from rmbench.impact.dataset import save

    grid = load_schedule_grid(args.schedule)
    robot = load_robot(argparse_robot(args, grid))
    n = len(grid.postures(robot)[0])

    def tick(i):
        if not args.json:
            sys.stderr.write(f"\rshaker tests: posture {i + 1}/{n}")
            sys.stderr.flush()
    ds = measure_campaign(robot, grid, seed=args.seed, progress=tick)
    save(ds, args.out)
    summary = {"out": str(args.out), "postures": n, "axes": list(grid.axes), "robot": robot.name,
               "duration_s": grid.duration}
    if args.json:
        print_json(summary)
    else:
        print(f"\n{n} postures x {len(grid.axes)} shaker tests of {grid.duration:g} s; wrote {args.out}")
    return 0


def _load_any(path):
    """A controller or a schedule file."""
    import json

    from rmbench.control import Controller
    from rmbench.control.schedule import Schedule

    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
    except FileNotFoundError:
        raise InputError(f"no controller file {path}") from None
    except (OSError, ValueError, KeyError) as exc:
        raise InputError(f"{path} is not an rmbench controller file ({exc})") from None
    return Schedule.load(path) if "rmbench_schedule_version" in meta else Controller.load(path)


def _run_moving(args, ctrl) -> int:
    from rmbench.control.moving import moving_figures, moving_test
    from rmbench.control.trajectory import load_trajectory

    robot = load_robot(args)
    path = Path(args.trajectory)
    bundled = Path(__file__).parents[1] / "control" / "configs" / f"{args.trajectory}.csv"
    if path.suffix != ".csv" and bundled.exists():
        path = bundled  # a bundled move by name (move_j2j3)
    traj = load_trajectory(path, len(robot.arm_joints))
    op = robot.at(traj.q[0])
    if args.force_rms <= 0:
        raise InputError(f"--force-rms must be positive, got {args.force_rms}")
    ds = moving_test(op, {"controlled": ctrl}, traj, axis=ctrl.axes[0], force_rms=args.force_rms,
                     **_moving_disturbance(args))
    result = {"trajectory": str(args.trajectory), "duration_s": float(traj.t[-1]), "axis": ctrl.axes[0],
              "disturbance": ds.attrs["label"], **moving_figures(ds, "controlled")}
    if args.out:
        from rmbench.impact.dataset import save

        save(ds, args.out)
    if args.json:
        print_json(result)
        return 0
    shaken = (f"random force {args.force_rms:g} N rms on the {result['axis']} coil" if args.disturbance == "random"
              else result["disturbance"])
    print(f"{result['duration_s']:.1f} s along {args.trajectory}, {shaken}")
    print(f"{'t, s':>6} {'mode, Hz':>9} {'reduction':>10}")
    for w in result["windows"]:
        print(f"{w['t_s']:6.1f} {w['mode_hz']:9.2f} {100 * w['reduction']:9.1f}%")
    print(f"over the move: reduction {100 * result['reduction']:.1f} % at the mode; loudest 0.25 s "
          f"{result['transient']:.2f} of the uncontrolled level; stroke used {100 * result['stroke_used']:.0f} %, "
          f"saturated {100 * result['saturated']:.1f} % of samples ({result['saturation_events']} saturation "
          f"event(s)), stroke guard tripped {result['guard_trips']} "
          f"time(s); {result['realtime_factor']:.1f}x real time")
    return 0


def _moving_disturbance(args) -> dict:
    """``moving_test``'s disturbance arguments from ``--disturbance`` and its options (rev/min, mm
    and µm here; rev/s and m there)."""
    kind = args.disturbance
    given = [f"--{k.replace('_', '-')}" for k, default in (("rpm", None), ("depth", None), ("runout", 0.0))
             if getattr(args, k) != default]
    if kind == "random":
        if given:
            raise InputError(f"{', '.join(given)}: only with --disturbance eccentric or milling")
        return {}
    if args.rpm is None or not (np.isfinite(args.rpm) and args.rpm > 0):
        raise InputError(f"--disturbance {kind} needs a positive spindle speed --rpm (rev/min), got {args.rpm}")
    if kind == "eccentric":
        if args.depth is not None or args.runout != 0.0:
            raise InputError("--depth and --runout: only with --disturbance milling")
        return {"disturbance": "none", "spindle_hz": args.rpm / 60.0,
                "label": f"spindle's eccentric mass at {args.rpm:g} rev/min"}
    from rmbench import stability

    if args.depth is None or not (np.isfinite(args.depth) and args.depth > 0):
        raise InputError(f"--disturbance milling needs a positive axial depth --depth (mm), got {args.depth}")
    if not (np.isfinite(args.feed_per_tooth) and args.feed_per_tooth > 0):
        raise InputError(f"--feed-per-tooth must be positive (mm), got {args.feed_per_tooth}")
    if not (np.isfinite(args.runout) and args.runout >= 0):
        raise InputError(f"--runout must be ≥ 0 (µm), got {args.runout}")
    cut, column = getattr(stability, CUTS[args.material]), ("feed", "normal").index(args.force_component)

    def force(t):
        return stability.cutting_force(cut, args.rpm, args.depth * 1e-3, t, feed_per_tooth=args.feed_per_tooth * 1e-3,
                             runout=args.runout * 1e-6)[:, column]

    return {"disturbance": force,
            "label": f"milling {args.material} at {args.rpm:g} rev/min, {args.depth:g} mm deep, "
                     f"{args.feed_per_tooth:g} mm/tooth, runout {args.runout:g} µm: its {args.force_component} "
                     "force on the disturbance coil"}


def cmd_run(args) -> int:
    from rmbench.control import Controller
    from rmbench.control.suppression import suppression_test

    report = report_path(args)
    ctrl = _load_any(args.controller)
    if args.trajectory:
        return _run_moving(args, ctrl)
    if args.disturbance != "random":
        raise InputError(f"--disturbance {args.disturbance} shakes a moving arm: give it a --trajectory")
    if not isinstance(ctrl, Controller):
        raise InputError(f"{args.controller} is a posture schedule: run it along a move with --trajectory TRAJ.csv")
    op = _operating_point(args)
    freqs = _freqs(args.freqs)
    if args.test == "sweep" and (args.axis or ctrl.axes[0]) not in ctrl.axes:
        raise InputError(f"--axis {args.axis!r}: the controller drives {', '.join(ctrl.axes)}")
    run = suppression_test(op, ctrl, args.test, freqs, axis=args.axis, amplitude=args.amplitude,
                           workers=args.workers, scheduler=args.scheduler, progress=not args.json)
    if args.out:
        from rmbench.impact.dataset import save

        save(run.to_dataset(), args.out)
    if args.plot:
        from rmbench.control.plot import plot_sensitivity

        plot_sensitivity(run.runs, args.plot, title=f"{args.test}: {', '.join(ctrl.axes)} controller")
    if report:
        _run_report(args, op, ctrl, run, report)
        if not args.json:
            print(f"wrote {report}")
    if args.json:
        print_json(run.to_dict())
    else:
        print(run.summary())
    return 0


def _freqs(text):
    """``--freqs F1,F2,...`` as a list of positive frequencies, Hz (None where not given)."""
    if not text:
        return None
    try:
        freqs = [float(v) for v in text.split(",")]
    except ValueError:
        raise InputError(f"--freqs must be comma-separated numbers, got {text!r}") from None
    if any(f <= 0 for f in freqs):
        raise InputError("--freqs must be positive")
    return freqs


def _run_report(args, op, ctrl, run, report) -> None:
    """The HTML page of a suppression test: sensitivity, stroke and force use, and time traces of both
    runs at the first axis's mode."""
    from rmbench.control.experiments import traced_runs
    from rmbench.report import Page
    from rmbench.report.control import control_sections

    traces, f0 = None, None
    if run.axes:
        f0 = run.mode_hz[0]
        traces = traced_runs(op, ctrl, run.axes[0] if args.test == "sweep" else None, f0, amplitude=args.amplitude)
    page = Page(f"Proof-mass suppressor: {args.test} test", {
        "controller": args.controller, "robot": args.robot, "test": args.test,
        "reduction": ", ".join(f"{a}: {100 * r:.1f} % at {f:.2f} Hz"
                               for a, f, r in zip(run.axes, run.mode_hz, run.reduction)),
        "time traces": f"{'sine' if args.test == 'sweep' else 'eccentric mass'} at {f0:.2f} Hz" if traces else "none"})
    control_sections(page, run.runs, controller=ctrl, traces=traces)
    page.write(report)


def cmd_tune(args) -> int:
    from rmbench.control.tune import load_tune_config, tune, tune_table

    cfg = load_tune_config(args.config)
    ds = tune(cfg, workers=args.workers, scheduler=args.scheduler, progress=not args.json)
    if args.out:
        from rmbench.impact.dataset import save

        save(ds.drop_vars("reason"), args.out)
    rows = tune_table(ds, cfg)
    if args.json:
        print_json({"cases": rows, "mode_ratios": list(cfg.mode_ratios)})
        return 0
    print(f"{len(rows)} cases, postures with the mode at x{', x'.join(str(r) for r in cfg.mode_ratios)}:")
    print(f"{'case':>4}  {'weights':<32} {'min red.':>8} {'stable':>6} {'amp dB':>7} {'stroke':>7} {'force N':>8}")
    for i, r in enumerate(rows):
        w = ",".join(f"{k}={v:g}" for k, v in r["weights"].items()) or "defaults"
        red = f"{100 * r['reduction_min']:.1f}%" if r["reduction_min"] is not None else "-"
        print(f"{i:>4}  {w:<32} {red:>8} {str(r['stable_all']):>6} {r['amplification_db_max']:7.2f} "
              f"{100 * r['stroke_used_max']:6.0f}% {r['force_max']:8.1f}" + (f"  {r['reason']}" if r["reason"] else ""))
    return 0
