"""The verdict of a calibrated diagnosis after its confirmation: the confirmable candidates
recalibrated in place (:mod:`rmbench.gap.frf.confirm`), judged by the verdict rules
(:mod:`rmbench.gap.frf.rules`), and the diagnosis rewritten with what they showed
(:func:`confirmed`)."""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from rmbench.gap.frf.calibration import FirstCalibration
from rmbench.gap.frf.effects import Change, library
from rmbench.gap.frf.evidence import metrics
from rmbench.gap.frf.model import ModelBench
from rmbench.gap.frf.picks import confirm_picks, fitted_sizes, pinned
from rmbench.gap.frf.prepare import SearchData
from rmbench.gap.frf.result import Diagnosis, EffectResult, step_seconds
from rmbench.gap.frf.rules import better_calibration, confirms
from rmbench.gap.frf.search import Objective
from rmbench.gap.selection import bootstrap_shrink, selection_weights

__all__ = ["Recalibrated", "confirmed", "explained"]


@dataclass(frozen=True)
class Recalibrated:
    """The confirmation's recalibrations, as the verdict reads them.

    Attributes
    ----------
    null : Confirmed
        The null recalibration (no structural effect).
    base : Confirmed
        The baseline a candidate's shrink is measured against: the null, or the first calibration
        where that has the lower held-out χ² (the null with its χ² and objective).
    done : list of Confirmed
        Every candidate recalibrated.
    record : dict
        :attr:`Diagnosis.confirmation`.
    gap : bool
        The joint search left the gap unexplained (False: it found none, and the candidates are
        the effects behind parameters pinned on a bound of their spread).
    first_chi2 : float
        The first calibration's held-out χ².
    """

    null: object
    base: object
    done: list
    record: dict
    gap: bool
    first_chi2: float


def confirmed(dg: Diagnosis, problem: SearchData, first: FirstCalibration, settings, say, t) -> tuple:
    """The diagnosis ``dg`` after the confirmable candidates were recalibrated in place,
    best-ranked first (:mod:`rmbench.gap.frf.confirm`): explained by the best of those whose
    held-out residual is noise, that closes ``settings.min_shrink`` of the baseline's held-out gap
    and that left its ordinary spread (:func:`rmbench.gap.frf.rules.confirms`); "no significant
    gap" when the null recalibration alone reaches the noise; otherwise unexplained as before.

    ``problem``: the prepared data with the nominal robot; ``first``: its first calibration;
    ``say``: the progress callback; ``t``: the step times, to which the confirmation's is added.
    Returns the diagnosis and the calibration it reports where that is the null recalibration of
    the ordinary parameters alone (None: the first calibration, or one with an effect freed)."""
    from rmbench.gap.frf.confirm import ConfirmOptions, ConfirmSetup, confirm

    cal, sub, cal_settings = first.cal, first.data, first.settings
    # the search's library: the calibrated robot's (a lateral-only foundation where the
    # calibration mounted one)
    lib = {e.name: e for e in library(first.robot, sub.design)}
    on_bound = pinned(cal, lib)
    gap = dg.verdict == "unexplained"
    sizes = fitted_sizes(dg.models)
    if gap:
        picks = confirm_picks(dg.models, lib, settings.confirm)
        picks += [e for e in on_bound if e not in picks]
    else:
        picks = on_bound[:settings.confirm]
    if not picks:
        return dg, None
    held_sub = list(range(len(problem.train), len(problem.train) + len(problem.held)))
    # the baseline: the better of the null recalibration and the first calibration (a short
    # recalibration can end worse than it started; a candidate must beat the best model without it)
    first_chi2 = float(dg.models[0]["chi2_held"])

    def explains(c, null_):
        return confirms(c, null_, gap=gap, pinned=on_bound, first_chi2=first_chi2, min_shrink=settings.min_shrink,
                        nominal=problem.robot, groups=cal_settings.groups)

    if on_bound:
        say("on a bound of their spread after calibration, confirmed freed: " + ", ".join(e.name for e in on_bound))
    setup = ConfirmSetup(problem, sub, held_sub, cal, cal_settings)
    options = ConfirmOptions(p_noise=settings.p_noise, min_shrink=settings.min_shrink, need_gap=gap)
    null, done = confirm(setup, picks, options=options, accept=explains, sizes=sizes, progress=say)
    t["confirm"] = time.perf_counter()
    base = _baseline(dg, null, first_chi2, first, problem)
    record = {"null": null.to_dict(), "first_chi2_held": first_chi2,
              "candidates": [c.to_dict(base) for c in done], "min_shrink": settings.min_shrink,
              "pinned": [p.name for p in cal.params if p.on_bound and not np.isclose(p.value, p.nominal)]}
    outcome = Recalibrated(null, base, done, record, gap, first_chi2)
    winners = [c for c in done if explains(c, null)]
    return _verdict(dg, winners, outcome, problem, settings, t)


