"""Posture prediction (issue 15): the default predictor, STGP and a kNN baseline on the seed's full campaign, scored against the truth.

Prediction quality is judged against the exact modes and FRFs at postures no learner saw, never by
cross-validated R² (veering modes make that meaningless). Learners: the grouped MTGP
(``mtgp-grouped``, :class:`rmbench.predict.PosturePredictor`'s default), one STGP per parameter
(``stgp``) and inverse-distance k nearest neighbours (``knn``, the cheap baseline); each learns the
modes of each band in order of frequency (the predictor's default) with its own veering clusters
and residual terms.

1. Data: the seed's full campaign (112 postures, time domain, hand-held hammer) fitted by the modal
   stage (``--modal`` reuses a fit; otherwise ``DIR/seed_full.nc`` of ``--work`` is fitted, the
   campaign run first where it is missing). Exact modes and FRFs come from linear-path campaigns
   (same robot, sensors and hammer as tested), kept in ``--work``.
2. The seed's three validation postures against the exact modes: RE per natural frequency and
   damping ratio (the seed's Tables 2-3) per learner; the default predictor's tool-tip FRFs rebuilt
   from its parameters (Eq. 15) against the exact FRFs at every exact peak (``peak_errors``), the
   same with each mode alone (no veering clusters), and the modal fit itself rebuilt at its grid
   postures (the data's floor).
3. 200 unseen quasi-random postures (Sobol, inside the grid's box) against the exact modes (the
   modal stage's pairing): per learner and mode the 50th and 95th percentiles of the relative
   |f error| and |ζ error|, and the predicted modes paired with no exact mode; the same for the
   modes learnt as the modal stage tracked them (default predictor and STGP); the tight veering's
   frequencies from its cluster's poles against each mode learnt alone, also on two fresh Sobol sets.
4. The FRFs there: each band's 4 x 4 receptance rebuilt from each learner's predicted parameters
   (with the band's residual terms) against the exact one; per entry max |ΔH| / max |H_exact| over
   the band's lines; 50th and 95th percentiles over the postures, both bands and the entries of
   each class: direct (diagonal), same direction (1X-1aX, 1Y-1aY), X<->Y cross (the classes of
   bench/campaign_speed.py); for the default predictor also with each mode alone.
5. Training time of one Kronecker MTGP against its number of tasks m (the seed's MATLAB: 88.86 s at
   m = 5; a model of every parameter is skipped, in one line, where no three postures have every
   one); each learner's training time; prediction time at one posture.
6. Learning curve: the 95th percentile of |f error| at the unseen postures (the largest over the
   modes) against the number of hammered grid postures, space-filling (maximin) subsets of the grid
   against active selection (largest predictive variance first, batches of 8).

``--quick``: 50 unseen postures, no fresh Sobol sets, tracked identities, floor or learning curve.

Last line: ``{"unseen_fn_err_p95", "unseen_zeta_err_p95", "frf_err_p95_direct", "frf_err_p95_same",
"frf_err_p95_cross", "re_fn_max", "re_zeta_max", "stgp_unseen_fn_err_p95",
"baseline_unseen_fn_err_p95", "train_s_grouped", "predict_ms"}``, the default predictor's unless
prefixed (``baseline``: kNN): the unseen f and ζ figures are the largest over the modes of each
mode's 95th percentile of the relative error (modes in frequency order); the FRF figures the 95th
percentile over the unseen postures, both bands and the class's entries of max |ΔH| / max |H_exact|;
RE the largest at the validation postures; ``train_s_grouped`` the parameters' learner (s, 2 cores,
beside the clusters' and residual terms' learners); ``predict_ms`` one posture with standard
deviations. Strict JSON (null for a figure that could not be computed).

usage: python bench/predict.py [--modal MODAL.nc] [--work DIR] [--quick]
"""

from __future__ import annotations

import argparse
import copy
import os
import tempfile
import time
import warnings
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")   # torch's idle threads sleep beside other jobs

import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402
from scipy.stats import qmc  # noqa: E402

from rmbench.impact import load_config, open_campaign, run_campaign  # noqa: E402
from rmbench.io.strict_json import strict_dumps  # noqa: E402
from rmbench.modal.campaign_fit import truth_errors  # noqa: E402
from rmbench.predict import PerTask, PosturePredictor, make_learner, predicted_frf, training_set  # noqa: E402
from rmbench.predict.data import TrainingSet, constant_tasks, frequency_ordered  # noqa: E402
from rmbench.predict.gp import MTGP  # noqa: E402
from rmbench.robot import validation_postures  # noqa: E402

