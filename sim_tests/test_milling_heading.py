"""Virtual milling with the feed along a heading (issue 82): the simulator turns its cut as the
stability model turns the tool tip's modes, so that a plan fed along the path can be milled.

The cut takes its chip in the (feed, normal) frame turned by the heading ψ from base X and applies
its force turned back; ψ = 0 is the cut along base X, bit for bit. The physical checks run on the
arm with the light tool at (1800, 200, 0) mm, deg, in steel at 2,000 rev/min, where the heading
matters most: fed along base Y its zero-order critical depth (every mode of the arm below 8 kHz) is
0.28 mm, along base X 1.2 mm. About a second a cut.
"""

import numpy as np
import pytest

from rmbench.errors import InputError
from rmbench.io.toolpath import ToolPath
from rmbench.path import PlanSettings, mill_schedule, plan_path
from rmbench.robot import Posture
from rmbench.stability import STEEL_C45, to_cut_frame, zoa_limit
from rmbench.stability.milling import Motion, mill

RPM = 2000.0


@pytest.fixture(scope="module")
def op(irb):
    return irb.at(Posture.from_mm_deg(1800, 200, 0))


def _zoa_limit(op, heading: float) -> float:
    """The zero-order critical depth at ``RPM``, m, from every mode of the arm below 8 kHz at the
    tool tip, their residues turned to the feed ``heading`` (rad)."""
    cm = op.linear.modes()
    rows = op.coordinate_map(("1X", "1Y"))
    sel = (cm.f_n < 8000.0) & ~cm.real_pole
    poles = cm.poles[sel]
    res = (rows @ cm.phi_r).T[sel][:, :, None] * (rows @ cm.phi_l).T[sel][:, None, :]
    f = np.abs(poles) / (2 * np.pi)
    freq = np.geomspace(0.2 * f.min(), 1.6 * f.max(), 4000)
    return float(zoa_limit(poles[None], to_cut_frame(res, heading)[None], STEEL_C45, RPM, freq)[0])


# -- heading 0 is the cut along base X --------------------------------------------------------------
def test_a_cut_at_heading_zero_is_the_default_cut_bit_for_bit(op):
    default = mill(op, STEEL_C45, RPM, 0.3e-3, periods=20)
    assert mill(op, STEEL_C45, RPM, 0.3e-3, periods=20, heading=0.0).to_dict() == default.to_dict()


def test_a_motion_whose_headings_are_zero_mills_bit_for_bit_as_one_without(irb):
    a, b = (irb.at(Posture.from_mm_deg(x, 0, 0)) for x in (1600, 1610))
    plain = mill(a, STEEL_C45, RPM, 0.3e-3, periods=20, motion=Motion.through([a, b], [-0.01, 0.2]))
    zero = mill(a, STEEL_C45, RPM, 0.3e-3, periods=20, motion=Motion.through([a, b], [-0.01, 0.2], [0.0, 0.0]))
    assert zero.to_dict() == plain.to_dict()


# -- the turned cut is the stability model's ----------------------------------------------------------
@pytest.fixture(scope="module")
def limits(op):
    """Zero-order critical depths fed along base Y and along base X, m."""
    return _zoa_limit(op, np.pi / 2), _zoa_limit(op, 0.0)


def test_the_heading_moves_the_critical_depth_of_this_pose(limits):
    along_y, along_x = limits
    assert along_x > 3 * along_y        # so that 1.3x the one lies far below the other


def test_a_cut_fed_along_base_y_is_stable_at_07_of_its_turned_limit(op, limits):
    run = mill(op, STEEL_C45, RPM, 0.7 * limits[0], heading=np.pi / 2)
    assert not run.chatter and run.kind == "stable"


def test_a_cut_fed_along_base_y_chatters_at_13_of_its_turned_limit(op, limits):
    run = mill(op, STEEL_C45, RPM, 1.3 * limits[0], heading=np.pi / 2)
    assert run.chatter and run.off_harmonic > 0.5


