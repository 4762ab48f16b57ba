"""Rigid-body kinematics with pinocchio, built from the same MJCF text as the MuJoCo model.

Inverse kinematics drives the actuated (motor-side) joints only; every passive joint (gearbox
flexibility, bearings, tool) is at zero, i.e. the robot as its controller believes it to be. The
robot then settles under gravity (:mod:`rmbench.robot.linear`).
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from rmbench.errors import UnreachablePosture

__all__ = ["Kinematics", "IKSolution"]


@dataclass(frozen=True)
class IKSolution:
    """Joint commands reaching a pose.

    Attributes
    ----------
    q : ndarray, shape (n_act,), rad
        Actuated joint angles.
    position_error : float
        Residual position error of the target frame, m.
    rotation_error : float
        Residual rotation error, rad.
    limit_margin : float
        Smallest distance of a joint to its limit, rad.
    sigma_min : float
        Smallest singular value of the 6 x n_act Jacobian (position rows in m/rad), a measure of
        the distance to a singularity.
    """

    q: np.ndarray
    position_error: float
    rotation_error: float
    limit_margin: float
    sigma_min: float


class Kinematics:
    """Forward and inverse kinematics of the actuated chain of a robot.

    Parameters
    ----------
    xml : str
        MJCF text of the assembled robot (the same text MuJoCo compiles).
    actuated : sequence of str
        Names of the actuated joints, in command order.
    limits : ndarray, shape (n_act, 2), rad
    frame : str
        Site whose pose is the posture's target (tool tip).
    """

    def __init__(self, xml: str, actuated, limits: np.ndarray, frame: str):
        fd, path = tempfile.mkstemp(suffix=".xml")
        try:
            with os.fdopen(fd, "w") as f:
                f.write(xml)
            self.model = pin.buildModelFromMJCF(path)
        finally:
            os.unlink(path)
        self.data = self.model.createData()
        self.frame = frame
        self.frame_id = self.model.getFrameId(frame, pin.FrameType.OP_FRAME)
        if self.frame_id >= len(self.model.frames):
            raise UnreachablePosture(f"no frame {frame!r} in the kinematic model")
        idx = [self.model.getJointId(n) for n in actuated]
        self.idx_q = np.array([self.model.joints[i].idx_q for i in idx])
        self.idx_v = np.array([self.model.joints[i].idx_v for i in idx])
        self.limits = np.asarray(limits, float)

    def full_q(self, q_act: np.ndarray) -> np.ndarray:
        """pinocchio configuration with the actuated joints at ``q_act``, all others at zero."""
        q = pin.neutral(self.model)
        q[self.idx_q] = q_act
        return q

    def from_mujoco(self, model, qpos: np.ndarray) -> np.ndarray:
        """pinocchio configuration of a MuJoCo ``qpos`` of the same MJCF (every joint, passive included).

        pinocchio's MJCF reader merges a body's several joints (a spindle's bearing freedoms) into one
        ``Composite_<first>`` joint, whose coordinates are those joints in the body's order.
        """
        import mujoco

        q = pin.neutral(self.model)
        for j in range(1, self.model.njoints):
            joint, name = self.model.joints[j], self.model.names[j]
            body = model.joint(name.removeprefix("Composite_")).bodyid[0]
            names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, k) for k in range(model.njnt)
                     if model.jnt_bodyid[k] == body]
            for k, n in enumerate(names if joint.shortname() == "JointModelComposite" else [name]):
                q[joint.idx_q + k] = qpos[model.joint(n).qposadr[0]]
        return q

    def fk(self, q_act: np.ndarray) -> pin.SE3:
        """Pose of the target frame in the base frame."""
        pin.framesForwardKinematics(self.model, self.data, self.full_q(q_act))
        return self.data.oMf[self.frame_id].copy()

    def jacobian(self, q_act: np.ndarray) -> np.ndarray:
        """Frame Jacobian in the local frame, shape (6, n_act)."""
        q = self.full_q(q_act)
        j = pin.computeFrameJacobian(self.model, self.data, q, self.frame_id, pin.LOCAL)
        return j[:, self.idx_v]

    def solve(self, target: pin.SE3, seeds, *, tol: float = 1e-10, max_iter: int = 100) -> IKSolution:
        """Inverse kinematics: the converged solution within limits closest to the first seed.

        Raises
        ------
        UnreachablePosture
            If no seed converges to a solution inside the joint limits.
        """
        seeds = [np.asarray(s, float) for s in seeds]
        best = None
        for seed in seeds:
            q = self._newton(target, seed.copy(), tol, max_iter)
            if q is None:
                continue
            margin = float(np.min(np.minimum(q - self.limits[:, 0], self.limits[:, 1] - q)))
            if margin < 0:
                continue
            dist = float(np.linalg.norm(q - seeds[0]))
            if best is None or dist < best[0] - 1e-9:
                best = (dist, q, margin)
        if best is None:
            raise UnreachablePosture("no inverse-kinematics solution within the joint limits")
        q, margin = best[1], best[2]
        err = pin.log6(self.fk(q).actInv(target)).vector
        sigma = np.linalg.svd(self.jacobian(q), compute_uv=False)
        return IKSolution(q=q, position_error=float(np.linalg.norm(err[:3])),
                          rotation_error=float(np.linalg.norm(err[3:])), limit_margin=margin,
                          sigma_min=float(sigma[-1]))

    def _newton(self, target, q, tol, max_iter):
        for _ in range(max_iter):
            delta = self.fk(q).actInv(target)   # one forward kinematics for the error and its Jacobian
            err = pin.log6(delta).vector
            if np.linalg.norm(err) < tol:
                # wrap into (-π, π] where that stays within limits, for a canonical branch
                return q
            j = self.jacobian(q) @ np.eye(len(q))
            jl = pin.Jlog6(delta)
            jj = jl @ j
            # the minimum-norm Gauss-Newton step: on a redundant arm (Panda) it has no component
            # along the self-motion. Solving the damped normal equations instead moved the arm along
            # it by roundoff / damping (~1e-6 rad a solve), which differed between BLAS kernels.
            step = np.linalg.lstsq(jj, err, rcond=None)[0]
            q = q + np.clip(step, -0.3, 0.3)
        return None
