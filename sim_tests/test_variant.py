"""Model variants derived through MjSpec and saved as MJCF."""

import numpy as np
import pytest

from rmbench.errors import InputError, ModelError
from rmbench.robot import Posture, Robot
from rmbench.robot.variant import make_variant, parse_edit

POSTURE = Posture.from_mm_deg(1600, 100, 0)


def _save(tmp_path, robot, *edits, **kw):
    path = tmp_path / "variant.xml"
    path.write_text(make_variant(robot, edits, **kw))
    return Robot.load(path)


def test_saved_variant_without_edits_reproduces_the_robot(tmp_path, irb):
    # the variant file carries robot and tool; reloading it gives the same modes to round-off of
    # the MJCF writer (6 significant digits)
    same = _save(tmp_path, irb, "j1_flex.damping*=1")
    f0 = irb.at(POSTURE).modes("low").f_n
    np.testing.assert_allclose(same.at(POSTURE).modes("low").f_n, f0, rtol=1e-5)
    assert same.tool == "dummy"


def test_scaling_spindle_bearing_stiffness_shifts_the_spindle_modes(tmp_path, irb):
    # all four bearing stiffnesses x1.21 → every spindle mode rises by ~10 % (√1.21), less the
    # share of the tool and the arm in each mode's strain energy
    stiff = _save(tmp_path, irb, "spindle_*.stiffness*=1.21")
    f0 = irb.at(POSTURE).modes("high").f_n
    f1 = stiff.at(POSTURE).modes("high").f_n
    ratio = f1 / f0
    assert np.all((ratio > 1.05) & (ratio < 1.10))


def test_tool_holder_contact_stiffness_edit(tmp_path, irb):
    softer = _save(tmp_path, irb, "tool_contact_x.stiffness*=0.5", "tool_contact_y.stiffness*=0.5")
    assert softer.model.joint("tool_contact_x").stiffness[0] == pytest.approx(0.5 * 6.25e7)


def test_point_mass_at_the_tool_tip_lowers_the_spindle_modes(tmp_path, irb):
    heavy = _save(tmp_path, irb, masses=[("tool_tip", 0.2, (0, 0, 0))])
    assert np.all(heavy.at(POSTURE).modes("high").f_n < irb.at(POSTURE).modes("high").f_n)


def test_compliant_base_adds_six_passive_freedoms(tmp_path, irb):
    based = _save(tmp_path, irb, compliant_base=(5e8, 5e8))
    assert based.model.nv == irb.model.nv + 6
    # a stiff foundation barely moves the first mode, a soft one lowers it
    soft = _save(tmp_path, irb, compliant_base=(2e7, 2e7))
    f0 = irb.at(POSTURE).modes("low").f_n[0]
    assert based.at(POSTURE).modes("low").f_n[0] == pytest.approx(f0, rel=0.02)
    assert soft.at(POSTURE).modes("low").f_n[0] < f0


def test_moving_a_site_changes_its_position(tmp_path, irb):
    moved = _save(tmp_path, irb, "tool_p1a.pos+=0.001,0,0")
    assert moved.model.site("tool_p1a").pos[0] == pytest.approx(irb.model.site("tool_p1a").pos[0] + 0.001)


@pytest.mark.parametrize("text, message", [
    ("j2_flex.stiffness", "cannot parse"),
    ("j2_flex.stiffness*=abc", "numbers"),
    ("nosuchjoint.stiffness*=2", "no joint, body or site"),
    ("j2_flex.colour=1", "unknown field"),
    ("j2_flex.stiffness=-5", "non-negative"),
], ids=["no-operator", "not-a-number", "unknown-name", "unknown-field", "negative"])
def test_bad_edits_are_rejected_with_a_clear_message(irb, text, message):
    with pytest.raises(InputError, match=message):
        make_variant(irb, [parse_edit(text)] if "abc" not in text and "=" in text else [text])


@pytest.mark.parametrize("edit, matrix, change", [
    ("a2.kp*=0.8", "K", -0.2 * 8e7),  # a2: kp = 8e7 N·m/rad
    ("a2.kv*=1.5", "C", 0.5 * 6e4),  # a2: kv = 6e4 N·m·s/rad
], ids=["kp", "kv"])
def test_servo_edit_changes_the_linearisation_at_the_motor_dof_by_the_gain_change(tmp_path, irb, edit, matrix,
                                                                                 change):
    edited = _save(tmp_path, irb, edit)
    q = irb.ik(POSTURE).q
    op0, op1 = irb.at(q), edited.at(q)
    i = op0.linear.dof_names.index("j2")
    before, after = getattr(op0.linear, matrix), getattr(op1.linear, matrix)
    expected = np.zeros_like(before)
    expected[i, i] = change
    # the servo holds the motor at its command whatever its gains, so the equilibrium, and every
    # other entry, stay put; central differences of the linear servo term are exact to round-off
    # (1e-6 of the largest entry)
    np.testing.assert_allclose(after - before, expected, atol=1e-6 * np.abs(before).max())


def test_servo_edit_wildcard_sets_every_matching_position_actuator(tmp_path, irb):
    stiff = _save(tmp_path, irb, "a[1-3].kp=1e8", "a[1-3].kv+=100")
    for name, kv in (("a1", 5e4), ("a2", 6e4), ("a3", 3.5e4)):
        act = stiff.model.actuator(name)
        assert act.gainprm[0] == 1e8 and act.biasprm[1] == -1e8  # kp enters gain and bias alike
        assert act.biasprm[2] == -(kv + 100)
    assert stiff.model.actuator("a4").gainprm[0] == irb.model.actuator("a4").gainprm[0]


@pytest.mark.parametrize("text, message", [
    ("a9.kp*=2", "no actuator named 'a9'"),
    ("a2.kp=0", "kp of 'a2' must stay positive"),
    ("a2.kv+=-1e9", "kv of 'a2' must stay non-negative"),
    ("a2.kp=1,2", "servo fields take one number"),
], ids=["unknown-actuator", "zero-kp", "negative-kv", "two-numbers"])
def test_bad_servo_edits_are_rejected_with_a_clear_message(irb, text, message):
    with pytest.raises(InputError, match=message):
        make_variant(irb, [text])


def test_servo_edit_of_a_force_actuator_is_rejected(mh180):
    # the proof-mass voice coil is a motor (force) actuator: it has no kp or kv
    with pytest.raises(InputError, match="actuator 'vc_axial' is not a position actuator"):
        make_variant(mh180, ["vc_axial.kp*=2"])


def test_naming_the_tool_a_saved_variant_carries_keeps_that_tool(tmp_path, irb):
    path = tmp_path / "variant.xml"
    path.write_text(make_variant(irb, ["j1_flex.damping*=1"]))
    same = Robot.load(path, tool="dummy")
    assert same.tool == "dummy" and same.model.nv == irb.model.nv  # not grafted twice
    with pytest.raises(ModelError, match="already carries the tool 'dummy'"):
        Robot.load(path, tool="endmill")
