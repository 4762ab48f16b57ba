"""Posture scheduling of the proof-mass controller (issue 41): the multi-axis plant identified from
shaker tests, controllers designed at a grid of postures and blended, their certificate, the
schedule file, and the loop running on a moving robot."""

import numpy as np
import pytest

from rmbench.control import Controller, achieves_gamma, design, is_stable, reaction_mass, run_loop, two_mass_plant
from rmbench.control.identify import fit_modes_matrix
from rmbench.control.plant import first_strong_mode, modal_plant
from rmbench.control.schedule import Schedule, blend_plants, certify, design_schedule, grid_posture
from rmbench.control.trajectory import Trajectory, linear_move, load_trajectory
from rmbench.errors import InputError

# a 5.9 Hz robot mode and a weaker 11.9 Hz one, as the reference posture's shaker test shows them
MODES = [(92.8, 5.9, 0.03), (400.0, 11.9, 0.045)]  # (modal mass kg, f_n Hz, ζ)


@pytest.fixture(scope="module")
def rm(op):
    return reaction_mass(op.robot.model, "tangential")


def plant_at(rm, scale: float):
    """The two-mode plant with every mode frequency times ``scale`` (a posture moving the arm)."""
    M = np.array([m for m, _, _ in MODES])
    w = 2 * np.pi * scale * np.array([f for _, f, _ in MODES])
    z = np.array([z for _, _, z in MODES])
    return two_mass_plant(M, M * w**2, 2 * z * M * w, rm)


@pytest.fixture(scope="module")
def schedule(rm):
    """A 2 x 2 grid over J2 and J3 whose plants' modes sit at ×0.85 … ×1.15."""
    grid = (np.radians([-10.0, 20.0]), np.radians([-10.0, 30.0]))
    scales = [1.15, 1.05, 0.95, 0.85]  # C order: J2 moving the mode most
    plants = [plant_at(rm, s) for s in scales]
    return design_schedule(plants, grid, (1, 2), np.array([0, 0, 0, 0, np.pi / 2, 0]), hold=4), plants


# -- the plant from a shaker campaign ----------------------------------------------------------------
def test_modal_plant_of_one_axis_is_the_two_mass_plant(rm):
    M = np.array([m for m, _, _ in MODES])
    f = np.array([f for _, f, _ in MODES])
    z = np.array([z for _, _, z in MODES])
    freq = np.array([0.5, 3.0, 5.9, 9.0, 11.9, 30.0])
    p = modal_plant(f, z, (1 / np.sqrt(M))[None], [rm], ("tangential",))
    # the same equations in modal coordinates: only round-off separates them
    np.testing.assert_allclose(p.frf(freq), plant_at(rm, 1.0).frf(freq), rtol=1e-9, atol=1e-15)


def test_fit_modes_matrix_recovers_a_two_axis_modal_system():
    freq = np.arange(2.0, 40.0, 0.125)
    f_n, zeta = np.array([5.9, 11.9, 15.3]), np.array([0.03, 0.045, 0.06])
    V = np.array([[0.10, 0.02, 0.06], [0.01, 0.09, -0.05]])  # 1/√kg: the axes couple through mode 3
    w, wr = 2 * np.pi * freq[:, None], 2 * np.pi * f_n[None]
    acc = np.einsum("fr,ir,jr->fij", -w**2 / (wr**2 - w**2 + 2j * zeta * wr * w), V, V)
    fit = fit_modes_matrix(freq, acc)
    k = fit.n_residual
    # noise-free data of exactly this model (the residual pseudo-modes take nothing): recovered to
    # the solver's tolerance
    np.testing.assert_allclose(fit.f_n[k:], f_n, rtol=1e-3)
    np.testing.assert_allclose(fit.zeta[k:], zeta, rtol=1e-2)
    np.testing.assert_allclose(np.abs(fit.shapes[:, k:]), np.abs(V), rtol=1e-2, atol=1e-4)


def test_first_strong_mode_takes_the_lower_of_two_comparable_peaks(rm):
    # the 11.9 Hz mode's accelerance peak rises above the 5.9 Hz one once its modal mass is light
    M = np.array([92.8, 60.0])
    p = modal_plant([5.9, 11.9], [0.03, 0.03], (1 / np.sqrt(M))[None], [rm], ("tangential",))
    assert p.mode_hz[0] > 11.0  # the largest peak
    assert abs(first_strong_mode(p) - 5.9) < 0.1


