"""A trained posture predictor: modal parameters and FRF matrices at any posture (issue 15).

    pred = PosturePredictor("mtgp-grouped").fit(xr.open_dataset("modal.nc"))
    out = pred.predict([[1.8, 0.2, 0.0]])       # x, y (m), θ (rad) per row
    out.modal, out.modal_std                     # (posture, mode, param), like a modal fit
    H = predicted_frf(out, freq)                 # (posture, freq, 4, 4), m/N (Eq. 15)
    H = predicted_frf(out, freq, band="high")    # that band's modes and residual terms
    pred.save("pred.npz"); PosturePredictor.load("pred.npz")

The prediction is laid out like a modal dataset (``modal``, ``modal_std``, ``phiL_1aY``,
``mode_band``, ``phiL_ref``), so the modal stage's tools read it. A posture outside the training
postures' convex hull is an extrapolation: it is flagged (``outside_hull``) and warned about, and its
standard deviations say how far to trust it.

Where the modal dataset holds each band's residual terms (``residual``, from the modal fit), they
are learnt too, one GP per real and imaginary part of each entry (any GP model; the baselines learn
them per entry too): a band's modes alone leave out the modes above it, which on the IRB6660
stand-in moves the tool-holder modes that RCSA couples to and the lobes' flanks by up to 9 %
(bench/lobes.py).

Modes that veer (consecutive modes of a band closer than their half-power bandwidths at some posture:
on the stand-in the low band's modes 2-5) have parameters that turn too sharply between the grid's
postures for any learner. Their receptance is rebuilt from what stays smooth, the cluster's
characteristic polynomial and residue moments (:mod:`rmbench.predict.cluster`), learnt one GP per
column: the prediction carries ``cluster_pole`` and ``cluster_residue`` for those modes, and
:func:`predicted_frf` uses them (at 200 unseen postures the low band's tool-tip receptances come
1.4-10× closer to the exact ones, median over the postures; bench/predict.py). The modes' own
parameters (``modal``) are learnt one by one, for tables and scores, except for modes that veer
tightly (closer than 0.3 of their bandwidths' sum at some posture: on the stand-in modes 3-5, not
2): their natural frequencies and damping ratios are the roots of the cluster's characteristic
polynomial, learnt on its own by one multi-task GP (coefficients' real and imaginary parts as its
tasks; the baselines learn them per column), and their standard deviations are propagated from the
coefficients' to first order; the receptance's cluster poles for those modes are the same
roots, with the residues solved from the larger cluster's moments at them, so the rebuilt FRF
peaks where the modal table says (at the validation postures the worst cross-entry peak error
fell from 18.8 to 14.0 %). Why not every veering cluster's: a root's error grows with the
cluster's span, so a mode that veers only mildly (mode 2) is predicted better alone. At 3 × 200
unseen postures the 95th percentile of the frequency error of modes 3-5 falls from 1.0-1.5 % to
0.22-0.87 % (bench/predict.py). The 0.3 was chosen on the first 200 of them.

A saved predictor is one ``.npz`` of plain arrays with its metadata as JSON text in it: loaded with
``allow_pickle=False``, never unpickled. The Gaussian-process learners can be saved; the tree and
linear baselines only cross-validate.
"""

from __future__ import annotations

import json
import time
import warnings
from pathlib import Path

import numpy as np
import xarray as xr
from scipy.spatial import ConvexHull, QhullError

from rmbench._version import __version__
from rmbench.errors import InputError
from rmbench.io.strict_json import jsonable
from rmbench.modal.campaign_fit import COORDS
from rmbench.modal.residual import RESIDUAL_TERMS
from rmbench.predict.baselines import MULTI_TASK, PerTask, make_learner
from rmbench.predict.cluster import (cluster_features, cluster_poles, cluster_residues, pole_features,
                                     poles_of, round_off_features, veering_clusters)
