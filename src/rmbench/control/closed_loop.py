"""The controller running closed loop against the simulated robot, in MuJoCo.

Per controller sample (``Hardware.fs``, default 2 kHz) the loop reads the accelerometer (site
``acc``; AC-coupled: the static reading at equilibrium is removed, then projected on each axis's
slide direction; white noise and a constant bias added) and the encoders (``pm_<axis>`` slides,
quantised), steps the discretised controller (Tustin), and after ``delay_samples`` samples sends
the force to the voice coils through an amplifier (first-order lag, ``amp_bandwidth``) with the
coil's force limit (the MJCF ``ctrlrange``, static gravity share included). The robot is the full
nonlinear MuJoCo model at the operating point's equilibrium, integrated by semi-implicit Euler at
``fs × substeps`` (the MH180 stand-in's fastest mode, 133 Hz, is resolved with ω·dt ≈ 0.4 at
2 kHz). MuJoCo's constraints are off (no contacts, no joint limits: they would cost half the
speed); the stages' end stops are stiff damped springs beyond ±stroke instead, applied here, so a
run that asks for more travel than the stage has hits them, with the acceleration spikes that
brings (``end_stop`` in the record: the fraction of samples at a stop). With
``Hardware.anti_windup`` the controller's state follows the force the limit let through
(:mod:`rmbench.control.antiwindup`), not the command it asked for.

Disturbances: the disturbance voice coils ``shaker_<axis>`` (a force history per sample, N; ``d``
on the robot is minus the coil force), and the spindle turning its eccentric mass at a constant
speed (position servo ``spindle`` tracking ``2π f t``).

The robot may move: with a :class:`~rmbench.control.trajectory.Trajectory` the arm's position
servos follow it (commands interpolated per sample). A :class:`~rmbench.control.schedule.Schedule`
runs all its controllers on the same measurements and blends their outputs with the weights of the
arm's measured joint angles (the motor-side encoders), every sample.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import mujoco
import numpy as np

from rmbench.control.antiwindup import observer_gain
from rmbench.control.controller import Controller
from rmbench.control.plant import AXES, axis_directions
from rmbench.control.schedule import Schedule
from rmbench.control.trajectory import Trajectory
from rmbench.errors import InputError, RmbenchError
from rmbench.robot.simulate import stepping_model
from rmbench.plotting import axes_or_new

__all__ = ["Hardware", "LoopRecord", "LoopDiverged", "run_loop", "eccentric_force_amplitude"]

BLEND_HZ = 200.0
"""Rate at which a schedule's blend weights follow the encoders, Hz: the posture moves over seconds,
and a weight step of 5 ms of motion is far below the loop's resolution."""


class LoopDiverged(RmbenchError):
    """The closed loop went unstable (the controller does not stabilise the robot here)."""


