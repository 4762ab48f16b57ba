"""The evidence a diagnosis carries: held-out gap metrics of a model (:func:`metrics`), the scored
models' selection weights (:func:`model_weights`), the effects ranked with their held-out shrink and
confidence (:func:`ranked`), the candidates the data cannot tell apart (:func:`equivalent`) and,
for an unexplained gap, where it lies and what comes closest (:func:`localise`)."""

from __future__ import annotations

import numpy as np

from rmbench.calibrate.residual import mode_residuals
from rmbench.errors import RmbenchError
from rmbench.gap.frf.effects import Change
from rmbench.gap.frf.result import EffectResult
from rmbench.gap.frf.search import Objective
from rmbench.gap.frf.where import GapMap
from rmbench.gap.selection import bootstrap_shrink, confidences, parallel_groups, selection_weights
from rmbench.modeshape import mac

__all__ = ["metrics", "model_weights", "ranked", "equivalent", "localise"]

_DB = 20 / np.log(10)


def metrics(held: Objective, ds, change) -> dict:
    """Held-out gap metrics of a model (see EffectResult)."""
    bench, meas, bands = held.bench, held.meas, held.bands
    f_err, z_err, macs, frf, unpaired, failed = [], [], [], [], 0, 0
    for p in held.postures:
        try:                  # each band's robot carries its own sensors
            models = {b: bench.modes(change, p, b) for b in bands}
        except RmbenchError:
            failed += 1       # the changed robot cannot hold this posture: counted, not compared
            continue
        for b in bands:
            mm, model = meas[p][b], models[b]
            _, pairing = mode_residuals(mm, model)
            i, j = pairing.meas, pairing.model
            unpaired += len(pairing.unpaired_meas) + len(pairing.unpaired_model)
            if len(i):
                f_err += list(np.abs(model.f_n[j] / mm.f_n[i] - 1))
                z_err += list(np.abs(model.zeta[j] / mm.zeta[i] - 1))
                for a, c in zip(i, j):
                    rd, rm = mm.residue[a].ravel(), model.residue[c].ravel()
                    macs.append(mac(rd, rm))
            if ds is not None:
                sel = ds.band.values == b
                h = ds.H.values[p][sel]
                hm = bench.frf(change, p, b, ds.freq.values[sel])
                frf.append(_DB * np.log(np.abs(hm) / np.abs(h)))
    gap = float(np.sqrt(held.per_posture(change).sum() / held.n))
    return {"gap": gap, "f_err": float(np.mean(f_err)) if f_err else np.nan,
            "zeta_err": float(np.mean(z_err)) if z_err else np.nan,
            "mac": float(np.mean(macs)) if macs else np.nan,
            "frf_db": (float(np.sqrt(np.nanmean(np.concatenate([x.ravel() for x in frf]) ** 2)))
                       if frf else float("nan")),
            "unpaired": int(unpaired), "failed": int(failed)}


def model_weights(scored, held: Objective) -> np.ndarray:
    """Model weights: bootstrap selection frequencies over the held-out postures (see
    :mod:`rmbench.gap.selection`), or over-dispersed BIC weights with fewer than 4 of them."""
    n_post = len(held.postures)
    per = [f.chi2_held_posture for f in scored]
    if any(len(c) != n_post for c in per):     # no per-posture split: one unit
        per = [(f.chi2_held,) for f in scored]
        n_units = [held.n]
    else:
        n_units = [held.n_posture(p) for p in held.postures]
    return selection_weights(per, n_units, [f.k for f in scored])


def ranked(ds, held, scored, weights, chosen, settings) -> list[EffectResult]:
    """The effects best first, with held-out evidence and confidences."""
    conf = confidences([[e.name for e in f.effects] for f in scored], weights)
    before = metrics(held, ds, Change())
    out, seen = [], set()
    order = []
    singles = sorted([f for f in scored if len(f.effects) == 1], key=lambda f: f.score)
    if chosen is not None:
        # within the chosen model, the effect the held-out postures most often select comes
        # first; between equally certain ones, the one that alone explains the most
        alone = {f.effects[0].name: f.score for f in singles}
        order += sorted(((chosen, k) for k in range(len(chosen.effects))),
                        key=lambda fk: (-round(conf.get(fk[0].effects[fk[1]].name, 0.0), 6),
                                        alone.get(fk[0].effects[fk[1]].name, np.inf)))
    order += [(f, 0) for f in singles]
    for fitted, k in order:
        eff, val = fitted.effects[k], fitted.values[k]
        if eff.name in seen:
            continue
        seen.add(eff.name)
        is_chosen = chosen is not None and fitted is chosen
        change = fitted.change() if is_chosen else eff.change(val)
        after = metrics(held, ds, change)
        shrink, interval = _shrink(held, Change(), change, settings.bootstrap)
        out.append(EffectResult(name=eff.name, kind=eff.kind, location=eff.location,
                                params=eff.params_dict(val), description=eff.describe(val),
                                heldout_before=before, heldout_after=after, shrink=shrink,
                                shrink_interval=interval, confidence=conf.get(eff.name, 0.0),
                                chosen=is_chosen))
    return out


def equivalent(screens, *, cos_min: float = 0.995) -> tuple:
    """Groups of candidates whose first-order signatures coincide (|cos| ≥ ``cos_min``)."""
    vecs, names = [], []
    for s in screens:
        v = s.sensitivity[:, 0]
        norm = np.linalg.norm(v)
        if norm > 0:
            vecs.append(v / norm)
            names.append(s.effect.name)
    return parallel_groups(vecs, names, cos_min)


def localise(where: GapMap, screens, e0) -> str:
    """For an unexplained gap: where it lies, and which candidates come closest to it."""
    chi0 = float(e0 @ e0)
    near = sorted(screens, key=lambda s: s.chi2)[:3]
    closest = ", ".join(f"{s.effect.name} (closes {100 * (1 - s.chi2 / chi0):.0f} % to first order)"
                        for s in near)
    return f"{where.describe()}; closest candidates: {closest}"


def _shrink(held: Objective, before: Change, after: Change, n_boot: int, seed: int = 0):
    """Held-out shrink of the rms normalised gap and its 95 % bootstrap interval over postures."""
    return bootstrap_shrink(held.per_posture(before), held.per_posture(after), n_boot, seed)
