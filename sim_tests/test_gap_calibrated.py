"""Specification of the FRF gap diagnosis on top of a calibration (``gap diagnose --calibrate``): the
ordinary spread calibrated first, the structural effect named on top of it (a file of its own so
that its campaign and diagnosis build beside test_gap_diagnose.py's, on another test worker)."""

import json
import warnings

import numpy as np
import pytest

from rmbench.gap import diagnose
from rmbench.robot import Robot
from rmbench.robot.variant import make_variant

from test_gap_diagnose import CORNERS, _campaign


@pytest.fixture(scope="module")
def spread_and_contact(tmp_path_factory):
    """Data of an IRB6660 whose j2 and j5 gearboxes differ from the data sheet (ordinary spread)
    and whose tool sits 2.5 times stiffer in its holder (a structural effect the gearboxes cannot
    stand in for: it moves the high band's tool modes), at the four corner postures: the gearboxes
    move the arm's modes and the holder the tool's at every posture, so the verdicts, the effect
    and its size are those of the eight postures (holder ×2.51 against ×2.49, j2 ×0.800 both; the
    null recalibration's held-out χ² per residual 59 against 58 with the gearboxes alone, 0.01
    against 0.02 with the tool group) at half the fits, screening and recalibrations."""
    tmp = tmp_path_factory.mktemp("gapcal")
    robot = Robot.load("irb6660", tool="dummy")
    (tmp / "real.xml").write_text(make_variant(robot, ["j2_flex.stiffness*=0.8", "j5_flex.stiffness*=1.25",
                                                       "tool_contact_*.stiffness*=2.5"]))
    return _campaign(tmp, str(tmp / "real.xml"), "irb6660", postures=CORNERS)


@pytest.fixture(scope="module")
def calibrated_diagnosis(spread_and_contact):
    from rmbench.gap import DiagnosisSettings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return diagnose("irb6660", spread_and_contact, tool="dummy", workers=0,
                        settings=DiagnosisSettings(calibrate=("joints",)))


def test_with_calibration_the_structural_effect_is_named_on_top_of_the_calibrated_gearboxes(calibrated_diagnosis):
    dg = calibrated_diagnosis
    assert dg.verdict == "explained"
    assert dg.effects[0].name == "tool_contact_stiffness@tool_contact"
    # the data's noise is the sensors' only (linear method): the factor comes back within 5 %
    assert np.exp(dg.effects[0].params["ln_translation"]) == pytest.approx(2.5, rel=0.05)
    by = {p["name"]: p for p in dg.calibration["params"]}
    # the gearboxes come out of the calibration, not out of the effect search
    assert by["j2_flex.stiffness"]["value"] / by["j2_flex.stiffness"]["nominal"] == pytest.approx(0.8, abs=0.05)
    assert not any(e.kind == "joint_stiffness" for e in dg.effects)


def test_calibration_enters_the_json_beside_the_effects(calibrated_diagnosis):
    out = json.loads(json.dumps(calibrated_diagnosis.to_json()))
    assert out["calibration"]["groups"] == ["joints"]
    assert {"params", "heldout_errors", "chi2_per_residual"} <= set(out["calibration"])
    assert out["verdict"] == "explained" and out["effects"]


def _null(chi2_held):
    """A null recalibration's record, as much of it as the choice of the reported calibration reads."""
    from types import SimpleNamespace

    account = {"params": [], "iterations": 8}
    return SimpleNamespace(chi2_held=chi2_held, rounds=2, calibration=SimpleNamespace(
        to_json=lambda: dict(account), xml="<mujoco model='null'/>"))


def test_the_recalibration_with_the_frfs_is_reported_where_it_is_the_better_model():
    # the first calibration stopped short of the data (its held-out χ² far above the null's):
    # the verdict rests on the recalibration, so that is the calibration a user gets
    from types import SimpleNamespace

    from rmbench.gap.frf.rules import better_calibration

    dg, notes = SimpleNamespace(calibration={"groups": ["joints", "com"]}), []
    better = better_calibration(dg, _null(44.0), 3448.0, notes)
    assert better["calibrated_xml"] == "<mujoco model='null'/>"
    assert better["calibration"]["groups"] == ["joints", "com"]
    assert len(notes) == 1 and "recalibration with the FRFs" in notes[0]


