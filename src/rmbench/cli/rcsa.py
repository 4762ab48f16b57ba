"""``rmbench rcsa``: receptance coupling — a new tool on the robot (and a robot holding a part)."""

from __future__ import annotations

from pathlib import Path

from rmbench.cli._common import add_report_option, command_group, load_dataset, print_json, report_path
from rmbench.errors import InputError

__all__ = ["register"]


def register(sub) -> None:
    from rmbench.robot.tool import TOOLS

    g = command_group(sub, "rcsa", "receptance coupling: tool change, robot-supported part")
    t = g.add_parser("tool", help="predict a target tool's tip FRFs from the reference tool's campaign")
    t.add_argument("--reference", required=True, help="impact campaign (netCDF) of the reference tool")
    t.add_argument("--target-tool", required=True, choices=sorted(TOOLS), help="the tool to predict")
    where = t.add_mutually_exclusive_group()
    where.add_argument("--posture", help="a measured posture x,y,theta in mm, mm, degrees")
    where.add_argument("--index", type=int, help="posture index in the campaign (default 0)")
    t.add_argument("--contact", help="target contact k_t,k_r[,c_t,c_r] in N/m, N m/rad, N s/m, N m s/rad "
                                     "(default: identified from --calibration, else the tool's catalogue value)")
    t.add_argument("--calibration", help="campaign of the target tool at a posture the reference campaign "
                                         "also measured: the target contact is fitted there")
    t.add_argument("--calibration-index", type=int, default=0, help="posture index in --calibration (default 0)")
    t.add_argument("--calibration-reference", help="campaign of the reference tool measured like --calibration "
                                                   "(e.g. both from the bundled tool_calibration config, to 3.5 kHz): "
                                                   "the contact is fitted on these two")
    t.add_argument("--method", choices=("difference", "beam"), default="difference",
                   help="rotations by finite differences and Eq. 4 (the seed's, default), or the "
                        "translations at 1 and 1a coupled through the tool's beam model")
    t.add_argument("--tool-model", choices=("beam", "lumped"), default="beam",
                   help="substructure model of the overhangs: Timoshenko beam (default) or the "
                        "simulator's own two-segment tool (a check free of model-form error)")
    t.add_argument("--free", default="k_t,c_t",
                   help="contact parameters fitted on --calibration, comma-separated among "
                        "k_t,k_r,c_t,c_r (default k_t,c_t: with the beam model the rotational "
                        "contact is not identifiable)")
    t.add_argument("--no-shank", action="store_true", help="leave out the shank change (pure Eq. 4)")
    t.add_argument("--no-mass-loading", action="store_true",
                   help="leave the campaigns' accelerometers off the measured tools' substructures")
    t.add_argument("--no-cross-axis", action="store_true",
                   help="leave the accelerometers' transverse sensitivity in the measured readings")
    t.add_argument("--no-hit-offset", action="store_true",
                   help="leave the tip hits' mean offset above the tip (hammer location scatter) in")
    t.add_argument("--json", action="store_true", help="print the result as JSON")
    t.add_argument("--out", help="figure of predicted (and simulated) FRFs (.png)")
    t.add_argument("--save", help="write the predicted full tip receptances (netCDF)")
    add_report_option(t, "the predicted (and simulated) FRFs and the peak errors")
    t.set_defaults(func=cmd_tool)

    pt = g.add_parser("part", help="a robot supporting a thin-walled plate: simulated assembly against RCSA")
    pt.add_argument("--robot", default="irb6660", help="bundled robot name or MJCF path (default irb6660)")
    pt.add_argument("--posture", default="1800,0,0", help="x,y,theta of the ball in mm, mm, degrees")
    pt.add_argument("--k-x", default="2e7", help="contact stiffness, N/m, or 'inf' (default 2e7)")
    pt.add_argument("--preload", type=float, default=100.0, help="contact force at rest, N (default 100)")
    pt.add_argument("--contact-mm", type=float, default=None,
                    help="contact point, mm from the left clamp (default 0.4 of the span)")
    pt.add_argument("--offset-mm", type=float, default=20.0,
                    help="misplaced sensor's distance from the joint, mm (default 20)")
    pt.add_argument("--json", action="store_true", help="print the result as JSON")
    pt.add_argument("--out", help="figure of the FRFs (.png)")
    pt.add_argument("--scene", help="also write the scene's MJCF")
    add_report_option(pt, "the FRFs of part, robot, assembly and RCSA")
    pt.set_defaults(func=cmd_part)


