"""The blind tracker bench beyond the model (bench/blind_tracker.py): how a named source's size and
the calibrated compliances are read against the truth."""


import numpy as np
import pytest

from _bench_path import bench_on_path

with bench_on_path():
    from blind_tracker import found_size, scored_params, true_size


def test_a_gear_harmonics_size_is_its_amplitude_whatever_its_phase():
    # a sin(q) + b cos(q) is A sin(q + φ) with A = √(a² + b²)
    truth = {"kind": "gear_periodic_error", "amplitude": 1e-4, "phase": 0.7}
    found = found_size("gear_periodic_error", {"a_sin": 1e-4 * np.cos(0.7), "b_cos": 1e-4 * np.sin(0.7)})
    assert found == pytest.approx(true_size(truth))


def test_a_reflector_offsets_size_is_its_length():
    assert true_size({"kind": "frame_error", "offset": [3e-3, 4e-3, 0.0]}) == pytest.approx(5e-3)
    assert found_size("frame_error", {"dx": 0.0, "dy": 5e-3, "dz": 0.0}) == pytest.approx(5e-3)


def test_a_stiffer_gearbox_is_a_negative_compliance_fraction_within_five_percent():
    # stiffness × 1.25 is compliance × 0.8: fraction −0.2; an estimate of −0.18 is 2.5 % off the
    # true compliance, inside; its interval holds the truth
    cal = {"params": [{"name": "gravity_compliance@j2.fraction", "value": -0.18, "interval": [-0.25, -0.1],
                       "identifiability": "identifiable"}]}
    row, = scored_params(cal, {"j2_flex.stiffness": 1.25})
    assert row["true"] == pytest.approx(-0.2) and row["within5"] and row["covered"]


def test_a_placement_is_scored_for_coverage_alone():
    cal = {"params": [{"name": "link_geometry@j3.length", "value": 4e-4, "interval": [1e-4, 6e-4],
                       "identifiability": "weak"}]}
    row, = scored_params(cal, {"motor3.length": 3e-4})
    assert row["covered"] and "within5" not in row


def _bench_robot(i: int, seed: int, p_form: float):
    """Bench robot ``i`` of ``seed`` (bench/blind_tracker.py's draw, read with its noise) and its
    calibrated diagnosis."""
    with bench_on_path():
        import blind_tracker
        from truth.tracker import Reader
    from rmbench.gap.tracker.data import TrackerData, default_covariance
    from rmbench.gap.tracker.diagnosis import TrackerSettings, diagnose_tracker

    nominal, real, (q, order, previous, t), rng = blind_tracker.draw_robot(i, seed, p_form)
    y = Reader(real).positions(q, previous, t, rng)
    cov = default_covariance(nominal, q, y)
    data = TrackerData(q, y, order, np.sqrt(np.diagonal(cov, axis1=1, axis2=2)), t, tuple(nominal.arm_joints),
                       covariance=cov)
    return real, diagnose_tracker(nominal, data, settings=TrackerSettings(calibrate=True))


def test_a_gear_harmonic_a_joints_lost_motion_beats_held_out_is_not_named():
    """A bench robot inside its spread with a 160 µrad backlash at j4 (read in a shuffled order):
    j4's second gear harmonic takes it up well enough to leave the held-out readings at the
    noise, a wrong "explained"; j4's lost motion, one parameter, leaves them far lower (χ² 117
    against 839), so no source of the library is named, none is confident, and the lost motion
    is localised within 5 % of the backlash (about 1 µrad of noise on 160)."""
    real, dg = _bench_robot(8, 999, 0.0)
    assert real.source["kind"] == "backlash" and real.source["location"] == "j4" and not real.form
    assert dg.verdict in ("unexplained", "model form")
    assert any("explains the held-out readings better than gear_periodic_error@j4" in n for n in dg.notes)
    assert all(s.confidence < 0.5 for s in dg.sources)
    first = dg.form["located"]["places"][0]
    assert (first["where"], first["what"]) == ("j4", "lost motion")
    assert abs(first["size"]) == pytest.approx(real.source["angle"], rel=0.05)


@pytest.mark.slow
def test_a_reflector_offset_beside_a_bending_forearm_is_named_beside_the_model_form():
    """Bench robot 16 of tracker seed 96533: the reflector sits 1.57 mm off its nominal place on a
    robot whose forearm bends and whose upper arm warms along its length. No model reaches the
    noise (the verdict is "model form"), but the offset, added alone to the calibration, removes
    92 % of the held-out rms gap and no joint's generic augmentation beats it: it is named beside
    the form error, at its size to within the tracker's noise (a few µm on 1.57 mm)."""
    real, dg = _bench_robot(16, 96533, 0.5)
    assert real.source["kind"] == "frame_error" and {f["kind"] for f in real.form} >= {"bending_link"}
    assert dg.verdict == "model form"
    top = dg.sources[0]
    assert top.name == "frame_error@tool" and top.confidence >= 0.5
    found = np.array([top.params[k] for k in ("dx", "dy", "dz")])
    assert np.linalg.norm(found) == pytest.approx(np.linalg.norm(real.source["offset"]), rel=0.05)
    assert any(n.startswith("beside the gap no source closes") for n in dg.notes)


@pytest.mark.slow
def test_a_gear_harmonic_removing_a_sliver_of_a_bending_arms_gap_is_not_named():
    """Bench robot 27 of tracker seed 11082 has no source: its lower arm bends at four times the
    bench's median compliance. j2's first gear harmonic, a function of the arm's angle as the
    bending load is, drops the held-out χ² decisively (2,900 to 2,728 on 750 residuals) but
    removes 3 % of the rms gap: not the gap's main part, so it is not named. (A 24 kg payload
    beside a bending lower arm, robot 40 of seed 96533, is refused alike: the calibrated masses
    and compliances take most of it up, and what it adds, 4 % of the gap, is no more decisive.)"""
    real, dg = _bench_robot(27, 11082, 0.5)
    assert real.source is None and any(f["kind"] == "bending_link" for f in real.form)
    assert dg.verdict == "model form"
    assert all(s.confidence < 0.5 for s in dg.sources)
