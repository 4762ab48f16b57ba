"""Re-orienting θ at a path's corners, the tool standing (issue 82).

``PlanSettings.reorient = "ramps"`` (the default) plans as before: θ changes only by cycloidal ramps
of one grid step while cutting. ``"corners"`` also lets θ turn by any number of grid steps where
the feed heading turns by more than ``corner_angle``: the feed stops, the joints move rest to rest
at their rate, acceleration and jerk limits, and the time the tool stands (the dwell) is reported.

A 300 x 200 mm rectangle, locations 50 mm apart and evaluated at every one, five angles 20° apart,
the exact model's modes in steel at 400 rev/min with the feed along the path.
"""

import contextlib
import io
import json

import numpy as np
import pytest

from rmbench.errors import InputError
from rmbench.io.toolpath import ToolPath, write_cl_csv
from rmbench.path import REORIENTS, PlanSettings, example, plan_path, plan_schedule
from rmbench.path.corners import dwell_time, find_corners
from rmbench.path.milling import cut_stretch, cut_window, mill_schedule, smooth_stretch
from rmbench.path.ramps import ramp_moves
from rmbench.stability import STEEL_C45

THETA = tuple(np.radians([-40.0, -20.0, 0.0, 20.0, 40.0]))


def _rectangle():
    """300 x 200 mm, counter-clockwise from (1500, -100) mm: along +X, +Y, -X, -Y."""
    xy = np.array([[1.5, -0.1], [1.8, -0.1], [1.8, 0.1], [1.5, 0.1], [1.5, -0.1]])
    return ToolPath(xy, np.full(5, -2e-3), np.full(5, 0.05), np.full(5, np.nan), np.array([False] + [True] * 4),
                    np.arange(1, 6))


def _settings(**kw):
    return PlanSettings(theta=THETA, spacing=50e-3, eval_spacing=40e-3, feed="path", **kw)


def _plan(irb, reorient):
    return plan_path(irb, None, _rectangle(), speed_rpm=400.0, cutting=STEEL_C45, settings=_settings(reorient=reorient))


@pytest.fixture(scope="module")
def ramps(irb):
    return _plan(irb, "ramps")


@pytest.fixture(scope="module")
def corners(irb):
    return _plan(irb, "corners")


# -- the default ------------------------------------------------------------------------------------
def test_ramps_is_the_default_and_adds_nothing_to_the_plan(ramps):
    assert PlanSettings().reorient == "ramps" and REORIENTS == ("ramps", "corners")
    assert ramps.planned.corners is None and ramps.reorientation is None
    assert "reorient" not in ramps.to_dict()


def test_without_corners_the_schedule_is_the_ramps_only_one(ramps):
    """plan_schedule with no corner locations plans exactly what it plans without the option."""
    margin = np.where(ramps.reach.ok, ramps.depths.a_lim, -np.inf)
    arc = ramps.toolpath.arc_length()
    dt = np.diff(arc) / ramps.toolpath.feed[1:]
    st = _settings()
    kw = dict(q=ramps.reach.q, max_step=1, max_dq=st.max_joint_rate * dt, ramp=ramp_moves(st, ramps.reach, dt), dt=dt,
              max_ddq=st.max_joint_accel, max_dddq=st.max_joint_jerk)
    plain = plan_schedule(margin, THETA, **kw)
    none = plan_schedule(margin, THETA, corners=[], **kw)
    for a, b in ((plain, none), (plain, ramps.planned)):
        assert np.array_equal(a.index, b.index) and np.array_equal(a.theta, b.theta)
        assert np.array_equal(a.margin, b.margin)
    assert none.corners is not None and len(none.corners) == 0


# -- what turning at corners buys -------------------------------------------------------------------
def test_the_rectangle_has_three_inner_corners():
    tp = _rectangle().resampled(50e-3)
    assert find_corners(tp, np.radians(30.0)).tolist() == [6, 10, 16]