# -- the synthesis check ---------------------------------------------------------------------------
def test_synthesis_check_rejects_a_controller_with_the_wrong_sign(rm):
    plant = plant_at(rm, 1.0)
    d = design(plant, order=None)
    k = d.controller
    assert achieves_gamma(plant, k, d.gamma)
    # the same controller pushing instead of damping misses γ (or destabilises the loop)
    assert not achieves_gamma(plant, Controller(k.axes, k.A, k.B, -k.C, -k.D), d.gamma)


# -- blending --------------------------------------------------------------------------------------
def test_weights_at_a_grid_posture_select_its_controller(schedule):
    sch, _ = schedule
    s = sch.grid_variables()[2]
    np.testing.assert_array_equal(sch.weights(s), [0, 0, 1, 0])


def test_weights_are_bilinear_and_sum_to_one(schedule):
    sch, _ = schedule
    g2, g3 = sch.grid
    w = sch.weights([g2[0] + 0.25 * (g2[1] - g2[0]), g3[0] + 0.5 * (g3[1] - g3[0])])
    np.testing.assert_allclose(w, [0.375, 0.375, 0.125, 0.125])


def test_weights_hold_the_grid_edge_outside_it(schedule):
    sch, _ = schedule
    assert not sch.inside(np.radians([40.0, 0.0]))
    np.testing.assert_array_equal(sch.weights(np.radians([40.0, 30.0])), [0, 0, 0, 1])


def test_blended_controller_at_a_grid_posture_is_its_design(schedule):
    sch, _ = schedule
    freq = np.array([2.0, 5.9, 12.0])
    np.testing.assert_allclose(sch.at(sch.grid_variables()[1]).frf(freq), sch.controllers[1].frf(freq))


def test_grid_posture_turns_the_hold_joint_against_the_scheduled_ones():
    q = grid_posture(np.array([0, 0, 0, 0, 1.5, 0]), (1, 2), [0.1, 0.2], hold=4)
    np.testing.assert_allclose(q, [0, 0.1, 0.2, 0, 1.2, 0])  # J2 + J3 + J5 unchanged: spindle keeps its tilt


# -- where the schedule vouches for its loop ---------------------------------------------------------
def limited(sch):
    """``sch`` vouching for 5 deg beyond its grid and for J1 anywhere, J4 within 15 deg."""
    from dataclasses import replace

    return replace(sch, reach=(np.radians(5.0),) * 2, span=tuple(np.radians([180.0, 0, 0, 15.0, 0, 0])))


def test_a_posture_in_the_extrapolation_ring_is_covered(schedule):
    sch = limited(schedule[0])
    q = sch.posture(np.radians([23.0, 0.0]))  # 3 deg past J2's edge, inside the 5 deg reach
    assert sch.refusal(q) is None


def test_a_posture_past_the_reach_is_refused_naming_the_joint(schedule):
    sch = limited(schedule[0])
    with pytest.raises(InputError, match=r"J2 at 27\.0 deg lies 7\.0 deg beyond .* reach of 5\.0 deg"):
        sch.check(sch.posture(np.radians([27.0, 0.0])))


def test_an_unscheduled_joint_past_its_span_is_refused(schedule):
    sch = limited(schedule[0])
    q = sch.posture(np.radians([0.0, 0.0]))
    q[3] += np.radians(20.0)  # J4 20 deg off against 15 allowed
    assert "J4 departs +20.0 deg" in sch.refusal(q)
    q[3] -= np.radians(10.0)
    q[0] += np.radians(120.0)  # J1 free, J4 within its span
    assert sch.refusal(q) is None


def test_the_hold_joint_follows_the_scheduled_ones_before_its_span_is_checked(schedule):
    sch = limited(schedule[0])
    q = sch.posture(np.radians([15.0, 25.0]))  # J5 turned by -(J2 + J3 moves): the schedule's own posture
    assert sch.refusal(q) is None
    q[4] += np.radians(1.0)  # J5 has no span: any departure is refused
    assert "J5" in sch.refusal(q)


def test_reach_and_span_survive_the_schedule_file(schedule, tmp_path):
    sch = limited(schedule[0])
    back = Schedule.load(sch.save(tmp_path / "k.npz"))
    assert back.reach == sch.reach and back.span == sch.span


# -- certificate -----------------------------------------------------------------------------------
def test_certificate_passes_for_designs_on_their_own_plants(schedule):
    sch, plants = schedule
    cert = certify(sch, plants, dense=2)
    assert cert.stable and cert.on_grid.sum() == 4 and len(cert.margin) == 9
    assert cert.margin.min() > 0.1  # a loop margin: σ_min(I − K G) away from zero


