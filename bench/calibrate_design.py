"""Which postures to test (issue 38, item 5): 8 D-optimal postures against 12 (and 8) grid postures
and 8 random ones, by the held-out error of the calibration each gives.

Per "real robot" (``bench/truth/robot.py``: ``draw_truth``, every ordinary parameter drawn, on a rigid
floor so that the groups calibrated cover what was drawn but the tool holder's ±25 %):

1. four held-out postures drawn from the seed grid, and a first test of four grid postures;
2. the nominal robot calibrated on those four (``--groups``, default
   ``joints,damping,servo,masses,com``: 42 parameters), then ``suggest_postures`` picks
   four more from the whole seed grid (greedy D-optimal with the calibrated model), which are
   measured in a second campaign;
3. calibrations (the same groups) on: the 8 D-optimal (first four + suggested),
   12 grid postures, 8 grid postures, 8 random postures; each scored on the same four held-out
   postures (held-out frequency error p95 over their measured modes).

Grid postures are spread evenly through the seed grid's (x, y, θ) order; random ones drawn from
it. Campaigns in the time domain through UFF58, as in ``bench/calibrate.py``.

Last line: ``{"robots", "dopt8_f_p95_median", "grid12_f_p95_median", "grid8_f_p95_median",
"random8_f_p95_median", "dopt8_reaches_grid12"}`` (the share of robots where the D-optimal
eight's held-out p95 is at most the twelve grid postures').

usage: python bench/calibrate_design.py [--robots 6] [--seed S] [--workers 2] [--groups G]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from calibrate import measure  # noqa: E402
from truth.robot import draw_truth  # noqa: E402

from rmbench.calibrate import CalibrationSettings, ModalData, calibrate  # noqa: E402
from rmbench.calibrate.suggest import suggest_postures  # noqa: E402
from rmbench.robot import Robot, seed_grid  # noqa: E402
from rmbench.robot.parameters import parse_groups  # noqa: E402

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"


def _even(idx, n):
    idx = sorted(idx)
    return [idx[int(round(k))] for k in np.linspace(0, len(idx) - 1, n)]


def _merge(a: ModalData, b: ModalData) -> ModalData:
    return ModalData(a.postures + b.postures, a.modes + b.modes, a.bands, a.design, a.source)


def run_robot(i: int, seed: int, workers: int, groups) -> dict:
    rng = np.random.default_rng([seed, i])
    nominal = Robot.load("irb6660", tool="dummy")
    xml, _ = draw_truth(nominal.xml, rng, base=False)
    grid = seed_grid()
    held = sorted(rng.choice(len(grid), 4, replace=False).tolist())
    rest = [k for k in range(len(grid)) if k not in held]
    grid12 = _even(rest, 12)
    grid8 = _even(rest, 8)
    first4 = _even(grid12, 4)
    random8 = sorted(rng.choice(rest, 8, replace=False).tolist())
    first = sorted(set(held) | set(grid12) | set(grid8) | set(random8))
    tmp = Path(tempfile.mkdtemp(prefix="rmbench_design_"))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            data1 = measure(xml, [grid[k] for k in first], "time", seed * 1000 + i, workers, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    at = {k: j for j, k in enumerate(first)}
    settings = CalibrationSettings(groups=groups, workers=workers)
    cal4 = calibrate(nominal, data1.subset([at[k] for k in first4]), settings=settings)
    sug = suggest_postures(Robot(cal4.xml, name="cal4", tool="dummy"), data1.subset([at[k] for k in first4]),
                           [grid[k] for k in rest if k not in first4], n=4, settings=settings)
    tmp = Path(tempfile.mkdtemp(prefix="rmbench_design_"))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            data2 = measure(xml, list(sug.postures), "time", seed * 1000 + 500 + i, workers, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    data = _merge(data1, data2)
    held_i = [at[k] for k in held]
    designs = {"dopt8": [at[k] for k in first4] + list(range(len(first), len(first) + 4)),
               "grid12": [at[k] for k in grid12], "grid8": [at[k] for k in grid8],
               "random8": [at[k] for k in random8]}
    out = {"index": i, "seed": seed, "groups": list(groups),
           "suggested_mm_deg": [[1e3 * p.x, 1e3 * p.y, float(np.degrees(p.theta))] for p in sug.postures]}
    for name, train in designs.items():
        sub = data.subset(train + held_i)
        cal = calibrate(nominal, sub, held=list(range(len(train), len(train) + 4)), settings=settings)
        h = cal.heldout_summary()["after"]
        out[name] = {"f_p95": h["f_err_p95"], "f_mean": h["f_err_mean"], "unpaired": h["unpaired"],
                     "identifiable": sum(p.identifiability == "identifiable" for p in cal.params)}
        print(f"robot {i} {name:8s}: held-out f p95 {100 * h['f_err_p95']:.3f} %, "
              f"{out[name]['identifiable']} identifiable", flush=True)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", type=int, default=6)
    ap.add_argument("--seed", type=int, default=None, help="default: a fresh one, printed")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--groups", default="joints,damping,servo,masses,com")
    args = ap.parse_args(argv)
    groups = parse_groups(args.groups)
    seed = args.seed if args.seed is not None else int(np.random.SeedSequence().entropy % 100000)
    lines = RESULTS / f"calibrate_design_s{seed}_{'-'.join(groups)}.jsonl"
    print(f"seed {seed}; lines {lines}", flush=True)
    done = {}
    if lines.exists():
        done = {c["index"]: c for c in map(json.loads, lines.read_text().splitlines()) if c}
    for i in range(args.robots):
        if i in done:
            continue
        c = run_robot(i, seed, args.workers, groups)
        done[i] = c
        with open(lines, "a") as fh:
            fh.write(json.dumps(c) + "\n")
    cases = [done[i] for i in sorted(done)]
    med = {k: float(np.median([c[k]["f_p95"] for c in cases])) for k in ("dopt8", "grid12", "grid8", "random8")}
    reach = float(np.mean([c["dopt8"]["f_p95"] <= c["grid12"]["f_p95"] for c in cases]))
    print(json.dumps({"robots": len(cases), "dopt8_f_p95_median": med["dopt8"], "grid12_f_p95_median": med["grid12"],
                      "grid8_f_p95_median": med["grid8"], "random8_f_p95_median": med["random8"],
                      "dopt8_reaches_grid12": reach}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
