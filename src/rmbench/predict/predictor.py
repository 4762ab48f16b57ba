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
from rmbench.io.npz_file import read_npz, write_npz
from rmbench.modal.campaign_fit import COORDS, mode_vectors
from rmbench.modal.mdof import synthesize
from rmbench.modal.residual import RESIDUAL_TERMS, residual_frf
from rmbench.predict.baselines import MULTI_TASK, PerTask, make_learner
from rmbench.predict.cluster import (ModeCluster, cluster_features, cluster_poles, cluster_residues, pole_features,
                                     poles_of, round_off_features, veering_clusters)
from rmbench.predict.data import constant_tasks, frequency_ordered, training_set
from rmbench.predict.gauge import _vectors, from_gauge, gauge_directions, to_gauge
from rmbench.predict.gp import MTGP, _torch
from rmbench.predict.mtgp import GroupedMTGP
from rmbench.robot.modes import PARAMS
from rmbench.threads import run_concurrently

__all__ = ["PosturePredictor", "ExtrapolationWarning", "predicted_frf", "SAVEABLE"]

SAVEABLE = MULTI_TASK
_FORMAT = 1
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
        phi_l, phi_r = _vectors(modal, ay)
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
        """Whether each posture (x, y, θ row) lies outside the training postures' convex hull."""
        return self.hull_distance(X) > 1e-9

    def hull_distance(self, X) -> np.ndarray:
        """How far each posture (x, y, θ row) lies outside the training postures' convex hull, in
        the training postures' standard deviations per coordinate (0 inside; the largest distance
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

        if std or at:
            mu_live, sd_live = self.learner_.predict(X, return_std=True, **at)
            if calibrated:
                sd_live = sd_live * _scale_of(self.learner_, sd_live.shape[1])
        else:
            mu_live = means(self.learner_)
            sd_live = np.full(np.shape(mu_live), np.nan)
        n, n_tasks = len(X), len(self.tasks_)
        mu = np.tile(self.constant_, (n, 1))
        sd = np.zeros((n, n_tasks))
        sd[:, np.isnan(self.constant_)] = np.nan
        mu[:, self.live_], sd[:, self.live_] = mu_live, sd_live
        outside = self.outside_hull(X)
        if outside.any():
            warnings.warn(f"{int(outside.sum())} of {n} postures lie outside the training postures' "
                          "hull: the predictions there extrapolate (see modal_std)",
                          ExtrapolationWarning, stacklevel=2)
        n_modes, n_p = len(self.modes_), len(self.params_)
        main = mu[:, :n_modes * n_p].reshape(n, n_modes, n_p)
        main_sd = sd[:, :n_modes * n_p].reshape(n, n_modes, n_p)
        ay = (mu[:, n_modes * n_p:n_modes * (n_p + 1)] + 1j * mu[:, n_modes * (n_p + 1):]
              if n_tasks > n_modes * n_p else np.ones((n, n_modes), complex))
        if self.vectors == "gauge":
            ay_sd = sd[:, n_modes * n_p:n_modes * (n_p + 1)] + 1j * sd[:, n_modes * (n_p + 1):]
            main, ay, main_sd, _ = from_gauge(main, ay, self.phiL_ref_, main_sd, ay_sd)
        i_f, i_z = self.params_.index("f_n"), self.params_.index("zeta")
        tight = np.full((n, n_modes), np.nan, complex)       # the tight veerings' poles
        for cl, learner in zip(self.pole_clusters_, self.pole_learners_):
            if std or at:
                mu_c, sd_c = (np.asarray(v, float) for v in learner.predict(X, return_std=True, **at))
            else:
                mu_c = np.asarray(means(learner), float)
                sd_c = np.full(mu_c.shape, np.nan)
            if calibrated:
                sd_c = sd_c * _scale_of(learner, sd_c.shape[1])
            lam, lam_sd = cluster_poles(cl, mu_c, sd_c)
            tight[:, list(cl.modes)] = lam
            idx, w = list(cl.modes), np.abs(lam)
            main[:, idx, i_f], main[:, idx, i_z] = w / (2 * np.pi), -lam.real / w
            main_sd[:, idx, i_f], main_sd[:, idx, i_z] = lam_sd[..., 0], lam_sd[..., 1]
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
            y = np.asarray(means(self.residual_learner_), float)
            half = y.shape[1] // 2
            z = (y[:, :half] + 1j * y[:, half:]).reshape(n, len(self.residual_bands_), len(RESIDUAL_TERMS), 4, 4)
            data_vars["residual"] = (("posture", "fit_band", "term", "out", "inp"), z)
            coords.update(fit_band=list(self.residual_bands_), residual_f_max=("fit_band", list(self.residual_f_max_)),
                          term=list(RESIDUAL_TERMS), out=list(COORDS), inp=list(COORDS))
        if self.clusters_:
            pole = np.full((n, n_modes), np.nan, complex)
            residue = np.full((n, n_modes, 4, 4), np.nan, complex)
            for cl, learner in zip(self.clusters_, self.cluster_learners_):
                # a tight veering inside the cluster keeps its own poles, the ones ``modal`` reports
                # (at the validation postures the low band's worst cross peak 18.8 -> 14.0 %)
                lam, R = cluster_residues(cl, np.asarray(means(learner), float),
                                          poles=tight[:, list(cl.modes)])
                pole[:, list(cl.modes)], residue[:, list(cl.modes)] = lam, R
            data_vars["cluster_pole"] = (("posture", "mode"), pole)
            data_vars["cluster_residue"] = (("posture", "mode", "out", "inp"), residue)
            coords.update(out=list(COORDS), inp=list(COORDS))
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

    # -- plain-file persistence -------------------------------------------------------------------
    def save(self, path) -> Path:
        """Write the predictor to one ``.npz`` (arrays + JSON metadata; no pickle), atomically."""
        path = Path(path)
        if self.model not in SAVEABLE:
            raise InputError(f"only the Gaussian-process learners ({', '.join(SAVEABLE)}) are saved "
                             f"as plain arrays; {self.model!r} would need pickle")
        learner = self.learner_
        models = learner.models_ if isinstance(learner, GroupedMTGP) else [learner]
        groups = learner.groups if isinstance(learner, GroupedMTGP) else [list(range(len(self.live_)))]
        arrays = {"X_train": self.X_train_, "live": self.live_, "constant": self.constant_}
        for i, m in enumerate(models):
            arrays.update({f"m{i}/{k}": v for k, v in _state(m).items()})
        if self.residual_learner_ is not None:
            arrays.update(_grouped_state("residual", self.residual_learner_))
        for i, learner in enumerate(self.cluster_learners_):
            arrays.update(_grouped_state(f"cluster{i}", learner))
        for i, learner in enumerate(self.pole_learners_):
            arrays.update(_grouped_state(f"poles{i}", learner))
        meta = {"format": _FORMAT, "rmbench_version": __version__, "model": self.model,
                "order": self.order, "vectors": self.vectors,
                "tasks": list(self.tasks_), "modes": self.modes_.tolist(), "params": list(self.params_),
                "mode_band": self.mode_band_.tolist(), "phiL_ref": self.phiL_ref_.tolist(),
                "groups": [list(map(int, g)) for g in groups], "train_seconds": self.train_seconds_,
                "source": self.source_, "residual_bands": list(self.residual_bands_),
                "residual_f_max": list(self.residual_f_max_),
                "residual_seconds": self.residual_seconds_, "clusters_option": self.clusters,
                "entry_learners": "per column",
                "clusters": [{"modes": list(map(int, c.modes)), "center": [c.center.real, c.center.imag],
                              "radius": c.radius} for c in self.clusters_],
                "cluster_seconds": self.cluster_seconds_,
                "pole_clusters": [{"modes": list(map(int, c.modes)), "center": [c.center.real, c.center.imag],
                                   "radius": c.radius} for c in self.pole_clusters_]}
        return write_npz(path, meta, arrays)

    @classmethod
    def load(cls, path) -> "PosturePredictor":
        """Read a predictor written by :meth:`save` (arrays only; nothing is unpickled)."""
        path = Path(path)
        if not path.is_file():
            raise InputError(f"predictor not found: {path}")
        try:
            meta, a = read_npz(path, _FORMAT)
            # files written before the gauge learnt the dataset's normalisation
            order = meta.get("order", "frequency")
            self = cls(meta["model"], order, meta.get("vectors", "dataset"),
                       meta.get("clusters_option", "auto" if order == "frequency" else "none"))
            self.tasks_ = tuple(meta["tasks"])
            self.modes_ = np.asarray(meta["modes"], int)
            self.params_ = tuple(meta["params"])
            self.mode_band_ = np.asarray(meta["mode_band"], str)
            self.phiL_ref_ = np.asarray(meta["phiL_ref"], str)
            self.train_seconds_ = float(meta["train_seconds"])
            self.source_ = str(meta.get("source", ""))
            self.X_train_ = np.asarray(a["X_train"], float)
            self.live_ = np.asarray(a["live"], int)
            self.constant_ = np.asarray(a["constant"], float)
            models = [_from_state({k.split("/", 1)[1]: v for k, v in a.items()
                                   if k.startswith(f"m{i}/")}) for i in range(len(meta["groups"]))]
            # files written before the residual terms were learnt have none
            self.residual_bands_ = tuple(meta.get("residual_bands", ()))
            self.residual_f_max_ = tuple(float(v) for v in meta.get("residual_f_max", ()))
            self.residual_seconds_ = float(meta.get("residual_seconds", 0.0))
            # files written before the terms were learnt per column hold one Kronecker MTGP
            per_column = meta.get("entry_learners") == "per column"
            self.residual_learner_ = (_grouped_from_state("residual", a, per_column)
                                      if self.residual_bands_ else None)
            # files written before veering clusters were learnt have none
            self.clusters_ = tuple(ModeCluster(tuple(c["modes"]), complex(*c["center"]), float(c["radius"]))
                                   for c in meta.get("clusters", ()))
            self.cluster_learners_ = [_grouped_from_state(f"cluster{i}", a, True)
                                      for i in range(len(self.clusters_))]
            self.cluster_seconds_ = float(meta.get("cluster_seconds", 0.0))
            # files written before tight veerings took their frequencies from poles have none
            self.pole_clusters_ = tuple(ModeCluster(tuple(c["modes"]), complex(*c["center"]), float(c["radius"]))
                                        for c in meta.get("pole_clusters", ()))
            self.pole_learners_ = [_grouped_from_state(f"poles{i}", a, True) for i in range(len(self.pole_clusters_))]
        except (OSError, ValueError, KeyError, TypeError) as err:
            raise InputError(f"{path}: not an rmbench predictor ({type(err).__name__}: {err})") from None
        if meta["model"] in ("mtgp", "mtgp-lowrank"):
            self.learner_ = models[0]
        else:
            g = GroupedMTGP(meta["groups"])
            g.models_, g.n_tasks_ = models, len(self.live_)
            self.learner_ = g
        self._hull()
        return self


_STATE_SCALARS = ("n_tasks_", "dropped_")
_STATE_ARRAYS = ("varying_", "constant_", "x_mean_", "x_scale_", "y_mean_", "y_scale_", "loo_scale_", "y_fit_",
                 "loo_mu_", "loo_sd_")


def _state(m: MTGP) -> dict:
    """Plain arrays of a fitted MTGP (see :func:`_from_state`)."""
    out = {k: np.asarray(getattr(m, k)) for k in _STATE_SCALARS + _STATE_ARRAYS if hasattr(m, k)}
    if m.posterior_ is not None:
        out.update({f"post/{k}": v for k, v in m.posterior_.arrays().items()})
    return out


def _from_state(a: dict) -> MTGP:
    from rmbench.predict.posterior import KronPosterior

    m = MTGP()
    for k in _STATE_SCALARS:
        setattr(m, k, int(a[k]))
    for k in _STATE_ARRAYS:
        if k in a:
            setattr(m, k, np.asarray(a[k]))
    # a group left unlearnt (its mode found at too few postures) has no varying tasks
    m.varying_ = np.asarray(getattr(m, "varying_", ()), int)
    if not hasattr(m, "loo_scale_"):       # a file saved before the scales were kept: uncalibrated
        m.loo_scale_ = np.ones(m.n_tasks_)
    post = {k[5:]: v for k, v in a.items() if k.startswith("post/")}
    m.posterior_ = KronPosterior.from_arrays(post) if post else None
    return m


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


def _grouped_state(prefix: str, learner) -> dict:
    """Plain arrays of a GroupedMTGP of single columns (``{prefix}/m{j}/...``)."""
    if not isinstance(learner, GroupedMTGP):
        raise InputError("only Gaussian-process learners are saved as plain arrays")
    out = {f"{prefix}/groups": np.array([len(g) for g in learner.groups])}
    for j, m in enumerate(learner.models_):
        out.update({f"{prefix}/m{j}/{k}": v for k, v in _state(m).items()})
    return out


def _grouped_from_state(prefix: str, a: dict, per_column: bool):
    if not per_column:                 # one Kronecker MTGP under ``{prefix}/``
        return _from_state({k.split("/", 1)[1]: v for k, v in a.items() if k.startswith(f"{prefix}/")})
    sizes = np.asarray(a[f"{prefix}/groups"], int)
    start = np.concatenate([[0], np.cumsum(sizes)])
    g = GroupedMTGP([list(range(start[j], start[j + 1])) for j in range(len(sizes))])
    g.models_ = [_from_state({k[len(f"{prefix}/m{j}/"):]: v for k, v in a.items()
                              if k.startswith(f"{prefix}/m{j}/")}) for j in range(len(sizes))]
    g.n_tasks_ = int(start[-1])
    return g


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
