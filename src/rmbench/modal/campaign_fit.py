"""Modal fitting of a whole campaign: every posture and band, modes tracked over the postures.

The postures are fitted in parallel (worker processes, :func:`rmbench.parallel.map_cases`);
modes are numbered by frequency at the first posture and tracked by MAC and frequency
(METHODS.md §2, DATA.md ``mode``). Where the dataset carries ground truth (``modal_exact``), each fitted mode is paired with its exact counterpart and
the errors are stored beside the fit.
"""

from __future__ import annotations

import time
import warnings

import numpy as np
import xarray as xr

from rmbench._version import __version__
from rmbench.errors import InputError
from rmbench.impact.dataset import posture_positions, track_modes
from rmbench.modal.residual import RESIDUAL_TERMS, out_of_band_terms
from rmbench.modeshape import mac, pair_modes
from rmbench.parallel import map_cases
from rmbench.robot.modes import PARAMS, ModeTable

__all__ = ["fit_posture", "fit_campaign", "truth_errors", "truth_scores", "renormalise_phi_l",
           "mode_vectors"]

COORDS = ("1X", "1Y", "1aX", "1aY")
_EVIDENCE = ("uncertain", "delta_bic", "share", "n_orders")   # per-mode evidence, in that order


def fit_posture(freq: np.ndarray, H: np.ndarray, coherence: np.ndarray | None, *,
                n_modes: int | None = None, **settings) -> dict:
    """Fit one band of one posture; never raises for a fit that fails (the reason is returned).

    ``settings`` go to :class:`~rmbench.modal.ModalFit` (e.g. ``max_order``).

    Returns
    -------
    dict
        ``ok`` (the fit ran), ``fit_ok`` (it ran and needs no look), ``reason`` (why not, one
        line; "" when ``fit_ok``), ``notes`` (tuple of str), ``seconds``; for a fit that ran,
        ``params`` (n_modes, 16), ``std`` (n_modes, 16), ``phi_r``, ``phi_l`` (n_modes, 4)
        complex, ``nmse`` (4, 4), ``residual`` (3, 4, 4) complex (the fit's out-of-band terms,
        :func:`~rmbench.modal.residual.out_of_band_terms`) and the per-mode evidence
        ``uncertain``, ``delta_bic``, ``share``, ``n_orders`` (n_modes,).
    """
    from rmbench.modal import ModalFit

    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = ModalFit(n_modes=n_modes, **settings).fit(freq, H, coherence=coherence)
    except Exception as err:  # one failed posture must not stop the campaign
        return {"ok": False, "fit_ok": False, "reason": f"{type(err).__name__}: {err}", "notes": (),
                "seconds": time.perf_counter() - t0}
    ev = fit.quality_.evidence
    residual = out_of_band_terms(fit, freq)
    return {"ok": True, "fit_ok": fit.fit_ok_, "reason": fit.fit_reason_,
            "notes": fit.quality_.notes, "params": fit.params_, "std": fit.std_,
            "phi_r": fit.phi_r_, "phi_l": fit.phi_l_, "nmse": fit.nmse_, "residual": residual,
            "uncertain": ev.uncertain, "delta_bic": ev.delta_bic, "share": ev.share,
            "n_orders": ev.n_orders, "seconds": time.perf_counter() - t0}


def _task(job):
    """One fit of :func:`_fit_all`'s ``(key, (freq, H, coherence, n_modes))``: the key travels
    with it, since the fits come back as they finish."""
    _, (freq, h, coh, n_modes) = job
    return fit_posture(freq, h, coh, n_modes=n_modes)


