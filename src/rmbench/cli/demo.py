"""``rmbench demo``: the main job on an embedded default.

A small time-domain impact campaign (the seed's three validation postures, the seed's test
design) on the IRB6660 stand-in, with its exact ground truth beside it: mode tables, the dataset,
plots of measured vs exact FRF matrices, and the MDOF modal fit of the measured FRFs scored
against the exact modes; posture prediction (48 grid postures fitted and learnt by the seed's
grouped multi-task GPs, a never-hammered posture predicted); the bundled contour's redundant angle
planned from that predictor, and again at low speed in steel on the exact model (θ turned at
the corners, the spindle speed chosen), both milled; then the MH180 stand-in's proof-mass
suppressor: an H∞ controller designed on its linearisation and run closed loop in MuJoCo
against a 20 N sine at its mode, and a
posture schedule designed from a two-posture shaker campaign run on the moving arm; the
RCSA tool change and supported plate; lobes; the gap diagnoses, on tracker readings also of a
robot off its data sheet in every joint, calibrated first. It ends by writing one HTML report
of everything it ran (``report.html``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rmbench.cli.demo_machining import demo_lobes, demo_low_speed, demo_path

__all__ = ["register"]


def register(sub) -> None:
    p = sub.add_parser("demo", help="run the main job on an embedded default and plot it")
    p.add_argument("--out", default="rmbench_demo", help="directory for the dataset and figures (default rmbench_demo)")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")
    p.set_defaults(func=cmd_demo)


def cmd_demo(args) -> int:
    from rmbench import __version__
    from rmbench.report import Page, campaign_sections, modal_sections

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    page = Page("rmbench demo", {"rmbench": __version__, "folder": str(out.resolve()),
                                 "robots": "IRB6660 stand-in (dummy tool), MH180 stand-in (suppressor)"})
    _demo_exact(out)
    ds = _demo_campaign(out, args.workers)
    fit = _demo_modal(out, ds, args.workers)
    page.part("Impact campaign and modal fit (3 validation postures, time domain)")
    campaign_sections(page, ds, fit=fit)
    modal_sections(page, fit, ds)
    _demo_predict(out, args.workers, page)
    demo_path(out, page)
    demo_low_speed(out, page)
    _demo_rcsa(out, ds, page)
    demo_lobes(out, fit, page)
    _demo_control(out, page)
    _demo_gap(out, args.workers, page)
    _demo_calibrate(out, args.workers, page)
    _demo_form(out, args.workers, page)
    _demo_tracker_gap(out, page)
    _demo_any_arm(out, args.workers, page)
    report = page.write(out / "report.html")
    print(f"\nreport of everything above (open it in a browser): {report}")
    return 0


def _demo_exact(out: Path) -> None:
    """The IRB6660 stand-in's exact modes and tip receptances at the seed's validation postures."""
    from rmbench.robot import Robot, validation_postures
    from rmbench.robot.plot import plot_tip_frfs

    robot = Robot.load("irb6660", tool="dummy")
    print(f"rmbench demo: the {robot.name} stand-in with the {robot.tool} tool")
    curves = {"low": [], "high": []}
    for p in validation_postures():
        op = robot.at(p)
        print(f"\nposture {p.label()} (x mm, y mm, theta deg): q_cmd = "
              + ", ".join(f"{np.degrees(q):.2f}" for q in op.q_cmd) + " deg")
        for band in ("low", "high"):
            b = robot.bands[band]
            t = op.modes(band)
            print(f"  {band:>4} band exact modes: "
                  + ", ".join(f"{f:.2f} Hz ({100 * z:.1f} %)" for f, z in zip(t.f_n, t.zeta)))
            freq = np.linspace(b.f_min, b.f_max, 2000)
            curves[band].append((p.label(), freq, op.frf(freq, s_1a=b.s_1a)))
    for band in ("low", "high"):
        path = out / f"exact_tip_frf_{band}.png"
        plot_tip_frfs(curves[band], path, title=f"Exact tool-tip receptance, {band} band, IRB6660 stand-in")
        print(f"wrote {path}")


def _demo_campaign(out: Path, workers):
    """The bundled demo campaign (time domain) run into ``out``, its FRF matrices plotted; the dataset."""
    from rmbench.impact import bundled_configs, frf_error_median, load_config, open_campaign, run_campaign
    from rmbench.impact.plot import plot_frf_matrix

    config = bundled_configs()["demo"]
    data = out / "demo_campaign.nc"
    print(f"\nvirtual impact campaign {config.name} (time domain): 3 postures, hits at 1X 1Y 1aX 1aY x 3")
    run_campaign(load_config(config), data, toml=config.read_text(), workers=workers)
    ds = open_campaign(data)
    for i in range(ds.sizes["posture"]):
        for band in ("low", "high"):
            path = out / f"campaign_posture{i}_{band}.png"
            plot_frf_matrix(ds, i, path, band=band)
        print(f"  posture {i}: median |measured/exact - 1| = {frf_error_median(ds, i):.4f}; "
              f"figures {out}/campaign_posture{i}_*.png")
    print(f"wrote {data}")
    return ds


def _demo_modal(out: Path, ds, workers):
    """The campaign's automatic MDOF modal fit, scored against the exact modes; the fit dataset."""
    from rmbench.impact.dataset import save
    from rmbench.modal.campaign_fit import fit_campaign
    from rmbench.modal.worst_errors import worst_truth_errors

    print("\nMDOF modal fit of the campaign (automatic: pLSCF, stabilisation, model order by the "
          "information criterion, all 16 FRFs per band)")
    fit = fit_campaign(ds, workers=workers)
    for i in range(fit.sizes["posture"]):
        found = np.isfinite(fit.modal.values[i, :, 0])
        verdict = ("fit ok" if fit.fit_ok.values[i].all() else "needs a look: " + "; ".join(
            f"{b} band: {r}" for b, r in zip(fit.fit_band.values, fit.fit_reason.values[i]) if r))
        print(f"  posture {i}: " + ", ".join(
            f"{f:.2f} Hz ({100 * z:.1f} %)" for f, z in fit.modal.values[i, found, :2])
            + f" [{verdict}]")
    worst = worst_truth_errors(fit)
    if worst is not None:
        print(f"  against ground truth: |f error| max {worst['f_err_max']:.2e}, "
              f"|zeta error| max {worst['zeta_err_max']:.3f}, "
              f"MAC phiR/phiL min {worst['mac_phiR_min']:.4f}/{worst['mac_phiL_min']:.4f}")
    save(fit, out / "demo_modal.nc")
    print(f"wrote {out / 'demo_modal.nc'}")
    return fit


