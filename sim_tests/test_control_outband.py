"""Out-of-band amplification (issue 83 item 5): the out-of-band force weight above 2 f0, and the
two figures that measure what the reduction at the mode costs elsewhere."""

import numpy as np
import pytest

from rmbench.control import (Controller, Weights, amplification_db, design, fullband_ratio, generalized_plant,
                             rms_ratio, sensitivity)
from rmbench.control.plant import first_strong_mode
from rmbench.errors import InputError

FREQ = np.geomspace(1.0, 100.0, 700)  # the schedule bench's grid


@pytest.fixture(scope="module")
def f0(tangential):
    return first_strong_mode(tangential, 0)


@pytest.fixture(scope="module")
def designs(tangential, f0):
    """The bench's single-axis design (order 12) without (k_o = 0) and with the weight (k_o = 5)."""
    return {k_o: design(tangential, Weights(k_o=k_o), order=12, mode_hz=[f0]) for k_o in (0.0, 5.0)}


def test_out_of_band_weight_lowers_the_amplification_above_twice_the_mode(tangential, f0, designs):
    o = np.abs(sensitivity(tangential, None, FREQ)["acc"][:, 0, 0])
    amp = {k_o: amplification_db(FREQ, o, np.abs(sensitivity(tangential, d.controller, FREQ)["acc"][:, 0, 0]), f0)
           for k_o, d in designs.items()}
    assert amp[5.0] < amp[0.0] - 0.5  # 1.39 → 0.34 dB at the reference posture


def test_out_of_band_weight_bounds_the_force_above_its_corner_by_gamma(tangential, f0, designs):
    """The synthesised controller keeps |W_o u/d| within γ: |u/d| ≤ γ / k_o well above r_o f0."""
    d = designs[5.0]
    w = d.weights
    f = FREQ[FREQ > 2 * w.r_o * f0]
    force = np.abs(sensitivity(tangential, d.full, f)["force"][:, 0, 0])  # |u/d|
    assert np.max(np.abs(w.out_of_band_force(f0)(2j * np.pi * f)) * force) <= 1.05 * d.gamma


def test_out_of_band_weight_is_off_by_default_and_adds_no_channel(tangential):
    assert not Weights().out_of_band
    off = generalized_plant(tangential, Weights())
    on = generalized_plant(tangential, Weights(k_o=5.0))
    assert on.noutputs == off.noutputs + 1
    assert not any(name.startswith("z_out") for name in off.output_labels)


def test_out_of_band_weight_is_high_above_its_corner_and_low_at_the_mode():
    w = Weights(k_o=5.0, r_o=2.0)
    mag = np.abs(w.out_of_band_force(5.0)(2j * np.pi * np.array([5.0, 10.0, 1000.0])))
    assert mag[2] == pytest.approx(5.0, rel=1e-3)  # k_o at high frequency
    assert mag[1] == pytest.approx(5.0 / 1.4**2, rel=1e-3)  # two sections of ζ 0.7: 1/(2ζ)² at the corner
    assert mag[0] < 5.0 / 2**4  # off the mode itself


@pytest.mark.parametrize("changes", [dict(k_o=-1.0), dict(k_o=float("nan")), dict(r_o=1.0), dict(r_o=0.5)])
def test_bad_out_of_band_weight_is_input_error(changes):
    with pytest.raises(InputError):
        Weights(**changes)


def test_amplification_of_an_unchanged_response_is_zero_db():
    mag = np.linspace(1.0, 2.0, FREQ.size)
    assert amplification_db(FREQ, mag, mag, 5.0) == pytest.approx(0.0, abs=1e-12)


def test_amplification_of_a_halved_response_is_minus_6_db():
    mag = np.linspace(1.0, 2.0, FREQ.size)
    assert amplification_db(FREQ, mag, mag / 2, 5.0) == pytest.approx(-6.0206, abs=1e-4)


def test_amplification_reads_only_above_twice_the_mode():
    open_mag = np.ones(FREQ.size)
    closed = np.where(FREQ < 9.0, 10.0, 1.0)  # a 20 dB bump below 2 f0 = 10 Hz does not count
    assert amplification_db(FREQ, open_mag, closed, 5.0) == pytest.approx(0.0, abs=1e-12)


def test_amplification_without_lines_above_the_band_is_an_error():
    with pytest.raises(ValueError):
        amplification_db(FREQ, np.ones(FREQ.size), np.ones(FREQ.size), 60.0)


def test_rms_ratio_of_an_unchanged_response_is_one():
    mag = 1.0 / (1.0 + (FREQ / 5.0) ** 2)
    assert rms_ratio(FREQ, mag, mag) == pytest.approx(1.0, abs=1e-12)


def test_rms_ratio_of_a_response_halved_everywhere_is_one_half():
    mag = 1.0 / (1.0 + (FREQ / 5.0) ** 2)
    assert rms_ratio(FREQ, mag, mag / 2) == pytest.approx(0.5, abs=1e-12)


def test_rms_ratio_integrates_on_the_linear_frequency_axis():
    """A flat response doubled above 50 Hz of 1-99 Hz: on the linear axis half the band is doubled,
    ratio sqrt((1 + 4) / 2) = 1.58; on a log-spaced grid's plain mean it would read 1.16."""
    f = np.geomspace(1.0, 99.0, 4000)
    ratio = rms_ratio(f, np.ones(f.size), np.where(f > 50.0, 2.0, 1.0))
    assert ratio == pytest.approx(np.sqrt(2.5), rel=2e-3)


def test_fullband_ratio_without_feedback_is_one_per_axis(tangential):
    zero = Controller(tangential.axes, -np.eye(1), np.zeros((1, 2)), np.zeros((1, 1)), np.zeros((1, 2)))
    assert fullband_ratio(tangential, zero, FREQ) == pytest.approx([1.0], abs=1e-12)


def test_fullband_ratio_is_the_rms_ratio_of_the_acceleration_sensitivity(tangential, designs):
    c = designs[0.0].controller
    o = np.abs(sensitivity(tangential, None, FREQ)["acc"][:, 0, 0])
    cl = np.abs(sensitivity(tangential, c, FREQ)["acc"][:, 0, 0])
    assert fullband_ratio(tangential, c, FREQ)[0] == pytest.approx(rms_ratio(FREQ, o, cl), rel=1e-12)
