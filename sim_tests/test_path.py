"""Specification of the path stage's first steps: tool paths read and validated, the robot's
reach over (cutter location, θ), and the redundant-angle schedule that keeps the most margin."""

import itertools

import numpy as np
import pytest

from rmbench.errors import InputError
from rmbench.io.toolpath import read_cl_csv, read_gcode, write_cl_csv
from rmbench.path import example, fixed_schedule, plan_schedule, pointwise_schedule, reach_grid


# -- tool paths in ------------------------------------------------------------------------------
def test_the_bundled_pocket_gives_over_a_thousand_cutter_locations_inside_the_posture_grid():
    tp = example("pocket").resampled(5e-3)
    assert len(tp) > 1000
    # the seed's grid spans x 1.3-1.9 m, y ±0.3 m
    assert tp.xy[:, 0].min() >= 1.3 and tp.xy[:, 0].max() <= 1.9 and np.abs(tp.xy[:, 1]).max() <= 0.3
    # only the approach is not cut; no step longer than the spacing
    assert not tp.cutting[0] and tp.cutting[1:].all()
    assert np.diff(tp.arc_length()).max() <= 5e-3 + 1e-12


def test_the_gcode_feed_and_speed_are_read_in_si_units(tmp_path):
    f = tmp_path / "p.ngc"
    f.write_text("G21 G90 (mm, absolute)\nS12000 M3\nG0 X1500 Y0 Z5\nG1 Z-1 F600\nG1 X1600 F3000 ; cut\n")
    tp = read_gcode(f)
    assert tp.xy.tolist() == [[1.5, 0.0], [1.6, 0.0]]
    # 3000 mm/min is 0.05 m/s; a Z-only block adds no cutter location
    assert tp.feed[-1] == pytest.approx(0.05) and tp.rpm[-1] == 12000 and tp.cutting.tolist() == [False, True]


@pytest.mark.parametrize("block, word", [("G2 X1600 Y100 I50 J0", "G2"), ("G20", "G20"), ("G91", "G91"),
                                         ("G1 X1600 T3", "T3")],
                         ids=["arc", "inches", "incremental", "tool-change"])
def test_an_unsupported_gcode_word_is_a_one_line_error_naming_it_and_its_line(tmp_path, block, word):
    f = tmp_path / "p.ngc"
    f.write_text(f"G21 G90\nG0 X1500 Y0\n{block}\nG1 X1700\n")
    with pytest.raises(InputError, match=rf"p\.ngc:3: unsupported G-code word {word}") as err:
        read_gcode(f)
    assert "\n" not in str(err.value)


def test_a_cutter_location_csv_round_trips_and_names_a_bad_value_by_line(tmp_path):
    tp = example("contour")
    back = read_cl_csv(write_cl_csv(tp, tmp_path / "c.csv"))
    np.testing.assert_allclose(back.xy, tp.xy, atol=1e-9)
    np.testing.assert_allclose(back.feed, tp.feed)
    bad = tmp_path / "bad.csv"
    bad.write_text("x_mm,y_mm\n1500,0\n1510,zero\n")
    with pytest.raises(InputError, match=r"bad\.csv:3: y_mm must be a number"):
        read_cl_csv(bad)
    bad.write_text("x_mm,y_mm,speed\n1500,0,1\n")
    with pytest.raises(InputError, match="unknown column 'speed'"):
        read_cl_csv(bad)


# -- reach --------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def contour_reach(irb):
    tp = example("contour").resampled(20e-3)
    return tp, reach_grid(irb, tp, np.radians([-60.0, 0.0, 60.0]), workers=1)


def test_every_contour_location_is_reached_on_one_branch_per_angle(contour_reach):
    tp, reach = contour_reach
    assert reach.ok.all() and len(reach.unreachable()) == 0
    # warm-started along the path: neighbouring locations 20 mm apart move no joint by more than a
    # few degrees (a branch flip moves the wrist by ~180°)
    assert np.degrees(np.nanmax(np.abs(np.diff(reach.q, axis=0)))) < 5.0


def test_the_angles_shared_among_processes_give_the_same_solutions(irb, contour_reach):
    """Each process follows its own columns from the same warm starts: bit for bit the solutions
    of one process."""
    tp, one = contour_reach
    two = reach_grid(irb, tp, one.theta, workers=2)
    np.testing.assert_array_equal(two.q, one.q)
    np.testing.assert_array_equal(two.sigma_min, one.sigma_min)
    np.testing.assert_array_equal(two.ok, one.ok)


