"""``rmbench model calibrate`` and ``rmbench model suggest``: model updating from measured modes."""

from __future__ import annotations

import csv
import io
from pathlib import Path

from rmbench.cli._common import add_report_option, print_json, read_test_design, report_path
from rmbench.errors import InputError

__all__ = ["register_model_commands"]

_DATA_HELP = ("measured modes: a campaign (.nc), a UFF58 directory, a modal fit (rmbench modal fit --out) "
              "or a modal table CSV (x_mm, y_mm, theta_deg, band, f_n_hz, zeta_pct[, phi...])")


def register_model_commands(msub) -> None:
    from rmbench.robot.parameters import GROUPS, OPTIONAL_GROUPS

    cal = msub.add_parser("calibrate", help="fit a robot's ordinary parameters to measured modes (model updating)")
    _common(cal)
    cal.add_argument("--params", default=None, metavar="GROUPS",
                     help=f"parameter groups, comma-separated, of {', '.join(GROUPS)}; 'all' for every group "
                          f"(default joints,damping,servo,masses); {', '.join(OPTIONAL_GROUPS)} by name only")
    cal.add_argument("--heldout", type=int, default=0, metavar="K",
                     help="hold K postures out of the fit (spread over the data) and report their errors")
    cal.add_argument("--out", default=None, metavar="CAL.xml",
                     help="calibrated MJCF to write; CAL_params.csv and CAL_modes.csv are written beside it")
    cal.add_argument("--frf", action="store_true",
                     help="fit the FRFs too (mean log magnitude per entry and quarter band), where the data are FRFs")
    cal.add_argument("--json", action="store_true", help="print the calibration as JSON")
    add_report_option(cal, "the calibrated parameters and the modes before and after")
    cal.set_defaults(func=cmd_calibrate)

    sug = msub.add_parser("suggest", help="name the next postures to test (D-optimal for the parameters)")
    _common(sug)
    sug.add_argument("--candidates", required=True, metavar="GRID",
                     help="campaign TOML (or bundled config name) whose grid lists the candidate postures")
    sug.add_argument("-n", type=int, default=4, help="postures to suggest (default 4)")
    sug.add_argument("--params", default=None, metavar="GROUPS", help="parameter groups (as for calibrate)")
    sug.add_argument("--json", action="store_true", help="print JSON")
    sug.set_defaults(func=cmd_suggest)


def _common(p) -> None:
    p.add_argument("--robot", default="irb6660", help="nominal robot: bundled name or MJCF path (default irb6660)")
    p.add_argument("--tool", default=None, help="tool on the nominal robot (default: its own)")
    p.add_argument("--data", required=True, help=_DATA_HELP)
    p.add_argument("--test", default=None, metavar="TOML",
                   help="campaign TOML of the test design, where the data carry none (default for a table: seed_full)")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: the cores' share)")


def _load(args):
    from rmbench.calibrate import load_modal_data
    from rmbench.robot import Robot

    robot = Robot.load(args.robot, tool=args.tool)
    data = load_modal_data(args.data, test=read_test_design(args), workers=args.workers)
    return robot, data


def _spread(data, k: int) -> list[int]:
    """``k`` posture indices spread over the data in (θ, x, y) order."""
    n = len(data)
    if k < 0 or k >= n:
        raise InputError(f"--heldout must be between 0 and {n - 1} (the data have {n} postures), got {k}")
    from rmbench.calibrate.split import held_out_postures

    return held_out_postures(data, k)


