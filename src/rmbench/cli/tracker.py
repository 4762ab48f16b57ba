"""``rmbench tracker`` and ``rmbench invalidate`` (laser-tracker campaigns, model invalidation).

Lengths on the command line and in printed tables are in mm (η, repeatability, errors); files and
JSON keep SI (m), as everywhere in rmbench.
"""

from __future__ import annotations

import math
import time

from rmbench.cli._common import add_report_option, command_group, print_json, report_path
from rmbench.errors import InputError

__all__ = ["register"]

MM = 1e-3


def register(sub) -> None:
    """Register the ``tracker`` and ``invalidate`` commands on the argparse subparsers ``sub``."""
    tsub = command_group(sub, "tracker", "simulated laser-tracker campaigns")
    run = tsub.add_parser("run", help="simulate a tracker campaign and write its readings as CSV")
    run.add_argument("config", help="campaign TOML file (SI units; see rmbench.tracker.CampaignConfig)")
    run.add_argument("--out", required=True, help="CSV file for the readings")
    run.add_argument("--json", action="store_true", help="print a JSON summary")
    run.set_defaults(func=cmd_tracker_run)

    isub = command_group(sub, "invalidate", "model invalidation (METHODS.md §7)")
    r = isub.add_parser("run", help="sequential invalidation test against the simulated tracker")
    r.add_argument("--robot", default="mh180", help="bundled robot name or MJCF path (default mh180)")
    r.add_argument("--config", default=None, help="campaign TOML (overrides the defaults; --robot "
                                                 "and --seed override it)")
    r.add_argument("--seed", type=int, default=None, help="campaign seed (default 0)")
    _add_test_options(r)
    r.add_argument("--refit-frames", action="store_true",
                   help="re-fit base and tool frames after each measurement, as the seed did")
    r.add_argument("--level", action="store_true",
                   help="also search the smallest eta not rejected")
    r.add_argument("--plot", default=None, metavar="PNG", help="write the measured errors (seed Fig. 7)")
    add_report_option(r, "the measured errors per location (seed Fig. 7) and the verdict")
    r.set_defaults(func=cmd_invalidate_run)

    rd = isub.add_parser("readings", help="judge readings already taken (no new measurements)")
    rd.add_argument("csv", help="readings CSV (rmbench.io.tracker_csv columns)")
    _add_test_options(rd, cap_default=None)
    rd.add_argument("--robot", default="mh180",
                    help="robot whose nominal kinematics give σ and the tool frame (default mh180)")
    rd.add_argument("--repeatability", type=float, default=0.2,
                    help="rated ISO 9283 RP in mm, when the CSV has no sigma columns (default 0.2)")
    rd.add_argument("--no-register", action="store_true",
                    help="take errors as measured minus nominal, without the best-fit registration")
    rd.set_defaults(func=cmd_invalidate_readings)

    b = isub.add_parser("benchmark", help="reproduce the seed's Table 1 (1-D benchmark)")
    b.add_argument("--seeds", type=int, default=5, help="number of seeds averaged (default 5)")
    b.add_argument("--json", action="store_true", help="print JSON instead of a table")
    b.set_defaults(func=cmd_invalidate_benchmark)


def _add_test_options(p, *, cap_default: int | None = 10) -> None:
    p.add_argument("--eta", type=float, required=True, help="accuracy level η, mm")
    p.add_argument("--alpha", type=float, default=0.9, help="confidence level α in (0, 1) (default 0.9)")
    p.add_argument("--max-per-location", type=int, default=cap_default,
                   help="cap of measurements per location (default "
                        f"{cap_default if cap_default else 'none'})")
    p.add_argument("--on-cap", choices=("skip", "reject"), default="skip",
                   help="worst location at its cap: re-measure the next worst (skip, default) or "
                        "reject at once (reject)")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")