@dataclass(frozen=True)
class Hardware:
    """Sampling, sensors and actuators of the suppressor's real-time loop.

    Attributes
    ----------
    fs : float
        Controller sample rate, Hz.
    substeps : int
        Physics steps per controller sample.
    acc_noise : float
        Accelerometer white noise, m/s² rms per sample.
    acc_bias : float
        Accelerometer bias, m/s² (every axis).
    encoder_resolution : float
        Encoder quantum, m.
    delay_samples : int
        Samples between a measurement and the force it produces.
    amp_bandwidth : float
        Amplifier (current loop) bandwidth, Hz.
    end_stop_stiffness, end_stop_damping : float
        The stages' end stops beyond ±stroke, N/m and N·s/m (92 Hz and ζ 0.3 against a 3 kg
        mass: stiff, yet resolved by the 0.5 ms step).
    guard : bool
        The stroke guard: a reaction mass beyond ``guard_trip`` of its stroke fades the controller
        out over ``guard_fade`` s and resets its state; once every mass has stayed within
        ``guard_rearm`` of its stroke for ``guard_rest`` s the controller fades back in. Without
        it a loop driven into the end stops can stay in a limit cycle banging them (a 1 s burst of
        60 N at the mode did that to the default design), where the uncontrolled robot decays.
    guard_trip, guard_rearm : float
        Fractions of the stroke.
    guard_rest, guard_fade : float
        Seconds.
    force_limit : float or None
        The amplifier's current limit as a coil force, N, on the dynamic part (the static gravity
        share rides on top); None: the coil's own range (the MJCF ``ctrlrange``) alone.
    anti_windup : bool
        Observer-form anti-windup (:func:`rmbench.control.antiwindup.observer_gain`): each
        controller's state is corrected by ``L (u_sat − u)``, ``u_sat`` the force the coil's range
        and ``force_limit`` let through (the stroke guard's fade is a deliberate gain, not a limit:
        the correction is taken per unit of that gain, and the guard's reset covers a full fade).
        Off by default: the loop is then exactly the plain controller.
    """

    fs: float = 2000.0
    substeps: int = 1
    acc_noise: float = 2e-3
    acc_bias: float = 5e-3
    encoder_resolution: float = 1e-6
    delay_samples: int = 1
    amp_bandwidth: float = 1000.0
    end_stop_stiffness: float = 1e6
    end_stop_damping: float = 1e3
    guard: bool = True
    guard_trip: float = 0.9
    guard_rearm: float = 0.3
    guard_rest: float = 0.5
    guard_fade: float = 0.05
    force_limit: float | None = None
    anti_windup: bool = False

    def __post_init__(self):
        if not (self.fs > 0 and self.substeps >= 1 and self.delay_samples >= 0 and self.amp_bandwidth > 0
                and self.acc_noise >= 0 and self.encoder_resolution >= 0
                and 0 < self.guard_rearm < self.guard_trip and self.guard_rest >= 0 and self.guard_fade > 0
                and (self.force_limit is None or self.force_limit > 0)):
            raise InputError(f"invalid hardware settings: {self}")


@dataclass(frozen=True)
class LoopRecord:
    """What one closed-loop run recorded, one row per controller sample.

    Attributes
    ----------
    t : ndarray, shape (n,), s
    axes : tuple of str
        Axes the accelerations are recorded along.
    acc : ndarray, shape (n, n_axes), m/s²
        True acceleration at the accelerometer along each axis (no sensor noise).
    pos : ndarray, shape (n, n_ctrl_axes), m
        Reaction-mass positions of the controlled axes.
    force : ndarray, shape (n, n_ctrl_axes), N
        Voice-coil forces applied (dynamic part, static gravity share removed).
    saturated : float
        Fraction of samples at the force limit.
    stroke_used : float
        Largest |position| / stroke over the run (just above 1 at an end stop).
    end_stop : float
        Fraction of samples with a reaction mass against an end stop.
    wall_s : float
    q_arm : ndarray, shape (n, n_arm), rad, or None
        The arm's motor-side joint angles, recorded when the robot follows a trajectory.
    guard_trips : int
        Times the stroke guard took the controller out (:class:`Hardware`).
    guard_off : float
        Fraction of samples with the controller faded (partly or wholly) out by the guard.
    saturation_events : int
        Times the command went into the force limit (runs of saturated samples).
    """

    t: np.ndarray
    axes: tuple[str, ...]
    acc: np.ndarray
    pos: np.ndarray
    force: np.ndarray
    saturated: float
    stroke_used: float
    end_stop: float
    wall_s: float
    q_arm: np.ndarray | None = None
    guard_trips: int = 0
    guard_off: float = 0.0
    saturation_events: int = 0

    @property
    def stroke_exceeded(self) -> bool:
        """Whether a reaction mass hit an end stop."""
        return self.end_stop > 0

    @property
    def realtime_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return float(self.t[-1] + self.t[1] - self.t[0]) / self.wall_s if self.wall_s > 0 else np.inf

    @property
    def duration(self) -> float:
        """Simulated time, s."""
        return float(self.t[-1] + self.t[1] - self.t[0])

    def to_dict(self) -> dict:
        """The run's figures as strict JSON values (the traces left out): duration (s), rms and
        peak acceleration per recorded axis (m/s²), peak force (N), stroke used, end-stop and
        saturated fractions, saturation events, stroke-guard trips and faded fraction, real-time
        factor (None if unmeasured)."""
        from rmbench.io.strict_json import jsonable

        return jsonable({"duration_s": self.duration, "samples": len(self.t), "axes": list(self.axes),
                         "acc_rms": {a: float(np.sqrt(np.mean(self.acc[:, i] ** 2))) for i, a in enumerate(self.axes)},
                         "acc_peak": {a: float(np.abs(self.acc[:, i]).max()) for i, a in enumerate(self.axes)},
                         "force_max": float(np.abs(self.force).max(initial=0.0)),
                         "stroke_used": self.stroke_used, "end_stop": self.end_stop, "saturated": self.saturated,
                         "saturation_events": self.saturation_events,
                         "guard_trips": self.guard_trips, "guard_off": self.guard_off,
                         "realtime_factor": self.realtime_factor})

    def summary(self) -> str:
        """Duration, rms acceleration per axis (m/s²), and the suppressor's use: peak force (N),
        stroke (% of ±stroke), end-stop and saturated samples (%) and saturation events, guard trips;
        real-time factor."""
        d = self.to_dict()
        acc = ", ".join(f"{a} {v:.4g}" for a, v in d["acc_rms"].items())
        return "\n".join([
            f"{d['duration_s']:.3g} s closed loop ({d['samples']} samples); acceleration rms {acc} m/s²",
            f"peak force {d['force_max']:.1f} N, stroke used {100 * self.stroke_used:.0f} % of ±stroke, "
            f"at an end stop {100 * self.end_stop:.1f} % and saturated {100 * self.saturated:.1f} % of samples "
            f"({self.saturation_events} saturation event(s)), "
            f"stroke guard tripped {self.guard_trips} time(s); {self.realtime_factor:.1f}x real time"])

    def plot(self, ax=None):
        """The recorded accelerations over time, one line per axis (m/s² against s).

        Drawn on ``ax`` or a new figure's Axes (:func:`rmbench.plotting.axes_or_new`), which it
        returns.
        """
        ax = axes_or_new(ax, (7, 3))
        for i, a in enumerate(self.axes):
            ax.plot(self.t, self.acc[:, i], lw=0.8, label=a)
        ax.set_xlabel("time, s")
        ax.set_ylabel("acceleration, m/s²")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
        return ax


