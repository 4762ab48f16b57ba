"""HTML reports (issue 18): size and opening time of the 112-posture reports, and every report kind
rendered in headless Chromium (Debian's package) with its console and plots checked.

1. The seed's 112-posture grid hammered with the dummy rod (linear path) and fitted by the modal
   stage. Its campaign report and its modal-fit report (fitted overlays, parameter maps, the
   stabilisation diagram of posture 0): file size, and opening time = navigation until the plots of
   the first screen have drawn (the page draws the others as they are scrolled to), and until every
   plot on the page has drawn; medians of 5 openings in a fresh browser each. Beside them, a page
   holding plotly.js and one figure: the floor of any plotly page on this machine.
2. One report of each kind: campaign, modal fit, predictor (grouped MTGP learnt on the 112 fits,
   parameter maps; k-NN cross-validation), controller with its closed-loop runs and time traces,
   FRF gap diagnosis (a robot whose j3 is 20 % softer, 16 postures), tracker gap diagnosis,
   lobes (fitted against exact modes), RCSA tool change, robot-supported plate, model invalidation
   on the simulated tracker (`rmbench invalidate run --report`). Console errors,
   dialogs, plots that drew nothing; a screenshot of each -> bench/results/report_<kind>.jpg.

Last line: ``{"campaign112_open_s", "campaign112_mb", "modal112_open_s", "modal112_mb",
"plotly_only_s", "reports", "reports_clean"}``.

usage: python bench/report.py [--work DIR]   (DIR keeps the generated data between runs)
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
import warnings
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmbench.impact import load_config, open_campaign, run_campaign  # noqa: E402
from rmbench.impact.dataset import save  # noqa: E402
from rmbench.report import Page  # noqa: E402
from rmbench.report.browser import render  # noqa: E402
from rmbench.report.files import write_report  # noqa: E402

RESULTS = Path(__file__).parent / "results"


def _timed(fn, label):
    t0 = time.perf_counter()
    out = fn()
    print(f"  {label}: {time.perf_counter() - t0:.0f} s")
    return out


def data_112(work: Path):
    """The seed grid's campaign (linear path) and its modal fit, made once per work folder."""
    from rmbench.modal.campaign_fit import fit_campaign

    camp, modal = work / "grid112.nc", work / "grid112_modal.nc"
    if not camp.exists():
        cfg = load_config("seed_full").with_overrides(name="report_grid", method="linear", grid={"kind": "seed"})
        _timed(lambda: run_campaign(cfg, camp, workers=2, progress=False), "112-posture campaign")
    if not modal.exists():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = _timed(lambda: fit_campaign(open_campaign(camp), workers=2), "modal fit")
        fit.attrs["upstream"] = str(camp)
        save(fit, modal)
    return camp, modal


def opening(path: Path, n: int = 5) -> tuple[list[float], list[float]]:
    """Seconds until the first screen's plots drew, and until every plot drew, per opening."""
    first, every = [], []
    for _ in range(n):
        r = render(path)
        if r.console_errors or r.undrawn:
            raise SystemExit(f"{path}: console {r.console_errors}, undrawn {r.undrawn}")
        first.append(r.first_seconds)
        every.append(r.seconds)
    return first, every


def plotly_floor(work: Path, n: int = 5) -> float:
    """Median start time of a page that holds plotly.js and one empty figure."""
    page = Page("plotly.js alone")
    page.section("one figure").figure({"data": [{"type": "scatter", "x": [0, 1], "y": [0, 1]}], "layout": {}})
    path = page.write(work / "plotly_only.html")
    return statistics.median(opening(path, n)[1])


