"""The learning baselines of seed 003 (METHODS.md §9): one estimator per task, ``fit``/``predict``.

* :class:`IDWNeighbours` — inverse-distance-weighted k nearest neighbours in a k-d tree over the
  standardised inputs, k chosen in 2..20 by leave-one-out error on the training set;
* ``RandomForest``, ``GradientBoosting``, ``ElasticNet`` — scikit-learn's, on standardised inputs
  (gradient boosting: scikit-learn's, as XGBoost is not a dependency).

Inputs are (x, y, θ) rows in SI units; targets one task's values, rows with NaN dropped by the caller.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["IDWNeighbours", "PerTask", "make_learner", "LEARNERS", "MULTI_TASK"]


class _Scaled:
    """Standardises the inputs with the training set's mean and spread."""

    def _scale_fit(self, X):
        X = np.asarray(X, float)
        self.mean_ = X.mean(axis=0)
        sd = X.std(axis=0)
        self.scale_ = np.where(sd > 0, sd, 1.0)
        return (X - self.mean_) / self.scale_

    def _scale(self, X):
        return (np.asarray(X, float) - self.mean_) / self.scale_


class IDWNeighbours(_Scaled):
    """Inverse-distance-weighted k-nearest-neighbour interpolation.

    Parameters
    ----------
    k : int, optional
        Neighbours; by default chosen in ``ks`` by leave-one-out error on the training set.
    ks : iterable of int
        Candidates for k (seed 003: 2..20).
    power : float
        Weights ``1 / d**power``; a query on a training point returns its value.
    """

    def __init__(self, k: int | None = None, ks=range(2, 21), power: float = 2.0):
        self.k, self.ks, self.power = k, tuple(ks), float(power)

    def fit(self, X, y) -> "IDWNeighbours":
        """Learn ``y`` over the postures ``X``; k by leave-one-out error unless given.

        Parameters
        ----------
        X : ndarray, shape (n_postures, 3)
            Training postures: x, y (m), θ (rad). Standardised per column (the training set's
            mean and standard deviation) before distances are taken.
        y : ndarray, shape (n_postures,)
            One task's values, in its own units; finite (the caller drops NaN rows).

        Returns
        -------
        IDWNeighbours
            ``self``, fitted: ``k_`` the number of neighbours used.
        """
        Z = self._scale_fit(X)
        self.y_ = np.asarray(y, float)
        self.tree_ = cKDTree(Z)
        n = len(Z)
        if self.k is not None:
            self.k_ = int(min(self.k, n))
            return self
        # leave-one-out: each point from its neighbours but itself
        ks = [k for k in self.ks if k < n] or [max(n - 1, 1)]
        d, i = self.tree_.query(Z, k=list(range(1, min(max(ks) + 1, n) + 1)))
        d, i = d[:, 1:], i[:, 1:]
        errors = [np.mean((self._weighted(d[:, :k], i[:, :k]) - self.y_) ** 2) for k in ks]
        self.k_ = ks[int(np.argmin(errors))]
        return self

    def predict(self, X) -> np.ndarray:
        """The inverse-distance-weighted mean of the ``k_`` nearest training values, shape
        (n_query,), in ``y``'s units, at postures ``X`` of shape (n_query, 3): x, y (m), θ (rad)."""
        Z = self._scale(X)
        d, i = self.tree_.query(Z, k=list(range(1, self.k_ + 1)))
        return self._weighted(d, i)

    def _weighted(self, d, i):
        exact = d[:, 0] <= 1e-12
        w = 1.0 / np.maximum(d, 1e-12) ** self.power
        out = np.sum(w * self.y_[i], axis=1) / np.sum(w, axis=1)
        out[exact] = self.y_[i[exact, 0]]
        return out


class _Sklearn(_Scaled):
    def __init__(self, make):
        self._make = make

    def fit(self, X, y):
        self.model_ = self._make().fit(self._scale_fit(X), np.asarray(y, float))
        return self

    def predict(self, X) -> np.ndarray:
        return self.model_.predict(self._scale(X))


