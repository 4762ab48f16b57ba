"""Specification of the gap diagnosis's parts: test design, effect library, model bench (its fast
path against re-simulation), pairing and residuals, what is read of the data."""

import copy
import warnings
from dataclasses import replace

import numpy as np
import pytest
import xarray as xr

from rmbench.errors import InputError
from rmbench.gap import Change, GapDataWarning, MeasuredModes, ModelBench, TestDesign, library, measured_data
from rmbench.calibrate.design import SensorOffset
from rmbench.calibrate.residual import UNPAIRED, hammer_leak, mode_residuals, overlap, pair
from rmbench.impact import parse_config
from rmbench.robot import Posture, Robot
from rmbench.robot.parameters import parameter_set


@pytest.fixture(scope="module")
def robot():
    return Robot.load("irb6660", tool="dummy")


@pytest.fixture(scope="module")
def bench(robot, design):
    return ModelBench.commanded(robot, design, [Posture.from_mm_deg(1800, -200, 0),
                                                Posture.from_mm_deg(1500, 100, 40)])


# -- test design -----------------------------------------------------------------------------------
def test_design_keeps_bands_sensors_and_hits_and_drops_how_the_data_were_made():
    cfg = parse_config('seed = 42\nmethod = "time"\nnoise_scale = 3.0\n[robot]\nname = "secret.xml"\n'
                       'spindle_rpm = 9000.0\n[hits]\naverages = 5\n')
    d = TestDesign.from_config(cfg)
    assert d.config.seed == 0 and d.config.method == "linear" and d.config.noise_scale == 1.0
    assert d.config.robot.name == "irb6660" and d.config.robot.spindle_rpm == 0.0
    assert d.averages() == 5 and d.band_names == ("low", "high")
    assert d.band("low").s_1a == pytest.approx(0.0334)


def test_design_is_read_from_toml_or_from_a_datasets_json(design):
    assert TestDesign.from_text(design.config.model_dump_json()).config == design.config
    with pytest.raises(InputError, match="no test design"):
        TestDesign.of_dataset(xr.Dataset(), None)


def test_sensor_offset_moves_and_turns_one_sensor(design):
    moved = design.with_offsets([SensorOffset("high", "1aX", along=0.002, angle=0.1)])
    s0, s1 = design.sensors("high"), moved.sensors("high")
    np.testing.assert_allclose(s1.s_up - s0.s_up, [0, 0, 0.002, 0])
    np.testing.assert_allclose(s1.angle - s0.angle, [0, 0, 0.1, 0])
    np.testing.assert_array_equal(moved.sensors("low").s_up, design.sensors("low").s_up)
    with pytest.raises(InputError, match="sensor coordinate"):
        SensorOffset("high", "2X")


# -- effect library --------------------------------------------------------------------------------
def test_library_names_the_models_own_joints_actuators_bodies_and_the_designs_sensors(robot, design):
    effects = {e.name: e for e in library(robot, design)}
    for j in ("j1_flex", "j6_flex"):
        assert f"joint_stiffness@{j}" in effects and f"load_dependent_stiffness@{j}" in effects
    assert "servo_stiffness@a3" in effects and "servo_stiffness@a_spin" not in effects
    assert {"tool_contact_stiffness@tool_contact", "spindle_stiffness@spindle", "base_compliance@base",
            "added_mass@flange", "non_reciprocity@spindle_spin", "sensor_misplacement@high:1aY",
            "sensor_misalignment@low:1X"} <= set(effects)
    assert not any(n.startswith("added_mass@motor") for n in effects)   # 1 kg rotor stand-ins


