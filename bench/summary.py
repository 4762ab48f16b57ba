"""Index of the benches, written to `bench/README.md`: for each `bench/results/*.txt`, what its
script measures, how to run it, where its output is discussed and which files are kept beside it.

The figures themselves are stated once, in the results files (each ends with one JSON line of its
bench's headline keys); the index repeats none of them. It reads the first sentence and the
``usage:`` lines of each bench script's module docstring (with `ast`, never imported or run), the
results file's seed, the names of the other files in `bench/results/`, the Makefile's `bench`
target and the headings of `docs/results.md`. Standard library only; run it with
`make bench-summary` or `.venv/bin/python bench/summary.py`.
"""

from __future__ import annotations

import ast
import json
import re
from dataclasses import dataclass
from pathlib import Path

__all__ = ["BenchSummary", "read_summaries", "unclaimed", "render", "readme_text", "main"]

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
RESULTS = BENCH / "results"
OUT = BENCH / "README.md"
DOCS = ROOT / "docs" / "results.md"
MAKEFILE = ROOT / "Makefile"
FIGURE = (".png", ".jpg", ".jpeg", ".svg")
# results files that another bench script writes with an option (the seed ledger names the command)
PRODUCED_BY = {"gap_tracker_spread": ("gap_tracker", "--spread-only")}


@dataclass(frozen=True)
class BenchSummary:
    """What the index says of one results file.

    Parameters
    ----------
    stem : str
        Name shared by `bench/<stem>.py` and `bench/results/<stem>.txt`.
    description : str
        First sentence of the script's module docstring ("" when there is none).
    usage : str
        The docstring's ``usage:`` lines on one line, without the prefix ("" when there are none).
    has_script : bool
        Whether the script that writes it exists: `bench/<stem>.py`, or the one `PRODUCED_BY` names.
    in_make_bench : bool
        Whether the Makefile's `bench` target runs the script.
    has_line : bool
        Whether the results file ends with a JSON summary line.
    seed : int or None
        The run's seed: the summary line's ``seed``, else the "seed N" that opens the file (a bench
        over drawn robots prints its seed first).
    kept : tuple of str
        Names of the other files in `bench/results/` that belong to this results file (its cases'
        JSON lines, figures, saved models), sorted.
    docs_anchor : str or None
        Anchor of the `docs/results.md` heading whose section first cites the results file.
    """

    stem: str
    description: str
    usage: str
    has_script: bool
    in_make_bench: bool
    has_line: bool
    seed: int | None
    kept: tuple[str, ...]
    docs_anchor: str | None


def read_summaries(results: Path = RESULTS, bench: Path = BENCH, docs: Path = DOCS,
                   makefile: Path = MAKEFILE) -> list[BenchSummary]:
    """One `BenchSummary` per `results/*.txt`, in file-name order."""
    others = sorted(p.name for p in results.iterdir() if p.is_file() and p.suffix != ".txt")
    docs_text = docs.read_text(encoding="utf-8") if docs.is_file() else ""
    make_text = makefile.read_text(encoding="utf-8") if makefile.is_file() else ""
    summaries = []
    for path in sorted(results.glob("*.txt")):
        stem, text = path.stem, path.read_text(encoding="utf-8", errors="replace")
        name, option = PRODUCED_BY.get(stem, (stem, ""))
        script = bench / f"{name}.py"
        source = script.read_text(encoding="utf-8") if script.is_file() else ""
        line = last_json_object(path)
        seed = run_seed(text, line)
        usage = script_usage(script)
        if option:
            usage = re.sub(rf"(bench/{re.escape(name)}\.py)", rf"\1 {option}", usage, count=1)
        summaries.append(BenchSummary(
            stem, script_description(script), usage, script.is_file(),
            re.search(rf"(^|[\s/]){re.escape(stem)}\.py\b", make_text, re.M) is not None,
            line is not None, seed,
            tuple(n for n in others if belongs(n, stem, seed, text + source)),
            docs_anchor(docs_text, f"results/{stem}.txt")))
    return summaries


