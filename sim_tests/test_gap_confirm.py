"""Specification of a structural candidate's confirmation by recalibration: how a candidate's size
maps onto model parameters and back, which kinds map at all, and the shrink against the null."""

from types import SimpleNamespace

import numpy as np
import pytest

from rmbench.calibrate import CalibrationSettings, TestDesign
from rmbench.gap.frf.confirm import candidate_terms, confirmable
from rmbench.gap.selection import bootstrap_shrink
from rmbench.gap.frf.effects import library
from rmbench.impact import load_config
from rmbench.robot.parameters import parameter_set


@pytest.fixture(scope="module")
def calibrated_library(irb):
    robot, _ = parameter_set(irb, ("joints", "tool", "base"))
    design = TestDesign.from_config(load_config("seed_full"))
    return {e.name: e for e in library(robot, design)}


def test_a_holder_candidate_frees_the_calibrated_contact_and_reads_back_against_the_nominal(irb, calibrated_library):
    effect = calibrated_library["tool_contact_stiffness@tool_contact"]
    cal_u = {"tool_contact.translation": 0.1, "tool_contact.rotation": -0.2}
    terms = candidate_terms(effect, cal_u, ("joints", "tool"), irb)
    # the tool group already holds the contact: nothing added, both freed
    assert terms.extra == () and set(terms.free) == set(cal_u)
    # and back: the recalibrated contact in the effect's units (ln factors), against the nominal
    back = terms.values({"tool_contact.translation": np.log(0.3), "tool_contact.rotation": -0.2})
    np.testing.assert_allclose(back, [np.log(0.3), -0.2], atol=1e-12)


def test_a_sliding_foundation_candidate_is_the_lateral_compliance_added(irb, calibrated_library):
    effect = calibrated_library["base_compliance@base"]
    terms = candidate_terms(effect, {}, ("joints", "base"), irb)
    assert terms.extra[0] == "base.lateral_compliance" and terms.free == ("base.lateral_compliance",)
    assert terms.values({"base.lateral_compliance": 60.0})[0] == pytest.approx(60.0)


def test_a_sliding_foundation_candidate_fits_the_plates_mass_within_its_prior(irb, calibrated_library):
    """A foundation's moving mass is never known: at a fixed plate, a slab twice as heavy is read
    as a slide about 1.5 times too soft (the same sway frequency), so the plate's mass is fitted
    too, held by its prior, not freed."""
    effect = calibrated_library["base_compliance@base"]
    terms = candidate_terms(effect, {}, ("joints", "base"), irb)
    assert "base_mount.mass" in terms.extra and "base_mount.mass" not in terms.free


def test_the_foundations_plate_is_no_body_a_mass_is_added_to(calibrated_library):
    assert "added_mass@base_mount" not in calibrated_library


def test_a_heavier_body_candidate_reads_back_as_mass_added_to_the_nominal(irb, calibrated_library):
    effect = calibrated_library["added_mass@wrist"]
    m0 = float(irb.model.body("wrist").mass[0])
    terms = candidate_terms(effect, {"wrist.mass": np.log(1.1)}, ("masses",), irb)
    assert terms.extra == () and terms.free == ("wrist.mass",)
    assert terms.values({"wrist.mass": np.log(1.4)})[0] == pytest.approx(0.4 * m0)


def test_joint_candidates_map_onto_neither_a_model_parameter_nor_the_design(calibrated_library):
    kinds = {e.kind for e in calibrated_library.values() if not confirmable(e)}
    assert {"joint_stiffness", "load_dependent_stiffness"} <= kinds
    assert not ({"tool_contact_stiffness", "base_compliance", "added_mass", "sensor_misalignment",
                 "sensor_misplacement", "non_reciprocity"} & kinds)