def test_a_rounded_corner_is_one_and_a_pass_end_two():
    contour = example("contour").resampled(5e-3)
    c = find_corners(contour, np.radians(30.0))
    assert len(c) == 4
    # the middle of each 50 mm-radius arc, 45° round it
    assert np.allclose(np.abs(contour.xy[c] - [1.6, 0.0]), 0.15 + 0.05 / np.sqrt(2), atol=5e-3)
    pocket = example("pocket").resampled(5e-3)
    assert len(find_corners(pocket, np.radians(30.0))) == 60            # 30 step-overs, two right angles each


def test_corners_keep_at_least_the_ramps_and_the_best_fixed_depth(ramps, corners):
    """Every schedule of holds and ramps remains allowed, so the DP's feasible set only grows:
    its largest smallest depth cannot fall."""
    assert corners.planned.feasible
    assert corners.planned.min_margin >= ramps.planned.min_margin
    assert corners.planned.min_margin >= corners.best_fixed.min_margin


def test_on_the_rectangle_turning_at_corners_beats_the_best_fixed_angle(ramps, corners):
    assert ramps.gain_best_fixed < 1.05
    assert corners.gain_best_fixed > 1.3


def test_theta_changes_by_more_than_one_ramp_step_only_at_corners(corners):
    s = corners.planned
    c = np.asarray(s.corners, int)
    assert len(c) and set(c) <= set(find_corners(corners.toolpath, np.radians(30.0)))
    step = np.abs(np.diff(s.index))
    off = np.setdiff1d(np.arange(len(step)), c)      # move s -> s + 1 leaves a corner s
    assert np.all(step[off] <= 1)
    if s.to is not None:
        assert np.all(np.abs(s.to - s.index) <= 1)
    assert np.all(step[c] >= 1)


def _rest_to_rest(d, v, a, j):
    """The shortest rest-to-rest time over distance d at joint limits v, a, j, by bisection on the
    peak speed (a separate derivation from the planner's closed form)."""
    def ramp(vp):                           # time from rest to vp
        return vp / a + a / j if vp >= a * a / j else 2 * np.sqrt(vp / j)

    if d >= v * ramp(v):
        return d / v + ramp(v)
    lo, hi = 0.0, v
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if mid * ramp(mid) < d else (lo, mid)
    return 2 * ramp(lo)


def test_the_dwell_is_the_joint_limited_time_of_the_largest_joint_move(corners):
    s, st = corners.planned, _settings()
    q = corners.joint_trajectory()
    ro = corners.reorientation
    assert np.array_equal(ro.used, s.corners)
    for c, t in zip(ro.used, ro.dwell):
        move = np.max(np.abs(corners.reach.q[c, s.index[c + 1]] - q[c]))
        assert t == pytest.approx(_rest_to_rest(move, st.max_joint_rate, st.max_joint_accel, st.max_joint_jerk),
                                  rel=1e-9)
    assert ro.total_dwell == pytest.approx(float(np.sum(ro.dwell))) and ro.total_dwell > 0


def test_dwell_time_cruises_at_the_rate_on_a_long_move():
    v, a, j = 1.0, 1.0, 10.0
    assert dwell_time(5.0, v, a, j) == pytest.approx(5.0 / v + v / a + a / j)
    assert dwell_time(0.0, v, a, j) == 0.0


def test_the_standing_turn_is_no_cutting_move(corners):
    """The joint rate while cutting stays within the limit: the turn happens while the tool stands."""
    assert corners.joint_motion()["rate"] <= _settings().max_joint_rate + 1e-9


def test_the_corners_are_in_the_summary_and_the_strict_json(corners):
    d = json.loads(json.dumps(corners.to_dict(), allow_nan=False))
    ro = d["reorient"]
    assert ro["mode"] == "corners" and ro["corners"] == 3 and ro["corners_used"] == corners.planned.corners.tolist()
    assert ro["dwell_total_s"] == pytest.approx(sum(ro["dwell_s"]))
    assert "dwell" in corners.summary() and "rubs" in corners.summary()