def _fit_all(ds: xr.Dataset, bands, n_modes, workers) -> dict:
    """Every (band, posture) fit of the campaign, keyed so; postures marked not ok are left out."""
    n_post = ds.sizes["posture"]
    ok_in = ds.ok.values if "ok" in ds.coords else np.ones(n_post, bool)
    jobs = []
    for b in bands:
        sel = ds.band.values == b
        freq = ds.freq.values[sel]
        for p in range(n_post):
            if not ok_in[p]:
                continue
            h = ds.H.values[p][sel]
            coh = ds.coherence.values[p][sel] if "coherence" in ds else None
            jobs.append(((b, p), (freq, h, coh, n_modes)))
    # a few fits run here rather than pay for starting worker processes
    n = 0 if workers == 0 or len(jobs) < 4 else workers
    done = {job[0]: result for job, result in map_cases(_task, jobs, workers=n)}
    return {key: done[key] for key, _ in jobs}


def _tracked(tables, stds, evs, positions) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One band's mode tables tracked over the postures, with each mode's standard errors and
    evidence carried along to its tracked slot: (n_post, n_mode, param) twice and
    (n_post, n_mode, len(_EVIDENCE))."""
    tracked, order = _track(tables, positions)
    std = np.full_like(tracked, np.nan)
    ev = np.full(tracked.shape[:2] + (len(_EVIDENCE),), np.nan)
    for p, (sd, e, o) in enumerate(zip(stds, evs, order)):
        if sd is not None:
            for i, j in enumerate(o):
                if j >= 0:
                    std[p, i] = sd[j]
                    ev[p, i] = e[j]
    return tracked, std, ev


def fit_campaign(ds: xr.Dataset, *, bands=("low", "high"), n_modes: int | None = None,
                 workers: int | None = None, progress: bool = False) -> xr.Dataset:
    """Fit every posture and band of a campaign dataset (DATA.md layout).

    Parameters
    ----------
    ds : xarray.Dataset
        Campaign (or imported) dataset with ``H`` (posture, freq, out, inp) and coordinate ``band``.
    bands : sequence of str
        Bands to fit.
    n_modes : int, optional
        Modes per band (default: chosen by the data).
    workers : int, optional
        Worker processes (default: the machine's cores; 0: in this process).

    Returns
    -------
    xarray.Dataset
        ``modal`` (posture, mode, param), ``modal_std``, ``nmse`` (posture, fit_band, out,
        inp); ``residual`` (posture, fit_band, term, out, inp), complex: what each band's fit
        needed besides its modes (residual terms and out-of-band poles) as ``lower`` L (1/kg),
        ``upper`` U and ``quadratic`` V (m/N) of −L/ω² + U + V (f/f_max)², f_max the band's top
        line (coordinate ``residual_f_max``, Hz; :mod:`rmbench.modal.residual`) — without them a
        band's modes alone misplace the tool-holder modes that RCSA couples to (bench/lobes.py);
        the verdict of each band's fit ``fit_ok``, ``fit_reason`` (one line naming what is
        wrong and where, "" when ok) and ``fit_notes`` (posture, fit_band); the evidence of each
        fitted mode ``mode_uncertain`` (its standard errors do not support the accuracy asked),
        ``mode_delta_bic`` (the information criterion's case for it), ``mode_share`` (its share
        of the band's fitted energy), ``mode_stable_orders`` (stable pLSCF orders of its cluster,
        0 when the residual scan found it) on (posture, mode); and where ``ds`` has ground truth
        the errors ``f_err``, ``zeta_err``, ``mac_phiR``, ``mac_phiL`` (posture, mode).
    """
    _check_dataset(ds)
    present = [b for b in bands if np.any(ds.band.values == b)]
    if not present:
        raise InputError(f"no frequency lines of band(s) {', '.join(bands)} in the dataset")
    t0 = time.perf_counter()
    by_key = _fit_all(ds, present, n_modes, workers)
    elapsed = time.perf_counter() - t0
    positions = (posture_positions(ds.x.values, ds.y.values, ds.theta.values)
                 if all(c in ds.coords for c in ("x", "y", "theta")) else None)
    per_band = [_band_results(by_key, b, ds.sizes["posture"], positions) for b in present]
    out = _modal_dataset(ds, present, per_band)
    if "modal_exact" in ds:
        out = out.merge(truth_errors(out, ds))
    out.attrs.update(rmbench_version=__version__, rmbench_dataset_version=1, kind="modal",
                     upstream=str(ds.attrs.get("source_file", "")), fit_seconds=elapsed,
                     phiL_normalisation="phiL[phiL_ref] = 1 per mode, 1aY unless it nears zero "
                     "somewhere in the campaign (METHODS.md §2); phiL_1aY holds the 1aY element",
                     residual_terms="-lower/omega^2 + upper + quadratic (f/residual_f_max)^2; "
                                    "lower 1/kg, upper and quadratic m/N")
    return out


def _band_results(by_key: dict, band: str, n_post: int, positions) -> dict:
    """One band's fits over the postures: its modes tracked across them (``tracked``, ``std``,
    ``evidence``, as :func:`_tracked` gives them) and per posture the verdict (``fit_ok``,
    ``reason``, ``notes``), ``nmse`` (n_post, 4, 4) and ``residual`` (n_post, n_terms, 4, 4)."""
    tables, stds, evs = [], [], []
    out = {"fit_ok": np.zeros(n_post, bool), "reason": np.full(n_post, "", dtype=object),
           "notes": np.full(n_post, "", dtype=object), "nmse": np.full((n_post, 4, 4), np.nan),
           "residual": np.full((n_post, len(RESIDUAL_TERMS), 4, 4), np.nan + 0j)}
    for p in range(n_post):
        r = by_key.get((band, p))
        if r is None or not r["ok"]:
            tables.append(None)
            stds.append(None)
            evs.append(None)
            out["reason"][p] = r["reason"] if r is not None else "posture not measured"
            continue
        prm = r["params"]
        tables.append(ModeTable(band=band, f_n=prm[:, 0], zeta=prm[:, 1], phi_r=r["phi_r"],
                                phi_l=r["phi_l"], peak=np.zeros(len(prm))))
        stds.append(r["std"])
        evs.append(np.column_stack([r[k] for k in _EVIDENCE]).astype(float))
        out["nmse"][p] = r["nmse"]
        out["residual"][p] = r["residual"]
        out["fit_ok"][p] = r["fit_ok"]
        out["reason"][p] = r["reason"]
        out["notes"][p] = "; ".join(r["notes"])
    out["tracked"], out["std"], out["evidence"] = _tracked(tables, stds, evs, positions)
    return out


def _modal_dataset(ds: xr.Dataset, present: list, per_band: list) -> xr.Dataset:
    """The modal dataset (DATA.md) of the bands' results, modes of the bands side by side."""
    modal = np.concatenate([r["tracked"] for r in per_band], axis=1)
    modal_std = np.concatenate([r["std"] for r in per_band], axis=1)
    evidence = np.concatenate([r["evidence"] for r in per_band], axis=1)
    band_of_mode = [b for b, r in zip(present, per_band) for _ in range(r["tracked"].shape[1])]
    modal, modal_std, phi_l_1ay, refs = renormalise_phi_l(modal, modal_std)
    f_max = [float(ds.freq.values[ds.band.values == b].max()) for b in present]
    pm, pb = ("posture", "mode"), ("posture", "fit_band")

    def by_band(name):
        return np.stack([r[name] for r in per_band], axis=1)

    out = xr.Dataset(
        {"modal": (("posture", "mode", "param"), modal),
         "modal_std": (("posture", "mode", "param"), modal_std),
         "phiL_1aY": (pm, phi_l_1ay),
         "nmse": (("posture", "fit_band", "out", "inp"), by_band("nmse")),
         "residual": (("posture", "fit_band", "term", "out", "inp"), by_band("residual")),
         "fit_ok": (pb, by_band("fit_ok")),
         "fit_reason": (pb, by_band("reason").astype(str)),
         "fit_notes": (pb, by_band("notes").astype(str)),
         "mode_uncertain": (pm, evidence[..., 0] > 0.5),
         "mode_delta_bic": (pm, evidence[..., 1]),
         "mode_share": (pm, evidence[..., 2]),
         "mode_stable_orders": (pm, evidence[..., 3])},
        coords={"posture": ds.posture.values, "mode": np.arange(modal.shape[1]),
                "mode_band": ("mode", np.array(band_of_mode, dtype=str)),
                "phiL_ref": ("mode", np.array(refs, dtype=str)), "param": list(PARAMS),
                "fit_band": list(present), "residual_f_max": ("fit_band", f_max),
                "term": list(RESIDUAL_TERMS), "out": list(COORDS), "inp": list(COORDS)})
    for c in ("x", "y", "theta", "ok"):
        if c in ds.coords:
            out = out.assign_coords({c: ("posture", ds[c].values)})
    return out