def _demo_any_arm(out: Path, workers, page) -> None:
    """Any arm from URDF: the UR10 of example-robot-data made a bench robot, hammered and fitted."""
    from rmbench.impact import load_config, open_campaign, run_campaign
    from rmbench.modal.campaign_fit import fit_campaign
    from rmbench.modal.worst_errors import band_fits_ok, worst_truth_errors
    from rmbench.report import campaign_sections
    from rmbench.robot.flexible_arm import build_arm, campaign_toml

    print("\nany arm from URDF: the UR10 of example-robot-data with flexible joints and a spindle")
    built = build_arm("ur10")
    path = out / "ur10.xml"
    path.write_text(built.xml)
    (out / "ur10_campaign.toml").write_text(campaign_toml(built, path))
    g = built.grid
    print(f"  wrote {path}: arm modes {', '.join(f'{f:.1f}' for f in built.f_low)} Hz, spindle modes "
          f"{', '.join(f'{f:.0f}' for f in built.f_high[:2])} Hz; posture grid table {1000 * g.table_z:.0f} mm, "
          f"x {1000 * g.x[0]:.0f}..{1000 * g.x[-1]:.0f} mm, y ±{1000 * g.y[-1]:.0f} mm, theta ±60 deg")
    cfg = load_config(out / "ur10_campaign.toml").with_overrides(name="demo_ur10", grid={"kind": "validation"})
    data = out / "demo_ur10_campaign.nc"
    run_campaign(cfg, data, workers=workers, progress=False)
    ds = open_campaign(data)
    fit = fit_campaign(ds, workers=workers)
    n_ok, n_fits = band_fits_ok(fit)
    print(f"  time-domain campaign at its 3 validation postures, fitted: {n_ok} of {n_fits} band fits hold; "
          f"natural frequencies within {100 * worst_truth_errors(fit)['f_err_max']:.3f} % of the exact")
    page.part("Any arm from URDF: UR10 (3 validation postures, time domain)")
    campaign_sections(page, ds, fit=fit)


