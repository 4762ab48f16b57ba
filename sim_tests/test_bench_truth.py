"""The blind benches' real robots (bench/truth): drawn reproducibly, and each model-form error is
physics the nominal model lacks, large enough to see in the tested band and beyond what calibrating
the ordinary parameters takes up."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from _bench_path import bench_on_path

with bench_on_path():
    from truth import FORM_KINDS, apply_form, draw_real_robot, median_form
    from truth.visibility import visibility

from rmbench.calibrate import CalibrationSettings, TestDesign, calibrate  # noqa: E402
from rmbench.impact import load_config  # noqa: E402
from rmbench.robot import Robot, seed_grid  # noqa: E402
from rmbench.robot.parameters import parse_groups  # noqa: E402

from _exact_modes import exact_modes  # noqa: E402

# three postures across the seed grid: near, middle and far reach
POSTURES = (0, 40, 90)
LOW_BAND = (4.0, 40.0)       # Hz, the low band of the test design


@pytest.fixture(scope="module")
def nominal():
    return Robot.load("irb6660", tool="dummy")


def _low_modes(robot, posture) -> np.ndarray:
    f = robot.at(posture).linear.modes().f_n
    return np.sort(f[(f > LOW_BAND[0]) & (f < LOW_BAND[1])])


def _with(nominal, error) -> Robot:
    root = ET.fromstring(nominal.xml)
    apply_form(root, error)
    return Robot(ET.tostring(root, encoding="unicode"), name="real", tool="dummy")


@pytest.mark.parametrize("kind", FORM_KINDS)
def test_each_form_error_at_its_median_size_moves_the_low_modes_beyond_the_measurement_scatter(nominal, kind):
    # a 16-posture campaign's fitted frequencies scatter by about 0.1-0.3 % (the spread-only bench
    # reaches 0.22 % held-out after calibration): a 1 % shift of a mode, or a mode more in the
    # band, is beyond it at some posture
    real = _with(nominal, median_form(kind))
    shifts, added = [], False
    for i in POSTURES:
        p = seed_grid()[i]
        f0, f = _low_modes(nominal, p), _low_modes(real, p)
        added |= len(f) != len(f0)
        n = min(len(f), len(f0))
        shifts.append(np.max(np.abs(f[:n] / f0[:n] - 1)))
    assert added or max(shifts) > 0.01


def test_a_hardening_gear_stiffens_the_arm_by_a_posture_dependent_amount(nominal):
    # the second spring engages only beyond the backlash, so the share of the gravity deflection
    # beyond it, and the shift, follow the posture: no constant stiffness factor reproduces it
    real = _with(nominal, median_form("gear_nonlinear"))
    first = []
    for i in POSTURES:
        p = seed_grid()[i]
        first.append(_low_modes(real, p)[0] / _low_modes(nominal, p)[0] - 1)
    assert max(first) - min(first) > 0.005


def test_a_skewed_foundation_replaces_a_tilting_one_drawn_before(nominal):
    robot = draw_real_robot(nominal.xml, np.random.default_rng(3), base=True, p_form=0.0)
    root = ET.fromstring(robot.xml)
    apply_form(root, median_form("foundation_skew"))
    names = {b.get("name") for b in root.iter("body")}
    assert "foundation_skew" in names and "foundation" not in names


def test_a_real_robot_is_the_same_from_the_same_seed_and_differs_from_another(nominal):
    a = draw_real_robot(nominal.xml, np.random.default_rng([7, 1]), base=True)
    b = draw_real_robot(nominal.xml, np.random.default_rng([7, 1]), base=True)
    c = draw_real_robot(nominal.xml, np.random.default_rng([7, 2]), base=True)
    assert a.xml == b.xml and a.to_dict() == b.to_dict()
    assert a.xml != c.xml


def test_the_foundation_of_a_real_robot_is_not_the_models_plate(nominal):
    # the model's foundation is a 1000 kg plate at 5 % damping: the truth's slab has its own
    masses = [draw_real_robot(nominal.xml, np.random.default_rng([11, i]), base=True, p_form=0.0).foundation["mass"]
              for i in range(8)]
    assert min(masses) >= 500 and max(masses) <= 3000
    assert not np.allclose(masses, 1000.0, rtol=0.05)


def test_without_form_errors_a_real_robot_differs_only_in_its_ordinary_parameters(nominal):
    robot = draw_real_robot(nominal.xml, np.random.default_rng(5), base=False, p_form=0.0)
    assert robot.form == () and robot.ordinary["base.tilt_compliance"] == 0.0
    assert {b.get("name") for b in ET.fromstring(robot.xml).iter("body")} == \
        {b.get("name") for b in ET.fromstring(nominal.xml).iter("body")}


def test_a_change_that_is_no_change_is_not_visible_and_a_bending_forearm_is(nominal):
    # the visibility rule's two sides on two postures: the difference of two independent noise
    # sums stays within z·√(2n) (p = 1e-3), and a forearm bending at its median compliance moves
    # the low modes by 0.5-1 % (above), far beyond the campaign's noise
    postures = [seed_grid()[i] for i in (0, 90)]
    same = visibility(nominal.xml, nominal.xml, postures, 11)
    assert not same["visible"] and same["effect_chi2"] == 0.0
    real = _with(nominal, median_form("bending_link", "forearm"))
    bent = visibility(nominal.xml, real.xml, postures, 11)
    assert bent["visible"] and bent["effect_chi2"] > 10 * bent["threshold"]


# eight postures across the grid's reach, height and angle: six to calibrate on, two held out
CALIBRATION_POSTURES = (0, 25, 40, 55, 70, 90, 15, 100)
BENCH_SCALE = 3.0       # blind_frf.py draws the form errors at 3 times their stated ranges


@pytest.mark.slow
@pytest.mark.parametrize("kind", FORM_KINDS)
def test_calibrating_the_ordinary_parameters_does_not_remove_a_form_error(nominal, kind):
    # noise-free low-band modes (4-40 Hz: the arm's, where every form kind acts; the high band is
    # the tool on its holder) of a robot that differs from the model by one form error at the
    # bench's median size; every ordinary group calibrated on six postures. A robot that differs
    # only in the ordinary parameters is matched to the fit's tolerance (held-out p95 under 0.2 %,
    # test_calibrate); the spread-only bench's noisy floor is 0.22 %. A form error leaves more than
    # twice that at the held-out postures
    design = TestDesign.from_config(load_config("seed_full"))
    real = _with(nominal, median_form(kind, scale=BENCH_SCALE))
    data = exact_modes(real, design, [seed_grid()[i] for i in CALIBRATION_POSTURES], bands=("low",))
    settings = CalibrationSettings(groups=parse_groups("joints,damping,servo,masses,com,base,tool"), workers=1)
    cal = calibrate(nominal, data, held=[6, 7], settings=settings)
    after = np.abs([r["f_err"] for r in cal.modes_held["after"] if r["paired"]])
    unpaired = sum(not r["paired"] for r in cal.modes_held["after"])
    assert unpaired > 0 or np.percentile(after, 95) > 0.005


@pytest.mark.slow
@pytest.mark.parametrize("link", ("lower_arm", "forearm"))
def test_the_bending_group_takes_up_a_bending_link(nominal, link):
    # the same robot, postures and groups as above, with the bending group beside them: the
    # method's own split link (rmbench.robot.kinds, the distal half on two hinges, built apart from
    # the truth's) stands in for the truth's. The lower arm's error left 10 % held-out p95 without
    # it; with it, less than 1 %: what a form group is for (the fitted compliances come to 0.85-0.95
    # of the truth's; the rest the ordinary parameters take)
    design = TestDesign.from_config(load_config("seed_full"))
    real = _with(nominal, median_form("bending_link", link, scale=BENCH_SCALE))
    data = exact_modes(real, design, [seed_grid()[i] for i in CALIBRATION_POSTURES], bands=("low",))
    settings = CalibrationSettings(groups=parse_groups("joints,damping,servo,masses,com,base,tool,bending"), workers=1)
    cal = calibrate(nominal, data, held=[6, 7], settings=settings)
    after = np.abs([r["f_err"] for r in cal.modes_held["after"] if r["paired"]])
    assert all(r["paired"] for r in cal.modes_held["after"])
    assert np.percentile(after, 95) < 0.01