def renormalise_phi_l(modal: np.ndarray, std: np.ndarray, *, floor: float = 0.05):
    """METHODS.md §2 fallback: per mode, fix the φL element that is largest over the campaign.

    A mode whose φL at 1aY falls below ``floor`` times its largest φL element at some posture is
    renormalised at every posture so that its campaign-wide largest element is 1: the element
    whose smallest ``|φL_k| / max |φL|`` over the postures is largest. (Largest at its weakest, not
    on the median: a mode that turns in the XY plane across the grid has an element that is
    largest at most postures and nearly zero at a few, and fixing it makes the others spike there
    — on the IRB6660's 855 Hz mode the median choice 1Y falls to 3 % of the largest, 1X never
    below 11 %.) φR is multiplied by the same factor, so the model is unchanged.
    The 16 parameters then hold φL at 1X, 1aX, 1Y (the fixed one reads 1 + 0i) and the 1aY
    element goes to the returned ``phi_l_1ay``. Standard errors of the rescaled φ entries are
    scaled to first order (the uncertainty of the divisor is neglected).

    Parameters
    ----------
    modal, std : ndarray, shape (n_postures, n_modes, 16)
        Parameters normalised with φL 1aY = 1, and their standard errors.

    Returns
    -------
    modal, std : ndarray, shape (n_postures, n_modes, 16)
    phi_l_1ay : ndarray, shape (n_postures, n_modes), complex
        φL at 1aY (1 for modes left at the default).
    refs : list of str
        The fixed element of each mode (``"1aY"`` by default).
    """
    modal, std = modal.copy(), std.copy()
    phi_l_1ay = np.where(np.isfinite(modal[:, :, 0]), 1.0 + 0j, np.nan)
    refs = ["1aY"] * modal.shape[1]
    for m in range(modal.shape[1]):
        found = np.isfinite(modal[:, m, 0])
        if not found.any():
            continue
        phi_l = np.stack([_phi(prm, "L") for prm in modal[found, m]])  # (n_found, 4)
        rel = np.abs(phi_l) / np.abs(phi_l).max(axis=1, keepdims=True)
        if rel[:, 3].min() >= floor:
            continue
        k = int(np.argmax(rel.min(axis=0)))
        refs[m] = COORDS[k]
        scale = phi_l[:, k]                        # new φL = φL / scale, new φR = φR · scale
        phi_l = phi_l / scale[:, None]
        phi_l[:, k] = 1.0  # exactly, not to rounding
        phi_r = np.stack([_phi(prm, "R") for prm in modal[found, m]]) * scale[:, None]
        block, sblock = modal[found, m], std[found, m]
        for t, c in enumerate(("1X", "1aX", "1Y")):
            i = COORDS.index(c)
            block[:, 2 + 2 * t], block[:, 3 + 2 * t] = phi_l[:, i].real, phi_l[:, i].imag
            sblock[:, 2 + 2 * t:4 + 2 * t] /= np.abs(scale)[:, None]
        for t, c in enumerate(("1X", "1aX", "1Y", "1aY")):
            i = COORDS.index(c)
            block[:, 8 + 2 * t], block[:, 9 + 2 * t] = phi_r[:, i].real, phi_r[:, i].imag
            sblock[:, 8 + 2 * t:10 + 2 * t] *= np.abs(scale)[:, None]
        modal[found, m], std[found, m] = block, sblock
        phi_l_1ay[found, m] = phi_l[:, 3]
    return modal, std, phi_l_1ay, refs


