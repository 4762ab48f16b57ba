"""Gap diagnosis on withheld effects (issue 13): how often it names the hidden cause, and how fast.

1. Blind cases: ``rmbench gap blind --cases N --seed S --method mixed --time-share T`` (each case a
   16-posture campaign on a copy of the IRB6660 with hidden effects injected by plain MJCF edits,
   ``rmbench.gap.cases.truth``, never the variant code that builds the candidates, commanded by
   the nominal IK, exported to UFF58 and read back, diagnosed against the nominal model). The
   cases go to a JSON-lines file, so a killed run resumes.
2. From those lines: top-1 and top-3 identification (kind and location) on the single in-library
   cases, strict and up to the effects the diagnosis reports as indistinguishable; median held-out
   shrink over the in-library cases; false attributions on the out-of-library cases; both effects
   of a two-effect case in the top 3; calibration of the confidences; the indistinguishable groups
   and how often each was reported; per-case seconds.
3. Speed on the seed's campaign: a linear-path campaign of all 112 postures on a variant
   (j3_flex stiffness × 0.8) commanded by the nominal IK, then ``rmbench gap diagnose`` on it,
   timed end to end (modal fit of the data included).

Last line: ``{"cases", "top1", "top3", "median_shrink", "false_attribution", "pair_recall",
"diagnose_s"}`` (top-1 and top-3 strict; ``diagnose_s`` the 112-posture diagnosis).

A fresh seed is drawn per run unless ``--seed`` is given, and printed; the cases go to
``bench/results/gap_blind_s<seed>_<digest>.jsonl``, keyed by the seed and a digest of the code,
so a rerun resumes only the same code's run and never re-prints another's case list. Draws the
generator rejected (invisible, or postures the changed robot cannot hold) are counted and printed.

With ``--scheduler ADDRESS`` the cases run on an existing dask cluster (``rmbench gap blind
--scheduler``), one a single-threaded worker; the speed timing stays here.

usage: python bench/gap_blind.py [--cases 40] [--seed S] [--time-share 0.3] [--workers 2]
                                 [--lines FILE] [--no-speed] [--scheduler ADDRESS]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from _stats import RMBENCH, blind_cases, keyed_run  # noqa: E402
from _stats import rate as _rate  # noqa: E402

from rmbench.gap.cases.blind import case_from_dict, summarise  # noqa: E402

HERE = Path(__file__).resolve().parent


def run_cases(args) -> list:
    return [case_from_dict(c) for c in blind_cases(
        args, "--method", "mixed", "--time-share", str(args.time_share), "--workers", str(args.workers),
        *(() if args.scheduler is None else ("--scheduler", args.scheduler)))]


def speed(args) -> tuple[float, str]:
    """Seconds of ``rmbench gap diagnose`` on a 112-posture campaign, and its verdict line."""
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        variant = tmp / "soft_j3.xml"
        subprocess.run([RMBENCH, "model", "variant", "--robot", "irb6660", "--tool", "dummy",
                        "--set", "j3_flex.stiffness*=0.8", "--out", str(variant)], check=True,
                       stdout=subprocess.DEVNULL)
        data = tmp / "seed_full.nc"
        subprocess.run([RMBENCH, "campaign", "run", "seed_full", "--robot", str(variant),
                        "--commands-from", "irb6660", "--method", "linear", "--out", str(data),
                        "--workers", str(args.workers)], check=True, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL)
        t0 = time.perf_counter()
        out = subprocess.run([RMBENCH, "gap", "diagnose", "--robot", "irb6660", "--data", str(data),
                              "--workers", str(args.workers), "--json"], check=True,
                             capture_output=True, text=True)
        seconds = time.perf_counter() - t0
    res = json.loads(out.stdout)
    top = res["effects"][0] if res["effects"] else {}
    return seconds, (f"verdict {res['verdict']}, top {top.get('name')} "
                     f"{top.get('params')}, shrink {top.get('shrink', float('nan')):.3f}")


def report(cases) -> dict:
    s = summarise(cases)
    one = [c for c in cases if len(c.hidden) == 1 and c.hidden[0].in_library]
    two = [c for c in cases if len(c.hidden) == 2]
    out = [c for c in cases if not c.hidden[0].in_library]
    print("case  method  hidden                                              verdict      top-3 (confidence)                                  shrink  s")
    for c in cases:
        hidden = " + ".join(h.name for h in c.hidden)
        top = ", ".join(f"{n} ({p:.2f})" for n, p in c.ranked[:3])
        mark = ("1" if c.top1 else ("c" if c.top1_class else ("3" if c.top3 or c.top3_class else "-")))
        if not c.hidden[0].in_library:
            mark = "ok" if c.verdict == "unexplained" else "FA"
        secs = c.seconds.get("campaign", 0) + c.seconds.get("diagnose", 0)
        print(f"{c.index:4d}  {c.method:6s}  {hidden:50s}  {c.verdict:11s}  {mark:2s} {top:52s}  "
              f"{100 * c.shrink:5.1f}  {secs:.0f}")
    print()
    print(f"cases {len(cases)} ({s['time_domain']} time-domain): {len(one)} single in library, "
          f"{len(two)} pairs, {len(out)} out of library; {s['rejected']} draws rejected (invisible, or "
          "postures not held) and drawn again")
    print(f"top-1 (kind and location, strict)          {_rate(c.top1 for c in one)}")
    print(f"top-1 up to indistinguishable effects      {_rate(c.top1_class for c in one)}")
    print(f"top-3 (strict)                             {_rate(c.top3 for c in one)}")
    print(f"top-3 up to indistinguishable effects      {_rate(c.top3_class for c in one)}")
    shr = [c.shrink for c in one + two]
    print(f"held-out shrink, in library: median {100 * np.median(shr):.1f} %, "
          f"25th percentile {100 * np.percentile(shr, 25):.1f} %" if shr else "no in-library cases")
    print(f"false attributions (out of library)        {_rate(c.verdict != 'unexplained' for c in out)}")
    for kind, n in s["out_kinds"].items():
        sel = [c for c in out if c.hidden[0].kind == kind]
        if sel:
            print(f"  {kind:22s} unexplained             {_rate(c.verdict == 'unexplained' for c in sel)}")
    print(f"both effects of a pair in the top 3        {_rate(bool(c.pair_in_top3) for c in two)}")
    print(f"explained verdicts, in library             {_rate(c.verdict == 'explained' for c in one + two)}")
    for m in ("linear", "time"):
        sub = [c for c in one if c.method == m]
        if sub:
            print(f"  {m:6s}: top-1 {_rate(c.top1 for c in sub)}, top-3 {_rate(c.top3 for c in sub)}")
    print()
    print("calibration of the confidence (top-3 entries of the in-library cases)")
    print("confidence bin  n    mean confidence  fraction right")
    for b in s["calibration"]:
        mc = "-" if not b["n"] else f"{b['mean_confidence']:.3f}"
        fr = "-" if not b["n"] else f"{b['fraction_right']:.3f}"
        print(f"{b['bin'][0]:.1f}-{b['bin'][1]:.1f}         {b['n']:<4d} {mc:16s} {fr}")
    groups = Counter(tuple(g) for c in cases for g in c.equivalent)
    print()
    print("effects the data could not tell apart (|cos| >= 0.995 of their sensitivity columns), cases reporting each group")
    for g, n in groups.most_common():
        print(f"  {n:3d}  {' = '.join(g)}")
    t = [c.seconds.get("diagnose", 0) for c in cases]
    tc = [c.seconds.get("campaign", 0) for c in cases]
    for m in ("linear", "time"):
        sel = [c for c in cases if c.method == m]
        if sel:
            tot = [c.seconds.get("campaign", 0) + c.seconds.get("diagnose", 0) for c in sel]
            print(f"seconds per {m} case: median {np.median(tot):.0f}, max {np.max(tot):.0f} "
                  f"(campaign median {np.median([c.seconds.get('campaign', 0) for c in sel]):.0f})")
    print(f"diagnosis alone: median {np.median(t):.0f} s, max {np.max(t):.0f} s; campaign median {np.median(tc):.0f} s")
    return s


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", type=int, default=40)
    ap.add_argument("--seed", type=int, default=None, help="default: a fresh one, printed")
    ap.add_argument("--time-share", type=float, default=0.3)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--lines", default=None,
                    help="JSON-lines file (default: bench/results/gap_blind_s<seed>_<code digest>.jsonl)")
    ap.add_argument("--no-speed", action="store_true", help="skip the 112-posture timing")
    ap.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="address of an existing dask scheduler: the cases run on its cluster, one a worker")
    args = ap.parse_args()
    keyed_run(args, "gap_blind", __file__)
    cases = run_cases(args)
    s = report(cases)
    diagnose_s = float("nan")
    if not args.no_speed:
        diagnose_s, line = speed(args)
        print()
        print(f"112-posture campaign (seed_full, j3_flex stiffness x 0.8, linear path): "
              f"gap diagnose {diagnose_s:.1f} s; {line}")
    one = [c for c in cases if len(c.hidden) == 1 and c.hidden[0].in_library]
    print(json.dumps({"cases": len(cases), "top1": round(float(np.mean([c.top1 for c in one])), 4),
                      "top3": round(float(np.mean([c.top3 for c in one])), 4),
                      "median_shrink": round(s["median_shrink"], 4),
                      "false_attribution": round(s["false_attribution"], 4),
                      "pair_recall": round(s["pair_recall"], 4), "diagnose_s": round(diagnose_s, 1),
                      "seed": args.seed, "rejected": s["rejected"]}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
