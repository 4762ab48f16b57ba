"""A bench resumes only its own seed's cases (``bench/_stats.py``): a JSON-lines file reused under
another seed would count that seed's robots as done and pool two seeds in one summary."""

import importlib.util
import json
from pathlib import Path

import pytest

# loaded by path, not by putting bench/ on sys.path: no bench script then shadows a library
# module for the later tests in the same process
_spec = importlib.util.spec_from_file_location("bench_stats", Path(__file__).resolve().parents[1] / "bench" / "_stats.py")
_stats = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_stats)
resumed_cases = _stats.resumed_cases


def _write(path: Path, cases: list[dict]) -> Path:
    path.write_text("".join(json.dumps(c) + "\n" for c in cases))
    return path


def test_a_missing_lines_file_resumes_nothing(tmp_path):
    assert resumed_cases(tmp_path / "absent.jsonl", 7) == []


def test_the_same_seeds_cases_and_seedless_rejected_lines_are_resumed(tmp_path):
    cases = [{"index": 0, "seed": 7}, {"index": 3, "rejected": "hidden at x4"}]
    assert resumed_cases(_write(tmp_path / "l.jsonl", cases), 7) == cases


def test_a_file_holding_another_seeds_cases_stops_with_a_one_line_error(tmp_path):
    path = _write(tmp_path / "l.jsonl", [{"index": 0, "seed": 7}, {"index": 2, "seed": 27994}])
    with pytest.raises(SystemExit) as stop:
        resumed_cases(path, 7)
    message = str(stop.value)
    assert "\n" not in message and "27994" in message and message.startswith("error:")


def test_a_gzipped_lines_file_resumes_the_same_cases_and_takes_appended_ones(tmp_path):
    # finished runs' lines are kept gzipped in bench/results/; a replay reads them as they were
    import gzip

    cases = [{"index": 0, "seed": 7}, {"index": 1, "seed": 7}]
    path = tmp_path / "l.jsonl.gz"
    path.write_bytes(gzip.compress(_write(tmp_path / "l.jsonl", cases[:1]).read_bytes()))
    with _stats.open_lines(path, "a") as fh:
        fh.write(json.dumps(cases[1]) + "\n")
    assert resumed_cases(path, 7) == cases