def test_a_turned_sensor_candidate_is_freed_from_its_fitted_size(irb, calibrated_library):
    """A sensor's placement is a parameter of the design: the recalibration reads the data through
    the design turned by the joint search's angle and frees the angle from there (in degrees), so
    the size reported is the fitted one plus what the recalibration moved it."""
    effect = calibrated_library["sensor_misalignment@high:1Y"]
    terms = candidate_terms(effect, {}, ("joints",), irb, size=[-8.0])
    name = "sensor.high:1Y.angle"
    assert terms.extra == (name,) and terms.free == (name,) and terms.groups == ("joints",)
    (offset,) = terms.change.offsets
    assert offset.angle == pytest.approx(np.radians(-8.0))
    assert terms.values({name: 0.5}) == pytest.approx([-7.5])
    with pytest.raises(ValueError, match="fitted size"):
        candidate_terms(effect, {}, ("joints",), irb)


def test_a_spinning_spindle_candidate_frees_the_speed_in_thousands_of_rev_per_min(irb, calibrated_library):
    effect = next(e for e in calibrated_library.values() if e.kind == "non_reciprocity")
    terms = candidate_terms(effect, {}, ("joints",), irb)
    assert terms.extra == ("spindle.speed",) and terms.free == ("spindle.speed",)
    assert terms.values({"spindle.speed": 17.5}) == pytest.approx([17500.0])
    assert terms.change.is_null()     # the data are read through the design as it is


def test_the_shrink_against_the_null_is_of_the_rms_gap():
    c0, c1 = np.array([400.0, 400.0, 400.0, 400.0]), np.array([100.0, 100.0, 100.0, 100.0])
    shrink, (lo, hi) = bootstrap_shrink(c0, c1, n_boot=50)
    # a quarter of the χ² is half the rms gap, at every posture: no spread in the bootstrap
    assert shrink == pytest.approx(0.5) and lo == pytest.approx(0.5) and hi == pytest.approx(0.5)


def _confirmed_with(u: dict, freed):
    from types import SimpleNamespace

    from rmbench.gap.frf.confirm import Confirmed

    cal = SimpleNamespace(params=[SimpleNamespace(name=n) for n in u], u=np.array(list(u.values())))
    return Confirmed(effect=None, values=None, calibration=cal, robot=None, chi2_held=1.0, n_held=1,
                     peak_held=0.0, chi2_held_posture=np.ones(1), objective=None, significant=False,
                     seconds=0.0, freed=tuple(freed))


def test_a_holder_confirmed_inside_its_ordinary_spread_is_no_structural_effect(irb):
    from rmbench.gap.frf.rules import within_spread

    names = ("tool_contact.translation", "tool_contact.rotation")
    # × 0.8: inside the tool group's prior range (0.4-2.5): the first calibration's prior held it back
    assert within_spread(_confirmed_with({n: np.log(0.8) for n in names}, names), irb, ("joints", "tool"))
    # ÷ 4: outside it: a structural fault
    assert not within_spread(_confirmed_with({n: np.log(0.25) for n in names}, names), irb, ("joints", "tool"))
    # a parameter no ordinary group holds (the foundation's slide) is structural at any size
    assert not within_spread(_confirmed_with({"base.lateral_compliance": 5.0}, ["base.lateral_compliance"]),
                              irb, ("joints", "base"))


def test_each_confirmable_kind_is_confirmed_once_and_an_unrefined_foundation_too(calibrated_library):
    """After a calibration has mimicked a sliding foundation, the first-order search can rank it
    below everything (or not refine it at all): the recalibration sees one candidate of each
    kind, the best-scored first."""
    from rmbench.gap.frf.picks import confirm_picks

    def row(name, score):
        return {"params": {name: {}}, "score": score}

    models = [{"params": {}, "score": 0.0}, row("added_mass@wrist", 1.0), row("added_mass@flange", 2.0),
              row("sensor_misalignment@low:1aX", 0.5), row("tool_contact_stiffness@tool_contact", 3.0)]
    picks = [e.name for e in confirm_picks(models, calibrated_library, 5)]
    assert picks[:3] == ["sensor_misalignment@low:1aX", "added_mass@wrist", "tool_contact_stiffness@tool_contact"]
    # the unrefined kinds follow, but no unrefined sensor: it has no fitted size to be confirmed at
    assert set(picks[3:]) == {"spindle_stiffness@spindle", "base_compliance@base"}


