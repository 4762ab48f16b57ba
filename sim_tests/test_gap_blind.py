"""Specification of the withheld-effect check and of the seed-000 real case's data."""

import numpy as np
import pytest

from rmbench.gap.cases.blind import summarise
from rmbench.gap.cases.hidden import Hidden, draw_case, inject, within_library
from rmbench.robot import Robot


@pytest.fixture(scope="module")
def robot():
    return Robot.load("irb6660", tool="dummy")


def test_cases_are_one_effect_two_or_one_outside_the_library_in_about_3_1_1():
    rng = np.random.default_rng(0)
    cases = [draw_case(rng) for _ in range(400)]
    one = np.mean([len(c) == 1 and c[0].in_library for c in cases])
    two = np.mean([len(c) == 2 for c in cases])
    out = np.mean([not c[0].in_library for c in cases])
    # 400 draws: shares within 3 standard errors of 0.6, 0.2, 0.2
    assert abs(one - 0.6) < 0.075 and abs(two - 0.2) < 0.06 and abs(out - 0.2) < 0.06
    assert all(c[0].name != c[1].name for c in cases if len(c) == 2)


def test_injection_edits_a_copy_of_the_model_by_its_own_path(robot):
    """The hidden stiffness is in the injected MJCF; the nominal robot is untouched."""
    k0 = robot.model.joint("j4_flex").stiffness[0]
    xml, placement, rpm = inject(robot, (Hidden("joint_stiffness", "j4_flex", {"factor": 1.4}),))
    changed = Robot(xml, name="hidden", tool="dummy")
    assert changed.model.joint("j4_flex").stiffness[0] == pytest.approx(1.4 * k0, rel=1e-6)
    assert robot.model.joint("j4_flex").stiffness[0] == k0 and rpm == 0.0
    assert placement["high"]["position_error_mm"] == [0.0] * 4


def test_sensor_and_spindle_effects_go_to_the_test_not_the_model(robot):
    xml, placement, rpm = inject(robot, (Hidden("sensor_misalignment", "low:1aY", {"angle_deg": 6.0}),
                                        Hidden("non_reciprocity", "spindle_spin", {"rpm": 12000.0})))
    assert placement["low"]["misalignment_deg"] == [0.0, 0.0, 0.0, 6.0] and rpm == 12000.0
    assert xml == robot.xml


@pytest.mark.parametrize("hidden", [Hidden("hose_resonator", "forearm", {"mass": 8.0, "f_hz": 20.0, "zeta": 0.05}),
                                    Hidden("tendon_coupling", "j2_flex+j3_flex", {"fraction": 0.5})],
                         ids=["hose", "tendon"])
def test_out_of_library_effects_add_what_no_candidate_can(robot, hidden):
    xml, _, _ = inject(robot, (hidden,))
    changed = Robot(xml, name="hidden", tool="dummy")
    if hidden.kind == "hose_resonator":
        assert changed.model.nv == robot.model.nv + 1           # one more freedom: a new mode
    else:
        assert changed.model.ntendon == robot.model.ntendon + 1  # a spring across two joints


def test_an_offset_mass_moves_the_bodys_centre_of_mass_off_its_origin(robot):
    """The library's added mass scales a body's mass where its centre is; 12 kg at 0.3 m moves the
    subtree's centre, which no candidate of the library can."""
    hidden = Hidden("offset_mass", "forearm", {"mass": 12.0, "offset_m": [0.0, 0.3, 0.0]})
    changed = Robot(inject(robot, (hidden,))[0], name="hidden", tool="dummy")
    b0, b1 = robot.model.body("forearm").id, changed.model.body("forearm").id
    m0, m1 = robot.model.body_subtreemass[b0], changed.model.body_subtreemass[b1]
    assert m1 == pytest.approx(m0 + 12.0)
    assert changed.model.nv == robot.model.nv          # rigidly attached: no new freedom


def test_a_bending_link_has_a_hinge_about_an_axis_none_of_its_joints_has(robot):
    hidden = Hidden("link_bending", "forearm", {"compliance_ratio": 0.5})
    changed = Robot(inject(robot, (hidden,))[0], name="hidden", tool="dummy")
    bend = changed.model.joint("forearm_bending")
    assert changed.model.nv == robot.model.nv + 1
    # twice the root joint's stiffness (compliance ratio 0.5), at mid-span
    assert bend.stiffness[0] == pytest.approx(2 * robot.model.joint("j4_flex").stiffness[0])
    axis = changed.model.jnt_axis[bend.id]
    assert abs(axis @ changed.model.jnt_axis[changed.model.joint("j4_flex").id]) < 1e-12


