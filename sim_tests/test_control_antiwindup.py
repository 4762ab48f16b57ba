"""Anti-windup (observer form) and the amplifier's force limit in the simulated loop: off by
default, a no-op while the coil is within its limit, and counted saturation events."""

import json

import numpy as np
import pytest

from rmbench.control import Hardware, run_loop
from rmbench.control.antiwindup import observer_gain
from rmbench.errors import InputError

FS = 2000


def burst(amplitude=40.0, seconds=0.5, duration=2.0):
    """A sine at the tangential mode (5.9 Hz) for ``seconds``, then nothing: (n,) N."""
    t = np.arange(int(duration * FS)) / FS
    return np.where(t < seconds, amplitude * np.sin(2 * np.pi * 5.9 * t), 0.0)


def run(op, k, hw=None, shaker=None, duration=2.0):
    return run_loop(op, k, duration, shaker={"tangential": burst() if shaker is None else shaker},
                    record_axes=("tangential",), hardware=hw)


def traces_equal(a, b):
    return all(np.array_equal(getattr(a, f), getattr(b, f)) for f in ("acc", "pos", "force"))


def test_anti_windup_is_off_by_default_and_off_is_the_plain_loop_bit_for_bit(op, default_design):
    k = default_design.controller
    assert Hardware().anti_windup is False
    limited = Hardware(force_limit=5.0)
    assert traces_equal(run(op, k, Hardware(anti_windup=False, force_limit=5.0)), run(op, k, limited))
    assert traces_equal(run(op, k, Hardware(anti_windup=False)), run(op, k))


def test_anti_windup_leaves_an_unsaturated_loop_unchanged(op, default_design):
    k = default_design.controller
    small = burst(amplitude=5.0)
    plain, aw = run(op, k, shaker=small), run(op, k, Hardware(anti_windup=True), shaker=small)
    assert plain.saturated == 0 and aw.saturated == 0
    # u_sat − u is zero but for the rounding of (base + u) − base, ~1e-14 N
    np.testing.assert_allclose(aw.acc, plain.acc, rtol=0, atol=1e-9)


def test_anti_windup_gain_keeps_the_conditioned_controller_stable(default_design):
    A, B, C, D = default_design.controller.discretize(FS)
    L = observer_gain(A, B, C, D)
    assert L.shape == (A.shape[0], 1)
    assert np.abs(np.linalg.eigvals(A - L @ C)).max() < 1.0


def test_anti_windup_under_a_5_newton_limit_saturates_less_and_recovers_as_well(op, default_design):
    k = default_design.controller
    plain = run(op, k, Hardware(force_limit=5.0))
    aw = run(op, k, Hardware(force_limit=5.0, anti_windup=True))
    free = run(op, None)
    after = slice(int(0.8 * FS), None)  # 0.3 s after the burst
    rms = {n: float(np.sqrt(np.mean(r.acc[after, 0] ** 2))) for n, r in
           (("plain", plain), ("aw", aw), ("open", free))}
    assert np.isfinite(aw.acc).all() and aw.stroke_used < 1 and aw.guard_trips == 0
    # the 40 N burst needs ~8x the 5 N limit: both loops sit at the limit most of the time; the
    # corrected state stops asking for force the coil cannot give (measured 67 % → 65 % of samples)
    assert aw.saturated < plain.saturated - 0.01
    # this H∞ design is itself stable and band-pass, so there is little to wind up: recovery is
    # the same within the 2 % measured (a relay-like loop at the limit either way), and both damp
    # the free robot's ringing
    assert rms["aw"] == pytest.approx(rms["plain"], rel=0.05)
    assert rms["aw"] < 0.7 * rms["open"]


def test_saturation_events_are_counted_and_reported(op, default_design):
    k = default_design.controller
    rec = run(op, k, Hardware(force_limit=5.0))
    # the 5.9 Hz burst drives the command through the limit about twice a period (0.5 s: ~6 periods)
    assert rec.saturated > 0 and rec.saturation_events >= 5
    d = json.loads(json.dumps(rec.to_dict(), allow_nan=False))
    assert d["saturation_events"] == rec.saturation_events
    assert f"({rec.saturation_events} saturation event(s))" in rec.summary()
    assert run(op, k, shaker=burst(amplitude=5.0)).saturation_events == 0


def test_a_force_limit_that_is_not_positive_is_input_error():
    with pytest.raises(InputError):
        Hardware(force_limit=0.0)
