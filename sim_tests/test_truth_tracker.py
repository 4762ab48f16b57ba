"""The tracker bench's real MH180s (bench/truth/tracker.py): read by their own physics, with form
errors, sources and noise the diagnosis is not told; each form error beyond what calibrating the pose
model takes up."""

from dataclasses import replace
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from _bench_path import bench_on_path

with bench_on_path():
    from truth import apply_form, median_form
    from truth.tracker import FORM_KINDS, Reader, TrackerRobot, _ar1, campaign, draw_tracker_robot, visibility

from rmbench.gap.tracker.data import TrackerData, default_covariance  # noqa: E402
from rmbench.gap.tracker.diagnosis import TrackerSettings, diagnose_tracker  # noqa: E402
from rmbench.robot import Robot  # noqa: E402

# three configurations across the MH180's ranges, rad
Q = np.array([[0.0, 0.2, -0.3, 0.0, 0.4, 0.0], [0.5, -0.1, 0.2, 0.8, -0.6, 1.0], [-0.6, 0.4, -0.5, -1.0, 0.9, -0.5]])
TRACKER_SIGMA = 15e-6       # m: the tracker's σ at 3-5 m (5 µm/m and 12.5 µm as 2σ bounds)


@pytest.fixture(scope="module")
def plain():
    nominal = Robot.load("mh180")
    base = draw_tracker_robot(nominal.xml, np.random.default_rng(1), p_form=0.0)
    return replace(base, source=None, form=(), noise={"scale": 1.0, "rho": 0.0})


def _read(robot, t=None):
    t = np.zeros(len(Q)) if t is None else t
    return Reader(robot).positions(Q, Q, t)


@pytest.mark.parametrize("form", [{"kind": "reflector_sag", "location": "tool", "size": {"per_g": 50e-6}},
                                  {"kind": "thermal_gradient", "location": "forearm", "size": {"per_hour": 2.5e-5}}],
                         ids=["reflector sag", "thermal gradient"])
def test_a_reading_form_error_moves_the_tcp_beyond_the_trackers_noise(plain, form):
    # a mount sagging 50 µm per g, or a forearm 1.2 m long growing 25 µm/m an hour read two hours
    # on: tens of µm, several times the tracker's σ
    t = np.full(len(Q), 7200.0)
    moved = np.linalg.norm(_read(replace(plain, form=(form,)), t) - _read(plain, t), axis=1)
    assert moved.max() > 2 * TRACKER_SIGMA


def test_a_joint_stiffer_under_positive_torque_reads_differently_on_one_side_only(plain):
    # the arm leaning back (j2 at -0.8 rad) loads j2 the other way than leaning forward (+0.4)
    src = {"kind": "directional_stiffness", "location": "j2", "joint": 1, "ratio": 2.0}
    q = np.array([[0.0, -0.8, -0.5, 0.0, 0.4, 0.0], [0.0, 0.4, -0.5, 0.0, 0.4, 0.0]])
    t = np.zeros(2)
    back, forward = np.linalg.norm(Reader(replace(plain, source=src)).positions(q, q, t)
                                   - Reader(plain).positions(q, q, t), axis=1)
    assert back < 1e-9 and forward > 10 * TRACKER_SIGMA


def test_backlash_lags_against_the_last_move():
    # moving up to a configuration and down to it read two places: the lag's sign follows the move
    nominal = Robot.load("mh180")
    base = draw_tracker_robot(nominal.xml, np.random.default_rng(1), p_form=0.0)
    robot = replace(base, form=(), noise={"scale": 1.0, "rho": 0.0},
                    source={"kind": "backlash", "location": "j3", "joint": 2, "angle": 150e-6})
    q = np.repeat(Q[:1], 2, axis=0)
    previous = q.copy()
    previous[0, 2] -= 0.1
    previous[1, 2] += 0.1
    up, down = Reader(robot).positions(q, previous, np.zeros(2))
    assert np.linalg.norm(up - down) > 10 * TRACKER_SIGMA


def test_correlated_noise_keeps_unit_variance_and_its_lag_one_correlation():
    e = _ar1(np.random.default_rng(3), (20000, 1), 0.6)[:, 0]
    assert np.var(e) == pytest.approx(1.0, rel=0.05)
    assert np.corrcoef(e[1:], e[:-1])[0, 1] == pytest.approx(0.6, abs=0.03)


def test_a_reflector_offset_of_its_smallest_draw_is_visible(plain):
    src = {"kind": "frame_error", "location": "tool", "offset": [1.5e-3, 0.0, 0.0]}
    q = np.tile(Q, (4, 1))
    seen = visibility(replace(plain, source=src), q, q, np.arange(len(q)) * 15.0, 5)
    assert seen["visible"] and seen["effect_chi2"] > 10 * seen["threshold"]


def test_no_source_is_not_visible(plain):
    # the rule's other side: two independent noise sums differ by less than its threshold
    robot = replace(plain, source={"kind": "thermal_drift", "location": "time", "per_hour": 0.0})
    q = np.tile(Q, (4, 1))
    seen = visibility(robot, q, q, np.arange(len(q)) * 15.0, 5)
    assert not seen["visible"] and seen["effect_chi2"] == 0.0