def test_an_effect_is_data_turned_into_a_change(robot, design):
    effects = {e.name: e for e in library(robot, design)}
    ch = effects["joint_stiffness@j2_flex"].change([np.log(0.8)])
    (p, u), = ch.values
    assert (p.name, p.kind, p.targets, u) == ("j2_flex.stiffness", "stiffness", ("j2_flex",), np.log(0.8))
    assert p.value(u) == pytest.approx(0.8 * robot.model.joint("j2_flex").stiffness[0], rel=1e-12)
    assert effects["sensor_misplacement@high:1aX"].change([2.0]).offsets == (
        SensorOffset("high", "1aX", along=0.002),)
    both = ch + effects["non_reciprocity@spindle_spin"].change([6000.0])
    assert both.values == ch.values and both.spindle_rpm == 6000.0 and both.robot_part == both
    # one parameter twice: its log factors multiply
    assert (ch + ch).values == ((p, 2 * np.log(0.8)),)
    assert effects["joint_stiffness@j2_flex"].describe([np.log(0.8)]) == "j2_flex stiffness × 0.8"
    assert effects["base_compliance@base"].change([0.0, 0.0]).is_null()


# -- the model bench -------------------------------------------------------------------------------
def test_nominal_modes_at_a_posture_are_the_robots_exact_modes(bench, robot):
    op = robot.at(Posture.from_mm_deg(1800, -200, 0))
    exact = op.modes("low")
    got = bench.modes(Change(), 0, "low")
    for f in exact.f_n:
        assert np.min(np.abs(got.f_n / f - 1)) < 1e-6


@pytest.mark.parametrize("effect, value", [("joint_stiffness@j2_flex", np.log(0.9)),
                                           ("servo_stiffness@a3", np.log(0.3)),
                                           ("joint_damping@j3_flex", np.log(2.0)),
                                           ("load_dependent_stiffness@j2_flex", 0.2)],
                         ids=["stiffness", "servo", "damping", "load-stiffness"])
def test_fast_path_agrees_with_re_simulation_to_first_order(bench, robot, design, effect, value):
    """The fast path applies the change to the nominal linearisation and neglects the shift of
    the equilibrium it causes: frequencies agree to 0.1 %, damping ratios to 1 %."""
    delta = {e.name: e for e in library(robot, design)}[effect].change([value])
    assert bench.fast(delta)
    for band in ("low", "high"):
        full, fast = bench.modes(delta, 0, band), bench.modes_fast(Change(), delta, 0, band)
        assert len(full) == len(fast)
        np.testing.assert_allclose(fast.f_n, full.f_n, rtol=1e-3)
        np.testing.assert_allclose(fast.zeta, full.zeta, rtol=1e-2)


@pytest.mark.parametrize("effect, values", [("joint_stiffness@j2_flex", [np.log(0.8)]),
                                            ("servo_stiffness@a3", [np.log(0.5)]),
                                            ("tool_contact_stiffness@tool_contact", [np.log(0.5), np.log(2.0)])],
                         ids=["stiffness", "servo", "tool"])
def test_an_effect_edits_the_model_as_its_parameters_written_by_a_parameter_set(bench, robot, design, effect,
                                                                               values):
    """An effect's values are the ``u`` of the calibration's own parameters (the same records but
    for their group and search bounds): the model its change gives is the one a
    :class:`ParameterSet` of those parameters writes at those ``u``."""
    eff = {e.name: e for e in library(robot, design)}[effect]
    _, params = parameter_set(robot, ("joints", "servo", "tool"))
    own = {p.name: p for p in params}
    u = np.zeros(len(params))
    for p, x in zip(eff.parameters, values):
        twin = own[p.name]
        assert replace(p, group=twin.group, lower=twin.lower, upper=twin.upper) == twin
        u[params.names.index(p.name)] = x
    model = copy.copy(robot.model)
    params.apply_model(model, u)
    changed = bench.robot_for(eff.change(values)).model
    edited = "actuator_gainprm" if eff.kind == "servo_stiffness" else "jnt_stiffness"
    assert not np.array_equal(getattr(changed, edited), getattr(robot.model, edited))
    for field in ("jnt_stiffness", "dof_damping", "actuator_gainprm", "actuator_biasprm"):
        np.testing.assert_allclose(getattr(changed, field), getattr(model, field), rtol=1e-12, err_msg=field)


def test_masses_and_bases_are_not_on_the_fast_path(bench):
    assert not bench.fast(Change(masses=(("flange", 3.0),)))
    assert not bench.fast(Change(base=(1e8, 1e9)))
    assert not bench.fast(Change(spindle_rpm=5000.0))