from rmbench.predict.data import constant_tasks, frequency_ordered, training_set
from rmbench.predict.frf import frf_lines, predicted_frf, predicted_frf_dataset
from rmbench.predict.gauge import from_gauge, gauge_directions, to_gauge, vectors
from rmbench.predict.gp import _torch
from rmbench.predict.mtgp import GroupedMTGP
from rmbench.predict.persist import load_predictor, save_predictor
from rmbench.robot.modes import PARAMS
from rmbench.threads import run_concurrently

# predicted_frf and its kin live in rmbench.predict.frf; named here for the callers that import them from here
__all__ = ["PosturePredictor", "ExtrapolationWarning", "predicted_frf", "frf_lines", "predicted_frf_dataset",
           "SAVEABLE"]

#: The learners a :class:`PosturePredictor` can be saved with (plain arrays, no pickle) and whose
#: ``predict`` takes ``source="loo" | "data"``: the Gaussian-process ones.
SAVEABLE = MULTI_TASK
_OVERLAP = 1.0      # veering_clusters: peaks closer than their half-power bandwidths
# frequencies and damping ratios from a cluster's poles only where the modes come far closer (module
# docstring): on the stand-in modes 3-5 meet within 0.07-0.2 of their bandwidths, mode 2 within 0.36
_TIGHT = 0.3


class ExtrapolationWarning(UserWarning):
    """A posture outside the convex hull of the training postures."""