def test_the_foundation_is_confirmed_even_when_others_fill_the_quota(calibrated_library):
    """The ordinary parameters mimic a slide best of all (the base's tilt, the links' centres of
    mass): it is recalibrated whatever its first-order rank."""
    from rmbench.gap.frf.picks import confirm_picks

    models = [{"params": {}, "score": 0.0}, {"params": {"added_mass@wrist": {}}, "score": 1.0},
              {"params": {"sensor_misalignment@low:1aX": {}}, "score": 0.5}]
    picks = [e.name for e in confirm_picks(models, calibrated_library, 2)]
    assert picks == ["sensor_misalignment@low:1aX", "added_mass@wrist", "base_compliance@base"]


def test_a_holder_explanation_is_read_on_top_of_the_calibrated_holder(irb):
    """The joint search's holder factor multiplies the calibrated one: ×0.85 on a holder the
    calibration left at ×1.1 is ×0.94 of the nominal, inside the tool group's spread."""
    from types import SimpleNamespace

    from rmbench.gap.frf.rules import ordinary_total

    e = SimpleNamespace(kind="tool_contact_stiffness", params={"ln_translation": 0.0, "ln_rotation": np.log(0.85)})
    total = ordinary_total(e, {"tool_contact.rotation": np.log(1.1)}, irb)
    assert total["tool_contact.rotation"] == pytest.approx(np.log(0.935))
    assert total["tool_contact.translation"] == 0.0
    sensor = SimpleNamespace(kind="sensor_misalignment", params={"angle": 1.0})
    assert ordinary_total(sensor, {}, irb) is None


def test_an_ordinary_parameter_left_on_a_bound_of_its_spread_stands_for_the_structural_effect_behind_it(
        calibrated_library):
    """A 50 % heavier forearm is reached by an ordinary calibration with the forearm's mass on its
    ×1.25 bound and the neighbours' centres of mass moved to make up the rest: the bound, not the
    residual, is the sign. A foundation resting at rigid (its nominal, a bound) is no sign."""
    from types import SimpleNamespace

    from rmbench.gap.frf.picks import pinned

    def est(name, on_bound, value=2.0, nominal=1.0):
        return SimpleNamespace(name=name, on_bound=on_bound, value=value, nominal=nominal)

    cal = SimpleNamespace(params=[est("upper_arm.mass", False), est("forearm.mass", True),
                                  est("base.tilt_compliance", True, value=0.0, nominal=0.0),
                                  est("upper_arm.com_x", True), est("tool_contact.rotation", True)])
    assert [e.name for e in pinned(cal, calibrated_library)] == [
        "added_mass@forearm", "tool_contact_stiffness@tool_contact"]


def test_a_freed_mass_is_beyond_its_spread_only_when_its_interval_clears_the_range(irb):
    """The masses' prior range is ×0.8-1.25: ×1.5 ± 5 % lies beyond it; ×1.3 ± 10 % reaches back into it."""
    from types import SimpleNamespace

    from rmbench.gap.frf.confirm import Confirmed
    from rmbench.gap.frf.rules import beyond_spread

    def freed(factor, sd):
        cal = SimpleNamespace(params=[SimpleNamespace(name="forearm.mass")], u=np.array([np.log(factor)]),
                              cov_u=np.array([[sd ** 2]]))
        return Confirmed(effect=None, values=None, calibration=cal, robot=None, chi2_held=1.0, n_held=1,
                         peak_held=0.0, chi2_held_posture=np.ones(1), objective=None, significant=False,
                         seconds=0.0, freed=("forearm.mass",))

    assert beyond_spread(freed(1.5, 0.05), irb, ("masses",))
    assert not beyond_spread(freed(1.3, 0.10), irb, ("masses",))
    # a mass no calibrated group holds is not judged against a spread here
    assert not beyond_spread(freed(1.5, 0.05), irb, ("joints",))