DEFAULT, BASELINE = "mtgp-grouped", "knn"
LEARNERS = (DEFAULT, "stgp", BASELINE)
TOOL_TIP = (("1X", "1X"), ("1Y", "1Y"), ("1X", "1Y"), ("1Y", "1X"))
COORDS = ("1X", "1Y", "1aX", "1aY")
# the 16 entries of H (row-major over 1X, 1Y, 1aX, 1aY): 0 direct, 1 same direction, 2 X<->Y
# cross, as in bench/campaign_speed.py
_DIR = np.array([0, 1, 0, 1])
ENTRY_CLASS = np.where(np.eye(4, dtype=bool), 0, np.where(_DIR[:, None] == _DIR[None, :], 1, 2)).ravel()
CLASSES = ("direct", "same", "cross")


def modal_dataset(args, work: Path) -> xr.Dataset:
    if args.modal:
        return xr.load_dataset(args.modal)
    from rmbench.modal.campaign_fit import fit_campaign

    data = work / "seed_full.nc"
    if not data.exists():
        t0 = time.perf_counter()
        run_campaign(load_config("seed_full"), data, workers=2, progress=True)
        print(f"campaign: {time.perf_counter() - t0:.0f} s")
    t0 = time.perf_counter()
    fit = fit_campaign(open_campaign(data), workers=2)
    fit.to_netcdf(work / "modal_full.nc", engine="h5netcdf", invalid_netcdf=True)
    print(f"modal fit: {time.perf_counter() - t0:.0f} s")
    return fit


def truth_campaign(postures_mm_deg, work: Path, name: str) -> xr.Dataset:
    """Exact modes and FRFs (as tested) at the given postures: a linear-path campaign."""
    out = work / f"truth_{name}.nc"
    if not out.exists():
        cfg = load_config("seed_full").with_overrides(
            name=f"truth_{name}", method="linear",
            grid={"kind": "list", "postures": [list(map(float, p)) for p in postures_mm_deg]})
        run_campaign(cfg, out, workers=2, progress=False)
    return open_campaign(out)


def unseen_postures(n: int = 200, seed: int = 15) -> np.ndarray:
    """Quasi-random (x mm, y mm, θ deg) inside the seed grid's box, none on a grid point."""
    s = qmc.Sobol(3, seed=seed).random(n)
    lo, hi = np.array([1300.0, -300.0, -60.0]), np.array([1900.0, 300.0, 60.0])
    return lo + s * (hi - lo)


def si(p_mm_deg: np.ndarray) -> np.ndarray:
    p = np.atleast_2d(p_mm_deg)
    return np.column_stack([p[:, 0] / 1e3, p[:, 1] / 1e3, np.radians(p[:, 2])])


def bands_of(ds: xr.Dataset) -> np.ndarray:
    f = ds.freq.values
    return ds.band.values if "band" in ds.coords else np.where(f < 300, "low", "high")


def pct(a, q, axis=None):
    """NaN-aware percentile; NaN where nothing is finite (no warning)."""
    a = np.asarray(a, float)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanpercentile(a, q, axis=axis)


def worst(v) -> float:
    v = np.asarray(v, float)
    return float(np.nanmax(v)) if np.isfinite(v).any() else np.nan