def test_a_sensor_offset_changes_the_residues_not_the_poles(bench):
    delta = Change(offsets=(SensorOffset("high", "1X", angle=np.radians(10)),))
    a, b = bench.modes(Change(), 0, "high"), bench.modes(delta, 0, "high")
    np.testing.assert_allclose(a.f_n, b.f_n)
    assert np.abs(a.residue[:, 0] - b.residue[:, 0]).max() > 0.01 * np.abs(a.residue[:, 0]).max()
    np.testing.assert_allclose(a.residue[:, 1:], b.residue[:, 1:])


# -- pairing and residuals -------------------------------------------------------------------------
def _as_measured(model, *, f_scale=1.0, std=0.0):
    n = len(model)
    return MeasuredModes(f_n=model.f_n * f_scale, zeta=model.zeta, f_std=np.full(n, std),
                         zeta_std=np.zeros(n), residue=model.residue, residue_std=np.zeros(n),
                         mode_id=np.arange(n))


def test_a_model_that_is_the_measurement_has_no_gap(bench):
    model = bench.modes(Change(), 0, "low")
    e, pairing = mode_residuals(_as_measured(model), model)
    assert len(pairing.meas) == len(model) and not len(pairing.unpaired_model)
    # √(1 − MAC) of a vector with itself is the root of a rounding error, ~1e-8, over the 0.02 floor
    np.testing.assert_allclose(e, 0, atol=1e-5)


def test_a_frequency_gap_is_measured_in_floors(bench):
    """1 % higher measured frequencies with no standard error: each mode's frequency residual is
    ln(1/1.01) over its floor, 0.1 % in quadrature with 0.1 ζ o for a mode overlapping its
    nearest neighbour by o (close modes trade frequency off in any fit)."""
    model = bench.modes(Change(), 0, "low")
    meas = _as_measured(model, f_scale=1.01)
    e, _ = mode_residuals(meas, model)
    floor = np.hypot(1e-3, 0.1 * np.abs(meas.zeta) * overlap(meas.f_n, meas.zeta))
    np.testing.assert_allclose(e[:-1].reshape(-1, 4)[:, 0], np.log(1 / 1.01) / floor, rtol=1e-9)


def test_overlap_is_the_bandwidth_over_the_spacing_of_the_nearest_mode():
    """Modes at 10 and 11 Hz with 5 % damping: (0.5 + 0.55) / 1 = 1.05 for both; a lone mode 0."""
    np.testing.assert_allclose(overlap([10.0, 11.0, 100.0], [0.05, 0.05, 0.05])[:2], 1.05)
    assert overlap([10.0], [0.05])[0] == 0.0


def test_a_measured_mode_the_model_lacks_costs_the_unpaired_penalty(bench):
    model = bench.modes(Change(), 0, "low")
    meas = _as_measured(model)
    extra = MeasuredModes(f_n=np.append(meas.f_n, 33.0), zeta=np.append(meas.zeta, 0.02),
                          f_std=np.zeros(len(meas) + 1), zeta_std=np.zeros(len(meas) + 1),
                          residue=np.concatenate([meas.residue, meas.residue[:1]]),
                          residue_std=np.zeros(len(meas) + 1))
    e, pairing = mode_residuals(extra, model)
    assert list(pairing.unpaired_meas) == [len(meas)]
    assert e[4 * len(meas)] == UNPAIRED


def test_the_peak_test_reads_normalised_gaps_not_the_pairing_penalties(bench):
    """A measured mode with no model partner (a mode the modal fit split off, say) weighs in χ²,
    but the largest residual the peak test compares with noise is the largest real gap: here
    the 1 % frequency offsets, well below the 10σ penalty."""
    from rmbench.calibrate.residual import penalties
    from rmbench.gap.frf.search import peak_residual

    model = bench.modes(Change(), 0, "low")
    meas = _as_measured(model, f_scale=1.01)
    extra = MeasuredModes(f_n=np.append(meas.f_n, 33.0), zeta=np.append(meas.zeta, 0.02),
                          f_std=np.zeros(len(meas) + 1), zeta_std=np.zeros(len(meas) + 1),
                          residue=np.concatenate([meas.residue, meas.residue[:1]]),
                          residue_std=np.zeros(len(meas) + 1))
    e, _ = mode_residuals(extra, model)
    assert list(np.flatnonzero(penalties(e))) == [4 * len(meas)]
    gaps = np.abs(e[:4 * len(meas)])
    assert peak_residual(e) == gaps.max() < UNPAIRED
    assert e @ e == pytest.approx(gaps @ gaps + UNPAIRED ** 2)


