"""Training data of the posture predictors: postures in, modal parameters out (DATA.md).

A modal dataset (``rmbench modal fit``) holds ``modal`` (posture, mode, param) and the postures'
``x``, ``y`` (m) and ``theta`` (rad). Each (mode, param) pair is one task; a mode missing at some
postures leaves NaN there, and every learner drops those rows for that task only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError

__all__ = ["TrainingSet", "training_set"]


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
    """

    X: np.ndarray
    Y: np.ndarray
    tasks: tuple

    def __post_init__(self):
        if self.X.ndim != 2 or self.X.shape[1] != 3 or self.Y.shape != (len(self.X), len(self.tasks)):
            raise InputError(f"training set shapes disagree: X {self.X.shape}, Y {self.Y.shape}, "
                             f"{len(self.tasks)} tasks")


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
    tasks = tuple(f"mode{int(m)}:{p}" for m in modes for p in params)
    return TrainingSet(X, values.reshape(len(X), -1), tasks)
