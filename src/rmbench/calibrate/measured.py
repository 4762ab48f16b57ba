"""The measured side of a diagnosis: what a real test gives, read and fitted.

The data are read as a real test's would be: FRFs, coherence where present, the postures, and the
test design. Ground-truth variables, the robot's name or file and any record of how the data were
made are never read; a dataset that carries ground truth gets a warning (they are dropped here).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import xarray as xr

from rmbench.errors import InputError
from rmbench.robot import Posture

__all__ = ["MeasuredModes", "GapDataWarning", "measured_data", "fit_measured", "modes_of_fit", "frf_targets",
           "postures_of"]

_TRUTH = ("H_exact", "H_exact_bare", "modal_exact", "modal_exact_bare")
_KEEP_ATTRS = ("config", "rmbench_dataset_version", "original_kind", "sensor_spacing_low",
               "sensor_spacing_high", "table_z")


class GapDataWarning(UserWarning):
    """Something in the data a diagnosis must not use was found and set aside."""


@dataclass(frozen=True)
class MeasuredModes:
    """Fitted modes of the measurement at one posture in one band.

    Attributes
    ----------
    f_n, zeta : ndarray, shape (n,)
    f_std, zeta_std : ndarray, shape (n,)
        Standard errors (Hz, ratio).
    residue : ndarray, shape (n, 4, 4), complex
        ``φR φLᵀ`` of each mode.
    residue_std : ndarray, shape (n,)
        Relative standard error of the residue (from those of φR and φL).
    mode_id : ndarray of int, shape (n,)
        Tracked mode number over the campaign (rmbench.modal's ``mode``).
    fit_ok : bool
        The band fit's verdict (rmbench.modal).
    """

    f_n: np.ndarray
    zeta: np.ndarray
    f_std: np.ndarray
    zeta_std: np.ndarray
    residue: np.ndarray
    residue_std: np.ndarray
    mode_id: np.ndarray = None
    fit_ok: bool = True

    def __len__(self) -> int:
        return len(self.f_n)


def measured_data(ds: xr.Dataset) -> xr.Dataset:
    """The part of a dataset a real test would give: H, coherence, postures, the test design.

    Ground-truth variables are dropped with a :class:`GapDataWarning`, and so are every attribute
    but the configuration (read for its test design only) and the layout's version.

    Raises
    ------
    InputError
        No measured receptance, or no postures with positions.
    """
    if "H" not in ds:
        raise InputError("the data have no measured receptance 'H' (posture, freq, out, inp)")
    found = [v for v in _TRUTH if v in ds]
    if found:
        warnings.warn(f"the data carry ground-truth variables ({', '.join(found)}) that a real test "
                      "would not have: they are set aside and not read", GapDataWarning, stacklevel=2)
    keep = [v for v in ("H", "coherence") if v in ds]
    coords = [c for c in ("x", "y", "theta", "ok", "reason", "band", "out", "inp") if c in ds.coords]
    out = xr.Dataset({v: ds[v] for v in keep}, coords={c: ds[c] for c in coords})
    out.attrs = {k: ds.attrs[k] for k in _KEEP_ATTRS if k in ds.attrs}
    if not all(c in out.coords for c in ("x", "y", "theta")):
        raise InputError("the data have no posture positions (x, y, theta): a diagnosis compares "
                         "the model at the measured postures")
    if "band" not in out.coords:
        raise InputError("the data have no 'band' coordinate on freq")
    return out


def postures_of(ds: xr.Dataset) -> list[Posture]:
    """The measured postures (those with finite positions and ok)."""
    ok = ds.ok.values if "ok" in ds.coords else np.ones(ds.sizes["posture"], bool)
    out = []
    for x, y, t, good in zip(ds.x.values, ds.y.values, ds.theta.values, ok):
        if not (good and np.isfinite([x, y, t]).all()):
            raise InputError("a measured posture has no position or was not measured; drop it "
                             "from the data first")
        out.append(Posture(float(x), float(y), float(t)))
    return out


def fit_measured(ds: xr.Dataset, bands, *, workers: int | None = None) -> tuple[list[dict], xr.Dataset]:
    """Fit the measured FRFs of every posture and band (rmbench.modal, blind).

    Returns
    -------
    modes : list of dict
        Per posture, ``{band: MeasuredModes}``.
    fit : xarray.Dataset
        The modal dataset of :func:`rmbench.modal.campaign_fit.fit_campaign`.
    """
    from rmbench.modal.campaign_fit import fit_campaign

    fit = fit_campaign(ds, bands=tuple(bands), workers=workers)
    return modes_of_fit(fit, bands), fit


def modes_of_fit(fit: xr.Dataset, bands) -> list[dict]:
    """Per posture ``{band: MeasuredModes}`` of a modal fit (:func:`rmbench.modal.fit_campaign`'s
    dataset, or a ``rmbench modal fit --out`` file)."""
    from rmbench.modal.campaign_fit import mode_vectors

    n_post = fit.sizes["posture"]
    out = []
    fit_bands = list(fit.fit_band.values)
    for p in range(n_post):
        per = {}
        for b in bands:
            sel = [m for m in range(fit.sizes["mode"]) if fit.mode_band.values[m] == b
                   and np.isfinite(fit.modal.values[p, m, 0])]
            prm, std = fit.modal.values[p, sel], fit.modal_std.values[p, sel]
            res, rstd = [], []
            for m in sel:
                phi_r, phi_l = mode_vectors(fit, p, m)
                res.append(np.outer(phi_r, phi_l))
                s = fit.modal_std.values[p, m]
                var_r = np.nansum(s[8:16] ** 2) / max(np.sum(np.abs(phi_r) ** 2), 1e-300)
                var_l = np.nansum(s[2:8] ** 2) / max(np.sum(np.abs(phi_l) ** 2), 1e-300)
                rstd.append(np.sqrt(var_r + var_l))
            ok = bool(fit.fit_ok.values[p, fit_bands.index(b)]) if b in fit_bands else False
            per[b] = MeasuredModes(f_n=prm[:, 0], zeta=prm[:, 1], f_std=std[:, 0], zeta_std=std[:, 1],
                                   residue=np.array(res, complex).reshape(len(sel), 4, 4),
                                   residue_std=np.array(rstd), mode_id=np.array(sel, int), fit_ok=ok)
        out.append(per)
    return out


def frf_targets(ds: xr.Dataset, fit: xr.Dataset, bands, averages: int,
                scatter: dict | None = None) -> list[dict]:
    """Per posture ``{band: FrfTarget}``: the measured FRFs the residual compares.

    Each line's relative noise comes from the coherence (``√((1 − γ²) / (2 n γ²))`` for an H1
    estimate of ``n`` averages) or, for data without coherence (a UFF58 import), from the modal
    fit's residual (its NMSE spread evenly over the band: constant absolute noise per FRF).
    ``scatter`` maps a band to its hammer's direction scatter (rad), whose leak from the other
    direction's response is added to the cross entries (:func:`rmbench.calibrate.residual.hammer_leak`).
    """
    from rmbench.calibrate.residual import frf_target, hammer_leak

    out = []
    fit_bands = list(fit.fit_band.values)
    for p in range(ds.sizes["posture"]):
        per = {}
        for b in bands:
            sel = ds.band.values == b
            freq, H = ds.freq.values[sel], ds.H.values[p][sel]
            if "coherence" in ds:
                g2 = np.clip(ds.coherence.values[p][sel], 1e-6, 1 - 1e-12)
                noise = np.sqrt((1 - g2) / (2 * averages * g2))
            else:
                nmse = fit.nmse.values[p, fit_bands.index(b)] if b in fit_bands else np.full((4, 4), np.nan)
                nmse = np.where(np.isfinite(nmse), nmse, 1e-4)
                rms = np.sqrt(np.mean(np.abs(H) ** 2, axis=0))
                noise = np.sqrt(nmse)[None] * rms[None] / np.maximum(np.abs(H), 1e-300)
            leak = None
            if scatter and scatter.get(b):
                leak = hammer_leak(H, ds.inp.values, scatter[b], averages)
            per[b] = frf_target(freq, H, noise, leak)
        out.append(per)
    return out
