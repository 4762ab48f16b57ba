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

__all__ = ["stable_step", "stepping_model", "simulate", "hold_commands", "site_positions", "pulse_check"]


# Stability limits of ω_max·dt on an undamped oscillator: semi-implicit Euler 2, RK4 2.8.
_LIMIT = {"euler": 2.0, "rk4": 2.8}
_INTEGRATOR = {"euler": mujoco.mjtIntegrator.mjINT_EULER, "rk4": mujoco.mjtIntegrator.mjINT_RK4}


def stable_step(op, *, integrator: str = "rk4", safety: float = 0.7) -> float:
    """A stable time step for the operating point's fastest mode, s."""
    w_max = float(np.abs(op.linear.modes().poles).max())
    return safety * _LIMIT[integrator] / w_max


def stepping_model(op, *, dt: float, integrator: str = "rk4") -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The operating point's model set up for time stepping, and its data at the equilibrium.

    A fresh model of ``op.robot``'s MJCF with time step ``dt`` (s), the integrator (``"rk4"`` or
    ``"euler"``) and the constraint solver off (small motions about equilibrium: no contact, no
    joint limit reached); the data hold the equilibrium's full physics state and servo commands.
    """
    m = mujoco.MjModel.from_xml_string(op.robot.xml)
    m.opt.timestep = dt
    m.opt.integrator = _INTEGRATOR[integrator]
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    d = mujoco.MjData(m)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.zeros(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(op.robot.model, op.data, state, spec)
    mujoco.mj_setState(m, d, state, spec)
    d.ctrl[:] = op.data.ctrl
    return m, d


def simulate(op, qfrc: np.ndarray, *, dt: float, ctrl: np.ndarray | None = None,
             integrator: str = "rk4") -> np.ndarray:
    """Integrate the robot from equilibrium under applied generalised forces.

    Parameters
    ----------
    op : OperatingPoint
    qfrc : ndarray, shape (n_step, nv) or (n_batch, n_step, nv)
        Generalised forces held constant over each step (zero-order hold), N and N·m; a batch
        runs several force histories from the same equilibrium in one rollout.
    dt : float
        Time step, s.
    ctrl : ndarray, shape (n_step, nu), optional
        Actuator commands; by default those that hold the equilibrium, with a spinning
        spindle's drive command turning with the rotor (:func:`hold_commands`).
    integrator : {"rk4", "euler"}
        RK4 (4 evaluations a step) or MuJoCo's semi-implicit Euler (1 evaluation, damping
        implicit; stable to ω_max·dt < 2, frequency error (ω·dt)²/24).

    Returns
    -------
    ndarray, shape (n_step, nq) or (n_batch, n_step, nq)
        Joint positions at the end of each step.
    """
    qfrc = np.asarray(qfrc, float)
    single = qfrc.ndim == 2
    if single:
        qfrc = qfrc[None]
    m, d = stepping_model(op, dt=dt, integrator=integrator)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.zeros(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state0, spec)
    nb, n = qfrc.shape[:2]
    u = np.empty((nb, n, m.nu + m.nv))
    u[:, :, : m.nu] = hold_commands(op, n, dt) if ctrl is None else ctrl
    u[:, :, m.nu:] = qfrc
    control_spec = mujoco.mjtState.mjSTATE_CTRL | mujoco.mjtState.mjSTATE_QFRC_APPLIED
    state, _ = rollout.rollout(m, d, np.tile(state0, (nb, 1)), u, control_spec=control_spec)
    q = state[:, :, 1: 1 + m.nq]
    return q[0] if single else q


def hold_commands(op, n_step: int, dt: float) -> np.ndarray:
    """Actuator commands that hold the operating point, shape (n_step, nu).

    The servos' commands of the equilibrium, constant; a spinning spindle's position-servo drive
    (an actuator on the joint ``spindle_spin``) is commanded along the rotor's steady rotation,
    ``u0 + Ω t`` at each step's midpoint, as a spindle drive in speed control holds its speed. A
    constant command would pull the rotor back to its start angle: the drive's torque would then
    grow without bound and shake the arm, which no linearisation about the steady spin describes.
    """
    m, d = op.robot.model, op.data
    u = np.tile(np.asarray(d.ctrl, float), (n_step, 1))
    spin = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "spindle_spin")
    if spin < 0:
        return u
    omega = float(d.qvel[m.jnt_dofadr[spin]])
    if omega == 0.0:
        return u
    t = (np.arange(n_step) + 0.5) * dt
    for a in range(m.nu):
        if m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and m.actuator_trnid[a, 0] == spin:
            u[:, a] += omega * t
    return u


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


def pulse_check(op, band: str, column: int, *, record: float, pulse: float, amplitude: float, tau: float,
                s_1a: float = 0.020, dt: float = 5e-6):
    """The exact receptance checked against MuJoCo's time-domain response to a force pulse.

    A half-sine force pulse (``pulse`` s, ``amplitude`` N) at the coordinate ``column`` of
    (1X, 1Y, 1aX, 1aY) is integrated with RK4 from the deflected equilibrium; the site
    displacements are exponentially windowed, exp(−t/τ), and transformed, which evaluates the
    transfer function at s = 1/τ + iω exactly, so the windowed measurement is compared with the
    exact receptance at the same s at each of the band's modal peaks (ω = ω_n).

    Returns
    -------
    list of (f_n, measured, exact)
        Per mode of the band: Hz, and the column of the receptance matrix, m/N, shape (4,).
    """
    if dt >= stable_step(op):
        raise ValueError(f"dt {dt:g} s is not below the stable step {stable_step(op):g} s")
    n = int(record / dt)
    t = np.arange(n) * dt
    force = np.where(t < pulse, amplitude * np.sin(np.pi * t / pulse), 0.0)
    rows = op.coordinate_map(("1X", "1Y", "1aX", "1aY"), s_1a=s_1a)
    qpos = simulate(op, force[:, None] * rows[column][None, :], dt=dt)
    keep = slice(None, None, 2)
    sites = (op.robot.tcp, "tool_p1a")
    pos = site_positions(op, qpos[keep], sites)
    pos0 = site_positions(op, op.data.qpos[None], sites)[0]
    disp = (pos - pos0)[:, :, :2].reshape(len(pos), 4)  # 1X, 1Y, 1aX, 1aY
    t_out = t[keep] + dt  # positions are at the end of each step
    sigma = 1 / tau
    result = []
    for f_n in op.modes(band, s_1a=s_1a).f_n:
        s = sigma + 2j * np.pi * f_n
        f_s = dt * np.sum(force * np.exp(-s * (t + dt / 2)))  # zero-order-held force
        y_s = 2 * dt * np.exp(-s * t_out) @ disp
        exact = op.linear.modes().transfer(np.array([s]), rows, rows)[0][:, column]
        result.append((float(f_n), y_s / f_s, exact))
    return result