def test_modes_without_shapes_pair_by_frequency(bench):
    model = bench.modes(Change(), 0, "low")
    n = len(model)
    meas = MeasuredModes(f_n=model.f_n * 1.02, zeta=model.zeta, f_std=np.zeros(n), zeta_std=np.zeros(n),
                         residue=np.full((n, 4, 4), np.nan + 0j), residue_std=np.zeros(n))
    e, pairing = mode_residuals(meas, model)
    np.testing.assert_array_equal(pairing.meas, pairing.model)
    assert np.all(e[:-1].reshape(-1, 4)[:, 2:] == 0)   # no shape, no shape residual


# -- what is read of the data ----------------------------------------------------------------------
def test_ground_truth_is_set_aside_with_a_warning_and_provenance_dropped():
    ds = xr.Dataset({"H": (("posture", "freq", "out", "inp"), np.ones((1, 3, 4, 4), complex)),
                     "H_exact": (("posture", "freq", "out", "inp"), np.ones((1, 3, 4, 4), complex))},
                    coords={"x": ("posture", [1.8]), "y": ("posture", [0.0]), "theta": ("posture", [0.0]),
                            "band": ("freq", ["low"] * 3)},
                    attrs={"config": "x", "robot": "secret", "source_file": "hidden.xml"})
    with pytest.warns(GapDataWarning, match="ground-truth"):
        out = measured_data(ds)
    assert "H_exact" not in out and set(out.attrs) == {"config"}


def test_data_without_postures_are_refused():
    ds = xr.Dataset({"H": (("posture", "freq", "out", "inp"), np.ones((1, 3, 4, 4), complex))},
                    coords={"band": ("freq", ["low"] * 3)})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InputError, match="posture positions"):
            measured_data(ds)


def test_the_hammer_leak_of_a_cross_entry_is_the_other_directions_response_ratio():
    """A 0.2° scatter over 4 hits leaks 0.2°/√4 of the X-hit response into the Y-hit column:
    with |H(1X, 1X)| ten times |H(1X, 1Y)| the cross entry's relative error is 10 × 1.745e-3."""
    H = np.ones((3, 2, 2), complex)
    H[:, 0, 0] = 10.0
    leak = hammer_leak(H, ["1X", "1Y"], np.radians(0.2), 4)
    np.testing.assert_allclose(leak[:, 0, 1], 10 * np.radians(0.2) / 2)
    np.testing.assert_allclose(leak[:, 0, 0], 0.1 * np.radians(0.2) / 2)


def test_one_large_residual_among_many_small_ones_is_significant():
    """χ² of 10 000 residuals hides one 8-sigma residual (χ²/n ≈ 1.006); the peak test, at a
    Bonferroni level, does not: a gap confined to one mode at one posture is still a gap."""
    from rmbench.gap.frf.search import significant

    n = 10_000
    chi2 = n - 1 + 64.0
    assert not significant(chi2, n, p=1e-3)
    assert significant(chi2, n, p=1e-3, peak=8.0)
    assert not significant(chi2, n, p=1e-3, peak=4.0)