def test_a_location_beyond_the_arms_reach_is_named_unreachable(irb):
    from rmbench.io.toolpath import ToolPath

    tp = ToolPath(np.array([[1.6, 0.0], [4.0, 0.0]]), np.zeros(2), np.full(2, np.nan), np.full(2, np.nan),
                  np.array([False, True]), np.array([1, 2]))
    reach = reach_grid(irb, tp, [0.0])
    assert reach.unreachable().tolist() == [1] and np.isnan(reach.q[1]).all()


# -- the schedule -------------------------------------------------------------------------------
def _brute_bottleneck(margin, max_step):
    n, m = margin.shape
    best = -np.inf
    for path in itertools.product(range(m), repeat=n):
        if all(abs(path[i] - path[i - 1]) <= max_step for i in range(1, n)):
            best = max(best, min(margin[i, path[i]] for i in range(n)))
    return best


def test_the_plan_reaches_the_largest_smallest_margin_any_allowed_schedule_has():
    rng = np.random.default_rng(3)
    for _ in range(60):
        n, m = int(rng.integers(2, 6)), int(rng.integers(2, 5))
        margin = rng.normal(size=(n, m))
        step = int(rng.integers(0, 3))
        plan = plan_schedule(margin, np.linspace(-1, 1, m), max_step=step)
        assert plan.min_margin == pytest.approx(_brute_bottleneck(margin, step), abs=1e-12)
        assert np.all(np.abs(np.diff(plan.index)) <= step)


def _brute_ramped(margin, ramp, max_step):
    """The best bottleneck over every schedule of holds and θ ramps of ``ramp`` moves (a ramp's
    inner locations count the smaller margin of its two angles), by enumeration."""
    n, m = margin.shape
    best = -np.inf

    def go(s, k, val):
        nonlocal best
        if s == n - 1:
            best = max(best, val)
            return
        go(s + 1, k, min(val, margin[s + 1, k]))
        for d in [d for a in range(1, max_step + 1) for d in (a, -a)]:
            j = k + d
            if 0 <= j < m and s + ramp <= n - 1:
                inner = [min(margin[i, k], margin[i, j]) for i in range(s + 1, s + ramp)]
                go(s + ramp, j, min([val, margin[s + ramp, j]] + inner))

    for k in range(m):
        go(0, k, margin[0, k])
    return best


def test_a_ramped_plan_reaches_the_largest_smallest_margin_any_schedule_of_ramps_has():
    rng = np.random.default_rng(6)
    for _ in range(120):
        n, m = int(rng.integers(2, 8)), int(rng.integers(1, 4))
        ramp, step = int(rng.integers(1, 4)), int(rng.integers(0, 3))
        margin = rng.normal(size=(n, m))
        plan = plan_schedule(margin, np.linspace(-1, 1, m), max_step=step, ramp=ramp)
        rows = np.arange(n)
        to = plan.index if plan.to is None else plan.to
        counted = np.minimum(margin[rows, plan.index], margin[rows, to])
        assert counted.min() == pytest.approx(_brute_ramped(margin, ramp, step), abs=1e-12)
        # the margin reported along a ramp interpolates its two angles': never below the counted
        assert np.all(plan.margin >= counted - 1e-12)


def test_a_theta_change_is_spread_over_its_ramp_along_a_cycloid():
    """The best angle changes once: θ leaves the first grid angle and reaches the next over
    ``ramp`` moves, its fractions the cycloid's (no speed or acceleration at either end)."""
    from rmbench.path.plan import ramp_profile

    margin = np.array([[1.0, 0.5]] * 10 + [[0.5, 1.0]] * 10)
    plan = plan_schedule(margin, np.array([0.0, 0.1]), max_step=1, ramp=5)
    inner = np.flatnonzero(plan.ramping)
    assert len(inner) == 4 and np.all(np.diff(inner) == 1)
    np.testing.assert_allclose(plan.frac[inner], ramp_profile(5)[1:5])
    np.testing.assert_allclose(plan.theta[inner], 0.1 * ramp_profile(5)[1:5])
    assert np.all(np.diff(plan.theta) >= 0) and plan.theta[0] == 0.0 and plan.theta[-1] == 0.1
    f = ramp_profile(5)
    assert np.diff(f)[0] == pytest.approx(np.diff(f)[-1]) and np.diff(f)[0] < 0.05