def cmd_calibrate(args) -> int:
    from rmbench.calibrate import CalibrationSettings, calibrate
    from rmbench.calibrate.form import check_calibration
    from rmbench.robot.parameters import parse_groups

    groups = parse_groups(args.params)
    report = report_path(args)
    out = Path(args.out) if args.out else None
    if out is not None and (out.suffix.lower() != ".xml" or not out.resolve().parent.is_dir()):
        raise InputError(f"--out must be an .xml file in an existing folder, got {args.out}")
    robot, data = _load(args)
    if args.frf and data.frf is None:
        raise InputError("--frf needs FRF data (a campaign dataset or a UFF58 directory); a modal fit or table "
                         "carries none")
    held = _spread(data, args.heldout)
    say = None if args.json else (lambda msg: print(msg, flush=True))
    settings = CalibrationSettings(groups=groups, workers=args.workers, frf=args.frf)
    cal = calibrate(robot, data, held=held, settings=settings, progress=say)
    # whether the ordinary parameters explain the held-out postures, or the model's form is wrong
    form = check_calibration(robot, data, cal, settings)
    files = {}
    if out is not None:
        params_csv = out.with_name(out.stem + "_params.csv")
        modes_csv = out.with_name(out.stem + "_modes.csv")
        texts = {out: cal.xml, params_csv: _params_csv(cal), modes_csv: _modes_csv(cal)}
        for path, text in texts.items():
            tmp = path.with_name(path.name + ".part")
            tmp.write_text(text)
        for path in texts:
            path.with_name(path.name + ".part").replace(path)   # all written before any is replaced
        files = {"model": str(out), "params": str(params_csv), "modes": str(modes_csv)}
    if report is not None:
        _report(cal, data, robot, report)
        files["report"] = str(report)
    if args.json:
        print_json({**cal.to_json(), "form": None if form is None else form.to_dict(), "files": files,
                    "robot": robot.name, "data": data.source})
        return 0
    _print(cal)
    if form is not None:
        print(form.summary())
    for kind, path in files.items():
        print(f"wrote {path}" + (f"; use it with --robot {path}" if kind == "model" else ""))
    return 0


def _print(cal) -> None:
    from rmbench.calibrate.fit import error_summary

    chi2 = cal.chi2_per_residual
    print(f"{len(cal.params)} parameters on {len(cal.train)} postures ({cal.n_residuals} residuals): "
          f"χ²/residual {chi2['before']:.3g} -> {chi2['after']:.3g}, "
          f"{cal.seconds:.1f} s")
    print(f"{'parameter':28s} {'nominal':>12s} {'calibrated':>12s} {'95 % interval':>27s}  identifiability")
    for p in cal.params:
        print(f"{p.name:28s} {p.nominal:12.5g} {p.value:12.5g} [{p.interval[0]:11.5g}, {p.interval[1]:11.5g}]  "
              f"{p.identifiability}{' (on its bound)' if p.on_bound else ''}  {p.unit}")
    for c in cal.combinations:
        print(f"  determined only together: {c}")
    for key, rows in (("training", cal.modes_train), ("held-out", cal.modes_held)):
        if not rows:
            continue
        s0, s1 = (error_summary(rows[k]) for k in ("before", "after"))
        print(f"{key} modes: |f error| mean {_pct(s0['f_err_mean'])} -> {_pct(s1['f_err_mean'])}, "
              f"p95 {_pct(s0['f_err_p95'])} -> {_pct(s1['f_err_p95'])}; |zeta error| p95 "
              f"{_pct(s0['zeta_err_p95'])} -> {_pct(s1['zeta_err_p95'])}; unpaired {s0['unpaired']} -> {s1['unpaired']}")
    for n in cal.notes:
        print(f"note: {n}")


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.2f} %"


