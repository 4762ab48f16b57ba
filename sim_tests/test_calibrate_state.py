"""Specification of the model under test's parameters that are not MJCF numbers: a sensor's
placement (read through the test design) and the spindle's speed (the robot's state). They are
calibrated beside the ordinary parameters, with the same solver and sensitivities."""

from dataclasses import replace

import numpy as np
import pytest

from rmbench.calibrate import CalibrationSettings, ModalData, ModalModel, SensorOffset, calibrate
from rmbench.calibrate.design import sensor_parameter
from rmbench.calibrate.model import spindle_parameter
from rmbench.errors import InputError
from rmbench.robot import Posture, Robot
from rmbench.robot.parameters import ParameterSet

from _exact_modes import exact_modes
from test_calibrate import POSTURES

TURN = np.radians(6.0)       # a sensor turned about the tool axis, as the bench's largest draws


def test_a_sensor_parameter_moves_no_mode_only_what_the_sensor_reads(irb, design):
    params = ParameterSet([sensor_parameter("sensor.low:1aX.angle")])
    q = np.array([irb.ik(POSTURES[0]).q])
    mm = ModalModel(irb, params, design, q, ("low",))
    u = np.array([np.degrees(TURN)])
    turned = ModalModel(irb, ParameterSet([]), design.with_offsets([SensorOffset("low", "1aX", angle=TURN)]),
                        q, ("low",))
    fitted, exact = mm.modes(u, 0, "low"), turned.modes(np.zeros(0), 0, "low")
    np.testing.assert_array_equal(fitted.f_n, mm.modes(np.zeros(1), 0, "low").f_n)
    # the same design read the same modes: equal to rounding
    np.testing.assert_allclose(fitted.residue, exact.residue, rtol=1e-12, atol=1e-12 * np.abs(exact.residue).max())


def test_a_sensor_step_is_the_unstepped_modes_read_at_the_moved_sensor(irb, design):
    params = ParameterSet([sensor_parameter("sensor.low:1aX.angle")])
    q = np.array([irb.ik(POSTURES[0]).q])
    mm = ModalModel(irb, params, design, q, ("low",))
    (base, _), stepped = mm.sensitivity(np.zeros(1), 0, "low", np.array([0.5]))
    exact = mm.modes(np.array([0.5]), 0, "low")
    # a reading is linear in the sensor's direction, and the modes do not move: exact, not first order
    np.testing.assert_allclose(stepped[0][0].residue, exact.residue, atol=1e-12 * np.abs(exact.residue).max())
    assert not np.allclose(stepped[0][0].residue, base.residue)


def test_a_malformed_sensor_parameter_is_a_one_line_error():
    with pytest.raises(InputError, match="not a sensor parameter"):
        sensor_parameter("sensor.low.angle")
    with pytest.raises(InputError, match="unknown sensor coordinate"):
        sensor_parameter("sensor.low:1Z.angle")


def test_a_turned_sensor_is_recovered_beside_the_gearboxes(irb, design):
    turned = design.with_offsets([SensorOffset("low", "1aX", angle=TURN)])
    data = exact_modes(irb, turned, POSTURES[:3])
    data = ModalData(data.postures, data.modes, data.bands, design, data.source)   # the design as written
    name = "sensor.low:1aX.angle"
    cal = calibrate(irb, data, settings=CalibrationSettings(groups=("joints",), workers=1, extra=(name,),
                                                            free=(name,)))
    by = {p.name: p for p in cal.params}
    # noise-free modes of a model of the fitted form: the angle to a tenth of a degree (its resolution)
    assert by[name].value == pytest.approx(np.degrees(TURN), abs=0.1)
    lo, hi = by[name].interval
    assert lo <= np.degrees(TURN) <= hi


def test_the_spindle_speed_step_follows_the_exact_modes(irb, design):
    params = ParameterSet([spindle_parameter(irb)])
    q = np.array([irb.ik(POSTURES[0]).q])
    mm = ModalModel(irb, params, design, q, ("high",))
    u = np.array([15.0])                    # 15,000 rev/min
    step = np.array([1.0])
    (base, _), stepped = mm.sensitivity(u, 0, "high", step)
    exact = mm.modes(u + step, 0, "high")
    moved = np.abs(exact.f_n - base.f_n).max()
    # the gyroscopic coupling splits the spindle's bending modes: they move, and the first-order
    # step sits on the exact modes to a small part of that move
    assert moved > 0
    assert np.abs(stepped[0][0].f_n - exact.f_n).max() < 0.05 * moved


def test_a_spinning_spindle_is_recovered_from_the_modes(irb, design):
    spinning = Robot(irb.xml, name="truth", tool="dummy", spindle_rpm=15000.0)
    data = exact_modes(spinning, design, POSTURES[:3])
    cal = calibrate(irb, data, settings=CalibrationSettings(groups=("joints",), workers=1, extra=("spindle.speed",),
                                                            free=("spindle.speed",)))
    speed = next(p for p in cal.params if p.name == "spindle.speed")
    # noise-free modes of a model of the fitted form: to the 100 rev/min that matter
    assert speed.value == pytest.approx(15000.0, abs=100.0)


def test_a_robot_without_a_spinning_spindle_has_no_speed_to_fit():
    with pytest.raises(InputError, match="no spindle that spins"):
        spindle_parameter(Robot.load("mh180"))
