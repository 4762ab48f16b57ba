"""The exact FRF agrees with MuJoCo's time-domain response to a small force pulse.

The pulse response of the nonlinear model, integrated with RK4 from the deflected equilibrium, is
exponentially windowed, exp(−σt), and transformed. Windowing evaluates the transfer function at
s = σ + iω exactly, so the windowed measurement is compared with the exact receptance at the same s,
at each modal peak (ω = ω_n). Displacements come from MuJoCo's nonlinear kinematics of the sites.
"""

import numpy as np
import pytest

from rmbench.robot.simulate import simulate, site_positions, stable_step

S_1A = 0.020  # the tool MJCF's site p1a sits 20 mm up the tool
SITES = ("tool_tip", "tool_p1a")


def _windowed_frf(op, band, column, *, record, pulse, amplitude, tau):
    dt = 5e-6
    assert dt < stable_step(op)
    n = int(record / dt)
    t = np.arange(n) * dt
    force = np.where(t < pulse, amplitude * np.sin(np.pi * t / pulse), 0.0)
    rows = op.coordinate_map(("1X", "1Y", "1aX", "1aY"), s_1a=S_1A)
    qpos = simulate(op, force[:, None] * rows[column][None, :], dt=dt)
    keep = slice(None, None, 2)
    pos = site_positions(op, qpos[keep], SITES)
    pos0 = site_positions(op, op.data.qpos[None], SITES)[0]
    disp = (pos - pos0)[:, :, :2].reshape(len(pos), 4)[:, [0, 1, 2, 3]]  # 1X, 1Y, 1aX, 1aY
    t_out = t[keep] + dt  # positions are at the end of each step
    sigma = 1 / tau
    result = []
    for f_n in op.modes(band, s_1a=S_1A).f_n:
        s = sigma + 2j * np.pi * f_n
        f_s = dt * np.sum(force * np.exp(-s * (t + dt / 2)))  # zero-order-held force
        y_s = 2 * dt * np.exp(-s * t_out) @ disp
        exact = op.linear.modes().transfer(np.array([s]), rows, rows)[0][:, column]
        result.append((f_n, y_s / f_s, exact))
    return result


def _check(result):
    for f_n, measured, exact in result:
        direct = abs(exact).max()
        # within 1 % in magnitude at every modal peak; entries far below the column's largest
        # (cross terms under 5 %) are held to 1 % of that largest entry instead, the level of
        # quadrature error in the transform
        big = abs(exact) >= 0.05 * direct
        rel = np.abs(np.abs(measured) - np.abs(exact)) / np.abs(exact)
        assert np.all(rel[big] < 0.01), (f_n, rel)
        assert np.all(np.abs(measured - exact)[~big] < 0.01 * direct), f_n


@pytest.mark.parametrize("column", [0, 1], ids=["force_1X", "force_1Y"])
def test_high_band_pulse_response_matches_exact_frf(irb_op, column):
    # 0.2 ms hammer-like pulse; σ = 40/s makes the low modes' tail negligible after 0.25 s
    _check(_windowed_frf(irb_op, "high", column, record=0.25, pulse=2e-4, amplitude=300.0, tau=0.025))


@pytest.mark.slow
def test_low_band_pulse_response_matches_exact_frf(irb_op):
    # 5 ms pulse; σ = 4/s with a 1.5 s record leaves e^-6 of the slowest mode's envelope
    _check(_windowed_frf(irb_op, "low", 0, record=1.5, pulse=5e-3, amplitude=200.0, tau=0.25))