def test_the_first_calibration_stays_where_the_recalibration_is_no_better():
    from types import SimpleNamespace

    from rmbench.gap.frf.rules import better_calibration

    notes = []
    assert better_calibration(SimpleNamespace(calibration={"groups": ["joints"]}), _null(120.0), 100.0, notes) == {}
    assert notes == []


class _Runs:
    """Stands in for the recalibrations of ``confirm``: the null continued from the first
    calibration leaves a gap, the candidate reaches the noise, and a null from the candidate's end
    reaches it (``fresh_noise``) or not; each call recorded as (effect, from the candidate's end)."""

    def __init__(self, fresh_noise, fresh_objective=300.0):
        self.fresh_noise, self.fresh_objective, self.calls = fresh_noise, fresh_objective, []

    def run(self, effect, prev=None, *, from_nominal=False, null=None, warm=None):
        from types import SimpleNamespace

        self.calls.append((None if effect is None else effect, warm is not None))
        significant = effect is None and not (warm is not None and self.fresh_noise)
        # training objectives (data χ² and prior): the candidate 300, a null from its end
        # ``fresh_objective``
        return SimpleNamespace(effect=effect, significant=significant, from_nominal=from_nominal,
                               warm=warm is not None, same_chance=warm is not None, freed=("x",),
                               chi2_held=900.0 if significant else 200.0,
                               train_objective=self.fresh_objective if warm is not None else 300.0,
                               shrink_against=lambda null: 0.5)


def _setup():
    """A confirmation's setup with nothing in it but a first calibration without parameters."""
    from types import SimpleNamespace

    from rmbench.gap.frf.confirm import ConfirmSetup

    first = SimpleNamespace(params=(), u=np.zeros(0))
    return ConfirmSetup(None, None, [], first, None)


def _confirm(monkeypatch, fresh_noise, fresh_objective=300.0):
    import rmbench.gap.frf.confirm as confirm_module

    runs = _Runs(fresh_noise, fresh_objective)
    monkeypatch.setattr(confirm_module, "_Recalibration", lambda *a: runs.run)
    null, done = confirm_module.confirm(_setup(), ["base_compliance@base"], accept=lambda c, n: True)
    return runs, null, done


def test_a_candidate_is_not_credited_with_a_gap_a_null_from_its_end_closes(monkeypatch):
    # the candidate ran from the nominal with the full budget, the null only on from a first
    # calibration caught short: the null runs on from where the candidate ended (its ordinary
    # parameters), and where it reaches the noise the gap was the first calibration's
    runs, null, done = _confirm(monkeypatch, fresh_noise=True)
    assert runs.calls == [(None, False), ("base_compliance@base", False), (None, True)]
    assert null.same_chance and not null.significant
    assert [c.effect for c in done] == ["base_compliance@base"]


def test_a_candidate_stands_where_the_null_from_its_end_reaches_the_noise_only_far_worse_in_training(monkeypatch):
    # the held-out postures cannot tell them apart; the training data with the prior can: 690
    # against 300 is far beyond the chi2(1) quantile at the noise test's level (10.8 at 1e-3),
    # the ordinary parameters pulled out of their spread to take the candidate's part
    runs, null, _ = _confirm(monkeypatch, fresh_noise=True, fresh_objective=690.0)
    assert runs.calls[-1] == (None, True)
    assert not null.same_chance and null.significant


def test_a_candidate_stands_where_a_null_from_its_end_still_leaves_a_gap(monkeypatch):
    runs, null, _ = _confirm(monkeypatch, fresh_noise=False)
    assert runs.calls[-1] == (None, True)
    assert not null.same_chance and null.significant


