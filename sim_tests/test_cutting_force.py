"""The cutting force of a rigid tool (:func:`rmbench.stability.cutting_force`): its revolution
average is the closed-form average force of a straight-fluted cutter, and a tooth's runout puts a
line at the spindle frequency. Milliseconds a test."""

import math

import numpy as np
import pytest

from rmbench.errors import InputError
from rmbench.stability import STEEL_C45, TI6AL4V, Cutting, cutting_force, tooth_force

RPM, DEPTH, FZ = 600.0, 1e-3, 0.05e-3


def closed_form_average(cutting: Cutting, depth: float, fz: float) -> np.ndarray:
    """Average force over a revolution, (F̄x, F̄y) N in the feed and normal directions (Altintas,
    Manufacturing Automation, ch. 2): F̄x = N a f_z/(8π) [K_t cos 2φ − K_n (2φ − sin 2φ)] and
    F̄y = N a f_z/(8π) [K_t (2φ − sin 2φ) + K_n cos 2φ], each taken from φ_st to φ_ex. The signs
    follow from F_x = −F_t cos φ − F_n sin φ, F_y = F_t sin φ − F_n cos φ with h = f_z sin φ."""
    st, ex = cutting.angles

    def fx(p):
        return cutting.k_t * math.cos(2 * p) - cutting.k_n * (2 * p - math.sin(2 * p))

    def fy(p):
        return cutting.k_t * (2 * p - math.sin(2 * p)) + cutting.k_n * math.cos(2 * p)

    scale = cutting.teeth * depth * fz / (8 * math.pi)
    return scale * np.array([fx(ex) - fx(st), fy(ex) - fy(st)])


def one_revolution(n: int = 20000) -> np.ndarray:
    return np.arange(n) / n * 60.0 / RPM


@pytest.mark.parametrize("cutting", [STEEL_C45, TI6AL4V, Cutting(6e8, 2e8, 3, 0.3, down=False),
                                     Cutting(8e8, 3e8, 2, 1.0)], ids=["steel", "titanium", "up", "slot"])
def test_revolution_average_is_the_closed_form_average_force(cutting):
    f = cutting_force(cutting, RPM, DEPTH, one_revolution(), feed_per_tooth=FZ)
    expected = closed_form_average(cutting, DEPTH, FZ)
    np.testing.assert_allclose(f.mean(axis=0), expected, rtol=2e-3, atol=1e-3 * np.abs(expected).max())


def test_force_has_shape_n_by_2_in_newtons_of_the_order_of_k_t_a_f_z():
    f = cutting_force(STEEL_C45, RPM, DEPTH, one_revolution(500))
    assert f.shape == (500, 2)
    # one tooth's peak tangential force is K_t a f_z = 100 N; at most two teeth cut at half immersion
    assert 50.0 < np.abs(f).max() < 2 * 100.0 * math.hypot(1, STEEL_C45.k_n / STEEL_C45.k_t)


def test_without_runout_the_force_repeats_every_tooth():
    t = one_revolution(6000)
    f = cutting_force(STEEL_C45, RPM, DEPTH, t)
    tooth = 6000 // STEEL_C45.teeth
    np.testing.assert_allclose(f[tooth:], f[:-tooth], atol=1e-9 * np.abs(f).max())


def spectrum_lines(f: np.ndarray, revolutions: int) -> np.ndarray:
    """|amplitude| of the normal force per multiple of the spindle frequency (index k: k × rpm/60)."""
    spec = np.abs(np.fft.rfft(f[:, 1] - f[:, 1].mean())) * 2 / len(f)
    return spec[::revolutions]


def test_runout_puts_a_line_at_the_spindle_frequency():
    revs = 8
    # half a sample off the teeth's entry angles: a sample on the force's step at entry would fall
    # on either side of it by round-off, a different side per tooth
    t = (np.arange(revs * 2400) + 0.5) / 2400 * 60.0 / RPM
    clean = spectrum_lines(cutting_force(STEEL_C45, RPM, DEPTH, t), revs)
    bumped = spectrum_lines(cutting_force(STEEL_C45, RPM, DEPTH, t, runout=10e-6), revs)
    teeth_line = clean[STEEL_C45.teeth]
    assert clean[1] < 1e-6 * teeth_line                  # without runout: tooth-passing harmonics only
    # tooth 0 cuts 10 µm more and tooth 5 10 µm less of a 50 µm feed: a spindle line of several N
    assert bumped[1] > 0.02 * teeth_line and bumped[1] > 1.0


def test_runout_changes_no_average_while_every_tooth_stays_in_the_cut():
    t = one_revolution()
    plain = cutting_force(STEEL_C45, RPM, DEPTH, t).mean(axis=0)
    # 5 µm below a 50 µm feed: the chip added to tooth 0 is the chip taken from tooth 5, wherever
    # f_z sin φ exceeds 5 µm (all but the cut's ends)
    np.testing.assert_allclose(cutting_force(STEEL_C45, RPM, DEPTH, t, runout=5e-6).mean(axis=0), plain,
                               rtol=2e-2)


def test_tooth_force_of_a_rigid_tool_is_the_force_history_at_its_angles():
    force = tooth_force(TI6AL4V, DEPTH, FZ)
    t = one_revolution(50)
    omega = 2 * math.pi * RPM / 60
    expected = np.array([force(omega * ti, (0.0, 0.0)) for ti in t])
    np.testing.assert_array_equal(cutting_force(TI6AL4V, RPM, DEPTH, t, feed_per_tooth=FZ), expected)


@pytest.mark.parametrize("kw", [{"rpm": 0.0}, {"depth": -1e-3}, {"feed_per_tooth": 0.0}, {"runout": np.nan}])
def test_bad_cutting_force_input_is_input_error(kw):
    args = {"rpm": RPM, "depth": DEPTH} | kw
    extra = {k: v for k, v in kw.items() if k in ("feed_per_tooth", "runout")}
    with pytest.raises(InputError):
        cutting_force(STEEL_C45, args["rpm"], args["depth"], one_revolution(10), **extra)
