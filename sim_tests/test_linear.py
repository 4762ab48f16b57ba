"""Exact linear ground truth: equilibrium, modes with left/right eigenvectors, FRF, reciprocity."""

import numpy as np
import pytest

from rmbench.robot import COORDS, Posture, Robot
from rmbench.robot.simulate import simulate


def test_equilibrium_is_held_by_the_servos(irb_op):
    # at the deflected equilibrium with the holding commands nothing moves: after 2000 RK4 steps
    # the state drifts by round-off only (1e-12 rad), far below any measurable vibration
    q = simulate(irb_op, np.zeros((2000, irb_op.robot.model.nv)), dt=5e-6)
    assert np.abs(q - irb_op.data.qpos).max() < 1e-12


def test_gravity_deflects_the_flexible_joints(irb_op):
    # the arm sags under its own weight: J2 and J3 gearbox deflections of order 0.1-1 mrad
    j2 = irb_op.data.qpos[irb_op.robot.model.joint("j2_flex").qposadr[0]]
    assert 1e-5 < abs(j2) < 1e-2


def test_stiffness_is_symmetric_without_spin(irb_op):
    # springs, servo gains and gravity's geometric stiffness are conservative at equilibrium;
    # central differences leave ~1e-10 relative asymmetry
    k = irb_op.linear.K
    assert np.abs(k - k.T).max() < 1e-8 * np.abs(k).max()


def test_left_and_right_eigenvectors_are_biorthogonal(irb_op):
    lin = irb_op.linear
    n = lin.n_dof
    z = np.zeros((n, n))
    a = np.block([[lin.C, lin.M], [lin.M, z]])
    b = np.block([[lin.K, z], [z, -lin.M]])
    modes = lin.modes()
    lam = np.concatenate([modes.poles, modes.poles.conj()])
    # rebuild full state eigenvectors from the displacement partitions: ψ = [φ; λφ]
    psi_r = np.vstack([np.hstack([modes.phi_r, modes.phi_r.conj()]),
                       np.hstack([modes.phi_r, modes.phi_r.conj()]) * lam])
    psi_l = np.vstack([np.hstack([modes.phi_l, modes.phi_l.conj()]),
                       np.hstack([modes.phi_l, modes.phi_l.conj()]) * lam])
    ga = psi_l.T @ a @ psi_r
    gb = psi_l.T @ b @ psi_r
    scale = np.abs(np.diag(gb)).max()
    np.testing.assert_allclose(ga, np.eye(2 * n), atol=1e-8)
    np.testing.assert_allclose(gb / scale, -np.diag(lam) / scale, atol=1e-8)


def test_modal_superposition_equals_direct_solution(irb_op):
    freq = np.linspace(1, 2000, 700)
    t = irb_op.coordinate_map(COORDS)
    modal = irb_op.linear.modes().frf(freq, t, t)
    direct = irb_op.linear.frf(freq, t, t)
    assert np.abs(modal - direct).max() < 1e-7 * np.abs(direct).max()


def test_frf_matrix_is_reciprocal_with_the_spindle_at_rest(irb_op):
    freq = np.linspace(4, 1400, 3000)
    h = irb_op.frf(freq)
    asym = np.abs(h - h.transpose(0, 2, 1)).max() / np.abs(h).max()
    assert asym < 1e-8


def test_spinning_spindle_makes_the_frf_matrix_non_reciprocal():
    # gyroscopic coupling of a rotor at 15 000 rpm: |H - Hᵀ| of per-cent order at the spindle modes
    robot = Robot.load("irb6660", tool="dummy", spindle_rpm=15000)
    op = robot.at(Posture.from_mm_deg(1800, -200, 0))
    freq = np.linspace(700, 1100, 2000)
    h = op.frf(freq)
    asym = np.abs(h - h.transpose(0, 2, 1)).max() / np.abs(h).max()
    assert asym > 1e-3


def test_spinning_spindle_is_a_steady_state(irb):
    # the rotor keeps its speed and the structure stays at equilibrium while it turns
    robot = Robot.load("irb6660", tool="dummy", spindle_rpm=12000)
    op = robot.at(Posture.from_mm_deg(1500, 100, 0))
    dt = 5e-6
    n = 2000
    spin = robot.model.joint("spindle_spin")
    ctrl = np.tile(op.data.ctrl, (n, 1))
    a = robot.model.actuator("a_spin").id
    omega = 12000 * 2 * np.pi / 60
    ctrl[:, a] += omega * dt * (np.arange(n) + 0.5)  # set point at mid-step: the drive follows the rotor
    q = simulate(op, np.zeros((n, robot.model.nv)), dt=dt, ctrl=ctrl)
    flex = [robot.model.joint(f"j{i}_flex").qposadr[0] for i in range(1, 7)]
    # the drive's set point is constant over each step: its ripple (kp ω dt / 2 at most) shakes the
    # wrist by nanoradians, against a millirad gravity sag
    assert np.abs(q[:, flex] - op.data.qpos[flex]).max() < 1e-8
    turned = q[-1, spin.qposadr[0]] - op.data.qpos[spin.qposadr[0]]
    assert turned == pytest.approx(omega * n * dt, rel=1e-3)