# -- the dwell charged: a standing turn only where the smallest depth needs it -----------------------
TH3 = np.radians([-20.0, 0.0, 20.0])


def _two_sides(before, after, first=None):
    """12 locations, a corner at 5: ``before`` (3 margins) at 0-5, ``after`` at 6-11; location 0's
    margins ``first`` where given."""
    m = np.array([before] * 6 + [after] * 6, float)
    if first is not None:
        m[0] = first
    return m


def test_where_one_angle_is_best_everywhere_no_turn_is_taken():
    s = plan_schedule(_two_sides([1.0, 3.0, 2.0], [1.0, 3.0, 2.0]), TH3, corners=[5])
    assert len(s.corners) == 0 and np.all(s.index == 1)


def test_a_turn_that_only_raises_the_summed_depth_is_not_taken():
    """Location 0 sets the smallest margin (0.5) at every angle: turning at the corner would raise
    the sum along 6-11 (2 rather than 1) but not the smallest margin, so the tool does not stand."""
    s = plan_schedule(_two_sides([3.0, 1.0, 1.0], [1.0, 1.0, 2.0], first=[0.5, 0.5, 0.5]), TH3, max_step=0,
                      corners=[5])
    assert s.min_margin == 0.5 and len(s.corners) == 0 and np.all(s.index == 0)


def test_the_turn_the_smallest_depth_needs_is_taken_and_the_shortest_of_them():
    """Only a turn keeps 2.0 after the corner; to 0° (one step) and to 20° (two) both do, and the
    shorter is taken although the longer would raise the summed margin."""
    s = plan_schedule(_two_sides([2.0, 0.2, 0.2], [0.2, 2.5, 3.0]), TH3, max_step=0, corners=[5])
    assert s.min_margin == 2.0 and s.corners.tolist() == [5]
    assert s.index[5] == 0 and s.index[6] == 1


def test_a_turn_that_raises_the_smallest_depth_by_less_than_min_turn_gain_is_not_taken():
    """θ = -20° keeps 1.0 throughout; a turn to 0° at the corner would keep 1.02 (2 % more): below
    the default 5 % the tool does not stand for it, at 1 % it does."""
    m = _two_sides([1.02, 0.2, 0.2], [1.0, 1.02, 0.2])
    kept = plan_schedule(m, TH3, max_step=0, corners=[5])
    assert kept.min_margin == 1.0 and len(kept.corners) == 0 and np.all(kept.index == 0)
    turned = plan_schedule(m, TH3, max_step=0, corners=[5], min_turn_gain=0.01)
    assert turned.min_margin == 1.02 and turned.corners.tolist() == [5]


def test_a_negative_min_turn_gain_is_one_line_input_error():
    with pytest.raises(InputError, match="min_turn_gain"):
        plan_schedule(_two_sides([1.0, 3.0, 2.0], [1.0, 3.0, 2.0]), TH3, corners=[5], min_turn_gain=-0.1)
    with pytest.raises(InputError, match="min_turn_gain"):
        PlanSettings(min_turn_gain=-0.1)


def test_on_the_rectangle_the_turns_that_raise_the_smallest_depth_are_taken(ramps, corners):
    assert len(corners.reorientation.used) >= 1
    assert corners.planned.min_margin > 1.3 * ramps.planned.min_margin