def section_1(work: Path) -> dict:
    print("1. 112-posture reports (seed grid, linear path, dummy rod)")
    camp, modal = data_112(work)
    out = {}
    for name, src, kw in (("campaign112", camp, {}), ("modal112", modal, {"data": camp})):
        path = work / f"{name}.html"
        t0 = time.perf_counter()
        write_report(src, path, **kw)
        build = time.perf_counter() - t0
        first, every = opening(path)
        mb = path.stat().st_size / 1e6
        out[name] = (statistics.median(first), mb)
        print(f"  {name:12s} {mb:6.1f} MB, written in {build:4.1f} s; opens (first screen drawn) in median "
              f"{statistics.median(first):.2f} s (range {min(first):.2f}-{max(first):.2f}); every plot drawn: "
              f"median {statistics.median(every):.2f} s (range {min(every):.2f}-{max(every):.2f}); {len(first)} openings")
    floor = plotly_floor(work)
    print(f"  a page with plotly.js alone starts in median {floor:.2f} s on this machine")
    return {"campaign112_open_s": round(out["campaign112"][0], 2), "campaign112_mb": round(out["campaign112"][1], 1),
            "modal112_open_s": round(out["modal112"][0], 2), "modal112_mb": round(out["modal112"][1], 1),
            "plotly_only_s": round(floor, 2)}


