"""The demo's low-speed step and the plan report per segment (issue 82).

The report shows a plan per segment between the path's corners: the planned angle, the speed, the
smallest critical depth and its band, the best fixed angle's, and the cuts made there. The demo
mills the planned schedule and the best fixed angle's at the same locations, where the best fixed
angle's critical depth lies below the depth cut.

A 300 x 200 mm rectangle, locations 50 mm apart, five angles 20° apart, the exact model's modes in
steel at 400 rev/min with the feed along the path (as in ``test_path_corners``).
"""

from types import SimpleNamespace

import numpy as np
import pytest

import rmbench.path
from rmbench.cli.demo_machining import mill_low_speed
from rmbench.io.toolpath import ToolPath
from rmbench.path import PlanSettings, plan_path
from rmbench.report import Page
from rmbench.report.path import SEGMENT_COLUMNS, segment_rows, segments_section
from rmbench.stability import STEEL_C45

THETA = tuple(np.radians([-40.0, -20.0, 0.0, 20.0, 40.0]))


def _rectangle():
    """300 x 200 mm, counter-clockwise from (1500, -100) mm: along +X, +Y, -X, -Y."""
    xy = np.array([[1.5, -0.1], [1.8, -0.1], [1.8, 0.1], [1.5, 0.1], [1.5, -0.1]])
    return ToolPath(xy, np.full(5, -2e-3), np.full(5, 0.05), np.full(5, np.nan), np.array([False] + [True] * 4),
                    np.arange(1, 6))


def _plan(irb, reorient):
    return plan_path(irb, None, _rectangle(), speed_rpm=[400.0, 900.0], cutting=STEEL_C45,
                     settings=PlanSettings(theta=THETA, spacing=50e-3, eval_spacing=40e-3, feed="path",
                                           reorient=reorient))


@pytest.fixture(scope="module")
def corners(irb):
    return _plan(irb, "corners")


@pytest.fixture(scope="module")
def ramps(irb):
    return _plan(irb, "ramps")


def _cuts(index, chatter, expected):
    """What the report reads of a :class:`rmbench.path.PathMilling`."""
    return SimpleNamespace(index=np.asarray(index), chatter=np.asarray(chatter), expected=np.asarray(expected))


def test_a_plan_with_corners_has_a_segment_between_each_two(corners):
    rows = segment_rows(corners)
    assert len(rows) == len(corners.reorientation.candidates) + 1
    assert [r[0] for r in rows] == list(range(1, len(rows) + 1))
    assert all(len(r) == len(SEGMENT_COLUMNS) for r in rows)


def test_a_ramps_only_plan_is_one_segment(ramps):
    assert len(segment_rows(ramps)) == 1


def test_the_segments_smallest_depths_are_the_plans_and_the_best_fixed_angles(corners):
    rows = segment_rows(corners)
    assert min(r[4] for r in rows) == pytest.approx(1e3 * corners.planned.min_margin)
    assert min(r[6] for r in rows) == pytest.approx(1e3 * corners.best_fixed.min_margin)


def test_each_segment_shows_the_plans_speed_and_no_band_on_the_exact_model(corners):
    rows = segment_rows(corners)
    assert {r[3] for r in rows} == {f"{corners.speed_rpm:g}"}
    assert {r[5] for r in rows} == {""}


def test_the_cuts_are_counted_in_the_segment_they_lie_in(corners):
    first = int(corners.reorientation.candidates[0])         # the last location of segment 1
    rows = segment_rows(corners, {"planned": _cuts([0, first, first + 1], [True, False, True], [False, False, True])})
    assert rows[0][7] == "planned 1 / 0 of 2"
    assert rows[1][7] == "planned 1 / 1 of 1"
    assert rows[-1][7] == "none"


def test_the_section_names_the_speeds_chosen_among_and_the_corners(corners):
    page = Page("t", {})
    segments_section(page, corners)
    html = page.html()
    assert "The plan per segment" in html
    assert "the best of 400, 900 rev/min" in html
    assert "corners" in html and "dwell" in html


def test_the_demo_mills_both_schedules_where_the_best_fixed_angle_is_below_the_depth(corners, irb, monkeypatch):
    calls = []
    monkeypatch.setattr(rmbench.path, "mill_schedule", lambda robot, plan, **kw: calls.append((plan, kw)) or kw)
    depth = 0.5 * (corners.planned.min_margin + corners.best_fixed.min_margin)
    milled = mill_low_speed(irb, corners, depth)
    assert list(milled) == ["planned", "best fixed"]
    (plan_a, a), (plan_b, b) = calls
    assert np.array_equal(a["locations"], b["locations"]) and len(a["locations"]) == 3
    assert np.all(corners.best_fixed.margin[a["locations"]] < depth)
    assert b["schedule"] == "fixed" and plan_b.fixed is corners.best_fixed
