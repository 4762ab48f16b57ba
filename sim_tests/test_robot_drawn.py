"""A robot drawn off its data sheet: random stiffness, damping and mass edits."""

import re

import numpy as np

from rmbench.robot.drawn import drawn_edits
from rmbench.robot.variant import parse_edit


def test_a_seed_draws_the_same_robot():
    assert drawn_edits(np.random.default_rng(7)) == drawn_edits(np.random.default_rng(7))
    assert drawn_edits(np.random.default_rng(7)) != drawn_edits(np.random.default_rng(8))


def test_stiffness_then_damping_per_joint_then_mass_per_body_each_factor_within_its_bounds():
    edits = drawn_edits(np.random.default_rng(0), joints=("a", "b"), bodies=("c",), stiffness=(0.5, 2.0),
                        damping=(0.9, 1.1), mass=(0.99, 1.01))
    assert [re.sub(r"=.*", "", e) for e in edits] == ["a.stiffness*", "b.stiffness*", "a.damping*", "b.damping*",
                                                      "c.mass*"]
    factors = [float(e.split("=")[1]) for e in edits]
    assert all(0.5 <= f <= 2.0 for f in factors[:2]) and all(0.9 <= f <= 1.1 for f in factors[2:4])
    assert 0.99 <= factors[4] <= 1.01


def test_the_default_edits_are_the_irb6660_stand_ins_joints_and_links_in_variant_syntax():
    edits = [parse_edit(e) for e in drawn_edits(np.random.default_rng(2026))]
    assert [e.target for e in edits[:6]] == [f"j{k}_flex" for k in range(1, 7)]
    assert [e.target for e in edits[12:]] == ["lower_arm", "upper_arm", "forearm", "flange"]
    assert all(e.op == "*=" for e in edits)
