"""Receptance matrices rebuilt from predicted (or fitted) modal parameters (Eq. 15).

    H = predicted_frf(out, freq)                 # (posture, freq, 4, 4), m/N
    H = predicted_frf(out, freq, band="high")    # that band's modes and residual terms
    predicted_frf_dataset(out)                   # on frf_lines(), as a dataset with the postures

``out`` is a prediction (:meth:`~rmbench.predict.PosturePredictor.predict`) or a modal fit; a
veering cluster's modes contribute through the cluster's poles and full residues where the
prediction carries them (``cluster_pole``, ``cluster_residue``; :mod:`rmbench.predict.cluster`).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from rmbench.errors import InputError
from rmbench.modal.campaign_fit import COORDS, mode_vectors
from rmbench.modal.mdof import synthesize
from rmbench.modal.residual import residual_frf
from rmbench.robot.modes import PARAMS

__all__ = ["predicted_frf", "frf_lines", "predicted_frf_dataset"]


def predicted_frf(pred: xr.Dataset, freq, posture: int | None = None, *, band: str | None = None) -> np.ndarray:
    """Receptance matrices rebuilt from predicted (or fitted) modal parameters (Eq. 15).

    By default every mode of every band contributes at every frequency, so each band's matrix
    carries the other band's modes (only those) as residual terms. With ``band``, that band's modes
    alone, plus its residual terms where the dataset has them (``residual``: the modal fit's
    stand-ins for every mode outside the band, :mod:`rmbench.modal.residual`; valid within the
    band's lines only): the form to use where a band's ``1a`` is its
    own point (the bands' sensor spacings differ, so the other band's mode vectors do not apply).

    Parameters
    ----------
    pred : xarray.Dataset
        A prediction (or a modal fit): ``modal``, ``phiL_1aY``; optionally ``residual``.
    freq : array_like, shape (n_freq,), Hz
    posture : int, optional
        One posture; by default all.
    band : str, optional
        One band's modes and residual terms.

    Returns
    -------
    ndarray, shape (n_posture, n_freq, 4, 4) or (n_freq, 4, 4), complex, m/N; rows and columns
    1X, 1Y, 1aX, 1aY.
    """
    if tuple(pred["param"].values) != PARAMS:
        raise InputError("the FRF matrix needs all 16 parameters per mode (DATA.md order)")
    freq = np.asarray(freq, float)
    in_band = np.ones(pred.sizes["mode"], bool)
    residual = None
    if band is not None:
        bands = pred["mode_band"].values if "mode_band" in pred.coords else np.array([])
        in_band = bands == band
        if not in_band.any():
            raise InputError(f"no mode of the {band!r} band in the dataset")
        if "residual" in pred and band in pred["residual"]["fit_band"].values:
            r = pred["residual"].sel(fit_band=band)
            residual = residual_frf(r.transpose("posture", "term", "out", "inp").values, freq,
                                    float(r["residual_f_max"]))
    which = range(pred.sizes["posture"]) if posture is None else [posture]
    cl_pole = pred["cluster_pole"].values if "cluster_pole" in pred else None
    out = []
    for p in which:
        prm = pred.modal.values[p]
        ok = np.isfinite(prm[:, 0]) & np.isfinite(prm[:, 1]) & in_band
        h = np.zeros((len(freq), 4, 4), complex)
        if cl_pole is not None:         # veering clusters: their full residues (module docstring)
            cl = np.isfinite(cl_pole[p]) & in_band
            if cl.any():
                s = 2j * np.pi * freq[:, None]
                lam, R = cl_pole[p, cl], pred["cluster_residue"].transpose("posture", "mode", "out", "inp").values[p, cl]
                h = (np.einsum("fm,moi->foi", 1 / (s - lam), R)
                     + np.einsum("fm,moi->foi", 1 / (s - lam.conj()), R.conj()))
                ok &= ~cl
        vecs = [mode_vectors(pred, p, i) for i in np.flatnonzero(ok)]
        wn, z = 2 * np.pi * prm[ok, 0], prm[ok, 1]
        poles = -z * wn + 1j * wn * np.sqrt(1 - z**2)
        h = h + synthesize(freq, poles, np.array([v[0] for v in vecs]).reshape(-1, 4),
                           np.array([v[1] for v in vecs]).reshape(-1, 4))
        if residual is not None and np.all(np.isfinite(residual[p])):
            h = h + residual[p]
        out.append(h)
    return out[0] if posture is not None else np.stack(out)


def frf_lines() -> np.ndarray:
    """The default lines of a predicted FRF, Hz: 2-60 Hz every 0.05 Hz and 500-1500 Hz every
    0.5 Hz (both campaign bands with margin, finer than their lines), shape (3160,)."""
    return np.concatenate([np.arange(2.0, 60.0, 0.05), np.arange(500.0, 1500.0, 0.5)])


def predicted_frf_dataset(pred: xr.Dataset, *, freq=None, model: str = "", source: str = "") -> xr.Dataset:
    """The receptance matrices of a prediction (:func:`predicted_frf`) as a dataset with the
    postures' coordinates, on ``freq`` (Hz; default :func:`frf_lines`); ``model`` and ``source``
    (the predictor's kind and file) go into the attributes."""
    freq = frf_lines() if freq is None else np.asarray(freq, float)
    H = predicted_frf(pred, freq)
    return xr.Dataset({"H": (("posture", "freq", "out", "inp"), H)},
                      coords={"posture": pred.posture.values, "x": ("posture", pred["x"].values),
                              "y": ("posture", pred["y"].values), "theta": ("posture", pred["theta"].values),
                              "freq": freq, "out": list(COORDS), "inp": list(COORDS)},
                      attrs={"kind": "predicted_frf", "units": "m/N", "model": model, "predictor": source})