def _two_starts(monkeypatch, from_nominal: float, from_null: float, null=True, closes: float = 0.5,
                near_at_noise: bool = False, null_chi2: float = 100.0, terms=None, null_u=None, budgets=None):
    """``_Recalibration._candidate`` with calibrations that stand in for the two starts, each
    ending at the given training objective; the run from the null's end removes ``closes`` of the
    null's excess held-out χ² (the null: 100 on 50 residuals) and reaches the noise where
    ``near_at_noise``. The starts each was given recorded; ``terms``: the candidate's
    (:func:`candidate_terms`), ``null_u``: the null's end (default: ``{"j1_flex.stiffness": 0.2}``);
    ``budgets``: a list each start's (where, evaluations) is appended to."""
    from types import SimpleNamespace

    import rmbench.calibrate
    from rmbench.gap.frf.confirm import ConfirmOptions, Confirmed, _kept, _Recalibration, _Run

    starts = []

    def calibrate(robot, data, *, held=(), settings=None, start=None, progress=None):
        starts.append(start)
        if budgets is not None:
            budgets.append(("nominal" if start is None else "null's end", settings.max_iter))
        end = from_nominal if start is None else from_null
        return SimpleNamespace(chi2_after=end - 10.0, chi2_prior=10.0, start=start)

    def scored(self, effect, terms, cal, run):
        chi2 = 100.0 - 50.0 * closes if cal.start is not None else 60.0
        return Confirmed(effect=None, values=None, calibration=cal, robot=None, chi2_held=chi2, n_held=50,
                         peak_held=0.0, chi2_held_posture=np.ones(1), objective=None,
                         significant=not (near_at_noise and cal.start is not None),
                         seconds=1.0 if cal.start is not None else 3.0, start=run.started)

    monkeypatch.setattr(rmbench.calibrate, "calibrate", calibrate)
    monkeypatch.setattr(_Recalibration, "_scored", scored)
    run = _Recalibration(SimpleNamespace(nominal=None, held_data=None), None, ConfirmOptions(), None, None)
    null_u = null_u or {"j1_flex.stiffness": 0.2}
    base = SimpleNamespace(calibration=SimpleNamespace(params=[SimpleNamespace(name=n) for n in null_u],
                                                       u=np.array(list(null_u.values()))), chi2_held=null_chi2,
                           n_held=50)
    c = run._candidate(None, terms, None, CalibrationSettings(), base if null else None,
                       _Run("nominal", False, None, 0.0))
    if c.stalled:        # its second start, as :func:`confirm` asks for it
        c = _kept(c, run._far(None, terms, None, CalibrationSettings(), _Run("nominal", False, None, 0.0)))
    return c, starts


def test_a_candidate_keeps_the_null_recalibrations_end_where_that_start_ends_lower(monkeypatch):
    # the modes-alone stage from the nominal trades a freed holder against the centres of mass
    # and the foundation; from the null's end the ordinary parameters are already near the data
    c, starts = _two_starts(monkeypatch, from_nominal=368.0, from_null=142.0)
    assert starts == [{"j1_flex.stiffness": 0.2}, None]
    assert c.start == "null" and c.calibration.start == {"j1_flex.stiffness": 0.2} and c.second_start


def test_a_candidate_started_twice_is_timed_over_both_starts(monkeypatch):
    # the record says what the confirmation cost: 1 s from the null's end and 3 s from the
    # nominal, whichever is kept
    c, _ = _two_starts(monkeypatch, from_nominal=368.0, from_null=142.0)
    assert c.start == "null" and c.seconds == 4.0


def test_a_candidates_run_from_the_nulls_end_has_the_nulls_budget(monkeypatch):
    # it starts where the null stopped, as the null's own continuation does (8 evaluations); the
    # start from the nominal keeps the calibration's full budget for its gross grid, modes and FRFs
    budgets = []
    _two_starts(monkeypatch, from_nominal=368.0, from_null=142.0, budgets=budgets)
    assert budgets == [("null's end", 8), ("nominal", CalibrationSettings().max_iter)]
    assert CalibrationSettings().max_iter > 8


