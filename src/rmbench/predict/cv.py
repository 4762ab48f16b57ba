"""Cross-validated scores of a learner per task (METHODS.md §5, §9).

``R² = 1 − Σ(κ − κ̂)² / Σ(κ − mean κ)²`` over each fold's held-out postures: accuracy is its mean
over the folds, robustness its sample standard deviation. Splits: ``random`` (k folds of shuffled
postures) and ``angle`` (each fold holds out every posture of one redundant angle θ, seed 003).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError
from rmbench.predict.baselines import MULTI_TASK, make_learner
from rmbench.predict.data import TrainingSet, constant_tasks

__all__ = ["CVScores", "cross_validate", "folds_of", "validate_predictor"]


@dataclass(frozen=True)
class CVScores:
    """Cross-validation of one learner.

    Attributes
    ----------
    learner, split : str
    tasks : tuple of str
    r2_mean, r2_std : ndarray, shape (n_tasks,)
        NaN for a task that was skipped.
    r2_folds : ndarray, shape (n_tasks, n_folds)
    skipped : dict
        ``{task: reason}``: all NaN, constant, or too few postures for the folds.
    notes : dict
        ``{task: note}``: numerical trouble a fit reported (a GP's covariance needed jitter).
    predictions : ndarray, shape (n_postures, n_tasks)
        Out-of-fold predictions (each posture predicted by the model that did not see it).
    """

    learner: str
    split: str
    tasks: tuple
    r2_mean: np.ndarray
    r2_std: np.ndarray
    r2_folds: np.ndarray
    skipped: dict
    notes: dict = None
    predictions: np.ndarray = None

    def summary(self) -> str:
        """A few readable lines: the mean R² over the scored parameters and its spread over the
        folds, the five worst parameters, the first five skipped and the fits that needed jitter."""
        ok = np.isfinite(self.r2_mean)
        lines = [f"{self.learner}, {self.split} split: mean R² {np.mean(self.r2_mean[ok]):.3f} over "
                 f"{int(ok.sum())} parameters (mean spread over folds {np.mean(self.r2_std[ok]):.3f}); "
                 f"{len(self.skipped)} skipped"]
        worst = np.argsort(np.where(ok, self.r2_mean, np.inf))[:5]
        lines += [f"  {self.tasks[t]}: R² {self.r2_mean[t]:.3f} ± {self.r2_std[t]:.3f}" for t in worst if ok[t]]
        lines += [f"  skipped {task}: {why}" for task, why in list(self.skipped.items())[:5]]
        if self.notes:
            lines.append(f"  {len(self.notes)} fits needed jitter, e.g. {next(iter(self.notes))}: "
                         f"{next(iter(self.notes.values()))}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """The scores as plain JSON types: the learner and split, the mean R² (dimensionless) over
        the scored tasks and the mean of their spreads over the folds (None when no task was
        scored), each scored task's ``r2_mean`` and ``r2_std``, and the skipped tasks and fit notes
        (``{task: reason}``). The per-fold scores and the out-of-fold predictions are left out."""
        ok = np.isfinite(self.r2_mean)
        return {"learner": self.learner, "split": self.split,
                "r2_mean": float(np.mean(self.r2_mean[ok])) if ok.any() else None,
                "r2_std_mean": float(np.mean(self.r2_std[ok])) if ok.any() else None,
                "tasks": {t: {"r2_mean": float(m), "r2_std": float(s)}
                          for t, m, s in zip(self.tasks, self.r2_mean, self.r2_std) if np.isfinite(m)},
                "skipped": self.skipped, "notes": self.notes or {}}


def folds_of(X: np.ndarray, split: str, folds: int, seed: int = 0) -> list[np.ndarray]:
    """Held-out row indices of each fold.

    Parameters
    ----------
    X : ndarray, shape (n_postures, 3)
        Postures: x, y (m) and redundant angle θ (rad); the ``angle`` split groups the rows by θ
        (equal to within 1e-9 rad).
    split : str
        ``random`` (``folds`` folds of the shuffled rows) or ``angle`` (one fold per distinct θ;
        ``folds`` is then ignored).
    folds : int
        Folds of the ``random`` split, 2 ≤ folds ≤ n_postures.
    seed : int
        Seed of the ``random`` split's shuffle.

    Returns
    -------
    list of ndarray of int
        Each fold's held-out row indices of ``X``, sorted; every row in exactly one fold.

    Raises
    ------
    rmbench.errors.InputError
        An unknown split, fewer than two angles for ``angle``, or folds out of range for ``random``.
    """
    n = len(X)
    if split == "angle":
        angles = np.unique(np.round(X[:, 2], 9))
        if len(angles) < 2:
            raise InputError("the angle split needs postures at two or more redundant angles")
        return [np.flatnonzero(np.isclose(X[:, 2], a, atol=1e-9)) for a in angles]
    if split != "random":
        raise InputError(f"unknown split {split!r}; use random or angle")
    if folds < 2 or folds > n:
        raise InputError(f"{n} postures cannot make {folds} folds (need 2 <= folds <= postures)")
    order = np.random.default_rng(seed).permutation(n)
    return [np.sort(part) for part in np.array_split(order, folds)]


def cross_validate(ts: TrainingSet, learner: str, *, folds: int = 5, split: str = "random",
                   seed: int = 0) -> CVScores:
    """Score ``learner`` (see :data:`rmbench.predict.baselines.LEARNERS`) on every task.

    Raises
    ------
    rmbench.errors.InputError
        Fewer postures than folds, an unknown split or learner.
    """
    make_learner(learner)                      # an unknown name fails here, once
    parts = folds_of(ts.X, split, folds, seed)
    k = len(parts)
    r2 = np.full((len(ts.tasks), k), np.nan)
    skipped, notes = {}, {}
    for t, task in enumerate(ts.tasks):
        y = ts.Y[:, t]
        finite = np.isfinite(y)
        if not finite.any():
            skipped[task] = "no finite values (mode never found)"
        elif constant_tasks(y[finite][:, None])[0]:
            skipped[task] = "constant: R² undefined"
    live = [t for t, task in enumerate(ts.tasks) if task not in skipped]
    oof = np.full(ts.Y.shape, np.nan)
    if learner in MULTI_TASK:
        model = None
        for f, test in enumerate(parts):
            train = np.setdiff1d(np.arange(len(ts.X)), test)
            model = make_learner(learner, ts, live).fit(ts.X[train], ts.Y[train][:, live])
            if getattr(model, "jitter_added_", 0.0) > 0:
                notes[f"fold{f}"] = (f"covariance not positive definite: jitter up to "
                                     f"{model.jitter_added_:.0e} added")
            pred = model.predict(ts.X[test])
            oof[np.ix_(test, live)] = pred
            for j, t in enumerate(live):
                r2[t, f] = _r2(ts.Y[test, t], pred[:, j])
    else:
        for t in live:
            y = ts.Y[:, t]
            finite = np.isfinite(y)
            for f, test in enumerate(parts):
                test = test[finite[test]]
                train = np.setdiff1d(np.flatnonzero(finite), test)
                if len(test) < 2 or len(train) < 2:
                    continue
                model = make_learner(learner).fit(ts.X[train], y[train])
                if getattr(model, "jitter_added_", 0.0) > 0:
                    notes[ts.tasks[t]] = (f"covariance not positive definite: jitter up to "
                                          f"{model.jitter_added_:.0e} added")
                oof[test, t] = model.predict(ts.X[test])
                r2[t, f] = _r2(y[test], oof[test, t])
    for t in live:
        if np.sum(np.isfinite(r2[t])) < 2:
            skipped[ts.tasks[t]] = "fewer than two folds with two or more finite held-out values"
            r2[t] = np.nan
    mean = np.full(len(ts.tasks), np.nan)
    std = np.full(len(ts.tasks), np.nan)
    for t, task in enumerate(ts.tasks):
        if task not in skipped:
            scores = r2[t][np.isfinite(r2[t])]
            mean[t], std[t] = scores.mean(), scores.std(ddof=1)
    return CVScores(learner, split, ts.tasks, mean, std, r2, skipped, notes, oof)


def _r2(y: np.ndarray, pred: np.ndarray) -> float:
    """R² of one fold's held-out values (NaN where fewer than two are finite or they have no spread)."""
    ok = np.isfinite(y) & np.isfinite(pred)
    y, pred = y[ok], pred[ok]
    ss = np.sum((y - y.mean()) ** 2) if len(y) >= 2 else 0.0
    return 1.0 - np.sum((y - pred) ** 2) / ss if ss > 0 else np.nan


def validate_predictor(pred, modal, learners=None) -> tuple[TrainingSet, list]:
    """Cross-validate a fitted predictor's learner, and others beside it, on the modal dataset it
    learnt from.

    Parameters
    ----------
    pred : rmbench.predict.PosturePredictor
    modal : xarray.Dataset
        The modal dataset (``rmbench modal fit``) the predictor was trained on.
    learners : sequence of str, optional
        Default: the predictor's own and the k-nearest-neighbour baseline.

    Returns
    -------
    ts : TrainingSet
        In the predictor's mode order.
    cvs : list of CVScores
        One per learner, in order.

    Raises
    ------
    rmbench.errors.InputError
        ``modal`` is not a modal dataset.
    """
    from rmbench.predict.data import frequency_ordered, training_set

    if "modal" not in modal:
        raise InputError("not a modal dataset (no 'modal'): the data must be what the predictor learnt")
    ts = training_set(frequency_ordered(modal) if getattr(pred, "order", "") == "frequency" else modal)
    return ts, [cross_validate(ts, m) for m in (learners or dict.fromkeys([pred.model, "knn"]))]
