"""The low-speed path bench's scoring helpers (bench/path_low_speed.py), on made-up figures."""

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np

# loaded by path; the bench/ folder it puts on sys.path is taken off again, so no bench script
# shadows a library module for the tests after this one
_before = list(sys.path)
_spec = importlib.util.spec_from_file_location(
    "bench_path_low_speed", Path(__file__).resolve().parents[1] / "bench" / "path_low_speed.py")
pls = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(pls)
sys.path[:] = _before


def test_mrr_gain_is_against_the_best_single_speed_and_angle():
    # fixed angle: 1 mm at 300 rev/min (300), 0.2 mm at 3000 (600): the best pair is 600
    assert np.isclose(pls.mrr_gain(0.4, 3000.0, [1.0, 0.2], [300.0, 3000.0]), 2.0)


def test_relative_errors_skip_non_finite_and_zero_exact():
    err = pls.relative_errors([1.1, 2.0, np.nan, 1.0], [1.0, np.inf, 1.0, 0.0])
    assert np.allclose(err, [0.1])


def test_coverage_counts_finite_exact_depths_inside_the_band():
    assert pls.covered([0.9, 0.9, 0.9], [1.1, 1.1, 1.1], [1.0, 1.2, np.nan]) == (1, 2)


def test_tally_counts_refused_cuts_apart():
    cuts = [{"factor": 0.9, "chatter": False, "expected": False}, {"factor": 1.1, "chatter": False, "expected": True},
            {"factor": 1.1, "refused": "no"}, {"factor": 0.95, "chatter": True, "expected": False}]
    assert pls.tally(cuts, pls.OUTSIDE10) == (1, 2, 1)
    assert pls.tally(cuts, pls.AT5) == (0, 1, 0)


def test_bench_line_is_strict_json_with_the_issue_keys():
    path = {"exact_gain": 1.4, "pred_gain": 1.3, "mrr_gain": None, "pred_claimed_gain": 1.5,
            "alim_err": [0.01, 0.2], "band_covered": [1, 2],
            "mill": [{"factor": f, "chatter": f > 1, "expected": f > 1} for f in pls.FACTORS]}
    line = pls.bench_line([{"robot": 0, "paths": {"contour": path}, "plan_s": None},
                           {"robot": 1, "rejected": "posture"}], seed=5, quick=True)
    text = json.dumps(line, allow_nan=False)
    for key in ("robots", "exact_gain_low_speed", "pred_gain_low_speed", "mrr_gain", "agree_outside10",
                "agree_at5", "alim_err_p95", "band_coverage", "plan_s"):
        assert key in line
    assert line["robots"] == 1 and line["refused_robots"] == 1 and line["agree_outside10"] == 1.0
    assert line["mrr_gain"] is None and "NaN" not in text