def eccentric_force_amplitude(model: mujoco.MjModel, f_spin: float) -> float:
    """Rotating force of the spindle's eccentric mass at ``f_spin`` Hz, N: ``m e (2π f)²``."""
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "eccentric")
    if bid < 0:
        raise InputError("the robot has no spindle eccentric mass (body 'eccentric')")
    me = model.body_mass[bid] * np.linalg.norm(model.body_pos[bid])
    return float(me * (2 * np.pi * f_spin) ** 2)


def _actuator(m, name: str) -> int:
    i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, name)
    if i < 0:
        raise InputError(f"the robot has no actuator {name!r}")
    return i


def _joint(m, name: str) -> int:
    j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
    if j < 0:
        raise InputError(f"the robot has no joint {name!r}")
    return j


def _accelerometer(m, d, op, axes) -> tuple[int, np.ndarray, np.ndarray]:
    """The accelerometer ``acc``: its sensordata address, the rows E (len(axes), 3) taking its
    site-frame reading onto the world ``axes``, and E times its static reading (subtracted, so
    the loop sees the vibration alone)."""
    sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, "acc")
    if sid < 0:
        raise InputError("the robot has no accelerometer sensor 'acc'")
    adr = m.sensor_adr[sid]
    mujoco.mj_forward(m, d)
    rot = d.site_xmat[m.sensor_objid[sid]].reshape(3, 3).copy()
    E = axis_directions(op, axes) @ rot if axes else np.zeros((0, 3))
    return adr, E, E @ d.sensordata[adr:adr + 3].copy()