def _report(cal, data, robot, path) -> None:
    from rmbench.calibrate.fit import error_summary
    from rmbench.report import Page

    page = Page(f"Calibration of {robot.name} to {data.source}",
                {"robot": robot.name, "data": data.source, "postures": f"{len(cal.train)} fitted, "
                 f"{len(cal.held)} held out", "seconds": f"{cal.seconds:.1f}"})
    sec = page.section("Parameters", "Nominal and calibrated values, 95 % intervals from the posterior "
                       "covariance; a parameter the data do not determine stays at its nominal.")
    sec.table(["parameter", "unit", "nominal", "calibrated", "95 % interval", "identifiability"],
              [[p.name, p.unit, f"{p.nominal:.5g}", f"{p.value:.5g}",
                f"{p.interval[0]:.5g} - {p.interval[1]:.5g}", p.identifiability] for p in cal.params])
    for key, rows in (("Training postures", cal.modes_train), ("Held-out postures", cal.modes_held)):
        if not rows:
            continue
        s0, s1 = (error_summary(rows[k]) for k in ("before", "after"))
        sec = page.section(key, f"|f error| mean {_pct(s0['f_err_mean'])} before, {_pct(s1['f_err_mean'])} "
                           f"after; |zeta error| mean {_pct(s0['zeta_err_mean'])} before, "
                           f"{_pct(s1['zeta_err_mean'])} after.")
        sec.table(["x mm", "y mm", "theta deg", "band", "mode", "f measured Hz", "f before Hz", "f after Hz",
                   "zeta measured", "zeta before", "zeta after"],
                  [[f"{r0['x_mm']:.0f}", f"{r0['y_mm']:.0f}", f"{r0['theta_deg']:.0f}", r0["band"], r0["mode"],
                    f"{r0['f_meas']:.3f}", _g(r0["f_model"]), _g(r1["f_model"]), f"{r0['zeta_meas']:.4f}",
                    _g(r0["zeta_model"]), _g(r1["zeta_model"])] for r0, r1 in zip(rows["before"], rows["after"])])
    page.write(path)


def _params_csv(cal) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["name", "group", "unit", "nominal", "calibrated", "lower95", "upper95", "identifiability",
                "posterior_over_prior_sd", "on_bound"])
    for p in cal.params:
        w.writerow([p.name, p.group, p.unit, f"{p.nominal:.8g}", f"{p.value:.8g}", f"{p.interval[0]:.8g}",
                    f"{p.interval[1]:.8g}", p.identifiability, f"{p.shrink:.4g}", p.on_bound])
    return buf.getvalue()


def _modes_csv(cal) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    cols = ["x_mm", "y_mm", "theta_deg", "band", "mode", "f_meas", "zeta_meas"]
    w.writerow(["set"] + cols + ["f_before", "f_after", "f_err_before", "f_err_after", "zeta_before",
                                 "zeta_after", "zeta_err_before", "zeta_err_after"])
    for key, rows in (("train", cal.modes_train), ("held", cal.modes_held)):
        if not rows:
            continue
        for r0, r1 in zip(rows["before"], rows["after"]):
            w.writerow([key] + [_g(r0[c]) for c in cols] + [_g(r0["f_model"]), _g(r1["f_model"]),
                                                           _g(r0["f_err"]), _g(r1["f_err"]),
                                                           _g(r0["zeta_model"]), _g(r1["zeta_model"]),
                                                           _g(r0["zeta_err"]), _g(r1["zeta_err"])])
    return buf.getvalue()


def _g(v) -> str:
    return "" if v is None else (f"{v:.8g}" if isinstance(v, float) else str(v))


def cmd_suggest(args) -> int:
    from rmbench.calibrate import CalibrationSettings
    from rmbench.calibrate.suggest import suggest_postures
    from rmbench.impact import load_config, parse_config
    from rmbench.impact.campaign import postures_of
    from rmbench.robot.parameters import parse_groups

    groups = parse_groups(args.params)
    path = Path(args.candidates)
    cfg = parse_config(path.read_text()) if path.is_file() else load_config(args.candidates)
    robot, data = _load(args)
    candidates = [p for p in postures_of(cfg, robot) if p not in data.postures]
    say = None if args.json else (lambda msg: print(msg, flush=True))
    s = suggest_postures(robot, data, candidates, args.n,
                         settings=CalibrationSettings(groups=groups, workers=args.workers,
                                                                     frf=args.frf), progress=say)
    if args.json:
        print_json(s.to_json())
        return 0
    print(f"next {len(s.postures)} postures to test (of {len(candidates)} candidates), best first:")
    for p, v in zip(s.postures, s.volume_factors):
        print(f"  {p.label()} (x mm, y mm, theta deg): confidence volume × {v:.3g}")
    print("  parameters they would determine best (posterior over prior sd, now -> after):")
    for k in s.best_determined(5):
        print(f"  {k}: posterior/prior sd {s.sd_before[k]:.2f} -> {s.sd_after[k]:.2f}")
    for line in s.skipped:
        print(f"  skipped {line}")
    return 0
