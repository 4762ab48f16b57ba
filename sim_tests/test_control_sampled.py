"""Stability certified on the sampled-data loop the hardware runs (issue 83, item 1): the controller
in Tustin form at ``fs``, the delay, the hold and the amplifier, against the continuous check."""

import json
from dataclasses import replace

import numpy as np
import pytest

from rmbench.control import (Controller, Hardware, ReactionMass, certify_sampled, is_stable, run_loop, sampled_loop,
                             sampled_radius, sampled_stable, two_mass_plant)
from rmbench.control.analysis import closed_loop_matrix
from rmbench.control.schedule import certify, design_schedule

# no delay, a 100 kHz loop and a 1 MHz amplifier: the sampled loop with (almost) nothing of the hardware
IDEAL = Hardware(fs=1e5, delay_samples=0, amp_bandwidth=1e6)
# a 25 Hz controller (physics still at 2 kHz: 80 steps a sample) against the 5.9 Hz mode: the hold and
# the one-sample delay cost about 130° there, which the continuous check cannot see
SLOW = Hardware(fs=25.0, substeps=80)


def scaled(k: Controller, gain: float) -> Controller:
    return Controller(k.axes, k.A, k.B, gain * k.C, gain * k.D)


def max_real(plant, k) -> float:
    return float(np.linalg.eigvals(closed_loop_matrix(plant, k)).real.max())


# -- the loop ------------------------------------------------------------------------------------------
def test_sampled_loop_holds_plant_force_reading_controller_and_delay_states(tangential, default_design):
    k = default_design.controller
    phi, lay = sampled_loop(tangential, k, Hardware(delay_samples=2))
    n = tangential.n_axes
    assert phi.shape == (tangential.order + 2 * n + k.order + 2 * n,) * 2
    assert [lay[b].stop - lay[b].start for b in ("plant", "force", "acc_read", "controller", "delay")] == \
        [tangential.order, n, n, k.order, 2 * n]


@pytest.mark.parametrize("gain", [1.0, 5.0])
def test_without_delay_fast_sampling_and_amplifier_the_verdict_is_the_continuous_one(tangential, default_design,
                                                                                     gain):
    k = scaled(default_design.controller, gain)
    # ×1 is the design (stable), ×5 beyond its gain margin (unstable in continuous time)
    assert sampled_stable(tangential, k, IDEAL) == is_stable(tangential, k)


def test_at_a_fast_sample_rate_the_slowest_pole_maps_to_the_continuous_one(tangential, default_design):
    k = default_design.controller
    rate = IDEAL.fs * np.log(sampled_radius(tangential, k, IDEAL))
    # ρ = exp(σ T): the hold's half-sample lag and Tustin's warping move a pole s by O(|s| T), under
    # 1 % for every pole of this loop (|s| ≤ 2π·133 Hz, T = 10 µs)
    assert rate == pytest.approx(max_real(tangential, k), rel=0.01)


def test_default_hardware_runs_the_default_design_stably(tangential, default_design):
    assert sampled_stable(tangential, default_design.controller, Hardware())


def test_certificate_fails_where_the_continuous_check_passes(tangential, default_design):
    cert = certify_sampled([tangential], default_design.controller, SLOW)
    assert cert.continuous_unstable == 0
    assert cert.unstable == 1 and not cert.stable


# -- agreement with the simulation ---------------------------------------------------------------------
def _pulse_response(op, k, hw, duration):
    """Tangential acceleration after a 20 N, 50 ms shaker pulse, stroke guard off, and the positions."""
    n = int(round(duration * hw.fs))
    pulse = np.zeros(n)
    pulse[:max(1, int(0.05 * hw.fs))] = 20.0
    hw = replace(hw, guard=False)
    rec = run_loop(op, k, duration, hardware=hw, shaker={"tangential": pulse}, record_axes=("tangential",))
    return rec.acc[:, 0], rec.pos[:, 0]


def _rms(a, fs, t0, t1):
    return float(np.sqrt(np.mean(a[int(t0 * fs):int(t1 * fs)] ** 2)))