class PosturePredictor:
    """Modal parameters as functions of the posture, learnt from a modal dataset.

    Parameters
    ----------
    model : str
        ``mtgp-grouped`` (the seed's grouped MTGPs), ``mtgp`` (one Kronecker model of all
        parameters), ``mtgp-lowrank`` or ``stgp`` (these can be saved); ``knn``, ``rf``, ``gb``,
        ``enet`` (in memory only, no standard deviations).
    order : str
        ``frequency`` (default): each band's modes learnt in order of frequency; ``tracked``: as the
        modal stage tracked them.
    vectors : str
        ``gauge`` (default): each mode's φR and φL learnt in the gauge of
        :mod:`rmbench.predict.gauge` (unit-norm φL turned to a direction chosen per mode, so no
        element near zero is divided by) and returned in the dataset's normalisation; ``dataset``:
        learnt as the modal stage normalised them (φL[phiL_ref] = 1).
    clusters : str
        ``auto`` (default): veering modes (:func:`~rmbench.predict.cluster.veering_clusters`) are also
        learnt as clusters, for the receptance; ``none``: every mode alone. Clusters need the modes
        in order of frequency: with ``order = "tracked"`` none are learnt.

    Attributes
    ----------
    tasks_ : tuple of str
        ``"mode{m}:{param}"`` per learnt column.
    train_seconds_ : float
        Training time of the parameters' learner, s.
    residual_seconds_ : float
        Training time of the residual terms' learner, s (0 without residual terms).
    clusters_ : tuple of ModeCluster
        The veering clusters learnt as a whole (empty with ``clusters = "none"``).
    cluster_seconds_ : float
        Training time of the clusters' learners, s.
    """

    def __init__(self, model: str = "mtgp-grouped", order: str = "frequency", vectors: str = "gauge",
                 clusters: str = "auto"):
        make_learner(model)                # an unknown name fails here
        if order not in ("frequency", "tracked"):
            raise InputError(f"unknown mode order {order!r}; use frequency or tracked")
        if vectors not in ("gauge", "dataset"):
            raise InputError(f"unknown vector normalisation {vectors!r}; use gauge or dataset")
        if clusters not in ("auto", "none"):
            raise InputError(f"unknown clusters {clusters!r}; use auto or none")
        self.model, self.order, self.vectors, self.clusters = model, order, vectors, clusters

    def fit(self, ds: xr.Dataset) -> "PosturePredictor":
        """Learn every parameter of a modal dataset (``rmbench modal fit``); with ``order =
        "frequency"`` (default) the modes of each band are learnt in order of frequency
        (:func:`~rmbench.predict.data.frequency_ordered`), else as the modal stage tracked them."""
        if self.order == "frequency":
            ds = frequency_ordered(ds)
        plain = ds                         # the clusters learn from the dataset's own vectors
        self.gauge_worst_ = None
        if self.vectors == "gauge" and "modal" in ds:
            if "phiL_1aY" not in ds:     # φL fixed at 1aY everywhere (DATA.md's default)
                ds = ds.assign(phiL_1aY=(("posture", "mode"),
                                         np.ones((ds.sizes["posture"], ds.sizes["mode"]), complex)))
            v, self.gauge_worst_ = gauge_directions(ds)
            ds = to_gauge(ds, v)
        ts = training_set(ds)
        if len(ts.X) < 3:
            raise InputError(f"{len(ts.X)} usable postures: a Gaussian process needs at least three")
        found = np.isfinite(ts.Y).any(axis=0)
        self.live_ = np.flatnonzero(found)
        if self.model in MULTI_TASK:
            _torch()   # loaded before the threads: run_concurrently divides its pool among them
        # the parameters, the clusters and the residual terms are independent learners: they run
        # side by side on the process's share of the cores (each deterministic, so the result is
        # the one of a run in turn)
        run_concurrently([lambda: self._fit_parameters(ts), lambda: self._fit_clusters(plain),
                          lambda: self._fit_pole_clusters(plain), lambda: self._fit_residuals(ds)])
        modal = ds["modal"]
        self.tasks_ = ts.tasks
        self.modes_ = np.asarray(modal["mode"].values, int)
        self.params_ = tuple(str(v) for v in modal["param"].values)
        self.mode_band_ = np.asarray(modal["mode_band"].values if "mode_band" in modal.coords
                                     else [""] * len(self.modes_), str)
        self.phiL_ref_ = np.asarray(modal["phiL_ref"].values if "phiL_ref" in modal.coords
                                    else ["1aY"] * len(self.modes_), str)
        self.X_train_ = ts.X
        self.constant_ = np.array([ts.Y[np.isfinite(ts.Y[:, j]), j][0]
                                   if constant_tasks(ts.Y[:, j:j + 1])[0] and found[j] else np.nan
                                   for j in range(len(ts.tasks))])
        self.source_ = str(ds.attrs.get("upstream", ""))
        self._hull()
        return self

    def _fit_parameters(self, ts) -> None:
        """Learn the modal parameters of the training set (the live columns)."""
        t0 = time.perf_counter()
        learner = (make_learner(self.model, ts, self.live_) if self.model in MULTI_TASK
                   else PerTask(self.model))
        self.learner_ = learner.fit(ts.X, ts.Y[:, self.live_])
        self.train_seconds_ = time.perf_counter() - t0

    def _fit_residuals(self, ds: xr.Dataset) -> None:
        """Learn the bands' residual terms: 3 x 16 complex entries per band, real and imaginary
        parts as tasks (:func:`_entry_learner`); a posture whose band fit failed (NaN) is left out."""
        self.residual_bands_, self.residual_learner_, self.residual_seconds_ = (), None, 0.0
        self.residual_f_max_ = ()
        if "residual" not in ds or "residual_f_max" not in ds["residual"].coords:
            return
        res = ds["residual"].transpose("posture", "fit_band", "term", "out", "inp")
        keep = np.asarray(ds["ok"].values, bool) if "ok" in ds else np.ones(ds.sizes["posture"], bool)
        z = np.asarray(res.values, complex)[keep].reshape(int(keep.sum()), -1)
        Y = np.column_stack([z.real, z.imag])
        rows = np.isfinite(Y).all(axis=1)
        if rows.sum() < 3:
            return
        X = np.column_stack([np.asarray(ds[c].values, float) for c in ("x", "y", "theta")])[keep]
        t0 = time.perf_counter()
        self.residual_learner_ = _entry_learner(self.model, Y.shape[1]).fit(X[rows], Y[rows])
        self.residual_seconds_ = time.perf_counter() - t0
        self.residual_bands_ = tuple(str(b) for b in res["fit_band"].values)
        self.residual_f_max_ = tuple(float(v) for v in res["residual_f_max"].values)

    def _fit_clusters(self, ds: xr.Dataset) -> None:
        """Learn each veering cluster's invariants (:func:`_entry_learner`); postures missing one of
        its modes are left out of it."""
        self.clusters_, self.cluster_learners_, self.cluster_seconds_ = (), [], 0.0
        if self.clusters == "none" or self.order != "frequency" or "modal" not in ds:
            return
        keep = np.asarray(ds["ok"].values, bool) if "ok" in ds else np.ones(ds.sizes["posture"], bool)
        modal = np.asarray(ds["modal"].values, float)[keep]
        ay = (np.asarray(ds["phiL_1aY"].values)[keep] if "phiL_1aY" in ds
              else np.ones(modal.shape[:2], complex))
        bands = ds["mode_band"].values if "mode_band" in ds.coords else [""] * modal.shape[1]
        f, z = modal[..., PARAMS.index("f_n")], modal[..., PARAMS.index("zeta")]
        phi_l, phi_r = vectors(modal, ay)
        X = np.column_stack([np.asarray(ds[c].values, float) for c in ("x", "y", "theta")])[keep]
        t0 = time.perf_counter()
        found = []
        for cl in veering_clusters(f, z, bands, overlap=_OVERLAP):
            idx = list(cl.modes)
            F = cluster_features(cl, poles_of(f[:, idx], z[:, idx]), phi_r[:, idx], phi_l[:, idx])
            rows = np.isfinite(F).all(axis=1)
            if rows.sum() < 3:
                continue
            F[:, round_off_features(cl, F[rows])] = 0.0
            self.cluster_learners_.append(_entry_learner(self.model, F.shape[1]).fit(X[rows], F[rows]))
            found.append(cl)
        self.clusters_ = tuple(found)
        self.cluster_seconds_ = time.perf_counter() - t0

    def _fit_pole_clusters(self, ds: xr.Dataset) -> None:
        """Learn the characteristic polynomial of each tightly veering cluster (:data:`_TIGHT`)."""
        self.pole_clusters_, self.pole_learners_ = (), []
        if self.clusters == "none" or self.order != "frequency" or "modal" not in ds:
            return
        keep = np.asarray(ds["ok"].values, bool) if "ok" in ds else np.ones(ds.sizes["posture"], bool)
        modal = np.asarray(ds["modal"].values, float)[keep]
        bands = ds["mode_band"].values if "mode_band" in ds.coords else [""] * modal.shape[1]
        f, z = modal[..., PARAMS.index("f_n")], modal[..., PARAMS.index("zeta")]
        X = np.column_stack([np.asarray(ds[c].values, float) for c in ("x", "y", "theta")])[keep]
        found = []
        for cl in veering_clusters(f, z, bands, overlap=_TIGHT):
            F = pole_features(cl, poles_of(f[:, list(cl.modes)], z[:, list(cl.modes)]))
            rows = np.isfinite(F).all(axis=1)
            if rows.sum() < 3:
                continue
            self.pole_learners_.append(_pole_learner(self.model, F.shape[1]).fit(X[rows], F[rows]))
            found.append(cl)
        self.pole_clusters_ = tuple(found)

    def _hull(self) -> None:
        X = self.X_train_
        self._x_mean, sd = X.mean(axis=0), X.std(axis=0)
        self._x_scale = np.where(sd > 0, sd, 1.0)
        try:
            self._facets = ConvexHull((X - self._x_mean) / self._x_scale).equations
        except QhullError:              # flat training set (one θ, say): every query is outside
            self._facets = None

    # -- what the predictor is ---------------------------------------------------------------------
    def to_dict(self) -> dict:
        """The fitted predictor's account as plain JSON types: its settings, modes and parameters,
        what it learnt from how many postures (their range: x, y in m, θ in rad) and the training
        times (s)."""
        X = self.X_train_
        return jsonable({
            "model": self.model, "order": self.order, "vectors": self.vectors, "clusters_option": self.clusters,
            "modes": self.modes_, "mode_band": self.mode_band_, "params": list(self.params_),
            "n_postures": len(X), "n_parameters": len(self.tasks_), "n_learnt": len(self.live_),
            "posture_range": {c: [X[:, i].min(), X[:, i].max()] for i, c in enumerate(("x_m", "y_m", "theta_rad"))},
            "residual_bands": list(self.residual_bands_),
            "clusters": [list(map(int, c.modes)) for c in self.clusters_],
            "modes_from_poles": [list(map(int, c.modes)) for c in self.pole_clusters_],
            "train_seconds": self.train_seconds_, "residual_seconds": self.residual_seconds_,
            "cluster_seconds": self.cluster_seconds_, "source": self.source_})

    def summary(self) -> str:
        """A few readable lines: the learner, its modes per band, how many parameters it learnt
        from how many postures (their range in m and degrees) and what it learnt besides."""
        X = self.X_train_
        bands = ", ".join(f"{b or 'unnamed'}: {int(np.sum(self.mode_band_ == b))}"
                          for b in dict.fromkeys(self.mode_band_.tolist()))
        lines = [f"{self.model} predictor: {len(self.modes_)} modes ({bands}); {len(self.live_)} of "
                 f"{len(self.tasks_)} parameters learnt from {len(X)} postures in {self.train_seconds_:.1f} s",
                 f"training postures: x {X[:, 0].min():.3f}-{X[:, 0].max():.3f} m, "
                 f"y {X[:, 1].min():.3f}-{X[:, 1].max():.3f} m, "
                 f"θ {np.degrees(X[:, 2].min()):.0f}-{np.degrees(X[:, 2].max()):.0f}°"]
        if self.residual_bands_:
            lines.append(f"residual terms of the {', '.join(self.residual_bands_)} band(s)")
        if self.clusters_:
            lines.append("veering clusters: " + ", ".join("modes " + "-".join(map(str, c.modes))
                                                          for c in self.clusters_))
        if self.pole_clusters_:
            lines.append("f_n and ζ from cluster poles: " + ", ".join("modes " + "-".join(map(str, c.modes))
                                                                     for c in self.pole_clusters_))
        return "\n".join(lines)

    def plot(self, ax=None):
        """The training postures in the workspace, x against y (mm), coloured by θ (degrees).

        Drawn on ``ax`` or a new figure's Axes (:func:`rmbench.plotting.axes_or_new`), which it
        returns.
        """
        from rmbench.predict.plot import plot_postures

        return plot_postures(self.X_train_, ax=ax, title=f"{self.model}: {len(self.X_train_)} training postures")

    def std_scale(self) -> xr.DataArray:
        """The leave-one-posture-out factor on each learnt parameter's standard deviation
        (``predict(..., calibrated=True)``), dims (mode, param); 1 for a constant parameter or a
        learner without standard deviations. Above 1: the GP's own variance is overconfident. With
        ``vectors = "gauge"`` the eigenvector components' factors are those of their gauge."""
        n_modes, n_p = len(self.modes_), len(self.params_)
        out = np.ones(len(self.tasks_))
        out[self.live_] = _scale_of(self.learner_, len(self.live_))
        return xr.DataArray(out[:n_modes * n_p].reshape(n_modes, n_p), dims=("mode", "param"),
                            coords={"mode": self.modes_, "param": list(self.params_)})

    def outside_hull(self, X) -> np.ndarray:
        """Whether each posture of ``X``, shape (n_postures, 3) (x, y in m, θ in rad), lies outside
        the training postures' convex hull (:meth:`hull_distance` above 1e-9): bool, shape
        (n_postures,)."""
        return self.hull_distance(X) > 1e-9

    def hull_distance(self, X) -> np.ndarray:
        """How far each posture of ``X``, shape (n_postures, 3) (x, y in m, θ in rad), lies
        outside the training postures' convex hull, shape (n_postures,): dimensionless, in the
        training postures' standard deviations per coordinate (0 inside; the largest distance
        beyond a facet's plane, which is the distance to the hull where the nearest point is on a
        facet and less than it near an edge or corner); inf where the training postures span no
        volume."""
        Z = (np.atleast_2d(np.asarray(X, float)) - self._x_mean) / self._x_scale
        if self._facets is None:
            return np.full(len(Z), np.inf)
        return np.maximum((Z @ self._facets[:, :-1].T + self._facets[:, -1]).max(axis=1), 0.0)

    def predict(self, X, *, std: bool = True, calibrated: bool = False, source: str = "posterior") -> xr.Dataset:
        """Parameters and their standard deviations at postures ``X`` (n, 3): x, y (m), θ (rad).

        With ``std`` False the learnt standard deviations are not computed (NaN in ``modal_std``): about
        a fifth of the time, for callers that use the means alone (a path's thousands of poses).
        ``modal_std`` is the GPs' latent standard deviation; with ``calibrated`` each learnt column's
        is multiplied by its leave-one-posture-out factor (:meth:`std_scale`), so that the training
        postures' held-out errors have unit variance in its units.
        ``source`` (Gaussian-process learners only): "loo" predicts each training posture in ``X``
        with that posture left out of every learner (the mean and predictive standard deviation of
        the block formula, no refit; see :func:`~rmbench.predict.posterior.loo_residuals`), "data"
        gives the learners' training data there (NaN at other postures), both for cross-validating
        what is computed from a prediction (a path's critical depth).
        Warns (:class:`ExtrapolationWarning`) for postures outside the training hull.
        """
        X = np.atleast_2d(np.asarray(X, float))
        if X.ndim != 2 or X.shape[1] != 3 or not np.all(np.isfinite(X)):
            raise InputError(f"postures must be finite (x, y, θ) rows, got shape {X.shape}")
        return self._predict(X, None, std=std, calibrated=calibrated, source=source)

    def predict_grid(self, xy, theta) -> xr.Dataset:
        """Parameters at every (location, angle) pair, postures location-major (``x, y = xy[i]``,
        ``θ = theta[j]`` at posture ``i * len(theta) + j``), means only: :meth:`predict`'s with
        ``std=False`` (to round-off) for a path's grid, the kernel split into location and angle
        factors where the learner allows (:meth:`GroupedMTGP.predict_product`).

        Parameters
        ----------
        xy : ndarray, shape (n, 2), m
        theta : ndarray, shape (m,), rad
        """
        xy, theta = np.atleast_2d(np.asarray(xy, float)), np.atleast_1d(np.asarray(theta, float))
        if xy.shape[1] != 2 or theta.ndim != 1 or not (np.all(np.isfinite(xy)) and np.all(np.isfinite(theta))):
            raise InputError(f"locations must be finite (x, y) rows and angles a finite vector, got shapes "
                             f"{xy.shape} and {theta.shape}")
        X = np.column_stack([np.repeat(xy, len(theta), axis=0), np.tile(theta, len(xy))])
        return self._predict(X, (xy, theta), std=False, calibrated=False, source="posterior")

    def _predict(self, X, grid, *, std: bool, calibrated: bool, source: str) -> xr.Dataset:
        if source != "posterior" and self.model not in SAVEABLE:
            raise InputError(f"leave-one-out and training-data predictions need a Gaussian-process learner "
                             f"({', '.join(SAVEABLE)}), not {self.model!r}")
        at = {} if source == "posterior" else {"source": source}

        def means(learner):
            """A learner's means at X, over the grid's factors where it can."""
            if grid is not None and hasattr(learner, "predict_product"):
                return learner.predict_product(*grid)
            return learner.predict(X, **at)

        def moments(learner):
            """A learner's means and standard deviations at X (NaN where not asked for)."""
            if std or at:
                mu, sd = (np.asarray(v, float) for v in learner.predict(X, return_std=True, **at))
                return mu, (sd * _scale_of(learner, sd.shape[1]) if calibrated else sd)
            mu = np.asarray(means(learner), float)
            return mu, np.full(mu.shape, np.nan)

        n = len(X)
        main, main_sd, ay = self._modal_arrays(*moments(self.learner_), n)
        outside = self.outside_hull(X)
        if outside.any():
            warnings.warn(f"{int(outside.sum())} of {n} postures lie outside the training postures' "
                          "hull: the predictions there extrapolate (see modal_std)",
                          ExtrapolationWarning, stacklevel=2)
        tight = self._tight_poles(moments, main, main_sd)
        # every variable and coordinate in one constructor call: successive assign()s re-align
        # the whole dataset each time, which cost more than the GPs (about 3 of 5.7 ms)
        data_vars = {"modal": (("posture", "mode", "param"), main),
                     "modal_std": (("posture", "mode", "param"), main_sd),
                     "phiL_1aY": (("posture", "mode"), ay),
                     "outside_hull": ("posture", outside)}
        coords = {"posture": np.arange(n), "x": ("posture", X[:, 0]), "y": ("posture", X[:, 1]),
                  "theta": ("posture", X[:, 2]), "mode": self.modes_,
                  "mode_band": ("mode", self.mode_band_), "phiL_ref": ("mode", self.phiL_ref_),
                  "param": list(self.params_)}
        if self.residual_learner_ is not None:
            self._add_residuals(data_vars, coords, np.asarray(means(self.residual_learner_), float))
        if self.clusters_:
            self._add_clusters(data_vars, coords, [np.asarray(means(lr), float) for lr in self.cluster_learners_],
                               tight)
        return self._prediction(data_vars, coords)

    def _modal_arrays(self, mu_live, sd_live, n: int):
        """The learnt columns' means and standard deviations (n, n_live) with the constant ones,
        as ``modal`` and ``modal_std`` (n, mode, param) and ``phiL_1aY`` (n, mode), in the
        dataset's normalisation."""
        n_tasks, n_modes, n_p = len(self.tasks_), len(self.modes_), len(self.params_)
        mu = np.tile(self.constant_, (n, 1))
        sd = np.zeros((n, n_tasks))
        sd[:, np.isnan(self.constant_)] = np.nan
        mu[:, self.live_], sd[:, self.live_] = mu_live, sd_live
        main = mu[:, :n_modes * n_p].reshape(n, n_modes, n_p)
        main_sd = sd[:, :n_modes * n_p].reshape(n, n_modes, n_p)
        ay = (mu[:, n_modes * n_p:n_modes * (n_p + 1)] + 1j * mu[:, n_modes * (n_p + 1):]
              if n_tasks > n_modes * n_p else np.ones((n, n_modes), complex))
        if self.vectors == "gauge":
            ay_sd = sd[:, n_modes * n_p:n_modes * (n_p + 1)] + 1j * sd[:, n_modes * (n_p + 1):]
            main, ay, main_sd, _ = from_gauge(main, ay, self.phiL_ref_, main_sd, ay_sd)
        return main, main_sd, ay

    def _tight_poles(self, moments, main, main_sd) -> np.ndarray:
        """The tight veerings' poles from their learnt polynomials, (n, mode) complex rad/s (NaN
        for other modes); their modes' f_n and ζ in ``main`` and ``main_sd`` are set from them."""
        i_f, i_z = self.params_.index("f_n"), self.params_.index("zeta")
        tight = np.full(main.shape[:2], np.nan, complex)
        for cl, learner in zip(self.pole_clusters_, self.pole_learners_):
            lam, lam_sd = cluster_poles(cl, *moments(learner))
            tight[:, list(cl.modes)] = lam
            idx, w = list(cl.modes), np.abs(lam)
            main[:, idx, i_f], main[:, idx, i_z] = w / (2 * np.pi), -lam.real / w
            main_sd[:, idx, i_f], main_sd[:, idx, i_z] = lam_sd[..., 0], lam_sd[..., 1]
        return tight

    def _add_residuals(self, data_vars: dict, coords: dict, y: np.ndarray) -> None:
        """The bands' residual terms from their learner's means ``y`` (n, 2 x entries: real parts,
        then imaginary), into ``data_vars`` and ``coords``."""
        half = y.shape[1] // 2
        z = (y[:, :half] + 1j * y[:, half:]).reshape(len(y), len(self.residual_bands_), len(RESIDUAL_TERMS), 4, 4)
        data_vars["residual"] = (("posture", "fit_band", "term", "out", "inp"), z)
        coords.update(fit_band=list(self.residual_bands_), residual_f_max=("fit_band", list(self.residual_f_max_)),
                      term=list(RESIDUAL_TERMS), out=list(COORDS), inp=list(COORDS))

    def _add_clusters(self, data_vars: dict, coords: dict, features: list, tight: np.ndarray) -> None:
        """The veering clusters' poles and full residues from their learnt invariants (one (n, k)
        array per cluster), into ``data_vars`` and ``coords``."""
        n, n_modes = tight.shape
        pole = np.full((n, n_modes), np.nan, complex)
        residue = np.full((n, n_modes, 4, 4), np.nan, complex)
        for cl, f in zip(self.clusters_, features):
            # a tight veering inside the cluster keeps its own poles, the ones ``modal`` reports
            # (at the validation postures the low band's worst cross peak 18.8 -> 14.0 %)
            lam, R = cluster_residues(cl, f, poles=tight[:, list(cl.modes)])
            pole[:, list(cl.modes)], residue[:, list(cl.modes)] = lam, R
        data_vars["cluster_pole"] = (("posture", "mode"), pole)
        data_vars["cluster_residue"] = (("posture", "mode", "out", "inp"), residue)
        coords.update(out=list(COORDS), inp=list(COORDS))

    def _prediction(self, data_vars: dict, coords: dict) -> xr.Dataset:
        """The prediction dataset of its variables and coordinates, with its attributes."""
        out = xr.Dataset(
            data_vars, coords=coords,
            attrs={"kind": "modal_prediction", "model": self.model, "rmbench_version": __version__,
                   "vectors": self.vectors,
                   "modes_from_poles": json.dumps([list(map(int, c.modes)) for c in self.pole_clusters_]),
                   "modal_std_is": "standard deviation of the latent function (no noise)"
                                   + ("; mode vectors' to first order from the gauge's"
                                      if self.vectors == "gauge" else "")})
        if self.clusters_:
            out["cluster_pole"].attrs["description"] = ("pole of a veering cluster's mode from the "
                                                        "cluster's learnt invariants, rad/s (NaN: no cluster)")
            out["cluster_residue"].attrs["description"] = ("its full residue matrix R_r (receptance "
                                                           "R_r/(s-λ_r) + conj), m/N rad/s")
        return out

    # -- plain-file persistence (rmbench.predict.persist) -------------------------------------------
    def save(self, path) -> Path:
        """Write the predictor to one ``.npz`` (arrays + JSON metadata; no pickle), atomically."""
        return save_predictor(self, path)

    @classmethod
    def load(cls, path) -> "PosturePredictor":
        """Read a predictor written by :meth:`save` (arrays only; nothing is unpickled)."""
        self = load_predictor(cls, path)
        self._hull()
        return self

