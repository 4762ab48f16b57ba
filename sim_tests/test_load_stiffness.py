"""Load-dependent joint stiffness: MJCF metadata honoured by Robot.at, variants and campaigns."""

import mujoco
import numpy as np
import pytest

from rmbench.errors import ModelError
from rmbench.impact import Campaign, open_campaign, parse_config, run_campaign
from rmbench.robot import Posture, Robot
from rmbench.robot.linear import linearize
from rmbench.robot.load_stiffness import LOAD_STIFFNESS, REFERENCE_DEFLECTION, set_load_stiffness
from rmbench.robot.spec import spec_to_xml
from rmbench.robot.variant import condensed, make_variant, with_tool_masses

POSTURE = Posture.from_mm_deg(1800, -200, 0)
NEAR = Posture.from_mm_deg(1300, 0, 0)  # short reach: small gravity torque on J2
FAR = Posture.from_mm_deg(1900, 0, 0)  # long reach: about twice the torque


def _with_metadata(robot, coeffs_text):
    """The robot with a raw ``rmbench_load_stiffness`` text (no checks on the way in)."""
    spec = robot.spec
    spec.add_text(name=LOAD_STIFFNESS, data=coeffs_text)
    return Robot(spec_to_xml(spec), name=robot.name, tool=robot.tool)


@pytest.fixture(scope="module")
def stiffening(tmp_path_factory, irb):
    """The IRB6660 stand-in saved as a variant whose J2 and J3 gearboxes stiffen under load."""
    path = tmp_path_factory.mktemp("load") / "stiffening.xml"
    path.write_text(make_variant(irb, load_stiffness={"j2_flex": 0.2, "j3_flex": 0.1}))
    return path


def test_robot_without_the_metadata_is_posed_as_itself(irb):
    op = irb.at(POSTURE)
    assert irb.load_stiffness == {} and op.robot is irb
    # bit for bit the operating point as defined before load-dependent stiffness existed
    before = linearize(irb.model, irb.settle(op.q_cmd)).modes()
    np.testing.assert_array_equal(op.linear.modes().poles, before.poles)
    np.testing.assert_array_equal(op.linear.modes().phi_r, before.phi_r)


def test_zero_coefficients_give_bit_for_bit_the_nominal_modes(irb):
    # k0 (1 + 0) = k0 is written back with the same digits: the per-posture copy is the same model
    zero = _with_metadata(irb, "j2_flex:0 j3_flex:0")
    op, op0 = zero.at(POSTURE), irb.at(POSTURE)
    assert op.robot is not zero
    np.testing.assert_array_equal(op.linear.modes().poles, op0.linear.modes().poles)


def test_posture_stiffness_is_the_secant_of_the_nominal_gravity_deflection(stiffening):
    robot = Robot.load(stiffening)
    op = robot.at(POSTURE)
    nominal = robot.settle(op.q_cmd)  # the deflected equilibrium with the nominal stiffness k0
    for joint, alpha in (("j2_flex", 0.2), ("j3_flex", 0.1)):
        j = robot.model.joint(joint)
        k0 = j.stiffness[0]
        delta = nominal.qpos[j.qposadr[0]] - robot.spec.joint(joint).springref
        expected = k0 * (1 + alpha * abs(delta) / REFERENCE_DEFLECTION)
        assert expected > 1.1 * k0  # the gravity deflection is well above 1 mrad: a real change
        # the MJCF writer keeps 6 significant digits: half a unit in the 6th is at most 5e-6
        assert op.robot.model.joint(joint).stiffness[0] == pytest.approx(expected, rel=5e-6)


def test_per_posture_robot_carries_its_stiffness_in_its_mjcf(stiffening):
    robot = Robot.load(stiffening)
    op = robot.at(POSTURE)
    assert (op.robot.name, op.robot.tool, op.robot.spindle_rpm) == (robot.name, robot.tool, robot.spindle_rpm)
    assert op.robot.load_stiffness == {}  # stiffened once, for this posture
    # time-domain simulations rebuild the model from the MJCF text: it must hold the same stiffness
    rebuilt = mujoco.MjModel.from_xml_string(op.robot.xml)
    np.testing.assert_array_equal(rebuilt.jnt_stiffness, op.robot.model.jnt_stiffness)
    assert not np.array_equal(rebuilt.jnt_stiffness, robot.model.jnt_stiffness)


def test_heavier_gravity_load_stiffens_the_first_mode_more(tmp_path, irb):
    path = tmp_path / "j2.xml"
    path.write_text(make_variant(irb, load_stiffness={"j2_flex": 0.5}))
    robot = Robot.load(path)
    j2 = robot.model.joint("j2_flex").qposadr[0]
    deflection = {p: abs(robot.settle(robot.ik(p).q).qpos[j2]) for p in (NEAR, FAR)}
    assert deflection[FAR] > 1.5 * deflection[NEAR]  # the premise: more reach, more J2 torque
    ratio = {p: robot.at(p).linear.modes().f_n[0] / irb.at(p).linear.modes().f_n[0] for p in (NEAR, FAR)}
    # the first mode is J2's pitch: a stiffer J2 raises it, and more so where J2 carries more load
    assert 1.0 < ratio[NEAR] < ratio[FAR]