def _relative_first_order_error(irb_op, scale, seed=0):
    """How far the first-order modes of a random change of size ``scale`` lie from the exact modes
    of the changed matrices, against how far the exact ones moved: poles and residues φR φLᵀ."""
    from rmbench.robot.linear import complex_modes, perturbed_modes

    lin = irb_op.linear
    rng = np.random.default_rng(seed)
    dm = scale * np.diag(rng.uniform(-1, 1, lin.n_dof)) * np.abs(np.diag(lin.M))
    dk = scale * rng.uniform(-1, 1, lin.K.shape) * np.abs(np.diag(lin.K))[:, None] * np.eye(lin.n_dof)
    dc = scale * np.diag(rng.uniform(-1, 1, lin.n_dof)) * np.abs(np.diag(lin.C))
    base, exact = lin.modes(), complex_modes(lin.M + dm, lin.C + dc, lin.K + dk)
    first = perturbed_modes(base, dm, dc, dk)
    low = base.f_n < 2000           # the modes a test sees; the tool's X and Y pairs above coincide

    def residue(m):
        return np.einsum("im,jm->mij", m.phi_r[:, low], m.phi_l[:, low])

    pole = np.abs(first.poles - exact.poles)[low].max() / np.abs(exact.poles - base.poles)[low].max()
    res = np.abs(residue(first) - residue(exact)).max() / np.abs(residue(exact) - residue(base)).max()
    return pole, res


def test_first_order_modes_err_by_the_square_of_the_change(irb_op):
    # analytic eigen-sensitivities (Fox-Kapoor, Nelson): the first-order modes miss the exact ones by
    # O(change²), so their error relative to the change itself falls tenfold for a tenfold smaller change
    big = _relative_first_order_error(irb_op, 1e-3)
    small = _relative_first_order_error(irb_op, 1e-4)
    assert small[0] < 0.2 * big[0] and small[1] < 0.2 * big[1]
    assert small[0] < 1e-2 and small[1] < 1e-2


def test_first_order_modes_of_many_changes_are_each_change_alone(irb_op):
    from rmbench.robot.linear import perturbed_modes, perturbed_modes_many

    lin = irb_op.linear
    rng = np.random.default_rng(1)
    d = [1e-4 * rng.normal(size=(3, lin.n_dof, lin.n_dof)) * np.abs(np.diag(x)) for x in (lin.M, lin.C, lin.K)]
    many = perturbed_modes_many(lin.modes(), *d)
    for i, m in enumerate(many):
        one = perturbed_modes(lin.modes(), d[0][i], d[1][i], d[2][i])
        np.testing.assert_allclose(m.poles, one.poles, rtol=1e-12)


def _heavier_forearm(irb):
    """The operating point at (1800, -200, 0) mm and a copy of its model with a forearm 10 % heavier."""
    import copy

    import mujoco

    op = irb.at(Posture.from_mm_deg(1800, -200, 0))
    model = copy.copy(op.robot.model)
    b = model.body("forearm").id
    model.body_mass[b] *= 1.1
    model.body_inertia[b] *= 1.1
    mujoco.mj_setConst(model, mujoco.MjData(model))
    return op, model


def test_chord_settling_from_a_nearby_equilibrium_reaches_the_same_state(irb):
    # a heavier forearm settled from the nominal's equilibrium on the nominal's stiffness (chord
    # steps) lands where Newton from the undeflected commands lands, to the settling tolerance
    import mujoco

    from rmbench.robot.linear import equilibrium

    op, model = _heavier_forearm(irb)
    held = np.unique(model.jnt_dofadr[model.actuator_trnid[:, 0]])     # the servo-held joints
    fresh, chord = mujoco.MjData(model), mujoco.MjData(model)
    fresh.qpos[:] = op.data.qpos
    for j in range(model.njnt):              # the passive joints undeflected, the arm as commanded
        if model.jnt_dofadr[j] not in held:
            fresh.qpos[model.jnt_qposadr[j]] = 0.0
    equilibrium(model, fresh, held)
    chord.qpos[:] = op.data.qpos
    equilibrium(model, chord, held, stiffness=op.linear.K)
    # 1e-10 of the largest joint stiffness in N·m is the settling tolerance: the states agree to
    # far below a micro-radian
    assert np.abs(chord.qpos - fresh.qpos).max() < 1e-9


def test_forward_differences_give_a_mass_step_s_stiffness_change_as_central_ones_do(irb):
    # the calibration's mass columns difference two forward-difference stiffnesses at one state:
    # each errs by the difference step (10⁻⁶ rad) times K's slope, nearly the same in both, so
    # their difference must match the central differences' to 10⁻⁴ of the change itself (the
    # gravity stiffness a 10 % heavier forearm adds, about 40 N·m/rad beside entries of 3·10⁸)
    import mujoco

    from rmbench.robot.linear import linearize

    op, heavy = _heavier_forearm(irb)

    def k_of(model, differences):
        data = mujoco.MjData(model)
        data.qpos[:] = op.data.qpos
        data.ctrl[:] = op.data.ctrl
        return linearize(model, data, op.linear.C, differences=differences).K

    central = k_of(heavy, "central") - k_of(op.robot.model, "central")
    forward = k_of(heavy, "forward") - k_of(op.robot.model, "forward")
    assert np.abs(central).max() > 10.0
    assert np.abs(forward - central).max() < 1e-4 * np.abs(central).max()


def test_linearize_refuses_an_unknown_difference_scheme(irb_op):
    import mujoco

    from rmbench.robot.linear import linearize

    data = mujoco.MjData(irb_op.robot.model)
    with pytest.raises(ValueError, match="central"):
        linearize(irb_op.robot.model, data, differences="backward")


def test_the_nearest_mode_is_the_one_whose_natural_frequency_is_closest():
    from rmbench.robot import ComplexModes

    f = np.array([10.0, 25.0, 60.0])
    zeta = np.array([0.01, 0.02, 0.03])
    poles = 2 * np.pi * f * (-zeta + 1j * np.sqrt(1 - zeta ** 2))
    modes = ComplexModes(poles, np.eye(3, dtype=complex), np.eye(3, dtype=complex), np.zeros(3, bool))
    assert [modes.nearest(x) for x in (0.0, 17.0, 18.0, 1e4)] == [0, 0, 1, 2]