def cmd_tracker_run(args) -> int:
    from rmbench.io.tracker_csv import write_tracker_csv
    from rmbench.tracker import CampaignConfig, TrackerCampaign

    config = CampaignConfig.from_toml(args.config)
    camp = TrackerCampaign.build(config)
    readings = camp.readings(camp.rng(10))
    write_tracker_csv(args.out, readings)
    ident = camp.identification_summary()
    summary = {"out": args.out, "robot": camp.robot.name, "seed": config.seed,
               "n_readings": len(readings.location), "n_locations": len(camp.q_validation),
               "identification_mean": ident["mean"], "identification_max": ident["max"],
               "units": "m"}
    if args.json:
        print_json(summary)
        return 0
    print(f"{camp.robot.name}: {summary['n_readings']} readings at {summary['n_locations']} "
          f"configurations written to {args.out}")
    if ident["n"]:
        print(f"model under test: calibrated on {ident['n']} configurations, identification-set "
              f"error mean {ident['mean'] / MM:.3f} mm, max {ident['max'] / MM:.3f} mm")
    return 0


def cmd_invalidate_run(args) -> int:
    from rmbench.tracker import CampaignConfig, TrackerCampaign, accuracy_level, invalidate

    eta = _eta_m(args.eta)
    report = report_path(args)
    config = CampaignConfig.from_toml(args.config) if args.config else CampaignConfig()
    overrides = {"robot": args.robot}
    if args.seed is not None:
        overrides["seed"] = args.seed
    config = CampaignConfig.from_dict({**_as_dict(config), **overrides})
    camp = TrackerCampaign.build(config)
    q = camp.q_validation
    sigma = camp.sigma(q)
    correct = camp.frame_refit(q) if args.refit_frames else None
    cap = args.max_per_location
    result = invalidate(camp.error_meter(camp.rng(1)), q, sigma, eta, args.alpha, cap,
                        on_cap=args.on_cap, correct=correct)
    level = None
    if args.level:
        level = accuracy_level(camp.error_meter(camp.rng(2)), q, sigma, args.alpha, cap,
                               on_cap=args.on_cap, eta_start=eta,
                               correct=camp.frame_refit(q) if args.refit_frames else None)
    if args.plot:
        result.plot(args.plot, scale=1e3, unit="mm")
    if report:
        from rmbench.report import Page
        from rmbench.report.tracker import invalidation_sections

        page = Page(f"Model invalidation, {camp.robot.name}", {"robot": camp.robot.name, "seed": config.seed,
                                                              "config": args.config or "defaults"})
        invalidation_sections(page, result)
        page.write(report)
        if not args.json:
            print(f"wrote {report}")
    if args.json:
        out = {"robot": camp.robot.name, "seed": config.seed, "units": "m", **result.to_dict()}
        if level is not None:
            out["accuracy_level"] = level.to_dict()
        print_json(out)
        return 0
    print(f"{camp.robot.name} (seed {config.seed}): model under test calibrated on "
          f"{config.n_identification} configurations; {len(q)} validation configurations")
    print(f"H0 |e| <= {args.eta:g} mm at alpha = {args.alpha:g}: {result.verdict.upper()} "
          f"(P* = {result.p_star:.4f}, stop: {result.stop})")
    print(f"measurements: {result.n_measurements} at {result.n_explored} configurations; "
          f"re-measured: {', '.join(str(j) for j in result.remeasured) or 'none'}")
    if level is not None:
        print(f"smallest eta not rejected: {level.eta / MM:.4f} mm "
              f"({level.final.n_measurements} measurements in that test, {len(level.tested)} tests)")
    return 0


