"""The exact model's plan can see every mode below f_max (issue 82).

``PlanSettings.exact_modes = "all"`` plans on :func:`rmbench.path.margin.exact_modes` with
``bands="all"`` (every mode of the linearised robot below ``f_max`` in one receptance) instead of
the measured bands' mode tables (``"bands"``, the default). At (1800, 200, 30°), 1,500 rev/min in
steel, the bands give 2.74 mm and every mode 1.20 mm (the end mill's modes near 2.7 kHz set it):
a bands-only plan can pick a speed whose lobe the full model lacks.

A 100 mm pass along +X through (1800, 200) mm, a location every 50 mm and evaluated at each, at
θ = 0 and 30°.
"""

import numpy as np
import pytest

from rmbench.errors import InputError
from rmbench.io.toolpath import ToolPath
from rmbench.path import PlanSettings, exact_modes, load_plan, mill_schedule, plan_path, save_plan
from rmbench.path.planner import EXACT_MODES, SPEED_BY
from rmbench.robot import Robot
from rmbench.stability import STEEL_C45

THETA = tuple(np.radians([0.0, 30.0]))
RPM = 1500.0


@pytest.fixture(scope="module")
def endmill():
    return Robot.load("irb6660", tool="endmill")


def _pass():
    xy = np.array([[1.75, 0.2], [1.85, 0.2]])
    return ToolPath(xy, np.full(2, -2e-3), np.full(2, 0.05), np.full(2, np.nan), np.array([False, True]),
                    np.arange(1, 3))


def _plan(robot, **kw):
    st = PlanSettings(theta=THETA, spacing=50e-3, eval_spacing=50e-3, **kw)
    return plan_path(robot, None, _pass(), speed_rpm=RPM, cutting=STEEL_C45, settings=st)


@pytest.fixture(scope="module")
def bands(endmill):
    return _plan(endmill)


@pytest.fixture(scope="module")
def every(endmill):
    return _plan(endmill, exact_modes="all")


def test_the_bands_are_the_default():
    assert PlanSettings().exact_modes == "bands" and PlanSettings().f_max == 8000.0
    assert EXACT_MODES == ("bands", "all")


def test_all_plans_on_the_depths_of_every_mode_at_its_poses(endmill, every):
    ref = exact_modes(endmill, every.toolpath.xy, THETA, reach=every.reach, bands="all").depths_at(STEEL_C45, [RPM])[0]
    assert np.array_equal(every.depths.a_lim, ref.a_lim)
    assert tuple(every.depths.by_band) == ("all",)


def test_f_max_reaches_the_exact_modes(endmill):
    plan = _plan(endmill, exact_modes="all", f_max=1000.0)
    ref = exact_modes(endmill, plan.toolpath.xy, THETA, reach=plan.reach, bands="all",
                      f_max=1000.0).depths_at(STEEL_C45, [RPM])[0]
    assert np.array_equal(plan.depths.a_lim, ref.a_lim)


def test_every_mode_lowers_the_limit_the_bands_give_at_1500_rpm_in_steel(bands, every):
    """The end mill's 2.7 kHz modes, outside the bands, set the limit at (1800, 200, 30°)."""
    assert every.depths.a_lim[1, 1] < 0.6 * bands.depths.a_lim[1, 1]


def test_a_bad_exact_modes_or_f_max_is_one_line_input_error():
    with pytest.raises(InputError, match="bands or all") as e:
        PlanSettings(exact_modes="every")
    assert len(str(e.value).splitlines()) == 1
    with pytest.raises(InputError, match="f_max"):
        PlanSettings(f_max=0.0)


def _diagonal():
    """The same 100 mm pass turned to run at 45° in the base plane: the feed along it is not X."""
    xy = np.array([[1.75, 0.15], [1.75 + 0.1 / np.sqrt(2), 0.15 + 0.1 / np.sqrt(2)]])
    return ToolPath(xy, np.full(2, -2e-3), np.full(2, 0.05), np.full(2, np.nan), np.array([False, True]),
                    np.arange(1, 3))


@pytest.mark.parametrize("modes", EXACT_MODES)
def test_milling_reference_is_the_plans_own_exact_depth_along_the_feed(endmill, modes):
    """A plan fed along a 45° pass is milled with the exact depth it was planned on: the same
    modes (the bands' or all) turned into the same cut frame. They agree to the chatter-frequency
    grid's resolution, not to rounding: each call spreads its 800 lines over the span of its own
    poles (the plan's over every pose, the milling reference's over one), and with every mode,
    from a few Hz to 8 kHz, neighbouring lines lie about 1.1 % apart: 0.4 % measured, 1 % allowed."""
    st = PlanSettings(theta=THETA, spacing=50e-3, eval_spacing=50e-3, feed="path", exact_modes=modes)
    plan = plan_path(endmill, None, _diagonal(), speed_rpm=RPM, cutting=STEEL_C45, settings=st)
    run = mill_schedule(endmill, plan, depth=0.2e-3, locations=[0, 1], periods=14, moving=False)
    np.testing.assert_allclose(run.exact, run.predicted, rtol=1e-2)


def test_a_saved_plan_keeps_the_modes_it_saw(every, tmp_path):
    plan, _ = load_plan(save_plan(every, tmp_path / "plan.npz"))
    assert (plan.exact_modes, plan.f_max) == ("all", 8000.0)


# -- the speed kept: by depth or by removal rate -------------------------------------------------------
def test_by_removal_the_faster_speed_is_kept_where_its_depth_falls_less_than_the_speed_rises():
    """Aluminium slot on the dummy tool at (1550-1650, 0): 15,000 rev/min keeps the larger smallest
    depth, 16,000 a depth under 7 % smaller, so a removal rate (depth x speed) about 5 % larger."""
    dummy = Robot.load("irb6660", tool="dummy")
    xy = np.array([[1.55, 0.0], [1.65, 0.0]])
    tp = ToolPath(xy, np.full(2, -2e-3), np.full(2, 0.05), np.full(2, np.nan), np.array([False, True]),
                  np.arange(1, 3))
    plans = {by: plan_path(dummy, None, tp, speed_rpm=[15000.0, 16000.0], settings=PlanSettings(
        theta=tuple(np.radians([-30.0, 0.0, 30.0])), spacing=50e-3, eval_spacing=50e-3, speed_by=by))
        for by in SPEED_BY}
    a = np.array(plans["depth"].speed_scan["min_alim"])
    assert a[0] > a[1] and 16000 * a[1] > 15000 * a[0]
    assert plans["depth"].speed_rpm == 15000.0 and plans["removal"].speed_rpm == 16000.0


def test_depth_is_the_default_speed_choice_and_a_bad_one_is_one_line_input_error():
    assert PlanSettings().speed_by == "depth" and SPEED_BY == ("depth", "removal")
    with pytest.raises(InputError, match="depth or removal"):
        PlanSettings(speed_by="rate")
