"""A real case (issue 13, item 7): the bundled IRB6660 stand-in against seed 000's real IRB6660.

Seed 000's measured modes (frequencies and damping ratios of nine modes at the three validation
postures, Tables 2-3; all 16 parameters at Table B1's posture; ``src/rmbench/gap/data/
seed000_irb6660.csv``) are diagnosed against the stand-in, fitting on two validation postures and
Table B1's posture and scoring on the third, all three ways round. Printed per fold: the verdict,
the ranked effects with their parameters, the held-out gap before and after (normalised rms gap,
mean frequency and damping error); then the mode-by-mode gap of the nominal model at every
measured posture, and the first mode at the mirror postures (1800, ±200, 0) measured and modelled.
The updated model of each fold whose verdict rests on an effect is saved as an MJCF variant beside
this script's output (``bench/results/gap_real_fold{k}.xml``), and the FRF matrix Table B1 implies
is written as UFF58 (``bench/results/gap_real_table_b1/``).

Last line: ``{"folds", "explained", "f_err_before", "f_err_after", "gap_before", "gap_after",
"mirror_measured_hz", "mirror_model_hz", "seconds"}`` (errors: means over the folds of the held-out
posture's mean relative frequency error; gaps: its rms normalised gap).

usage: python bench/gap_real.py [--workers 2] [--out bench/results]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import warnings
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmbench.gap.cases.real import VALIDATION, diagnose_seed000, write_table_b1_uff  # noqa: E402

HERE = Path(__file__).resolve().parent


def _variant(effect) -> str:
    """MJCF of the stand-in with one ranked effect's fitted model change."""
    from rmbench.gap import ModelBench, TestDesign, library
    from rmbench.impact import load_config
    from rmbench.robot import Robot

    robot = Robot.load("irb6660", tool="dummy")
    design = TestDesign.from_config(load_config("seed_full"))
    eff = {e.name: e for e in library(robot, design)}[effect.name]
    change = eff.change(np.array(list(effect.params.values()), float)).robot_part
    return ModelBench(robot, design, []).robot_for(change).xml


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=str(HERE / "results"))
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    warnings.simplefilter("ignore")
    rc = diagnose_seed000(workers=args.workers)

    f_before, f_after, g_before, g_after, explained = [], [], [], [], 0
    for k, dg in enumerate(rc.folds):
        print(f"fold {k + 1}: held out {VALIDATION[k]} (mm, mm, deg); verdict {dg.verdict}; "
              f"nominal χ²/n {dg.nominal_chi2 / dg.n_residuals:.1f}")
        if dg.verdict == "explained":
            explained += 1
        for i, e in enumerate(dg.effects[:5]):
            b, a = e.heldout_before, e.heldout_after
            mark = "*" if e.chosen else " "
            print(f"  {mark}{i + 1}. {e.name:34s} {e.description:48s} conf {e.confidence:.2f}  "
                  f"held-out gap {b['gap']:7.2f} -> {a['gap']:7.2f} (shrink {100 * e.shrink:5.1f} %), "
                  f"f err {100 * b['f_err']:.1f} -> {100 * a['f_err']:.1f} %, "
                  f"ζ err {100 * b['zeta_err']:.0f} -> {100 * a['zeta_err']:.0f} %")
        if dg.effects:
            best = dg.effects[0]
            f_before.append(best.heldout_before["f_err"])
            f_after.append(best.heldout_after["f_err"])
            g_before.append(best.heldout_before["gap"])
            g_after.append(best.heldout_after["gap"])
        if dg.variant_xml is not None:
            path = out / f"gap_real_fold{k + 1}.xml"
            path.write_text(dg.variant_xml)
            print(f"  updated model saved: {path.name}")
        elif dg.effects:
            # no explanation, but the best single update is still the closest bench robot
            path = out / f"gap_real_fold{k + 1}_best_partial.xml"
            path.write_text(_variant(dg.effects[0]))
            print(f"  best partial update (not an explanation) saved: {path.name}")
        print(f"  localisation: {dg.localisation}")
        print()

    print("nominal model against the real robot, mode by mode (fold 1's gap map)")
    print("posture (mm, mm, deg)       band  mode  f_meas Hz  f_model Hz  Δf %    ζ_meas %  ζ_model %")
    for r in rc.folds[0].where.records:
        key = rc.postures[r["posture"]]
        fm = f"{r['f_model']:10.2f}" if r["paired"] else "  unpaired"
        df = f"{100 * r['df']:+6.1f}" if r["paired"] else "     -"
        zm = f"{100 * r['zeta_model']:9.2f}" if r["paired"] else "        -"
        print(f"{str(key):26s}  {r['band']:4s}  {r['mode']:4d}  {r['f_meas']:9.2f}  {fm}  {df}  "
              f"{100 * r['zeta_meas']:8.2f}  {zm}")
    print()
    print("first mode at the mirror postures")
    for key, m in rc.mirror.items():
        print(f"  {key}: measured {m['measured_hz']:.2f} Hz, stand-in's lowest {m['model_lowest_hz']:.2f} Hz")
    meas_hz = [m["measured_hz"] for m in rc.mirror.values()]
    model_hz = [m["model_lowest_hz"] for m in rc.mirror.values()]
    print(f"  measured asymmetry {100 * (max(meas_hz) / min(meas_hz) - 1):.1f} %, "
          f"stand-in's {100 * (max(model_hz) / min(model_hz) - 1):.2f} %")
    uff = write_table_b1_uff(out / "gap_real_table_b1")
    print(f"Table B1's FRF matrix as UFF58: {len(uff)} files in {out / 'gap_real_table_b1'}")
    print(f"seconds {rc.seconds:.1f}")
    print(json.dumps({"folds": len(rc.folds), "explained": explained,
                      "f_err_before": round(float(np.mean(f_before)), 4) if f_before else None,
                      "f_err_after": round(float(np.mean(f_after)), 4) if f_after else None,
                      "gap_before": round(float(np.mean(g_before)), 3) if g_before else None,
                      "gap_after": round(float(np.mean(g_after)), 3) if g_after else None,
                      "mirror_measured_hz": [round(v, 2) for v in meas_hz],
                      "mirror_model_hz": [round(v, 2) for v in model_hz],
                      "seconds": round(rc.seconds, 1)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