def mode_vectors(res: xr.Dataset, posture: int, mode: int) -> tuple[np.ndarray, np.ndarray]:
    """φR (s/kg) and φL of one fitted mode at one posture, each shape (4,) complex, 1X 1Y 1aX 1aY."""
    prm = res.modal.values[posture, mode]
    phi_l = _phi(prm, "L")
    if "phiL_1aY" in res:
        phi_l[3] = res.phiL_1aY.values[posture, mode]
    return _phi(prm, "R"), phi_l


def _track(tables, positions):
    """Tracked parameters (n_post, n_modes, 16) and, per posture, the fitted index of each mode."""
    tracked = track_modes(tables, positions)
    order = []
    for p, t in enumerate(tables):
        if t is None:
            order.append(np.full(tracked.shape[1], -1))
            continue
        idx = np.full(tracked.shape[1], -1)
        for i in range(tracked.shape[1]):
            if np.isfinite(tracked[p, i, 0]):
                idx[i] = int(np.argmin(np.abs(t.f_n - tracked[p, i, 0])))
        order.append(idx)
    return tracked, order


def truth_errors(fit: xr.Dataset, ds: xr.Dataset) -> xr.Dataset:
    """Errors of the fitted modes against the exact ones as tested, paired per posture and band.

    Pairing: minimum ``(1 − MAC(φR)) + |Δf| / (0.05 f)`` between fitted and exact modes of the
    same band (Hungarian); a pair costing more than 1 (e.g. 5 % apart in frequency) is no pair.
    Returns ``f_err``, ``zeta_err`` (relative), ``mac_phiR``, ``mac_phiL`` and ``truth_mode``
    (the paired exact mode number, −1 for none) on (posture, mode).
    """
    exact = ds.modal_exact.values
    exact_band = ds.mode_band.values if "mode_band" in ds.coords else np.array([""] * exact.shape[1])
    fitted = fit.modal.values
    n_post, n_modes = fitted.shape[:2]
    f_err, z_err, mac_r, mac_l = (np.full((n_post, n_modes), np.nan) for _ in range(4))
    truth = np.full((n_post, n_modes), -1)
    for b in np.unique(fit.mode_band.values):
        fm = np.flatnonzero(fit.mode_band.values == b)
        em = np.flatnonzero(exact_band == b)
        for p in range(n_post):
            fp = [m for m in fm if np.isfinite(fitted[p, m, 0])]
            ep = [m for m in em if np.isfinite(exact[p, m, 0])]
            if not fp or not ep:
                continue
            # a pair costing more than 1 is nothing alike: the fitted mode is not this exact one
            rows, cols = pair_modes(fitted[p, fp, 0], exact[p, ep, 0], [_phi(fitted[p, i], "R") for i in fp],
                                    [_phi(exact[p, j], "R") for j in ep], freq_scale=0.05, freq="relative",
                                    max_cost=1.0)
            for a, c in zip(rows, cols):
                i, j = fp[a], ep[c]
                truth[p, i] = j
                f_err[p, i] = (fitted[p, i, 0] - exact[p, j, 0]) / exact[p, j, 0]
                z_err[p, i] = (fitted[p, i, 1] - exact[p, j, 1]) / exact[p, j, 1]
                phi_r, phi_l = mode_vectors(fit, p, i)
                mac_r[p, i] = mac(phi_r, _phi(exact[p, j], "R"))
                mac_l[p, i] = mac(phi_l, _phi(exact[p, j], "L"))
    dims = ("posture", "mode")
    return xr.Dataset({"f_err": (dims, f_err), "zeta_err": (dims, z_err), "mac_phiR": (dims, mac_r),
                       "mac_phiL": (dims, mac_l), "truth_mode": (dims, truth)})