class PerTask:
    """All parameters with one single-task learner per column (NaN rows dropped per column);
    ``predict(X, return_std=True)`` gives NaN standard deviations (these learners have none)."""

    def __init__(self, name: str):
        self.name = name

    def fit(self, X, Y) -> "PerTask":
        """One learner per column of ``Y``, each on the rows where that column is finite; a column
        with fewer than two finite values or no spread is kept as its constant (NaN if none).

        Parameters
        ----------
        X : ndarray, shape (n_postures, 3)
            Training postures: x, y (m), θ (rad).
        Y : ndarray, shape (n_postures, n_tasks)
            The tasks' values, each in its own units; NaN where missing.

        Returns
        -------
        PerTask
            ``self``, fitted.
        """
        X, Y = np.asarray(X, float), np.asarray(Y, float)
        self.models_ = []
        for j in range(Y.shape[1]):
            ok = np.isfinite(Y[:, j])
            y = Y[ok, j]
            if len(y) < 2 or np.ptp(y) == 0:
                self.models_.append(float(y[0]) if len(y) else np.nan)
            else:
                self.models_.append(make_learner(self.name).fit(X[ok], y))
        return self

    def predict(self, X, return_std: bool = False):
        """The tasks' predicted values at postures ``X`` of shape (n_query, 3) (x, y in m, θ in
        rad): an array of shape (n_query, n_tasks) in the tasks' units; with ``return_std`` also
        their standard deviations, the same shape and all NaN."""
        X = np.atleast_2d(np.asarray(X, float))
        mu = np.column_stack([np.full(len(X), m) if isinstance(m, float) else m.predict(X)
                              for m in self.models_])
        return (mu, np.full_like(mu, np.nan)) if return_std else mu


def _forest():
    from sklearn.ensemble import RandomForestRegressor

    return RandomForestRegressor(n_estimators=200, random_state=0, n_jobs=1)


def _boosting():
    from sklearn.ensemble import GradientBoostingRegressor

    return GradientBoostingRegressor(random_state=0)


def _enet():
    from sklearn.linear_model import ElasticNetCV

    return ElasticNetCV(l1_ratio=(0.1, 0.5, 0.9, 1.0), cv=3, max_iter=20_000)


#: Names of the learners :func:`make_learner` makes, the default (``mtgp-grouped``) first.
LEARNERS = ("mtgp-grouped", "mtgp", "mtgp-lowrank", "stgp", "knn", "rf", "gb", "enet")
#: The learners fitted on all parameters at once (one gpytorch batch or one Kronecker model),
#: ``fit(X, Y)``, not task by task.
MULTI_TASK = ("mtgp-grouped", "mtgp", "mtgp-lowrank", "stgp")
LOW_RANK = 8   # columns of B in the low-rank all-parameter model (K_c = B Bᵀ + diag v)


def make_learner(name: str, ts=None, tasks=None):
    """A fresh estimator.

    Single-task (``fit(X, y)``, one per parameter): ``knn``, ``rf`` (random forest), ``gb``
    (gradient boosting), ``enet``. On all parameters at once (``fit(X, Y)``; :mod:`rmbench.predict.gp`,
    :mod:`rmbench.predict.mtgp`): ``stgp`` (one single-task GP per column, fitted as one gpytorch
    batch; needs ``ts`` or ``tasks`` for the column count), ``mtgp-grouped`` (the seed's groups of m ≤ 3,
    which need the training set ``ts`` for the tasks' names and bands, and the column indices
    ``tasks`` of ``ts`` that ``Y`` holds), ``mtgp`` (one Kronecker model of all parameters, free
    K_c) and ``mtgp-lowrank`` (rank-``LOW_RANK`` K_c).
    """
    if name == "knn":
        return IDWNeighbours()
    if name in MULTI_TASK:
        from rmbench.predict.mtgp import MTGP, GroupedMTGP, seed_groups

        if name == "stgp":                 # one single-task GP per column, fitted as one batch
            return GroupedMTGP([[j] for j in range(len(tasks if tasks is not None else
                                                       (ts.tasks if ts is not None else ())))])
        if name == "mtgp":
            return MTGP()
        if name == "mtgp-lowrank":
            return MTGP(rank=LOW_RANK)
        if ts is None:
            return GroupedMTGP([])
        tasks = list(range(len(ts.tasks))) if tasks is None else list(tasks)
        return GroupedMTGP(seed_groups([ts.tasks[t] for t in tasks],
                                       [ts.bands[t] for t in tasks] if ts.bands else None))
    makers = {"rf": _forest, "gb": _boosting, "enet": _enet}
    if name not in makers:
        from rmbench.errors import InputError

        raise InputError(f"unknown learner {name!r}; choose from {', '.join(LEARNERS)}")
    return _Sklearn(makers[name])