def _demo_rcsa(out: Path, ds, page) -> None:
    """RCSA: the end mill predicted from the campaign's dummy-tool FRFs; a robot supporting a plate."""
    from rmbench.rcsa import campaign_receptance
    from rmbench.rcsa.plot import plot_support, plot_tool_change
    from rmbench.rcsa.support import support_study
    from rmbench.rcsa.tool_change import predict_campaign_tool
    from rmbench.robot import Posture, Robot
    from rmbench.robot.tool import TOOLS

    print("\nRCSA tool change: the 2-flute end mill predicted at validation posture 2 (index 1) from the campaign's dummy-tool "
          "FRFs (finite-difference rotations, Eq. 4, catalogue contact), against the simulated robot "
          "carrying the end mill")
    res = predict_campaign_tool(ds, 1, TOOLS["endmill"])
    for band in res.bands:
        peaks = [p for p in res.peaks if (p.f_true > 100) == (band == "high")]
        print(f"  {band:>4} band: {len(peaks)} peaks of H_1x1x, H_1x1y, H_1y1x, H_1y1y; largest errors "
              f"amplitude {100 * max(abs(p.amp_err) for p in peaks):.2f} %, "
              f"frequency {100 * max(abs(p.freq_err) for p in peaks):.2f} %")
    reference = {b: campaign_receptance(ds, 1, b).values for b in res.bands}
    path = plot_tool_change(res, out / "rcsa_tool_change.png", reference=reference)
    print(f"  wrote {path}")
    # the contact from a tool calibration (both tools at one posture, to 3.5 kHz, steel tip): the
    # seed's band cannot see the contact's damping, which acts on the tool-on-holder mode at 2.7 kHz
    from rmbench.impact import load_config, open_campaign, run_campaign

    cal = {}
    for tool in ("dummy", "endmill"):
        cal[tool] = out / f"calibration_{tool}.nc"
        run_campaign(load_config("tool_calibration").with_overrides(robot_tool=tool), cal[tool], workers=0,
                     progress=False)
    cal = {k: open_campaign(v) for k, v in cal.items()}
    fitted = predict_campaign_tool(ds, 1, TOOLS["endmill"], calibration=(cal["endmill"], 0),
                                   calibration_reference=cal["dummy"])
    k, true = fitted.bands["high"].target_contact, TOOLS["endmill"]
    print(f"  contact from the tool calibration (both tools at (1800, -200, 0), 600-3500 Hz): k_t "
          f"{k.k_t:.3g} N/m ({100 * (k.k_t / true.k_t - 1):+.1f} %), c_t {k.c_t:.3g} N s/m "
          f"({100 * (k.c_t / true.c_t - 1):+.1f} % against the simulator's); with it the largest peak errors "
          f"{100 * max(abs(p.amp_err) for p in fitted.peaks):.2f} % in amplitude, "
          f"{100 * max(abs(p.freq_err) for p in fitted.peaks):.2f} % in frequency")
    from rmbench.report.machining import support_sections, tool_change_sections

    page.part("RCSA")
    tool_change_sections(page, res, reference=reference)
    robot = Robot.load("irb6660")
    st = support_study(robot, robot.ik(Posture.from_mm_deg(1800, 0, 0)).q)
    d = st.to_dict()
    print(f"RCSA robot-supported plate (450 x 100 x 6 mm, modes {d['part_modes_hz'][0]:.0f} and "
          f"{d['part_modes_hz'][1]:.0f} Hz; ball pressed with {d['preload_n']:.0f} N): assembled low mode "
          f"{d['low_mode_sim_hz']:.2f} Hz simulated, {d['low_mode_rcsa_hz']:.2f} Hz by RCSA; peak reductions "
          + ", ".join(f"{100 * a:.2f}/{100 * b:.2f} %" for a, b in zip(d["reduction_sim"], d["reduction_rcsa"]))
          + " (simulated/RCSA)")
    print(f"  wrote {plot_support(st, out / 'rcsa_supported_plate.png')}")
    support_sections(page, st)