def test_a_ramp_that_would_accelerate_the_joints_beyond_the_limit_is_not_planned():
    """Two angles 0.5 rad apart in joint space, each tight (0.2) at one end of the path: spread
    over 4 moves of 0.1 s the change needs about 2π·0.5/0.4² ≈ 20 rad/s². Under a 5 rad/s² limit
    the plan must stay on one angle and keep 0.2; under 50 rad/s² it changes in the middle."""
    n = 12
    margin = np.array([[1.0, 0.2]] * 4 + [[1.0, 1.0]] * 4 + [[0.2, 1.0]] * 4)
    q = np.zeros((n, 2, 1))
    q[:, 1, 0] = 0.5
    kw = dict(q=q, max_step=1, max_dq=1.0, ramp=4, dt=0.1, max_dddq=1e6)
    slow = plan_schedule(margin, np.array([0.0, 0.1]), max_ddq=5.0, **kw)
    fast = plan_schedule(margin, np.array([0.0, 0.1]), max_ddq=50.0, **kw)
    assert len(set(slow.index.tolist())) == 1 and slow.min_margin == 0.2
    assert fast.index[0] == 0 and fast.index[-1] == 1 and fast.min_margin == 1.0


def test_the_plan_never_beats_the_pointwise_best_and_never_loses_to_a_fixed_angle():
    rng = np.random.default_rng(4)
    margin = rng.normal(size=(200, 9)).cumsum(axis=0)
    theta = np.linspace(-1, 1, 9)
    plan = plan_schedule(margin, theta, max_step=1)
    assert plan.min_margin <= pointwise_schedule(margin, theta).min_margin
    assert all(plan.min_margin >= fixed_schedule(margin, theta, t).min_margin for t in theta)


def test_a_joint_step_beyond_the_limit_is_never_planned_and_unusable_poses_are_avoided():
    """Two angles whose joint commands lie a branch flip apart cannot be switched between; a pose
    marked unusable (-inf) is never chosen where a usable schedule exists."""
    n = 6
    margin = np.array([[1.0, 2.0]] * n)
    margin[3, 1] = -np.inf
    q = np.zeros((n, 2, 1))
    q[:, 1, 0] = np.pi          # the second angle's branch is half a turn away
    plan = plan_schedule(margin, np.array([0.0, 0.5]), q=q, max_step=1, max_dq=0.1)
    # switching would be the best pointwise but is a flip: the plan keeps the first angle throughout
    assert plan.feasible and plan.index.tolist() == [0] * n
    unusable = plan_schedule(np.full((3, 1), -np.inf), np.array([0.0]))
    assert not unusable.feasible


def test_the_plan_does_not_wander_where_the_bottleneck_lies_elsewhere():
    """Flat margin but for one tight location: the θ steps cost, so the schedule sits at the angle
    the tight location needs rather than moving to it and back."""
    margin = np.ones((20, 5))
    margin[10] = [0.1, 0.1, 0.1, 0.1, 0.5]
    plan = plan_schedule(margin, np.linspace(-1, 1, 5), max_step=1)
    assert plan.min_margin == pytest.approx(0.5) and plan.index.tolist() == [4] * 20


# -- planned end to end -------------------------------------------------------------------------
def _square():
    """The contour's corners only (a 400 mm square on the seed's plane, 3000 mm/min): 80 cutter
    locations at 20 mm instead of the contour's 305, the same ground."""
    from rmbench.io.toolpath import ToolPath

    xy = np.array([[1.4, -0.2], [1.8, -0.2], [1.8, 0.2], [1.4, 0.2], [1.4, -0.2]])
    return ToolPath(xy, np.full(5, -2e-3), np.full(5, 0.05), np.full(5, 15000.0), np.array([False] + [True] * 4),
                    np.arange(1, 6))


@pytest.fixture(scope="module")
def small_predictor(irb, tmp_path_factory):
    """A single-task GP predictor on the exact modes of 12 postures around the contour (the
    simulator's truth, no campaign): what the planner reads, small enough for a test."""
    from rmbench.impact.dataset import exact_modes_dataset
    from rmbench.predict import PosturePredictor
    from rmbench.robot import Posture

    grid = [Posture.from_mm_deg(x, y, t) for x in (1350, 1850) for y in (-250, 250) for t in (-40, 0, 40)]
    pred = PosturePredictor("stgp").fit(exact_modes_dataset(irb, grid))
    return pred.save(tmp_path_factory.mktemp("pred") / "pred.npz")


@pytest.fixture(scope="module")
def predictor(small_predictor):
    """The small predictor as loaded from its file, once for the module: the tests only read it
    (a prediction leaves the predictor as it was), and each load costs most of a second."""
    from rmbench.predict import PosturePredictor

    return PosturePredictor.load(small_predictor)


