"""Planning a path at low speed (issue 82, second step): the cut and the speeds chosen, the feed
along the path's own direction, and the gain over the best fixed angle.

The planner's options are additive: ``PlanSettings().feed`` is ``"x"`` (every earlier plan's
numbers, bit for bit), the cut the aluminium slot. A 300 x 200 mm rectangle, locations 100 mm
apart and evaluated at every one (``eval_spacing`` below the spacing), three angles: small enough
for the exact model's modes at every pose.
"""

import contextlib
import io
import json

import numpy as np
import pytest

from rmbench.errors import InputError
from rmbench.io.toolpath import ToolPath, write_cl_csv
from rmbench.path import (CUTTINGS, PlanSettings, best_fixed_schedule, depth_band, exact_modes, load_plan,
                          plan_path, predicted_modes, save_plan)
from rmbench.stability import ALUMINIUM_6061, STEEL_C45

THETA = tuple(np.radians([-40.0, 0.0, 40.0]))
SPEEDS = [400.0, 1500.0]


def _rectangle():
    """300 x 200 mm, counter-clockwise from (1500, -100) mm: along +X, +Y, -X, -Y."""
    xy = np.array([[1.5, -0.1], [1.8, -0.1], [1.8, 0.1], [1.5, 0.1], [1.5, -0.1]])
    return ToolPath(xy, np.full(5, -2e-3), np.full(5, 0.05), np.full(5, np.nan), np.array([False] + [True] * 4),
                    np.arange(1, 6))


def _settings(**kw):
    return PlanSettings(theta=THETA, spacing=100e-3, eval_spacing=40e-3, **kw)


@pytest.fixture(scope="module")
def predictor(irb):
    """A single-task GP on the exact modes of 8 postures around the rectangle."""
    from rmbench.impact.dataset import exact_modes_dataset
    from rmbench.predict import PosturePredictor
    from rmbench.robot import Posture

    grid = [Posture.from_mm_deg(x, y, t) for x in (1450, 1850) for y in (-150, 150) for t in (-40, 40)]
    return PosturePredictor("stgp").fit(exact_modes_dataset(irb, grid))


@pytest.fixture(scope="module")
def exact_path_plan(irb):
    """The exact model's plan of the rectangle in steel, feed along the path."""
    return plan_path(irb, None, _rectangle(), speed_rpm=SPEEDS, cutting=STEEL_C45, settings=_settings(feed="path"))


def _same(a, b):
    da, db = a.to_dict(), b.to_dict()
    da.pop("seconds"), db.pop("seconds")
    assert da == db
    assert np.array_equal(a.depths.a_lim, b.depths.a_lim)
    for k in ("planned", "fixed", "pointwise", "best_fixed"):
        sa, sb = getattr(a, k), getattr(b, k)
        assert np.array_equal(sa.index, sb.index) and np.array_equal(sa.margin, sb.margin)


# -- feed along base X: as before -----------------------------------------------------------------
def test_feed_along_x_is_the_default_and_plans_exactly_as_without_the_option(irb, predictor):
    assert PlanSettings().feed == "x" and _settings().feed == "x"
    plain = plan_path(irb, predictor, _rectangle(), speed_rpm=SPEEDS, settings=_settings())
    along_x = plan_path(irb, predictor, _rectangle(), speed_rpm=SPEEDS, cutting=ALUMINIUM_6061,
                        settings=_settings(feed="x"))
    _same(plain, along_x)
    assert along_x.feed == "x" and along_x.cutting == ALUMINIUM_6061


def test_feed_along_x_gives_the_depths_of_the_tip_modes_unturned(irb, predictor):
    plan = plan_path(irb, predictor, _rectangle(), speed_rpm=SPEEDS, cutting=STEEL_C45, settings=_settings())
    tp = plan.toolpath
    k = SPEEDS.index(plan.speed_rpm)
    want = predicted_modes(predictor, tp.xy, plan.reach.theta).depths_at(STEEL_C45, SPEEDS)[k]
    assert np.array_equal(plan.depths.a_lim, want.a_lim)


