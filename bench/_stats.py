"""Shared helpers of the bench scripts."""

from __future__ import annotations

import ast
import gzip
import hashlib
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

RMBENCH = str(Path(sys.executable).with_name("rmbench"))
HERE = Path(__file__).resolve().parent


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a rate ``k / n`` (95 % by default); NaN for ``n == 0``."""
    if n == 0:
        return float("nan"), float("nan")
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return max(c - h, 0.0), min(c + h, 1.0)


def rate(flags) -> str:
    """``k/n = p % (95 %: lo-hi)`` of boolean flags, or ``-`` for none."""
    flags = list(flags)
    k, n = sum(bool(f) for f in flags), len(flags)
    if n == 0:
        return "-"
    lo, hi = wilson(k, n)
    return f"{k}/{n} = {100 * k / n:.1f} % (95 %: {100 * lo:.0f}-{100 * hi:.0f})"


def blind_cases(args, *extra: str) -> list[dict]:
    """Run ``rmbench gap blind`` (``--cases``, ``--seed`` from ``args``, ``extra`` options) into the
    JSON-lines file ``args.lines`` (a killed run resumes from it) and return its first
    ``args.cases`` cases as dicts."""
    lines = Path(args.lines)
    lines.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run([RMBENCH, "gap", "blind", "--cases", str(args.cases), "--seed", str(args.seed),
                    *extra, "--out", str(lines), "--json"], check=True, stdout=subprocess.DEVNULL)
    cases = [json.loads(s) for s in lines.read_text().splitlines() if s.strip()]
    return [c for c in cases if c["index"] < args.cases]


def ship_bench_modules() -> None:
    """Send the bench's helper modules (``_stats``, ``_profile``, ...: beside the scripts, not
    installed) and the truth package (``truth``, ``truth.robot``, ...) to a dask cluster with the
    cases' functions, by value, so that its workers need only rmbench. The bench imports them at
    its top: an import inside a case's function would run on the worker, where they are not."""
    import cloudpickle

    for name, module in list(sys.modules.items()):
        folder = Path(getattr(module, "__file__", None) or "/").resolve().parent
        if name.startswith("_") and folder == HERE or name.split(".")[0] == "truth" and folder == HERE / "truth":
            cloudpickle.register_pickle_by_value(module)


def open_lines(path, mode: str = "r"):
    """A bench's JSON-lines file, opened as text for reading (``"r"``) or appending (``"a"``):
    gzip-compressed where its name ends in ``.gz`` (a finished run's lines kept compressed in
    ``bench/results/``; appending adds a gzip member, which readers take as one stream), plain
    otherwise."""
    path = Path(path)
    if path.suffix == ".gz":
        return gzip.open(path, mode + "t", encoding="utf-8")
    return open(path, mode)


def resumed_cases(lines: Path, seed: int) -> list[dict]:
    """The cases a bench resumes from its JSON-lines file ``lines`` (none if it is absent).

    A file that holds another seed's cases stops the run with a one-line error: its
    indices would otherwise count as this seed's robots done, and the summary would pool two
    seeds (a scratch file reused under a fresh seed, seed 93970 of the calibration bench).
    Lines without a seed (a rejected draw's, before rejected lines carried one) are taken as
    they are."""
    lines = Path(lines)
    if not lines.exists():
        return []
    with open_lines(lines) as fh:
        cases = [json.loads(s) for s in fh.read().splitlines() if s.strip()]
    other = sorted({c["seed"] for c in cases if c.get("seed", seed) != seed})
    if other:
        raise SystemExit(f"error: {lines} holds cases of seed {', '.join(map(str, other))}, not {seed}: "
                         "give another --lines file")
    return cases


def fresh_seed() -> int:
    """A seed drawn from the operating system's entropy (a bench prints it, so a run can be
    repeated with ``--seed``)."""
    return int(np.random.SeedSequence().entropy % 100000)


def _code(path: Path) -> bytes:
    """A source file's syntax tree without docstrings: what it does, not how it is described."""
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr) \
                and isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str):
            node.body = body[1:] or [ast.Pass()]
    return ast.dump(tree).encode()


def code_digest(files) -> str:
    """Ten hex digits of the files' code (their syntax trees without docstrings, in path order):
    a results file keyed by it is resumed only by the code that wrote it."""
    h = hashlib.sha256()
    for p in sorted(Path(f) for f in files):
        h.update(_code(p))
    return h.hexdigest()[:10]