def test_a_sliding_foundation_starts_from_the_nulls_end_with_the_tilt_at_the_nominal(monkeypatch, irb,
                                                                                      calibrated_library):
    # tilt and slide both sway the robot on its base: a calibration without the slide bends the
    # tilt to mimic it, and from there the slide stalls (the tilt holds the sway modes)
    terms = candidate_terms(calibrated_library["base_compliance@base"], {}, ("joints", "base"), irb)
    _, starts = _two_starts(monkeypatch, from_nominal=368.0, from_null=142.0, terms=terms,
                            null_u={"j1_flex.stiffness": 0.2, "base.tilt_compliance": 3.0})
    assert starts[0] == {"j1_flex.stiffness": 0.2}


def test_a_candidate_keeps_the_nominal_start_where_that_ends_lower(monkeypatch):
    # from the null's end, where the ordinary parameters mimic the effect, a fit can stall
    c, _ = _two_starts(monkeypatch, from_nominal=142.0, from_null=368.0)
    assert c.start == "nominal" and c.calibration.start is None


def test_a_candidate_that_does_not_move_the_held_out_gap_from_the_null_is_not_started_again(monkeypatch):
    # a second basin is sought only for a candidate on the way (a fifth of the null's excess
    # held-out χ² removed): the start from the nominal costs three of the null's end
    c, starts = _two_starts(monkeypatch, from_nominal=142.0, from_null=368.0, closes=0.1)
    assert starts == [{"j1_flex.stiffness": 0.2}]
    assert c.start == "null" and not c.second_start


def test_a_candidate_that_makes_the_held_out_gap_worse_from_the_null_is_started_again(monkeypatch):
    # the candidate holds the null (its sizes at zero): from the null's end it can end worse on the
    # held-out postures only in another basin (seed 53076's sliding foundations, stalled beside a
    # calibrated tilt that had mimicked them, closed -1.4 and -2.9 of the null's excess χ²)
    c, starts = _two_starts(monkeypatch, from_nominal=142.0, from_null=368.0, closes=-1.4)
    assert starts == [{"j1_flex.stiffness": 0.2}, None]
    assert c.start == "nominal" and c.second_start


def test_a_candidate_that_reaches_the_noise_from_the_null_is_not_started_again(monkeypatch):
    # a run that reached the held-out noise did not stall: no second basin is sought for it
    c, starts = _two_starts(monkeypatch, from_nominal=142.0, from_null=368.0, closes=0.99, near_at_noise=True)
    assert starts == [{"j1_flex.stiffness": 0.2}]
    assert c.start == "null" and not c.second_start and not c.significant


def test_a_candidate_against_a_null_significant_by_its_peak_alone_runs_from_the_nulls_end_alone(monkeypatch):
    # a null at held-out χ² 40 on 50 residuals, significant by a peak: no excess χ² to judge the
    # candidate's progress by; which one starts again is decided over all of them (_favourite)
    c, starts = _two_starts(monkeypatch, from_nominal=142.0, from_null=368.0, null_chi2=40.0)
    assert starts == [{"j1_flex.stiffness": 0.2}]
    assert c.start == "null" and not c.second_start


def test_a_candidate_against_a_null_whose_chi2_passes_the_noise_test_is_not_judged_by_its_share(monkeypatch):
    # a null at held-out χ² 62 on 50 residuals (above n, inside the χ² test: chance at p 0.12),
    # significant by a peak: its excess χ² is noise, and a share of it says nothing either way
    c, starts = _two_starts(monkeypatch, from_nominal=142.0, from_null=368.0, null_chi2=62.0, closes=0.9)
    assert starts == [{"j1_flex.stiffness": 0.2}]
    assert c.start == "null" and not c.second_start


def test_a_run_without_a_null_starts_from_the_nominal_alone(monkeypatch):
    c, starts = _two_starts(monkeypatch, from_nominal=142.0, from_null=0.0, null=False)
    assert starts == [None] and c.start == "nominal"