# -- feed along the path ---------------------------------------------------------------------------
def test_on_the_y_going_sides_the_depth_is_the_tip_modes_turned_by_90_degrees(irb, exact_path_plan):
    plan = exact_path_plan
    tp = plan.toolpath
    up = np.isclose(tp.xy[:, 0], 1.8) & (tp.xy[:, 1] > -0.1 + 1e-9)          # the side along +Y
    # along -Y; the first location, at the last's place, starts along +X
    down = np.isclose(tp.xy[:, 0], 1.5) & (tp.xy[:, 1] < 0.1 - 1e-9) & (np.arange(len(tp)) > 0)
    assert up.sum() == 2 and down.sum() == 2
    heading = np.where(up, np.pi / 2, np.where(down, -np.pi / 2, tp.heading()))
    tip = exact_modes(irb, tp.xy, plan.reach.theta, reach=plan.reach)
    k = SPEEDS.index(plan.speed_rpm)
    turned = tip.depths_at(STEEL_C45, SPEEDS, heading=heading)[k].a_lim
    side = up | down
    assert np.array_equal(plan.depths.a_lim[side], turned[side])
    # and the turn matters there: along base X the same poses give other depths
    unturned = tip.depths_at(STEEL_C45, SPEEDS)[k].a_lim
    assert np.all(np.abs(unturned[side] / turned[side] - 1) > 1e-3)


def test_the_plan_keeps_its_cut_and_feed(exact_path_plan):
    assert exact_path_plan.cutting == STEEL_C45 and exact_path_plan.feed == "path"
    d = exact_path_plan.to_dict()
    assert d["feed"] == "path" and d["cutting"]["teeth"] == 6 and d["cutting"]["k_t_n_mm2"] == pytest.approx(2000.0)


def test_the_depth_band_turns_the_modes_by_the_heading(predictor):
    xy, theta = np.array([[1.8, 0.0], [1.5, 0.0]]), np.zeros(2)
    kw = dict(draws=4, seed=1)
    plain = depth_band(predictor, xy, theta, STEEL_C45, 400.0, **kw)
    zero = depth_band(predictor, xy, theta, STEEL_C45, 400.0, heading=np.zeros(2), **kw)
    turned = depth_band(predictor, xy, theta, STEEL_C45, 400.0, heading=np.radians([90.0, -90.0]), **kw)
    assert np.array_equal(zero.a_lim, plain.a_lim) and np.array_equal(zero.lower, plain.lower)
    assert np.all(turned.a_lim != plain.a_lim)


# -- the best fixed angle ------------------------------------------------------------------------
def test_the_gain_over_the_best_fixed_angle_is_the_plan_over_the_largest_per_angle_minimum(exact_path_plan):
    plan = exact_path_plan
    per_angle = np.where(plan.reach.ok, plan.depths.a_lim, -np.inf).min(axis=0)     # (angles,)
    assert plan.best_fixed.feasible and plan.fixed.feasible      # every angle can be held here
    assert plan.best_fixed.theta[0] == plan.reach.theta[int(np.argmax(per_angle))]
    assert plan.gain_best_fixed == plan.planned.min_margin / per_angle.max()
    assert plan.gain_best_fixed >= 1.0 and plan.gain >= plan.gain_best_fixed


def test_the_best_fixed_angle_is_one_that_can_be_held():
    # angle 1 keeps the most margin but its joints jump between locations 1 and 2
    margin = np.array([[2.0, 5.0, 1.0], [2.0, 5.0, 1.0], [2.0, 5.0, 1.0]])
    q = np.zeros((3, 3, 1))
    q[2, 1, 0] = 1.0
    s = best_fixed_schedule(margin, np.radians([-10.0, 0.0, 10.0]), q=q, max_dq=0.1)
    assert s.kind == "best fixed" and s.feasible and s.index.tolist() == [0, 0, 0] and s.min_margin == 2.0
    # none can be held: the largest minimum, flagged
    q[2, :, 0] = 1.0
    s = best_fixed_schedule(margin, np.radians([-10.0, 0.0, 10.0]), q=q, max_dq=0.1)
    assert not s.feasible and s.index.tolist() == [1, 1, 1]