def unclaimed(summaries: list[BenchSummary], results: Path = RESULTS) -> list[str]:
    """Names of the files in `results/` that are no results file and belong to none (folders a
    script rewrites on each run, such as `gap_real.py`'s UFF58 export, are not indexed)."""
    kept = {name for s in summaries for name in s.kept}
    return sorted(p.name for p in results.iterdir()
                  if p.is_file() and p.suffix != ".txt" and p.name not in kept)


def belongs(name: str, stem: str, seed: int | None, cited: str) -> bool:
    """Whether the file `name` in `results/` belongs to the results file `stem`: named (without a
    `.gz`) in `cited` (the results file and its script's source), or `stem` itself with another
    suffix, or `stem_...` carrying this run's seed (`_s<seed>_`) or no seed at all."""
    if name.removesuffix(".gz") in cited or name.split(".")[0] == stem:
        return True
    if not name.startswith(stem + "_"):
        return False
    marked = re.search(r"_s(\d+)_", name[len(stem):])
    return marked is None or (seed is not None and int(marked.group(1)) == seed)


def last_json_object(path: Path) -> dict | None:
    """The summary line of the text file `path`: its last line that parses as a JSON object, merged
    with the JSON-object lines directly before it (a bench's second line, e.g. its rejected draws
    counted as misses, follows its main line), or None."""
    found = []
    for line in reversed(path.read_text(encoding="utf-8", errors="replace").splitlines()):
        line = line.strip()
        value = None
        if line.startswith("{"):
            try:
                value = json.loads(line)
            except ValueError:
                value = None
        if isinstance(value, dict):
            found.append(value)
        elif found:
            break
    if not found:
        return None
    merged = {}
    for value in reversed(found):
        merged.update(value)
    return merged


def run_seed(text: str, line: dict | None) -> int | None:
    """The run's seed: the summary line's integer ``seed``, else the "seed N" that opens `text`
    (after a "# " where the run's notes head the file); None for a bench that draws no robots."""
    if line is not None and isinstance(line.get("seed"), int):
        return line["seed"]
    match = re.match(r"(?:#\s*)?seed (\d+)\b", text)
    return int(match.group(1)) if match else None


def script_description(script: Path) -> str:
    """First sentence of the module docstring of `script`, on one line ("" if none or no file)."""
    doc = _docstring(script)
    paragraph = " ".join(doc.strip().split("\n\n")[0].split())
    match = re.match(r"(.+?[.!?])(?=\s+[A-Z\"'(]|$)", paragraph)   # "e.g. x" does not end it
    return match.group(1) if match else paragraph


def script_usage(script: Path) -> str:
    """The ``usage:`` lines of the module docstring of `script` on one line, without the prefix."""
    doc = _docstring(script)
    match = re.search(r"^usage:(.*?)(?:\n\s*\n|\Z)", doc, re.M | re.S)
    return " ".join(match.group(1).split()) if match else ""


def docs_anchor(docs_text: str, cited: str) -> str | None:
    """GitHub's anchor of the heading (level 2 or below) over the first mention of `cited`."""
    at = docs_text.find(cited)
    if at < 0:
        return None
    headings = re.findall(r"^#{2,6} +(.+?) *$", docs_text[:at], re.M)
    return _slug(headings[-1]) if headings else None


def render(summaries: list[BenchSummary], loose: list[str] | None = None) -> str:
    """The whole of `bench/README.md` for `summaries` (and the unclaimed files `loose`)."""
    parts = [_intro()] + [_section(s) for s in summaries]
    missing = [s for s in summaries if not s.has_line]
    if missing:
        parts.append("\n".join(["## No summary line", "",
                                "These results files have no line that parses as a JSON object:", ""]
                               + [f"- [`results/{s.stem}.txt`](results/{s.stem}.txt)" for s in missing]))
    if loose:
        parts.append("\n".join(["## Files no results file claims", "",
                                "Neither named in a results file or its script nor keyed by a run's "
                                "seed: keep them only if a bench reads them.", ""]
                               + [f"- [`results/{n}`](results/{n})" for n in loose]))
    return "\n\n".join(parts) + "\n"