def test_the_planned_schedule_keeps_at_least_the_fixed_angles_smallest_depth_within_the_joint_rates(
        irb, predictor):
    from rmbench.path import PlanSettings, plan_path

    settings = PlanSettings(theta=tuple(np.radians([-40.0, -20.0, 0.0, 20.0, 40.0])), spacing=20e-3,
                            eval_spacing=40e-3)
    plan = plan_path(irb, predictor, _square(), speed_rpm=15000,
                     depth=3e-3, settings=settings)
    assert plan.planned.feasible
    assert plan.planned.min_margin >= plan.fixed.min_margin and plan.gain >= 1.0
    assert plan.planned.min_margin <= plan.pointwise.min_margin
    # every joint's move between neighbouring locations within 60°/s at the path's 3000 mm/min feed
    dt = np.diff(plan.toolpath.arc_length()) / 0.05
    moves = np.abs(np.diff(plan.joint_trajectory(), axis=0)).max(axis=1)
    assert np.all(moves <= np.radians(60.0) * dt + 1e-12)
    # the θ ramps add no more acceleration than the limit to the path's own (the fixed angle's)
    motion, held = plan.joint_motion(), plan.joint_motion(plan.fixed)
    assert motion["accel"] <= held["accel"] + settings.max_joint_accel
    # critical depths of a few millimetres, as the seed's robot has at this speed
    assert 1e-3 < plan.planned.min_margin < 20e-3


@pytest.fixture(scope="module")
def plan_9000(irb, predictor):
    """The square planned at 9000 rev/min on three angles, locations 40 mm apart."""
    from rmbench.path import PlanSettings, plan_path

    settings = PlanSettings(theta=tuple(np.radians([-40.0, 0.0, 40.0])), spacing=40e-3, eval_spacing=80e-3)
    return plan_path(irb, predictor, _square(), speed_rpm=9000, settings=settings)


@pytest.fixture(scope="module")
def cuts_at_5(irb, plan_9000):
    """Location 5 of the planned schedule milled 30 % below and 30 % above its predicted depth, the
    robot moving along the path: ``{0.7: PathMilling, 1.3: PathMilling}``."""
    from rmbench.path import mill_schedule

    a = plan_9000.planned.margin[5]
    return {f: mill_schedule(irb, plan_9000, depth=f * a, locations=[5], moving=True) for f in (0.7, 1.3)}


def test_virtual_milling_along_the_plan_chatters_above_its_predicted_depth_and_not_below(plan_9000, cuts_at_5):
    """At 9000 rev/min the impact bands' modes set the limit (the tool on its holder, outside them,
    only above ~12 krpm), so the simulator's cut at the planned pose follows the plan's critical
    depth: stable 30 % below it, chatter 30 % above (margins over this 12-posture predictor's few
    per cent and the zero-order method's, in slot milling). The robot moves along the path."""
    a = plan_9000.planned.margin[5]
    below, above = cuts_at_5[0.7], cuts_at_5[1.3]
    assert below.predicted[0] == a and below.decided.all() and above.decided.all()
    assert not below.chatter[0] and above.chatter[0]
    assert below.agreement == above.agreement == 1.0
    # a chattering cut shakes the tool tip more than a stable one
    assert above.amplitude[0] > below.amplitude[0] > 0
    # the exact model's zero-order depth at the pose, beside the prediction
    assert below.exact[0] == pytest.approx(a, rel=0.1)
    assert below.moved.all() and above.moved.all()        # the robot did move through both cuts


def test_a_cut_on_the_moving_robot_gives_the_held_postures_verdict(irb, plan_9000, cuts_at_5):
    """During a cut (90 tooth periods at 9000 rev/min, 0.3 s at 3 m/min) the arm moves 15 mm,
    centred on the location, where its modes change over hundreds of millimetres: the verdict is
    the held posture's and the vibration within 20 % of it (the moving cut has its slow drift
    removed and passes through neighbouring poses)."""
    from rmbench.path import mill_schedule

    for f, moving in cuts_at_5.items():
        held = mill_schedule(irb, plan_9000, depth=moving.depth, locations=[5], moving=False)
        assert not held.moving
        assert moving.chatter[0] == held.chatter[0]
        assert moving.amplitude[0] == pytest.approx(held.amplitude[0], rel=0.2)