# --- 2. validation postures --------------------------------------------------------------------
def peak_errors(H_pred: np.ndarray, H_ex: np.ndarray, freq: np.ndarray, band: np.ndarray) -> list:
    """Per tool-tip entry and exact peak: |max |H_pred| near the peak| / |H_exact| at the peak − 1.

    Peaks: local maxima of |H_exact| above 10 % of the entry's largest value in its band. The
    predicted peak is the local maximum of |H_pred| nearest the exact peak within ±3 % of its
    frequency (a 1 % frequency error must not read as a magnitude error), or |H_pred| at the exact
    peak's line where the prediction has no maximum there. Not the window's largest |H_pred|: a
    shallow peak on the flank of a larger mode would read that mode's flank at the window's edge
    (a 1Y1X peak at 814 Hz read +13.5 % that way; its own maximum is 2.5 % low)."""
    out = []
    for o, i in TOOL_TIP:
        a, b = COORDS.index(o), COORDS.index(i)
        for bnd in np.unique(band):
            sel = np.flatnonzero(band == bnd)
            h = np.abs(H_ex[sel, a, b])
            hp = np.abs(H_pred[sel, a, b])
            f = freq[sel]
            top = h.max()
            for k in range(1, len(sel) - 1):
                if h[k] >= h[k - 1] and h[k] >= h[k + 1] and h[k] > 0.1 * top:
                    near = np.flatnonzero(np.abs(f - f[k]) <= 0.03 * f[k])
                    tops = [j for j in near if 0 < j < len(f) - 1 and hp[j] >= hp[j - 1] and hp[j] >= hp[j + 1]]
                    j = min(tops, key=lambda j: abs(j - k)) if tops else k
                    out.append({"entry": f"{o}{i}", "band": str(bnd), "f": float(f[k]),
                                "err": float(hp[j] / h[k] - 1)})
    return out


def alone_of(pp: PosturePredictor) -> PosturePredictor:
    """The predictor with its tight veerings' frequencies from each mode's own learner (its
    clusters' poles not used); drop ``cluster_pole``/``cluster_residue`` from its predictions to
    rebuild FRFs from each mode alone."""
    alone = copy.copy(pp)
    alone.pole_clusters_, alone.pole_learners_ = (), []
    return alone


def no_clusters(out: xr.Dataset) -> xr.Dataset:
    return out.drop_vars(["cluster_pole", "cluster_residue"], errors="ignore")


def validation(preds: dict, work: Path, floor_of: xr.Dataset | None, grid_mm) -> dict:
    vp = validation_postures()
    vp_mm = np.array([[1e3 * p.x, 1e3 * p.y, np.degrees(p.theta)] for p in vp])
    tv = truth_campaign(vp_mm, work, "validation")
    print("\nValidation postures (seed's Tables 2-3): RE against the exact modes, %")
    re = {}
    for name, pp in preds.items():
        e = truth_errors(pp.predict(si(vp_mm)), tv)
        re[name] = (np.abs(e.f_err.values), np.abs(e.zeta_err.values))
        print(f"  {name:<13} max RE f_n {100 * worst(re[name][0]):.2f} %, ζ {100 * worst(re[name][1]):.2f} %; "
              f"unpaired modes {int(np.isnan(e.f_err.values).sum())}")
    f_re, z_re = re[DEFAULT]
    for k, p in enumerate(vp_mm):
        print(f"  {DEFAULT} ({p[0]:.0f}, {p[1]:.0f}, {p[2]:.0f}): f_n RE " + " ".join(f"{100 * v:.2f}" for v in f_re[k])
              + " | ζ RE " + " ".join(f"{100 * v:.1f}" for v in z_re[k]))
    freq, band = tv.freq.values, bands_of(tv)
    out = preds[DEFAULT].predict(si(vp_mm))
    H_pred = predicted_frf(out, freq)
    peaks = [pe for k in range(len(vp_mm)) for pe in peak_errors(H_pred[k], tv.H_exact.values[k], freq, band)]
    pk = np.array([abs(p["err"]) for p in peaks])
    print(f"  rebuilt tool-tip FRFs ({DEFAULT}): {len(pk)} exact peaks, |peak error| median "
          f"{100 * np.median(pk):.1f} %, max {100 * pk.max():.1f} %, within 10 %: {np.mean(pk <= 0.10):.2f}")
    for cls, entries in (("direct entries (1X1X, 1Y1Y)", ("1X1X", "1Y1Y")), ("X<->Y cross entries", ("1X1Y", "1Y1X"))):
        pc = np.array([abs(p["err"]) for p in peaks if p["entry"] in entries])
        print(f"    {cls:<28} {len(pc):>3} peaks: max {100 * pc.max():.1f} %, within 10 %: {np.mean(pc <= 0.10):.2f}")
    for p in sorted(peaks, key=lambda p: -abs(p["err"]))[:4]:
        print(f"    {p['entry']} {p['band']} {p['f']:.1f} Hz: {100 * p['err']:+.1f} %")
    H_alone = predicted_frf(no_clusters(alone_of(preds[DEFAULT]).predict(si(vp_mm))), freq)
    pa = np.array([abs(pe["err"]) for k in range(len(vp_mm))
                   for pe in peak_errors(H_alone[k], tv.H_exact.values[k], freq, band)])
    cl = preds[DEFAULT].clusters_
    print(f"  the same from each mode alone (veering clusters {[c.modes for c in cl]} not used): "
          f"|peak error| median {100 * np.median(pa):.1f} %, max {100 * pa.max():.1f} %, within 10 %: "
          f"{np.mean(pa <= 0.10):.2f}")
    if floor_of is not None:
        fit_floor(floor_of, truth_campaign(grid_mm, work, "grid"))
    return {"re_fn_max": worst(f_re), "re_zeta_max": worst(z_re)}


