"""Postures: IK reaches the seed's grid, pinocchio and MuJoCo agree on the kinematics."""

import mujoco
import numpy as np
import pytest

from rmbench.errors import UnreachablePosture
from rmbench.robot import Posture, seed_grid, validation_postures
from rmbench.robot.posture import rz


def _mujoco_tip_pose(robot, q_cmd):
    """Tool-tip pose by MuJoCo's own kinematics with the passive joints at zero (rigid robot)."""
    data = mujoco.MjData(robot.model)
    for name, q in zip(robot.arm_joints, q_cmd):
        data.qpos[robot.model.joint(name).qposadr[0]] = q
    mujoco.mj_kinematics(robot.model, data)
    site = data.site(robot.tcp)
    return site.xpos.copy(), site.xmat.reshape(3, 3).copy()


def test_seed_grid_has_112_postures():
    grid = seed_grid()
    assert len(grid) == 112
    assert len({p.label() for p in grid}) == 112


def test_ik_reaches_grid_and_validation_postures(irb):
    # 1e-6 m / 1e-6 rad: the target; checked with MuJoCo, not with the IK's own model
    for p in seed_grid() + validation_postures():
        sol = irb.ik(p)
        pos, rot = _mujoco_tip_pose(irb, sol.q)
        target = irb.target(p)
        assert np.linalg.norm(pos - target.translation) < 1e-6, p.label()
        rot_err = np.arccos(np.clip((np.trace(rot.T @ target.rotation) - 1) / 2, -1, 1))
        assert rot_err < 1e-6, p.label()


def test_grid_postures_keep_margin_from_limits_and_singularities(irb):
    # 5° from every joint limit; σ_min of the 6x6 Jacobian well away from 0 (singular)
    for p in seed_grid() + validation_postures():
        sol = irb.ik(p)
        assert sol.limit_margin > np.radians(5), p.label()
        assert sol.sigma_min > 0.05, p.label()


def test_tool_axis_points_down_and_theta_turns_about_it(irb):
    p = Posture.from_mm_deg(1500, 100, 40)
    _, rot = _mujoco_tip_pose(irb, irb.ik(p).q)
    np.testing.assert_allclose(rot, rz(np.radians(40)), atol=1e-6)


def test_pinocchio_forward_kinematics_matches_mujoco_sites(irb):
    # both are built from the same MJCF text: agreement to round-off, 1e-9 m
    kin = irb.kinematics
    rng = np.random.default_rng(0)
    data = mujoco.MjData(irb.model)
    import pinocchio as pin
    for _ in range(20):
        q = rng.uniform(-0.5, 0.5, irb.model.nq) * np.where(irb.model.jnt_type == 3, 1.0, 1e-3)
        data.qpos[:] = q
        mujoco.mj_kinematics(irb.model, data)
        qp = kin.from_mujoco(irb.model, q)
        pin.framesForwardKinematics(kin.model, kin.data, qp)
        for site in ("tool_tip", "tool_p1a", "flange_face"):
            fid = kin.model.getFrameId(site, pin.FrameType.OP_FRAME)
            np.testing.assert_allclose(kin.data.oMf[fid].translation, data.site(site).xpos, atol=1e-9)


def test_unreachable_posture_raises_with_the_posture_in_the_message(irb):
    with pytest.raises(UnreachablePosture, match="3500,0,0"):
        irb.ik(Posture.from_mm_deg(3500, 0, 0))
