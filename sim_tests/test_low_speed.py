"""Low-speed robotic milling (issue 82): steel and titanium cuts at 300-3,000 rev/min, and the cut's
frame turned to the path's feed direction.

The milling model works with x along the feed and y normal to it; the tool tip's modes come in the
robot's base axes. A feed heading ψ turns them (``R G Rᵀ``); heading None keeps the feed along
base X, the numbers of every earlier plan.
"""

import math

import numpy as np
import pytest

from rmbench.errors import InputError
from rmbench.io import ToolPath
from rmbench.path import TipModes, exact_modes
from rmbench.robot import Robot
from rmbench.stability import SPEED_RANGES, STEEL_C45, TI6AL4V, feed_rotation, speed_grid, to_cut_frame


def _u(angle):
    """Unit vector at ``angle`` (rad) from base X toward base Y."""
    return np.array([math.cos(angle), math.sin(angle)])


def _mode(f_n, zeta, mass, angle, skew=0.0):
    """Pole and residue of one mode whose direction lies at ``angle`` (rad) in the plane, built from
    the angle (not by turning a matrix): H = u uᵀ / (m (ω_n² − ω² + 2iζω_nω)) for a real mode, its
    residue u uᵀ / (2i m ω_d). ``skew`` adds a complex component normal to u on the left vector: a
    non-proportionally damped mode whose residue is neither real nor symmetric."""
    w = 2 * math.pi * f_n
    wd = w * math.sqrt(1 - zeta ** 2)
    phi_r = _u(angle) / (2j * mass * wd)
    phi_l = _u(angle) + skew * _u(angle + math.pi / 2)
    return complex(-zeta * w, wd), phi_r[:, None] * phi_l[None, :]


def _tip(modes_per_location):
    """TipModes with one angle per location, the modes by hand (one band)."""
    poles = np.array([[p for p, _ in loc] for loc in modes_per_location])
    res = np.array([[r for _, r in loc] for loc in modes_per_location])
    n = len(poles)
    return TipModes((n, 1), {"low": poles}, {"low": res}, np.arange(n), np.zeros((n, 1), bool))


# two low-band modes, coupled, at angles of their own; skewed so the residues are not symmetric
_MODES = ((12.0, 0.04, 400.0, math.radians(20), 0.1 + 0.05j), (27.0, 0.03, 250.0, math.radians(110), -0.08j))
_SPEEDS = np.array([300.0, 450.0, 700.0, 1200.0, 2500.0])


def test_turning_the_feed_is_the_same_cut_in_a_world_turned_by_the_heading():
    headings = np.radians([0.0, 35.0, -120.0, 180.0])
    base = _tip([[_mode(*m) for m in _MODES]] * len(headings))
    # the world turned by ψ: every mode's direction ψ less, the feed along the new X
    turned = _tip([[_mode(f, z, ms, a - psi, sk) for f, z, ms, a, sk in _MODES] for psi in headings])
    got = base.depths_at(STEEL_C45, _SPEEDS, heading=headings)
    want = turned.depths_at(STEEL_C45, _SPEEDS)
    # the same residues up to the rounding of cos and sin (1e-16): the depths agree to rounding,
    # far from a lobe's crossing integer where an ulp could move the crossing
    for g, w in zip(got, want):
        assert np.all(np.isfinite(w.a_lim))
        np.testing.assert_allclose(g.a_lim, w.a_lim, rtol=1e-9)


def test_the_heading_changes_the_depth_where_the_modes_are_not_round():
    # the check above would pass if the heading were ignored at ψ = 0 and 180° only: at 35° it is not
    a = _tip([[_mode(*m) for m in _MODES]] * 2).depths(STEEL_C45, 450.0, heading=np.radians([0.0, 35.0])).a_lim
    assert abs(a[1, 0] / a[0, 0] - 1) > 0.05


