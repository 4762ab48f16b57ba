"""Specification of the blind cases' truth: each hidden kind changes the compiled robot as it says."""

import sys

import numpy as np
import pytest

import rmbench.robot.variant as variant
from rmbench.errors import ModelError
from rmbench.gap.cases import truth
from rmbench.gap.cases.hidden import Hidden, inject, scaled
from rmbench.robot import Robot


@pytest.fixture(scope="module")
def robot():
    return Robot.load("irb6660", tool="dummy")


def _changed(robot, *hidden, scale=1.0) -> Robot:
    return Robot(inject(robot, hidden, scale)[0], name="hidden", tool="dummy")


def _k(model, joint):
    return float(model.joint(joint).stiffness[0])


@pytest.mark.parametrize("kind, field", [("joint_stiffness", "stiffness"), ("joint_damping", "damping")],
                         ids=["stiffness", "damping"])
def test_a_joint_effect_scales_that_joints_field_by_the_drawn_factor(robot, kind, field):
    changed = _changed(robot, Hidden(kind, "j3_flex", {"factor": 1.37}))
    before, after = getattr(robot.model.joint("j3_flex"), field)[0], getattr(changed.model.joint("j3_flex"), field)[0]
    assert after == pytest.approx(1.37 * before, rel=1e-12)


def test_a_joint_effect_leaves_the_other_joints_alone(robot):
    changed = _changed(robot, Hidden("joint_stiffness", "j3_flex", {"factor": 1.37}))
    others = [j for j in range(robot.model.njnt) if robot.model.joint(j).name != "j3_flex"]
    np.testing.assert_array_equal(changed.model.jnt_stiffness[others], robot.model.jnt_stiffness[others])


def test_load_dependent_stiffness_gives_the_joint_its_drawn_alpha(robot):
    changed = _changed(robot, Hidden("load_dependent_stiffness", "j2_flex", {"alpha": 0.35}))
    assert changed.load_stiffness == {"j2_flex": 0.35}


def test_a_servo_effect_scales_kp_in_gain_and_bias_and_keeps_kv(robot):
    changed = _changed(robot, Hidden("servo_stiffness", "a4", {"factor": 0.2}))
    a0, a1 = robot.model.actuator("a4"), changed.model.actuator("a4")
    assert a1.gainprm[0] == pytest.approx(0.2 * a0.gainprm[0], rel=1e-12)
    assert a1.biasprm[1] == -a1.gainprm[0] and a1.biasprm[2] == a0.biasprm[2]


@pytest.mark.parametrize("hidden, factors", [
    (Hidden("tool_contact_stiffness", "tool_contact", {"translation": 2.5, "rotation": 0.4}),
     {"tool_contact_x": 2.5, "tool_contact_y": 2.5, "tool_contact_rx": 0.4, "tool_contact_ry": 0.4}),
    (Hidden("spindle_stiffness", "spindle", {"radial": 1.4, "tilt": 0.7}),
     {"spindle_x": 1.4, "spindle_y": 1.4, "spindle_rx": 0.7, "spindle_ry": 0.7})], ids=["tool-contact", "spindle"])
def test_a_pair_effect_scales_the_translations_and_the_turns_by_their_factors(robot, hidden, factors):
    changed = _changed(robot, hidden)
    assert {j: _k(changed.model, j) / _k(robot.model, j) for j in factors} == pytest.approx(factors, rel=1e-12)


def test_added_mass_adds_the_drawn_fraction_of_the_body_at_its_centre(robot):
    changed = _changed(robot, Hidden("added_mass", "flange", {"fraction": -0.2}))
    b0, b1 = robot.model.body("flange"), changed.model.body("flange")
    assert b1.mass[0] == pytest.approx(0.8 * b0.mass[0], rel=1e-12)
    np.testing.assert_array_equal(b1.ipos, b0.ipos)
    np.testing.assert_array_equal(b1.inertia, b0.inertia)


@pytest.fixture(scope="module")
def based(robot):
    return _changed(robot, Hidden("base_compliance", "base", {"lateral": 40.0, "tilt": 25.0}))


def test_base_compliance_puts_the_drawn_compliances_under_the_arm(based):
    k = {j: _k(based.model, f"base_{j}") for j in ("x", "y", "z", "rx", "ry", "rz")}
    lateral, tilt = 1 / 40e-9, 1 / 25e-9      # 40 nm/N and 25 nrad/(N·m)
    assert k == pytest.approx({"x": lateral, "y": lateral, "z": 5 * lateral, "rx": tilt, "ry": tilt, "rz": tilt},
                              rel=1e-12)


def test_the_base_carries_the_whole_arm_on_a_1000_kg_plate(robot, based):
    plate = based.model.body("base_mount").id
    assert based.model.body_parentid[based.model.body("motor1").id] == plate
    assert based.model.body_subtreemass[plate] == pytest.approx(robot.model.body_subtreemass[1] + 1000.0)


def test_the_bases_dampers_are_5_percent_of_critical_against_arm_and_plate(robot, based):
    m = robot.model.body_subtreemass[1] + 1000.0
    for j in ("base_x", "base_z", "base_rx"):
        zeta = based.model.joint(j).damping[0] / (2 * np.sqrt(_k(based.model, j) * m))
        assert zeta == pytest.approx(0.05, rel=1e-12)


def test_the_hose_package_has_the_drawn_mass_and_frequency_on_a_still_link(robot):
    changed = _changed(robot, Hidden("hose_resonator", "upper_arm", {"mass": 9.0, "f_hz": 17.0, "zeta": 0.05}))
    model = changed.model
    hose = model.body("hose_package")
    assert model.body_parentid[hose.id] == model.body("upper_arm").id and hose.mass[0] == pytest.approx(9.0)
    slide = model.joint("hose_slide")
    assert np.sqrt(slide.stiffness[0] / hose.mass[0]) / (2 * np.pi) == pytest.approx(17.0, rel=1e-12)
    assert slide.damping[0] / (2 * np.sqrt(slide.stiffness[0] * hose.mass[0])) == pytest.approx(0.05, rel=1e-12)