def test_a_candidate_continued_to_the_noise_gets_the_same_check(monkeypatch):
    # a candidate that closed most of the gap but not to the noise is continued, the null with
    # it; where the continued candidate explains the gap, the null from its end runs too
    from types import SimpleNamespace

    import rmbench.gap.frf.confirm as confirm_module

    calls = []

    def run(effect, prev=None, *, from_nominal=False, null=None, warm=None):
        calls.append((effect, prev is not None, warm is not None))
        at_noise = (effect is not None and prev is not None) or warm is not None
        # held-out χ² on 700 residuals: the null's 900 fails the χ² test itself (not by a peak alone)
        return SimpleNamespace(effect=effect, significant=not at_noise, same_chance=warm is not None, freed=("x",),
                               stalled=False,
                               chi2_held=200.0 if at_noise else (300.0 if effect else 900.0), n_held=700,
                               train_objective=1.0, shrink_against=lambda null: 0.42 if effect else 0.0)

    monkeypatch.setattr(confirm_module, "_Recalibration", lambda *a: run)
    null, _ = confirm_module.confirm(_setup(), ["base_compliance@base"], accept=lambda c, n: not c.significant,
                                     options=confirm_module.ConfirmOptions(min_shrink=0.4))
    assert calls == [(None, False, False), ("base_compliance@base", False, False), (None, True, False),
                     ("base_compliance@base", True, False), (None, False, True)]
    assert null.same_chance


def test_every_candidate_runs_after_one_explains_the_gap(monkeypatch):
    # a mass on the wrist, listed first, explains a mass added to the flange nearly as well: the
    # choice between them and its confidence need the flange's run too (seed 13128 robot 3)
    from types import SimpleNamespace

    import rmbench.gap.frf.confirm as confirm_module

    calls = []

    def run(effect, prev=None, *, from_nominal=False, null=None, warm=None):
        calls.append(effect)
        return SimpleNamespace(effect=effect, significant=effect is None, from_nominal=from_nominal,
                               chi2_held=900.0 if effect is None else 300.0, train_objective=1.0, freed=("x",),
                               shrink_against=lambda n: 0.5)

    monkeypatch.setattr(confirm_module, "_Recalibration", lambda *a: run)
    _, done = confirm_module.confirm(_setup(), ["added_mass@wrist", "added_mass@flange"],
                                     accept=lambda c, n: not c.significant)
    assert [c.effect for c in done] == ["added_mass@wrist", "added_mass@flange"]
    assert calls == [None, "added_mass@wrist", "added_mass@flange", None]


def _remaining(data, groups):
    from rmbench.gap import DiagnosisSettings, remaining_gap

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return remaining_gap("irb6660", data, tool="dummy", workers=0,
                             settings=DiagnosisSettings(calibrate=groups))


@pytest.mark.slow
def test_a_gap_the_gearboxes_cannot_take_up_remains_after_their_recalibration(spread_and_contact):
    # the tool holder 2.5 times stiffer moves the high band's tool modes, which no gearbox
    # stiffness reaches: both noise tests fail the calibrated model, the null recalibration's too
    rg = _remaining(spread_and_contact, ("joints",))
    assert rg.first_significant and rg.null is not None
    assert rg.null["significant"] and rg.significant


@pytest.mark.slow
def test_no_gap_remains_where_an_ordinary_parameter_takes_the_effect_up(spread_and_contact):
    # the same holder is an ordinary parameter of the tool group, 2.5 times inside its spread:
    # calibrated with it, the data leave nothing a structural search could find
    rg = _remaining(spread_and_contact, ("joints", "tool"))
    assert not rg.significant
    assert json.loads(json.dumps(rg.to_dict()))["significant"] is False


def test_remaining_gap_needs_groups_to_calibrate(spread_and_contact):
    from rmbench.gap import DiagnosisSettings, remaining_gap

    with pytest.raises(ValueError, match="calibrate"):
        remaining_gap("irb6660", spread_and_contact, tool="dummy", settings=DiagnosisSettings())


