"""Automatic modal fitting over many draws (issue 12): how often it is right, and whether it knows.

Every band is fitted blind with ``ModalFit()`` and scored against the system that made it
(``rmbench.modal.synthetic.score_fit``): a fit is *correct* when every in-band mode is found within
0.5 % in frequency, 10 % in damping ratio and MAC >= 0.98 for φR and φL, and no other mode is
returned. A wrong fit is *flagged* when its ``fit_ok_`` is False, *silent* otherwise; a correct fit
with ``fit_ok_`` False is a *false alarm*.

1. Seed 000's Table B1 (9 modes, non-reciprocal; all 9 in the data, out-of-band ones acting as
   residuals), both bands, complex Gaussian noise of 1 % of each FRF's peak (``--b1-draws`` per
   band), and 0.3 % and 3 % (``--b1-other`` per band and level).
2. Random MDOF systems (``random_system``): 3-12 modes per band, ζ log-uniform 0.5-15 %,
   non-reciprocal random φL/φR, up to two modes below and above the band, noise log-uniform
   0.3-3 % of each FRF's peak. Three systems in four have their close pairs 1.0-1.5 half-power
   bandwidths apart, one in four 0.5-1.0 (closer than the issue's resolvability line).
   *Resolvable*: every pair at least one bandwidth apart and noise <= 1 %.

Rates carry Wilson 95 % intervals. Failures are listed with their seeds (rerun one with
``--show KIND:SEED``). Last line: ``{"tableB1_correct", "random_correct", "silent_failures",
"draws"}`` (Table B1 at 1 % noise, both bands; random systems that are resolvable; silent failures
over every fit of the run; number of fits).

usage: python bench/modal_robustness.py [--b1-draws 200] [--b1-other 100] [--random 600]
                                        [--workers 2] [--show b1-high-0.01:1234]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor

os.environ.setdefault("OMP_NUM_THREADS", "1")       # one core per worker
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from _stats import wilson  # noqa: E402
from tqdm import tqdm  # noqa: E402

from rmbench.modal import ModalFit  # noqa: E402
from rmbench.modal.synthetic import add_noise, random_system, score_fit, table_b1  # noqa: E402

B1_SEED, RANDOM_SEED = 10_000, 20_000


def draw(kind: str, seed: int):
    """The system and noisy FRFs of one draw; ``kind`` is ``b1-BAND-LEVEL`` or ``random``."""
    rng = np.random.default_rng(seed)
    if kind.startswith("b1-"):
        _, band, level = kind.split("-")
        system, level = table_b1(band), float(level)
    else:
        close = (1.0, 1.5) if rng.random() < 0.75 else (0.5, 1.0)
        system = random_system(rng, close=close)
        level = float(np.exp(rng.uniform(np.log(0.003), np.log(0.03))))
    return system, level, add_noise(system.frf(), level, rng)


def run(task):
    kind, seed = task
    system, level, H = draw(kind, seed)
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = ModalFit().fit(system.freq, H)
        score = score_fit(fit.f_n_, fit.zeta_, fit.phi_r_, fit.phi_l_, system)
        correct, flagged = score.correct, not fit.fit_ok_
        why, reason = score.reason, fit.fit_reason_
    except Exception as err:  # an exception is a loud failure, never a silent one
        correct, flagged, why, reason = False, True, "", f"{type(err).__name__}: {err}"
    return {"kind": kind, "seed": seed, "correct": correct, "flagged": flagged, "why": why,
            "reason": reason, "seconds": time.perf_counter() - t0, "level": level,
            "n_modes": int(system.in_band.sum()), "separation": system.min_separation,
            "lines": len(system.freq)}


def row(label: str, rs: list[dict]) -> str:
    n = len(rs)
    if n == 0:
        return f"  {label:<38} {0:>5}"
    c = sum(r["correct"] for r in rs)
    fl = sum((not r["correct"]) and r["flagged"] for r in rs)
    si = sum((not r["correct"]) and not r["flagged"] for r in rs)
    fa = sum(r["correct"] and r["flagged"] for r in rs)
    lo, hi = wilson(c, n)
    return (f"  {label:<38} {n:>5} {c / n:9.2%} [{lo:6.1%}, {hi:6.1%}] {fl / n:9.2%} {si / n:8.2%} "
            f"{fa / n:11.2%}")


def header() -> str:
    return (f"  {'':<38} {'fits':>5} {'correct':>9} {'95 % interval':>16} {'flagged':>9} "
            f"{'silent':>8} {'false alarm':>11}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--b1-draws", type=int, default=200, help="Table B1 draws per band at 1 %% noise")
    ap.add_argument("--b1-other", type=int, default=100, help="per band at 0.3 %% and at 3 %%")
    ap.add_argument("--random", type=int, default=600, help="random systems")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--show", default=None, help="KIND:SEED: fit one draw and print it")
    args = ap.parse_args()
    if args.show:
        return show(*args.show.rsplit(":", 1))

    tasks = []
    for band in ("low", "high"):
        tasks += [(f"b1-{band}-0.01", B1_SEED + i) for i in range(args.b1_draws)]
        for level in ("0.003", "0.03"):
            tasks += [(f"b1-{band}-{level}", B1_SEED + i) for i in range(args.b1_other)]
    tasks += [("random", RANDOM_SEED + i) for i in range(args.random)]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        res = list(tqdm(pool.map(run, tasks, chunksize=4), total=len(tasks), desc="fits",
                        file=sys.stderr))
    wall = time.perf_counter() - t0

    print(f"Automatic modal fitting, {len(res)} blind fits in {wall:.0f} s on {args.workers} workers")
    print("\nSeed 000's Table B1, noise as a share of each FRF's peak:")
    print(header())
    for band in ("low", "high"):
        for level in ("0.003", "0.01", "0.03"):
            rs = [r for r in res if r["kind"] == f"b1-{band}-{level}"]
            print(row(f"{band} band, {float(level):.1%} noise", rs))
    b1 = [r for r in res if r["kind"].startswith("b1-") and r["kind"].endswith("-0.01")]
    print(row("both bands, 1 % noise", b1))

    rnd = [r for r in res if r["kind"] == "random"]
    resolvable = [r for r in rnd if r["separation"] >= 1.0 and r["level"] <= 0.01]
    print(f"\nRandom MDOF systems ({len(rnd)}):")
    print(header())
    print(row("all", rnd))
    print(row("resolvable (sep >= 1 bw, noise <= 1 %)", resolvable))
    for lo, hi in ((0.5, 1.0), (1.0, 1.5), (1.5, np.inf)):
        rs = [r for r in rnd if lo <= r["separation"] < hi]
        print(row(f"closest pair {lo:g}-{hi:g} bandwidths", rs))
    for lo, hi in ((0.003, 0.01), (0.01, 0.03 + 1e-12)):
        rs = [r for r in rnd if lo <= r["level"] < hi]
        print(row(f"noise {lo:.1%}-{hi:.1%}", rs))
    for lo, hi in ((3, 5), (6, 8), (9, 12)):
        rs = [r for r in rnd if lo <= r["n_modes"] <= hi]
        print(row(f"{lo}-{hi} modes in band", rs))
    lines = np.array([r["lines"] for r in rnd])
    print(f"  drawn: {np.mean([r['n_modes'] for r in rnd]):.1f} modes per band on average, "
          f"{lines.min()}-{lines.max()} lines (median {np.median(lines):.0f})")

    print("\nEverything fitted:")
    print(header())
    print(row("all fits", res))
    secs = np.array([r["seconds"] for r in res])
    print(f"\nTime per band fit (one core): median {np.median(secs):.2f} s, 95th percentile "
          f"{np.percentile(secs, 95):.2f} s, max {secs.max():.2f} s")

    wrong = [r for r in res if not r["correct"]]
    if wrong:
        print("\nWrong fits (KIND:SEED, flagged or silent, what was wrong | what the fit said):")
        for r in wrong:
            print(f"  {r['kind']}:{r['seed']} {'flagged' if r['flagged'] else 'SILENT '} "
                  f"{r['why']} | {r['reason']}")
    silent = sum((not r["correct"]) and not r["flagged"] for r in res)
    print(json.dumps({
        "tableB1_correct": round(sum(r["correct"] for r in b1) / max(len(b1), 1), 4),
        "random_correct": round(sum(r["correct"] for r in resolvable) / max(len(resolvable), 1), 4),
        "silent_failures": round(silent / len(res), 4), "draws": len(res)}))


def show(kind: str, seed: str) -> None:
    """Fit one draw and print the truth beside the fit."""
    system, level, H = draw(kind, int(seed))
    np.set_printoptions(precision=4, suppress=True, linewidth=120)
    print(f"{kind}:{seed}: band {system.freq[0]:.4g}-{system.freq[-1]:.4g} Hz, "
          f"{len(system.freq)} lines, noise {level:.2%}, closest pair "
          f"{system.min_separation:.2f} bandwidths")
    inb = system.in_band
    print("true f_n", system.f_n[inb], "zeta", system.zeta[inb])
    print("outside ", system.f_n[~inb], "zeta", system.zeta[~inb])
    fit = ModalFit().fit(system.freq, H)
    print("fit  f_n", fit.f_n_, "zeta", fit.zeta_)
    print("score:", score_fit(fit.f_n_, fit.zeta_, fit.phi_r_, fit.phi_l_, system).reason or "correct")
    print("fit_ok:", fit.fit_ok_, fit.fit_reason_)
    for note in fit.quality_.notes:
        print("note:", note)


if __name__ == "__main__":
    main()
