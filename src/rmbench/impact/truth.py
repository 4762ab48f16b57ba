"""A virtual campaign against its own ground truth: how far the measured FRFs are from the exact
ones, and which exact mode a fitted or predicted frequency stands for.

Only a bench campaign carries the truth (``H_exact``, ``modal_exact``; DATA.md); a real one has
neither, and these functions raise an :class:`~rmbench.errors.InputError` on it.
"""

from __future__ import annotations

import numpy as np

from rmbench.errors import InputError

__all__ = ["frf_error_median", "nearest_exact_frequency"]


def frf_error_median(ds, posture: int) -> float:
    """The median over one posture's FRF lines (every frequency, output and input) of the
    magnitude error ``| |H| / |H_exact| - 1 |`` (a ratio, 0.01 = 1 %); lines where it is not
    defined (``H_exact`` zero, a posture not measured) are left out.

    Parameters
    ----------
    ds : xarray.Dataset
        A campaign with ground truth: ``H`` and ``H_exact``, each (posture, freq, out, inp), m/N.
    posture : int
        Index along ``posture``.
    """
    _need(ds, "H_exact")
    sel = ds.isel(posture=posture)
    err = np.abs(np.abs(sel.H.values) / np.abs(sel.H_exact.values) - 1)
    return float(np.nanmedian(err))


def nearest_exact_frequency(ds, posture: int, band: str, f_hz: float) -> float:
    """The exact natural frequency of ``band`` at one posture nearest ``f_hz``, Hz; NaN where the
    band has no exact mode there.

    Parameters
    ----------
    ds : xarray.Dataset
        A campaign with ground truth: ``modal_exact`` (posture, mode, param) and ``mode_band``.
    posture : int
        Index along ``posture``.
    band : str
        The band whose exact modes are candidates (``"low"``, ``"high"``).
    f_hz : float
        The frequency to match, Hz.
    """
    _need(ds, "modal_exact")
    exact_f = ds.modal_exact.sel(param="f_n").values[posture]
    cand = exact_f[(ds.mode_band.values == band) & np.isfinite(exact_f)]
    if not len(cand):
        return float("nan")
    return float(cand[np.argmin(np.abs(cand - f_hz))])


def _need(ds, name: str) -> None:
    if name not in ds:
        raise InputError(f"the campaign has no ground truth ({name!r}): only a virtual campaign carries it")