def package_files(*exclude: str) -> list:
    """Every module of rmbench but those under the subpackages ``exclude`` (``cli``, ...)."""
    import rmbench

    src = Path(rmbench.__file__).parent
    return [p for p in src.rglob("*.py") if p.relative_to(src).parts[0] not in exclude]


def used_files(*modules: str) -> list:
    """Every module of the rmbench subpackages that importing ``modules`` loads (a subpackage
    whole, so that its functions' late imports count too), ``cli`` left out: the code a bench
    that calls them runs."""
    import importlib

    import rmbench

    for m in modules:
        importlib.import_module(m)
    src = Path(rmbench.__file__).parent
    top = {name.split(".")[1] for name in sys.modules if name.startswith("rmbench.")} - {"cli"}
    return [p for p in src.rglob("*.py") if p.relative_to(src).parts[0].removesuffix(".py") in top]


def run_arguments(ap, *, robots: int, workers: bool = True) -> None:
    """Add to the parser ``ap`` the options of a bench run over robots that :func:`keyed_run` and
    :func:`cases_to_lines` read: ``--robots`` (default ``robots``), ``--seed``, ``--workers``
    (where ``workers``), ``--lines``, ``--only`` and ``--scheduler``."""
    ap.add_argument("--robots", type=int, default=robots)
    ap.add_argument("--seed", type=int, default=None, help="default: a fresh one, printed")
    if workers:
        ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--lines", default=None, help="JSON-lines file (default: keyed by seed and code)")
    ap.add_argument("--only", default=None, help="comma-separated robot indices to run")
    ap.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="address of an existing dask scheduler: the robots run on its cluster, one a worker")


def keyed_run(args, stem: str, bench_file: str, *, modules: tuple = (), extra: tuple = ()) -> None:
    """Fill ``args.seed`` (a fresh one unless given) and ``args.lines`` (unless given:
    ``bench/results/STEM_s<seed>_<digest>.jsonl``, resumed only by the same seed and the same code,
    so a rerun on changed code starts afresh), and print both.

    The digest covers the bench file, the bench modules ``extra`` (file names beside it: the truth
    it builds) and the rmbench subpackages that importing ``modules`` loads, or every subpackage
    but ``cli`` where none are named."""
    if args.seed is None:
        args.seed = fresh_seed()
    if args.lines is None:
        here = Path(bench_file).resolve().parent
        code = used_files(*modules) if modules else package_files("cli")
        digest = code_digest(code + [Path(bench_file)] + [here / f for f in extra])
        args.lines = str(Path(bench_file).resolve().parent / "results" / f"{stem}_s{args.seed}_{digest}.jsonl")
    print(f"seed {args.seed}; cases in {args.lines}", flush=True)


def cases_to_lines(args, fn, say, *, by_value=()) -> list[dict]:
    """Run ``fn(i)`` for robots ``0 .. args.robots - 1`` (``args.only`` of them, where given) not
    yet in the JSON-lines file ``args.lines``, here or on the cluster at ``args.scheduler``; each
    case's dict is appended to the file as it finishes and ``say(case)`` printed. Returns every
    case of the file, by index. ``by_value``: module names (and their submodules) sent to the
    cluster's workers with the cases, besides the bench's own helpers."""
    from rmbench.parallel import map_cases

    lines = Path(args.lines)
    lines.parent.mkdir(parents=True, exist_ok=True)
    done = {c["index"]: c for c in resumed_cases(lines, args.seed)}
    only = None if args.only is None else {int(x) for x in args.only.split(",") if x.strip()}
    todo = [i for i in range(args.robots) if i not in done and (only is None or i in only)]
    if args.scheduler is not None:
        import cloudpickle

        ship_bench_modules()
        for name, module in list(sys.modules.items()):
            if name.split(".")[0] in by_value:
                cloudpickle.register_pickle_by_value(module)
    for i, c in map_cases(fn, todo, workers=1, scheduler=args.scheduler):
        with open_lines(lines, "a") as fh:
            fh.write(json.dumps(c) + "\n")
        done[i] = c
        print(say(c), flush=True)
    return [done[i] for i in sorted(done)]