class _FakeRun:
    """Stands in for ``_Recalibration``: each run's end from ``ends[(name, how)]`` as
    ``(training objective, held-out χ², significant)``, ``how`` one of ``"nominal"``,
    ``"continued"``, ``"rank N"``, ``"from START"`` (a null from a candidate's end, START that
    run's own ``how``); the runs asked for recorded in ``calls``."""

    def __init__(self, ends):
        self.ends, self.calls = ends, []

    def __call__(self, effect, prev=None, *, from_nominal=False, null=None, rank=0, warm=None):
        from rmbench.gap.frf.confirm import Confirmed

        name = "null" if effect is None else effect
        if warm is not None:
            how = f"from {warm.start}"
        elif rank:
            how = f"rank {rank}"
        else:
            how = "continued" if prev is not None else "nominal"
        self.calls.append((name, how))
        obj, chi2, sig = self.ends.get((name, how), (1e4, 1e4, True))
        cal = SimpleNamespace(chi2_after=obj, chi2_prior=0.0)
        return Confirmed(effect=effect, values=None, calibration=cal, robot=None, chi2_held=chi2, n_held=700,
                         peak_held=0.0, chi2_held_posture=np.ones(1), objective=None, significant=sig,
                         seconds=0.0, start=how, warm=warm is not None)


def _confirm_with(monkeypatch, ends):
    import rmbench.gap.frf.confirm as C

    fake = _FakeRun(ends)
    monkeypatch.setattr(C, "_Recalibration", lambda *a, **k: fake)
    first = SimpleNamespace(params=[], u=np.zeros(0))
    setup = C.ConfirmSetup(None, None, None, first, None)
    null, done = C.confirm(setup, ["slide"], accept=lambda c, n: not c.significant)
    return fake.calls, null, done


# a foundation candidate that closes most of the gap (held-out χ² 1,700 against the null's
# 7,400: a shrink of 0.52) but stays above the noise after its continuation
_SHORT = {("null", "nominal"): (300.0, 7400.0, True), ("null", "continued"): (290.0, 7400.0, True),
          ("slide", "nominal"): (1300.0, 1700.0, True), ("slide", "continued"): (1270.0, 1700.0, True)}


def test_a_promising_candidate_short_of_the_noise_is_retried_from_the_next_gross_start(monkeypatch):
    calls, _, done = _confirm_with(monkeypatch, {**_SHORT, ("slide", "rank 1"): (137.0, 82.0, False)})
    assert ("slide", "rank 1") in calls and ("slide", "rank 2") not in calls    # accepted: no third
    assert done[0].start == "rank 1" and not done[0].significant


def test_a_further_start_is_kept_only_where_its_training_objective_is_lower(monkeypatch):
    # held-out noise from a worse training fit is no evidence: the held-out postures do not choose
    calls, _, done = _confirm_with(monkeypatch, {**_SHORT, ("slide", "rank 1"): (2000.0, 82.0, False),
                                                 ("slide", "rank 2"): (1500.0, 1700.0, True)})
    assert ("slide", "rank 2") in calls
    assert done[0].start == "continued"


def test_the_null_runs_from_the_accepted_candidates_end_at_its_further_start(monkeypatch):
    # the gap may be the basin's, not the data's: the null from the basin the accepted candidate
    # found (its end at the further start) reaching the noise is the null returned
    calls, null, _ = _confirm_with(monkeypatch, {**_SHORT, ("slide", "rank 1"): (137.0, 82.0, False),
                                                 ("null", "from rank 1"): (140.0, 90.0, False)})
    assert calls[-1] == ("null", "from rank 1")
    assert null.start == "from rank 1" and null.same_chance


def test_the_null_from_the_candidates_end_still_short_leaves_the_continued_null(monkeypatch):
    # the ordinary parameters alone cannot follow the candidate from its basin: the candidate
    # stands against the null continued from the first calibration
    calls, null, _ = _confirm_with(monkeypatch, {**_SHORT, ("slide", "rank 1"): (137.0, 82.0, False),
                                                 ("null", "from rank 1"): (900.0, 1650.0, True)})
    assert calls[-1] == ("null", "from rank 1")
    assert null.start == "continued" and not null.same_chance


