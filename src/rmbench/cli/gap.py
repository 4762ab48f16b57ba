"""``rmbench gap diagnose`` and ``rmbench gap blind``: sim-to-real gap diagnosis on FRF data and on
laser-tracker readings."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

from rmbench.cli._common import add_report_option, command_group, print_json, read_test_design, report_path
from rmbench.errors import InputError

__all__ = ["register"]


def register(sub) -> None:
    g = command_group(sub, "gap", "sim-to-real gap diagnosis: where the model departs, which effect, how far it shrinks")
    d = g.add_parser("diagnose", help="diagnose measured FRFs or tracker readings against a nominal model")
    d.add_argument("--robot", default=None,
                   help="nominal robot: bundled name or MJCF path (default irb6660 for FRFs, mh180 for readings)")
    d.add_argument("--tool", default=None, help="tool on the nominal robot (default: its own)")
    src = d.add_mutually_exclusive_group(required=True)
    src.add_argument("--data", help="measured FRFs: campaign dataset (netCDF) or UFF58 directory")
    src.add_argument("--readings", help="laser-tracker readings CSV (rmbench.io.tracker_csv columns)")
    d.add_argument("--repeatability", type=float, default=0.2,
                   help="with --readings and no sigma columns: the robot's rated ISO 9283 RP, mm (default 0.2)")
    d.add_argument("--test", default=None, help="campaign TOML of the test design (default: the data's own)")
    d.add_argument("--calibrate", nargs="?", const="default", default=None, metavar="GROUPS",
                   help="calibrate the ordinary parameters first (FRFs: groups as for 'model calibrate', default "
                        "joints,damping,servo,masses; readings: every joint's zero offset, placement and gravity "
                        "compliance and every link's mass), then search the structural effects on the calibrated model")
    d.add_argument("--confirm", type=int, default=4, metavar="N",
                   help="with --calibrate: recalibrate with the best candidate of each of N kinds (tool holder, "
                        "spindle, foundation, a body's mass, a sensor's placement) in place, and once without, "
                        "before calling the gap unexplained (default 4; 0: no recalibration)")
    d.add_argument("--heldout", type=float, default=None, metavar="SHARE",
                   help="share of the postures or configurations held out of every fit (default 0.5)")
    d.add_argument("--p-noise", type=float, default=None, metavar="P",
                   help="a held-out residual whose p-value against the noise falls below P is a gap (default 0.001)")
    d.add_argument("--refine", type=int, default=None, metavar="N",
                   help="candidates refined after each screening (default 6)")
    d.add_argument("--bootstrap", type=int, default=None, metavar="N",
                   help="resamples of the held-out postures for the shrink's interval and the confidences "
                        "(default 400)")
    d.add_argument("--out", default=None, help="directory for figures, tables and the updated variant MJCF")
    d.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")
    d.add_argument("--json", action="store_true", help="print the diagnosis as JSON")
    add_report_option(d, "the verdict, ranked effects, gap maps and before/after overlays")
    d.set_defaults(func=cmd_diagnose)

    b = g.add_parser("blind", help="withheld-effect check: inject hidden effects, diagnose them blind, score")
    b.add_argument("--data", choices=("frf", "tracker"), default="frf",
                   help="kind of data: FRF campaigns (default) or laser-tracker readings")
    b.add_argument("--cases", type=int, required=True, help="number of blind cases")
    b.add_argument("--seed", type=int, default=0)
    b.add_argument("--method", choices=("linear", "time", "mixed"), default="linear",
                   help="campaign method of the cases (mixed: --time-share of them time-domain)")
    b.add_argument("--time-share", type=float, default=0.25, help="share of time-domain cases with --method mixed")
    b.add_argument("--out", default=None,
                   help="JSON-lines file of the cases (resumed if it exists; each finished case is appended)")
    b.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")
    b.add_argument("--scheduler", default=None,
                   help="address of an existing dask scheduler: the cases run on its cluster, one a worker")
    b.add_argument("--json", action="store_true", help="print the summary as JSON")
    b.set_defaults(func=cmd_blind)


def _report(args, dg) -> None:
    """The diagnosis's report, drawn from the result ``dg`` itself."""
    from rmbench.report import Page
    from rmbench.report.gap import gap_sections

    page = Page(f"Gap diagnosis of {Path(args.data or args.readings).name}",
                {"data": args.data or args.readings, "robot": args.robot or "", "tool": args.tool or "",
                 "saved in": args.out or ""})
    gap_sections(page, dg)
    page.write(args.report)
    if not args.json:
        print(f"wrote {args.report}")


def _search_options(args) -> dict:
    """The search settings the command line gave (:class:`rmbench.gap.selection.SearchSettings`;
    the settings check their values)."""
    return {k: v for k, v in (("heldout", args.heldout), ("p_noise", args.p_noise), ("refine", args.refine),
                              ("bootstrap", args.bootstrap)) if v is not None}