@pytest.fixture(scope="module")
def quick_check():
    """The issue's quick check: the nominal IRB6660 with the end mill at (1800, 200) mm, θ = −60, 0,
    30°, every mode of both bands."""
    robot = Robot.load("irb6660", tool="endmill")
    return exact_modes(robot, np.array([[1.8, 0.2]]), np.radians([-60.0, 0.0, 30.0]))


def test_heading_zero_reproduces_the_depths_along_base_x_exactly(quick_check):
    for speed in (400.0, 15000.0):
        plain = quick_check.depths(STEEL_C45, speed)
        assert np.array_equal(quick_check.depths(STEEL_C45, speed, heading=[0.0]).a_lim, plain.a_lim)
        assert np.array_equal(quick_check.depths(STEEL_C45, speed, down=[True]).a_lim, plain.a_lim)


def test_down_per_location_is_the_cut_with_that_choice():
    from dataclasses import replace

    tip = _tip([[_mode(*m) for m in _MODES]] * 2)
    mixed = tip.depths(STEEL_C45, 450.0, down=[True, False]).a_lim
    up = tip.depths(replace(STEEL_C45, down=False), 450.0).a_lim
    down = tip.depths(STEEL_C45, 450.0).a_lim
    assert mixed[0, 0] == down[0, 0] and mixed[1, 0] == up[1, 0] and up[1, 0] != down[1, 0]


def test_a_mode_along_the_feed_hurts_a_climb_cut_less_than_along_the_normal():
    # one mode, 150 Hz, ζ 3 %: at 300-1,000 rev/min (tooth frequency 30-100 Hz) the lobes are dense
    # and the smallest depth over the speeds is the mode's own floor. A mode along u enters the
    # zero-order method through uᵀ H₀ u: for this cut (K_t 2,000, K_n 700 N/mm², 6 teeth, half
    # immersion, climb) −430 N/mm² along the feed and +1,480 along the normal. A real depth needs
    # uᵀH₀u · Re G < 0 and the floor goes as 1 / |uᵀH₀u · Re G| at Re G's extreme of that sign:
    # −1/(2kζ(1+ζ)) above the mode (the normal's), +1/(2kζ(1−ζ)) below it (the feed's). Along the
    # feed the depth is 1,480/430 · (1 − ζ)/(1 + ζ) = 3.24 times the normal's.
    speeds = np.linspace(300.0, 1000.0, 1401)     # 0.5 rev/min: the lobes' bottoms to 0.1 %
    tip = _tip([[_mode(150.0, 0.03, 20.0, 0.0)], [_mode(150.0, 0.03, 20.0, math.pi / 2)]])
    floor = np.min([g.a_lim[:, 0] for g in tip.depths_at(STEEL_C45, speeds)], axis=0)
    h0 = STEEL_C45.average_directional()
    assert h0[0, 0] == pytest.approx(-429.93e6, rel=1e-5) and h0[1, 1] == pytest.approx(1479.93e6, rel=1e-5)
    ratio = floor[0] / floor[1]
    # (1 − ζ)/(1 + ζ) holds to first order in ζ (the extremes of Re G shift by O(ζ²)) and the grid
    # samples each lobe's bottom (0.1 %): 0.5 %
    assert ratio == pytest.approx(h0[1, 1] / -h0[0, 0] * 0.97 / 1.03, rel=0.005)


def test_a_climb_cut_is_worst_for_a_mode_near_100_degrees_from_the_feed():
    # for a mode with uᵀH₀u > 0 the depth at any speed is exactly 1/(uᵀH₀u) times the same mode's
    # factor; uᵀH₀u = 1,537 N/mm² at 100°, 1,480 at 90°, 1,471 at 110°: 100° is the worst by 4 %
    angles = np.radians(np.arange(0.0, 180.0, 10.0))
    tip = _tip([[_mode(150.0, 0.03, 20.0, a)] for a in angles])
    depth = tip.depths(STEEL_C45, 450.0).a_lim[:, 0]
    assert np.degrees(angles[np.argmin(depth)]) == pytest.approx(100.0)