def test_a_model_better_at_every_held_out_posture_wins_every_bootstrap_resample():
    """Confidences are bootstrap selection frequencies: a model ahead at each of 8 postures wins
    all resamples; one ahead at 7 but far behind at the 8th (χ² 0 against 20 at seven, 200
    against 20 at one) wins only the resamples that miss that posture, (7/8)^8 ≈ 34 %."""
    from rmbench.gap.selection import selection_weights

    n_units = [100] * 8
    np.testing.assert_allclose(selection_weights([[100.0] * 8, [50.0] * 8], n_units, [0, 0]), [0.0, 1.0])
    w = selection_weights([[20.0] * 8, [0.0] * 7 + [200.0]], n_units, [0, 0], n_boot=4000)
    assert abs(w[1] - (7 / 8) ** 8) < 0.03


class _Eff:
    """A stand-in effect: a name and one parameter."""

    n_params = 1

    def __init__(self, name):
        self.name = name


def _single(name, chi2_train, chi2_held):
    from rmbench.gap.frf.search import Fitted

    return Fitted((_Eff(name),), (np.zeros(1),), chi2_train, chi2_held, 1000, 1000)


def test_pairs_are_built_on_the_best_single_and_the_next_one_that_is_no_look_alike():
    """j1 stiffness and servo a1 are springs in series: pairs on both would repeat each other."""
    from rmbench.gap.frf.pairs import pair_bases

    singles = [_single("servo@a1", 100, 100), _single("joint@j1", 101, 101), _single("base", 150, 150)]
    bases = pair_bases(singles, (("servo@a1", "joint@j1"),))
    assert [f.name for f in bases] == ["servo@a1", "base"]


def test_a_far_worse_second_single_gets_no_pairs_of_its_own():
    """A second single with more than twice the best's training χ² would need its partner to do
    the best's work; the best's own screening already offers that pair."""
    from rmbench.gap.frf.pairs import pair_bases

    bases = pair_bases([_single("a", 100, 100), _single("b", 250, 260)])
    assert [f.name for f in bases] == ["a"]


def _search_pairs(monkeypatch, calibrate):
    """Runs the diagnosis's search on stand-in singles far from the noise (none explains) and
    returns whether pairs were fitted; ``calibrate``: the settings' calibrated groups."""
    from types import SimpleNamespace

    import rmbench.gap.frf.diagnosis as D
    from rmbench.gap.frf.settings import DiagnosisSettings

    fitted = []
    monkeypatch.setattr(D, "pairs", lambda *a: fitted.append(True) or (a[3], []))
    refiner = SimpleNamespace(screen=lambda effects, e0: [SimpleNamespace(effect=e, values=np.zeros(1), chi2=1e4)
                                                          for e in effects],
                              run=lambda jobs: [_single(j[0][0].name, 5000, 5000) for j in jobs])
    nom = _single("nominal", 9000, 9000)
    D._search(refiner, None, nom, [_Eff("a"), _Eff("b")], None, DiagnosisSettings(calibrate=calibrate),
              lambda msg: None, {})
    return bool(fitted)


def test_pairs_are_fitted_where_no_single_explains_the_gap_of_the_nominal_model(monkeypatch):
    assert _search_pairs(monkeypatch, calibrate=None)


def test_no_pairs_are_fitted_beside_a_calibration(monkeypatch):
    # its verdict rests on a recalibration with one effect freed, which a pair fitted to first
    # order beside the calibrated parameters cannot have
    assert not _search_pairs(monkeypatch, calibrate=("joints",))


def test_a_single_refitted_from_a_pair_replaces_its_stalled_fit():
    from rmbench.gap.frf.pairs import better_singles

    stalled, refit, other = _single("base", 6000, 4900), _single("base", 85, 52), _single("j1", 9e4, 9e4)
    out = better_singles([stalled, other], [refit, _single("mass", 9e5, 9e5)])
    assert {f.name: f.chi2_held for f in out} == {"base": 52, "j1": 9e4, "mass": 9e5}


