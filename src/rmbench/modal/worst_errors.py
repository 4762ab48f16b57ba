"""The worst of a campaign fit: how many band fits hold, and the largest errors against the
campaign's exact modes over every (posture, mode).

:meth:`~rmbench.modal.campaign_result.CampaignFit.truth_errors` gives percentiles of the same
errors; a quick check of a small campaign (three postures) reads its extremes instead.
"""

from __future__ import annotations

import numpy as np

__all__ = ["band_fits_ok", "worst_truth_errors"]


def band_fits_ok(fit) -> tuple[int, int]:
    """How many of a campaign fit's band fits hold, and how many there are.

    Parameters
    ----------
    fit : xarray.Dataset
        :func:`~rmbench.modal.campaign_fit.fit_campaign`'s dataset (``fit_ok``, (posture, fit_band)).

    Returns
    -------
    (int, int)
        Band fits with ``fit_ok``, and all (postures x bands).
    """
    return int(fit.fit_ok.sum()), int(fit.fit_ok.size)


def worst_truth_errors(fit) -> dict | None:
    """The largest absolute relative errors of the fitted natural frequencies and damping ratios
    against the exact modes, and the smallest MACs of the fitted mode shapes, over every
    (posture, mode) paired with an exact mode; None for a fit without ground truth.

    Parameters
    ----------
    fit : xarray.Dataset
        :func:`~rmbench.modal.campaign_fit.fit_campaign`'s dataset; ground truth as ``f_err``,
        ``zeta_err``, ``mac_phiR``, ``mac_phiL`` (posture, mode).

    Returns
    -------
    dict or None
        ``f_err_max`` and ``zeta_err_max`` (ratios, 0.01 = 1 %), ``mac_phiR_min`` and
        ``mac_phiL_min`` (0..1).
    """
    if "f_err" not in fit:
        return None
    return {"f_err_max": float(np.nanmax(np.abs(fit.f_err))),
            "zeta_err_max": float(np.nanmax(np.abs(fit.zeta_err))),
            "mac_phiR_min": float(np.nanmin(fit.mac_phiR)),
            "mac_phiL_min": float(np.nanmin(fit.mac_phiL))}