def cmd_diagnose(args) -> int:
    report_path(args)
    if args.readings is not None:
        return _diagnose_readings(args)
    from rmbench.calibrate.measured import GapDataWarning
    from rmbench.gap import DiagnosisSettings, diagnose
    from rmbench.robot.parameters import parse_groups

    extra = {}
    if args.calibrate is not None:
        if args.confirm < 0:
            raise InputError(f"--confirm must be 0 or more, got {args.confirm}")
        extra = {"calibrate": parse_groups(args.calibrate), "confirm": args.confirm}
    settings = DiagnosisSettings(**_search_options(args), **extra)

    test = read_test_design(args)
    data = Path(args.data)
    if not data.exists():
        raise InputError(f"data not found: {data}")
    say = (lambda msg: None) if args.json else (lambda msg: print(f"  {msg}", file=sys.stderr))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", GapDataWarning)
        dg = diagnose(args.robot or "irb6660", data, test=test, tool=args.tool, workers=args.workers,
                      settings=settings, progress=say)
    for w in caught:
        if issubclass(w.category, GapDataWarning):
            print(f"rmbench: warning: {w.message}", file=sys.stderr)
    paths = dg.save(args.out) if args.out else {}
    if args.report:
        _report(args, dg)
    if args.json:
        print_json(dg.to_json(paths.get("variant")))
        return 0
    if dg.calibration is not None:
        c = dg.calibration
        ident = [p["name"] for p in c["params"] if p["identifiability"] == "identifiable"]
        h0, h1 = c["heldout_errors"].get("before", {}), c["heldout_errors"].get("after", {})
        print(f"calibrated {len(c['params'])} parameters ({', '.join(c['groups'])}); identifiable: "
              f"{', '.join(ident) or 'none'}")
        if h0 and h1 and h0.get("f_err_mean") is not None:
            print(f"  held-out |f error| mean {100 * h0['f_err_mean']:.2f} % -> {100 * h1['f_err_mean']:.2f} %")
    print(f"verdict: {dg.verdict} ({'calibrated' if dg.calibration is not None else 'nominal'} model's gap: "
          f"χ² {dg.nominal_chi2:.0f} over {dg.n_residuals} normalised residuals)")
    print(f"where: {dg.localisation}")
    if dg.form is not None:
        f = dg.form
        print(f"form: {'wrong' if f['flagged'] else 'consistent'} at the held-out postures (frequencies χ² "
              f"{f['chi2']:.4g} on {f['n']} modes, p {f['p']:.2g}, {f['beyond']} beyond 3σ)")
    for i, e in enumerate(dg.effects[:8]):
        mark = "*" if e.chosen else " "
        print(f" {mark}{i + 1}. {e.name}: {e.description}; held-out gap {e.heldout_before['gap']:.3g} -> "
              f"{e.heldout_after['gap']:.3g} (shrink {100 * e.shrink:.1f} %, "
              f"{100 * e.shrink_interval[0]:.1f}-{100 * e.shrink_interval[1]:.1f}), "
              f"confidence {e.confidence:.2f}")
    for group in dg.equivalent:
        print(f"   the data cannot tell apart: {', '.join(group)}")
    if dg.design_changes:
        print(f"   test design: {'; '.join(dg.design_changes)}")
    if paths:
        print(f"wrote {args.out}: " + ", ".join(Path(p).name for k, p in paths.items() if k != "figures")
              + f" and {len(paths.get('figures', []))} figures")
    return 0