def _demo_predict(out: Path, workers, page) -> None:
    """Posture prediction: hammer 48 grid postures, fit, learn, predict a posture never hammered."""
    import warnings

    from rmbench.impact import load_config, nearest_exact_frequency, open_campaign, run_campaign
    from rmbench.impact.dataset import save
    from rmbench.modal.campaign_fit import fit_campaign
    from rmbench.predict import PosturePredictor

    cfg = load_config("seed_full").with_overrides(
        name="demo_predict", method="linear",
        grid={"kind": "product", "x_mm": [1300, 1500, 1700, 1900], "y_mm": [-300, -100, 100, 300],
              "theta_deg": [-40, 0, 40]})
    data = out / "demo_predict_campaign.nc"
    print("\nposture prediction: 48 grid postures hammered (linear path), fitted, learnt by the "
          "seed's grouped multi-task GPs; predicted at (1800, 200, 20), never hammered")
    run_campaign(cfg, data, workers=workers, progress=False)
    fit = fit_campaign(open_campaign(data), workers=workers)
    save(fit, out / "demo_predict_modal.nc")
    pred = PosturePredictor("mtgp-grouped").fit(fit)
    pred.save(out / "demo_predictor.npz")
    print(f"  trained on {len(pred.X_train_)} postures, {len(pred.live_)} parameters, in "
          f"{pred.train_seconds_:.1f} s; wrote {out / 'demo_predictor.npz'}")
    run_campaign(cfg.with_overrides(name="demo_predict_truth",
                                    grid={"kind": "list", "postures": [[1800, 200, 20]]}),
                 out / "demo_predict_truth.nc", workers=1, progress=False)
    truth = open_campaign(out / "demo_predict_truth.nc")
    with warnings.catch_warnings():
        warnings.simplefilter("error")       # inside the grid: no extrapolation warning expected
        guess = pred.predict([[1.8, 0.2, np.radians(20)]])
    for k in range(guess.sizes["mode"]):
        f, s = (guess[v].sel(param="f_n").values[0, k] for v in ("modal", "modal_std"))
        b = guess.mode_band.values[k]
        if not np.isfinite(f):      # a slot of the dataset no training posture's fit filled
            print(f"  mode {k} ({b}): no training posture's fit holds this mode: nothing to learn or predict")
            continue
        near = nearest_exact_frequency(truth, 0, b, f)
        print(f"  mode {k} ({b}): f_n {f:8.3f} ± {s:.3f} Hz; nearest exact mode {near:8.3f} Hz "
              f"({100 * (f / near - 1):+.2f} %)")
    from rmbench.predict import cross_validate, training_set
    from rmbench.predict.data import frequency_ordered
    from rmbench.report.predict import cv_sections, predictor_sections

    page.part("Posture prediction (48 grid postures)")
    predictor_sections(page, pred)
    ts = training_set(frequency_ordered(fit))
    cv_sections(page, ts, [cross_validate(ts, "knn")])     # the fast baseline; GPs' CV takes minutes


