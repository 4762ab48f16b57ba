"""The worst of a campaign fit: band fits that hold, largest errors against the exact modes."""

import numpy as np
import pytest
import xarray as xr

from rmbench.modal.worst_errors import band_fits_ok, worst_truth_errors


def _fit(truth=True):
    dims = ("posture", "mode")
    out = xr.Dataset({"fit_ok": (("posture", "fit_band"), np.array([[True, False], [True, True]]))})
    if truth:
        out = out.assign(f_err=(dims, np.array([[1e-3, -4e-3], [np.nan, 2e-3]])),
                         zeta_err=(dims, np.array([[-0.05, 0.01], [0.02, np.nan]])),
                         mac_phiR=(dims, np.array([[0.99, 0.97], [np.nan, 0.999]])),
                         mac_phiL=(dims, np.array([[0.98, 0.995], [0.96, np.nan]])))
    return out


def test_band_fits_ok_counts_the_fits_that_hold_of_all():
    assert band_fits_ok(_fit()) == (3, 4)


def test_worst_truth_errors_are_the_largest_magnitudes_and_smallest_macs_ignoring_unpaired_modes():
    assert worst_truth_errors(_fit()) == pytest.approx(
        {"f_err_max": 4e-3, "zeta_err_max": 0.05, "mac_phiR_min": 0.97, "mac_phiL_min": 0.96})


def test_a_fit_without_ground_truth_has_no_worst_errors():
    assert worst_truth_errors(_fit(truth=False)) is None
