"""Mode shapes compared: the one MAC and the one pairing of two sets of modes that every stage uses."""

import numpy as np
import pytest

from rmbench.modeshape import mac, pair_modes

_RNG = np.random.default_rng(7)
_SHAPES = _RNG.normal(size=(4, 6)) + 1j * _RNG.normal(size=(4, 6))


def test_a_shape_matches_itself_fully():
    assert mac(_SHAPES[0], _SHAPES[0]) == pytest.approx(1.0)


def test_orthogonal_shapes_share_nothing():
    a = np.array([1.0, 1j, 0.0])
    b = np.array([1.0, -1j, 2.0])        # aᴴb = 1 + (−i)(−i) = 0
    assert mac(a, b) == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize("factor", [3.0, -0.5, 2.0 - 5.0j, 1e-6j],
                         ids=["real", "negative", "complex", "tiny-imaginary"])
def test_mac_ignores_a_complex_scaling_of_either_shape(factor):
    base = mac(_SHAPES[0], _SHAPES[1])
    assert mac(factor * _SHAPES[0], _SHAPES[1]) == pytest.approx(base, rel=1e-12)
    assert mac(_SHAPES[0], factor * _SHAPES[1]) == pytest.approx(base, rel=1e-12)


def test_mac_of_two_sets_is_a_matrix_of_rows_against_rows():
    out = mac(_SHAPES[:3], _SHAPES[1:])
    assert out.shape == (3, 3)
    assert out[1, 0] == pytest.approx(1.0)                    # row 1 of a is row 0 of b
    assert out[0, 2] == pytest.approx(mac(_SHAPES[0], _SHAPES[3]))


def test_a_single_shape_against_a_set_drops_its_axis():
    assert mac(_SHAPES[0], _SHAPES).shape == (4,)
    assert mac(_SHAPES, _SHAPES[0]).shape == (4,)
    assert np.ndim(mac(_SHAPES[0], _SHAPES[1])) == 0


def test_a_shape_of_zero_norm_gives_the_value_asked_for():
    zero = np.zeros(6)
    assert np.isnan(mac(zero, _SHAPES[0]))
    assert mac(zero, _SHAPES[0], zero=0.0) == 0.0


def test_a_shape_holding_nan_gives_nan_whatever_the_zero_value():
    assert np.isnan(mac(np.full(6, np.nan), _SHAPES[0], zero=0.0))


def test_pairing_finds_permuted_modes():
    f = np.array([10.0, 20.0, 30.0, 40.0])
    perm = np.array([2, 0, 3, 1])
    rows, cols = pair_modes(f, f[perm], _SHAPES, _SHAPES[perm], freq_scale=0.15)
    assert rows.tolist() == [0, 1, 2, 3]
    assert perm[cols].tolist() == [0, 1, 2, 3]


def test_pairing_weighs_shape_against_frequency():
    # two modes 1 % apart whose shapes swapped: shape decides which is which, not frequency
    f = np.array([100.0, 101.0])
    rows, cols = pair_modes(f, f, _SHAPES[:2], _SHAPES[1::-1], freq_scale=0.15)
    assert cols.tolist() == [1, 0]


def test_pairing_drops_pairs_costing_more_than_the_gate():
    f = np.array([10.0, 20.0])
    # mode 1 has the same shape but 30 % off in frequency: cost ln(1.3) / 0.15 ≈ 1.75 > 1.5
    rows, cols = pair_modes(f, [10.0, 26.0], _SHAPES[:2], _SHAPES[:2], freq_scale=0.15, max_cost=1.5)
    assert rows.tolist() == [0] and cols.tolist() == [0]


def test_pairing_drops_pairs_outside_the_frequency_window():
    rows, cols = pair_modes([10.0, 20.0], [10.5, 31.0], _SHAPES[:2], _SHAPES[:2], freq_scale=0.4, window=1.5)
    assert rows.tolist() == [0] and cols.tolist() == [0]


def test_a_mode_without_shape_pairs_by_frequency_alone():
    shapes = _SHAPES[:2].copy()
    shapes[0] = np.nan
    rows, cols = pair_modes([10.0, 20.0], [20.2, 10.1], shapes, _SHAPES[1::-1], freq_scale=0.15, max_cost=1.5)
    assert dict(zip(rows.tolist(), cols.tolist())) == {0: 1, 1: 0}


def test_relative_frequency_distance_is_taken_from_the_second_set():
    # |1 / 1.05 − 1| / 0.05 ≈ 0.95 passes a gate of 0.97; |1.05 / 1 − 1| / 0.05 = 1 does not
    same = np.ones((1, 3))
    assert len(pair_modes([1.0], [1.05], same, same, freq_scale=0.05, freq="relative", max_cost=0.97)[0]) == 1
    assert len(pair_modes([1.05], [1.0], same, same, freq_scale=0.05, freq="relative", max_cost=0.97)[0]) == 0


def test_pairing_with_an_empty_set_pairs_nothing():
    rows, cols = pair_modes([], [10.0], np.zeros((0, 3, 2)), np.ones((1, 3, 2)), freq_scale=0.15)
    assert rows.shape == cols.shape == (0,)


def test_a_mode_beyond_the_gate_does_not_displace_a_closer_pair():
    # seed 000's IRB6660 at (1800, −200, 0): measured 17.62 and 18.03 Hz, one model mode at
    # 18.13 Hz and the next at 25.7 Hz. The 18.03 Hz mode is the closer partner; forcing both onto
    # a partner made every choice an exact tie of summed |ln| distances
    no_shape = np.full((3, 2), np.nan)
    rows, cols = pair_modes([18.03, 17.62, 20.63], [18.13, 20.69, 25.70], no_shape, np.ones((3, 2)),
                            freq_scale=0.15, max_cost=1.5)
    assert dict(zip(rows.tolist(), cols.tolist())) == {0: 0, 2: 1}


def test_two_modes_between_two_partners_pair_in_order():
    # both partners lie above both modes: crossed and in-order pairs sum to the same |ln| distance,
    # and a physical drift keeps the order
    no_shape = np.full((2, 2), np.nan)
    rows, cols = pair_modes([17.62, 18.03], [18.13, 18.50], no_shape, no_shape, freq_scale=0.15, max_cost=1.5)
    assert cols[np.argsort(rows)].tolist() == [0, 1]


def test_a_pair_outside_the_window_leaves_its_partner_free_for_another():
    # 10 Hz may pair only with 10.5 Hz (20.5 is beyond a factor 1.5); 12 Hz then takes 15 Hz
    no_shape = np.full((2, 2), np.nan)
    rows, cols = pair_modes([10.0, 12.0], [10.5, 15.0], no_shape, no_shape, freq_scale=0.4, window=1.5)
    assert dict(zip(rows.tolist(), cols.tolist())) == {0: 0, 1: 1}
