"""The measured noise model (issue 80): how far the modal fit's own standard errors cover its
errors on robots inside the model.

Each robot is a blind-bench real robot with the ordinary spread and no form error
(``truth.draw_real_robot``, ``p_form=0``, a foundation on odd robots), measured by the 16-posture
campaign the blind FRF bench runs (``--method``). Its fitted modes are paired with the exact
modes of the same robot (its own linearisation, no fit) by the calibration's pairing, and each
pair gives ``z = ln(f_fit / f_exact) / (f_std / f_fit)`` (damping likewise). The bench reports, per
band, the coverage of the ±1.96 standard-error intervals, the factor ``κ`` by which the standard
errors must grow for 95 % coverage, and the relative error's median and 95th percentile: the
numbers :data:`rmbench.calibrate.noise.NOISE` states.

usage: python bench/noise_model.py [--robots 6] [--seed S] [--method time] [--workers 2]

The seed goes into ``bench/SEEDS.md`` before the run; pairs go to a JSON-lines file keyed by seed
and code (a killed run resumes). Ends with one JSON line.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
from functools import partial
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402

from _stats import cases_to_lines, keyed_run, run_arguments, wilson  # noqa: E402
from calibrate import measure  # noqa: E402
from truth import draw_real_robot  # noqa: E402

from rmbench.calibrate import ModalModel  # noqa: E402
from rmbench.calibrate.residual import pair  # noqa: E402
from rmbench.robot import Robot, seed_grid  # noqa: E402
from rmbench.robot.parameters import ParameterSet  # noqa: E402

TRUTH_FILES = ("truth/ordinary.py", "_stats.py", "calibrate.py", "truth/__init__.py", "truth/robot.py")
Z95 = 1.959964


def run_robot(i: int, *, seed: int, args) -> dict:
    """Robot ``i``'s pairs: fitted against exact modes, per posture and band."""
    rng = np.random.default_rng([seed, i])
    nominal = Robot.load("irb6660", tool="dummy")
    real = draw_real_robot(nominal.xml, rng, base=bool(i % 2), p_form=0.0)
    grid = seed_grid()
    postures = [grid[k] for k in sorted(rng.choice(len(grid), 16, replace=False))]
    tmp = Path(tempfile.mkdtemp(prefix="rmbench_noise_"))
    try:
        data = measure(real.xml, postures, args.method, seed * 1000 + i, args.workers, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    truth = Robot(real.xml, name="real", tool="dummy")
    q = np.array([truth.ik(p).q for p in data.postures])
    exact = ModalModel(truth, ParameterSet([]), data.design, q, data.bands)
    pairs = []
    for k in range(len(data.postures)):
        for band in data.bands:
            meas = data.modes[k].get(band)
            if meas is None or not len(meas):
                continue
            model = exact.modes(np.zeros(0), k, band)
            pr = pair(meas, model)
            for a, b in zip(pr.meas, pr.model):
                pairs.append({"posture": k, "band": band, "f_fit": float(meas.f_n[a]), "f_std": float(meas.f_std[a]),
                              "f_exact": float(model.f_n[b]), "zeta_fit": float(meas.zeta[a]),
                              "zeta_std": float(meas.zeta_std[a]), "zeta_exact": float(abs(model.zeta[b]))})
    return {"index": i, "seed": seed, "pairs": pairs,
            "unpaired": sum(len(pair(data.modes[k][b], exact.modes(np.zeros(0), k, b)).unpaired_meas)
                            for k in range(len(data.postures)) for b in data.bands if b in data.modes[k])}


def _rate(flags) -> list:
    """``[rate, lo, hi]``: a rate with its Wilson 95 % interval."""
    k, n = int(np.sum(flags)), len(flags)
    return [k / n if n else float("nan"), *wilson(k, n)]


def summary(cases: list) -> dict:
    """Coverage and the standard errors' scale per band, over every pair."""
    out = {}
    for band in sorted({p["band"] for c in cases for p in c["pairs"]}):
        rows = [p for c in cases for p in c["pairs"] if p["band"] == band and p["f_std"] > 0]
        e_f = np.array([np.log(p["f_fit"] / p["f_exact"]) for p in rows])
        s_f = np.array([p["f_std"] / p["f_fit"] for p in rows])
        e_z = np.array([np.log(p["zeta_fit"] / p["zeta_exact"]) for p in rows if p["zeta_std"] > 0])
        s_z = np.array([p["zeta_std"] / p["zeta_fit"] for p in rows if p["zeta_std"] > 0])
        z_f, z_z = np.abs(e_f) / s_f, np.abs(e_z) / s_z
        out[band] = {"pairs": len(rows),
                     "f_coverage95": _rate(z_f <= Z95),
                     "f_kappa95": float(np.percentile(z_f, 95) / Z95),
                     "f_err_median": float(np.median(np.abs(e_f))), "f_err_p95": float(np.percentile(np.abs(e_f), 95)),
                     "f_std_median": float(np.median(s_f)),
                     "zeta_coverage95": _rate(z_z <= Z95),
                     "zeta_kappa95": float(np.percentile(z_z, 95) / Z95),
                     "zeta_err_median": float(np.median(np.abs(e_z))), "zeta_std_median": float(np.median(s_z))}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    run_arguments(ap, robots=6)
    ap.add_argument("--method", default="time", choices=("time", "linear"))
    args = ap.parse_args(argv)
    keyed_run(args, f"noise_model_{args.method}", __file__, modules=("rmbench.calibrate", "rmbench.impact"),
              extra=TRUTH_FILES)
    cases = cases_to_lines(args, partial(run_robot, seed=args.seed, args=args),
                           lambda c: f"robot {c['index']}: {len(c['pairs'])} pairs, {c['unpaired']} unpaired")
    line = {"seed": args.seed, "robots": len(cases), "unpaired": sum(c["unpaired"] for c in cases),
            **summary(cases)}
    text = "\n".join(f"{b}: f coverage {100 * v['f_coverage95'][0]:.1f} % "
                     f"({100 * v['f_coverage95'][1]:.1f}-{100 * v['f_coverage95'][2]:.1f}), κ95 {v['f_kappa95']:.2f}, "
                     f"|ln f error| median {100 * v['f_err_median']:.3f} % p95 {100 * v['f_err_p95']:.3f} %, "
                     f"σ_f median {100 * v['f_std_median']:.3f} %; ζ coverage {100 * v['zeta_coverage95'][0]:.1f} %, "
                     f"κ95 {v['zeta_kappa95']:.2f}" for b, v in line.items() if isinstance(v, dict))
    print(text)
    print(json.dumps(line))
    return 0


if __name__ == "__main__":
    sys.exit(main())