def _demo_tracker_gap(out: Path, page) -> None:
    """An MH180 with a gear error on j4 and a heavier tool than its model: read by a tracker,
    diagnosed, the accuracy it costs before and after."""
    from rmbench.gap import diagnose_tracker, tracker_data
    from rmbench.gap.cases.tracker_blind import HiddenSource, TrueRobot
    from rmbench.io.tracker_csv import TrackerReadings, read_tracker_csv, write_tracker_csv
    from rmbench.robot import Robot
    from rmbench.tracker import MH180_JOINT_BOX, sobol_points

    robot = Robot.load("mh180")
    rng = np.random.default_rng(2026)
    hidden = (HiddenSource("gear_periodic_error", "j4:h2", (2.4e-4, -1.8e-4)),
              HiddenSource("payload", "tool", (25.0,)))
    truth = TrueRobot(robot, hidden, 1.0, rng)
    q = np.repeat(sobol_points(200, *MH180_JOINT_BOX, rng), 2, axis=0)
    t = np.arange(len(q)) * 15.0
    csv = out / "demo_tracker_readings.csv"
    write_tracker_csv(csv, TrackerReadings(np.repeat(np.arange(200), 2), tuple(robot.arm_joints), q,
                                           truth.positions(q, t, q, noise=True, rng=rng), None, None,
                                           ("rmbench demo: MH180, j4 gear error and a 25 kg payload",), t))
    print("\nsim-to-real gap on tracker readings: an MH180 with a j4 gear error (300 µrad, 2nd harmonic) "
          "and 25 kg the model lacks, 400 readings")
    dg = diagnose_tracker(robot, tracker_data(read_tracker_csv(csv), robot=robot))
    b, a = dg.heldout_before, dg.heldout_after
    print(f"  verdict: {dg.verdict}; held-out rms {1e3 * b['rms']:.3f} -> {1e3 * a['rms']:.3f} mm, "
          f"max {1e3 * b['max']:.3f} -> {1e3 * a['max']:.3f} mm (the readings' noise is "
          f"{1e3 * dg.where.noise_rms:.3f} mm rms)")
    for s in dg.chosen:
        print(f"  * {s.name}: {s.description}, {100 * s.share:.0f} % of the error, confidence {s.confidence:.2f}")
    dg.save(out / "demo_tracker_gap")
    print(f"  wrote {out / 'demo_tracker_gap'}: diagnosis.json, sources.csv, pose_errors.png")
    from rmbench.report.gap import gap_sections

    page.part("Sim-to-real gap on tracker readings (MH180)")
    gap_sections(page, dg)
    _demo_tracker_calibrated(out, page)


def _demo_tracker_calibrated(out: Path, page) -> None:
    """An MH180 whose every joint is 15-25 % softer than its data sheet, with a 2 mm reflector
    offset (issue 43's case): diagnosed as it stands, where the spread is blamed on structural
    sources, and with ``--calibrate``, where the ordinary parameters are fitted first."""
    from rmbench.gap import TrackerSettings, diagnose_tracker, tracker_data
    from rmbench.io.tracker_csv import TrackerReadings, read_tracker_csv, write_tracker_csv
    from rmbench.report.gap import gap_sections
    from rmbench.robot import Robot
    from rmbench.tracker import MH180_CALIBRATION_BOX, sobol_points
    from rmbench.tracker.simulator import soft_robot_simulator

    robot = Robot.load("mh180")
    rng = np.random.default_rng(43)
    sim = soft_robot_simulator(robot, rng, softer=(0.75, 0.85), reflector=(1.2e-3, -1.4e-3, 0.6e-3))
    n = 200     # a calibration campaign: every joint swept as far as the cell allows
    q = np.repeat(sobol_points(n, *MH180_CALIBRATION_BOX, rng), 2, axis=0)
    t = np.arange(len(q)) * 15.0
    csv = out / "demo_tracker_spread_readings.csv"
    write_tracker_csv(csv, TrackerReadings(np.repeat(np.arange(n), 2), tuple(robot.arm_joints), q,
                                           sim.measure(q, rng), None, None,
                                           ("rmbench demo: MH180, every joint 15-25 % softer, 2 mm reflector offset",), t))
    data = tracker_data(read_tracker_csv(csv), robot=robot)
    print("\nthe same on a robot off its data sheet: every joint 15-25 % softer and the reflector 1.94 mm off "
          "the modelled TCP (+1.2, -1.4, +0.6 mm), 400 readings of a calibration campaign")
    plain = diagnose_tracker(robot, data)
    print(f"  as it stands: {plain.verdict}; chosen "
          + ", ".join(f"{s.name} ({s.description})" for s in plain.chosen))
    dg = diagnose_tracker(robot, data, settings=TrackerSettings(calibrate=True))
    cal = dg.calibration
    n_id = sum(p["identifiability"] == "identifiable" for p in cal["params"])
    print(f"  --calibrate: {cal['n_params']} ordinary parameters calibrated ({n_id} identifiable), then "
          f"{dg.verdict}; chosen " + ", ".join(f"{s.name} ({s.description}, confidence {s.confidence:.2f})"
                                              for s in dg.chosen))
    b, a = dg.heldout_before, dg.heldout_after
    print(f"  held-out rms {1e3 * b['rms']:.3f} -> {1e3 * a['rms']:.3f} mm (noise {1e3 * dg.where.noise_rms:.3f} mm rms)")
    dg.save(out / "demo_tracker_calibrated")
    print(f"  wrote {out / 'demo_tracker_calibrated'}: diagnosis.json (with its calibration), sources.csv")
    page.part("Tracker gap with --calibrate: a robot off its data sheet (MH180)")
    gap_sections(page, dg)


