"""The proof-mass suppressor's results describe themselves: a closed-loop run (LoopRecord), a
suppression test (uncontrolled against controlled) and a schedule's certificate each give a few
readable lines, a strict-JSON dict and a plot; and the figures the CLI prints come from the library."""

import json

import matplotlib
import numpy as np
import pytest
import xarray as xr

from rmbench.control import Controller, LoopRecord, SuppressionTest, suppression_frequencies
from rmbench.control.moving import moving_figures
from rmbench.control.schedule import Certificate, Schedule
from rmbench.errors import InputError

matplotlib.use("Agg")


def _strict(d: dict) -> dict:
    return json.loads(json.dumps(d, allow_nan=False))


def _lines(ax) -> int:
    return len(ax.get_lines()) + len(ax.collections)


# -- a closed-loop run ---------------------------------------------------------------------------------
@pytest.fixture
def record():
    t = np.arange(400) / 2000.0
    acc = np.stack([np.sin(2 * np.pi * 10 * t), 0.5 * np.cos(2 * np.pi * 20 * t)], axis=1)  # whole periods
    return LoopRecord(t, ("tangential", "axial"), acc, 1e-3 * acc[:, :1], 10.0 * acc[:, :1], saturated=0.0,
                      stroke_used=0.25, end_stop=0.0, wall_s=0.1, guard_trips=1, guard_off=0.05)


def test_loop_record_summary_names_each_axis_rms_and_the_stroke_used(record):
    text = record.summary()
    assert "acceleration rms tangential 0.7071, axial 0.3536 m/s²" in text and "stroke used 25 %" in text


def test_loop_record_to_dict_is_strict_json_with_the_figures(record):
    d = _strict(record.to_dict())
    assert d["duration_s"] == pytest.approx(0.2) and d["acc_rms"]["axial"] == pytest.approx(0.5 / np.sqrt(2))
    assert d["force_max"] == pytest.approx(10.0, rel=1e-3) and d["guard_trips"] == 1


def test_loop_record_of_an_unmeasured_wall_time_has_a_null_realtime_factor(record):
    quick = LoopRecord(record.t, record.axes, record.acc, record.pos, record.force, 0.0, 0.25, 0.0, wall_s=0.0)
    assert _strict(quick.to_dict())["realtime_factor"] is None


def test_loop_record_plot_draws_one_trace_per_axis(record):
    ax = record.plot()
    assert len(ax.get_lines()) == 2


# -- a suppression test ----------------------------------------------------------------------------------
def _runs(freq, peak, ok=True):
    """A sweep-shaped Dataset: a resonance of height ``peak`` at 6 Hz on the tangential axis."""
    sens = peak / (1 + 4j * (freq - 6.0))
    n = len(freq)
    return xr.Dataset({"sensitivity": (("freq", "axis"), sens[:, None]),
                       "stroke_used": ("freq", np.full(n, 0.4 if ok else np.nan)),
                       "end_stop": ("freq", np.zeros(n) if ok else np.full(n, np.nan)),
                       "force_max": ("freq", np.full(n, 12.0 if ok else np.nan)),
                       "saturated": ("freq", np.zeros(n) if ok else np.full(n, np.nan)),
                       "ok": ("freq", np.full(n, ok)), "reason": ("freq", np.full(n, "", dtype=object))},
                      coords={"freq": freq, "axis": ["tangential"]})


@pytest.fixture
def sweep():
    f = np.linspace(4.0, 8.0, 21)
    return SuppressionTest("sweep", _runs(f, 1.0), _runs(f, 0.2), ("tangential",), (6.0,), (0.8,))


def test_suppression_summary_states_the_reduction_at_the_mode_and_the_effort(sweep):
    text = sweep.summary()
    assert "tangential: reduction 80.0 % at the 6.00 Hz mode" in text
    assert "stroke used 40 % of ±stroke, peak force 12.0 N, runs at an end stop 0, failed runs 0" in text


def test_suppression_to_dict_is_the_run_record_in_strict_json(sweep):
    d = _strict(sweep.to_dict())
    assert d["test"] == "sweep" and d["axes"] == {"tangential": {"mode_hz": 6.0, "reduction": 0.8}}
    assert d["stroke_used_max"] == 0.4 and d["failed_runs"] == 0 and d["end_stop_runs"] == 0


def test_suppression_where_every_controlled_run_failed_writes_null_not_nan():
    f = np.linspace(4.0, 8.0, 5)
    with pytest.warns(RuntimeWarning):  # numpy's all-NaN max
        d = SuppressionTest("sweep", _runs(f, 1.0), _runs(f, np.nan, ok=False), ("tangential",), (6.0,),
                            (float("nan"),)).to_dict()
    d = _strict(d)
    assert d["stroke_used_max"] is None and d["failed_runs"] == 5 and d["axes"]["tangential"]["reduction"] is None