def fit_floor(fit: xr.Dataset, tg: xr.Dataset) -> None:
    """The modal fit itself rebuilt like a prediction at the grid postures it was fitted at."""
    fg, bg = tg.freq.values, bands_of(tg)
    H_fit = predicted_frf(fit, fg)
    floor = [pe for k in range(H_fit.shape[0]) for pe in peak_errors(H_fit[k], tg.H_exact.values[k], fg, bg)]
    print(f"  the modal fit itself rebuilt the same way at its {H_fit.shape[0]} grid postures (the data's floor):")
    for cls, entries in (("direct", ("1X1X", "1Y1Y")), ("X<->Y cross", ("1X1Y", "1Y1X"))):
        for b in np.unique(bg):
            pc = np.array([abs(p["err"]) for p in floor if p["entry"] in entries and p["band"] == b])
            print(f"    {cls:<12} {b:<5} {len(pc):>4} peaks: max {100 * pc.max():.1f} %, "
                  f"p95 {100 * np.quantile(pc, 0.95):.1f} %, within 10 %: {np.mean(pc <= 0.10):.3f}")


# --- 3. unseen postures: modes -----------------------------------------------------------------
def mode_table(name: str, out: xr.Dataset, truth: xr.Dataset) -> dict:
    """Per mode p50/p95 of the relative |f error| and |ζ error| (printed, %); returns the p95s."""
    e = truth_errors(out, truth)
    fe, ze = np.abs(e.f_err.values), np.abs(e.zeta_err.values)
    rows = {"f p50": pct(fe, 50, 0), "f p95": pct(fe, 95, 0), "ζ p50": pct(ze, 50, 0), "ζ p95": pct(ze, 95, 0)}
    print(f"  {name}")
    for k, v in rows.items():
        print(f"    {k:<10}" + "".join(f"{100 * x:7.2f}" for x in v))
    print(f"    {'unpaired':<10}" + "".join(f"{n:7d}" for n in np.isnan(fe).sum(axis=0)))
    return {"f": rows["f p95"], "zeta": rows["ζ p95"]}


def unseen_modes(preds: dict, X_un, tu, header: str) -> tuple[dict, dict]:
    print(f"\n{len(X_un)} unseen quasi-random postures against the exact modes: per mode (modes in "
          "frequency order), relative |f error| and |ζ error|, 50th and 95th percentiles over the "
          "postures, %, and the predicted modes paired with no exact mode")
    print(header)
    outs, p95 = {}, {}
    for name, pp in preds.items():
        outs[name] = pp.predict(X_un)
        p95[name] = mode_table(name, outs[name], tu)
    return outs, p95


def tracked_modes(ds_tracked: xr.Dataset, X_un, tu) -> None:
    """The same learnt as the modal stage tracked the modes (no veering clusters there)."""
    print("\nModes learnt as the modal stage tracked them (order = tracked) instead of in frequency "
          "order, same postures and percentiles, %")
    md = ds_tracked.modal.values[..., 0]
    print(f"  {'mode':<10}" + "".join(f"{m:7d}" for m in ds_tracked.mode.values))
    print(f"  {'median Hz':<10}" + "".join(f"{v:7.1f}" for v in pct(md, 50, 0)))
    for name in (DEFAULT, "stgp"):
        t0 = time.perf_counter()
        pp = PosturePredictor(name, order="tracked").fit(ds_tracked)
        mode_table(f"{name} (tracked; fitted in {time.perf_counter() - t0:.0f} s)", pp.predict(X_un), tu)