def reports(work: Path) -> dict:
    """One report of each kind, through the library (the CLI's --report writes the same pages)."""
    from rmbench.control import design, excitation_frequencies, robot_plant, sine_sweep
    from rmbench.control.experiments import traced_runs
    from rmbench.gap import GapDataWarning, diagnose, diagnose_tracker, tracker_data
    from rmbench.gap.cases.tracker_blind import HiddenSource, TrueRobot
    from rmbench.io.tracker_csv import TrackerReadings
    from rmbench.predict import PosturePredictor
    from rmbench.rcsa import campaign_receptance
    from rmbench.rcsa.support import support_study
    from rmbench.rcsa.tool_change import predict_campaign_tool
    from rmbench.report.control import control_sections
    from rmbench.report.machining import lobes_sections, support_sections, tool_change_sections
    from rmbench.robot import Posture, Robot, seed_grid
    from rmbench.robot.suppressor import reference_point
    from rmbench.robot.tool import TOOLS
    from rmbench.robot.variant import make_variant
    from rmbench.stability import ALUMINIUM_6061, Structure, lobes, lowest_envelope
    from rmbench.tracker import MH180_JOINT_BOX, sobol_points

    import xarray as xr

    from rmbench.predict import validate_predictor

    camp, modal = data_112(work)
    paths = {"campaign": write_report(camp, work / "r_campaign.html"),
             "modal": write_report(modal, work / "r_modal.html", data=camp)}
    pred_file = work / "pred.npz"
    if not pred_file.exists():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _timed(lambda: PosturePredictor("mtgp-grouped").fit(xr.load_dataset(modal)).save(pred_file), "grouped MTGP")
    validation = validate_predictor(PosturePredictor.load(pred_file), xr.load_dataset(modal), ["knn"])
    paths["predictor"] = write_report(pred_file, work / "r_predictor.html", validation=validation)

    op = reference_point()
    d = design(robot_plant(op, ("tangential",), order=14))
    f0 = d.plant.mode_hz[0]
    zeta = float(op.linear.modes().zeta[np.argmin(np.abs(op.linear.modes().f_n - f0))])
    freqs = excitation_frequencies([(f0, zeta)], 0.8 * f0, 1.2 * f0, coarse=0.1 * f0)
    runs = {n: sine_sweep(op, k, "tangential", freqs, workers=0) for n, k in (("uncontrolled", None), ("controlled", d.controller))}
    page = Page("Proof-mass suppressor, MH180 stand-in")
    control_sections(page, runs, controller=d.controller, traces=traced_runs(op, d.controller, "tangential", f0))
    paths["controller"] = page.write(work / "r_controller.html")

    nominal = Robot.load("irb6660", tool="dummy")
    (work / "soft_j3.xml").write_text(make_variant(nominal, ["j3_flex.stiffness*=0.8"]))
    grid = seed_grid()
    rows = [[1e3 * p.x, 1e3 * p.y, float(np.degrees(p.theta))] for p in (grid[7 * k + k % 7] for k in range(16))]
    cfg = load_config("seed_full").with_overrides(name="report_gap", method="linear", robot_name=str(work / "soft_j3.xml"),
                                                  robot_commands_from="irb6660", grid={"kind": "list", "postures": rows})
    gap_data = work / "gap_campaign.nc"
    if not gap_data.exists():
        run_campaign(cfg, gap_data, workers=2, progress=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", GapDataWarning)
        dg = _timed(lambda: diagnose("irb6660", gap_data, tool="dummy", workers=2), "FRF gap diagnosis")
    dg.save(work / "gap")
    paths["gap"] = write_report(work / "gap", work / "r_gap.html")

    mh = Robot.load("mh180")
    rng = np.random.default_rng(2026)
    truth = TrueRobot(mh, (HiddenSource("gear_periodic_error", "j4:h2", (2.4e-4, -1.8e-4)),
                           HiddenSource("payload", "tool", (25.0,))), 1.0, rng)
    q = np.repeat(sobol_points(200, *MH180_JOINT_BOX, rng), 2, axis=0)
    t = np.arange(len(q)) * 15.0
    readings = TrackerReadings(np.repeat(np.arange(200), 2), tuple(mh.arm_joints), q,
                               truth.positions(q, t, q, noise=True, rng=rng), None, None, ("bench",), t)
    diagnose_tracker(mh, tracker_data(readings, robot=mh)).save(work / "tracker_gap")
    paths["tracker_gap"] = write_report(work / "tracker_gap", work / "r_tracker_gap.html")

    import xarray as xr

    fit = xr.load_dataset(modal)
    ds = open_campaign(camp)
    p = int(np.argmin(np.abs(ds.x.values - 1.8) + np.abs(ds.y.values - 0.2) + np.abs(ds.theta.values)))
    opx = nominal.at(Posture(float(ds.x[p]), float(ds.y[p]), float(ds.theta[p])))
    speeds, depths = np.linspace(5000, 20000, 60), np.linspace(0, 10e-3, 100)
    env = {"fitted": lowest_envelope(*(lobes(Structure.from_modal(fit, p, band=b), ALUMINIUM_6061, speeds, depths, every=5)
                                       for b in ("low", "high"))),
           "exact": lowest_envelope(*(lobes(Structure.from_mode_table(opx.modes(b)), ALUMINIUM_6061, speeds, depths, every=5)
                                      for b in ("low", "high")))}
    page = Page("Stability lobes")
    lobes_sections(page, env, title=f"Lobes at posture {p} of the grid: fitted against exact modes")
    paths["lobes"] = page.write(work / "r_lobes.html")

    res = predict_campaign_tool(ds, p, TOOLS["endmill"])
    page = Page("RCSA")
    tool_change_sections(page, res, reference={b: campaign_receptance(ds, p, b).values for b in res.bands})
    robot = Robot.load("irb6660")
    support_sections(page, support_study(robot, robot.ik(Posture.from_mm_deg(1800, 0, 0)).q))
    paths["rcsa"] = page.write(work / "r_rcsa.html")

    import contextlib
    import io

    from rmbench.cli import main as cli

    paths["invalidation"] = work / "r_invalidation.html"
    with contextlib.redirect_stdout(io.StringIO()):          # the command's own summary: not this table's
        cli(["invalidate", "run", "--eta", "0.375", "--max-per-location", "10", "--report", str(paths["invalidation"])])
    return paths


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", default=None, help="folder for the generated data (kept between runs)")
    args = ap.parse_args()
    work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="report_bench_"))
    work.mkdir(parents=True, exist_ok=True)
    line = section_1(work)
    print("\n2. One report of each kind in headless Chromium")
    paths = reports(work)
    print(f"  {'report':12s} {'MB':>5s} {'plots':>5s} {'open s':>7s}  console errors / undrawn plots")
    clean = 0
    for kind, path in paths.items():
        r = render(path, screenshot=RESULTS / f"report_{kind}.jpg")
        ok = not (r.console_errors or r.dialogs or r.undrawn)
        clean += ok
        print(f"  {kind:12s} {path.stat().st_size / 1e6:5.1f} {r.n_plots:5d} {r.seconds:7.2f}  "
              + ("none" if ok else f"{r.console_errors} {r.dialogs} {r.undrawn}"))
    print(f"  screenshots: {RESULTS}/report_<kind>.jpg")
    line.update({"reports": len(paths), "reports_clean": clean})
    print(json.dumps(line))


if __name__ == "__main__":
    main()
