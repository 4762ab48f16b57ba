"""Gap diagnosis on laser-tracker readings: which kinematic error source, and the accuracy it costs.

The same engine as the FRF diagnosis (:mod:`rmbench.gap.selection`): candidate models are fitted
on training configurations and scored on held-out ones by ``χ²_held + k ln n_held``; sources are
added greedily (forward selection), since real robots carry several at once; confidences are
bootstrap selection frequencies over the held-out configurations, a resample crediting its winner
only where the winner leaves noise there; the verdict is "explained" when the best model's
held-out residuals are noise. Calibrated, where the calibrated pose model fails the noise test at
the held-out configurations and no source explains the readings, the verdict is "model form";
where no name fits ("model form" or "unexplained"), :mod:`.locate` says at which joint the gap
lies and what it acts like (a lost motion, a compliance that differs with the torque's side).
A library source can be named beside such a gap (a real robot carries a source and a form error
at once): a chosen source whose held-out drop, added alone to the calibration, is decisive and
that no joint's generic augmentation beats carries a confidence there (:func:`_beside_form`).

1. **Where** (:class:`PoseErrorMap`): the nominal model's registered error per axis, the share of
   it above the noise, its rms over bins of each joint's angle, and how much of it each joint's
   angle, gravity torque and the harmonics of its angle explain (R² of a linear fit).
2. **Which**: every source of :func:`~rmbench.gap.tracker.sources.source_library` is screened by one
   linearised least-squares step on top of the current model; the best few are refined by
   Gauss-Newton (sources and the base registration together) and scored held out; the best joins
   the model while it lowers the held-out score and the residual is not yet noise.
3. **How far**: held-out rms and largest pose error before and after, with bootstrap intervals
   over held-out configurations, and each chosen source's share of the error it removes.

Every model registers the robot base in the tracker frame by a best fit (6 parameters, fitted on
the training configurations with the sources), so a base frame error, and any source whose
signature the registration takes up (a zero offset of the first joint, whose axis is vertical), is
reported as absorbed, not diagnosed.

The result (:class:`TrackerDiagnosis`, its sources and fitted poses) is :mod:`.result`'s, its folder
:mod:`.files`'s, the error map :mod:`.where`'s; all are importable from here too.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError
from rmbench.gap.selection import SearchSettings, bic, bootstrap_shrink, selection_weights, significant
from rmbench.gap.tracker.data import (TrackerData, check_readings, default_covariance, default_sigma,
                                      repeat_scale, split_readings, tracker_data)
from rmbench.gap.tracker.engine import Engine, Fit, pruned, signatures
from rmbench.gap.frf.locate import FOUND
from rmbench.gap.tracker.locate import locate
from rmbench.gap.tracker.result import FittedPose, SourceResult, TrackerDiagnosis
from rmbench.gap.tracker.sources import ORDINARY, PoseModel, Source, source_library
from rmbench.gap.tracker.where import PoseErrorMap, pose_error_map

_IMPLAUSIBLE = 0.025   # m rms after registration: no calibration error is that large

__all__ = ["TrackerData", "TrackerSettings", "SourceResult", "PoseErrorMap", "TrackerDiagnosis",
           "FittedPose", "diagnose_tracker", "pose_error_map", "tracker_data", "default_sigma",
           "default_covariance", "adequate_confidences", "decisive", "prior_sd"]


@dataclass(frozen=True)
class TrackerSettings(SearchSettings):
    """How hard the diagnosis searches: :class:`~rmbench.gap.selection.SearchSettings` (held-out
    share of the configurations, refinement, noise test, bootstrap, kinds) and

    Attributes
    ----------
    max_sources : int
        Most sources in a model (structural ones, with ``calibrate``).
    harmonics : int
        Gear-error harmonics per joint in the library.
    calibrate : bool
        Calibrate the ordinary parameters first (:data:`ORDINARY`: every joint's zero offset,
        each placement's length and twist, each compliant joint's gravity compliance, each
        link's mass), each with a Gaussian prior of the sizes below, on the training
        configurations; then search
        the structural sources on top, each fitted with the ordinary parameters (their priors
        kept). A structural source the calibrated parameters explain is never chosen.
    offset_sd, length_sd, twist_sd, compliance_sd, mass_sd : float
        Prior standard deviations of the ordinary parameters: zero offset (rad), placement
        length (m) and twist (rad), the fractions added to a joint's compliance and to the mass
        of the body it carries (link masses ±10 %). A stated
        tolerance is a 2σ bound, as the tracker's accuracy is (link lengths ±0.5 mm, twists
        ±0.05°, stiffness within ×0.7-1.3 of the data sheet).
    """

    max_sources: int = 4
    harmonics: int = 2
    calibrate: bool = False
    offset_sd: float = float(np.radians(0.05))
    length_sd: float = 0.25e-3
    twist_sd: float = float(np.radians(0.025))
    compliance_sd: float = 0.25
    mass_sd: float = 0.05


def diagnose_tracker(nominal, data: TrackerData, *, settings: TrackerSettings = TrackerSettings(),
                     progress=None) -> TrackerDiagnosis:
    """Diagnose tracker readings against a nominal robot (module docstring).

    Parameters
    ----------
    nominal : str, Path or rmbench.robot.Robot
        Bundled robot name, MJCF path or loaded robot.
    data : TrackerData
        From :func:`tracker_data`.

    Raises
    ------
    rmbench.errors.InputError
        Readings of another number of joints, too few configurations for the registration and a
        source, non-finite values.
    """
    t0 = time.perf_counter()
    say = progress or (lambda msg: None)
    p = _prepared(nominal, data, settings)
    say("nominal model registered; gap map")
    eng, nominal_fit, library = p.eng, p.nominal_fit, p.library
    base, calibration, start = (), None, nominal_fit
    if settings.calibrate:
        base = tuple(s for s in library if s.kind in ORDINARY)
        library = [s for s in library if s.kind not in ORDINARY]
        start, calibration = _calibrated(eng, base, nominal_fit, settings, say)
    best, scored, verdict, more = _search(eng, library, start, base, p.e_all, settings, say)
    if calibration is not None and len(best.sources) > len(base):
        # the ordinary parameters as the model the diagnosis ends with holds them: beside the
        # sources it chose, which the calibration alone had taken up in part (a payload in the
        # gravity compliances)
        calibration = {**calibration, **_account(eng, best)}
    form, rival, located = None, False, None
    if settings.calibrate:
        verdict, form, rival, located, more = _form_and_place(eng, start, best, base, verdict, more, settings, say)
    # the prior's term spread over the held-out units, so a resample keeps it on average
    n_units = [3 * np.sum(data.location[eng.held] == u) for u in eng.held_units]
    weights = selection_weights([np.asarray(f.chi2_held_unit) + f.chi2_prior / len(f.chi2_held_unit)
                                 for f in scored], n_units, [f.k for f in scored], n_boot=settings.bootstrap)
    # a source a generic joint augmentation beats held out is no confident answer
    conf = {} if rival else adequate_confidences(scored, n_units, settings)
    if verdict in ("model form", "unexplained") and base and len(best.sources) > len(base):
        held = {n: float(sum(w for f, w in zip(scored, weights) if n in f.names)) for n in best.names}
        beside, notes = _beside_form(eng, start, best, base, located, held, len(library), settings.p_noise)
        conf, more = {**conf, **beside}, list(more) + notes
    chosen = best if best.sources else None
    before = _heldout(eng, nominal_fit, settings.bootstrap)
    after = _heldout(eng, best, settings.bootstrap) if chosen is not None else before
    shrink, interval = _shrink(eng, nominal_fit, best, settings.bootstrap)
    results = _ranked(eng, start, best if len(best.sources) > len(base) else None, scored, conf, base)
    registered = (nominal_fit.rotation, nominal_fit.translation)
    return TrackerDiagnosis(
        verdict=verdict, sources=tuple(results), where=p.where, heldout_before=before,
        heldout_after=after, shrink=shrink, shrink_interval=interval, equivalent=p.equivalent,
        absorbed=tuple(p.absorbed),
        values={s.name: np.atleast_1d(v).tolist() for s, v in zip(best.sources, best.values)}
        if chosen is not None else {},
        models=tuple({"name": f.name, "k": f.k, "chi2_train": f.chi2_train, "n_train": f.n_train,
                      "chi2_held": f.chi2_held, "n_held": f.n_held, "score": f.score,
                      "weight": float(w)} for f, w in zip(scored, weights)),
        calibration=calibration, form=form,
        n_readings=len(data.q), train=tuple(int(u) for u in p.train_units),
        held=tuple(int(u) for u in p.held_units), seconds=time.perf_counter() - t0,
        notes=p.notes + tuple(more),
        fitted=FittedPose(p.model, best.sources, best.values, best.rotation, best.translation)
        if chosen is not None else FittedPose(p.model, (), (), *registered),
        nominal_fitted=FittedPose(p.model, (), (), *registered))


@dataclass(frozen=True)
class _Prepared:
    """The readings ready for the search: the nominal pose model, the engine on the split, the
    registered nominal fit, the library less what the registration absorbs, where the nominal's
    error lies and its normalised residuals at every reading (for the noise test)."""

    model: PoseModel
    eng: Engine
    nominal_fit: Fit
    library: list
    absorbed: list
    equivalent: tuple
    where: PoseErrorMap
    e_all: np.ndarray
    train_units: np.ndarray
    held_units: np.ndarray
    notes: tuple


def _prepared(nominal, data: TrackerData, settings: TrackerSettings) -> _Prepared:
    """Check the readings against the nominal robot, split them, register the nominal model and
    map its error (:func:`diagnose_tracker`'s first step)."""
    from rmbench.robot import Robot
    from rmbench.tracker.chain import SerialChain
    from rmbench.tracker.simulator import nominal_stiffness

    robot = nominal if isinstance(nominal, Robot) else Robot.load(nominal)
    chain = SerialChain.from_kinematics(robot.kinematics, robot.arm_joints)
    check_readings(data, chain)
    compliance = 1.0 / nominal_stiffness(robot)
    model = PoseModel(chain, compliance)
    train, held, train_units, held_units = split_readings(data, settings.heldout)
    if min(len(train_units), len(held_units)) < 3:
        raise InputError(f"{len(np.unique(data.location))} configurations: the diagnosis needs at "
                         f"least 6 (3 to fit the base registration's 6 parameters and a source on, "
                         f"3 held out)")
    library = source_library(chain, compliance, harmonics=settings.harmonics, drive=data.drive_kind,
                             masses=settings.calibrate)
    if settings.kinds is not None:
        library = [s for s in library if s.kind in settings.kinds]
    eng = Engine(model, data, train, held)
    nominal_fit = eng.fit(())
    notes = []
    absorbed, equivalent = signatures(eng, nominal_fit, library)
    library = [s for s in library if s.name not in absorbed]
    if absorbed:
        notes.append("no signature beyond the base registration: " + ", ".join(absorbed))
    every = np.arange(len(data.q))
    e_nom = eng.error((), [], nominal_fit.rotation, nominal_fit.translation, every)
    rms_nom = float(np.sqrt(np.mean(np.sum(e_nom ** 2, axis=1))))
    if rms_nom > _IMPLAUSIBLE:
        raise InputError(f"the readings depart from robot {robot.name} by {1e3 * rms_nom:.0f} mm rms "
                         f"after registration: readings of another robot, another joint order, or "
                         f"not in rad and m?")
    where = pose_error_map(chain, compliance, data, e_nom)
    e_all = eng.residual((), [], nominal_fit.rotation, nominal_fit.translation, every)
    return _Prepared(model, eng, nominal_fit, library, absorbed, equivalent, where, e_all, train_units,
                     held_units, tuple(notes))


def _calibrated(eng: Engine, base: tuple, nominal: Fit, settings: TrackerSettings, say) -> tuple:
    """The ordinary sources ``base`` fitted with their priors (the calibration), their
    uncertainty carried into the held-out residuals (:meth:`Engine.carry`): the start of the
    structural search and the calibration's account."""
    eng.prior = {s.name: prior_sd(s, settings) for s in base}
    start = eng.fit(base, iterations=8)
    eng.carry(start)
    start = eng.score(start.sources, start.values, start.rotation, start.translation)
    calibration = {**_account(eng, start), "heldout_before": _heldout(eng, nominal, settings.bootstrap),
                   "heldout_after": _heldout(eng, start, settings.bootstrap),
                   "chi2_train_per_n": start.chi2_train / max(start.n_train, 1)}
    say(f"calibrated {sum(x.n_params for x in base)} ordinary parameters: held-out rms "
        f"{1e3 * calibration['heldout_before']['rms']:.3f} -> {1e3 * calibration['heldout_after']['rms']:.3f} mm")
    return start, calibration


def _form_and_place(eng: Engine, start: Fit, best: Fit, base: tuple, verdict: str, notes, settings: TrackerSettings,
                    say) -> tuple:
    """The calibrated diagnosis's form test and localisation: ``(verdict, form, rivalled, located,
    notes)``.

    A library explanation is first set against the joints' generic augmentations
    (:func:`~rmbench.gap.tracker.locate.locate`, fitted on the calibration): where one of them
    scores better held out (BIC, one parameter beside the calibration's), the library's name is
    not given ("unexplained", ``rivalled``). Then, "unexplained" where the calibrated pose model
    fails the form test (:func:`_form`) becomes "model form", and where no name fits the
    localisation is the verdict's content (``form["located"]``)."""
    form, notes, rivalled = _form(eng, start, settings), list(notes), False
    located = locate(eng, start) if verdict in ("model form", "unexplained", "explained") else None
    place = _place_fit(start, located)
    if verdict == "explained" and place is not None and place[1] < best.score:
        top = located.places[0]
        rivalled, verdict = True, "unexplained"
        named = " + ".join(s.name for s in best.sources[len(base):])
        notes.append(f"{top.acts_like} at {top.where} explains the held-out readings better than "
                     f"{named} (held-out χ² {place[0]:.4g} against {best.chi2_held:.4g}): no source of the "
                     f"library is named")
    if form["flagged"] and verdict == "unexplained":
        # the calibrated ordinary parameters cannot explain the held-out readings (their own
        # uncertainty carried there) and no source of the library does: the pose model's form
        verdict = "model form"
        notes.append(f"model form: the calibrated pose model leaves held-out χ² {form['chi2']:.4g} on "
                     f"{form['n']} residuals (p {form['p']:.2g}; the noise as its repeats measure it, "
                     f"{form['noise_scale']:.2f} × the stated), and no source explains it")
    if located is not None and verdict in ("model form", "unexplained"):
        form = {**form, "located": located.to_dict()}
        notes.append(located.summary())
        say(located.summary())
    return verdict, form, rivalled, located, notes


def _place_fit(start: Fit, located) -> tuple[float, float] | None:
    """``(χ²_held, score)`` of the calibrated model ``start`` with the first place of ``located``
    (the joints' generic augmentations), scored as a model is (BIC, one parameter beside the
    calibration's); None without a place."""
    if located is None or not located.places:
        return None
    top = located.places[0]
    # what the place removes beyond the same first-order fit without it, from the calibration
    chi2 = start.chi2_held - located.chi2_held * (1.0 - (1.0 - top.shrink) ** 2)
    return chi2, bic(chi2 + start.chi2_prior, start.k + 1, start.n_held)


def _beside_form(eng: Engine, start: Fit, best: Fit, base: tuple, located, held: dict, n_candidates: int,
                 p: float) -> tuple[dict, list]:
    """``({source: confidence}, notes)``: the chosen sources named beside a gap no source
    closes ("model form" or "unexplained"; issue 80: a real robot carries a library source and a
    form error at once). A chosen source is named where, added alone to the calibration, it
    removes a quarter of the held-out rms gap (``FOUND``, as a localisation must), its held-out
    drop is decisive (beyond what the best of the library's candidates reaches on noise,
    :func:`decisive` at level ``p``) and no joint's generic augmentation beats it held out
    (:func:`_place_fit`: a backlash's look-alike, a gear harmonic, is not named); its confidence is
    ``held[name]``, the bootstrap selection frequency of the models that hold it."""
    out, notes, place = {}, [], _place_fit(start, located)
    for s, v in zip(best.sources[len(base):], best.values[len(base):]):
        alone = eng.fit(start.sources + (s,), start.values + (v,))
        # the gap's main part, as a place must be to localise it: a quarter of the held-out rms
        # (a form-only robot's bending lower arm took a j2 gear harmonic, decisive on 750
        # residuals, that removed 3 % of it)
        main = start.chi2_held > 0 and 1.0 - np.sqrt(alone.chi2_held / start.chi2_held) >= FOUND
        if not main or not decisive(start, alone, n_candidates, p) or (place and place[1] < alone.score):
            continue
        out[s.name] = held[s.name]
        notes.append(f"beside the gap no source closes, {s.describe(v)} (held-out χ² {start.chi2_held:.4g} → "
                     f"{alone.chi2_held:.4g} added alone to the calibration; named at {out[s.name]:.2f})")
    return out, notes


def _noise_scale(eng: Engine, start: Fit) -> tuple[float, float, int]:
    """``(scale, measured, dof)``: the noise over the stated as the readings' repeats measure it
    about the calibrated model ``start`` (:func:`~rmbench.gap.tracker.data.repeat_scale`), and
    the scale the noise tests use, never below 1."""
    every = np.arange(len(eng.data.q))
    r = eng.residual(start.sources, start.values, start.rotation, start.translation, every)
    measured, dof = repeat_scale(r, eng.data.location)
    # never below the stated noise: repeats minutes apart miss what a tracker's data sheet covers
    # and they do not (its slow drift, the reflector's reseating), and noise-free readings would
    # make any error a wrong form
    return max(1.0, measured), measured, dof


def _above(fit: Fit, settings: TrackerSettings, scale: float = 1.0) -> bool:
    """Whether ``fit``'s held-out residuals are above the noise (:func:`significant` at
    ``settings.p_noise``), the noise ``scale`` × the stated."""
    return significant(fit.chi2_held / scale ** 2, fit.n_held, p=settings.p_noise, peak=fit.peak_held / scale)


def _form(eng: Engine, start: Fit, settings: TrackerSettings) -> dict:
    """The calibrated pose model's lack of fit at the held-out configurations (issue 80): its
    residuals there, each over the tracker's noise and the calibration's own uncertainty carried
    there (:meth:`Engine.carry`), against the noise test at ``settings.p_noise``, the noise as
    measured on the readings' repeats (:func:`~rmbench.gap.tracker.data.repeat_scale`, from the
    calibrated model's residuals at every reading) where it exceeds the stated: readings twice
    as noisy as their stated σ are not a wrong model."""
    from scipy.stats import chi2 as chi2_dist

    scale, measured, dof = _noise_scale(eng, start)
    chi2, peak = start.chi2_held / scale ** 2, start.peak_held / scale
    flagged = _above(start, settings, scale)
    return {"flagged": bool(flagged), "chi2": float(chi2), "n": int(start.n_held),
            "p": float(chi2_dist.sf(chi2, start.n_held)), "peak": float(peak),
            "noise_scale": scale, "noise_measured": measured, "noise_dof": dof}


def _search(eng: Engine, library, start: Fit, base: tuple, e_all: np.ndarray, settings: TrackerSettings,
            say) -> tuple:
    """Forward selection of structural sources on top of ``start`` (the nominal, or the
    calibration with the ordinary sources ``base``), then pruning and the verdict. ``e_all``: the
    nominal's normalised residuals at every reading, for the noise test. Returns ``(best, scored,
    verdict, notes)``."""
    scored, notes = [start], []
    best = start
    if not significant(float(np.sum(e_all ** 2)), e_all.size, p=settings.p_noise,
                       peak=float(np.max(np.abs(e_all)))):
        verdict = "no significant gap"
    else:
        # once calibrated, a model whose held-out readings are already noise takes a source only
        # on decisive evidence: a held-out drop (χ² and prior) that none of the candidates
        # screened would reach by chance, at the noise test's level (Bonferroni). The BIC charges
        # k ln n for one model, but the best of N candidates fitted to noise drops by the largest
        # of N χ²(k) draws, which grows with ln N: with ~30 candidates it passes the BIC often
        # (e.g. a gear harmonic of the joint whose stiffness is furthest off, a drop of ~17),
        # while a payload the calibration half absorbed still stands out (a drop of ~100)
        while len(best.sources) - len(base) < settings.max_sources:
            # a model must leave residuals to spare: the registration's 6 parameters and the
            # sources' fewer than the training residuals
            room = best.n_train - 6 - best.k
            free = [s for s in library if s.name not in best.names and s.n_params < room]
            if not free:
                break
            screened = eng.screen(best, free)[: settings.refine]
            fits = [eng.fit(best.sources + (s,), best.values + (x,)) for _, s, x in screened]
            scored += fits
            step_best = min(fits, key=lambda f: f.score)
            say(f"{len(step_best.sources)} source(s): {step_best.name}")
            if step_best.score >= best.score:
                break
            if base and not _above(best, settings) and not decisive(best, step_best, len(free), settings.p_noise):
                break
            best = step_best
            if not _above(best, settings):
                break
        if len(best.sources) > len(base):
            # each chosen source dropped in turn, refitted: a source the others made redundant goes
            best = pruned(eng, best, scored, base)
        noise = not _above(best, settings)
        if len(best.sources) > len(base):
            verdict = "explained" if noise else "unexplained"
        else:   # no source helps held out: a gap only if the held-out postures show one
            verdict = "no significant gap" if noise else "unexplained"
            if noise and base:
                notes.append("the calibrated ordinary parameters bring the held-out error to the noise: "
                             "no structural source is needed")
    return best, scored, verdict, notes


# -- helpers -----------------------------------------------------------------------------------

def adequate_confidences(scored, n_units, settings: TrackerSettings, seed: int = 0) -> dict:
    """``{source: share of bootstrap resamples of the held-out configurations whose winning model
    holds it and leaves noise}``, from the ``scored`` models (each with ``names``, ``k``,
    ``score``, ``chi2_prior``, ``n_held``, ``peak_held`` and ``chi2_held_unit``: its held-out χ²
    per configuration, shape (n_configurations,)) and ``n_units``, the residuals per held-out
    configuration, shape (n_configurations,). The selection's weights alone
    (:func:`selection_weights`, the same resamples and scores) assume the library holds the
    truth; where the winner's held-out residuals stay above the noise (χ² of the resample, and
    the full sample's largest residual, at the verdict's level) the resample credits no source:
    a source named inside an "unexplained" verdict, the best partial model of something outside
    the library, is not reported as a confident answer (a backlash's best look-alike, a gear
    harmonic, was named at 0.90-1.0 there)."""
    chi2 = np.array([np.asarray(f.chi2_held_unit, float) for f in scored])
    score_unit = chi2 + np.array([f.chi2_prior / chi2.shape[1] for f in scored])[:, None]
    n_res = np.asarray(n_units, float)
    k = np.array([f.k for f in scored], float)
    peaked = [significant(0.0, f.n_held, p=settings.p_noise, peak=f.peak_held) for f in scored]
    n_boot = settings.bootstrap
    if chi2.shape[1] < 4 or n_boot < 1:     # too few units to resample: the whole sample's test
        winner = int(np.argmin([f.score for f in scored]))
        f = scored[winner]
        ok = not _above(f, settings)
        return {n: float(ok) for n in f.names}
    rng = np.random.default_rng(seed)
    out: dict[str, float] = {}
    for _ in range(n_boot):
        idx = rng.integers(0, chi2.shape[1], chi2.shape[1])
        n = n_res[idx].sum()
        win = int(np.argmin(score_unit[:, idx].sum(axis=1) + k * np.log(max(n, 2))))
        if peaked[win] or significant(float(chi2[win, idx].sum()), int(n), p=settings.p_noise):
            continue
        for name in scored[win].names:
            out[name] = out.get(name, 0.0) + 1.0 / n_boot
    return out


def decisive(before: Fit, after: Fit, n_candidates: int, p: float) -> bool:
    """Whether ``after``'s held-out drop (χ² and prior) from ``before`` is beyond what the best
    of ``n_candidates`` sources of its size would reach on noise, at level ``p``: a χ² with the
    added parameters' count (``after.k - before.k``, at least 1) as degrees of freedom,
    Bonferroni-corrected. A drop that is not positive is never decisive."""
    from scipy.stats import chi2 as chi2_dist

    drop = (before.chi2_held + before.chi2_prior) - (after.chi2_held + after.chi2_prior)
    k = max(after.k - before.k, 1)
    return drop > 0 and float(chi2_dist.sf(drop, k)) * max(n_candidates, 1) < p


def prior_sd(source: Source, settings: TrackerSettings) -> np.ndarray:
    """Prior σ of an ordinary source's parameters, shape (source.n_params,), SI (rad for an
    offset or a twist, m for a length, fractions for a mass or a compliance), from ``settings``."""
    if source.kind == "joint_offset":
        return np.array([settings.offset_sd])
    if source.kind == "link_geometry":
        return np.array([settings.length_sd, settings.twist_sd])
    if source.kind == "link_mass":
        return np.array([settings.mass_sd])
    return np.array([settings.compliance_sd])


# SI resolution that matters per (kind, field): a stiffness within 5 % (``1 + x`` for a compliance
# fraction), a length within 5 mm, an angle within 0.1° (the calibration stage's sensor angle),
# a link mass within 5 %
_RESOLUTION = {("link_geometry", "length"): 5e-3, ("link_geometry", "twist"): float(np.radians(0.1)),
               ("joint_offset", "offset"): float(np.radians(0.1)), ("link_mass", "fraction"): 0.05}


def _resolved(source: Source, field: str, value: float, half_width: float) -> bool:
    """Whether a 95 % half-width fixes a parameter to the resolution that matters (:data:`_RESOLUTION`)."""
    if source.kind == "gravity_compliance":
        return half_width <= 0.05 * abs(1.0 + value)
    return half_width <= _RESOLUTION.get((source.kind, field), np.inf)


def _account(eng: Engine, fit: Fit) -> dict:
    """The calibration's account in ``fit`` (the calibration alone, or the model the diagnosis
    ends with: the calibration and the sources it chose, fitted together): each ordinary
    parameter's value, 95 % interval and identifiability.

    The interval is the Gauss-Newton covariance with the prior, the structural sources freed
    beside the ordinary ones, widened by √(χ²/dof) where the model does not reach the noise on
    its training readings and further to the held-out χ² per residual where that is larger (a
    model error the fit took up in part on its own configurations shows on the others), as the
    FRF calibration's account (:func:`rmbench.calibrate.account.account`) does. Identifiable: the
    posterior below 0.3 of the prior σ and the interval within the resolution that matters
    (:func:`_resolved`); weak below 0.7."""
    from rmbench.calibrate.solver import identifiability, posterior

    idx = eng.train
    jac = np.hstack([eng.columns(fit.sources, fit.values, fit.rotation, idx),
                     eng.registration_columns(fit.sources, fit.values, fit.rotation, idx)])
    sd_prior = eng.prior_sd(fit.sources)
    k = len(sd_prior)
    finite = np.isfinite(sd_prior)
    # the registration and the structural sources have no prior: the data fix them or nothing does
    prior = np.concatenate([np.where(finite, 1.0 / np.where(finite, sd_prior, 1.0) ** 2, 0.0), np.zeros(6)])
    ref = np.concatenate([np.where(finite, sd_prior, 1.0), np.ones(6)])
    post = posterior(jac, prior, fit.chi2_train, fit.n_train, reference=ref)
    widening = float(np.sqrt(max(1.0, fit.chi2_held / max(fit.n_held, 1) / post.scale)))
    sd = post.sd[:k] * widening
    rows, off = [], 0
    for s, v in zip(fit.sources, fit.values):
        if s.kind in ORDINARY:
            for i, p in enumerate(s.parameters):
                ratio = float(post.ratio[off + i])
                x, half = float(np.atleast_1d(v)[i]), 1.96 * float(sd[off + i])
                field = p.name.rpartition(".")[2]
                rows.append({"name": p.name, "value": x, "prior_sd": float(sd_prior[off + i]),
                             "interval": [x - half, x + half], "posterior_over_prior": ratio,
                             "identifiability": identifiability(ratio, resolved=_resolved(s, field, x, half))})
        off += s.n_params
    return {"params": rows, "n_params": int(np.sum(finite)), "widening": widening,
            "with": [s.name for s in fit.sources if s.kind not in ORDINARY]}


def _heldout(eng: Engine, fit: Fit, n_boot: int, seed: int = 0) -> dict:
    e = eng.error(fit.sources, fit.values, fit.rotation, fit.translation, eng.held)
    norm = np.linalg.norm(e, axis=1)
    resid = eng.held_residual(fit.sources, fit.values, fit.rotation, fit.translation)
    loc = eng.data.location[eng.held]
    units = eng.held_units
    sq = np.array([np.sum(norm[loc == u] ** 2) for u in units])
    cnt = np.array([np.sum(loc == u) for u in units])
    mx = np.array([np.max(norm[loc == u]) for u in units])
    rng = np.random.default_rng(seed)
    rms_b, max_b = [], []
    for _ in range(n_boot):
        i = rng.integers(0, len(units), len(units))
        rms_b.append(np.sqrt(sq[i].sum() / cnt[i].sum()))
        max_b.append(mx[i].max())
    out = {"rms": float(np.sqrt(np.mean(norm ** 2))), "max": float(norm.max()),
           "chi2_per_n": float(np.sum(resid ** 2) / resid.size)}
    if n_boot:
        out["rms_interval"] = [float(np.percentile(rms_b, 2.5)), float(np.percentile(rms_b, 97.5))]
        out["max_interval"] = [float(np.percentile(max_b, 2.5)), float(np.percentile(max_b, 97.5))]
    return out


def _shrink(eng: Engine, before: Fit, after: Fit, n_boot: int, seed: int = 0):
    loc = eng.data.location[eng.held]
    units = eng.held_units

    def per_unit(fit):
        e = eng.error(fit.sources, fit.values, fit.rotation, fit.translation, eng.held)
        n2 = np.sum(e ** 2, axis=1)
        return np.array([n2[loc == u].sum() for u in units])

    return bootstrap_shrink(per_unit(before), per_unit(after), n_boot, seed)


def _ranked(eng: Engine, nominal: Fit, chosen: Fit | None, scored, conf, base: tuple = ()) -> list[SourceResult]:
    """The sources beyond ``base`` (the calibrated ordinary ones): the chosen model's by their
    share of what it removes from ``nominal``'s held-out error, then the others by score."""
    out, seen = [], set()
    if chosen is not None and len(chosen.sources) > len(base):
        e_full = eng.error(chosen.sources, chosen.values, chosen.rotation, chosen.translation, eng.held)
        e_nom = eng.error(nominal.sources, nominal.values, nominal.rotation, nominal.translation, eng.held)
        msq_full, msq_nom = np.mean(np.sum(e_full ** 2, 1)), np.mean(np.sum(e_nom ** 2, 1))
        total = max(msq_nom - msq_full, 0.0)
        drops = []
        for i in range(len(base), len(chosen.sources)):
            keep = tuple(s for j, s in enumerate(chosen.sources) if j != i)
            vals = tuple(v for j, v in enumerate(chosen.values) if j != i)
            f = eng.fit(keep, vals)
            e = eng.error(f.sources, f.values, f.rotation, f.translation, eng.held)
            drops.append(max(np.mean(np.sum(e ** 2, 1)) - msq_full, 0.0))
        drops = np.array(drops)
        shares = drops / drops.sum() * total / msq_nom if drops.sum() > 0 and msq_nom > 0 else 0 * drops
        after = _heldout(eng, chosen, 0)
        order = np.argsort(-shares)
        for i in order:
            s, v = chosen.sources[len(base) + i], chosen.values[len(base) + i]
            out.append(SourceResult(s.name, s.kind, s.location, s.params_dict(v), s.describe(v),
                                    float(shares[i]), conf.get(s.name, 0.0),
                                    {"rms": after["rms"], "max": after["max"]}, True))
            seen.add(s.name)
    singles = sorted([f for f in scored if len(f.sources) == len(base) + 1], key=lambda f: f.score)
    for f in singles:
        s, v = f.sources[-1], f.values[-1]
        if s.name in seen:
            continue
        seen.add(s.name)
        h = _heldout(eng, f, 0)
        out.append(SourceResult(s.name, s.kind, s.location, s.params_dict(v), s.describe(v), 0.0,
                                conf.get(s.name, 0.0), {"rms": h["rms"], "max": h["max"]}, False))
    return out