def pole_clusters(pg: PosturePredictor, tu, work: Path, fresh: bool) -> None:
    """Tight veerings' frequencies from their clusters' poles against each mode learnt alone, on
    the unseen set and (``fresh``) two Sobol sets drawn after the clusters' threshold was chosen."""
    alone = alone_of(pg)
    print(f"  {DEFAULT}, modes {[tuple(int(m) for m in c.modes) for c in pg.pole_clusters_]} from their "
          "cluster's poles (default) and each learnt alone: p95 of |f error| per mode, % | max ζ p95")
    for seed in (15, 16, 17) if fresh else (15,):
        t_s = tu if seed == 15 else truth_campaign(unseen_postures(seed=seed), work, f"unseen{seed}")
        pts = unseen_postures(seed=seed)[:t_s.sizes["posture"]]
        for nm, pp in (("poles", pg), ("alone", alone)):
            e = truth_errors(pp.predict(si(pts)), t_s)
            v = pct(np.abs(e.f_err.values), 95, 0)
            print(f"    Sobol seed {seed}, {nm:<6}" + "".join(f"{100 * x:7.2f}" for x in v)
                  + f" | {100 * worst(pct(np.abs(e.zeta_err.values), 95, 0)):.1f}")


# --- 4. unseen postures: FRFs ------------------------------------------------------------------
def frf_errors(out: xr.Dataset, truth: xr.Dataset) -> dict:
    """Per band max |ΔH| / max |H_exact| over the band's lines, shape (n_posture, 16) (row-major
    entries, ENTRY_CLASS), the prediction rebuilt with that band's modes and residual terms."""
    freq, band = truth.freq.values, bands_of(truth)
    res = {}
    for b in np.unique(band):
        sel = band == b
        H = predicted_frf(out, freq[sel], band=str(b))
        Hx = truth.H_exact.values[:, sel]
        res[str(b)] = (np.abs(H - Hx).max(axis=1) / np.abs(Hx).max(axis=1)).reshape(len(H), 16)
    return res


def frf_table(cases: dict, truth: xr.Dataset) -> dict:
    print(f"\nThe FRFs there: 4 x 4 receptance of each band rebuilt from the predicted parameters against "
          "the exact one, per entry max |ΔH| / max |H_exact| over the band's lines; 50th / 95th "
          f"percentile over the {truth.sizes['posture']} postures and the class's entries, %")
    print(f"  {'':<28}{'band':<6}" + "".join(f"{c:>16}" for c in CLASSES))
    p95 = {}
    for name, out in cases.items():
        err = frf_errors(out, truth)
        for b in (*err, "both"):
            e = np.concatenate(list(err.values())) if b == "both" else err[b]
            q = [(pct(e[:, ENTRY_CLASS == k], 50), pct(e[:, ENTRY_CLASS == k], 95)) for k in range(3)]
            print(f"  {name:<28}{b:<6}" + "".join(f"{100 * a:8.1f} /{100 * c:6.1f}" for a, c in q))
        p95[name] = {c: float(q[k][1]) for k, c in enumerate(CLASSES)}
    return p95


# --- 5. timing ---------------------------------------------------------------------------------
def timing(ts: TrainingSet, varying, preds: dict, fit_s: dict, x1) -> float:
    print(f"\nTraining time of one Kronecker MTGP against its number of tasks m ({len(ts.X)} postures, 2 cores; "
          "parameters found at every posture)")
    cols = np.flatnonzero(varying & np.isfinite(ts.Y).all(axis=0))
    for m in [m for m in (1, 2, 3, 5, 10, 20, 40, 80) if m < len(cols)] + [len(cols)]:
        t0 = time.perf_counter()
        MTGP().fit(ts.X, ts.Y[:, cols[:m]])
        print(f"  m = {m:>3}: {time.perf_counter() - t0:6.2f} s"
              + ("   (seed's MATLAB at m = 5: 88.86 s)" if m == 5 else ""), flush=True)
    every = int(np.isfinite(ts.Y[:, varying]).all(axis=1).sum())
    if every < 3:
        print(f"  one Kronecker model of all {int(varying.sum())} varying parameters: skipped, {every} postures "
              "have every one (it needs three; modes found at some postures only)")
    for name, pp in preds.items():
        print(f"  {name:<13} parameters {pp.train_seconds_:6.1f} s; beside them: veering clusters' invariants "
              f"{pp.cluster_seconds_:.1f} s, residual terms {pp.residual_seconds_:.1f} s; whole fit "
              f"{fit_s[name]:.1f} s")
    ms = {}
    for name, pp in preds.items():
        pp.predict(x1)
        t0 = time.perf_counter()
        for _ in range(100):
            pp.predict(x1)
        ms[name] = (time.perf_counter() - t0) / 100 * 1e3
    print("  prediction at one posture (parameters with standard deviations): "
          + ", ".join(f"{k} {v:.2f} ms" for k, v in ms.items()))
    return ms[DEFAULT]