def test_a_moving_cut_stays_on_its_smooth_stretch_and_holds_where_the_stretch_is_too_short():
    """A raster: 300 mm along X, a 10 mm stepover, back along X (locations 5 mm apart). A chatter
    verdict is about steady cutting, so a 15 mm cut near a right-angle corner is shifted along its
    pass rather than carried round it, and a cut on the stepover, shorter than itself, holds its
    posture. A rounded corner (10° per move) is steady cutting and does not end a stretch."""
    from rmbench.path.milling import cut_window, smooth_stretch

    x = np.arange(0.0, 0.3001, 0.005)
    xy = np.vstack([np.column_stack([x, np.zeros_like(x)]), [[0.3, 0.005], [0.3, 0.01]],
                    np.column_stack([x[::-1][1:], np.full(len(x) - 1, 0.01)])])
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    first_pass, stepover = (0, 60), (60, 62)
    assert smooth_stretch(xy, 30) == first_pass and smooth_stretch(xy, 59) == first_pass
    assert smooth_stretch(xy, 61) == stepover
    # centred on the location; the motion's locations span the cut, at most a spacing beyond it
    start, a, b = cut_window(arc, 30, 0.015, first_pass)
    assert start == pytest.approx(arc[30] - 0.0075)
    assert arc[a] <= start < arc[a + 1] and arc[b - 1] < start + 0.015 <= arc[b]
    # near the corner: shifted back along the pass, ending at the corner
    start, a, b = cut_window(arc, 59, 0.015, first_pass)
    assert start + 0.015 == pytest.approx(arc[60]) and b == 60
    assert cut_window(arc, 61, 0.015, stepover) is None           # held
    # a rapid along the pass's line is no cut: the stretch ends before it
    cutting = np.ones(len(xy), bool)
    cutting[40] = False
    assert smooth_stretch(xy, 30, cutting=cutting) == (0, 39)
    # a straight run into a quarter circle of 9 moves: one stretch
    phi = np.radians(np.arange(0, 91, 10.0))
    bend = np.vstack([np.column_stack([np.arange(-0.05, 0.0, 0.01), np.zeros(5)]),
                      np.column_stack([0.05 * np.sin(phi), 0.05 * (1 - np.cos(phi))])])
    assert smooth_stretch(bend, 8) == (0, len(bend) - 1)


@pytest.mark.parametrize("kw, message", [({"schedule": "best", "depth": 1e-3}, "unknown schedule"),
                                         ({"depth": 0.0}, "depth of cut must be > 0")],
                         ids=["unknown-schedule", "zero-depth"])
def test_milling_a_schedule_refuses_an_unknown_schedule_or_depth(irb, kw, message):
    from rmbench.path import mill_schedule

    with pytest.raises(InputError, match=message):
        mill_schedule(irb, None, **kw)


@pytest.fixture(scope="module")
def planned_cli(small_predictor, tmp_path_factory):
    """``rmbench path plan --json --out --report`` on the square: (exit code, its JSON, its folder).
    16 band draws, not the default 64: what the tests read of the band (limits ordered and positive,
    the JSON's smallest lower limit and count at risk those of the CSV, the band drawn in the report)
    holds for any number of draws; how wide the band is, is depth_band's tests' concern."""
    import contextlib
    import io
    import json

    from rmbench.cli import main

    tmp_path = tmp_path_factory.mktemp("plan_cli")
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(["path", "plan", str(write_cl_csv(_square(), tmp_path / "square.csv")), "--predictor",
                     str(small_predictor), "--speed", "15000",
                     "--depth", "3", "--theta-range=-40,40", "--theta-step", "20", "--spacing", "20",
                     "--mill", "1", "--band-draws", "16", "--out", str(tmp_path / "plan"), "--report",
                     str(tmp_path / "plan.html"), "--json"])
    return code, json.loads(buf.getvalue()), tmp_path


