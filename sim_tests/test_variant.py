"""Model variants derived through MjSpec and saved as MJCF."""

import numpy as np
import pytest

from rmbench.errors import InputError
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