def test_the_noise_the_diagnosis_is_not_told_is_drawn_from_its_stated_ranges():
    nominal = Robot.load("mh180")
    noises = [draw_tracker_robot(nominal.xml, np.random.default_rng([9, i]), p_form=0.0).noise for i in range(24)]
    scales = [n["scale"] for n in noises]
    assert min(scales) >= 0.5 and max(scales) <= 2.0
    correlated = [n["rho"] for n in noises if n["rho"] > 0]
    assert 6 <= len(correlated) <= 18 and all(0.3 <= r <= 0.8 for r in correlated)


def test_a_real_tracker_robot_is_a_frozen_record_of_plain_values():
    assert TrackerRobot.__dataclass_params__.frozen


# each tracker form kind at the middle of its drawn range (truth.tracker.draw_tracker_robot)
READ_FORMS = {"reflector_sag": {"kind": "reflector_sag", "location": "tool", "size": {"per_g": 50e-6}},
              "thermal_gradient": {"kind": "thermal_gradient", "location": "forearm", "size": {"per_hour": 2.5e-5}}}


def _with_form(plain, kind):
    if kind in READ_FORMS:
        return replace(plain, form=(READ_FORMS[kind],))
    root = ET.fromstring(plain.xml)
    error = median_form(kind)
    apply_form(root, error)
    return replace(plain, xml=ET.tostring(root, encoding="unicode"), form=(error.to_dict(),))


def _diagnosed(robot, rng=None, n_config=250):
    """The calibrated diagnosis of ``robot``'s readings over the bench's campaign of ``n_config``
    configurations (noise-free, or with the robot's noise drawn from ``rng``), and the readings
    ``(q, y, order, t)``."""
    nominal = Robot.load("mh180")
    q, order, previous = campaign(np.random.default_rng(5), n_config=n_config)
    t = np.arange(len(q)) * 15.0
    y = Reader(robot).positions(q, previous, t, rng)
    cov = default_covariance(nominal, q, y)
    data = TrackerData(q, y, order, np.sqrt(np.diagonal(cov, axis1=1, axis2=2)), t, tuple(nominal.arm_joints),
                       covariance=cov)
    return diagnose_tracker(nominal, data, settings=TrackerSettings(calibrate=True)), (q, y, order, t)


@pytest.mark.slow
def test_a_form_error_beyond_the_trackers_noise_is_called_model_form(plain):
    # a reflector mount sagging 500 µm/g (ten times the bench's median) leaves the calibrated pose
    # model far off at the held-out configurations; no source of the library explains it (the
    # payload and gear harmonics it takes leave the gap). At the median size the same sag stays
    # inside the tracker's noise model (25-40 µm at 3-5 m with the calibration's uncertainty
    # carried): held-out χ² 45 on 750 residuals, and no test can call it. A third of the bench's
    # campaign (84 configurations read twice): the sag leaves χ² about 6 per held-out residual
    # whatever their number (4500 on 750 with 250, 2200 on 372 with 125, 1455 on 252 here,
    # against noise's n ± √(2n)), and the search takes the same payload and gear harmonics (j4 h1,
    # j5 h1 and h2, in the same order) and leaves the gap (0.6 of the CPU of 125)
    sag = {"kind": "reflector_sag", "location": "tool", "size": {"per_g": 500e-6}}
    dg, _ = _diagnosed(replace(plain, form=(sag,)), n_config=84)
    assert dg.verdict == "model form" and dg.form["flagged"]


@pytest.mark.slow
def test_the_spread_alone_passes_the_form_test(plain):
    dg, _ = _diagnosed(plain)
    assert not dg.form["flagged"] and dg.verdict == "no significant gap"


@pytest.mark.slow
def test_readings_twice_as_noisy_as_stated_are_not_a_wrong_form(plain):
    # the spread alone, read with twice the tracker's and the joints' rated scatter: under the
    # stated noise (the default covariance, somewhat above the rated level) the held-out χ² is
    # about twice its count, which the test flags; the repeats measure the noise at 1.5 times the
    # stated (750 degrees of freedom: ±3 %), and the form test uses that
    dg, _ = _diagnosed(replace(plain, noise={"scale": 2.0, "rho": 0.0}), np.random.default_rng(11))
    assert not dg.form["flagged"] and dg.verdict != "model form"
    assert dg.form["noise_measured"] > 1.25


@pytest.mark.slow
@pytest.mark.parametrize("kind", FORM_KINDS)
def test_calibrating_the_pose_model_does_not_remove_a_form_error(plain, kind):
    # noise-free readings of the bench's campaign (250 configurations read twice, 15 s apart, two
    # hours) on a robot with one form error at its median size, the ordinary pose parameters
    # calibrated: a robot with the spread alone is matched to 2.5 µm rms at the held-out
    # configurations; a form error leaves more than the tracker's σ there, a systematic error that
    # the held-out readings' χ² (excess about n against a spread of √(2n)) sees at once
    dg, (q, y, order, t) = _diagnosed(_with_form(plain, kind))
    held = np.isin(order, dg.held)
    e = y[held] - dg.fitted.position(q[held], t[held] / 3600.0)
    assert np.sqrt(np.mean(np.sum(e ** 2, axis=1))) > TRACKER_SIGMA
