"""The blind FRF bench beyond the model (bench/blind_frf.py): who gets what, how a named size is
read, and what its line counts."""

from types import SimpleNamespace

import numpy as np
import pytest

from _bench_path import bench_on_path

with bench_on_path():
    from blind_frf import _same_modes, bench_line, draw_robot, found_size, slot

ARGS = SimpleNamespace(p_form=0.5, form_scale=1.0)


def test_a_third_of_the_robots_carry_no_effect_a_third_one_of_the_library_a_third_one_from_outside():
    assert [slot(i) for i in range(6)] == ["none", "in_library", "out_of_library"] * 2


def test_half_the_robots_without_an_effect_are_the_spread_alone():
    # robots 0, 6, 12, ...: no form error either, the in-model reference inside the same run
    _, real, _, effect, xml = draw_robot(6, 3, ARGS)
    assert effect is None and real.form == () and xml == real.xml


def test_a_robots_effect_is_drawn_on_top_of_its_real_robot_from_its_own_seed():
    _, real_a, postures_a, effect_a, xml_a = draw_robot(1, 3, ARGS)
    _, real_b, postures_b, effect_b, xml_b = draw_robot(1, 3, ARGS)
    assert effect_a == effect_b and effect_a.in_library and xml_a == xml_b
    assert [p.x for p in postures_a] == [p.x for p in postures_b] and len(postures_a) == 16


def _account(**values):
    return {"params": [{"name": n, "nominal": nom, "value": v} for n, (nom, v) in values.items()]}


def test_a_holders_named_size_is_its_calibrated_factor_times_the_effects():
    top = SimpleNamespace(name="tool_contact_stiffness@tool_contact", params={"ln_translation": np.log(2.0)})
    size = found_size("tool_contact_stiffness", top, _account(**{"tool_contact.translation": (1e7, 1.5e7)}))
    assert size == pytest.approx(3.0)


def test_an_added_masss_named_size_counts_what_the_calibration_already_added():
    top = SimpleNamespace(name="added_mass@wrist", params={"mass": 10.0})
    assert found_size("added_mass", top, _account(**{"wrist.mass": (35.0, 40.0)})) == pytest.approx(15.0)


def test_held_out_errors_before_and_after_are_counted_on_the_same_modes():
    # a mode paired after calibration but not before (or the reverse) would make the two averages
    # speak of different modes (calibrate_real once printed 6.43 -> 4.83 % that way)
    row = dict(posture=0, band="low")
    rows = {"before": [{**row, "mode": 1, "paired": True, "f_err": 0.1}, {**row, "mode": 2, "paired": False}],
            "after": [{**row, "mode": 1, "paired": True, "f_err": -0.01}, {**row, "mode": 2, "paired": True,
                                                                              "f_err": 0.5}]}
    assert _same_modes(rows) == [0.01]
    assert _same_modes(rows, "before") == [0.1]


def test_the_bench_line_counts_invisible_and_rejected_draws_apart_from_the_scored():
    params = [{"name": "a", "identifiability": "identifiable", "within5": True, "covered": True}]
    scored = {"class": "form", "hidden": None, "verdict": "unexplained", "top": None, "params": params,
              "f_err_after": [0.02], "seconds": {"total": 50.0}}
    cases = [scored, {"index": 1, "class": "in_library", "invisible": True},
             {"index": 2, "class": "out_of_library", "rejected": "the real robot could not hold a posture"}]
    line = bench_line(cases, 7)
    assert line["cases"] == 1 and line["invisible"] == 1 and line["rejected"] == 1 and line["seed"] == 7
    assert line["form_blamed"][:2] == [0, 1] and line["s_per_robot"] == 50.0