def cmd_invalidate_readings(args) -> int:
    from rmbench.io.tracker_csv import read_tracker_csv
    from rmbench.tracker import judge_readings, reading_errors

    eta = _eta_m(args.eta)
    readings = read_tracker_csv(args.csv)
    if readings.nominal is None:
        raise InputError(f"{args.csv}: judging readings needs the model's predictions "
                         f"(columns x_nom, y_nom, z_nom)")
    sigma, rotations = readings.sigma, None
    if sigma is None or not args.no_register:
        sigma_rob, rotations = _robot_model(args, readings)
        sigma = sigma if sigma is not None else sigma_rob
    errors = reading_errors(readings.measured, readings.nominal, rotations, sigma, register=not args.no_register)
    verdict = judge_readings(readings.location, errors, sigma, eta, args.alpha,
                             args.max_per_location)
    if args.json:
        print_json({"csv": args.csv, "units": "m", **verdict.to_dict()})
        return 0
    res = verdict.result
    print(f"{args.csv}: {res.n_measurements} readings at {len(verdict.labels)} locations")
    print(f"H0 |e| <= {args.eta:g} mm at alpha = {args.alpha:g}: {res.verdict.upper()} "
          f"(P* = {res.p_star:.4f})")
    if len(verdict.to_remeasure):
        marks = [f"{lab}{' (at cap)' if cap else ''}"
                 for lab, cap in zip(verdict.to_remeasure, verdict.at_cap)]
        print("the sequential procedure would re-measure, worst first: " + ", ".join(marks))
        print("conclusive: " + ("yes, every one is at the cap: rejected" if verdict.conclusive
                                else "no, re-measure them to decide"))
    label, error = verdict.worst_location()
    print(f"largest location mean error {error / MM:.4f} mm at location {label}")
    return 0


def cmd_invalidate_benchmark(args) -> int:
    from rmbench.tracker import METHODS, SEED_TABLE1, table1

    if args.seeds < 1:
        raise InputError(f"--seeds must be >= 1, got {args.seeds}")
    t0 = time.perf_counter()
    table = table1(seeds=range(args.seeds))
    seconds = time.perf_counter() - t0
    out = table.to_dict()       # the means over seeds, per method and noise level
    if args.json:
        out["seed_table1"] = {k: list(v) for k, v in SEED_TABLE1.items()}
        out["seconds"] = seconds
        print_json(out)
        return 0
    noise = out["noise"]
    print(f"Table 1: identified accuracy of e = sin(2π(q + 0.1)) (true 1.0), mean of {args.seeds} "
          f"seeds; rmbench / seed")
    print(f"{'method':<20}" + "".join(f"{'noise ' + format(s, 'g'):>16}" for s in noise))
    for m in METHODS:
        seed = dict(zip(SEED_TABLE1["noise"], SEED_TABLE1[m]))
        cells = "".join(f"{a:>9.3f} / {seed.get(s, math.nan):<4.2f}" for s, a in zip(noise, out[m]))
        print(f"{m.replace('_', ' ').title():<20}{cells}")
    print(f"({seconds:.1f} s; model invalidation: search {table.settings['search']}, "
          f"on_cap {table.settings['on_cap']})")
    return 0


def _eta_m(eta_mm: float) -> float:
    if not (math.isfinite(eta_mm) and eta_mm >= 0):
        raise InputError(f"--eta must be a finite accuracy level >= 0 in mm, got {eta_mm!r}")
    return eta_mm * MM


def _as_dict(config) -> dict:
    from dataclasses import fields

    return {f.name: getattr(config, f.name) for f in fields(config)}


def _robot_model(args, readings):
    """σ per reading (repeatability through the nominal Jacobian + tracker noise) and nominal
    TCP orientations, from the robot's nominal kinematics at the readings' joint angles."""
    from rmbench.robot import Robot
    from rmbench.tracker import SerialChain
    from rmbench.tracker.simulator import reading_sigma

    if not (math.isfinite(args.repeatability) and args.repeatability > 0):
        raise InputError(f"--repeatability must be > 0 mm, got {args.repeatability!r}")
    robot = Robot.load(args.robot)
    chain = SerialChain.from_kinematics(robot.kinematics, robot.arm_joints)
    if len(readings.joints) != chain.n_joint:
        raise InputError(f"the readings have {len(readings.joints)} joint columns, robot "
                         f"{robot.name} has {chain.n_joint} arm joints")
    sigma = reading_sigma(robot, readings.q, readings.measured, repeatability=args.repeatability * MM)
    return sigma, chain.pose(readings.q)[1]