def _demo_gap(out: Path, workers, page) -> None:
    """A robot whose third joint is 20 % softer than its model: measured, diagnosed, fixed."""
    import warnings

    from rmbench.gap import GapDataWarning, diagnose

    print("\nsim-to-real gap: a 'real' robot with j3 20 % softer than the model, 16 postures "
          "commanded by the model's IK (linear-path campaign)")
    data = _commanded_campaign(out, "demo_gap", ["j3_flex.stiffness*=0.8"], 0, workers)
    with warnings.catch_warnings():     # the bench's file carries ground truth; the diagnosis sets it aside
        warnings.simplefilter("ignore", GapDataWarning)
        dg = diagnose("irb6660", data, tool="dummy", workers=workers)
    print(f"  verdict: {dg.verdict}; where: {dg.localisation}")
    for e in dg.effects[:3]:
        print(f"  {'*' if e.chosen else ' '} {e.name}: {e.description}; held-out gap "
              f"{e.heldout_before['gap']:.2f} -> {e.heldout_after['gap']:.2f} "
              f"(shrink {100 * e.shrink:.0f} %), confidence {e.confidence:.2f}")
    paths = dg.save(out / "demo_gap")
    print(f"  wrote {out / 'demo_gap'}: diagnosis.json, effects.csv, {len(paths.get('figures', []))} figures"
          + (", variant.xml (the updated model)" if paths.get("variant") else ""))
    from rmbench.report.gap import gap_sections

    page.part("Sim-to-real gap on FRF data (j3 20 % softer)")
    gap_sections(page, dg)


def _commanded_campaign(out: Path, name: str, edits, shift: int, workers, *, xml: str | None = None) -> Path:
    """A linear-path campaign of the stand-in changed by ``edits`` (or the MJCF ``xml``; written as
    ``NAME_true_robot.xml``), commanded by the nominal model's IK at 16 of the seed's 112
    postures: every (x, y) once, θ stepping through the grid (``shift`` picks another θ
    sequence). Returns the campaign file ``NAME_campaign.nc``."""
    from rmbench.impact import load_config, run_campaign
    from rmbench.robot import Robot, seed_grid
    from rmbench.robot.variant import make_variant

    true = out / f"{name}_true_robot.xml"
    true.write_text(xml if xml is not None else make_variant(Robot.load("irb6660", tool="dummy"), edits))
    grid = seed_grid()
    postures = [grid[7 * k + ((1 + 2 * shift) * k + shift) % 7] for k in range(16)]
    rows = [[1e3 * p.x, 1e3 * p.y, float(np.degrees(p.theta))] for p in postures]
    cfg = load_config("seed_full").with_overrides(
        name=name, method="linear", robot_name=str(true), robot_commands_from="irb6660",
        grid={"kind": "list", "postures": rows})
    data = out / f"{name}_campaign.nc"
    run_campaign(cfg, data, workers=workers, progress=False)
    return data