def test_suppression_to_dataset_holds_both_runs_on_a_case_dimension(sweep):
    ds = sweep.to_dataset()
    assert list(ds.case.values) == ["uncontrolled", "controlled"] and "reason" not in ds


def test_suppression_plot_draws_both_runs(sweep):
    ax = sweep.plot()
    assert len(ax.get_lines()) >= 2


def test_suppression_test_of_unknown_kind_is_input_error(sweep):
    with pytest.raises(InputError, match="impact"):
        SuppressionTest("impact", sweep.uncontrolled, sweep.controlled, ("tangential",), (6.0,), (0.8,))


def test_default_frequencies_are_dense_at_the_design_mode(op):
    k = Controller(("tangential",), np.zeros((1, 1)), np.zeros((1, 2)), np.zeros((1, 1)), np.zeros((1, 2)),
                   meta={"mode_hz": [5.9]})
    sweep, ecc = suppression_frequencies(op, k, "sweep"), suppression_frequencies(op, k, "eccentric")
    assert sweep.min() == 2.0 and sweep.max() == 30.0 and ecc.max() == 20.0
    # 1 Hz steps away from the mode, a fraction of the half-power band across it
    assert np.sum(np.abs(sweep - 5.9) < 0.5) > 3


# -- a schedule's certificate ----------------------------------------------------------------------------
@pytest.fixture
def certificate():
    s = np.radians([[-10.0], [0.0], [10.0], [20.0]])
    return Certificate(s, np.array([True, False, False, True]), np.array([-1.0, -0.5, -0.2, -0.8]),
                       np.array([0.6, 0.4, 0.25, 0.5]), "interpolated")


def test_certificate_summary_names_the_worst_point_in_degrees(certificate):
    text = certificate.summary()
    assert "stable" in text and "smallest loop margin 0.250 at (10.0) deg (between grid postures)" in text


def test_unstable_certificate_says_so():
    c = Certificate(np.zeros((1, 1)), np.array([True]), np.array([0.3]), np.array([0.0]), "model")
    assert "UNSTABLE" in c.summary()


def test_certificate_to_dict_is_strict_json_with_every_point(certificate):
    d = _strict(certificate.to_dict())
    assert d["stable"] and d["min_margin"] == 0.25 and d["points"] == 4 and len(d["points_checked"]) == 4
    assert d["worst"]["variables"] == pytest.approx([np.radians(10.0)]) and not d["worst"]["on_grid"]


def test_certificate_headline_is_what_a_schedule_file_keeps(certificate):
    assert certificate.headline() == {"stable": True, "min_margin": 0.25, "points": 4}


def test_certificate_plot_of_one_joint_draws_the_margin(certificate):
    ax = certificate.plot()
    assert _lines(ax) >= 1


def test_certificate_plot_of_two_joints_draws_the_margin_map():
    s = np.radians([[0.0, 0.0], [0.0, 10.0], [10.0, 0.0], [10.0, 10.0]])
    c = Certificate(s, np.ones(4, bool), -np.ones(4), np.array([0.5, 0.4, 0.3, 0.6]), "model")
    assert _lines(c.plot()) >= 1


# -- figures the command line prints ---------------------------------------------------------------------
def test_schedule_mode_range_spans_its_designs():
    def k(f):
        return Controller(("tangential",), np.zeros((1, 1)), np.zeros((1, 2)), np.zeros((1, 1)), np.zeros((1, 2)),
                          meta={"mode_hz": [f]})
    sch = Schedule(("tangential",), (1,), (np.radians([-10.0, 0.0, 20.0]),), (k(6.4), k(5.9), k(5.1)), np.zeros(6))
    assert sch.mode_range() == ((5.1, 6.4),)


def test_moving_figures_give_each_window_its_reduction():
    ds = xr.Dataset({"energy": (("controller", "window"), [[4.0, 1.0], [1.0, 0.25]]),
                     "f0": ("window", [6.0, 5.5]),
                     **{v: ("controller", [0.0, 0.5]) for v in ("reduction", "transient", "saturated",
                                                                 "stroke_used", "guard_trips", "realtime_factor")}},
                    coords={"controller": ["open", "controlled"], "window": [0, 1], "t_mid": ("window", [2.0, 3.0])})
    w = moving_figures(ds)["windows"]
    assert [x["reduction"] for x in w] == [0.5, 0.5] and [x["t_s"] for x in w] == [2.0, 3.0]
