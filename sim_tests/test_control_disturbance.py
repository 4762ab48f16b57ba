"""Disturbances of the moving test (issue 83, item 3): a given force history or a function of time
on the disturbance coil, the spindle's eccentric mass, and a milling force from the stability
stage's cutting model; the same disturbance in the open loop and every controller, its kind
recorded, saturation events reported. The MH180 stand-in's tangential mode (5.9 Hz) under the
default design, along a 2 s move (0.5 s hold, 1.5 s J2/J5 move); under a second a test."""

import numpy as np
import pytest

from rmbench.control import Controller, Hardware, run_loop
from rmbench.control.moving import moving_figures, moving_test
from rmbench.control.trajectory import linear_move
from rmbench.errors import InputError
from rmbench.stability import STEEL_C45, cutting_force

FS = 2000.0          # Hz, the default controller rate
MODE = 5.9           # Hz, the tangential mode at the reference posture
SETTINGS = {"window": 1.0, "hop": 0.5, "start": 0.5, "mode_hz": lambda q: MODE}


@pytest.fixture(scope="module")
def traj(op):
    return linear_move(op.q_cmd, op.q_cmd + np.radians([0, 3, 0, 0, -3, 0]), 1.5, hold=0.5)


def samples(traj) -> np.ndarray:
    """The controller sample times of a run along ``traj``, s, shape (n,)."""
    return np.arange(int(round(traj.t[-1] * FS))) / FS


def sine(traj, amplitude: float) -> np.ndarray:
    """A sine at the mode on the coil, N, one value per controller sample."""
    return amplitude * np.sin(2 * np.pi * MODE * samples(traj))


def milling(t):
    """Steel at 354 rev/min (the spindle at the mode), 1 mm deep, 10 µm runout: the feed force, N."""
    return cutting_force(STEEL_C45, 60 * MODE, 1e-3, t, runout=10e-6)[:, 0]


def test_a_controller_that_does_nothing_meets_the_open_loops_force_and_spindle(op, traj):
    # a controller whose output is zero leaves the loop open: its record is the open loop's only if
    # it met the same force history and the same turning spindle
    zero = Controller(("tangential",), -np.eye(1), np.zeros((1, 2)), np.zeros((1, 1)), np.zeros((1, 2)))
    ds = moving_test(op, {"zero": zero}, traj, disturbance=sine(traj, 5.0), spindle_hz=2.0, **SETTINGS)
    still = moving_test(op, {"zero": zero}, traj, disturbance=sine(traj, 5.0), **SETTINGS)
    np.testing.assert_array_equal(ds.energy.sel(controller="zero").values, ds.energy.sel(controller="open").values)
    assert not np.allclose(ds.energy.sel(controller="open").values, still.energy.sel(controller="open").values)


def test_the_open_loop_energy_is_that_of_run_loop_under_the_same_force(op, default_design, traj):
    force = sine(traj, 5.0)
    ds = moving_test(op, {"k": default_design.controller}, traj, disturbance=force, **SETTINGS)
    rec = run_loop(op, None, float(traj.t[-1]), shaker={"tangential": force}, record_axes=("tangential",),
                   trajectory=traj)
    win, f = int(FS), np.fft.rfftfreq(int(FS), 1 / FS)
    starts = np.round((ds.t_mid.values - 0.5) * FS).astype(int)
    expected = [np.sum(np.abs(np.fft.rfft(np.hanning(win) * rec.acc[s:s + win, 0]))[np.abs(f - MODE) <= 0.25 * MODE] ** 2)
                for s in starts]
    np.testing.assert_allclose(ds.energy.sel(controller="open").values, expected, rtol=1e-12)


def test_a_function_of_time_is_the_force_history_at_the_controller_samples(op, default_design, traj):
    k = {"k": default_design.controller}
    by_function = moving_test(op, k, traj, disturbance=milling, **SETTINGS)
    by_array = moving_test(op, k, traj, disturbance=milling(samples(traj)), **SETTINGS)
    np.testing.assert_array_equal(by_function.energy.values, by_array.energy.values)
    np.testing.assert_array_equal(by_function.transient.values, by_array.transient.values)