def test_a_diagnosis_reads_as_a_few_lines_and_its_json_is_unchanged_by_the_alias():
    from types import SimpleNamespace

    from rmbench.gap.frf.result import VERDICTS, Diagnosis, EffectResult

    effect = EffectResult("joint_stiffness@j3_flex", "joint_stiffness", "j3_flex", {}, "j3 stiffer", {}, {}, 0.9,
                          (0.8, 0.95), 1.0, chosen=True)
    where = SimpleNamespace(describe=lambda: "j3", summary=lambda: {})
    dg = Diagnosis(verdict="explained", effects=(effect,), where=where, where_after=None, localisation="j3",
                   equivalent=(), nominal_chi2=10.0, n_residuals=5, nominal_peak=3.0, variant_xml=None,
                   design_changes=(), train=(), held=(), models=(), seconds={})
    assert VERDICTS == ("explained", "unexplained", "model form", "no significant gap")
    assert dg.summary().splitlines()[1].startswith("chosen joint_stiffness@j3_flex")
    assert dg.to_json("v.xml") == dg.to_dict("v.xml")
    with pytest.raises(ValueError, match="unknown verdict 'maybe'"):
        Diagnosis(**{**dg.__dict__, "verdict": "maybe"})


def _small_diagnosis(verdict="explained"):
    """An FRF diagnosis built directly: two postures, one tracked mode, two ranked effects."""
    from rmbench.gap.frf.result import Diagnosis, EffectResult
    from rmbench.gap.frf.where import GapMap

    def record(posture, f_model):
        return {"posture": posture, "x": 0.1 * posture, "y": 0.25, "theta": 0.5, "band": "low", "mode": 1,
                "f_meas": 10.0, "f_model": f_model, "zeta_meas": 0.02, "zeta_model": 0.02, "df": f_model / 10 - 1,
                "dzeta": 0.0, "dscale": 0.0, "mac": 0.99, "significant": True, "paired": True,
                "z": {"f": 12.5, "zeta": -0.5, "scale": 0.25, "shape": 1.5}}

    where = GapMap([record(0, 11.0), record(1, 11.5)], [], [])
    gap = {"gap": 4.0, "f_err": 0.1, "zeta_err": 0.0, "mac": 0.99, "frf_db": 2.0}
    after = {"gap": 1.0, "f_err": 0.01, "zeta_err": 0.0, "mac": 0.99, "frf_db": 0.5}
    chosen = EffectResult("joint_stiffness@j3_flex", "joint_stiffness", "j3_flex", {"ln_factor": -0.2},
                          "j3 20 % softer", gap, after, 0.75, (0.6, 0.85), 0.9, chosen=True)
    other = EffectResult("servo_stiffness@a3", "servo_stiffness", "a3", {"ln_factor": -1.0}, "a3 servo softer",
                         gap, {**after, "gap": 3.0}, 0.25, (0.1, 0.4), 0.1)
    return Diagnosis(verdict=verdict, effects=(chosen, other), where=where, where_after=None,
                     localisation="low band mode 1", equivalent=(), nominal_chi2=400.0, n_residuals=8,
                     nominal_peak=12.5, variant_xml=None, design_changes=(), train=(0,), held=(1,), models=(),
                     seconds={"total": 1.0})


def test_a_diagnosis_plots_the_ranked_effects_shrink_with_its_interval():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dg = _small_diagnosis()
    fig, ax = plt.subplots()
    assert dg.plot(ax) is ax
    bars = [p for p in ax.patches]
    assert [round(b.get_width()) for b in bars] == [75, 25]
    assert bars[0].get_facecolor() != bars[1].get_facecolor()      # the chosen effect stands out
    assert "explained" in ax.get_title()
    plt.close(fig)
    new = dg.plot()                                                 # its own figure without an ax
    assert new.figure is not fig
    plt.close(new.figure)


def test_the_report_of_a_diagnosis_is_the_same_from_the_object_and_from_its_folder(gap_reports, tmp_path):
    from rmbench.report import Page
    from rmbench.report.gap import diagnosis_document, gap_sections, read_diagnosis

    dg = _small_diagnosis()
    from_object, from_folder = gap_reports(dg)
    assert from_object == from_folder and "Gap diagnosis: explained" in from_object
    doc, read = diagnosis_document(dg), read_diagnosis(tmp_path / "saved")
    assert doc["kind"] == read["kind"] == "frf" and len(doc["modes"]) == len(read["modes"]) == 2
    with pytest.raises(TypeError, match="Diagnosis, TrackerDiagnosis or a diagnosis folder"):
        gap_sections(Page("gap"), {"verdict": "explained"})