def test_the_same_depth_fed_along_base_x_is_stable(op, limits):
    """1.3x the limit along base Y is a third of the limit along base X: the chatter above came
    from the turned cut, not from the depth."""
    run = mill(op, STEEL_C45, RPM, 1.3 * limits[0])
    assert not run.chatter


def test_a_cut_fed_back_along_minus_x_mirrors_the_cut_along_x(op):
    """R(π) = −I turns the chip and the force alike: the tip's vibration is the same one mirrored,
    and the chatter metrics are the same to within the arm's departure from linearity about its
    equilibrium (a deflection of tens of µm on a 3 m arm: 3e-5 relative measured, 1e-3 allowed)."""
    forth = mill(op, STEEL_C45, RPM, 1.5e-3, periods=40)
    back = mill(op, STEEL_C45, RPM, 1.5e-3, periods=40, heading=np.pi)
    assert back.kind == forth.kind == "hopf"
    for k in ("metric", "growth", "off_harmonic", "amplitude"):
        assert getattr(back, k) == pytest.approx(getattr(forth, k), rel=1e-3)


# -- refused headings -------------------------------------------------------------------------------
def test_a_motion_needs_one_finite_heading_per_knot(op):
    with pytest.raises(InputError, match="one finite value"):
        Motion.through([op, op], [0.0, 0.1], [0.0])
    with pytest.raises(InputError, match="one finite value"):
        Motion.through([op, op], [0.0, 0.1], [0.0, np.nan])


def test_a_heading_is_given_in_the_motion_or_for_the_cut_not_both(op):
    motion = Motion.through([op, op], [0.0, 0.1], [0.0, 0.0])
    with pytest.raises(InputError, match="heading once"):
        mill(op, STEEL_C45, RPM, 0.3e-3, periods=12, motion=motion, heading=0.5)


# -- a plan fed along the path is milled along it -----------------------------------------------------
def _rectangle():
    """300 x 200 mm, counter-clockwise from (1500, -100) mm: along +X, +Y, -X, -Y."""
    xy = np.array([[1.5, -0.1], [1.8, -0.1], [1.8, 0.1], [1.5, 0.1], [1.5, -0.1]])
    return ToolPath(xy, np.full(5, -2e-3), np.full(5, 0.05), np.full(5, np.nan), np.array([False] + [True] * 4),
                    np.arange(1, 6))


@pytest.fixture(scope="module")
def milled(irb):
    """The fixed-angle schedule of the rectangle's exact plan in steel, fed along base X and along
    the path, milled at location 1 (on the +X side) and 4 (on the +Y side), 14 tooth periods each
    (a little over the 12 a verdict takes: the headings and the turned force show from the start)."""
    out = {}
    for feed in ("x", "path"):
        settings = PlanSettings(theta=tuple(np.radians([-40.0, 0.0, 40.0])), spacing=100e-3, eval_spacing=40e-3,
                                feed=feed)
        plan = plan_path(irb, None, _rectangle(), speed_rpm=[RPM], cutting=STEEL_C45, settings=settings)
        out[feed] = mill_schedule(irb, plan, depth=0.3e-3, schedule="fixed", locations=[1, 4], periods=14)
    return out


def test_a_plan_fed_along_the_path_is_milled_and_its_cuts_carry_the_headings(milled):
    cuts = milled["path"]
    assert cuts.moved.all()
    np.testing.assert_allclose(cuts.heading, [0.0, np.pi / 2], atol=1e-12)
    assert milled["x"].heading is None


def test_a_cut_on_a_side_along_x_is_the_plan_fed_along_x_bit_for_bit(milled):
    assert milled["path"].kind[0] == milled["x"].kind[0]
    assert milled["path"].amplitude[0] == milled["x"].amplitude[0]


def test_a_cut_on_a_side_along_y_is_turned(milled):
    assert milled["path"].amplitude[1] != milled["x"].amplitude[1]