def explained(dg: Diagnosis, winners, outcome: Recalibrated, problem, settings, notes: list, t) -> Diagnosis:
    """The diagnosis explained by the best of the confirmed ``winners`` (by held-out χ² and its
    parameter count), its confidence the bootstrap selection frequency over ``problem.held``
    among the baseline ``outcome.base`` and every candidate run (``outcome.done``); ``notes``:
    the diagnosis's notes so far, added to."""
    null, base, done = outcome.null, outcome.base, outcome.done
    best = min(winners, key=lambda c: c.chi2_held + c.effect.n_params * np.log(max(c.n_held, 2)))
    # confidence: bootstrap selection frequency over the held-out postures among the null and
    # the confirmed candidates
    n_units = [best.objective.n_posture(p) for p in problem.held]
    weights = selection_weights([base.chi2_held_posture] + [c.chi2_held_posture for c in done],
                                n_units, [0] + [c.effect.n_params for c in done])
    conf = float(weights[1 + done.index(best)])
    shrink, interval = bootstrap_shrink(base.chi2_held_posture, best.chi2_held_posture, settings.bootstrap)
    before, after = metrics(base.objective, problem.ds, Change()), metrics(best.objective, problem.ds, best.change)
    top = EffectResult(name=best.effect.name, kind=best.effect.kind, location=best.effect.location,
                       params=best.effect.params_dict(best.values), description=best.effect.describe(best.values),
                       heldout_before=before, heldout_after=after, shrink=shrink, shrink_interval=interval,
                       confidence=conf, chosen=True)
    rest = tuple(e for e in dg.effects if e.name != top.name)
    notes.append(f"confirmed by recalibration with {best.effect.name} freed: held-out χ²/residual "
                 f"{best.chi2_held / max(best.n_held, 1):.3g} against {base.chi2_held / max(base.n_held, 1):.3g} "
                 "without it (the first effect's shrink is against the better of the first calibration and "
                 "a recalibration without it)")
    if not outcome.gap:
        notes.append(f"the ordinary calibration reached the data only with {', '.join(outcome.record['pinned'])} "
                     f"on a bound of the spread (training objective {null.train_objective:.3g}, data and prior); "
                     f"with {best.effect.name} freed it is {best.train_objective:.3g} and the size lies beyond "
                     "the spread: the held-out shrink is small because the calibration had mimicked the effect")
    design_changes = (best.effect.describe(best.values),) if not best.change.is_null() else ()
    # the calibration the verdict rests on: the ordinary parameters refitted with the effect freed
    # beside them; the first calibration had bent them to mimic the effect
    account = best.calibration.to_json()
    account["groups"] = list(dg.calibration["groups"])
    notes.append(f"the calibration reported is the recalibration with {best.effect.name} freed")
    return replace(dg, verdict="explained", effects=(top,) + rest, variant_xml=best.calibration.xml,
                   design_changes=design_changes, notes=tuple(notes), confirmation=outcome.record,
                   seconds=step_seconds(t), localisation=dg.where.describe(), calibration=account)


def _baseline(dg: Diagnosis, null, first_chi2: float, first: FirstCalibration, problem: SearchData):
    """The null recalibration, or the first calibration (held-out χ² ``first_chi2``) in its place
    where that is the better model without a structural effect."""
    if null.chi2_held <= first_chi2:
        return null
    md = problem.modal
    first_obj = Objective(ModelBench(first.robot, first.data.design, problem.bench.q_cmd), md.modes, md.frf,
                          md.bands, problem.held)
    return replace(null, chi2_held=first_chi2, objective=first_obj,
                   chi2_held_posture=np.asarray(dg.models[0]["chi2_held_posture"]))


def _verdict(dg: Diagnosis, winners, outcome: Recalibrated, problem, settings, t) -> tuple:
    """The verdict after the recalibrations ``outcome``, with notes on the candidates that reached
    the noise but do not explain the gap (inside their spread, or too small a share of it), and the
    calibration reported where it is the null recalibration (:func:`confirmed`)."""
    null, base, done, record, gap = outcome.null, outcome.base, outcome.done, outcome.record, outcome.gap
    notes = list(dg.notes)
    if not gap and not winners:
        notes.append(f"{', '.join(record['pinned'])} ended on a bound of the ordinary spread; recalibrated "
                     "with the structural effect behind it freed, no size beyond the spread explains the data "
                     "better: no structural effect is needed")
        return replace(dg, notes=tuple(notes), confirmation=record, seconds=step_seconds(t)), None
    fits = [c for c in done if not c.significant and c.shrink_against(base) >= settings.min_shrink]
    if null.same_chance and not null.significant:
        notes.append(f"{', '.join(c.effect.name for c in done if not c.significant)} reached the noise, "
                     f"but so do the ordinary parameters alone, recalibrated from {null.start}: the gap "
                     "was the first calibration's (it had stopped short of the data), or an ordinary "
                     "parameter takes the candidate's part")
    else:
        for c in fits:
            if c not in winners:
                notes.append(f"{c.effect.name} reaches the noise but stays within its ordinary spread: an "
                             "ordinary parameter, not a structural effect")
        for c in done:
            if gap and not c.significant and c not in fits and c not in winners:
                notes.append(f"{c.effect.name} reaches the noise but closes only {100 * c.shrink_against(base):.0f} % "
                             f"of the held-out gap (an explanation closes {100 * settings.min_shrink:.0f} %): "
                             "too little to tell apart from the noise's own share")
    if not winners:
        if not null.significant or fits:
            notes.append("recalibrated with the FRFs, the ordinary parameters bring the held-out gap "
                         "to the noise: no structural effect is needed")
            better = better_calibration(dg, null, outcome.first_chi2, notes)
            return (replace(dg, verdict="no significant gap", notes=tuple(notes), confirmation=record,
                            seconds=step_seconds(t), **better), null.calibration if better else None)
        return replace(dg, notes=tuple(notes), confirmation=record, seconds=step_seconds(t)), None
    return explained(dg, winners, outcome, problem, settings, notes, t), None