def test_the_disturbance_kind_and_label_are_recorded(op, default_design, traj):
    k = {"k": default_design.controller}
    assert moving_test(op, k, traj, **SETTINGS).attrs["disturbance"] == "random"
    history = moving_test(op, k, traj, disturbance=sine(traj, 5.0), label="a sine at the mode", **SETTINGS)
    assert history.attrs["disturbance"] == "force history" and history.attrs["label"] == "a sine at the mode"
    assert "force_rms_n" not in history.attrs              # the random force's level means nothing here
    spun = moving_test(op, k, traj, disturbance="none", spindle_hz=MODE, **SETTINGS)
    assert spun.attrs["disturbance"] == "none + eccentric" and spun.attrs["spindle_hz"] == MODE


def test_random_by_name_is_the_default_force(op, default_design, traj):
    k = {"k": default_design.controller}
    a = moving_test(op, k, traj, **SETTINGS)
    b = moving_test(op, k, traj, disturbance="random", **SETTINGS)
    np.testing.assert_array_equal(a.energy.values, b.energy.values)


def test_saturation_events_are_reported_per_controller(op, default_design, traj):
    ds = moving_test(op, {"k": default_design.controller}, traj, disturbance=sine(traj, 40.0),
                     hardware=Hardware(force_limit=5.0), **SETTINGS)
    # 40 N at the mode against a 5 N amplifier limit: the command clips about twice a period
    assert int(ds.saturation_events.sel(controller="k")) >= 10
    assert int(ds.saturation_events.sel(controller="open")) == 0
    assert moving_figures(ds, "k")["saturation_events"] == int(ds.saturation_events.sel(controller="k"))


def test_a_milling_force_on_the_moving_robot_is_reduced_at_the_mode_without_a_louder_transient(
        op, default_design, traj):
    ds = moving_test(op, {"k": default_design.controller}, traj, disturbance=milling, **SETTINGS)
    fig = moving_figures(ds, "k")
    # the runout's spindle line sits on the mode: the static design's ~85 % at the mode, kept on the move
    assert fig["reduction"] >= 0.6 and fig["transient"] <= 1.0 and fig["saturation_events"] == 0


@pytest.mark.parametrize("disturbance", [np.zeros(10), "sine", lambda t: np.zeros(3), np.full(4000, np.nan)],
                         ids=["short", "unknown-name", "function-wrong-length", "not-finite"])
def test_a_bad_disturbance_is_input_error(op, default_design, traj, disturbance):
    with pytest.raises(InputError):
        moving_test(op, {"k": default_design.controller}, traj, disturbance=disturbance, **SETTINGS)


def test_a_negative_spindle_speed_is_input_error(op, default_design, traj):
    with pytest.raises(InputError):
        moving_test(op, {"k": default_design.controller}, traj, disturbance="none", spindle_hz=-1.0, **SETTINGS)


# -- the command line ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def files(tmp_path_factory, default_design):
    """The default tangential controller's file and a 4.5 s move (the CLI's 4 s window fits once)."""
    d = tmp_path_factory.mktemp("disturbance")
    default_design.controller.save(d / "k.npz")
    (d / "t.csv").write_text("t_s,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n"
                             "0,0,0,0,0,90,0\n0.5,0,0,0,0,90,0\n4.5,0,3,0,0,87,0\n")
    return d


def test_cli_mills_along_the_move_and_reports_the_cut_and_saturation_events(cli, files):
    import json

    code, out, _ = cli("control", "run", files / "k.npz", "--trajectory", files / "t.csv", "--disturbance",
                       "milling", "--material", "steel", "--rpm", "354", "--depth", "1", "--runout", "10", "--json")
    data = json.loads(out)
    assert code == 0 and data["disturbance"].startswith("milling steel at 354 rev/min, 1 mm deep")
    assert data["saturation_events"] == 0 and data["reduction"] >= 0.6


@pytest.mark.parametrize("args", [["--disturbance", "milling", "--rpm", "300"], ["--rpm", "300"],
                                  ["--disturbance", "eccentric", "--rpm", "-5"]],
                         ids=["milling-without-depth", "rpm-with-random", "negative-rpm"])
def test_cli_bad_disturbance_options_are_one_line_errors(cli, files, args):
    code, _, err = cli("control", "run", files / "k.npz", "--trajectory", files / "t.csv", *args)
    assert code == 2 and len(err.strip().splitlines()) == 1