def test_quick_check_of_the_low_band_reproduces_the_investigation(quick_check):
    # issue 82's investigation (0.0525 / 0.0939 / 0.1213 mm at θ = −60 / 0 / 30°, 300-3,000 rev/min
    # every 10). The lobes' bottoms lie at 300-410 rev/min and the depth rises with speed above
    # (0.07-0.17 mm at 1,000 rev/min, 0.6-3 mm at 3,000): 10 rev/min steps up to 600 find the
    # minimum on the investigation's own lines, 100 rev/min steps above only show that nothing lower
    # is there. 1 %: the figures' rounding (0.2 % at 0.0525 mm) and a lobe bottom between lines
    # (0.3 % lower at 5 rev/min).
    speeds = np.concatenate([np.arange(300.0, 601.0, 10.0), np.arange(700.0, 3001.0, 100.0)])
    assert (speeds.min(), speeds.max()) == SPEED_RANGES["low"]
    a = np.array([g.a_lim[0] for g in quick_check.depths_at(STEEL_C45, speeds)])     # (speed, θ)
    np.testing.assert_allclose(1e3 * a.min(axis=0), [0.0525, 0.0939, 0.1213], rtol=0.01)
    assert np.all(speeds[np.argmin(a, axis=0)] <= 410.0)


def test_the_low_speed_grid_spans_300_to_3000_rev_per_min():
    g = speed_grid("low", 10)
    assert g[0] == 300.0 and g[-1] == 3000.0


def test_the_titanium_cut_is_a_four_tooth_half_immersion_climb_cut_in_si_units():
    assert (TI6AL4V.teeth, TI6AL4V.immersion, TI6AL4V.down) == (4, 0.5, True)
    assert 1e9 < TI6AL4V.k_t < 3e9 and 0 < TI6AL4V.k_n < TI6AL4V.k_t    # N/m², not N/mm²


def test_feed_rotation_rows_are_the_feed_and_its_normal():
    r = feed_rotation(math.radians(30.0))
    np.testing.assert_allclose(r, [[math.cos(math.pi / 6), 0.5], [-0.5, math.cos(math.pi / 6)]], atol=1e-15)


def test_to_cut_frame_needs_one_heading_per_leading_index():
    with pytest.raises(InputError, match="one feed heading per leading index"):
        to_cut_frame(np.zeros((3, 2, 2, 2)), np.zeros(2))


def test_depths_need_one_heading_per_location():
    with pytest.raises(InputError, match="heading needs one value per location"):
        _tip([[_mode(*_MODES[0])]] * 2).depths(STEEL_C45, 450.0, heading=[0.0])


def _path(xy):
    xy = np.asarray(xy, float)
    n = len(xy)
    cutting = np.ones(n, bool)
    cutting[0] = False
    return ToolPath(xy, np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan), cutting, np.arange(1, n + 1))


def test_a_straight_line_heads_where_it_goes():
    h = _path([[0.0, 0.0], [0.1, 0.1], [0.3, 0.3]]).heading()
    np.testing.assert_allclose(h, math.pi / 4)


def test_a_rectangle_contour_heads_0_90_180_270_degrees_side_by_side():
    # each point takes the move into it, the first the move leaving it; resampled, every point of
    # a side heads along it and the corner reached by a side keeps that side's heading
    tp = _path([[0.0, 0.0], [0.4, 0.0], [0.4, 0.2], [0.0, 0.2], [0.0, 0.0]]).resampled(0.1)
    deg = np.degrees(tp.heading()) % 360.0
    assert len(tp) == 13
    np.testing.assert_allclose(deg, [0] * 5 + [90] * 2 + [180] * 4 + [270] * 2, atol=1e-12)


def test_a_move_of_no_length_keeps_the_heading_before_it():
    h = _path([[0.0, 0.0], [0.0, 0.0], [0.0, 0.1], [0.0, 0.1], [-0.1, 0.1]]).heading()
    np.testing.assert_allclose(np.degrees(h), [90, 90, 90, 90, 180])
