"""The tracker simulator's robot: batch kinematics, compliance, repeatability, calibration."""

import math
from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest

from rmbench.errors import RmbenchError
from rmbench.tracker import (ErrorDistribution, FrameRefit, GeometricCalibration, SerialChain,
                             TrackerSimulator, TrackerSpec, iso9283_rp, kabsch, sobol_points)
from rmbench.tracker.campaign import MH180_JOINT_BOX
from rmbench.tracker.simulator import nominal_stiffness

QUIET = ErrorDistribution(gear_amplitude=(0.0, 0.0), payload=(0.0, 0.0), mass_sd=0.0,
                          stiffness_sd=0.0)


@pytest.fixture(scope="module")
def chain(mh180):
    return SerialChain.from_kinematics(mh180.kinematics, mh180.arm_joints)


@pytest.fixture(scope="module")
def configs():
    return np.random.default_rng(4).uniform(MH180_JOINT_BOX[0], MH180_JOINT_BOX[1], (12, 6))


def test_batch_forward_kinematics_matches_pinocchio(mh180, chain, configs):
    expected = np.array([mh180.kinematics.fk(q).translation for q in configs])
    assert np.max(np.abs(chain.position(configs) - expected)) < 1e-12  # same transforms, m


def test_position_jacobian_matches_finite_differences(chain, configs):
    q, h = configs[0], 1e-6
    numeric = np.stack([(chain.position(q + h * e) - chain.position(q - h * e)) / (2 * h)
                        for e in np.eye(6)], axis=1)
    assert np.max(np.abs(chain.jacobian(q) - numeric)) < 1e-8  # O(h²) error on ~2 m levers


def test_placement_jacobian_matches_finite_differences_of_perturbed_chains(chain, configs):
    analytic = chain.walk(configs[:3]).placement_jacobian()
    h, cols = 1e-7, []
    for k in range(42):
        tw = np.zeros((7, 6))
        tw.flat[k] = h
        plus = chain.perturbed(tw).position(configs[:3])
        tw.flat[k] = -h
        cols.append((plus - chain.perturbed(tw).position(configs[:3])) / (2 * h))
    assert np.max(np.abs(analytic - np.stack(cols, axis=-1))) < 1e-7


def test_gravity_torque_matches_pinocchio_generalized_gravity(mh180, chain, configs):
    model = mh180.kinematics.model
    keep = [model.getJointId(j) for j in mh180.arm_joints]
    red = pin.buildReducedModel(model, [i for i in range(1, model.njoints) if i not in keep],
                                pin.neutral(model))
    data = red.createData()
    expected = -np.array([pin.computeGeneralizedGravity(red, data, q) for q in configs])
    assert np.max(np.abs(chain.gravity_torque(configs) - expected)) < 1e-9  # N·m of ~3000


def test_compliance_deflection_matches_mujoco_deflected_equilibrium(mh180):
    import mujoco

    sim = TrackerSimulator.from_robot(mh180, np.random.default_rng(0),
                                      distribution=ErrorDistribution(0, 0, 0, 0, 0, 0, (0, 0),
                                                                     (0.0, 0.0)))
    site = mujoco.mj_name2id(mh180.model, mujoco.mjtObj.mjOBJ_SITE, mh180.tcp)
    for q in (np.array([0, 0, 0, 0, math.pi / 2, 0]), np.array([0.3, 0.4, -0.2, 0.5, 1.0, 0.3])):
        deflected = sim.nominal.position(sim.link_angles(q))
        # deflections are 1-3 mm; two fixed-point steps of τ/k agree with MuJoCo's equilibrium
        assert np.linalg.norm(deflected - mh180.settle(q).site_xpos[site]) < 1e-6


def test_iso9283_rp_of_isotropic_scatter_has_the_closed_form():
    # l = ||x|| is σ·chi(3): mean 2 sqrt(2/π) σ, variance (3 − 8/π) σ²
    expected = 2 * math.sqrt(2 / math.pi) + 3 * math.sqrt(3 - 8 / math.pi)
    assert iso9283_rp(np.eye(3) * 1e-8) == pytest.approx(1e-4 * expected, rel=1e-9)


def test_simulated_repeatability_at_the_reference_posture_is_the_rated_0_2_mm(mh180):
    sim = TrackerSimulator.from_robot(mh180, np.random.default_rng(1))
    q = np.tile([0, 0, 0, 0, math.pi / 2, 0], (40000, 1))
    v = np.random.default_rng(2).normal(size=q.shape) * sim.joint_sigma
    p = sim.true_chain.position(sim.link_angles(q, v))
    dist = np.linalg.norm(p - p.mean(axis=0), axis=1)
    # ISO 9283 RP = l̄ + 3 S_l; 40 000 cycles estimate it to about 0.5 % (sampling)
    assert dist.mean() + 3 * dist.std() == pytest.approx(0.2e-3, rel=0.02)