def _diagnose_readings(args) -> int:
    from rmbench.gap.tracker.diagnosis import TrackerSettings, diagnose_tracker, tracker_data
    from rmbench.io.tracker_csv import read_tracker_csv
    from rmbench.robot import Robot

    if not (args.repeatability > 0):
        raise InputError(f"--repeatability must be > 0 mm, got {args.repeatability!r}")
    readings = read_tracker_csv(args.readings)
    robot = Robot.load(args.robot or "mh180", tool=args.tool)
    if len(readings.joints) != len(robot.arm_joints):
        raise InputError(f"the readings have {len(readings.joints)} joint columns, robot {robot.name} "
                         f"has {len(robot.arm_joints)} arm joints")
    say = (lambda msg: None) if args.json else (lambda msg: print(f"  {msg}", file=sys.stderr))
    data = tracker_data(readings, robot=robot, repeatability=1e-3 * args.repeatability)
    if args.calibrate not in (None, "default"):
        raise InputError("--calibrate takes no groups with --readings: it calibrates every joint's zero "
                         "offset, placement, gravity compliance and link mass")
    settings = TrackerSettings(calibrate=args.calibrate is not None, **_search_options(args))
    dg = diagnose_tracker(robot, data, settings=settings, progress=say)
    paths = dg.save(args.out) if args.out else {}
    if args.report:
        _report(args, dg)
    if args.json:
        print_json(dg.to_json())
        return 0
    b, a = dg.heldout_before, dg.heldout_after
    print(f"verdict: {dg.verdict} ({dg.n_readings} readings; held-out rms {1e3 * b['rms']:.3f} -> "
          f"{1e3 * a['rms']:.3f} mm, max {1e3 * b['max']:.3f} -> {1e3 * a['max']:.3f} mm, "
          f"shrink {100 * dg.shrink:.1f} %)")
    print(f"where: {dg.where.describe()}")
    if dg.calibration is not None:
        c = dg.calibration
        n_id = sum(p["identifiability"] == "identifiable" for p in c["params"])
        print(f"calibrated {c['n_params']} ordinary parameters ({n_id} identifiable): held-out rms "
              f"{1e3 * c['heldout_before']['rms']:.3f} -> {1e3 * c['heldout_after']['rms']:.3f} mm")
        if dg.verdict == "no significant gap":
            print("   the calibrated ordinary parameters account for the readings: no structural source is needed")
        if dg.form is not None:
            f = dg.form
            print(f"form: {'wrong' if f['flagged'] else 'consistent'} at the held-out configurations (χ² "
                  f"{f['chi2']:.4g} on {f['n']} residuals, p {f['p']:.2g})")
    for i, s in enumerate(dg.sources[:8]):
        mark = "*" if s.chosen else " "
        share = f", {100 * s.share:.0f} % of the error" if s.chosen else ""
        print(f" {mark}{i + 1}. {s.name}: {s.description}{share}; held-out rms "
              f"{1e3 * s.heldout_after['rms']:.3f} mm, confidence {s.confidence:.2f}")
    for group in dg.equivalent:
        print(f"   the data cannot tell apart: {', '.join(group)}")
    if dg.absorbed:
        print(f"   no signature beyond the base registration: {', '.join(dg.absorbed)}")
    if paths:
        print(f"wrote {args.out}: " + ", ".join(Path(p).name for p in paths.values()))
    return 0


def _blind_tracker(args) -> int:
    from rmbench.gap.cases.tracker_blind import run_tracker_blind, summarise_tracker

    def progress(i, case):
        if not args.json:
            hidden = " + ".join(f"{h['kind']}@{h['location']}" for h in case["hidden"])
            print(f"case {i}: hidden {hidden}; {case['verdict']}, chosen "
                  f"{', '.join(case['chosen']) or '-'}", file=sys.stderr)

    cases = run_tracker_blind(args.cases, args.seed, out=args.out, progress=progress, scheduler=args.scheduler)
    s = summarise_tracker(cases)
    if args.json:
        print_json(s)
        return 0
    print(f"{s['cases']} cases: {s['in_library']} in the library, {s['out_of_library']} outside")
    print(f"  recall of every hidden source {s['recall']:.1%} (of those carrying >= 10 % of the error "
          f"{s['recall_major']:.1%}); sources reported that "
          f"were not there {s['false_sources']:.1%}; median held-out shrink of the true error "
          f"{s['median_shrink']:.1%} (measured rms {s['median_shrink_measured']:.1%}); out-of-library "
          f"cases unexplained {s['unexplained_ok']:.1%}")
    return 0


def cmd_blind(args) -> int:
    from rmbench.gap.cases.blind import BlindOptions, run_blind

    if args.cases < 1:
        raise InputError(f"--cases must be at least 1, got {args.cases}")
    if args.data == "tracker":
        return _blind_tracker(args)
    if not 0 <= args.time_share <= 1:
        raise InputError(f"--time-share must lie in [0, 1], got {args.time_share}")
    def progress(case):
        if not args.json:
            hidden = " + ".join(h.name for h in case.hidden)
            top = case.ranked[0][0] if case.ranked else "-"
            print(f"case {case.index} ({case.method}): hidden {hidden}; {case.verdict}, top {top}, "
                  f"shrink {100 * case.shrink:.0f} %", file=sys.stderr)

    options = BlindOptions(method=args.method, time_share=args.time_share, workers=args.workers,
                           scheduler=args.scheduler)
    report = run_blind(args.cases, args.seed, options, progress=progress, out=args.out or None)
    s = report.summary
    if args.json:
        print_json(s)
        return 0
    print(f"{s['cases']} cases ({s['time_domain']} time-domain): {s['single']} single, {s['pairs']} pairs, "
          f"{s['out_of_library']} out of the library")
    print(f"  top-1 {s['top1']:.1%} (up to indistinguishable effects {s['top1_class']:.1%}), top-3 "
          f"{s['top3']:.1%} ({s['top3_class']:.1%}); median held-out shrink {s['median_shrink']:.1%}")
    print(f"  false attributions (out of library) {s['false_attribution']:.1%}; both effects of a pair in "
          f"the top 3 {s['pair_recall']:.1%}")
    print(f"  draws rejected (invisible, or postures the robot cannot hold) and drawn again: {s['rejected']}")
    return 0