def _shaker_forces(m, shaker: dict | None, n: int, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Actuator indices of the shaker coils and their forces per controller sample, (n, n_coil), N."""
    idx, forces = [], []
    for a, f in (shaker or {}).items():
        idx.append(_actuator(m, f"shaker_{a}"))
        sig = np.asarray(f(np.arange(n) / fs) if callable(f) else f, float)
        if sig.shape != (n,):
            raise InputError(f"shaker force for {a!r} must have {n} samples, got shape {sig.shape}")
        forces.append(sig)
    return np.array(idx, int), (np.array(forces).T if forces else np.zeros((n, 0)))


class _Coils:
    """The controlled axes' voice coils behind their amplifier (a first-order lag) and their stages'
    end stops (stiff damped springs beyond ±stroke, applied as joint forces)."""

    def __init__(self, m, d, axes, hw: Hardware, ctrl0: np.ndarray):
        self.d, self.hw = d, hw
        self.vc = np.array([_actuator(m, f"vc_{a}") for a in axes], int)
        joints = [_joint(m, f"pm_{a}") for a in axes]
        self.pm_adr = np.array([m.jnt_qposadr[j] for j in joints], int)
        self.pm_dof = np.array([m.jnt_dofadr[j] for j in joints], int)
        stroke = np.array([max(abs(m.jnt_range[j])) for j in joints])
        self.stroke = np.where(stroke > 0, stroke, np.inf)        # m; inf where the joint has no range
        self.base = ctrl0[self.vc]                                # the static (gravity) share, N
        self.lo, self.hi = m.actuator_ctrlrange[self.vc, 0], m.actuator_ctrlrange[self.vc, 1]
        if hw.force_limit is not None:
            self.lo = np.maximum(self.lo, self.base - hw.force_limit)
            self.hi = np.minimum(self.hi, self.base + hw.force_limit)
        self.alpha = 1.0 - np.exp(-2 * np.pi * hw.amp_bandwidth / (hw.fs * hw.substeps))
        self.f_app = np.zeros(len(axes))                          # dynamic force applied, N
        self.at_stop = False

    def target(self, u: np.ndarray) -> tuple[np.ndarray, bool]:
        """The amplifier's target for the commanded dynamic forces ``u`` (N) within the coils'
        range, and whether the range clipped it."""
        total = self.base + u
        clipped = np.minimum(np.maximum(total, self.lo), self.hi)
        return clipped - self.base, bool((clipped != total).any())

    def substep(self, target: np.ndarray) -> None:
        """One physics step's coil forces and end-stop forces (before ``mj_step``)."""
        d, hw = self.d, self.hw
        self.f_app += self.alpha * (target - self.f_app)
        d.ctrl[self.vc] = self.base + self.f_app
        p = d.qpos[self.pm_adr]
        over = np.abs(p) - self.stroke
        if self.at_stop or (over > 0).any():
            hit = over > 0
            self.at_stop = bool(hit.any())
            d.qfrc_applied[self.pm_dof] = np.where(hit, -hw.end_stop_stiffness * np.sign(p) * over
                                                   - hw.end_stop_damping * d.qvel[self.pm_dof], 0.0)


class _Guard:
    """The stroke guard's state over a run (:class:`Hardware`): the gain it puts on the
    controller's output, and its trips and faded samples."""

    def __init__(self, hw: Hardware):
        self.hw = hw
        self.gain, self.engaged, self.calm, self.trips, self.off = 1.0, True, 0, 0, 0
        self.d_gain = 1.0 / max(hw.guard_fade * hw.fs, 1.0)
        self.n_rest = int(round(hw.guard_rest * hw.fs))

    def step(self, used: float) -> bool:
        """Advance one sample at stroke use ``used`` (largest |position| / stroke); True when the
        controller is wholly faded out and its state is to be reset (it re-engages from rest, not
        from the state the stops left)."""
        hw = self.hw
        if self.engaged and used > hw.guard_trip:
            self.engaged, self.trips = False, self.trips + 1
        reset = False
        if self.engaged:
            self.gain = min(1.0, self.gain + self.d_gain)
        else:
            self.gain = max(0.0, self.gain - self.d_gain)
            self.calm = self.calm + 1 if used < hw.guard_rearm else 0
            if self.gain == 0.0:
                reset = True
                if self.calm >= self.n_rest:
                    self.engaged, self.calm = True, 0
        self.off += self.gain < 1.0
        return reset


class _Controllers:
    """The controllers (one, or a schedule's) stepped side by side at ``fs`` on the same measurements,
    their outputs blended by the schedule's weights of the measured joint angles."""

    def __init__(self, controller: Controller | Schedule, fs: float, arm_adr: np.ndarray, anti_windup: bool):
        self.k_ax = len(controller.axes)
        parts = controller.controllers if isinstance(controller, Schedule) else (controller,)
        disc = [c.discretize(fs) for c in parts]
        # [u_1 … u_N; x+] = step_mat @ [x; y]
        self.step_mat, self.n_k, self.n_parts = _stacked_step(disc, self.k_ax)
        # every part is corrected by the blended command's excess, so an unsaturated loop is untouched
        self.aw = np.vstack([observer_gain(*d) for d in disc]) if anti_windup else None
        self.z = np.zeros(self.n_k + 2 * self.k_ax)
        self.blend = np.ones(1)
        self.schedule = controller if isinstance(controller, Schedule) else None
        if self.schedule is not None:
            self.sched_adr = arm_adr[list(controller.joints)]
            self.blend_every = max(1, int(round(fs / BLEND_HZ)))

    def step(self, k: int, acc: np.ndarray, pos: np.ndarray, qpos: np.ndarray) -> np.ndarray:
        """Sample ``k``: take the measured accelerations and positions (k_ax each), advance the
        state and return the blended forces before the guard's gain, N."""
        n_k, k_ax, z = self.n_k, self.k_ax, self.z
        z[n_k:n_k + k_ax] = acc
        z[n_k + k_ax:] = pos
        out = self.step_mat @ z
        if self.schedule is not None and k % self.blend_every == 0:
            self.blend = self.schedule.weights(qpos[self.sched_adr])
        z[:n_k] = out[self.n_parts * k_ax:]
        return self.blend @ out[:self.n_parts * k_ax].reshape(self.n_parts, k_ax)

    def reset(self) -> None:
        self.z[:self.n_k] = 0.0

    def unwind(self, excess: np.ndarray) -> None:
        """Anti-windup: correct the state just advanced by ``L (u_sat − u)``, ``excess`` (k_ax,) N."""
        self.z[:self.n_k] += self.aw @ excess


def _spindle(m, d, spindle_hz: float | None):
    """A function setting the spindle servo's command to turn at ``spindle_hz`` rev/s (its joint
    set spinning at that speed), or None where the spindle is held still."""
    if spindle_hz is None:
        return None
    act, j = _actuator(m, "spindle"), _joint(m, "spindle")
    w = 2 * np.pi * float(spindle_hz)
    d.qvel[m.jnt_dofadr[j]] = w
    q0 = d.qpos[m.jnt_qposadr[j]]

    def command(ctrl, time_s):
        ctrl[act] = q0 + w * time_s
    return command


def _commands(trajectory: Trajectory | None, op, n_arm: int, n: int, fs: float) -> np.ndarray | None:
    """The arm's joint commands per controller sample, (n, n_arm) rad, checked against the robot."""
    if trajectory is None:
        return None
    if trajectory.q.shape[1] != n_arm:
        raise InputError(f"the trajectory has {trajectory.q.shape[1]} joints, the robot's arm {n_arm}")
    if not np.allclose(trajectory.q[0], op.q_cmd, atol=1e-6):
        raise InputError("the trajectory must start at the operating point's posture (its first row)")
    return trajectory.at(np.arange(n) / fs)


class _Rig:
    """A run's MuJoCo model at ``op``'s equilibrium and everything wired to it: accelerometer, coils,
    shaker and spindle, arm servos and their commands, controllers and stroke guard."""

    def __init__(self, op, controller, n: int, hw: Hardware, shaker, spindle_hz, record_axes, trajectory):
        self.n, self.hw, self.record_axes = n, hw, record_axes
        self.m, self.d = m, d = stepping_model(op, dt=1.0 / (hw.fs * hw.substeps), integrator="euler")
        d.time = 0.0
        ctrl0 = op.data.ctrl.copy()
        ctrl_axes = controller.axes if controller is not None else ()
        for a in record_axes + ctrl_axes:
            if a not in AXES:
                raise InputError(f"unknown axis {a!r}; use {', '.join(AXES)}")
        self.k_ax, self.n_rec = len(ctrl_axes), len(record_axes)
        # the order matters: the accelerometer's static reading is taken before the spindle turns
        self.adr, self.E_all, self.c0 = _accelerometer(m, d, op, record_axes + ctrl_axes)
        self.coils = _Coils(m, d, ctrl_axes, hw, ctrl0)
        self.shake_idx, self.shake_f = _shaker_forces(m, shaker, n, hw.fs)
        self.shake_base = ctrl0[self.shake_idx]
        self.spin = _spindle(m, d, spindle_hz)
        self.arm_act, self.arm_adr = _arm(m, op.robot.arm_joints)
        self.q_cmd_t = _commands(trajectory, op, len(self.arm_act), n, hw.fs)
        self.loop = _Controllers(controller, hw.fs, self.arm_adr, hw.anti_windup) if controller is not None else None
        self.guard = _Guard(hw) if hw.guard and self.loop is not None else None

    def command(self, k: int, y_acc: np.ndarray, p: np.ndarray, u_hist: np.ndarray) -> tuple[np.ndarray, bool]:
        """Sample ``k``'s controller step on the measured accelerations ``y_acc`` (noise included)
        and true positions ``p``: store its force ``delay_samples`` ahead in ``u_hist`` and return
        the amplifier's target for this sample and whether the coils' range clipped it."""
        loop, guard, res = self.loop, self.guard, self.hw.encoder_resolution
        inv_res = 1.0 / res if res > 0 else 0.0
        u = loop.step(k, y_acc, np.rint(p * inv_res) * res if res > 0 else p, self.d.qpos)
        gain = 1.0
        if guard is not None:
            if guard.step(float(np.max(np.abs(p) / self.coils.stroke))):
                loop.reset()
            gain = guard.gain
        v = u_hist[k + self.hw.delay_samples] = gain * u
        if loop.aw is not None and gain > 0:
            # the limit is static, so the force this command will get is known now, delay or not
            loop.unwind((self.coils.target(v)[0] - v) / gain)
        return self.coils.target(u_hist[k])


def run_loop(op, controller: Controller | Schedule | None, duration: float, *, hardware: Hardware | None = None,
             shaker: dict | None = None, spindle_hz: float | None = None, record_axes=("tangential", "axial"),
             seed: int = 0, trajectory: Trajectory | None = None) -> LoopRecord:
    """Run the robot for ``duration`` s with the controller in the loop (None: uncontrolled).

    Parameters
    ----------
    op : OperatingPoint
        The robot (with a suppressor) at its equilibrium.
    controller : Controller, Schedule or None
        Continuous-time controller (or a posture schedule of them), discretised here at ``hardware.fs``.
    duration : float
        Simulated time, s.
    shaker : dict, optional
        ``{axis: force}``: the disturbance coil force per controller sample (array of length
        ``duration·fs``) or a function of time (s → N).
    spindle_hz : float, optional
        Spindle speed, rev/s, turning the eccentric mass (None: spindle held still).
    record_axes : sequence of str
        Axes along which the acceleration is recorded.
    seed : int
        Seed of the sensor noise.
    trajectory : Trajectory, optional
        Arm joint commands over time (from ``op``'s posture: its first row must be ``op.q_cmd``);
        without it the arm holds ``op``'s posture.

    Raises
    ------
    InputError
        A schedule that does not cover the posture or a row of the trajectory
        (:meth:`~rmbench.control.schedule.Schedule.check`).
    """
    hw = hardware if hardware is not None else Hardware()
    n = int(round(duration * hw.fs))
    if n < 2:
        raise InputError(f"duration {duration!r} s is shorter than two controller samples")
    if isinstance(controller, Schedule):
        # refused before it runs: past its reach or span the schedule's designs say nothing
        controller.check(op.q_cmd if trajectory is None else trajectory.q)
    rig = _Rig(op, controller, n, hw, shaker, spindle_hz, tuple(record_axes), trajectory)
    noise = np.random.default_rng(seed).normal(0.0, hw.acc_noise, (n, rig.k_ax)) + hw.acc_bias
    t0 = time.perf_counter()
    acc_all, pos, force, q_arm, sat, events, stops = _simulate(rig, noise)
    if not np.isfinite(acc_all).all():
        raise LoopDiverged("the closed loop diverged")
    wall = time.perf_counter() - t0
    used = float(np.max(np.abs(pos) / rig.coils.stroke)) if rig.k_ax else 0.0
    guard = rig.guard
    return LoopRecord(np.arange(n) / hw.fs, rig.record_axes, acc_all[:, :rig.n_rec], pos, force, sat / n, used,
                      stops / n, wall, q_arm, guard.trips if guard else 0, guard.off / n if guard else 0.0, events)


def _simulate(rig: _Rig, noise: np.ndarray):
    """The sample loop: accelerations (n, n_rec + k_ax) m/s², positions and forces (n, k_ax) m and N,
    arm angles (n, n_arm) rad or None, the count of saturated samples, of saturation events (runs of
    them) and of end-stop samples."""
    m, d, hw, n, coils, loop = rig.m, rig.d, rig.hw, rig.n, rig.coils, rig.loop
    k_ax, n_rec, adr, E_all, c0, pm_adr = rig.k_ax, rig.n_rec, rig.adr, rig.E_all, rig.c0, coils.pm_adr
    shake_idx, shake_f, shake_base, spin = rig.shake_idx, rig.shake_f, rig.shake_base, rig.spin
    u_hist = np.zeros((n + hw.delay_samples, k_ax))  # u_hist[k + delay] computed at sample k
    acc_all = np.empty((n, n_rec + k_ax))
    pos = np.empty((n, k_ax))
    force = np.empty((n, k_ax))
    q_arm = np.empty((n, len(rig.arm_adr))) if rig.q_cmd_t is not None else None
    sens, qpos, ctrl = d.sensordata, d.qpos, d.ctrl
    sat = events = stops = 0
    clipped = False
    for k in range(n):
        a = E_all @ sens[adr:adr + 3] - c0
        acc_all[k] = a
        p = qpos[pm_adr]
        pos[k] = p
        if q_arm is not None:
            ctrl[rig.arm_act] = rig.q_cmd_t[k]
            q_arm[k] = qpos[rig.arm_adr]
        if loop is not None:
            was = clipped
            target, clipped = rig.command(k, a[n_rec:] + noise[k], p, u_hist)
            sat += clipped
            events += clipped and not was
        for _ in range(hw.substeps):
            if loop is not None:
                coils.substep(target)
            if len(shake_idx):
                ctrl[shake_idx] = shake_base + shake_f[k]
            if spin is not None:
                spin(ctrl, d.time)
            mujoco.mj_step(m, d)
        force[k] = coils.f_app
        stops += coils.at_stop
        if k % 256 == 0 and (not np.isfinite(d.qacc).all() or (k_ax and np.abs(qpos[pm_adr]).max() > 1.0)):
            raise LoopDiverged(f"the closed loop diverged at t = {k / hw.fs:.3f} s")
    return acc_all, pos, force, q_arm, sat, events, stops


def _stacked_step(disc, k_ax: int) -> tuple[np.ndarray, int, int]:
    """One step matrix for controllers running side by side on the same measurements:
    ``[u_1; …; u_N; x+] = M @ [x; y]`` from the discrete forms ``(Ad, Bd, Cd, Dd)`` of each, and the
    total state count."""
    n_k = sum(d[0].shape[0] for d in disc)
    N = len(disc)
    M = np.zeros((N * k_ax + n_k, n_k + 2 * k_ax))
    r = 0
    for i, (Ad, Bd, Cd, Dd) in enumerate(disc):
        k = Ad.shape[0]
        M[i * k_ax:(i + 1) * k_ax, r:r + k] = Cd
        M[i * k_ax:(i + 1) * k_ax, n_k:] = Dd
        M[N * k_ax + r:N * k_ax + r + k, r:r + k] = Ad
        M[N * k_ax + r:N * k_ax + r + k, n_k:] = Bd
        r += k
    return M, n_k, N


def _arm(m, joints) -> tuple[np.ndarray, np.ndarray]:
    """The arm's position-servo actuators (in the order of ``joints``) and their joints' qpos addresses."""
    ids = [_joint(m, j) for j in joints]
    act = []
    for j, jid in zip(joints, ids):
        hits = [a for a in range(m.nu) if m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT
                and m.actuator_trnid[a, 0] == jid]
        if not hits:
            raise InputError(f"the robot has no servo on arm joint {j!r}")
        act.append(hits[0])
    return np.array(act, int), np.array([m.jnt_qposadr[j] for j in ids], int)
