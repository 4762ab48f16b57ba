"""Gap diagnosis on laser-tracker readings (issue 14): which error sources, found how often, at what cost.

1. Blind cases: ``rmbench gap blind --data tracker --cases N --seed S`` (each case an MH180 with
   hidden error sources drawn by :mod:`rmbench.gap.cases.tracker_blind` — one source in three cases of
   five, two or three in one, backlash outside the library in one — read at 250 quasi-random
   configurations twice, 500 readings, diagnosed against the nominal robot). The cases go to a
   JSON-lines file, so a killed run resumes.
2. From those lines: recall of every hidden source (and of those that carry ≥ 10 % of the true
   error), the share of reported sources that were not there (strict, and up to the look-alikes
   the diagnosis names),
   the median held-out shrink of the true (noise-free) error and of the measured rms, the share
   of out-of-library cases that say "unexplained", and per case the accuracy level (model
   invalidation, METHODS.md §7) of the nominal and updated model beside their true maximum errors.
3. Speed: ``rmbench gap diagnose --readings`` on a 500-reading CSV, end to end.

Last line: ``{"cases", "recall", "false_sources", "median_shrink", "unexplained_ok", "diagnose_s"}``
(``median_shrink`` of the true error at the held-out configurations).

A fresh seed is drawn per run unless ``--seed`` is given, and printed; the cases go to
``bench/results/gap_tracker_s<seed>_<digest>.jsonl``, keyed by the seed and a digest of the code.
The tracker generator rejects no draw: a faint one is scaled up until it is visible (the library's
blind cases, part 1). The spread robots (issue 43; ``bench/truth/tracker_spread.py``) carry their
structural source at its drawn size: whether it shows is decided without the diagnosis
(``truth.tracker.readings_visibility``: the noise-free readings with and without it against the
readings' own noise on independent draws, as ``bench/blind_tracker.py`` decides). Sizes are never
enlarged and draws never redrawn (issue 79): an invisible draw is counted and reported apart, kept
in the file, not scored. The spread keys ``spread_rejected`` and the second line's
``rejected_as_misses`` count the invisible draws (until issue 81 the draws rejected as hidden after
enlarging); ``spread_scaled`` is 0 (no source is enlarged any more); ``spread_invisible`` counts
them too.

With ``--scheduler ADDRESS`` both kinds of case run on an existing dask cluster, one a
single-threaded worker, and are written as they finish: the same lines as a run here, but for the
seconds.

usage: python bench/gap_tracker.py [--cases 40] [--seed S] [--lines FILE] [--scheduler ADDRESS]
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
from functools import partial
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from _stats import RMBENCH, blind_cases, keyed_run, rate, resumed_cases, ship_bench_modules, wilson  # noqa: E402
from truth.tracker import campaign, readings_visibility, spread_xml  # noqa: E402
from truth.tracker_spread import SpreadRobot, draw_structural  # noqa: E402

from rmbench.gap.cases.tracker_blind import summarise_tracker  # noqa: E402
from rmbench.parallel import map_cases  # noqa: E402

HERE = Path(__file__).resolve().parent


def run_cases(args) -> list:
    return blind_cases(args, "--data", "tracker", *(() if args.scheduler is None else ("--scheduler", args.scheduler)))


def speed() -> tuple[float, str]:
    """Seconds of ``rmbench gap diagnose --readings`` on 500 readings, and its verdict line."""
    from rmbench.gap.cases.tracker_blind import HiddenSource, TrueRobot
    from rmbench.io.tracker_csv import TrackerReadings, write_tracker_csv
    from rmbench.robot import Robot
    from rmbench.tracker import MH180_JOINT_BOX, sobol_points

    robot = Robot.load("mh180")
    rng = np.random.default_rng(5)
    hidden = (HiddenSource("gravity_compliance", "j2", (0.6,)),
              HiddenSource("joint_offset", "j5", (8e-4,)))
    truth = TrueRobot(robot, hidden, 1.0, rng)
    q = np.repeat(sobol_points(250, *MH180_JOINT_BOX, rng), 2, axis=0)
    t = np.arange(len(q)) * 15.0
    y = truth.positions(q, t, q, noise=True, rng=rng)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "readings.csv"
        write_tracker_csv(path, TrackerReadings(np.repeat(np.arange(250), 2), tuple(robot.arm_joints),
                                                q, y, None, None, ("bench: 500 readings",), t, None))
        t0 = time.perf_counter()
        out = subprocess.run([RMBENCH, "gap", "diagnose", "--readings", str(path), "--json"],
                             check=True, capture_output=True, text=True)
        seconds = time.perf_counter() - t0
    res = json.loads(out.stdout)
    chosen = [e["name"] for e in res["effects"] if e["chosen"]]
    return seconds, (f"hidden j2 compliance +60 % and j5 offset 0.046°: verdict {res['verdict']}, "
                     f"chosen {', '.join(chosen)}, shrink {res['shrink']:.3f}")


def report(cases) -> dict:
    s = summarise_tracker(cases)
    print("case  hidden (share of the true error)                                  verdict      chosen                                              "
          "shrink true/meas  level before/after vs true max (mm)")
    for c in cases:
        hidden = " + ".join(f"{h['kind']}@{h['location']} ({100 * c['shares'].get(h['kind'] + '@' + h['location'], 0):.0f} %)"
                            for h in c["hidden"])
        chosen = ", ".join(c["chosen"]) or "-"
        lv = (f"{1e3 * c['level_before']:.3f}/{1e3 * c['level_after']:.3f} vs "
              f"{1e3 * c['true_max_before']:.3f}/{1e3 * c['true_max_after']:.3f}"
              if c["level_before"] is not None else "-")
        print(f"{c['index']:4d}  {hidden:64s}  {c['verdict']:11s}  {chosen:50s}  "
              f"{100 * c['shrink_true']:5.1f}/{100 * c['shrink_measured']:5.1f}  {lv}")
    inl = [c for c in cases if c["in_library"]]
    out = [c for c in cases if not c["in_library"]]
    print()
    print(f"cases {len(cases)}: {len(inl)} in the library ({sum(len(c['hidden']) > 1 for c in inl)} with "
          f"several sources), {len(out)} outside (backlash)")
    print(f"recall, every hidden source                      "
          f"{rate(v for c in inl for v in c['found'].values())}")
    print(f"  of the sources carrying >= 10 % of the error   "
          f"{rate(v for c in inl for k, v in c['found'].items() if c['shares'].get(k, 0.0) >= 0.1)}")
    print(f"  up to look-alikes the diagnosis names          "
          f"{rate(v for c in inl for v in c['found_alike'].values())}")
    print(f"sources reported that were not there             {s['false_n'][0]}/{s['false_n'][1]} = "
          f"{100 * s['false_sources']:.1f} % (up to look-alikes {100 * s['false_alike']:.1f} %)")
    sh = [c["shrink_true"] for c in inl]
    shm = [c["shrink_measured"] for c in inl]
    print(f"held-out shrink, true error: median {100 * np.median(sh):.1f} %, 25th percentile "
          f"{100 * np.percentile(sh, 25):.1f} %; measured rms: median {100 * np.median(shm):.1f} %")
    print(f"out-of-library cases that say unexplained        {rate(c['verdict'] == 'unexplained' for c in out)}")
    print(f"explained verdicts, in library                   {rate(c['verdict'] == 'explained' for c in inl)}")
    by_kind = Counter()
    hit = Counter()
    for c in inl:
        for name, ok in c["found"].items():
            kind = name.split("@")[0]
            by_kind[kind] += 1
            hit[kind] += bool(ok)
    print("recall by kind: " + ", ".join(f"{k} {hit[k]}/{n}" for k, n in sorted(by_kind.items())))
    lv = [c for c in cases if c["level_before"] is not None]
    if lv:
        under_b = np.mean([c["level_before"] < c["true_max_before"] for c in lv])
        under_a = np.mean([c["level_after"] < c["true_max_after"] for c in lv])
        print(f"accuracy level (alpha 0.9, <= 10 readings per configuration) below the true maximum at the "
              f"held-out configurations: nominal {100 * under_b:.0f} % of cases, updated {100 * under_a:.0f} %")
        print(f"median accuracy level: nominal {1e3 * np.median([c['level_before'] for c in lv]):.3f} mm, "
              f"updated {1e3 * np.median([c['level_after'] for c in lv]):.3f} mm; median workspace true max: "
              f"nominal {1e3 * np.median([c['workspace_max_before'] for c in lv]):.3f} mm, updated "
              f"{1e3 * np.median([c['workspace_max_after'] for c in lv]):.3f} mm")
    d = [c["seconds"]["diagnose"] for c in cases]
    print(f"diagnosis seconds per case (500 readings, one core): median {np.median(d):.1f}, max {np.max(d):.1f}")
    return s


def _campaign_data(nominal, q, order, t, y):
    from rmbench.gap.tracker.diagnosis import TrackerData, default_covariance

    cov = default_covariance(nominal, q, y)
    return TrackerData(q, y, order, np.sqrt(np.diagonal(cov, axis1=1, axis2=2)), t, tuple(nominal.arm_joints),
                       covariance=cov)


def _truth(i: int, seed: int, nominal, xml: str, source, q, previous, t):
    """The case's true robot and, where it carries a structural source, whether the source shows
    in the readings (:func:`truth.tracker.readings_visibility`: decided without the diagnosis,
    never enlarged). Returns the robot and its visibility record (None without a source)."""
    def build(src):     # the same tracker placement with and without the source
        return SpreadRobot(xml, src, np.random.default_rng([seed, i, 43, 1]), tool=nominal.tool)

    truth = build(source)
    if source is None:
        return truth, None
    return truth, readings_visibility(truth, build(None), q, previous, t, seed * 1000 + i + 500)


def run_spread_case(i: int, *, seed: int, box: str = "calibration") -> dict:
    """One spread robot (``bench/truth/tracker_spread.py``), read over the joint ranges ``box``,
    diagnosed with and without ``--calibrate``; an invisible source's record, not diagnosed."""

    from rmbench.gap.tracker.diagnosis import TrackerSettings, diagnose_tracker
    from rmbench.robot import Robot

    rng = np.random.default_rng([seed, i, 43])
    nominal = Robot.load("mh180")
    xml, drawn = spread_xml(nominal.xml, rng)
    source = None
    if i % 2 == 1:          # half carry a structural source, one in four of those outside the library
        source = draw_structural(rng, in_library=(i // 2) % 4 != 3, n_joint=len(nominal.arm_joints))
    q, order, previous = campaign(rng, box=box)
    t = np.arange(len(q)) * 15.0
    truth, vis = _truth(i, seed, nominal, xml, source, q, previous, t)
    out = {"index": i, "seed": seed, "box": box, "drawn": drawn, "source": source,
           "name": None if source is None else f"{source['kind']}@{source['location']}",
           "in_library": source is None or source["kind"] not in ("backlash", "directional_stiffness")}
    if vis is not None and not vis["visible"]:      # counted and reported apart, never enlarged
        return {**out, "noise_free": vis, "invisible": True}
    y = truth.positions(q, previous, t, rng)
    data = _campaign_data(nominal, q, order, t, y)
    p_true = truth.positions(q, previous, t)
    for label, cal in (("calibrated", True), ("plain", False)):
        t0 = time.perf_counter()
        dg = diagnose_tracker(nominal, data, settings=TrackerSettings(calibrate=cal))
        seconds = time.perf_counter() - t0
        held = np.isin(order, dg.held)
        hours = t / 3600

        def true_rms(fitted):
            e = p_true[held] - fitted.position(q[held], hours[held])
            return float(np.sqrt(np.mean(np.sum(e ** 2, axis=1))))

        chosen = [s.name for s in dg.chosen]
        before, after = true_rms(dg.nominal_fitted), true_rms(dg.fitted)
        out[label] = {"verdict": dg.verdict, "chosen": chosen,
                      "confidence": {s.name: s.confidence for s in dg.chosen},
                      "true_rms_before": before, "true_rms_after": after,
                      "shrink_true": 1 - after / before if before > 0 else 0.0, "seconds": seconds}
        if cal and dg.calibration is not None:
            out[label]["identifiable"] = sum(p["identifiability"] == "identifiable" for p in dg.calibration["params"])
    if vis is not None:
        out["noise_free"] = vis
    return out


def summarise_spread(cases, invisible=()) -> dict:
    """Issue 43's figures: recall of the structural source with --calibrate, spurious sources
    where there are none, the held-out true error's shrink, out-of-library cases unexplained; the
    ``invisible`` draws (their lines) counted by source."""
    inl = [c for c in cases if c["source"] is not None and c["in_library"]]
    none = [c for c in cases if c["source"] is None]
    out = [c for c in cases if not c["in_library"]]
    frac = (lambda xs: float(np.mean(xs)) if xs else None)
    res = {"spread_cases": len(cases),
           # no source is enlarged (issue 79): [0, sources drawn]; the invisible draws by source
           "scaled": [0, int(sum(c["source"] is not None for c in cases)) + len(invisible)],
           "rejected": dict(Counter(c["name"] for c in invisible)), "invisible": len(invisible)}
    for label in ("calibrated", "plain"):
        res[label] = {
            "recall": frac([c["name"] in c[label]["chosen"] for c in inl]),
            "false_sources": frac([bool(c[label]["chosen"]) for c in none]),
            "extra_sources_with_one": frac([any(n != c["name"] for n in c[label]["chosen"]) for c in inl]),
            "median_shrink": float(np.median([c[label]["shrink_true"] for c in cases])) if cases else None,
            "unexplained_ok": frac([c[label]["verdict"] == "unexplained" for c in out]),
            # an out-of-library effect the calibration absorbs whole ("no significant gap") is
            # not attributed either, but is not the "unexplained" the issue asks for
            "out_not_attributed": frac([c[label]["verdict"] != "explained" for c in out]),
            "verdicts": dict(Counter(c[label]["verdict"] for c in cases)),
            "recall_by_kind": {k: [sum(c["name"] in c[label]["chosen"] for c in inl if c["source"]["kind"] == k),
                                   sum(c["source"]["kind"] == k for c in inl)]
                               for k in sorted({c["source"]["kind"] for c in inl})}}
        # where the source shows beyond the readings' noise (_truth); every scored one does since
        # issue 81 (an invisible draw is not scored), older lines' records say whether it reached
        # the bare threshold of the test that knew its form
        seen = [c for c in inl if c.get("noise_free", {}).get("visible")]
        res[label]["distinguishable"] = [len(seen), len(inl)]
        res[label]["recall_distinguishable"] = frac([c["name"] in c[label]["chosen"] for c in seen])
        seen_out = [c for c in out if c.get("noise_free", {}).get("visible")]
        res[label]["unexplained_ok_distinguishable"] = frac([c[label]["verdict"] == "unexplained" for c in seen_out])
        res[label]["out_distinguishable"] = [len(seen_out), len(out)]
        # each source named with confidence >= 0.8, and whether it is the hidden one
        confident = [n == c["name"] for c in cases for n, w in c[label]["confidence"].items() if w >= 0.8]
        res[label]["confident"] = len(confident)
        res[label]["confident_right"] = frac(confident)
    return res


def spread_with_rejected_as_misses(cases, invisible=()) -> dict:
    """The calibrated spread figures with every invisible draw (``invisible``: their lines) counted
    as a case of its class and a miss (issue 78; until issue 81 the draws rejected as hidden after
    enlarging): the draws no test could see are outcomes too. Each rate as ``[k, n, rate,
    wilson_lo95, wilson_hi95]``; ``rejected_in_library``, ``rejected_out_of_library``: the invisible
    draws of each class."""
    inl = [c for c in cases if c["source"] is not None and c["in_library"]]
    out = [c for c in cases if not c["in_library"]]
    rej_in = sum(bool(c["in_library"]) for c in invisible)
    rej_out = len(invisible) - rej_in

    def rated(k, n):
        lo, hi = wilson(k, n) if n else (None, None)
        return [k, n, round(k / n, 4) if n else None, None if lo is None else round(lo, 4),
                None if hi is None else round(hi, 4)]

    return {"rejected_in_library": rej_in, "rejected_out_of_library": rej_out,
            "recall": rated(sum(c["name"] in c["calibrated"]["chosen"] for c in inl), len(inl) + rej_in),
            "unexplained_strict": rated(sum(c["calibrated"]["verdict"] == "unexplained" for c in out),
                                        len(out) + rej_out)}


def run_spread(args) -> dict:
    """The spread cases into their own keyed JSON-lines file, resumed; their summary."""
    stem = "gap_tracker_spread_" if args.spread_box == "calibration" else f"gap_tracker_spread_{args.spread_box}_"
    lines = Path(args.lines).with_name(Path(args.lines).name.replace("gap_tracker_", stem))
    done = {c["index"]: c for c in resumed_cases(lines, args.seed)}
    only = None if args.only is None else {int(x) for x in args.only.split(",") if x.strip()}
    todo = [i for i in range(args.spread) if not (i in done or (only is not None and i not in only))]
    if args.scheduler is not None:
        ship_bench_modules()
    one = partial(run_spread_case, seed=args.seed, box=args.spread_box)
    for i, c in map_cases(one, todo, workers=1, scheduler=args.scheduler):
        with open(lines, "a") as fh:
            fh.write(json.dumps(c) + "\n")
        done[i] = c
        if c.get("invisible"):
            vis = c["noise_free"]
            print(f"spread {i}: hidden {c['name']} invisible (χ² excess {vis['chi2_with'] - vis['chi2_null']:.4g}, "
                  f"threshold {vis['threshold']:.4g}), not scored", flush=True)
            continue
        cal, plain = c["calibrated"], c["plain"]
        print(f"spread {i}: hidden {c['name'] or 'none'}; --calibrate {cal['verdict']}, chosen "
              f"{', '.join(cal['chosen']) or '-'}, true shrink {100 * cal['shrink_true']:.0f} %; without: "
              f"{plain['verdict']}, chosen {', '.join(plain['chosen']) or '-'}", flush=True)
    cases = [done[i] for i in sorted(done) if i < args.spread and not done[i].get("invisible")]
    invisible = [done[i] for i in sorted(done) if i < args.spread and done[i].get("invisible")]
    s = summarise_spread(cases, invisible)
    s["rejected_as_misses"] = spread_with_rejected_as_misses(cases, invisible)
    print(json.dumps(s, indent=1))
    return s


def _spread_line(spread: dict) -> dict:
    """The bench line's spread keys (issue 43), from :func:`summarise_spread`'s ``calibrated``."""
    c = spread["calibrated"]
    return {"spread_cases": spread["spread_cases"], "spread_recall": c["recall"],
            "spread_false_sources": c["false_sources"], "spread_median_shrink": c["median_shrink"],
            "spread_unexplained_ok": c["unexplained_ok"], "spread_confident_right": c["confident_right"],
            "spread_scaled": spread["scaled"][0], "spread_rejected": sum(spread["rejected"].values()),
            "spread_invisible": spread["invisible"]}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", type=int, default=40)
    ap.add_argument("--spread", type=int, default=40,
                    help="robots whose every joint, link and mass differs (issue 43), diagnosed with --calibrate")
    ap.add_argument("--spread-only", action="store_true", help="run only the spread cases")
    ap.add_argument("--spread-box", choices=("calibration", "machining"), default="calibration",
                    help="the spread campaign's joint ranges: every joint swept wide (default), or the "
                         "machining region, where a gear error once per revolution looks like offset and compliance")
    ap.add_argument("--seed", type=int, default=None, help="default: a fresh one, printed")
    ap.add_argument("--only", default=None, metavar="I,J,...",
                    help="run only these spread robots (indices; parallel processes, each with its own --lines copy)")
    ap.add_argument("--lines", default=None,
                    help="JSON-lines file (default: bench/results/gap_tracker_s<seed>_<code digest>.jsonl)")
    ap.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="address of an existing dask scheduler: the cases run on its cluster, one a worker")
    args = ap.parse_args()
    keyed_run(args, "gap_tracker", __file__, extra=("truth/tracker.py", "truth/tracker_spread.py", "_stats.py"),
              modules=("rmbench.gap.tracker.diagnosis", "rmbench.gap.cases.tracker_blind", "rmbench.robot", "rmbench.tracker"))
    spread = run_spread(args) if args.spread else {}
    if args.spread_only:
        print(json.dumps({**_spread_line(spread), "seed": args.seed}))
        # the second line: the invisible draws counted as misses
        print(json.dumps({"spread_cases": spread["spread_cases"], "seed": args.seed,
                          "rejected_as_misses": spread["rejected_as_misses"]}))
        return 0
    cases = run_cases(args)
    s = report(cases)
    seconds, line = speed()
    print()
    print(f"rmbench gap diagnose --readings, 500 readings: {seconds:.1f} s end to end; {line}")
    line = {"cases": len(cases), "recall": round(s["recall"], 4),
            "false_sources": round(s["false_sources"], 4),
            "median_shrink": round(s["median_shrink"], 4),
            "unexplained_ok": round(s["unexplained_ok"], 4), "diagnose_s": round(seconds, 1),
            "recall_major": round(s["recall_major"], 4), "seed": args.seed}
    if spread:
        line.update(_spread_line(spread))
    print(json.dumps(line))
    if spread:
        print(json.dumps({"spread_cases": spread["spread_cases"], "seed": args.seed,
                          "rejected_as_misses": spread["rejected_as_misses"]}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
