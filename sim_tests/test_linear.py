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
