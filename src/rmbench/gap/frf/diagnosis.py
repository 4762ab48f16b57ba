"""Sim-to-real gap diagnosis on FRF data: where the model departs, which effect causes it, how far
the gap shrinks once the effect is in the model (METHODS.md §11).

::

    dg = diagnose("irb6660", "measured.nc")           # or a UFF58 directory, or a Dataset
    dg.verdict                     # "explained" | "unexplained" | "model form" | "no significant gap"
    dg.effects[0].name, dg.effects[0].shrink          # best first, held-out shrink of the gap
    dg.where.describe()                                # the nominal model's gap, by mode
    dg.save("diagnosis/")                              # figures, tables, the updated variant MJCF
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from rmbench.errors import RmbenchError
from rmbench.calibrate.design import TestDesign
from rmbench.gap.frf.calibration import first_calibration
from rmbench.gap.frf.effects import Change, library
from rmbench.gap.frf.evidence import equivalent, localise, model_weights, ranked
from rmbench.gap.frf.model import ModelBench
from rmbench.gap.frf.pairs import pairs
from rmbench.gap.frf.prepare import SearchData, load_data, prepare
from rmbench.gap.frf.result import Diagnosis, EffectResult, RemainingGap, model_row, step_seconds
from rmbench.gap.frf.rules import explains, spread_checked
from rmbench.gap.frf.search import Fitted, Objective, Refiner, peak_residual, per_posture_chi2
from rmbench.gap.frf.settings import DiagnosisSettings, structural_kinds
from rmbench.gap.frf.where import gap_map
from rmbench.gap.selection import significant
from rmbench.threads import default_workers, one_blas_thread

# the results, settings and data loading live in their own modules; imported from here as before
__all__ = ["diagnose", "diagnose_modes", "Diagnosis", "EffectResult", "load_data", "DiagnosisSettings",
           "SearchData", "structural_kinds", "remaining_gap", "RemainingGap"]


@one_blas_thread
def diagnose(nominal, data, *, test: str | None = None, tool=None, workers: int | None = None,
             settings: DiagnosisSettings = DiagnosisSettings(), progress=None) -> Diagnosis:
    """Diagnose the gap between a nominal model and measured FRFs.

    Parameters
    ----------
    nominal : str, Path or Robot
        The nominal robot: a bundled name or an MJCF path (with ``tool``), or a loaded Robot.
    data : str, Path or xarray.Dataset
        Measured FRFs: a campaign dataset (netCDF) or a UFF58 directory (``rmbench campaign
        export``, or a real robot's test). Only H, coherence, postures and the test design are
        read.
    test : str, optional
        Campaign TOML text of the test design, when the data carry none (or to override it).
    tool : str, optional
        The tool on the nominal robot (default: the robot's default tool).
    workers : int, optional
        Worker processes of the measurement's modal fit.
    progress : callable, optional
        ``progress(message)`` after each step.

    Returns
    -------
    Diagnosis

    Raises
    ------
    InputError
        Unreadable data, no test design, postures the model cannot reach, no overlap of the
        data's and the model's bands, data of another robot or sensor layout.
    """
    say = progress or (lambda msg: None)
    t = {"start": time.perf_counter()}
    problem = prepare(nominal, data, test, tool, workers, settings, say, t)
    search, first = problem, None
    if settings.calibrate:
        first = first_calibration(problem, settings, workers, say)
        search = _calibrated(problem, first)
        t["calibrate"] = time.perf_counter()
    dg = _diagnose(search, settings, workers, say, t, ordinary=None if first is None else first.ordinary)
    if first is None:
        return dg
    dg = replace(dg, calibration=first.account, calibrated_xml=first.robot.xml)
    if dg.verdict == "explained":
        dg = spread_checked(dg, problem.robot, first)
    # "no significant gap" too: a calibration that reached the noise only by pushing an ordinary
    # parameter onto the edge of its spread may have mimicked a structural effect (picks.pinned)
    reported = None
    if settings.confirm > 0 and dg.verdict in ("unexplained", "no significant gap"):
        from rmbench.gap.frf.confirmed import confirmed

        dg, reported = confirmed(dg, problem, first, settings, say, t)
    return with_form(dg, problem, first, say, cal=reported)


def with_form(dg, problem, first, say, *, cal=None):
    """``dg`` with the lack-of-fit test (:mod:`rmbench.calibrate.form`) of the calibration it
    reports, and the verdict "model form" where the test fails and no effect explains the gap: the
    ordinary parameters cannot explain the held-out frequencies, whether or not the FRF noise test
    saw a gap (a robot that rocks on its base can miss every mode by ten times the modal fit's
    error, each residual below the FRF test's floors).

    ``cal``: the null recalibration where the diagnosis reports it (the ordinary parameters alone,
    continued with the FRFs), else None: the first calibration. The test asks whether the ordinary
    parameters can explain the data, so it judges their best fit: a first calibration that stopped
    short of the data fails it on an in-model robot. The localisation, where the test fails, reads
    the first calibration's linearisation."""
    from rmbench.calibrate.form import check_calibration

    t0 = time.perf_counter()
    form = check_calibration(problem.robot, first.data, first.cal if cal is None else cal, first.settings)
    if form is None:
        return dg
    say(form.summary())
    verdict = "model form" if form.flagged and dg.verdict != "explained" else dg.verdict
    notes, out, localisation = dg.notes, form.to_dict(), dg.localisation
    if verdict != dg.verdict:
        notes += (f"{form.summary()}: the verdict was {dg.verdict!r}",)
    if verdict == "model form":
        where = _located(problem, first)
        say(where.summary())
        out["located"] = where.to_dict()
        localisation = f"{where.summary()}; {localisation}" if localisation else where.summary()
    took = round(time.perf_counter() - t0, 3)
    seconds = {**dg.seconds, "form": took, "total": round(dg.seconds.get("total", 0.0) + took, 3)}
    return replace(dg, form=out, verdict=verdict, notes=notes, seconds=seconds, localisation=localisation)


def _located(problem, first):
    """Where the gap lies on the first calibration's model (:func:`rmbench.gap.frf.locate.locate`),
    its postures as the calibration saw them: the training ones first, then the held-out."""
    from rmbench.gap.frf.joint import Ordinary
    from rmbench.gap.frf.locate import locate

    order = list(problem.train) + list(problem.held)
    blocks = {(i, b): first.ordinary.blocks[(p, b)] for i, p in enumerate(order) for b in first.data.bands
              if (p, b) in first.ordinary.blocks}
    n_train = len(problem.train)
    return locate(first.robot, first.data, range(n_train), range(n_train, len(order)),
                  Ordinary(blocks, first.ordinary.z, first.ordinary.names), first.settings)


@one_blas_thread
def diagnose_modes(data: SearchData, *, settings: DiagnosisSettings = DiagnosisSettings(),
                   workers: int | None = None, notes=(), progress=None) -> Diagnosis:
    """The search on measured modes alone (a modal table, no FRFs), on a split the caller chose.

    Parameters
    ----------
    data : SearchData
        The modes, the model and the split (:meth:`SearchData.from_modes`).
    settings : DiagnosisSettings
    workers : int, optional
        Worker processes of the search (default: :func:`rmbench.threads.default_workers`).
    notes : sequence of str
        Carried into the diagnosis's notes (which fold this is, say).
    progress : callable, optional
        ``progress(message)`` after each step.
    """
    return _diagnose(data, settings, workers, progress or (lambda msg: None), {"start": time.perf_counter()},
                     notes=notes)


def remaining_gap(nominal, data, *, test: str | None = None, tool=None, workers: int | None = None,
                  settings: DiagnosisSettings = DiagnosisSettings(), progress=None) -> RemainingGap:
    """Whether a structural gap remains in ``data`` once ``settings.calibrate``'s ordinary
    parameters are calibrated: :func:`diagnose`'s calibration, its noise test over every posture
    and, where that passes, its null recalibration with the FRFs scored on the held-out postures;
    no structural search. A blind bench asks this of a hidden effect before it is measured: an
    effect the ordinary parameters take up whole leaves nothing any diagnosis could find.

    Parameters are :func:`diagnose`'s; ``settings.calibrate`` must name groups.

    Returns
    -------
    RemainingGap
    """
    from rmbench.gap.frf.confirm import ConfirmOptions, ConfirmSetup, confirm

    if not settings.calibrate:
        raise ValueError("remaining_gap needs settings.calibrate: the ordinary parameters to calibrate")
    say = progress or (lambda msg: None)
    t = {"start": time.perf_counter()}
    problem = prepare(nominal, data, test, tool, workers, settings, say, t)
    first = first_calibration(problem, settings, workers, say)
    obj_all, _, _ = _objectives(_calibrated(problem, first), first.ordinary)
    e_all = obj_all.vector(Change())
    chi2_all, peak_all = float(e_all @ e_all), float(abs(peak_residual(e_all)))
    gap = bool(significant(chi2_all, obj_all.n, p=settings.p_noise, peak=peak_all))
    null = None
    if gap:
        held_sub = list(range(len(problem.train), len(problem.train) + len(problem.held)))
        setup = ConfirmSetup(problem, first.data, held_sub, first.cal, first.settings)
        options = ConfirmOptions(p_noise=settings.p_noise, min_shrink=settings.min_shrink)
        run, _ = confirm(setup, [], options=options, progress=say)
        null = run.to_dict()
    return RemainingGap(chi2_all, int(obj_all.n), peak_all, gap, null,
                        bool(gap and null["significant"]), round(time.perf_counter() - t["start"], 1))


def _calibrated(problem: SearchData, first) -> SearchData:
    """The same data and split on the first calibration's robot (``first``: its
    :class:`~rmbench.gap.frf.calibration.FirstCalibration`)."""
    return replace(problem, robot=first.robot,
                   bench=ModelBench(first.robot, problem.modal.design, problem.bench.q_cmd))


def _diagnose(data: SearchData, settings, workers, say, t, notes=(), ordinary=None) -> Diagnosis:
    """The search, once the data are in: nominal gap, screening, refinement, pairs, verdict.

    With ``ordinary`` (a calibration's parameters, linearised) every candidate is fitted jointly
    with them on the modal residuals (:mod:`rmbench.gap.frf.joint`)."""
    obj_all, obj_train, obj_held = _objectives(data, ordinary)
    nominal_change = Change()
    e_all = obj_all.vector(nominal_change)
    chi2_all, peak_all = float(e_all @ e_all), peak_residual(e_all)
    where = _gap_map(data, nominal_change)
    t["where"] = time.perf_counter()
    say("gap map")
    e_held = obj_held.vector(nominal_change)
    nom = Fitted((), (), obj_train.chi2(nominal_change), float(e_held @ e_held),
                 obj_train.n, obj_held.n, peak_held=peak_residual(e_held),
                 chi2_held_posture=per_posture_chi2(obj_held, e_held))
    notes = list(notes)
    effects = _candidates(data.robot, data.modal.design, settings)
    common = dict(where=where, nominal_chi2=chi2_all, n_residuals=obj_all.n, nominal_peak=peak_all,
                  train=tuple(data.train), held=tuple(data.held))
    if not significant(chi2_all, obj_all.n, p=settings.p_noise, peak=peak_all):
        t["end"] = time.perf_counter()
        return Diagnosis(verdict="no significant gap", effects=(), where_after=None, localisation=where.describe(),
                         equivalent=(), variant_xml=None, design_changes=(), models=(model_row(nom, 1.0),),
                         seconds=step_seconds(t), notes=tuple(notes), **common)
    with Refiner(obj_train, obj_held, workers=_cores(workers)) as refiner:
        e0 = obj_train.vector(nominal_change)
        scored, best, screens = _search(refiner, obj_train, nom, effects, e0, settings, say, t)
    explained = explains(best, nom, settings)
    weights = model_weights(scored, obj_held)
    chosen = best if explained else None
    results = ranked(data.ds, obj_held, scored, weights, chosen, settings)
    variant_xml, design_changes, where_after = _updated(data, chosen, notes)
    localisation = where.describe() if explained else localise(where, screens, e0)
    t["end"] = time.perf_counter()
    return Diagnosis(verdict="explained" if explained else "unexplained", effects=tuple(results),
                     where_after=where_after, localisation=localisation, equivalent=equivalent(screens),
                     variant_xml=variant_xml, design_changes=design_changes,
                     models=tuple(model_row(f, w) for f, w in zip(scored, weights)),
                     seconds=step_seconds(t), notes=tuple(notes), **common)


def _objectives(data: SearchData, ordinary) -> tuple:
    """The search's objectives over every posture, the training and the held-out ones: the
    plain ones, or with ``ordinary`` the joint ones (the calibrated parameters fitted to first
    order beside each candidate, on the training postures)."""
    bench, meas, frf, bands = data.bench, data.modal.modes, data.modal.frf, data.modal.bands
    n = bench.n_postures
    if ordinary is None:
        return (Objective(bench, meas, frf, bands, range(n)), Objective(bench, meas, frf, bands, data.train),
                Objective(bench, meas, frf, bands, data.held))
    from rmbench.gap.frf.joint import JointObjective

    obj_train = JointObjective(bench, meas, frf, bands, data.train, ordinary)
    obj_held = JointObjective(bench, meas, frf, bands, data.held, ordinary, fitted_on=obj_train)
    obj_all = JointObjective(bench, meas, frf, bands, range(n), ordinary, fitted_on=obj_train)
    return obj_all, obj_train, obj_held


def _candidates(robot, design: TestDesign, settings) -> list:
    """The library's effects the search tries: ``settings.kinds`` of them, and with
    ``settings.calibrate`` only the structural kinds (:func:`structural_kinds`)."""
    effects = library(robot, design)
    if settings.kinds is not None:
        effects = [e for e in effects if e.kind in settings.kinds]
    if settings.calibrate:
        keep = structural_kinds(settings.calibrate)
        effects = [e for e in effects if e.kind in keep]
    return effects


def _search(refiner: Refiner, obj_train, nom: Fitted, effects, e0, settings, say, t) -> tuple:
    """Screening of every candidate (first order, from the nominal's training residual ``e0``),
    refinement of the best ``settings.refine``, and pairs where no single explains the gap.
    Returns the scored models (the nominal ``nom`` first), the best of them and the screens."""
    screens = refiner.screen(effects, e0)
    t["screen"] = time.perf_counter()
    say(f"screened {len(screens)} candidates")
    order = np.argsort([s.chi2 for s in screens])
    singles = refiner.run([((screens[i].effect,), (screens[i].values,)) for i in order[:settings.refine]])
    t["refine"] = time.perf_counter()
    say(f"refined {len(singles)} candidates")
    scored = [nom] + singles
    best = min(singles, key=lambda f: f.score)
    # no pairs beside a calibration: its verdicts rest on a recalibration with one effect freed
    # (:mod:`rmbench.gap.frf.confirm`), which a pair fitted to first order cannot have
    if not explains(best, nom, settings) and settings.pairs_of > 0 and not settings.calibrate:
        singles, paired = pairs(refiner, obj_train, effects, singles, screens, settings.pairs_of)
        if paired:
            scored = [nom] + singles + paired
            best = min(singles + paired, key=lambda f: f.score)
        t["pairs"] = time.perf_counter()
        say(f"fitted {len(paired)} pairs")
    return scored, best, screens


def _updated(data: SearchData, chosen: Fitted | None, notes: list) -> tuple:
    """The model with the ``chosen`` effects: its MJCF (the robot's part of the change), the
    chosen effects that belong to the test design, and its gap map (a note in ``notes`` where the
    updated model has none); ``(None, (), None)`` without a chosen model."""
    if chosen is None:
        return None, (), None
    robot_change = chosen.change().robot_part
    variant_xml = data.bench.robot_for(robot_change).xml if not robot_change.is_null() else data.robot.xml
    design_changes = tuple(e.describe(v) for e, v in zip(chosen.effects, chosen.values)
                           if e.kind.startswith("sensor_"))
    where_after = None
    try:
        where_after = _gap_map(data, chosen.change())
    except RmbenchError as err:
        notes.append(f"no gap map of the updated model: {err}")
    return variant_xml, design_changes, where_after


def _gap_map(data: SearchData, change: Change):
    """The gap map of the model with ``change`` over every measured posture (:func:`gap_map`)."""
    md = data.modal
    return gap_map(data.bench, md.modes, data.ds, md.bands, change, data.xyt,
                   averages=md.design.averages(), scatter=md.design.direction_scatter())


def _cores(workers) -> int:
    """Worker processes of the search: ``workers``, else :func:`rmbench.threads.default_workers`
    (``RMBENCH_THREADS``, else every core this process may run on)."""
    return int(workers) if workers is not None else default_workers()