def readme_text() -> str:
    """`bench/README.md` as the bench scripts and `bench/results/` give it now."""
    summaries = read_summaries()
    return render(summaries, unclaimed(summaries))


def main() -> int:
    """Write `bench/README.md` from `bench/results/`; print what was written."""
    text = readme_text()
    OUT.write_text(text, encoding="utf-8")
    print(f"wrote {OUT.relative_to(ROOT)}: {text.count(chr(10) + '## ')} sections")
    return 0


def _docstring(script: Path) -> str:
    if not script.is_file():
        return ""
    return ast.get_docstring(ast.parse(script.read_text(encoding="utf-8"))) or ""


def _slug(heading: str) -> str:
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def _intro() -> str:
    return "\n".join([
        "# Benches: how to run them, where their results are",
        "",
        "<!-- Generated by bench/summary.py from bench/results/ and the bench scripts; do not edit by hand. -->",
        "",
        "Each bench script `bench/<name>.py` measures one stage of rmbench against the simulator's exact",
        "ground truth (or the seeds' published figures) and writes its output to",
        "`bench/results/<name>.txt`, which ends with one JSON line of its headline figures. That file is",
        "the one place a figure is stated: this index repeats none, and",
        "[docs/results.md](../docs/results.md) says what each measures, how its truth is built and what",
        "its figures mean, quoting or linking the results file.",
        "",
        "- `make bench` reruns the benches marked so below (each in turn, then this index; hours); one",
        "  runs as the Makefile runs it: `.venv/bin/python bench/<name>.py | tee bench/results/<name>.txt`.",
        "  The others draw robots for hours and are run by hand, their seed ledgered in",
        "  [SEEDS.md](SEEDS.md) before the run.",
        "- A bench over drawn robots keeps each robot's case as a JSON line in",
        "  `bench/results/<name>_..._s<seed>_<code key>.jsonl` (gzipped, `.jsonl.gz`, where large) and",
        "  resumes from it: rerun with the results file's `--seed` and `--lines <that file>` to rebuild the",
        "  results file from its cases without simulating. Those files are the ones kept beside each",
        "  results file below; superseded runs' files are in the git history.",
        "- Regenerate this index: `make bench-summary` (`bench/summary.py`, standard library only).",
    ])


def _section(summary: BenchSummary) -> str:
    lines = [f"## {summary.stem}", ""]
    if summary.description:
        lines += [summary.description, ""]
    if summary.has_script:
        usage = summary.usage or f"python bench/{summary.stem}.py"
        note = re.match(r"(.*?)\s+(\(.*\))$", usage)      # a closing remark goes outside the code
        run = f"`{note.group(1)}` {note.group(2)}" if note else f"`{usage}`"
        lines.append(f"- Run: {run}" + ("; in `make bench`." if summary.in_make_bench else "; not in `make bench`."))
    else:
        lines.append(f"- Run: no script `bench/{summary.stem}.py`; the results file's first line names the run.")
    seed = "" if summary.seed is None else f" (seed {summary.seed})"
    output = f"- Output: [`results/{summary.stem}.txt`](results/{summary.stem}.txt){seed}"
    if summary.docs_anchor:
        output += f"; discussed in [docs/results.md](../docs/results.md#{summary.docs_anchor})"
    lines.append(output + ".")
    data = [n for n in summary.kept if not n.lower().endswith(FIGURE)]
    figures = [n for n in summary.kept if n.lower().endswith(FIGURE)]
    if data:
        lines.append("- Kept beside it: " + ", ".join(f"[`{n}`](results/{n})" for n in data) + ".")
    if figures:
        lines.append("- Figures: " + ", ".join(f"[`{n}`](results/{n})" for n in figures) + ".")
    return "\n".join(lines)


if __name__ == "__main__":
    raise SystemExit(main())