def _demo_calibrate(out: Path, workers, page) -> None:
    """A robot whose gearboxes, damping and link masses all differ from its data sheet (the demo is
    not told by how much): a 16-posture campaign, the model calibrated on 12, checked on 4."""
    import warnings

    from rmbench.calibrate import CalibrationSettings, calibrate, error_summary, load_modal_data
    from rmbench.robot import Robot
    from rmbench.robot.drawn import drawn_edits

    nominal = Robot.load("irb6660", tool="dummy")
    edits = drawn_edits(np.random.default_rng(2026))
    print("\nmodel updating: a 'real' robot whose 6 gearboxes, their damping and 4 link masses differ from "
          "the data sheet, 16 postures (linear-path campaign); calibrated on 12, 4 held out")
    data_path = _commanded_campaign(out, "demo_calibrate", edits, 1, workers)
    with warnings.catch_warnings():     # the bench's file carries ground truth; the fit sets it aside
        warnings.simplefilter("ignore")
        data = load_modal_data(data_path, workers=workers)
    cal = calibrate(nominal, data, held=[1, 5, 9, 13], settings=CalibrationSettings(workers=workers))
    b, a = (error_summary(cal.modes_held[k]) for k in ("before", "after"))
    print(f"  {len(cal.params)} parameters in {cal.seconds:.0f} s; held-out |f error| mean "
          f"{100 * b['f_err_mean']:.2f} % -> {100 * a['f_err_mean']:.2f} %, p95 {100 * b['f_err_p95']:.2f} % -> "
          f"{100 * a['f_err_p95']:.2f} %")
    for p in cal.params:
        if p.group == "joints":
            print(f"  {p.name}: {p.nominal:.4g} -> {p.value:.4g} {p.unit} ({p.identifiability})")
    kinds = {}
    for p in cal.params:
        kinds.setdefault(p.identifiability, []).append(p.name)
    print(f"  not identifiable from these postures: {', '.join(kinds.get('not identifiable', [])) or 'none'}")
    path = out / "demo_calibrated.xml"
    path.write_text(cal.xml)
    print(f"  wrote {path}: the calibrated robot (use it with --robot {path})")
    sec = page.part("Model updating (calibration to a 16-posture campaign)").section(
        "Calibrated parameters", f"Held-out |f error| mean {100 * b['f_err_mean']:.2f} % before, "
        f"{100 * a['f_err_mean']:.2f} % after calibration.")
    sec.table(["parameter", "nominal", "calibrated", "95 % interval", "identifiability"],
              [[p.name, f"{p.nominal:.4g} {p.unit}", f"{p.value:.4g}", f"{p.interval[0]:.4g} - {p.interval[1]:.4g}",
                p.identifiability] for p in cal.params])


def _demo_form(out: Path, workers, page) -> None:
    """A robot whose lower arm bends (a form the model lacks, the demo not told where): the
    calibration cannot explain the held-out postures, and the gap is localised on the robot."""
    import warnings

    from rmbench.calibrate import CalibrationSettings, calibrate, load_modal_data
    from rmbench.calibrate.form import check_calibration
    from rmbench.gap.frf.locate import locate_calibration
    from rmbench.gap.plot import plot_location
    from rmbench.report.gap import form_section
    from rmbench.robot import Robot
    from rmbench.robot.parameters import parameter_set
    from rmbench.robot.spec import spec_to_xml

    nominal = Robot.load("irb6660", tool="dummy")
    bent, params = parameter_set(nominal, ("bending",))
    spec = bent.spec
    params.apply_spec(spec, [400.0 if n.startswith("lower_arm") else 0.0 for n in params.names])
    print("\nmodel form: a 'real' robot whose lower arm bends (400 µrad/(kN·m) at mid-length, which the "
          "model has no parameter for), 16 postures; calibrated on 12, 4 held out")
    data_path = _commanded_campaign(out, "demo_form", (), 2, workers, xml=spec_to_xml(spec))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data = load_modal_data(data_path, workers=workers)
    settings = CalibrationSettings(workers=workers)
    cal = calibrate(nominal, data, held=[1, 5, 9, 13], settings=settings)
    form = check_calibration(nominal, data, cal, settings)
    print(f"  {form.summary()}")
    where = locate_calibration(nominal, data, cal, settings) if form.flagged else None
    part = page.part("Model form (a bending lower arm the model lacks)")
    if where is None:
        part.section("Lack of fit", form.summary())
        return
    print(f"  {where.summary()}")
    path = plot_location(where.to_dict(), out / "demo_form_location.png")
    print(f"  wrote {path}")
    form_section(part, {**form.to_dict(), "located": where.to_dict()})