def test_certificate_fails_where_a_grid_controller_destabilises_its_plant(schedule):
    sch, plants = schedule
    bad = sch.controllers[0]
    flipped = Controller(bad.axes, bad.A, bad.B, -bad.C, -bad.D)  # positive feedback at the mode
    broken = Schedule(sch.axes, sch.joints, sch.grid, (flipped,) + sch.controllers[1:], sch.q_ref, sch.hold)
    assert not is_stable(plants[0], flipped)
    cert = certify(broken, plants, dense=2)
    assert not cert.stable
    assert cert.max_real[np.flatnonzero(cert.on_grid)[0]] > 0


def test_blended_plant_response_is_the_weighted_mean(rm):
    a, b = plant_at(rm, 1.0), plant_at(rm, 1.1)
    freq = np.array([3.0, 6.0, 12.0])
    np.testing.assert_allclose(blend_plants([a, b], [0.3, 0.7]).frf(freq), 0.3 * a.frf(freq) + 0.7 * b.frf(freq))


# -- the schedule file -----------------------------------------------------------------------------
def test_schedule_file_round_trips(schedule, tmp_path):
    sch, _ = schedule
    back = Schedule.load(sch.save(tmp_path / "k.npz"))
    s = np.radians([3.0, 7.0])
    np.testing.assert_allclose(back.weights(s), sch.weights(s))
    np.testing.assert_allclose(back.at(s).frf([5.9]), sch.at(s).frf([5.9]))
    assert back.hold == 4 and back.joints == (1, 2)


def test_a_controller_file_is_not_a_schedule(schedule, tmp_path):
    sch, _ = schedule
    path = sch.controllers[0].save(tmp_path / "one.npz")
    with pytest.raises(InputError, match="not an rmbench schedule"):
        Schedule.load(path)


# -- trajectories ------------------------------------------------------------------------------------
def test_trajectory_csv_names_a_missing_joint_column(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text("t_s,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg\n0,0,0,0,0,90\n1,0,1,0,0,89\n")
    with pytest.raises(InputError, match="q6_deg"):
        load_trajectory(p, 6)


def test_trajectory_times_must_increase():
    with pytest.raises(InputError, match="row 3"):
        Trajectory(np.array([0.0, 1.0, 1.0]), np.zeros((3, 6)))


def test_trajectory_csv_reads_degrees_as_radians(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text("t_s,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n0,0,0,0,0,90,0\n2,0,10,0,0,80,0\n")
    traj = load_trajectory(p, 6)
    np.testing.assert_allclose(traj.at(1.0), np.radians([0, 5, 0, 0, 85, 0]))


# -- the loop on a moving robot ------------------------------------------------------------------------
def test_the_arm_follows_the_trajectory_during_a_closed_loop_run(op, schedule):
    sch, _ = schedule
    q1 = op.q_cmd + np.radians([0, 3, 0, 0, -3, 0])
    traj = linear_move(op.q_cmd, q1, 1.0, hold=0.2)
    rec = run_loop(op, sch, 1.6, record_axes=("tangential",), trajectory=traj)
    # position servos with ~0.1 mrad static sag: at rest after the move the joints sit on the command
    np.testing.assert_allclose(rec.q_arm[-1], q1, atol=2e-3)


def test_a_schedule_of_one_controller_everywhere_runs_as_that_controller(op, default_design):
    k = default_design.controller
    grid = (np.radians([-10.0, 20.0]),)
    sch = Schedule(k.axes, (1,), grid, (k, k), op.q_cmd)
    force = 5.0 * np.sin(2 * np.pi * 5.9 * np.arange(1000) / 2000.0)
    a = run_loop(op, k, 0.5, shaker={"tangential": force}, record_axes=("tangential",))
    b = run_loop(op, sch, 0.5, shaker={"tangential": force}, record_axes=("tangential",))
    # two copies of one controller blended with weights summing to one: the same force, to round-off
    np.testing.assert_allclose(b.force, a.force, rtol=1e-9, atol=1e-9)


def test_a_trajectory_not_starting_at_the_posture_is_input_error(op):
    traj = linear_move(op.q_cmd + 0.1, op.q_cmd, 1.0)
    with pytest.raises(InputError, match="must start"):
        run_loop(op, None, 0.1, trajectory=traj)


def test_a_grid_plant_without_a_mode_in_the_band_is_named(rm):
    high = modal_plant([60.0], [0.03], [[0.1]], [rm], ("tangential",))  # its only mode above 40 Hz
    grid = (np.radians([-10.0, 20.0]),)
    with pytest.raises(InputError, match="grid posture 1: the tangential response shows no resonance"):
        design_schedule([plant_at(rm, 1.0), high], grid, (1,), np.zeros(6))