def test_a_confirmed_explanation_reports_the_calibration_fitted_with_the_effect(monkeypatch):
    # the first calibration bent the ordinary parameters to mimic the effect; the verdict rests on
    # the recalibration with the effect freed, so its parameters are the calibration a user gets
    from types import SimpleNamespace

    import rmbench.gap.frf.confirmed as confirmed_module
    from rmbench.gap import Change, DiagnosisSettings
    from rmbench.gap.frf.confirmed import Recalibrated, explained
    from rmbench.gap.frf.diagnosis import Diagnosis

    monkeypatch.setattr(confirmed_module, "metrics", lambda objective, ds, change: {})
    objective = SimpleNamespace(n_posture=lambda p: 100)
    effect = SimpleNamespace(name="base_compliance@base", kind="base_compliance", location="base", n_params=1,
                             params_dict=lambda v: {"lateral_um_per_kn": 90.0}, describe=lambda v: "a foundation")
    with_effect = SimpleNamespace(to_json=lambda: {"params": [{"name": "j2_flex.stiffness", "value": 0.8}]},
                                  xml="<mujoco model='with the foundation'/>")
    best = SimpleNamespace(effect=effect, values=(0.0,), chi2_held=400.0, n_held=400, objective=objective,
                           chi2_held_posture=np.full(4, 100.0), change=Change(), calibration=with_effect)
    base = SimpleNamespace(chi2_held=3600.0, n_held=400, objective=objective, chi2_held_posture=np.full(4, 900.0))
    dg = Diagnosis(verdict="unexplained", effects=(), where=SimpleNamespace(describe=lambda: ""), where_after=None,
                   localisation="", equivalent=(), nominal_chi2=1.0, n_residuals=1, nominal_peak=1.0,
                   variant_xml=None, design_changes=(), train=(), held=(0, 1, 2, 3), models=(), seconds={},
                   calibration={"groups": ["joints", "base"], "params": [{"name": "j2_flex.stiffness", "value": 0.6}]})
    outcome = Recalibrated(null=base, base=base, done=[best], record={}, gap=True, first_chi2=3600.0)
    problem = SimpleNamespace(held=[0, 1, 2, 3], ds=None)
    out = explained(dg, [best], outcome, problem, DiagnosisSettings(), [], {"start": 0.0, "confirm": 1.0})
    assert out.verdict == "explained"
    assert out.calibration == {"params": [{"name": "j2_flex.stiffness", "value": 0.8}], "groups": ["joints", "base"]}
    assert out.variant_xml == with_effect.xml
    assert any("recalibration with base_compliance@base freed" in n for n in out.notes)


def _candidate(effect="tool_contact_stiffness@tool_contact", *, significant=False, chi2_held=317.0,
               train_objective=368.0):
    # robot 2 of the calibration bench's seed 28832, restated: a tool holder x3.40 whose ordinary
    # parameter the first calibration left on its bound; freed, it reaches the noise
    from types import SimpleNamespace

    return SimpleNamespace(effect=effect, significant=significant, chi2_held=chi2_held,
                           train_objective=train_objective)


def _rule(monkeypatch, c, *, pinned, beyond=True, within=False):
    from types import SimpleNamespace

    import rmbench.gap.frf.rules as rules

    monkeypatch.setattr(rules, "beyond_spread", lambda c, nominal, groups: beyond)
    monkeypatch.setattr(rules, "within_spread", lambda c, nominal, groups: within)
    null = SimpleNamespace(significant=True, chi2_held=1103.0, train_objective=3384.0)
    return rules.confirms(c, null, gap=True, pinned=pinned, first_chi2=11853.0, min_shrink=0.5,
                          nominal=None, groups=("tool",))


def test_a_freed_bound_explains_a_gap_it_closes_less_than_half_of(monkeypatch):
    # the calibration pressed against the holder's bound had mimicked most of the effect: what
    # is left is barely above the noise, so even the truth closes only 46 % of it
    c = _candidate()
    assert _rule(monkeypatch, c, pinned=[c.effect])


def test_a_freed_bound_inside_its_spread_explains_nothing(monkeypatch):
    c = _candidate()
    assert not _rule(monkeypatch, c, pinned=[c.effect], beyond=False)


def test_a_freed_bound_that_strains_the_fit_more_explains_nothing(monkeypatch):
    c = _candidate(train_objective=4000.0)
    assert not _rule(monkeypatch, c, pinned=[c.effect])


def test_an_effect_behind_no_bound_must_close_half_the_gap(monkeypatch):
    # the 40 g look-alike: a small spindle change that tidies up a gap near the noise threshold
    c = _candidate("spindle_stiffness@spindle")
    assert not _rule(monkeypatch, c, pinned=["tool_contact_stiffness@tool_contact"])
    assert _rule(monkeypatch, _candidate("spindle_stiffness@spindle", chi2_held=200.0),
                 pinned=["tool_contact_stiffness@tool_contact"])


def test_no_candidate_explains_what_it_leaves_above_the_noise(monkeypatch):
    c = _candidate(significant=True)
    assert not _rule(monkeypatch, c, pinned=[c.effect])
