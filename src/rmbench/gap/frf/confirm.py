"""A structural candidate confirmed by a full recalibration with it in place.

The joint search (:mod:`rmbench.gap.frf.joint`) lets the calibrated ordinary parameters follow a
candidate to first order. A large structural effect (a tool holder five times softer, a foundation
that slides) pulls the calibration far from the truth before the search starts, and a first-order
move back from there falls short: the candidate closes most of the gap but not all of it, and the
verdict stays "unexplained".

So the best candidate of each kind that maps onto model parameters is confirmed nonlinearly.
The calibration is run again with the candidate's parameters added
(:data:`rmbench.robot.parameters.STRUCTURAL`) and freed: fitted without a prior, beside every
ordinary parameter, which keeps its prior. The FRF residuals are on, since a holder's rotational
stiffness shows in the FRFs between the modes more than in the modes. A *null* recalibration with
the same settings and no candidate, continued from the first calibration, is the baseline, so
that the candidate is credited only with what it adds to a calibration that was given the same
data. A candidate runs from the null's end and, where it stalls there and no candidate explains
the gap from that end, the nominal, keeping the lower training objective
(``_Recalibration._candidate``); one that closes most of the null's gap short of the noise is
continued once, and the null with it.

A candidate explains the gap when its recalibrated model's held-out residual is noise (the
selection engine's test) and it closes at least ``min_shrink`` of the null's held-out rms gap.
Candidates are scored on the held-out postures only, with the parameters their training fit
chose.

A sensor's placement and the spindle's speed are no MJCF numbers but are parameters of the model
under test all the same (:func:`rmbench.calibrate.design.sensor_parameter`,
:func:`rmbench.calibrate.model.spindle_parameter`): freed in the recalibration beside the ordinary
parameters. A sensor candidate starts from the size the joint search fitted (a turned sensor's
angle is found there close to its size), the data read through the design so corrected.
Load-dependent stiffness maps onto no parameter and keeps the joint search's verdict.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from rmbench.gap.frf.effects import Change, Effect
from rmbench.gap.frf.model import ModelBench
from rmbench.gap.frf.search import Objective, peak_residual
from rmbench.gap.frf.restarts import chi2_gap, favourite, further_starts, same_chance
from rmbench.gap.selection import significant

__all__ = ["CONFIRMABLE", "DESIGN_KINDS", "Confirmed", "ConfirmSetup", "ConfirmOptions", "CandidateTerms",
           "candidate_terms", "confirmable", "confirm"]

CONFIRMABLE = ("tool_contact_stiffness", "spindle_stiffness", "base_compliance", "added_mass",
               "sensor_misplacement", "sensor_misalignment", "non_reciprocity")

# kinds confirmed through the test design at the joint search's size, not by a freed parameter
DESIGN_KINDS = ("sensor_misplacement", "sensor_misalignment")


@dataclass(frozen=True)
class Confirmed:
    """One recalibration: the null (``effect`` None) or one candidate in place.

    Attributes
    ----------
    effect : Effect or None
    values : ndarray or None
        The candidate's fitted size in its own units, relative to the nominal.
    calibration : Calibration
    robot : Robot
        The recalibrated model.
    chi2_held : float
    n_held : int
    peak_held : float
    chi2_held_posture : ndarray
        Held-out χ² of each held-out posture.
    objective : Objective
        The held-out objective on the recalibrated model, read with ``change``.
    significant : bool
        The held-out residual is above the noise.
    seconds : float
        Of every round.
    freed : tuple of str
        The parameters fitted without a prior (the candidate's).
    rounds : int
        Recalibrations run, each continuing the last (see :func:`confirm`'s ``min_shrink``).
    change : Change
        The test design's correction a sensor candidate reads the data through (null otherwise).
    from_nominal : bool
        A null recalibration run from the nominal with a candidate's budget, not continued from
        the first calibration.
    start : str
        Where the first round started: ``"first calibration"`` (the null), ``"nominal"`` or
        ``"null"`` (a candidate: the null recalibration's end, where that start ended lower or
        where it was the only one).
    second_start : bool
        A candidate that also ran from the nominal (its run from the null's end was promising,
        :attr:`ConfirmOptions.second_start`).
    stalled : bool
        A candidate whose run from the null's end stopped on the way (a second start is sought
        for it; :meth:`_Recalibration._candidate`), whether or not that start was run.
    warm : bool
        A null recalibration run from an accepted candidate's end (:func:`~rmbench.gap.frf.restarts.same_chance`).
    """

    effect: Effect | None
    values: np.ndarray | None
    calibration: object
    robot: object
    chi2_held: float
    n_held: int
    peak_held: float
    chi2_held_posture: np.ndarray
    objective: Objective
    significant: bool
    seconds: float
    freed: tuple = ()
    rounds: int = 1
    change: Change = Change()
    from_nominal: bool = False
    start: str = "nominal"
    second_start: bool = False
    warm: bool = False
    stalled: bool = False

    @property
    def name(self) -> str:
        return "null" if self.effect is None else self.effect.name

    @property
    def same_chance(self) -> bool:
        """A null given an accepted candidate's chance: run from the nominal or from the
        candidate's end, not only on from the first calibration."""
        return self.effect is None and (self.from_nominal or self.warm)

    @property
    def train_objective(self) -> float:
        """The recalibration's training objective: data χ² plus the prior's part over the
        ordinary parameters (a freed parameter has no prior)."""
        return _objective(self.calibration)

    def closes(self, null: "Confirmed") -> float:
        """The share of the null's excess held-out χ² (above its expectation under noise, the
        number of residuals) this run removes: 1 at the noise, 0 no better, negative worse."""
        excess = null.chi2_held - null.n_held
        return float((null.chi2_held - self.chi2_held) / excess) if excess > 0 else 0.0

    def shrink_against(self, null: "Confirmed") -> float:
        """``1 − gap / gap_null`` of the held-out rms normalised gap."""
        return float(1 - np.sqrt(self.chi2_held / null.chi2_held)) if null.chi2_held > 0 else 0.0

    def to_dict(self, null: "Confirmed | None" = None) -> dict:
        out = {"name": self.name, "chi2_held": self.chi2_held, "n_held": self.n_held,
               "peak_held": self.peak_held, "significant": self.significant,
               "iterations": self.calibration.iterations, "rounds": self.rounds, "seconds": self.seconds,
               "chi2_train": float(self.calibration.chi2_after), "chi2_prior": float(self.calibration.chi2_prior),
               "from_nominal": self.from_nominal, "start": self.start, "second_start": self.second_start,
               "stalled": self.stalled, "warm": self.warm}
        if self.effect is not None:
            out["params"] = self.effect.params_dict(self.values)
            out["description"] = self.effect.describe(self.values)
            if null is not None:
                out["shrink_against_null"] = self.shrink_against(null)
        return out


@dataclass(frozen=True)
class ConfirmSetup:
    """What the recalibrations of :func:`confirm` start from and are scored on.

    Attributes
    ----------
    problem : SearchData
        The diagnosis's data on the nominal robot (:func:`~rmbench.gap.frf.prepare.prepare`):
        the measured modes and FRF targets of every posture, the bench's joint commands and the
        held-out postures the recalibrations are scored on.
    data : ModalData
        The postures the first calibration saw, with FRF targets (:attr:`ModalData.frf`).
    held_data : sequence of int
        Held-out posture indices into ``data`` (the postures ``problem.held``).
    first : Calibration
        The first calibration (the null recalibration's start).
    settings : CalibrationSettings
        The first calibration's.
    """

    problem: object
    data: object
    held_data: object
    first: object
    settings: object

    @property
    def nominal(self):
        """The nominal robot the first calibration started from."""
        return self.problem.robot


@dataclass(frozen=True)
class ConfirmOptions:
    """How :func:`confirm` recalibrates and when it continues.

    Attributes
    ----------
    max_iter : int
        Evaluations of the null recalibration, of each continuation and of a candidate's run from
        the null's end (each starts where a fit stopped); a candidate's start from the nominal runs
        ``settings.max_iter``. A null that reaches the noise at this limit is
        continued once (it is the calibration reported).
    p_noise : float
        Level of the noise test of a recalibration's held-out residual.
    min_shrink : float
        A candidate that closes this much of the null's held-out gap but is not yet at the
        noise is continued for another ``max_iter`` evaluations, and the null with it (the same
        chance to converge): a large structural effect the first calibration had mimicked
        leaves the ordinary parameters far from where they belong, and they come back slowly.
        One still short of the noise and not accepted then runs from the nominal's next
        ``further`` gross starts (:attr:`CalibrationSettings.start_rank`), keeping the lowest
        training objective.
    second_start : float
        A candidate runs from the nominal as well as from the null's end only where its run
        from the null's end removed at least this share of the null's excess held-out χ², or
        added at least as much (:meth:`Confirmed.closes`; :meth:`_Recalibration._candidate`), or where the null's χ²
        passes the noise test (its gap is in its peak alone: no share to judge by; then the
        candidate the training objective favours starts again, :func:`~rmbench.gap.frf.restarts.favourite`).
    need_gap : bool
        False: run the candidates even where the null reaches the noise (an ordinary parameter
        that ended on its bound: the calibration reached the data only by pushing it to the edge
        of its spread, and the candidate asks whether it lies beyond).
    further : int
    """

    max_iter: int = 8
    p_noise: float = 1e-3
    min_shrink: float = 0.5
    need_gap: bool = True
    further: int = 2
    second_start: float = 0.2


@dataclass(frozen=True)
class CandidateTerms:
    """How a candidate maps onto model parameters (:func:`candidate_terms`), named as the
    calibration names them (``"base.lateral_compliance"``)."""

    extra: tuple           # parameters to add to the calibration
    free: tuple            # parameters to fit without a prior
    groups: tuple          # the calibration's groups (the base group added for a tilt)
    values: object         # callable: {name: u} of the recalibration -> the effect's values
    change: Change = Change()   # the test design the data are read through (a sensor candidate's)
    reread: bool = False   # not in the MJCF (a sensor, the spindle's speed): scored through its change
    reset: tuple = ()      # ordinary look-alikes: at the nominal in the start from the null's end


def confirmable(effect: Effect) -> bool:
    """Whether the effect maps onto model parameters a calibration can fit, or onto the test
    design it reads the data through."""
    return effect.kind in CONFIRMABLE


def candidate_terms(effect: Effect, cal_u: dict, groups: tuple, nominal, size=None) -> CandidateTerms:
    """The candidate's parameters (added where the first calibration, of ``cal_u``, lacks them),
    and its size read back from a recalibration in the effect's units, relative to the nominal.
    A sensor candidate reads the data through the design corrected by ``size`` (its joint-search
    fit, in the effect's units) and frees the sensor's placement from there
    (:func:`rmbench.calibrate.design.sensor_parameter`, in the effect's units: mm, degrees):
    the joint search fitted it against ordinary parameters the first calibration had bent, so
    its size is a start, not the answer (a sensor turned 6.02°, found 5.69° there, left a held-out
    peak of 16 σ). ``cal_u``: ``{parameter name: u}`` in the calibration's units (ln factors);
    ``groups``: the first calibration's; ``nominal``: the nominal Robot; ``size``: shape
    (effect.n_params,). Raises ValueError for a kind no calibration fits (:func:`confirmable`)."""
    k = effect.kind
    if k in DESIGN_KINDS:
        if size is None:
            raise ValueError(f"{effect.name} is confirmed from a fitted size: none given")
        v = np.asarray(size, float)
        name = f"sensor.{effect.location}.{'along' if k == 'sensor_misplacement' else 'angle'}"
        return CandidateTerms((name,), (name,), groups, lambda u: v + u[name], change=effect.change(v),
                              reread=True)
    if k == "non_reciprocity":         # the rotor's speed, in thousands of rev/min added to the nominal's
        return CandidateTerms(("spindle.speed",), ("spindle.speed",), groups,
                              lambda u: np.array([1e3 * u["spindle.speed"]]), reread=True)
    if k in ("tool_contact_stiffness", "spindle_stiffness"):
        stem = "tool_contact" if k == "tool_contact_stiffness" else "spindle"
        names = (f"{stem}.translation", f"{stem}.rotation") if stem == "tool_contact" else \
            (f"{stem}.radial", f"{stem}.tilt")
        return CandidateTerms(tuple(n for n in names if n not in cal_u), names, groups,
                              lambda u: np.array([u[n] for n in names]))
    if k == "added_mass":
        name = f"{effect.location}.mass"
        m0 = float(nominal.model.body(effect.location).mass[0])
        return CandidateTerms(() if name in cal_u else (name,), (name,), groups,
                              lambda u: np.array([m0 * np.exp(u[name]) - m0]))
    if k == "base_compliance":
        # the plate's mass is fitted too, with its prior (half to three times): its sway frequency
        # fixes compliance and mass together (held at the library's 1000 kg, a slab of 2000 kg made
        # the foundation 48 % too soft: 56.3 against 38.0 µm/kN)
        lat, plate = "base.lateral_compliance", "base_mount.mass"
        if effect.n_params == 1:          # lateral only, on a calibrated foundation
            # tilt and slide both sway the robot on its base: a calibration without the slide bends
            # the tilt to mimic it, and from there the slide stalls (the tilt holds the sway modes)
            return CandidateTerms((lat, plate), (lat,), groups, lambda u: np.array([u[lat]]),
                                  reset=("base.tilt_compliance",))
        tilt = "base.tilt_compliance"
        groups = groups if "base" in groups else groups + ("base",)
        return CandidateTerms((lat, plate), (lat, tilt), groups, lambda u: np.array([u[lat], u[tilt]]))
    raise ValueError(f"{effect.name} maps onto no model parameter")


@dataclass(frozen=True)
class _Recalibration:
    """The recalibrations of one :func:`confirm` (its arguments; ``cal_u``: the first calibration's
    values by parameter name, ``say``: the progress callback)."""

    setup: ConfirmSetup
    cal_u: dict
    options: ConfirmOptions
    sizes: dict
    say: object

    def __call__(self, effect: Effect | None, prev: Confirmed | None = None, *,
                 from_nominal: bool = False, null: Confirmed | None = None, rank: int = 0,
                 warm: Confirmed | None = None) -> Confirmed:
        """Recalibrate with ``effect`` in place (None: the null) and score it on the held-out
        postures; ``prev``: the run this one continues; ``from_nominal``: a null run as a
        candidate is, from the nominal with the full budget; ``null``: for a candidate, the null
        recalibration whose end is its second start; ``rank`` > 0: from the nominal alone, at
        that gross start (:attr:`CalibrationSettings.start_rank`); ``warm``: a null from a
        candidate's end (its ordinary parameters, its own ones dropped) with the full budget."""
        from rmbench.calibrate import calibrate

        t0 = time.perf_counter()
        setup = self.setup
        settings, nominal = setup.settings, setup.nominal
        terms, used, s = self._prepared(effect)
        c = None
        if rank:                        # a further gross start
            cal = calibrate(nominal, used, held=setup.held_data,
                            settings=replace(s, max_iter=settings.max_iter, start_rank=rank))
            started = f"gross start {rank + 1}"
            from_nominal = True
        elif prev is not None:          # a continuation
            cal = calibrate(nominal, used, held=setup.held_data, settings=s, start=_values(prev.calibration))
            started = prev.start
        elif warm is not None:          # the null from a candidate's end
            ordinary = {n: u for n, u in _values(warm.calibration).items() if n in self.cal_u}
            cal = calibrate(nominal, used, held=setup.held_data, settings=replace(s, max_iter=settings.max_iter),
                            start=ordinary)
            started = f"{warm.name}'s end"
        elif terms is None and not from_nominal:     # the null: from the first calibration
            cal = calibrate(nominal, used, held=setup.held_data, settings=s, start=dict(self.cal_u))
            started = "first calibration"
        else:
            c = self._candidate(effect, terms, used, replace(s, max_iter=settings.max_iter), null,
                                _Run("nominal", from_nominal, None, t0))
        if c is None:
            c = self._scored(effect, terms, cal, _Run(started, from_nominal, prev, t0))
        if warm is not None:
            c = replace(c, warm=True)
        self._said(c)
        return c

    def second_start(self, near: Confirmed) -> Confirmed:
        """The start from the nominal of a candidate ``near`` whose run from the null's end
        stalled (:attr:`Confirmed.stalled`), the lower training objective of the two kept and
        timed over both."""
        t0 = time.perf_counter()
        terms, used, s = self._prepared(near.effect)
        far = self._far(near.effect, terms, used, replace(s, max_iter=self.setup.settings.max_iter),
                        _Run("nominal", False, None, t0))
        c = _kept(near, far)
        self._said(c)
        return c

    def _prepared(self, effect) -> tuple:
        """The candidate's terms (None for the null), the data it reads (a sensor candidate's
        through the corrected design) and the recalibration's settings with ``options.max_iter``."""
        settings, data = self.setup.settings, self.setup.data
        terms = None if effect is None else candidate_terms(effect, self.cal_u, tuple(settings.groups),
                                                            self.setup.nominal, self.sizes.get(effect.name))
        change = Change() if terms is None else terms.change
        used = data if change.is_null() else replace(data, design=data.design.with_offsets(change.offsets))
        s = replace(settings, groups=tuple(settings.groups) if terms is None else terms.groups, frf=True,
                    max_iter=self.options.max_iter, extra=() if terms is None else terms.extra,
                    free=() if terms is None else terms.free)
        return terms, used, s

    def _said(self, c: Confirmed) -> None:
        alone = c.start == "null" and not c.second_start
        self.say(f"recalibrated with {c.name}: held-out χ²/residual {c.chi2_held / max(c.n_held, 1):.3g}"
                 + (" (noise)" if not c.significant else "") + (" (from the null's end alone)" if alone else "")
                 + (", stalled there" if c.stalled and not c.second_start else ""))

    def _scored(self, effect, terms, cal, run: "_Run") -> Confirmed:
        """A recalibration ``cal`` scored on the held-out postures, with the candidate's size."""
        from rmbench.robot import Robot

        setup, nominal = self.setup, self.setup.nominal
        out_values = None
        if terms is not None:
            out_values = terms.values(dict(zip([p.name for p in cal.params], np.asarray(cal.u, float))))
        change = Change() if terms is None else effect.change(out_values) if terms.reread else terms.change
        robot = Robot(cal.xml, name=nominal.name, tool=nominal.tool, spindle_rpm=nominal.spindle_rpm)
        md, problem = setup.problem.modal, setup.problem
        obj = Objective(ModelBench(robot, setup.data.design, problem.bench.q_cmd), md.modes, md.frf, md.bands,
                        problem.held)
        e = obj.vector(change)
        chi2, prev = float(e @ e), run.prev
        return Confirmed(effect=effect, values=out_values, calibration=cal, robot=robot, chi2_held=chi2,
                         n_held=obj.n, peak_held=peak_residual(e),
                         chi2_held_posture=np.asarray(obj.per_posture(change)), objective=obj,
                         significant=significant(chi2, obj.n, p=self.options.p_noise, peak=peak_residual(e)),
                         seconds=round(time.perf_counter() - run.t0 + (0 if prev is None else prev.seconds), 1),
                         freed=() if terms is None else terms.free, rounds=1 if prev is None else prev.rounds + 1,
                         change=change, from_nominal=run.from_nominal or (prev is not None and prev.from_nominal),
                         start=run.started)

    def _candidate(self, effect, terms, used, settings, null, run: "_Run") -> Confirmed:
        """A candidate's recalibration from the ``null`` recalibration's end, with the null's
        budget (``options.max_iter``: it continues from where the null stopped), marked
        :attr:`~Confirmed.stalled` where a start from the nominal is to be sought too
        (:meth:`second_start`; the lower training objective is kept there); without ``null``, the
        start from the nominal alone with ``settings`` (``run``: that start).

        * From the null's end, the freed parameters where it left them (at their gross sizes
          where it lacks them), its ordinary look-alikes at the nominal (:attr:`CandidateTerms.reset`:
          a foundation's tilt for its slide). From the nominal, the modes-alone stage trades the freed sizes
          against the centres of mass and the foundation, which the modes alone cannot tell
          apart, and can end in another basin (e.g. a tool holder ×3.40: training objective
          341 + 27 from the nominal, 127 + 15 from the null's end; the truth's parameters give
          227 + 10).
        * From the nominal, as the first calibration started, the freed parameters at the best of
          their gross sizes (:func:`rmbench.calibrate.calibrate`). The first calibration moved the
          ordinary parameters to mimic the effect, and a fit from there can stall before it has
          moved them back (a sliding foundation found 40 % short). Neither start is better on
          every kind, so the lower training objective decides; but a start from the nominal costs
          three times one from the null's end (the gross grid, the modes, then the FRFs), and it
          is run only where the null's end shows the candidate on the way but not yet there: its
          run removed at least ``options.second_start`` of the null's excess held-out χ²
          (:meth:`Confirmed.closes`) and stayed above the noise, or added as much (a sliding
          foundation beside a calibrated tilt that had mimicked it stalled at 8 of 41 µm/kN, held-out
          χ² 1470 against the null's 1022). A candidate that does not move the held-out gap from
          there is not one a second basin is sought for, nor is one that reached the noise from
          there (it did not stall).
        """
        from rmbench.calibrate import calibrate

        setup = self.setup
        if null is None:
            return self._far(effect, terms, used, settings, run)
        start = {n: u for n, u in _values(null.calibration).items() if n not in getattr(terms, "reset", ())}
        other = calibrate(setup.nominal, used, held=setup.held_data,
                          settings=replace(settings, max_iter=self.options.max_iter), start=start)
        near = self._scored(effect, terms, other, replace(run, started="null"))
        # a second basin is sought for a run that stalled short of the noise having moved the
        # null's excess χ² a fifth of the way, or a fifth worse (it holds the null: ending worse,
        # it is in another basin). A null whose χ² passes the noise test has no excess χ² that is
        # signal, no share to judge by: :func:`~rmbench.gap.frf.restarts.favourite` starts one
        # candidate again instead
        stalled = (near.significant and chi2_gap(null, self.options)
                   and abs(near.closes(null)) >= self.options.second_start)
        return replace(near, stalled=stalled)

    def _far(self, effect, terms, used, settings, run: "_Run") -> Confirmed:
        """The candidate's recalibration from the nominal, with ``settings``."""
        from rmbench.calibrate import calibrate

        cal = calibrate(self.setup.nominal, used, held=self.setup.held_data, settings=settings)
        return self._scored(effect, terms, cal, run)


@dataclass(frozen=True)
class _Run:
    """How a recalibration was started: where, whether from the nominal, the run it continues
    and the clock at its start."""

    started: str
    from_nominal: bool
    prev: object
    t0: float


def _kept(near: Confirmed, far: Confirmed) -> Confirmed:
    """Of a candidate's two starts, the one with the lower training objective, timed over both."""
    best = near if near.train_objective < far.train_objective else far
    return replace(best, second_start=True, stalled=True, seconds=round(near.seconds + far.seconds, 1))


def _values(cal) -> dict:
    """``{parameter name: u}`` of a calibration (a start for the next)."""
    return dict(zip([p.name for p in cal.params], np.asarray(cal.u, float)))


def _objective(cal) -> float:
    """A calibration's training objective: its data χ² and its prior's part."""
    return float(cal.chi2_after + cal.chi2_prior)


def confirm(setup: ConfirmSetup, candidates, *, options: ConfirmOptions = ConfirmOptions(), accept=None,
            sizes=None, progress=None) -> tuple:
    """The null recalibration and one per candidate, each scored on the held-out postures.

    Parameters
    ----------
    setup : ConfirmSetup
        The nominal, the first calibration and its data, and the held-out postures to score on.
    candidates : sequence of Effect
        Confirmable effects (of the calibrated model's library).
    options : ConfirmOptions
        Evaluations per run, the noise test's level, when a candidate is continued or started
        again, and whether the candidates run where the null reaches the noise.
    accept : callable, optional
        ``accept(candidate, null)``: whether a confirmed candidate explains the gap. Every
        candidate runs, in its order, also after one is accepted (the choice among those that
        explain the gap is the caller's); none run when the null recalibration reaches the noise, unless
        ``options.need_gap`` is False. Once one is accepted (with ``need_gap``), a null is run from
        the accepted candidate's end with the candidates' budget (:func:`~rmbench.gap.frf.restarts.same_chance`); where it
        reaches the noise it is the null returned (the gap was the first calibration's, not the
        data's).
    sizes : dict, optional
        ``{effect name: values}``: the joint search's fitted size of each sensor candidate.
    progress : callable, optional
        ``progress(message)`` after each recalibration.

    Returns
    -------
    null : Confirmed
    confirmed : list of Confirmed, one per candidate run
    """
    names = [p.name for p in setup.first.params]
    run = _Recalibration(setup, dict(zip(names, np.asarray(setup.first.u, float))), options, sizes or {},
                         progress or (lambda msg: None))
    need_gap = options.need_gap
    null = run(None)
    done = []
    if need_gap and not null.significant:        # the ordinary parameters alone reach the noise
        if null.calibration.at_limit:
            # it is then the calibration the diagnosis reports: one more run toward convergence,
            # so that its intervals are those of a minimum
            null = run(None, prev=null)
        return null, done
    done = [run(effect, null=null) for effect in candidates]
    if accept is None or not any(accept(c, null) for c in done):
        # the starts from the nominal, only where no candidate explains the gap from the null's
        # end: one that does shows that end to lie in the data's basin, so another that stalled
        # there is not held by a wrong basin but fits the data less well
        done = [run.second_start(c) if c.stalled else c for c in done]
    if accept is not None and not any(accept(c, null) for c in done):
        done = favourite(run, null, done, options)
    # every candidate runs, also after one explains the gap: a look-alike further down the list
    # may explain it better, and the choice among them and its confidence (a selection frequency
    # among the models run) need all of them; stopped at the first accepted, the first look-alike
    # would win at confidence 1 (e.g. a wrist's mass listed before the flange's that was added)
    if accept is not None and any(accept(c, null) for c in done):
        return same_chance(run, null, done, accept, options), done
    promising = [c for c in done if c.significant and c.shrink_against(null) >= options.min_shrink]
    if not promising:
        return null, done
    best = min(promising, key=lambda c: c.chi2_held)
    null = run(None, prev=null)
    best = run(best.effect, prev=best)
    done = [best if c.effect is best.effect else c for c in done]
    if accept is None:
        return null, done
    if any(accept(c, null) for c in done):
        return same_chance(run, null, done, accept, options), done
    return further_starts(run, null, best, done, accept, options)