def test_simulated_loop_grows_at_the_rate_the_sampled_loop_predicts(op, tangential, default_design):
    k = default_design.controller
    predicted = SLOW.fs * np.log(sampled_radius(tangential, k, SLOW))  # ≈ 2 /s
    acc, pos = _pulse_response(op, k, SLOW, 1.5)
    assert np.abs(pos).max() < 0.0125  # still linear: the reaction mass has not reached its end stop
    measured = np.log(_rms(acc, SLOW.fs, 1.0, 1.5) / _rms(acc, SLOW.fs, 0.5, 1.0)) / 0.5
    # the simulation is the nonlinear robot, Euler-integrated, with the faster modes' transients still
    # in the 0.5 s windows (three periods of the growing 6.1 Hz oscillation): within 15 %
    assert measured == pytest.approx(predicted, rel=0.15)


def test_simulated_loop_decays_where_the_sampled_loop_is_stable(op, tangential, default_design):
    k = default_design.controller
    hw = Hardware(fs=100.0, substeps=20)
    assert sampled_stable(tangential, k, hw)
    acc, _ = _pulse_response(op, k, hw, 2.0)
    assert _rms(acc, hw.fs, 1.5, 2.0) < 0.1 * _rms(acc, hw.fs, 0.0, 0.5)


# -- the schedule's certificate -----------------------------------------------------------------------
@pytest.fixture(scope="module")
def small_schedule():
    """Two postures of one joint, the 5.9 Hz mode moving ±5 %: two designs, no MuJoCo."""
    rm = ReactionMass(mass=3.0, stiffness=270.0, damping=6.0, stroke=0.0125, force_peak=180.0)
    plants = []
    for scale in (1.05, 0.95):
        w = 2 * np.pi * 5.9 * scale
        plants.append(two_mass_plant(92.8, 92.8 * w**2, 2 * 0.03 * 92.8 * w, rm))
    sch = design_schedule(plants, (np.radians([-10.0, 20.0]),), (1,), np.zeros(6))
    return sch, plants


def test_schedule_certificate_without_hardware_is_the_continuous_one(small_schedule):
    cert = certify(*small_schedule, dense=2)
    assert cert.loop == "continuous" and cert.spectral_radius is None
    assert set(cert.headline()) == {"stable", "min_margin", "points"}


def test_schedule_certificate_with_hardware_checks_the_sampled_loop(small_schedule):
    cert = certify(*small_schedule, dense=2, hardware=Hardware())
    assert cert.loop == "sampled" and cert.stable
    assert cert.spectral_radius.shape == cert.max_real.shape and (cert.spectral_radius < 1).all()
    assert cert.headline()["loop"] == "sampled"


def test_schedule_certificate_fails_on_a_slow_sampled_loop_the_continuous_one_passes(small_schedule):
    cert = certify(*small_schedule, dense=2, hardware=SLOW)
    assert (cert.max_real < 0).all()
    assert not cert.stable and "UNSTABLE on the sampled-data loop" in cert.summary()
    json.dumps(cert.to_dict(), allow_nan=False)


# -- the result ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def two_hardware_certificate(tangential, default_design):
    return certify_sampled([tangential, tangential], default_design.controller, SLOW)


def test_summary_names_the_unstable_count_and_the_continuous_one(two_hardware_certificate):
    s = two_hardware_certificate.summary()
    assert "2 of 2 plants unstable" in s and "continuous check: 0" in s and "25 Hz" in s


def test_to_dict_is_strict_json_with_every_plant(two_hardware_certificate):
    d = json.loads(json.dumps(two_hardware_certificate.to_dict(), allow_nan=False))
    assert d["unstable"] == 2 and len(d["spectral_radius"]) == 2 and d["hardware"]["fs"] == 25.0


def test_plot_draws_the_radius_against_the_limit(two_hardware_certificate):
    import matplotlib

    matplotlib.use("Agg")
    ax = two_hardware_certificate.plot()
    assert len(ax.lines) >= 3  # radii, unstable crosses, the limit 1