def truth_scores(fit: xr.Dataset, ds: xr.Dataset, *, f_tol: float = 0.005, zeta_tol: float = 0.10,
                 mac_min: float = 0.98) -> xr.Dataset:
    """Per exact mode: how well the fit found it over the postures where the truth has it.

    Parameters
    ----------
    fit : xarray.Dataset
        Output of :func:`fit_campaign` (with ``truth_mode``).
    ds : xarray.Dataset
        The campaign with ``modal_exact``.
    f_tol, zeta_tol : float
        Relative tolerances on natural frequency and damping ratio.
    mac_min : float
        Least MAC of φR and of φL.

    Returns
    -------
    xarray.Dataset on dimension ``truth_mode``
        ``f_n`` (median exact, Hz), ``present`` (postures with the mode), ``f_err_p95``,
        ``zeta_err_p95`` (95th percentile of the absolute relative errors), ``mac_p05`` (5th
        percentile of min(MAC φR, MAC φL)), ``ok_frac`` (share of the postures with the mode where
        it was fitted within all tolerances; a mode the fit missed counts as a failure) and
        ``band``.
    """
    exact = ds.modal_exact.values
    n_post, n_exact = exact.shape[:2]
    errs = {k: np.full((n_post, n_exact), np.nan) for k in ("f", "z", "mac")}
    tm = fit.truth_mode.values
    for p in range(n_post):
        for i in np.flatnonzero(tm[p] >= 0):
            j = tm[p, i]
            errs["f"][p, j] = abs(fit.f_err.values[p, i])
            errs["z"][p, j] = abs(fit.zeta_err.values[p, i])
            errs["mac"][p, j] = min(fit.mac_phiR.values[p, i], fit.mac_phiL.values[p, i])
    present = np.isfinite(exact[:, :, 0])
    good = (errs["f"] <= f_tol) & (errs["z"] <= zeta_tol) & (errs["mac"] >= mac_min)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a mode never found: all-NaN columns
        out = {"f_n": np.nanmedian(exact[:, :, 0], axis=0),
               "present": present.sum(0),
               "f_err_p95": np.nanpercentile(np.where(present, errs["f"], np.nan), 95, axis=0),
               "zeta_err_p95": np.nanpercentile(np.where(present, errs["z"], np.nan), 95, axis=0),
               "mac_p05": np.nanpercentile(np.where(present, errs["mac"], np.nan), 5, axis=0),
               "ok_frac": (good & present).sum(0) / np.maximum(present.sum(0), 1)}
    band = ds.mode_band.values if "mode_band" in ds.coords else np.array([""] * n_exact)
    return xr.Dataset({k: ("truth_mode", v) for k, v in out.items()},
                      coords={"truth_mode": np.arange(n_exact), "band": ("truth_mode", band)})


def _phi(params: np.ndarray, side: str) -> np.ndarray:
    """φR or φL (1X, 1Y, 1aX, 1aY) of one mode from its 16 parameters."""
    p = dict(zip(PARAMS, params))
    if side == "R":
        return np.array([p[f"phiR_{c}_re"] + 1j * p[f"phiR_{c}_im"] for c in COORDS])
    return np.array([p["phiL_1X_re"] + 1j * p["phiL_1X_im"], p["phiL_1Y_re"] + 1j * p["phiL_1Y_im"],
                     p["phiL_1aX_re"] + 1j * p["phiL_1aX_im"], 1.0])


def _check_dataset(ds) -> None:
    if "H" not in ds:
        raise InputError("the dataset has no variable 'H' (measured receptance)")
    if tuple(ds.H.dims) != ("posture", "freq", "out", "inp"):
        raise InputError(f"H must have dims (posture, freq, out, inp), got {ds.H.dims}")
    if ds.sizes["out"] != 4 or ds.sizes["inp"] != 4:
        raise InputError(f"H must be a 4x4 matrix per line, got {ds.sizes['out']}x{ds.sizes['inp']}")
    if "band" not in ds.coords:
        raise InputError("the dataset has no 'band' coordinate on freq")