def cmd_tool(args) -> int:
    import warnings

    from rmbench.rcsa import IllConditionedWarning
    from rmbench.rcsa.tool_change import predict_campaign_tool

    report = report_path(args)
    data, index, target, contact, free, calibration, cal_ref = _tool_inputs(args)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", IllConditionedWarning)
        res = predict_campaign_tool(data, index, target, contact=contact, calibration=calibration,
                                    calibration_reference=cal_ref, method=args.method, shank=not args.no_shank,
                                    tool_model=args.tool_model, free=free, mass_loading=not args.no_mass_loading,
                                    cross_axis=not args.no_cross_axis, hit_offset=not args.no_hit_offset)
    notes = [str(w.message) for w in caught if issubclass(w.category, IllConditionedWarning)]
    _write_tool_outputs(args, res, data, index, notes, report)
    if args.json:
        d = res.to_dict()
        d["warnings"] = notes
        print_json(d)
        return 0
    _print_tool(args, res, index, notes)
    for path in (args.out, args.save, report):
        if path:
            print(f"wrote {path}")
    return 0


def _tool_inputs(args):
    """Read and check ``rcsa tool``'s inputs: (campaign, posture index, target tool, contact or
    None, free parameters, calibration or None, reference calibration or None)."""
    from rmbench.rcsa import Contact
    from rmbench.rcsa.tool_change import posture_index, tool_geometry
    from rmbench.robot import parse_posture

    data = load_dataset(args.reference, "reference campaign")
    for key in ("H", "x", "band"):
        if key not in data:
            raise InputError(f"{args.reference}: not an impact campaign (no {key!r})")
    if args.posture:
        index = posture_index(data, parse_posture(args.posture))
    else:
        index = args.index or 0
    target = tool_geometry(args.target_tool)
    contact = Contact.parse(args.contact) if args.contact else None
    free = tuple(p.strip() for p in args.free.split(",") if p.strip())
    bad = [p for p in free if p not in ("k_t", "k_r", "c_t", "c_r")]
    if bad or not free:
        raise InputError(f"--free takes contact parameters among k_t,k_r,c_t,c_r, got {args.free!r}")
    calibration = cal_ref = None
    if args.calibration_reference and not args.calibration:
        raise InputError("--calibration-reference needs --calibration (the target tool's calibration campaign)")
    if args.calibration and contact is None:
        calibration = (load_dataset(args.calibration, "calibration campaign"), args.calibration_index)
        if args.calibration_reference:
            cal_ref = load_dataset(args.calibration_reference, "reference calibration campaign")
    return data, index, target, contact, free, calibration, cal_ref


def _write_tool_outputs(args, res, data, index: int, notes: list, report) -> None:
    """Write the files ``rcsa tool`` was asked for: the predictions, the figure, the report."""
    if args.save:
        from rmbench.impact.dataset import save

        save(res.to_dataset(reference=args.reference), args.save)
    if args.out:
        from rmbench.rcsa import campaign_receptance
        from rmbench.rcsa.plot import plot_tool_change

        ref = {b: campaign_receptance(data, index, b).values for b in res.bands}
        plot_tool_change(res, args.out, reference=ref)
    if report:
        from rmbench.rcsa import campaign_receptance
        from rmbench.report import Page
        from rmbench.report.machining import tool_change_sections

        page = Page(f"RCSA tool change: {args.target_tool} from {Path(args.reference).name}",
                    {"reference campaign": args.reference, "posture index": index, "method": args.method,
                     "contact": res.contact_source, "warnings": "; ".join(notes)})
        tool_change_sections(page, res, reference={b: campaign_receptance(data, index, b).values for b in res.bands})
        page.write(report)