def _demo_control(out: Path, page) -> None:
    from rmbench.control import design, excitation_frequencies, reduction_at, robot_plant, sine_sweep
    from rmbench.control.plot import plot_sensitivity
    from rmbench.robot.suppressor import reference_point

    op = reference_point()
    d = design(robot_plant(op, ("tangential",), order=14))
    f0 = d.plant.mode_hz[0]
    print(f"\nMH180 stand-in, proof-mass suppressor: tangential mode {f0:.2f} Hz; H-infinity controller "
          f"order {d.controller.order}, gamma {d.gamma:.2f}")
    modes = op.linear.modes()
    zeta = float(modes.zeta[modes.nearest(f0)])
    freqs = excitation_frequencies([(f0, zeta)], f0 * 0.8, f0 * 1.2, coarse=f0 * 0.1)
    runs = {name: sine_sweep(op, k, "tangential", freqs, workers=0)
            for name, k in (("uncontrolled", None), ("H-infinity", d.controller))}
    red = reduction_at(runs["uncontrolled"], runs["H-infinity"], "tangential", f0)
    print(f"  20 N sine on the disturbance coil, closed loop in MuJoCo at {len(freqs)} frequencies: "
          f"{100 * red:.1f} % reduction at the mode (seed: 75.2 %)")
    plot_sensitivity(runs, out / "demo_control_sweep.png", title="MH180 stand-in: 20 N sine sweep")
    print(f"  figure {out / 'demo_control_sweep.png'}")
    from rmbench.control.experiments import traced_runs
    from rmbench.report.control import control_sections

    page.part("Proof-mass suppressor (MH180)")
    control_sections(page, {"uncontrolled": runs["uncontrolled"], "controlled": runs["H-infinity"]},
                     controller=d.controller, traces=traced_runs(op, d.controller, "tangential", f0))
    _demo_schedule(op)


def _demo_schedule(op) -> None:
    """A posture schedule designed from a two-posture shaker campaign, run along a short move."""
    from rmbench.control.grid import ScheduleGrid, measure_campaign, plants_from_campaign
    from rmbench.control.moving import moving_test
    from rmbench.control.schedule import design_schedule
    from rmbench.control.trajectory import linear_move

    grid = ScheduleGrid(axes=("tangential",), hold="j5", duration=24.0, joints={"j2": [-5.0, 10.0]})
    robot = op.robot
    _, plants = plants_from_campaign(measure_campaign(robot, grid))
    idx, g, hold, q_ref = grid.resolve(robot)
    sch = design_schedule(plants, g, idx, q_ref, hold=hold)
    _, (q0, q1) = grid.postures(robot)
    ds = moving_test(robot.at(q0), {"scheduled": sch}, linear_move(q0, q1, 6.0, hold=1.0), start=1.0, window=2.0,
                     hop=0.5)
    modes = [c.meta["mode_hz"][0] for c in sch.controllers]
    print(f"  posture schedule over J2 -5..10 deg from a 2-posture shaker campaign (modes {modes[0]:.2f} and "
          f"{modes[1]:.2f} Hz), run on the arm moving for 6 s under a 10 N rms random force: "
          f"{100 * float(ds.reduction.sel(controller='scheduled')):.1f} % less vibration at the mode")