class _NullEndRun(_FakeRun):
    """:class:`_FakeRun` whose candidates run from the null's end alone (start ``"null"``) when
    given a null; without one, from the nominal (``how`` ``"nominal"``)."""

    def __call__(self, effect, prev=None, *, from_nominal=False, null=None, rank=0, warm=None):
        from dataclasses import replace

        if effect is None or null is None:
            return super().__call__(effect, prev, from_nominal=from_nominal, rank=rank, warm=warm)
        self.calls.append((effect, "null's end"))
        obj, chi2, sig = self.ends[(effect, "null's end")]
        c = super().__call__(effect)
        self.calls.pop()
        return replace(c, calibration=SimpleNamespace(chi2_after=obj, chi2_prior=0.0), chi2_held=chi2,
                       significant=sig, start="null")


def _favourite_with(monkeypatch, ends):
    import rmbench.gap.frf.confirm as C

    fake = _NullEndRun(ends)
    monkeypatch.setattr(C, "_Recalibration", lambda *a, **k: fake)
    first = SimpleNamespace(params=[], u=np.zeros(0))
    setup = C.ConfirmSetup(None, None, None, first, None)
    null, done = C.confirm(setup, ["wrist", "slide"], accept=lambda c, n: not c.significant)
    return fake.calls, null, done


# a null at held-out χ² 690 on 700 residuals, significant by its peak alone; a slide and a wrist
# from its end, both short of the noise, the slide lower in training objective
_PEAK_ONLY = {("null", "nominal"): (2400.0, 690.0, True), ("wrist", "null's end"): (2398.0, 680.0, True),
              ("slide", "null's end"): (2321.0, 685.0, True)}


def test_against_a_null_significant_by_its_peak_alone_the_training_favourite_starts_again(monkeypatch):
    calls, _, done = _favourite_with(monkeypatch, {**_PEAK_ONLY, ("slide", "nominal"): (1400.0, 500.0, False)})
    assert ("slide", "nominal") in calls and ("wrist", "nominal") not in calls
    slide = next(c for c in done if c.effect == "slide")
    assert slide.start == "nominal" and slide.second_start and not slide.significant


def test_the_favourites_second_start_is_kept_only_where_its_training_objective_is_lower(monkeypatch):
    _, _, done = _favourite_with(monkeypatch, {**_PEAK_ONLY, ("slide", "nominal"): (2500.0, 500.0, False)})
    slide = next(c for c in done if c.effect == "slide")
    assert slide.start == "null" and slide.second_start and slide.significant


def test_a_null_with_a_chi2_gap_starts_no_favourite_again(monkeypatch):
    # held-out χ² 7,400 on 700: the share rule inside each candidate's run decides instead
    ends = {**_PEAK_ONLY, ("null", "nominal"): (2400.0, 7400.0, True)}
    calls, _, _ = _favourite_with(monkeypatch, ends)
    assert ("slide", "nominal") not in calls and ("wrist", "nominal") not in calls


def _holder_diagnosis(ln_rotation):
    """A joint search's explanation by the tool holder alone, on a first calibration that left the
    holder's rotation at ×1.1 (the tool group's prior range is ×0.4-2.5)."""
    from rmbench.gap.frf.result import Diagnosis, EffectResult

    effect = EffectResult("tool_contact_stiffness@tool_contact", "tool_contact_stiffness", "tool_contact",
                          {"ln_translation": 0.0, "ln_rotation": ln_rotation}, "holder", {}, {}, 0.8, (0.7, 0.9),
                          1.0, chosen=True)
    where = SimpleNamespace(describe=lambda: "", summary=lambda: {})
    dg = Diagnosis(verdict="explained", effects=(effect,), where=where, where_after=None, localisation="",
                   equivalent=(), nominal_chi2=1.0, n_residuals=1, nominal_peak=1.0, variant_xml=None,
                   design_changes=(), train=(), held=(), models=(), seconds={})
    cal = SimpleNamespace(params=[SimpleNamespace(name="tool_contact.rotation")], u=np.array([np.log(1.1)]))
    first = SimpleNamespace(cal=cal, settings=SimpleNamespace(groups=("joints", "tool")))
    return dg, first