def test_a_tendon_couples_the_two_joints_difference_with_the_drawn_fraction_of_the_softer(robot):
    changed = _changed(robot, Hidden("tendon_coupling", "j2_flex+j3_flex", {"fraction": 0.6}))
    model = changed.model
    t = model.tendon("coupling").id
    k = 0.6 * min(_k(robot.model, "j2_flex"), _k(robot.model, "j3_flex"))
    assert float(np.ravel(model.tendon_stiffness[t])[0]) == pytest.approx(k, rel=1e-12)
    adr = int(model.tendon_adr[t])
    wraps = {model.joint(int(model.wrap_objid[adr + i])).name: model.wrap_prm[adr + i] for i in range(2)}
    assert wraps == {"j2_flex": 1.0, "j3_flex": -1.0}
    assert model.tendon_lengthspring[t].tolist() == [0.0, 0.0]     # relaxed when neither joint deflects


def test_an_offset_mass_sits_at_the_drawn_offset_on_its_body(robot):
    changed = _changed(robot, Hidden("offset_mass", "wrist", {"mass": 12.0, "offset_m": [0.1, -0.2, 0.15]}))
    model = changed.model
    point = model.body("point_mass1")
    assert model.body_parentid[point.id] == model.body("wrist").id and point.mass[0] == pytest.approx(12.0)
    np.testing.assert_allclose(point.pos + point.ipos, [0.1, -0.2, 0.15], rtol=0, atol=1e-15)


def test_a_bending_link_hinges_after_its_own_joints_at_the_drawn_compliance(robot):
    changed = _changed(robot, Hidden("link_bending", "lower_arm", {"compliance_ratio": 0.4}))
    model = changed.model
    bend = model.joint("lower_arm_bending")
    assert model.jnt_bodyid[bend.id] == model.body("lower_arm").id
    assert bend.id == model.joint("j2_flex").id + 1                    # after the link's own joint
    np.testing.assert_array_equal(bend.pos, [0.0, 0.0, 0.35])
    np.testing.assert_array_equal(bend.axis, [1.0, 0.0, 0.0])
    assert [bend.stiffness[0], bend.damping[0]] == pytest.approx(
        [_k(robot.model, "j2_flex") / 0.4, robot.model.joint("j2_flex").damping[0] / 0.4], rel=1e-12)


@pytest.mark.parametrize("hidden", [Hidden("sensor_misplacement", "high:1X", {"along_mm": -5.0}),
                                    Hidden("sensor_misalignment", "low:1aY", {"angle_deg": 6.0}),
                                    Hidden("non_reciprocity", "spindle_spin", {"rpm": 12000.0})],
                         ids=["misplacement", "misalignment", "non-reciprocity"])
def test_a_test_effect_leaves_the_robots_text_as_it_is(robot, hidden):
    assert inject(robot, (hidden,))[0] == robot.xml


_ONE_OF_EACH = [Hidden("joint_stiffness", "j2_flex", {"factor": 1.3}),
                Hidden("joint_damping", "j3_flex", {"factor": 2.0}),
                Hidden("load_dependent_stiffness", "j5_flex", {"alpha": 0.3}),
                Hidden("servo_stiffness", "a2", {"factor": 0.3}),
                Hidden("tool_contact_stiffness", "tool_contact", {"translation": 2.0, "rotation": 0.5}),
                Hidden("spindle_stiffness", "spindle", {"radial": 1.3, "tilt": 0.8}),
                Hidden("base_compliance", "base", {"lateral": 40.0, "tilt": 30.0}),
                Hidden("added_mass", "wrist", {"fraction": 0.2}),
                Hidden("hose_resonator", "forearm", {"mass": 8.0, "f_hz": 20.0, "zeta": 0.05}),
                Hidden("tendon_coupling", "j4_flex+j5_flex", {"fraction": 0.5}),
                Hidden("offset_mass", "flange", {"mass": 10.0, "offset_m": [0.0, 0.3, 0.0]}),
                Hidden("link_bending", "forearm", {"compliance_ratio": 0.5})]


@pytest.mark.parametrize("hidden", _ONE_OF_EACH, ids=[h.kind for h in _ONE_OF_EACH])
def test_injecting_with_a_scale_is_injecting_the_scaled_effect_a_case_reports(robot, hidden):
    assert inject(robot, (hidden,), 1.6)[0] == inject(robot, (scaled(hidden, 1.6),))[0]


def test_an_edit_of_a_missing_attribute_is_an_error_not_a_zero():
    root = truth.parse('<mujoco><worldbody><body name="b"><joint name="j"/></body></worldbody></mujoco>')
    with pytest.raises(ModelError, match="has no explicit stiffness"):
        truth.scale_joint(root, "j", "stiffness", 2.0)


def test_the_truth_is_built_without_the_variant_code(robot, monkeypatch):
    """Every model edit at once goes through, and compiles, with the variant primitives broken
    wherever they were imported."""
    def broken(*args, **kwargs):
        raise AssertionError("the truth used rmbench.robot.variant")

    for name in ("make_variant", "apply_edit", "add_point_mass", "add_compliant_base"):
        original = getattr(variant, name)
        for module in list(sys.modules.values()):
            if getattr(module, name, None) is original:
                monkeypatch.setattr(module, name, broken)
    changed = _changed(robot, *_ONE_OF_EACH)
    assert changed.model.nv == robot.model.nv + 8           # hose, bending and six base freedoms