def test_path_plan_writes_the_schedule_and_strict_json(planned_cli):
    import json

    code, out, tmp_path = planned_cli
    assert code == 0 and out["min_alim_gain"] >= 1.0 and not out["unreachable"]
    # one location of each schedule milled at the 3 mm depth, scored or counted inside the band
    for sched in ("planned", "fixed"):
        m = out["milling"][sched]
        assert m["cuts"] == 1 and m["decided"] + m["inside_band"] == 1 and m["depth_mm"] == pytest.approx(3.0)
    rows = (tmp_path / "plan" / "plan.csv").read_text().splitlines()
    assert rows[0].startswith("s_mm,x_mm,y_mm,theta_deg,q1_deg") and len(rows) == out["cl_points"] + 1
    # the band along the plan beside the depth (the true depth's, from the draws: the depth of the
    # mean parameters, a minimum over modes, need not lie inside it), and the locations it puts at
    # risk counted
    assert "a_lim_mm,a_lim_lower_mm,a_lim_upper_mm,cutting" in rows[0]
    lo, hi = (np.array([float(r.split(",")[i]) for r in rows[1:]]) for i in (-3, -2))
    assert np.all(lo <= hi) and np.all(lo > 0)
    assert out["band"]["min_lower_mm"] == pytest.approx(lo.min(), abs=1e-5)
    assert out["at_risk"]["planned_band"] == int(np.sum(lo < 3.0))
    assert json.loads((tmp_path / "plan" / "plan.json").read_text())["cl_points"] == out["cl_points"]
    html = (tmp_path / "plan.html").read_text()
    assert "Redundant angle along the path" in html and "Critical depth along the path" in html
    assert "Virtual milling along the path" in html and "moving along the path" in html
    assert "Tool path in 3-D" in html and '"scatter3d"' in html


def test_the_path_report_renders_its_3d_view_and_every_plot(browser, planned_cli, tmp_path):
    """The plan's report, the 3-D path (WebGL) included, draws in headless Chromium with a clean
    console (the report tests' criterion)."""
    r = browser.render(planned_cli[2] / "plan.html", screenshot=tmp_path / "plan.png")
    assert r.console_errors == () and r.undrawn == ()
    assert r.n_plots >= 5       # the plane and 3-D views, θ, the critical depth, the milling


@pytest.mark.slow
def test_path_mill_mills_a_saved_plan_as_the_plan_says(small_predictor, tmp_path, capsys):
    """The plan directory holds the whole plan (plan.npz, no pickle): milled from it, the cuts are
    those of the plan in memory, at the plan's poses and predicted depths."""
    import json

    from rmbench.cli import main
    from rmbench.path import load_plan

    args = ["path", "plan", str(write_cl_csv(_square(), tmp_path / "square.csv")), "--predictor",
            str(small_predictor), "--speed", "9000", "--theta-range=-40,40", "--theta-step", "40",
            "--spacing", "40", "--band-draws", "0", "--out", str(tmp_path / "plan"), "--json"]
    assert main(args) == 0
    plan_out = json.loads(capsys.readouterr().out)
    plan, meta = load_plan(tmp_path / "plan" / "plan.npz")
    assert meta["robot"] == "irb6660" and len(plan.toolpath) == plan_out["cl_points"]
    assert 1e3 * plan.planned.min_margin == pytest.approx(plan_out["min_alim_mm"]["planned"], rel=1e-12)
    depth = 0.7 * plan_out["min_alim_mm"]["planned"]          # 30 % below every planned limit: stable
    code = main(["path", "mill", str(tmp_path / "plan"), "--depth", f"{depth}", "-n", "2", "--json", "--moving",
                 "--report", str(tmp_path / "mill.html")])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["cuts"] == 2 and out["chatter"] == 0 and out["agreement"] == 1.0
    assert out["moving"] is True and out["held_cuts"] == 0 and all(c["moved"] for c in out["cuts_at"])
    assert [c["location"] for c in out["cuts_at"]] == [0, len(plan.toolpath) - 1]
    assert "Virtual milling along the path" in (tmp_path / "mill.html").read_text()


def test_a_speed_range_keeps_the_speed_whose_plan_keeps_the_most_depth(small_predictor, tmp_path, capsys):
    import json

    from rmbench.cli import main

    code = main(["path", "plan", str(write_cl_csv(_square(), tmp_path / "square.csv")), "--predictor",
                 str(small_predictor), "--speed-range", "9000,15000", "--speed-step", "1500",
                 "--theta-range=-40,40", "--theta-step", "40", "--spacing", "40", "--band-draws", "0", "--json"])
    out = json.loads(capsys.readouterr().out)
    scan = out["speed_scan"]
    assert code == 0 and scan["speeds_rpm"] == [9000.0, 10500.0, 12000.0, 13500.0, 15000.0]
    best = int(np.argmax(scan["min_alim_mm"]))
    assert out["speed_rpm"] == scan["speeds_rpm"][best]
    assert out["min_alim_mm"]["planned"] == pytest.approx(scan["min_alim_mm"][best], rel=1e-12)


def test_path_mill_refuses_a_directory_without_a_plan(tmp_path, capsys):
    from rmbench.cli import main

    assert main(["path", "mill", str(tmp_path), "--depth", "1"]) != 0
    assert "plan not found" in capsys.readouterr().err