def test_an_explanation_whose_total_size_stays_inside_the_ordinary_spread_is_no_structural_gap(irb):
    """×0.85 on a holder calibrated to ×1.1 is ×0.94 of the nominal: inside the spread, so the
    calibration's prior merely held the holder back ("no significant gap"); ÷5 on top of it,
    ×0.22, lies outside the spread and the explanation stands."""
    from rmbench.gap.frf.rules import spread_checked

    dg, first = _holder_diagnosis(np.log(0.85))
    held_back = spread_checked(dg, irb, first)
    assert held_back.verdict == "no significant gap" and "within its ordinary spread" in held_back.notes[-1]
    dg, first = _holder_diagnosis(np.log(0.2))
    assert spread_checked(dg, irb, first) is dg


class _StallRun(_FakeRun):
    """:class:`_FakeRun` whose candidates run from the null's end (``ends[(name, "null's end")]``
    as ``(training objective, held-out χ², significant, stalled)``), and whose second starts
    (:meth:`second_start`) are recorded in ``calls`` and end at ``ends[(name, "nominal")]``."""

    def __call__(self, effect, prev=None, *, from_nominal=False, null=None, rank=0, warm=None):
        from dataclasses import replace

        if effect is None or null is None:
            return super().__call__(effect, prev, from_nominal=from_nominal, rank=rank, warm=warm)
        obj, chi2, sig, stalled = self.ends[(effect, "null's end")]
        self.calls.append((effect, "null's end"))
        c = super().__call__(effect)
        self.calls.pop()
        return replace(c, calibration=SimpleNamespace(chi2_after=obj, chi2_prior=0.0), chi2_held=chi2,
                       significant=sig, start="null", stalled=stalled)

    def second_start(self, near):
        from dataclasses import replace

        self.calls.append((near.effect, "second start"))
        obj, chi2, sig = self.ends.get((near.effect, "nominal"), (1e4, 1e4, True))
        return replace(near, calibration=SimpleNamespace(chi2_after=obj, chi2_prior=0.0), chi2_held=chi2,
                       significant=sig, second_start=True)


def _stalled_with(monkeypatch, ends, names=("tool", "slide")):
    import rmbench.gap.frf.confirm as C

    fake = _StallRun(ends)
    monkeypatch.setattr(C, "_Recalibration", lambda *a, **k: fake)
    setup = C.ConfirmSetup(None, None, None, SimpleNamespace(params=[], u=np.zeros(0)), None)
    null, done = C.confirm(setup, list(names), accept=lambda c, n: not c.significant)
    return fake.calls, null, done


# a null at held-out χ² 7,400 on 700 residuals; a tool holder from its end stalled (moved the
# gap a fifth of the way and stopped short of the noise)
_TOOL_STALLED = {("null", "nominal"): (3000.0, 7400.0, True), ("tool", "null's end"): (2000.0, 5000.0, True, True)}


def test_a_stalled_candidate_is_started_again_where_none_explains_the_gap_from_the_nulls_end(monkeypatch):
    calls, _, done = _stalled_with(monkeypatch, {**_TOOL_STALLED,
                                                 ("slide", "null's end"): (2900.0, 7000.0, True, False)})
    assert ("tool", "second start") in calls and ("slide", "second start") not in calls
    assert done[0].second_start


def test_a_stalled_candidate_is_not_started_again_where_another_explains_the_gap_from_the_nulls_end(monkeypatch):
    # the slide reaches the noise from the null's end, listed after the stalled holder: that end
    # lies in the data's basin, and a start from the nominal (three runs from the null's end)
    # would not rescue the holder from a wrong one
    calls, _, done = _stalled_with(monkeypatch, {**_TOOL_STALLED, ("slide", "null's end"): (800.0, 650.0, False, False),
                                                 ("null", "from null"): (2000.0, 5000.0, True)})
    assert not any(how == "second start" for _, how in calls)
    assert done[0].stalled and not done[0].second_start and not done[1].significant