def test_a_parameter_must_close_more_than_ln_n_of_the_held_out_chi2():
    """The held-out score is BIC, χ² + k ln n: on 1000 held-out residuals a parameter costs
    ln 1000 ≈ 6.9, so a one-parameter model must lower the held-out χ² by more than that."""
    from rmbench.gap.selection import bic

    n = 1000
    assert bic(1000.0 - 7.0, 1, n) < bic(1000.0, 0, n) < bic(1000.0 - 6.8, 1, n)


def test_with_fewer_than_four_held_out_units_the_weights_are_bic_weights_widened_by_the_misfit():
    """Three units are too few to resample: the weights are exp(−ΔBIC / 2ĉ), ĉ the best model's
    χ² per residual where it exceeds 1 (a model short of the data is less sure of its lead)."""
    from rmbench.gap.selection import selection_weights

    n_units = [100, 100, 100]
    w = selection_weights([[100.0] * 3, [98.0] * 3], n_units, [0, 0])
    np.testing.assert_allclose(w, np.array([np.exp(-3.0), 1.0]) / (1 + np.exp(-3.0)))
    w = selection_weights([[200.0] * 3, [198.0] * 3], n_units, [0, 0])      # ĉ = 1.98
    np.testing.assert_allclose(w, np.array([np.exp(-3.0 / 1.98), 1.0]) / (1 + np.exp(-3.0 / 1.98)))


def test_an_effects_confidence_sums_the_weights_of_the_models_that_hold_it():
    from rmbench.gap.selection import confidences

    out = confidences([(), ("a",), ("a", "b")], [0.2, 0.5, 0.3])
    assert out == pytest.approx({"a": 0.8, "b": 0.3})


def test_candidates_with_parallel_signatures_are_reported_as_look_alikes():
    """|cos| ≥ 0.995 between two candidates' first-order signatures (sign ignored) at every
    training posture: the data cannot tell them apart; 0.98 they can."""
    from types import SimpleNamespace

    from rmbench.gap.frf.evidence import equivalent

    def screen(name, v):
        return SimpleNamespace(effect=SimpleNamespace(name=name), sensitivity=np.array(v, float)[:, None])

    a = [1.0, 0.0, 0.0]
    same = [-2.0, 0.1, 0.0]                 # cos 0.9988
    near = [1.0, 0.2, 0.0]                  # cos 0.981
    assert equivalent([screen("a", a), screen("b", same), screen("c", near)]) == (("a", "b"),)


def test_cli_report_is_drawn_from_the_diagnosis_and_saves_nothing_without_out(tmp_path, capsys, monkeypatch):
    import rmbench.gap
    from rmbench.cli.main import main
    from rmbench.gap.frf.result import Diagnosis

    data = tmp_path / "measured.nc"
    data.write_bytes(b"")
    monkeypatch.setattr(rmbench.gap, "diagnose", lambda *a, **k: _small_diagnosis())
    monkeypatch.setattr(Diagnosis, "save", lambda self, directory: pytest.fail("saved"))
    report = tmp_path / "r.html"
    assert main(["gap", "diagnose", "--data", str(data), "--report", str(report)]) == 0
    assert f"wrote {report}" in capsys.readouterr().out
    assert "Gap diagnosis: explained" in report.read_text()


def test_parallel_signatures_form_one_group_and_orthogonal_ones_none():
    # a sign flip is the same signature (the data fit either with the opposite size); a signature
    # 2.5° off (cos 0.999) is still one the data cannot tell apart, one 90° off is distinct
    from rmbench.gap.selection import parallel_groups

    a = np.array([1.0, 0.0, 0.0])
    near = np.array([np.cos(np.radians(2.5)), np.sin(np.radians(2.5)), 0.0])
    groups = parallel_groups([a, -a, near, np.array([0.0, 0.0, 1.0])], ["a", "minus_a", "near", "other"])
    assert groups == (("a", "minus_a", "near"),)
    assert parallel_groups([a], ["a"]) == ()