def test_an_unreachable_cutter_location_is_named_with_its_line_and_reach(irb, predictor, tmp_path):
    from rmbench.path import plan_path

    f = tmp_path / "far.csv"
    f.write_text("x_mm,y_mm\n1500,0\n1600,0\n3900,0\n")
    with pytest.raises(InputError, match=r"unreachable at every angle, the first at line 4: \(3900.0, 0.0\) mm, "
                                         r"3900 mm from the base axis"):
        plan_path(irb, predictor, read_cl_csv(f), speed_rpm=15000)


def test_the_exact_modes_dataset_is_a_modal_dataset_a_predictor_reads(irb):
    """Tracked exact modes at postures, in DATA.md's modal layout: the same mode keeps its number
    from posture to posture (frequencies move by a few per cent between neighbours, not by a mode)."""
    from rmbench.impact.dataset import exact_modes_dataset
    from rmbench.predict import training_set
    from rmbench.robot import Posture

    ds = exact_modes_dataset(irb, [Posture.from_mm_deg(1500, y, 0) for y in (-100, 0, 100)])
    ts = training_set(ds)
    f = ds.modal.sel(param="f_n").values
    assert ts.X.shape == (3, 3) and set(ds.mode_band.values) == {"low", "high"}
    assert np.nanmax(np.abs(f[1:] / f[:-1] - 1)) < 0.05


def test_the_depth_band_widens_with_the_predictors_standard_deviations(predictor):
    """Sampled from the predictor's variance: no spread, no band; twice the spread, about twice the
    width while the spread is small (this 12-posture predictor's own is large: a few tenths of a per cent
    of it keeps a tight veering's perturbed poles in the linear range)."""
    from rmbench.path import depth_band
    from rmbench.stability import ALUMINIUM_6061

    xy, theta = np.array([[1.5, 0.0], [1.7, 0.1]]), np.array([0.0, 0.3])
    b0 = depth_band(predictor, xy, theta, ALUMINIUM_6061, 15000.0, draws=8, sd_scale=0.0)
    np.testing.assert_allclose([b0.lower, b0.upper], [b0.a_lim, b0.a_lim])
    b1 = depth_band(predictor, xy, theta, ALUMINIUM_6061, 15000.0, draws=32, sd_scale=0.002)
    b2 = depth_band(predictor, xy, theta, ALUMINIUM_6061, 15000.0, draws=32, sd_scale=0.004)
    assert np.all(b1.lower < b0.a_lim) and np.all(b0.a_lim < b1.upper)
    np.testing.assert_allclose((b2.upper - b2.lower) / (b1.upper - b1.lower), 2.0, rtol=0.15)


def test_the_depth_bands_centre_is_the_predicted_depth_veering_clusters_included(predictor):
    """The band is drawn around the depth the planner uses: a veering cluster's modes keep the
    cluster's residues, also where the cluster's pole is the mode's own (a tight veering inside a
    looser cluster), as in a predictor trained on the seed's 112 postures."""
    from rmbench.path import depth_band
    from rmbench.path.margin import TipModes, tip_modes
    from rmbench.stability import ALUMINIUM_6061

    X = np.array([[1.5, 0.0, 0.0], [1.7, 0.1, 0.3]])
    ds = predictor.predict(X)
    high = np.flatnonzero(ds.mode_band.values == "high")
    clustered = high[np.isfinite(ds.cluster_pole.values[0, high])]
    assert len(clustered)
    # the first clustered mode's cluster pole set to the mode's own pole, its residues left the cluster's
    m = clustered[0]
    f, z = ds.modal.sel(param="f_n").values[:, m], ds.modal.sel(param="zeta").values[:, m]
    ds.cluster_pole.values[:, m] = 2 * np.pi * f * (-z + 1j * np.sqrt(1 - z ** 2))

    class Fixed:
        def predict(self, X, **kw):
            return ds

    band = depth_band(Fixed(), X[:, :2], X[:, 2], ALUMINIUM_6061, 9000.0, draws=2, bands=("high",))
    poles, res = tip_modes(ds, "high")
    # the planner's depth of the same modes: two postures, one angle each
    planned = TipModes((2, 1), {"high": poles}, {"high": res}, np.arange(2), np.zeros((2, 1), bool))
    want = planned.depths(ALUMINIUM_6061, 9000.0).a_lim.ravel()
    np.testing.assert_allclose(band.a_lim, want, rtol=1e-12)