# -- milling a plan that stands at corners ---------------------------------------------------------
def test_a_moving_cut_never_runs_through_a_corner_where_the_tool_stands():
    """The contour's corners are rounded (50 mm radius): a smooth stretch runs through them, a cut
    of 40 mm about a location near one would too; ended at the corners, none does."""
    tp = example("contour").resampled(5e-3)
    arc, c = tp.arc_length(), find_corners(tp, np.radians(30.0))
    crossed = 0
    for k in range(len(tp)):
        for stretch, clipped in ((smooth_stretch(tp.xy, k, cutting=tp.cutting), False), (cut_stretch(tp, k, c), True)):
            w = cut_window(arc, k, 40e-3, stretch)
            if w is None:
                continue
            inside = np.any((arc[c] > w[0] + 1e-9) & (arc[c] < w[0] + 40e-3 - 1e-9))
            assert not (clipped and inside), k
            crossed += inside
    assert crossed > 0
    assert cut_stretch(tp, 10, None) == smooth_stretch(tp.xy, 10, cutting=tp.cutting)


def test_a_plan_that_stands_at_corners_mills(irb, corners):
    """Cuts of 17.5 mm (14 tooth periods, a little over the 12 a verdict takes) at a corner where θ
    turns (ending there) and at the next location (starting at the corner, at the angle the turn
    ends at)."""
    c = int(corners.planned.corners[0])
    locs = [c, c + 1]
    milled = mill_schedule(irb, corners, depth=0.3e-3, locations=locs, periods=14)
    assert milled.index.tolist() == locs and np.all(milled.moved)
    assert np.allclose(milled.heading, corners.toolpath.heading()[locs], atol=1e-6)


def test_a_bad_reorient_or_corner_angle_is_one_line_input_error():
    with pytest.raises(InputError, match="re-oriented by ramps or corners") as e:
        PlanSettings(reorient="always")
    assert len(str(e.value).splitlines()) == 1
    with pytest.raises(InputError, match="corner_angle"):
        PlanSettings(corner_angle=0.0)


# -- the command line ------------------------------------------------------------------------------
def _main(argv):
    from rmbench.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def predictor(irb):
    """A single-task GP on the exact modes of 8 postures around the rectangle."""
    from rmbench.impact.dataset import exact_modes_dataset
    from rmbench.predict import PosturePredictor
    from rmbench.robot import Posture

    grid = [Posture.from_mm_deg(x, y, t) for x in (1450, 1850) for y in (-150, 150) for t in (-40, 40)]
    return PosturePredictor("stgp").fit(exact_modes_dataset(irb, grid))


def test_path_plan_reorients_at_corners_and_prints_strict_json(predictor, tmp_path):
    pred = predictor.save(tmp_path / "pred.npz")
    csv = write_cl_csv(_rectangle(), tmp_path / "rect.csv")
    code, out, _ = _main(["path", "plan", str(csv), "--predictor", str(pred), "--speed", "400", "--cutting", "steel",
                          "--feed", "path", "--reorient", "corners", "--theta-range=-40,40", "--theta-step", "20",
                          "--spacing", "50", "--band-draws", "0", "--json"])
    d = json.loads(out, parse_constant=lambda c: pytest.fail(f"not strict JSON: {c}"))
    assert code == 0 and d["reorient"]["mode"] == "corners" and d["reorient"]["corners"] == 3


def test_path_plan_refuses_a_bad_reorient_in_one_line(tmp_path):
    code, out, err = _main(["path", "plan", "contour", "--predictor", str(tmp_path / "none.npz"), "--speed", "400",
                            "--reorient", "often"])
    assert code != 0 and out == "" and "--reorient must be ramps or corners" in err
    assert len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("option, value, message", [("--min-turn-gain", "-5", "--min-turn-gain must be a percentage"),
                                                    ("--exact-modes", "every", "--exact-modes must be bands or all"),
                                                    ("--speed-by", "rate", "--speed-by must be depth or removal")],
                         ids=["min-turn-gain", "exact-modes", "speed-by"])
def test_path_plan_refuses_a_bad_turn_gain_or_exact_modes_in_one_line(tmp_path, option, value, message):
    code, out, err = _main(["path", "plan", "contour", "--predictor", str(tmp_path / "none.npz"), "--speed", "400",
                            f"{option}={value}"])
    assert code != 0 and out == "" and message in err
    assert len(err.strip().splitlines()) == 1
