"""The user documents stay true: the README's commands run as written, and bench/README.md is the
index of the results files and bench scripts it is generated from."""

import importlib.util
import shlex
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
PREFIX = ".venv/bin/rmbench "

# commands of the README run as written, in this order (later ones read what earlier ones wrote):
# the tour on the demo campaign, then one quick command of each stage that needs no long campaign
SAMPLE = (
    "model info --robot irb6660 --tool dummy --posture 1800,-200,0",
    "campaign run demo --out demo.nc --workers 2",
    "report demo.nc --out demo.html",
    "modal fit demo.nc --out modal.nc --csv modal.csv",
    "model variant --robot irb6660 --set j2_flex.stiffness*=0.8 --out soft.xml",
    "model info --robot soft.xml --posture 1500,100,20 --json",
    "rcsa part --posture 1800,0,0 --k-x 2e7 --preload 100 --out part.png --json",
    "invalidate benchmark --seeds 5",
)


def readme_commands() -> list[str]:
    """Every ``rmbench`` command line in the README's shell blocks, without its comment."""
    out, block = [], None       # the open block's language, "" for a shell block
    for line in README.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            block = line[3:].strip() if block is None else None
            continue
        if block == "" and line.startswith(PREFIX):
            out.append(line[len(PREFIX):].split("  #")[0].rstrip(" \\").strip())
    return out


def test_the_sampled_commands_are_the_readmes_own():
    # a README edit that changes one of them must change the sample too, so it keeps running
    # what users copy
    commands = readme_commands()
    assert [c for c in SAMPLE if c not in commands] == []


@pytest.mark.slow
def test_the_readmes_tour_and_a_command_of_each_stage_run_as_written(tmp_path, monkeypatch, capsys):
    from rmbench.cli import main

    monkeypatch.chdir(tmp_path)
    for command in SAMPLE:
        assert main(shlex.split(command)) == 0, command
        capsys.readouterr()
    for written in ("demo.nc", "demo.html", "modal.nc", "modal.csv", "soft.xml", "part.png"):
        assert (tmp_path / written).stat().st_size > 0, written


def _bench_summary(monkeypatch):
    spec = importlib.util.spec_from_file_location("bench_summary", ROOT / "bench" / "summary.py")
    summary = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, summary)    # its dataclasses look their module up
    spec.loader.exec_module(summary)
    return summary


def test_bench_readme_is_the_index_of_the_results_files(monkeypatch):
    # bench/README.md is generated (make bench-summary); a results file or bench script changed
    # without regenerating it leaves the index behind the benches
    summary = _bench_summary(monkeypatch)
    assert (ROOT / "bench" / "README.md").read_text(encoding="utf-8") == summary.readme_text()


def test_every_file_kept_in_bench_results_belongs_to_a_results_file(monkeypatch):
    # bench/results/ keeps only what its results files are rebuilt from or show (a run's lines,
    # figures); a superseded run's lines stay in the git history
    summary = _bench_summary(monkeypatch)
    assert summary.unclaimed(summary.read_summaries()) == []
