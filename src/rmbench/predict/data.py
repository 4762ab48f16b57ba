"""Training data of the posture predictors: postures in, modal parameters out (DATA.md).

A modal dataset (``rmbench modal fit``) holds ``modal`` (posture, mode, param) and the postures'
``x``, ``y`` (m) and ``theta`` (rad). Each (mode, param) pair is one task, and so are the real and
imaginary parts of ``phiL_1aY`` (φL at 1aY: 1 + 0i, a constant, unless the mode's φL is fixed at
another element, DATA.md), so that the predicted parameters rebuild the FRF matrix. A mode missing at
some postures leaves NaN there: single-task learners drop those rows for that task only, a
multi-task GP drops them for its whole model (Kronecker inference needs every task at every posture).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError

__all__ = ["TrainingSet", "training_set", "constant_tasks", "frequency_ordered"]


@dataclass(frozen=True)
class TrainingSet:
    """Inputs and targets of the posture predictors.

    Attributes
    ----------
    X : ndarray, shape (n_postures, 3)
        Tool-tip x, y (m) and redundant angle θ (rad).
    Y : ndarray, shape (n_postures, n_tasks)
        One column per (mode, parameter); NaN where the mode was not found.
    tasks : tuple of str
        ``"mode{m}:{param}"`` per column.
    bands : tuple of str
        Band of each task's mode (empty when unknown).
    """

    X: np.ndarray
    Y: np.ndarray
    tasks: tuple
    bands: tuple = ()

    def __post_init__(self):
        if self.bands and len(self.bands) != len(self.tasks):
            raise InputError(f"{len(self.bands)} bands for {len(self.tasks)} tasks")
        if self.X.ndim != 2 or self.X.shape[1] != 3 or self.Y.shape != (len(self.X), len(self.tasks)):
            raise InputError(f"training set shapes disagree: X {self.X.shape}, Y {self.Y.shape}, "
                             f"{len(self.tasks)} tasks")


def frequency_ordered(ds):
    """The modal dataset with, at every posture, the modes of each band renumbered in order of
    frequency (among modes whose φL is fixed at the same element, so the parameters stay comparable).

    Why: the modal stage tracks modes across postures by shape, and where two modes veer (their
    shapes mix as the frequencies approach) the tracked identity can flip at a few postures — on the
    IRB6660 stand-in modes 3 and 4 (17-28 Hz) swap at two of the seed's postures that mirror two
    unswapped ones. A flipped identity is a jump in every parameter, which no smooth learner can
    follow; frequency order makes the natural frequencies continuous (kinked at a crossing) and
    halves the frequency error at unseen postures of that pair (bench/predict.py).
    """
    ds = ds.copy(deep=True)
    modal, std = ds["modal"].values, ds["modal_std"].values if "modal_std" in ds else None
    ay = ds["phiL_1aY"].values if "phiL_1aY" in ds else None
    n_modes = modal.shape[1]
    band = ds["mode_band"].values if "mode_band" in ds.coords else np.array([""] * n_modes)
    ref = ds["phiL_ref"].values if "phiL_ref" in ds.coords else np.array(["1aY"] * n_modes)
    for key in sorted(set(zip(band.tolist(), ref.tolist()))):
        idx = np.flatnonzero((band == key[0]) & (ref == key[1]))
        for p in range(modal.shape[0]):
            ok = idx[np.isfinite(modal[p, idx, 0])]
            order = ok[np.argsort(modal[p, ok, 0], kind="stable")]
            for arr in (modal, std, ay):
                if arr is not None:
                    arr[p, ok] = arr[p, order]
    ds["modal"].values[:] = modal
    if std is not None:
        ds["modal_std"].values[:] = std
    if ay is not None:
        ds["phiL_1aY"].values[:] = ay
    ds.attrs["mode_order"] = "frequency within band and φL reference"
    return ds


def training_set(ds, variable: str = "modal") -> TrainingSet:
    """The training set of a modal dataset (postures marked not ok are left out).

    Raises
    ------
    rmbench.errors.InputError
        No such variable, no posture coordinates, fewer than two usable postures.
    """
    if variable not in ds:
        raise InputError(f"the dataset has no variable {variable!r} (a modal dataset from "
                         f"`rmbench modal fit` has 'modal')")
    for c in ("x", "y", "theta"):
        if c not in ds.coords and c not in ds:
            raise InputError(f"the dataset has no posture coordinate {c!r}")
    keep = np.asarray(ds["ok"].values, bool) if "ok" in ds else np.ones(ds.sizes["posture"], bool)
    X = np.column_stack([np.asarray(ds[c].values, float) for c in ("x", "y", "theta")])[keep]
    values = np.asarray(ds[variable].values, float)[keep]            # (posture, mode, param)
    modes = ds[variable]["mode"].values if "mode" in ds[variable].coords else np.arange(values.shape[1])
    params = ds[variable]["param"].values if "param" in ds[variable].coords else np.arange(values.shape[2])
    if len(X) < 2:
        raise InputError(f"{len(X)} usable postures: the predictors need at least two")
    tasks = [f"mode{int(m)}:{p}" for m in modes for p in params]
    mode_band = (ds[variable]["mode_band"].values if "mode_band" in ds[variable].coords
                 else [""] * len(modes))
    bands = [str(b) for b in mode_band for _ in params]
    Y = values.reshape(len(X), -1)
    if "phiL_1aY" in ds and variable == "modal":
        one_ay = np.asarray(ds["phiL_1aY"].values)[keep]          # (posture, mode) complex
        Y = np.column_stack([Y, one_ay.real, one_ay.imag])
        tasks += [f"mode{int(m)}:phiL_1aY_{part}" for part in ("re", "im") for m in modes]
        bands += [str(b) for _ in ("re", "im") for b in mode_band]
    return TrainingSet(X, Y, tuple(tasks), tuple(bands))


def constant_tasks(Y: np.ndarray) -> np.ndarray:
    """Columns of ``Y`` (n, m) without spread beyond round-off, shape (m,) bool: φL's reference
    element (1 + 0i by the normalisation) is one. R² is undefined for them and they are predicted
    as their constant."""
    Y = np.asarray(Y, float)
    with np.errstate(all="ignore"):
        spread = np.nanmax(Y, axis=0) - np.nanmin(Y, axis=0)
        size = np.nanmax(np.abs(Y), axis=0)
    return ~(spread > 1e-9 * np.maximum(size, 1e-300))
