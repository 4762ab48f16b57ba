"""Exact modal parameters in the seed's parameterisation (METHODS.md §2, DATA.md)."""

import numpy as np
import pytest

from rmbench.robot import PARAMS


def test_params_are_the_16_named_reals_per_mode(irb_op):
    table = irb_op.modes("low")
    p = table.params()
    assert p.shape == (len(table), 16)
    assert len(PARAMS) == 16
    np.testing.assert_allclose(p[:, PARAMS.index("f_n")], table.f_n)
    np.testing.assert_allclose(p[:, PARAMS.index("phiR_1aY_im")], table.phi_r[:, 3].imag)
    np.testing.assert_allclose(p[:, PARAMS.index("phiL_1Y_re")], table.phi_l[:, 1].real)


@pytest.mark.parametrize("band", ["low", "high"])
def test_left_eigenvector_is_normalised_on_1aY(irb_op, band):
    np.testing.assert_allclose(irb_op.modes(band).phi_l[:, 3], 1.0, atol=1e-12)


@pytest.mark.parametrize("band", ["low", "high"])
def test_visible_modes_reconstruct_the_band(irb_op, band):
    # the listed modes carry the band: outside-band modes only add a smooth residual, < 10 % of the
    # peak near the resonances
    table = irb_op.modes(band)
    b = irb_op.robot.bands[band]
    freq = table.f_n
    exact = irb_op.frf(freq, s_1a=b.s_1a)
    synth = table.frf(freq)
    assert np.abs(synth - exact).max() < 0.1 * np.abs(exact).max()


def test_reciprocal_structure_gives_left_proportional_to_right(irb_op):
    # symmetric M, C, K: φL ∝ φR (METHODS.md §2); the ratio is the same for all four coordinates
    table = irb_op.modes("high")
    ratio = table.phi_l / table.phi_r
    np.testing.assert_allclose(ratio, ratio[:, :1] * np.ones((1, 4)), rtol=1e-6)


def test_to_dict_lists_coordinates_as_re_im_pairs(irb_op):
    d = irb_op.modes("low").to_dict()[0]
    assert set(d) >= {"f_n", "zeta", "phiL", "phiR"}
    assert set(d["phiR"]) == {"1X", "1Y", "1aX", "1aY"}
    # normalised to 1 + 0j at the drive point: exact up to one rounding (BLAS kernels differ by CPU)
    assert d["phiL"]["1aY"] == [pytest.approx(1.0, abs=1e-12), pytest.approx(0.0, abs=1e-12)]