def test_tracker_noise_takes_5_um_per_m_and_12_5_um_as_two_sigma():
    spec = TrackerSpec()
    assert spec.sigma(4.0) == pytest.approx(math.hypot(2.5e-6 * 4.0, 6.25e-6))


def test_hidden_errors_are_reproducible_for_a_seed(mh180):
    a = TrackerSimulator.from_robot(mh180, np.random.default_rng(7))
    b = TrackerSimulator.from_robot(mh180, np.random.default_rng(7))
    assert np.array_equal(a.hidden.twists, b.hidden.twists)
    assert np.array_equal(a.hidden.gear_phase, b.hidden.gear_phase)


def test_calibration_recovers_planted_geometric_errors_of_a_rigid_robot(mh180):
    sim = TrackerSimulator.from_robot(mh180, np.random.default_rng(5), distribution=QUIET)
    rigid = replace(sim, hidden=replace(sim.hidden, stiffness=np.full(6, np.inf)))
    q = sobol_points(120, *MH180_JOINT_BOX, np.random.default_rng(6))
    cal = GeometricCalibration(rigid.nominal).fit(q[:80], rigid.true_position(q[:80]))
    # new configurations: errors of 0.5 mm and 0.05° recovered to the solver's precision
    assert np.max(np.linalg.norm(cal.predict(q[80:]) - rigid.true_position(q[80:]), axis=1)) < 1e-9


def test_calibration_with_nominal_compliance_recovers_a_compliant_robot_to_microns(mh180):
    sim = TrackerSimulator.from_robot(mh180, np.random.default_rng(5), distribution=QUIET)
    q = sobol_points(120, *MH180_JOINT_BOX, np.random.default_rng(6))
    cal = GeometricCalibration(sim.nominal, nominal_stiffness(mh180)).fit(q[:80],
                                                                         sim.true_position(q[:80]))
    # geometry the tracker cannot tell apart (a shift along a joint axis) still moves link
    # centres of mass: ~0.5 mm on 100 kg links changes wrist torques by ~1 N·m, i.e. a few µm
    assert np.max(np.linalg.norm(cal.predict(q[80:]) - sim.true_position(q[80:]), axis=1)) < 1e-5


def test_position_only_calibration_identifies_27_geometric_and_5_compliance_parameters(mh180):
    sim = TrackerSimulator.from_robot(mh180, np.random.default_rng(5), distribution=QUIET)
    q = sobol_points(80, *MH180_JOINT_BOX, np.random.default_rng(6))
    y = sim.true_position(q)
    geometric = GeometricCalibration(sim.nominal, nominal_stiffness(mh180),
                                     identify_compliance=False).fit(q, y)
    elastic = GeometricCalibration(sim.nominal, nominal_stiffness(mh180)).fit(q, y)
    # 4 per revolute joint + 6 base − 3 unobservable tool rotations = 27; J1 feels no gravity
    assert len(geometric.identifiable_) == 27 and len(elastic.identifiable_) == 32


def test_unfitted_calibration_refuses_to_predict(chain):
    with pytest.raises(RmbenchError, match="not fitted yet"):
        GeometricCalibration(chain).predict(np.zeros(6))


def test_kabsch_recovers_a_rigid_transform():
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(10, 3))
    rot, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    rot *= np.sign(np.linalg.det(rot))
    r, t = kabsch(pts, pts @ rot.T + [1.0, -2.0, 0.5])
    assert np.allclose(r, rot, atol=1e-12) and np.allclose(t, [1.0, -2.0, 0.5], atol=1e-12)


def test_frame_refit_removes_small_base_and_tool_errors(chain, configs):
    p, r = chain.pose(configs)
    planted = np.array([1e-4, -2e-4, 5e-5, 2e-5, -1e-5, 3e-5, 3e-4, -1e-4, 2e-4])
    errors = FrameRefit(p, r)._design @ planted
    left = FrameRefit(p, r)(np.arange(len(p)), errors)
    assert np.max(np.abs(left)) < 1e-15


def test_a_soft_robot_is_softer_in_every_joint_within_the_bounds_asked(mh180):
    from rmbench.tracker.simulator import soft_robot_simulator

    sim = soft_robot_simulator(mh180, np.random.default_rng(0), softer=(0.6, 0.7))
    ratio = sim.hidden.stiffness / nominal_stiffness(mh180)
    assert np.all((ratio >= 0.6) & (ratio <= 0.7))


def test_a_soft_robots_geometry_is_exact_but_for_the_reflector_offset(mh180):
    from rmbench.tracker.simulator import soft_robot_simulator

    sim = soft_robot_simulator(mh180, np.random.default_rng(0), reflector=(1e-3, 0.0, -2e-3))
    expected = np.zeros_like(sim.hidden.twists)
    expected[-1, :3] = [1e-3, 0.0, -2e-3]
    np.testing.assert_array_equal(sim.hidden.twists, expected)
    assert np.all(sim.hidden.offsets == 0.0) and sim.hidden.payload_mass == 0.0
