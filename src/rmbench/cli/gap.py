"""``rmbench gap diagnose`` and ``rmbench gap blind``: sim-to-real gap diagnosis on FRF data."""

from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path

from rmbench.cli._common import command_group, print_json
from rmbench.errors import InputError

__all__ = ["register"]


def register(sub) -> None:
    g = command_group(sub, "gap", "sim-to-real gap diagnosis: where the model departs, which effect, how far it shrinks")
    d = g.add_parser("diagnose", help="diagnose measured FRFs against a nominal model")
    d.add_argument("--robot", default="irb6660", help="nominal robot: bundled name or MJCF path (default irb6660)")
    d.add_argument("--tool", default=None, help="tool on the nominal robot (default: its own)")
    d.add_argument("--data", required=True, help="measured FRFs: campaign dataset (netCDF) or UFF58 directory")
    d.add_argument("--test", default=None, help="campaign TOML of the test design (default: the data's own)")
    d.add_argument("--out", default=None, help="directory for figures, tables and the updated variant MJCF")
    d.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")
    d.add_argument("--json", action="store_true", help="print the diagnosis as JSON")
    d.set_defaults(func=cmd_diagnose)

    b = g.add_parser("blind", help="withheld-effect check: inject hidden effects, diagnose them blind, score")
    b.add_argument("--cases", type=int, required=True, help="number of blind cases")
    b.add_argument("--seed", type=int, default=0)
    b.add_argument("--method", choices=("linear", "time", "mixed"), default="linear",
                   help="campaign method of the cases (mixed: --time-share of them time-domain)")
    b.add_argument("--time-share", type=float, default=0.25, help="share of time-domain cases with --method mixed")
    b.add_argument("--out", default=None,
                   help="JSON-lines file of the cases (resumed if it exists; each finished case is appended)")
    b.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")
    b.add_argument("--json", action="store_true", help="print the summary as JSON")
    b.set_defaults(func=cmd_blind)


def cmd_diagnose(args) -> int:
    from rmbench.gap import diagnose
    from rmbench.gap.measured import GapDataWarning

    test = None
    if args.test is not None:
        path = Path(args.test)
        if not path.is_file():
            raise InputError(f"test design file not found: {path}")
        test = path.read_text()
    data = Path(args.data)
    if not data.exists():
        raise InputError(f"data not found: {data}")
    say = (lambda msg: None) if args.json else (lambda msg: print(f"  {msg}", file=sys.stderr))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", GapDataWarning)
        dg = diagnose(args.robot, data, test=test, tool=args.tool, workers=args.workers, progress=say)
    for w in caught:
        if issubclass(w.category, GapDataWarning):
            print(f"rmbench: warning: {w.message}", file=sys.stderr)
    paths = dg.save(args.out) if args.out else {}
    if args.json:
        print_json(dg.to_json(paths.get("variant")))
        return 0
    print(f"verdict: {dg.verdict} (nominal gap: χ² {dg.nominal_chi2:.0f} over {dg.n_residuals} "
          f"normalised residuals)")
    print(f"where: {dg.localisation}")
    for i, e in enumerate(dg.effects[:8]):
        mark = "*" if e.chosen else " "
        print(f" {mark}{i + 1}. {e.name}: {e.description}; held-out gap {e.heldout_before['gap']:.3g} -> "
              f"{e.heldout_after['gap']:.3g} (shrink {100 * e.shrink:.1f} %, "
              f"{100 * e.shrink_interval[0]:.1f}-{100 * e.shrink_interval[1]:.1f}), "
              f"confidence {e.confidence:.2f}")
    for group in dg.equivalent:
        print(f"   the data cannot tell apart: {', '.join(group)}")
    if dg.design_changes:
        print(f"   test design: {'; '.join(dg.design_changes)}")
    if paths:
        print(f"wrote {args.out}: " + ", ".join(Path(p).name for k, p in paths.items() if k != "figures")
              + f" and {len(paths.get('figures', []))} figures")
    return 0


def cmd_blind(args) -> int:
    from rmbench.gap.blind import case_from_dict, dumps, run_blind

    if args.cases < 1:
        raise InputError(f"--cases must be at least 1, got {args.cases}")
    if not 0 <= args.time_share <= 1:
        raise InputError(f"--time-share must lie in [0, 1], got {args.time_share}")
    done = {}
    out = Path(args.out) if args.out else None
    if out is not None and out.is_file():
        for line in out.read_text().splitlines():
            if line.strip():
                case = case_from_dict(json.loads(line))
                done[case.index] = case

    def progress(case):
        if out is not None:
            with open(out, "a") as fh:
                fh.write(dumps(case) + "\n")
        if not args.json:
            hidden = " + ".join(h.name for h in case.hidden)
            top = case.ranked[0][0] if case.ranked else "-"
            print(f"case {case.index} ({case.method}): hidden {hidden}; {case.verdict}, top {top}, "
                  f"shrink {100 * case.shrink:.0f} %", file=sys.stderr)

    report = run_blind(args.cases, args.seed, method=args.method, time_share=args.time_share,
                       workers=args.workers, progress=progress, done=done)
    s = report.summary
    if args.json:
        print_json(s)
        return 0
    print(f"{s['cases']} cases ({s['time_domain']} time-domain): {s['single']} single, {s['pairs']} pairs, "
          f"{s['out_of_library']} out of the library")
    print(f"  top-1 {s['top1']:.1%} (up to indistinguishable effects {s['top1_class']:.1%}), top-3 "
          f"{s['top3']:.1%} ({s['top3_class']:.1%}); median held-out shrink {s['median_shrink']:.1%}")
    print(f"  false attributions (out of library) {s['false_attribution']:.1%}; both effects of a pair in "
          f"the top 3 {s['pair_recall']:.1%}")
    return 0