def _print_tool(args, res, index: int, notes: list) -> None:
    """``rcsa tool``'s text output: warnings, the contact used, its fit and the peak errors."""
    for n in notes:
        print(f"warning: {n}")
    x, y, t = res.posture_mm_deg
    tc = next(iter(res.bands.values()))
    k = tc.target_contact
    print(f"{tc.reference.name} -> {tc.target.name} at posture {index} ({x:.0f} mm, {y:.0f} mm, {t:.0f}°), "
          f"{args.method} rotations, {args.tool_model} tool model"
          f"{'' if not args.no_shank else ', no shank change'}")
    print(f"target contact ({res.contact_source}): k_t {k.k_t:.4g} N/m, k_r {k.k_r:.4g} N m/rad, "
          f"c_t {k.c_t:.4g} N s/m, c_r {k.c_r:.4g} N m s/rad")
    if res.contact_fit is not None:
        f = res.contact_fit
        print(f"  fit: rms misfit {100 * f.rms:.2f} % (start {100 * f.rms_start:.2f} %) over {f.n_lines} lines; "
              + ", ".join(f"{n} ±{100 * s:.1f} %" for n, s in f.rel_std.items()))
    if res.peaks:
        print("peaks of the simulated target tool (truth) against the prediction:")
        print("  entry     f_true Hz   f_pred Hz   freq err   amp err")
        for p in res.peaks:
            print(f"  {p.entry:8s} {p.f_true:10.2f} {p.f_pred:11.2f} {100 * p.freq_err:9.2f} % {100 * p.amp_err:8.2f} %")
        amp, fr = res.largest_peak_errors()
        print(f"largest errors: amplitude {100 * amp:.2f} %, frequency {100 * fr:.2f} %")


def cmd_part(args) -> int:
    import math

    from rmbench.rcsa.support import support_study
    from rmbench.robot import Robot, parse_posture
    from rmbench.robot.part import Plate, support_scene

    try:
        k_x = math.inf if args.k_x.strip().lower() == "inf" else float(args.k_x)
    except ValueError:
        raise InputError(f"--k-x must be a number in N/m or 'inf', got {args.k_x!r}") from None
    if not k_x > 0:
        raise InputError(f"--k-x must be positive, got {args.k_x}")
    report = report_path(args)
    robot = Robot.load(args.robot)
    q = robot.ik(parse_posture(args.posture)).q
    contact = None if args.contact_mm is None else 1e-3 * args.contact_mm
    # the simulated scene needs a finite spring; 'inf' is RCSA's rigid joint, simulated at 1e12 N/m
    study = support_study(robot, q, k_x=min(k_x, 1e12), preload=args.preload, contact=contact,
                          sensor_offset=1e-3 * args.offset_mm)
    if args.scene:
        scene = support_scene(robot, q, Plate(), contact=contact, k_x=min(k_x, 1e12), preload=args.preload)
        tmp = Path(args.scene).with_name(Path(args.scene).name + ".part")
        tmp.write_text(scene.xml)
        tmp.replace(args.scene)
    if args.out:
        from rmbench.rcsa.plot import plot_support

        plot_support(study, args.out)
    if report:
        from rmbench.report import Page
        from rmbench.report.machining import support_sections

        page = Page("Robot-supported thin-walled plate", {"robot": args.robot, "posture": args.posture,
                                                          "K_x (N/m)": args.k_x, "preload (N)": args.preload})
        support_sections(page, study)
        page.write(report)
        if not args.json:
            print(f"wrote {report}")
    d = study.to_dict()
    if args.json:
        print_json(d)
        return 0
    print(f"plate modes (part alone): {', '.join(f'{f:.1f}' for f in d['part_modes_hz'][:3])} Hz; "
          f"robot's main low mode alone {d['robot_low_mode_hz']:.2f} Hz")
    print(f"contact {d['contact_mm']:.0f} mm from the left clamp, K_x {d['k_x']:.3g} N/m, preload {d['preload_n']:.0f} N")
    print(f"assembled main low mode: simulated {d['low_mode_sim_hz']:.3f} Hz, RCSA {d['low_mode_rcsa_hz']:.3f} Hz "
          f"({100 * d['low_mode_err']:+.3f} %)")
    for k in range(2):
        print(f"amplitude reduction at part mode {k + 1} ({d['part_modes_hz'][k]:.1f} Hz): simulated "
              f"{100 * d['reduction_sim'][k]:.3f} %, RCSA {100 * d['reduction_rcsa'][k]:.3f} %, "
              f"RCSA rigid joint {100 * d['reduction_rcsa_rigid'][k]:.3f} %")
    print(f"sensor {d['offset_mm']:.0f} mm off the joint, fed to Eq. 6: worst at {d['offset_worst_hz']:.1f} Hz "
          f"({d['offset_worst_db']:.1f} dB off), up to {d['offset_db_near_part_mode_2']:.1f} dB within ±10 % of part "
          f"mode 2; Eqs. 12-14 at the sensor: within "
          f"{100 * d['eq12_14_at_sensor_max_rel']:.2f} % of the peak")
    for path in (args.out, args.scene):
        if path:
            print(f"wrote {path}")
    return 0