def _derive(how, path, tmp):
    """A robot derived from the saved variant ``path`` in one of the ways rmbench derives robots."""
    robot = Robot.load(path)
    if how == "with-tool-masses":
        return with_tool_masses(robot, [(0.0, 2e-4), (0.02, 2e-4)])
    if how == "condensed":
        return condensed(robot, ("spindle_", "tool_"))
    if how == "variant-edit":
        return Robot.load(_write(tmp / "edited.xml", make_variant(robot, ["j1_flex.damping*=2"])))
    if how == "variant-mass":
        return Robot.load(_write(tmp / "massed.xml", make_variant(robot, masses=[("tool_tip", 0.1, (0, 0, 0))])))
    campaign = Campaign.build(parse_config(f'[robot]\nname = "{path}"'))
    return campaign.tested_robots["high"] if how == "campaign-tested" else campaign.sim_robots["low"]


@pytest.mark.parametrize("how", ["with-tool-masses", "condensed", "variant-edit", "variant-mass",
                                 "campaign-tested", "campaign-sim-low"])
def test_derived_robots_keep_the_coefficients(stiffening, tmp_path, how):
    derived = _derive(how, stiffening, tmp_path)
    assert derived.load_stiffness == {"j2_flex": 0.2, "j3_flex": 0.1}
    op = derived.at(derived.ik(POSTURE).q)
    assert op.robot.model.joint("j2_flex").stiffness[0] > 1.1 * derived.model.joint("j2_flex").stiffness[0]


def test_condensing_drops_the_coefficients_of_welded_joints(irb):
    robot = _with_metadata(irb, "j2_flex:0.2 tool_contact_x:1")
    assert condensed(robot, ("tool_",)).load_stiffness == {"j2_flex": 0.2}


def test_variant_coefficients_add_to_and_replace_the_robots_own(tmp_path, stiffening):
    path = tmp_path / "again.xml"
    path.write_text(make_variant(Robot.load(stiffening), load_stiffness={"j3_flex": 0.0, "j5_flex": 0.3}))
    assert Robot.load(path).load_stiffness == {"j2_flex": 0.2, "j5_flex": 0.3}  # α = 0: constant again


@pytest.mark.parametrize("text, message", [
    ("j9_flex:0.2", "no joint 'j9_flex'"),
    ("j2_flex:-0.2", "joint 'j2_flex' must be finite and >= 0"),
    ("j2_flex:nan", "joint 'j2_flex' must be finite and >= 0"),
    ("j2:0.2", "joint 'j2' is driven by an actuator"),
    ("j2_flex", "entry 'j2_flex' must be JOINT:ALPHA"),
    ("j2_flex:0.1 j2_flex:0.2", "joint 'j2_flex' is named twice"),
], ids=["unknown-joint", "negative", "not-finite", "actuated-joint", "malformed", "twice"])
def test_bad_coefficients_are_model_errors_naming_the_joint(irb, text, message):
    with pytest.raises(ModelError, match=message):
        _with_metadata(irb, text)


def test_variant_with_a_coefficient_of_an_unknown_joint_is_rejected(irb):
    with pytest.raises(ModelError, match="no joint 'nosuch'"):
        make_variant(irb, load_stiffness={"nosuch": 0.2})


def test_setting_no_coefficients_removes_the_metadata(irb):
    spec = _with_metadata(irb, "j2_flex:0.2").spec
    set_load_stiffness(spec, {})
    assert LOAD_STIFFNESS not in {t.name for t in spec.texts}


TIME_LOW = """
seed = 5
method = "{method}"
noise_scale = 0.0
[robot]
name = "{robot}"
[grid]
kind = "list"
postures = [[1900, 0, 0]]
[hits]
points = ["1X"]
averages = 1
[bands.low]
f_min = 4.0
f_max = 40.0
sensor = "laser"
s_1a_mm = 33.4
sample_rate = 1024.0
line_spacing = 0.125
[bands.low.hammer]
pulse_ms = 8.0
peak_n = 300.0
force_scatter = 0.0
location_scatter_mm = 0.0
direction_scatter_deg = 0.0
"""


def test_time_domain_campaign_measures_the_load_stiffened_peak(tmp_path, irb):
    path = tmp_path / "j2.xml"
    path.write_text(make_variant(irb, load_stiffness={"j2_flex": 0.5}))
    runs = {}
    for method in ("time", "linear"):
        out = tmp_path / f"{method}.nc"
        run_campaign(parse_config(TIME_LOW.format(method=method, robot=path)), out, workers=0, progress=False)
        runs[method] = open_campaign(out)
    freq = runs["time"].freq.values
    h_time = np.abs(runs["time"].H.values[0, :, 0, 0])
    h_linear = np.abs(runs["linear"].H.values[0, :, 0, 0])  # noise-free: the exact FRF as tested
    f1 = float(runs["time"].modal_exact.values[0, 0, 0])
    f1_nominal = irb.at(FAR).linear.modes().f_n[0]
    assert f1 > f1_nominal + 0.5  # the stiffened J2 moved the first mode by several lines
    # the simulated robot was stiffened alike: its peak on the line nearest the exact mode
    assert abs(freq[np.argmax(h_time)] - f1) <= 0.125 / 2
    assert freq[np.argmax(h_time)] == freq[np.argmax(h_linear)]
    # noise-free, scatter-free hit: only the RK4 step (ω dt ≈ 0.05 at the peak) and the
    # windowing separate the two peak magnitudes
    assert h_time.max() == pytest.approx(h_linear.max(), rel=0.01)


def _write(path, text):
    path.write_text(text)
    return path
