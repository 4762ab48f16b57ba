"""A virtual campaign against its ground truth: the FRFs' magnitude error, the nearest exact mode."""

import numpy as np
import pytest
import xarray as xr

from rmbench.errors import InputError
from rmbench.impact import frf_error_median, nearest_exact_frequency


def _campaign(scale):
    """Two postures of 3 lines x 2 x 2, H = H_exact * scale; exact modes 10, 30 Hz (low) and
    800 Hz (high), a NaN slot (high) the second posture lacks."""
    exact = np.full((2, 3, 2, 2), 1e-6 + 1e-6j)
    modal = np.array([[[10.0, 0.01], [30.0, 0.02], [800.0, 0.03]],
                      [[11.0, 0.01], [31.0, 0.02], [np.nan, np.nan]]])
    return xr.Dataset({"H": (("posture", "freq", "out", "inp"), exact * scale),
                       "H_exact": (("posture", "freq", "out", "inp"), exact),
                       "modal_exact": (("posture", "mode", "param"), modal)},
                      coords={"param": ["f_n", "zeta"], "mode_band": ("mode", ["low", "low", "high"])})


def test_the_frf_error_is_the_median_magnitude_ratio_error_of_one_posture():
    scale = np.ones((2, 3, 2, 2))
    scale[0] = np.array([1.01, 1.02, 0.90])[:, None, None]     # |errors| 0.01, 0.02, 0.10
    ds = _campaign(scale)
    assert frf_error_median(ds, 0) == pytest.approx(0.02)
    assert frf_error_median(ds, 1) == 0.0


def test_the_nearest_exact_frequency_is_taken_from_the_band_asked():
    ds = _campaign(1.0)
    assert nearest_exact_frequency(ds, 0, "low", 22.0) == 30.0
    assert nearest_exact_frequency(ds, 0, "high", 22.0) == 800.0
    assert nearest_exact_frequency(ds, 1, "low", 5.0) == 11.0


def test_no_exact_mode_in_the_band_is_nan():
    assert np.isnan(nearest_exact_frequency(_campaign(1.0), 1, "high", 800.0))


def test_a_campaign_without_ground_truth_is_a_one_line_error():
    ds = _campaign(1.0).drop_vars(["H_exact", "modal_exact"])
    with pytest.raises(InputError, match="no ground truth.*H_exact"):
        frf_error_median(ds, 0)
    with pytest.raises(InputError, match="no ground truth.*modal_exact"):
        nearest_exact_frequency(ds, 0, "low", 10.0)
