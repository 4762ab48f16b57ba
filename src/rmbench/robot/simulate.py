"""Time-domain simulation of a robot about its operating point, in MuJoCo.

The nonlinear model is integrated from the deflected equilibrium with the servo commands that hold
it, under applied generalised forces. Joint stiffness and servo gains are integrated explicitly by
every MuJoCo integrator, so the step must resolve the fastest mode: with RK4, ``ω_max · dt`` must
stay below about 2.8 (:func:`stable_step` picks a step with margin).
"""

from __future__ import annotations

import mujoco
import numpy as np
from mujoco import rollout

__all__ = ["stable_step", "simulate", "site_positions"]


def stable_step(op, *, safety: float = 0.7) -> float:
    """A stable RK4 time step for the operating point's fastest mode, s."""
    w_max = float(np.abs(op.linear.modes().poles).max())
    return safety * 2.8 / w_max


def simulate(op, qfrc: np.ndarray, *, dt: float, ctrl: np.ndarray | None = None) -> np.ndarray:
    """Integrate the robot from equilibrium under applied generalised forces.

    Parameters
    ----------
    op : OperatingPoint
    qfrc : ndarray, shape (n_step, nv)
        Generalised forces held constant over each step (zero-order hold), N and N·m.
    dt : float
        Time step, s (RK4).
    ctrl : ndarray, shape (n_step, nu), optional
        Actuator commands; by default those that hold the equilibrium.

    Returns
    -------
    ndarray, shape (n_step, nq)
        Joint positions at the end of each step.
    """
    model = op.robot.model
    m = mujoco.MjModel.from_xml_string(op.robot.xml)
    m.opt.timestep = dt
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.zeros(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(model, op.data, state0, spec)
    n = len(qfrc)
    u = np.empty((1, n, m.nu + m.nv))
    u[0, :, : m.nu] = op.data.ctrl if ctrl is None else ctrl
    u[0, :, m.nu:] = qfrc
    control_spec = mujoco.mjtState.mjSTATE_CTRL | mujoco.mjtState.mjSTATE_QFRC_APPLIED
    state, _ = rollout.rollout(m, mujoco.MjData(m), state0[None], u, control_spec=control_spec)
    return state[0, :, 1: 1 + m.nq]


def site_positions(op, qpos: np.ndarray, sites) -> np.ndarray:
    """World positions of sites along a trajectory, m, shape (n_step, n_sites, 3)."""
    m = op.robot.model
    d = mujoco.MjData(m)
    ids = [m.site(s).id for s in sites]
    out = np.empty((len(qpos), len(ids), 3))
    for k, q in enumerate(qpos):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        out[k] = d.site_xpos[ids]
    return out