# --- 6. learning curve -------------------------------------------------------------------------
def maximin_order(X: np.ndarray, seed: int = 0) -> np.ndarray:
    """Grid postures in space-filling order (each next one farthest from those chosen)."""
    Z = (X - X.mean(0)) / X.std(0)
    order = [int(np.argmin(np.linalg.norm(Z - Z.mean(0), axis=1)))]
    d = np.linalg.norm(Z - Z[order[0]], axis=1)
    for _ in range(len(X) - 1):
        nxt = int(np.argmax(d))
        order.append(nxt)
        d = np.minimum(d, np.linalg.norm(Z - Z[nxt], axis=1))
    return np.array(order)


def learning_curve(ts: TrainingSet, ds: xr.Dataset, carrier: xr.Dataset, X_un, tu) -> None:
    """f_n learnt alone from growing subsets of the grid, scored at the unseen postures: the
    largest over the modes of the 95th percentile of the relative |f error| (the modal stage's
    pairing; ``carrier``, a prediction at those postures, lends each mode its other parameters)."""
    fcols = [ts.tasks.index(f"mode{m}:f_n") for m in ds.mode.values]
    sub = TrainingSet(ts.X, ts.Y[:, fcols], tuple(ts.tasks[c] for c in fcols), tuple(ts.bands[c] for c in fcols))

    def p95_f(model) -> float:
        out = carrier.copy(deep=True)
        out["modal"].loc[dict(param="f_n")] = model.predict(X_un)
        return worst(pct(np.abs(truth_errors(out, tu).f_err.values), 95, 0))

    def learner(name):
        return make_learner(name, sub) if name in (DEFAULT, "stgp") else PerTask(name)

    order = maximin_order(ts.X)
    sizes = (16, 24, 32, 48, 64, 88, len(ts.X))
    print("\nLearning curve: 95th percentile of the relative |f error| at the unseen postures (the largest over "
          "the modes), %, against the number of hammered grid postures (f_n learnt alone)")
    print(f"  {'learner':<26}" + "".join(f"{n:>7}" for n in sizes))
    curve = {}
    for name in (DEFAULT, "stgp", BASELINE, "rf"):
        curve[name + " (space-filling)"] = row = [p95_f(learner(name).fit(ts.X[order[:n]], sub.Y[order[:n]]))
                                                  for n in sizes]
        print(f"  {name + ' (space-filling)':<26}" + "".join(f"{100 * v:7.2f}" for v in row), flush=True)
    # active: the first 16 space-filling postures, then batches of 8 of largest summed standardised
    # predictive variance among the grid's remaining postures, refitting after each batch
    for name in ("stgp", DEFAULT):
        chosen, row = list(order[:16]), []
        for n in sizes:
            while len(chosen) < n:
                mdl = learner(name).fit(ts.X[chosen], sub.Y[chosen])
                rest = np.setdiff1d(np.arange(len(ts.X)), chosen)
                _, sd = mdl.predict(ts.X[rest], return_std=True)
                score = np.nansum((sd / np.nanstd(sub.Y[chosen], axis=0)) ** 2, axis=1)
                chosen += list(rest[np.argsort(score)[::-1][:min(8, n - len(chosen))]])
            row.append(p95_f(learner(name).fit(ts.X[chosen], sub.Y[chosen])))
        curve[name + " (active)"] = row
        print(f"  {name + ' (active)':<26}" + "".join(f"{100 * v:7.2f}" for v in row), flush=True)
    for name, row in curve.items():
        hit = [n for n, v in zip(sizes, row) if v <= 0.01]
        print(f"  {name}: p95 <= 1 % first reached at {hit[0] if hit else 'none of the'} postures")


