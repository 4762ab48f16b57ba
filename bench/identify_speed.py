"""Identification speed (issue 78): the calibration and the calibrated diagnosis as a user runs
them, each timed as a whole command (its own process, imports included) on 2 cores.

1. A drawn "real robot" (the calibration bench's spread, ``bench/truth/robot.py``'s ``draw_truth``:
   plain MJCF edits) hammered at 12 postures of the seed grid (``rmbench campaign run``, time domain), its
   campaign fitted (``rmbench modal fit``), then ``rmbench model calibrate --data MODAL.nc``: the
   default groups, 24 parameters. The modal fit is the campaign's own step and is timed apart.
2. ``rmbench gap diagnose --calibrate joints,damping,servo,masses,com,base,tool --heldout 0.25`` (the
   calibration bench's settings: 12 postures calibrated and searched, 4 held out) on 16-posture
   time-domain campaigns of three drawn robots: the spread alone, the spread with an effect of the
   diagnosis's library, and the spread with one from outside it (the calibration bench's draws,
   ``bench/truth/structural.py``: plain MJCF edits, a turned sensor applied to the measured
   signals; not the library's case injection). A speed bench: no visibility check, every draw timed.
   The data go in as a real test's do: UFF58 files and the test design's TOML, nothing else.
3. Where the time goes: the top lines of a profile (cProfile, time in each function itself) of the
   calibration and of the in-library diagnosis, run in this process on one worker.
4. The 40-robot calibration bench's machine time, estimated from these: 40 campaigns of 16
   postures and the diagnoses of 20 spread-only, 10 in-library and 10 out-of-library robots at the
   times measured here (the bench's visibility checks, which the blind-bench issue replaces by a
   rule that runs no diagnosis, left out). An estimate, not a run of the bench.

Last line: ``{"calibrate_s", "modal_fit12_s", "diagnose_inlib_s", "diagnose_spread_s",
"diagnose_outlib_s", "diagnose_any_max_s", "verdicts", "bench40_h", "bench40_h_is_estimate",
"profile_top"}``.

usage: python bench/identify_speed.py [--seed 78] [--workers 2] [--method time] [--work DIR]
       [--no-profile]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
import warnings
import xml.etree.ElementTree as ET
from functools import partial
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import numpy as np  # noqa: E402

from _profile import profile_top  # noqa: E402
from truth.robot import draw_truth  # noqa: E402
from truth.structural import apply_effect, draw_effect, turned_signals  # noqa: E402

RMBENCH = [str(Path(sys.executable).with_name("rmbench"))]
GAP_GROUPS = "joints,damping,servo,masses,com,base,tool"


def run(args: list[str]) -> tuple[float, str]:
    """One rmbench command as its own process: its wall time (s) and stdout; a failure stops the bench."""
    t0 = time.perf_counter()
    proc = subprocess.run(RMBENCH + args, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        sys.exit(f"rmbench {' '.join(args)} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    return wall, proc.stdout


def campaign(work: Path, name: str, xml: str, postures, method: str, seed: int, workers: int, *,
             rpm: float = 0.0, signals=None) -> tuple[Path, Path, float]:
    """The truth hammered as the calibration bench does (``calibrate._toml``), exported to UFF58
    (its signals through ``signals``, a map of the FRF dataset, where given: a turned sensor's),
    with the nominal test design's TOML beside it: ``(uff_dir, test_toml, campaign seconds)``."""
    from calibrate import _toml

    truth = work / f"{name}_truth.xml"
    truth.write_text(xml)
    toml = work / f"{name}_campaign.toml"
    toml.write_text(_toml(str(truth), postures, method, seed, commands_from="irb6660", rpm=rpm))
    test = work / f"{name}_test.toml"
    test.write_text(_toml("irb6660", postures, method, seed, None))
    nc = work / f"{name}.nc"
    seconds, _ = run(["campaign", "run", str(toml), "--out", str(nc), "--workers", str(workers), "--force"])
    if signals is None:
        run(["campaign", "export", str(nc), "--uff", str(work / f"{name}_uff")])
    else:       # what ``rmbench campaign export`` writes, of the signals as the turned sensor reads them
        from rmbench.impact import open_campaign
        from rmbench.io import write_uff58

        ds = open_campaign(nc)
        write_uff58(signals(ds)[["H"]].assign_attrs(ds.attrs), work / f"{name}_uff")
    return work / f"{name}_uff", test, seconds


def diagnose_cmd(uff: Path, test: Path, workers: int) -> list[str]:
    return ["gap", "diagnose", "--robot", "irb6660", "--data", str(uff), "--test", str(test),
            "--calibrate", GAP_GROUPS, "--heldout", "0.25", "--workers", str(workers), "--json"]


def profiles(modal: Path, cal_test: Path, uff: Path, test: Path) -> str:
    """The top lines of a profile of the calibration and of the in-library diagnosis, one worker."""
    import xarray as xr

    from rmbench.calibrate import CalibrationSettings, calibrate, load_modal_data
    from rmbench.gap import DiagnosisSettings, diagnose
    from rmbench.robot import Robot
    from rmbench.robot.parameters import parse_groups

    nominal = Robot.load("irb6660", tool="dummy")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data = load_modal_data(xr.open_dataset(modal).load(), test=cal_test.read_text())
        cal = profile_top(lambda: calibrate(nominal, data, settings=CalibrationSettings(workers=1)), 10,
                          sort="tottime")
        settings = DiagnosisSettings(calibrate=parse_groups(GAP_GROUPS), heldout=0.25)
        dg = profile_top(lambda: diagnose(nominal, str(uff), test=test.read_text(), workers=1,
                                          settings=settings), 12, sort="tottime")
    return "calibration (24 parameters, 12 postures, 1 worker):\n" + cal + \
        "\ndiagnosis (in library, 1 worker):\n" + dg


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=78)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--method", default="time", choices=("time", "linear"))
    ap.add_argument("--work", type=Path, default=None, help="folder for the campaigns (default: a temporary one)")
    ap.add_argument("--no-profile", action="store_true")
    args = ap.parse_args(argv)
    work = args.work or Path(tempfile.mkdtemp(prefix="rmbench_identify_"))
    work.mkdir(parents=True, exist_ok=True)
    from rmbench.robot import Robot, seed_grid

    nominal = Robot.load("irb6660", tool="dummy")
    grid = seed_grid()
    rng = np.random.default_rng(args.seed)
    print(f"seed {args.seed}, {args.workers} workers, {args.method} campaigns in {work}", flush=True)

    # 1. the calibration: 24 parameters on 12 postures
    xml, _ = draw_truth(nominal.xml, rng, base=False)
    postures = [grid[k] for k in sorted(rng.choice(len(grid), 12, replace=False))]
    from calibrate import _toml

    (work / "cal_truth.xml").write_text(xml)
    toml = work / "cal_campaign.toml"
    toml.write_text(_toml(str(work / "cal_truth.xml"), postures, args.method, args.seed, commands_from="irb6660"))
    cal_test = work / "cal_test.toml"
    cal_test.write_text(_toml("irb6660", postures, args.method, args.seed, None))
    nc, modal = work / "cal.nc", work / "cal_modal.nc"
    camp12, _ = run(["campaign", "run", str(toml), "--out", str(nc), "--workers", str(args.workers), "--force"])
    fit12, _ = run(["modal", "fit", str(nc), "--out", str(modal), "--workers", str(args.workers)])
    cal_s, out = run(["model", "calibrate", "--data", str(modal), "--test", str(cal_test), "--workers",
                      str(args.workers), "--json"])
    cal = json.loads(out)
    print(f"campaign 12 postures {camp12:.1f} s, modal fit {fit12:.1f} s; model calibrate "
          f"({len(cal['params'])} parameters): {cal_s:.1f} s ({cal['iterations']} evaluations, "
          f"χ²/residual {cal['chi2_per_residual']['after']:.3g})", flush=True)

    # 2. the calibrated diagnosis on three robots of 16 postures
    cases = {}
    for name, in_library in (("spread", None), ("inlib", True), ("outlib", False)):
        xml, _ = draw_truth(nominal.xml, rng, base=False)
        postures = [grid[k] for k in sorted(rng.choice(len(grid), 16, replace=False))]
        rpm, hidden, signals = 0.0, None, None
        if in_library is not None:
            root = ET.fromstring(xml)
            hidden = apply_effect(root, draw_effect(rng, in_library=in_library), ET.fromstring(nominal.xml))
            xml, rpm = ET.tostring(root, encoding="unicode"), hidden.rpm
            if hidden.kind == "sensor_misalignment":
                signals = partial(turned_signals, effect=hidden)
        uff, test, camp_s = campaign(work, name, xml, postures, args.method, args.seed, args.workers,
                                     rpm=rpm, signals=signals)
        seconds, out = run(diagnose_cmd(uff, test, args.workers))
        dg = json.loads(out)
        top = dg["effects"][0]["name"] if dg.get("effects") else None
        cases[name] = {"seconds": seconds, "campaign_s": camp_s, "verdict": dg["verdict"], "top": top,
                       "hidden": None if hidden is None else hidden.name, "uff": uff, "test": test}
        steps = ", ".join(f"{k} {v:.0f}" for k, v in (dg.get("seconds") or {}).items() if k != "total")
        print(f"{name}: hidden {cases[name]['hidden']}; campaign {camp_s:.1f} s; gap diagnose --calibrate "
              f"{seconds:.1f} s: {dg['verdict']}, top {top} (s per step: {steps})", flush=True)

    camp16 = float(np.mean([c["campaign_s"] for c in cases.values()]))
    # 40 campaigns; 20 spread-only, 10 in-library, 10 out-of-library diagnoses
    bench40 = (40 * camp16 + 20 * cases["spread"]["seconds"] + 10 * cases["inlib"]["seconds"]
               + 10 * cases["outlib"]["seconds"]) / 3600
    print(f"40-robot calibration bench, estimated: {bench40:.2f} h", flush=True)
    prof = "" if args.no_profile else profiles(modal, cal_test, cases["inlib"]["uff"], cases["inlib"]["test"])
    if prof:
        print(prof, flush=True)
    times = [c["seconds"] for c in cases.values()]
    line = {"calibrate_s": round(cal_s, 1), "modal_fit12_s": round(fit12, 1),
            "diagnose_inlib_s": round(cases["inlib"]["seconds"], 1),
            "diagnose_spread_s": round(cases["spread"]["seconds"], 1),
            "diagnose_outlib_s": round(cases["outlib"]["seconds"], 1),
            "diagnose_any_max_s": round(max(times), 1),
            "verdicts": {k: [c["hidden"], c["verdict"], c["top"]] for k, c in cases.items()},
            "bench40_h": round(bench40, 2), "bench40_h_is_estimate": True,
            "profile_top": " | ".join(ln.strip() for ln in prof.splitlines()[:8]) if prof else None}
    print(json.dumps(line, ensure_ascii=False))


if __name__ == "__main__":
    main()