def _scale_of(learner, n_columns: int) -> np.ndarray:
    """A learner's leave-one-posture-out factors on its standard deviations (ones for a learner
    without them), shape (n_columns,)."""
    return np.asarray(learner.std_scale(), float) if hasattr(learner, "std_scale") else np.ones(n_columns)


def _entry_learner(model: str, n_columns: int):
    """The learner of the residual terms' and the clusters' invariants: one single-task GP per
    column (fitted as one batch) for every GP model, the model itself per column for the baselines.

    Why not one Kronecker MTGP: its one posture kernel serves every column, and where one column
    varies sharply (or is mostly noise) the shared length scales collapse to the lower bound, 0.4°
    in θ and 2 mm in x, y on the stand-in's grid, so between the grid's postures it predicts the
    grid mean (at 200 unseen postures the low cluster's frequencies were 5-18 % off, p95)."""
    if model in MULTI_TASK:
        return GroupedMTGP([[j] for j in range(n_columns)])
    return PerTask(model)


def _pole_learner(model: str, n_columns: int):
    """The learner of a tight cluster's polynomial coefficients: one multi-task GP of all columns
    for the multi-task models (the 2 n coefficients share how the poles move), one GP per column for
    ``stgp``, the model itself per column for the baselines."""
    if model == "stgp":
        return GroupedMTGP([[j] for j in range(n_columns)])
    if model in MULTI_TASK:
        return GroupedMTGP([list(range(n_columns))])
    return PerTask(model)