def test_the_conformal_depth_band_scales_the_draws_spread_by_the_left_out_postures(predictor):
    """Symmetric in log depth about the predicted depth, by one factor found from every training
    posture's left-out depth; a higher level takes a larger factor."""
    from rmbench.path import depth_band
    from rmbench.stability import ALUMINIUM_6061

    xy, theta = np.array([[1.5, 0.0], [1.7, 0.1]]), np.array([0.0, 0.3])
    b = depth_band(predictor, xy, theta, ALUMINIUM_6061, 15000.0, draws=16, conformal=True, level=0.8)
    assert b.n_calibration == len(predictor.X_train_) and 0 < b.scale < np.inf
    np.testing.assert_allclose(np.log(b.upper / b.a_lim), np.log(b.a_lim / b.lower), rtol=1e-12)
    wider = depth_band(predictor, xy, theta, ALUMINIUM_6061, 15000.0, draws=16, conformal=True, level=0.9)
    assert wider.scale >= b.scale


def test_a_prediction_without_standard_deviations_has_the_same_means(predictor):
    X = [[1.5, 0.0, 0.0], [1.7, 0.1, 0.3]]
    full, fast = predictor.predict(X), predictor.predict(X, std=False)
    np.testing.assert_array_equal(fast.modal.values, full.modal.values)
    assert np.isnan(fast.modal_std.values).any() and not np.isnan(full.modal_std.values[np.isfinite(full.modal.values)]).any()


def test_a_repeated_cutter_location_does_not_freeze_the_schedule():
    """A move of zero length allows no joint motion, and needs none: the moves around it keep
    their own limits (one limit per move, not the tightest for all)."""
    margin = np.array([[1.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    q = np.array([[[0.0], [0.05]], [[0.0], [0.05]], [[0.0], [0.05]], [[0.05], [0.1]]])
    plan = plan_schedule(margin, np.array([0.0, 0.1]), q=q, max_step=1, max_dq=[0.0, 0.1, 0.1])
    assert plan.feasible and plan.index.tolist() == [0, 0, 0, 1] and plan.min_margin == 1.0


def test_poses_beyond_the_training_postures_are_counted_with_their_distance(irb, predictor):
    """The 12 training postures span x 1.35-1.85 m: a contour out to 1.8 m stays inside, one
    shifted 0.2 m further out leaves the hull, and the plan says by how much."""
    from rmbench.io.toolpath import ToolPath
    from rmbench.path import PlanSettings, plan_path

    settings = PlanSettings(theta=(0.0,), spacing=50e-3, eval_spacing=50e-3)
    inside = ToolPath(np.array([[1.5, 0.0], [1.6, 0.0]]), np.zeros(2), np.full(2, np.nan), np.full(2, np.nan),
                      np.array([False, True]), np.array([1, 2]))
    outside = ToolPath(np.array([[1.8, 0.0], [2.0, 0.0]]), inside.z, inside.feed, inside.rpm, inside.cutting,
                       inside.line)
    s_in = plan_path(irb, predictor, inside, speed_rpm=15000, settings=settings).to_dict()
    s_out = plan_path(irb, predictor, outside, speed_rpm=15000, settings=settings).to_dict()
    assert s_in["outside_hull"] == 0 and s_in["hull_distance_max"] == 0.0
    assert s_out["outside_hull"] >= 1 and s_out["hull_distance_max"] > 0.2


@pytest.mark.slow
def test_a_stable_cut_through_the_contours_rounded_corner_reads_stable_on_the_moving_robot(irb, predictor):
    """Location 73 of the bundled contour, θ held at 0, lies where the joint path's curvature
    changes (a rounded corner running into a straight). Milled at 60 % of its critical depth the
    cut is stable held, and must read stable moving too: a monotone-cubic reference stepped the
    servos' acceleration at every 5 mm knot (10 Hz at 3 m/min, the arm's lowest modes) and read a
    30 µm sway as chatter."""
    from rmbench.path import PlanSettings, example, mill_schedule, plan_path

    settings = PlanSettings(theta=(0.0,))
    plan = plan_path(irb, predictor, example("contour"), speed_rpm=9000,
                     settings=settings)
    depth = 0.6 * plan.fixed.margin[73]
    moving = mill_schedule(irb, plan, depth=depth, schedule="fixed", locations=[73])
    held = mill_schedule(irb, plan, depth=depth, schedule="fixed", locations=[73], moving=False)
    assert moving.moved[0] and not held.chatter[0]
    assert not moving.chatter[0]
    assert moving.amplitude[0] < 2 * held.amplitude[0]