def test_out_of_library_draws_cover_every_outside_kind():
    from rmbench.gap.cases.hidden import OUT_KINDS

    rng = np.random.default_rng(1)
    kinds = {draw_case(rng, "out")[0].kind for _ in range(200)}
    assert kinds == set(OUT_KINDS)


def test_hidden_effects_stay_inside_the_librarys_ranges():
    assert within_library(Hidden("servo_stiffness", "a4", {"factor": 0.05}))
    assert not within_library(Hidden("servo_stiffness", "a4", {"factor": 0.005}))
    assert within_library(Hidden("tendon_coupling", "j2_flex+j3_flex", {"fraction": 5.0}))


def test_summary_counts_each_kind_of_case():
    from rmbench.gap.cases.blind import CaseResult

    def case(hidden, verdict, ranked, **kw):
        base = dict(index=0, method="linear", hidden=hidden, verdict=verdict, ranked=ranked,
                    equivalent=(), shrink=0.9, top1=False, top3=False, top1_class=False,
                    top3_class=False, pair_in_top3=None, seconds={}, visible_db=2.0, scale=1.0)
        base.update(kw)
        return CaseResult(**base)

    a = Hidden("joint_stiffness", "j2_flex", {"factor": 1.3})
    b = Hidden("added_mass", "flange", {"fraction": 0.2})
    o = Hidden("tendon_coupling", "j2_flex+j3_flex", {"fraction": 0.5})
    s = summarise([case((a,), "explained", (("joint_stiffness@j2_flex", 0.9),), top1=True, top3=True),
                   case((a, b), "explained", (("joint_stiffness@j2_flex", 0.9), ("added_mass@flange", 0.8)),
                        pair_in_top3=True),
                   case((o,), "explained", (("joint_stiffness@j2_flex", 0.5),))])
    assert s["top1"] == 1.0 and s["pair_recall"] == 1.0 and s["false_attribution"] == 1.0
    assert s["single"] == 1 and s["pairs"] == 1 and s["out_of_library"] == 1


def test_the_summary_counts_rejected_draws():
    from dataclasses import replace

    from rmbench.gap.cases.blind import CaseResult

    a = Hidden("joint_stiffness", "j2_flex", {"factor": 1.3})
    c = CaseResult(index=0, method="linear", hidden=(a,), verdict="explained", ranked=(), equivalent=(),
                   shrink=0.9, top1=True, top3=True, top1_class=True, top3_class=True, pair_in_top3=None,
                   seconds={}, visible_db=2.0, scale=1.0, rejected=2)
    assert summarise([c, replace(c, index=1, rejected=1)])["rejected"] == 3


def test_seed000_tables_are_read_with_the_mirror_postures():
    from rmbench.gap.cases.real import VALIDATION, seed000_modes

    keys, meas = seed000_modes()
    assert keys[:3] == list(VALIDATION) and len(keys) == 4
    assert all(len(m["low"]) == 5 and len(m["high"]) == 4 for m in meas)
    # the real robot's first mode: 8.19 Hz at y = -200 mm, 9.68 Hz at +200 mm (18 % apart)
    first = [m["low"].f_n[list(m["low"].mode_id).index(1)] for m in meas[:2]]
    assert first == [8.19, 9.68]
    assert np.isnan(meas[0]["low"].residue).all() and np.isfinite(meas[3]["low"].residue).all()


def test_table_b1_frf_is_written_as_uff58_and_reads_back(tmp_path):
    from rmbench.gap.cases.real import write_table_b1_uff
    from rmbench.io import read_uff58
    from rmbench.modal import synthesize
    from rmbench.modal.synthetic import table_b1

    write_table_b1_uff(tmp_path)
    ds = read_uff58(tmp_path)
    s = table_b1("low")
    f = ds.freq.values
    np.testing.assert_allclose(ds.H.values[0], synthesize(f, s.poles, s.phi_r, s.phi_l), rtol=1e-9)
    assert ds.x.values[0] == pytest.approx(1.3) and ds.y.values[0] == pytest.approx(0.1)