def fit_learners(ds_tracked: xr.Dataset) -> tuple[dict, dict]:
    """Each learner's predictor (defaults: frequency order, gauge, clusters) and its fit's wall time, s."""
    preds, fit_s = {}, {}
    for name in LEARNERS:
        t0 = time.perf_counter()
        preds[name] = PosturePredictor(name).fit(ds_tracked)
        fit_s[name] = time.perf_counter() - t0
    return preds, fit_s


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--modal", help="modal fit of the seed's full campaign (else fit DIR/seed_full.nc, run first if missing)")
    ap.add_argument("--work", help="keep campaigns here (default: a temporary folder)")
    ap.add_argument("--quick", action="store_true",
                    help="50 unseen postures; no fresh Sobol sets, tracked identities, floor or learning curve")
    args = ap.parse_args()
    work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="rmbench_predict_"))
    work.mkdir(parents=True, exist_ok=True)
    warnings.simplefilter("ignore")
    t_start = time.perf_counter()

    import torch

    torch.set_num_threads(2)                # the GPs' timings are for 2 cores
    ds_tracked = modal_dataset(args, work)
    ds = frequency_ordered(ds_tracked)      # as the predictors learn it (PosturePredictor default)
    ts = training_set(ds)
    varying = ~constant_tasks(ts.Y)
    md = ds.modal.values[..., 0]
    print(f"Seed's full campaign fitted by the modal stage: {len(ts.X)} postures, {ds.sizes['mode']} "
          f"modes, {int(varying.sum())} varying parameters ({len(ts.tasks)} columns)")
    header = (f"  {'mode':<10}" + "".join(f"{m:7d}" for m in ds.mode.values) + "\n"
              + f"  {'median Hz':<10}" + "".join(f"{v:7.1f}" for v in pct(md, 50, 0)) + "\n"
              + f"  {'found at':<10}" + "".join(f"{n:7d}" for n in np.isfinite(md).sum(axis=0)))
    print("  modes in frequency order (as learnt), their median frequency and the grid postures where "
          "the modal stage found them\n" + header)
    preds, fit_s = fit_learners(ds_tracked)

    keep = np.asarray(ds["ok"].values, bool) if "ok" in ds else np.ones(ds.sizes["posture"], bool)
    grid_mm = np.column_stack([1e3 * ts.X[:, 0], 1e3 * ts.X[:, 1], np.degrees(ts.X[:, 2])])
    floor_of = None if args.quick else ds.isel(posture=np.flatnonzero(keep))
    re = validation(preds, work, floor_of, grid_mm)

    un_mm = unseen_postures()[:50 if args.quick else 200]
    tu = truth_campaign(un_mm, work, "unseen_quick" if args.quick else "unseen")
    X_un = si(un_mm)
    outs, p95 = unseen_modes(preds, X_un, tu, header)
    pole_clusters(preds[DEFAULT], tu, work, fresh=not args.quick)
    if not args.quick:
        tracked_modes(ds_tracked, X_un, tu)

    cases = dict(outs)
    cases[DEFAULT + ", each mode alone"] = no_clusters(alone_of(preds[DEFAULT]).predict(X_un))
    frf = frf_table(cases, tu)
    ms = timing(ts, varying, preds, fit_s, X_un[:1])
    if not args.quick:
        learning_curve(ts, ds, outs["stgp"], X_un, tu)
    print(f"\nwall time {time.perf_counter() - t_start:.0f} s")

    def r(v, n=5):
        return round(float(v), n) if np.isfinite(v) else None

    print(strict_dumps({
        "unseen_fn_err_p95": r(worst(p95[DEFAULT]["f"])), "unseen_zeta_err_p95": r(worst(p95[DEFAULT]["zeta"])),
        **{f"frf_err_p95_{c}": r(frf[DEFAULT][c], 4) for c in CLASSES},
        "re_fn_max": r(re["re_fn_max"]), "re_zeta_max": r(re["re_zeta_max"], 4),
        "stgp_unseen_fn_err_p95": r(worst(p95["stgp"]["f"])),
        "baseline_unseen_fn_err_p95": r(worst(p95[BASELINE]["f"])),
        "train_s_grouped": r(preds[DEFAULT].train_seconds_, 2), "predict_ms": r(ms, 3)}))


if __name__ == "__main__":
    main()