def test_the_best_fixed_comparison_is_in_the_summary_and_the_strict_json(exact_path_plan):
    d = json.loads(json.dumps(exact_path_plan.to_dict(), allow_nan=False))
    assert d["min_alim_gain_best_fixed"] == pytest.approx(exact_path_plan.gain_best_fixed, rel=1e-12)
    assert d["best_fixed"]["min_alim_mm"] == pytest.approx(1e3 * exact_path_plan.best_fixed.min_margin, rel=1e-12)
    line = [s for s in exact_path_plan.summary().splitlines() if s.startswith("best fixed θ")]
    assert len(line) == 1 and f"(gain {exact_path_plan.gain_best_fixed:.2f}x)" in line[0]
    assert "feed along the path" in line[0]


def test_a_saved_plan_reads_back_with_its_best_fixed_angle_cut_and_feed(exact_path_plan, tmp_path):
    plan, _ = load_plan(save_plan(exact_path_plan, tmp_path / "plan.npz", robot="irb6660", tool="dummy"))
    assert plan.cutting == STEEL_C45 and plan.feed == "path"
    assert plan.best_fixed.kind == "best fixed" and plan.gain_best_fixed == exact_path_plan.gain_best_fixed


# -- speeds ----------------------------------------------------------------------------------------
def test_a_named_speed_range_is_planned_at_ten_speeds_and_an_unknown_one_is_refused(irb):
    with pytest.raises(InputError, match="no speed range 'slow'"):
        plan_path(irb, None, _rectangle(), speed_rpm="slow", settings=_settings())
    with pytest.raises(InputError, match="the feed runs along x or path"):
        _settings(feed="y")
    assert set(CUTTINGS) == {"aluminium", "steel", "titanium"}


# -- the command line ------------------------------------------------------------------------------
def _main(argv):
    from rmbench.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def test_path_plan_takes_a_named_cut_the_feed_and_a_low_speed_range_and_prints_strict_json(predictor, tmp_path):
    pred = predictor.save(tmp_path / "pred.npz")
    csv = write_cl_csv(_rectangle(), tmp_path / "rect.csv")
    code, out, _ = _main(["path", "plan", str(csv), "--predictor", str(pred), "--speeds", "low", "--cutting",
                          "titanium", "--feed", "path", "--theta-range=-40,40", "--theta-step", "40",
                          "--spacing", "100", "--band-draws", "4", "--json"])
    d = json.loads(out, parse_constant=lambda c: pytest.fail(f"not strict JSON: {c}"))
    assert code == 0 and d["feed"] == "path" and d["cutting"]["teeth"] == 4
    assert d["speed_scan"]["speeds_rpm"] == [300.0 * k for k in range(1, 11)]
    assert d["min_alim_gain_best_fixed"] >= 1.0 and "band" in d


@pytest.mark.parametrize("option, value, message", [("--cutting", "brass", "--cutting must be one of aluminium"),
                                                    ("--feed", "y", "--feed must be x or path"),
                                                    ("--speeds", "slow", "--speeds must be rev/min")])
def test_path_plan_refuses_a_bad_cut_feed_or_speed_in_one_line(tmp_path, option, value, message):
    code, out, err = _main(["path", "plan", "contour", "--predictor", str(tmp_path / "none.npz"), "--speed", "400",
                            option, value] if option != "--speeds" else
                           ["path", "plan", "contour", "--predictor", str(tmp_path / "none.npz"), option, value])
    assert code != 0 and out == "" and message in err and len(err.strip().splitlines()) == 1
