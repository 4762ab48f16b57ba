"""Virtual milling in MuJoCo: regenerative cutting forces on the simulated robot, chatter detected.

The robot (with its tool, at a posture's deflected equilibrium) is integrated by MuJoCo (RK4, the
stable step of its fastest mode) while the cutter turns kinematically at the spindle speed. At
every step each tooth in the cut removes the chip

    h_j = f_z sin φ_j + (x(t) − x(t − T)) sin φ_j + (y(t) − y(t − T)) cos φ_j   (≥ 0: a tooth
    whose chip vanishes leaves the cut)

with x, y the tool tip's displacement in the feed and normal directions and the delayed values
interpolated from the run's own history; the forces F_t = K_t a_p h, F_n = K_n a_p h act at the tool
tip (as generalised forces through the tip's Jacobian at the equilibrium). The immersion, and with
it which side of the feed the material lies on, is the cut's (:attr:`Cutting.angles
<rmbench.stability.cutting.Cutting.angles>`: climb or conventional by ``Cutting.down``). The run
starts from the static deflection under the mean cutting force with a small velocity kick, so that
what follows is the regenerative dynamics rather than the robot's slow settling.

The feed runs along a heading ψ in the base XY plane (rad, from base X toward base Y; 0, the
default, along base X): the tip's base displacement since the previous tooth is turned into the
cut's (feed, normal) frame by R(ψ) before the chip is taken, and the cutting force turned back by
R(ψ)ᵀ (:func:`rmbench.stability.frame.feed_rotation`, the frame the stability model's
:func:`~rmbench.stability.frame.to_cut_frame` uses). At ψ = 0 the rotation is the identity and the
arithmetic exact: the run is bit for bit the one before headings. The starting kick is along the
feed and the normal; the tip's history, and the chatter metrics read from it, stay in base X and Y.
A moving cut's heading may follow the path (:class:`Motion`'s ``heading``, per knot).

The robot may also move through the cut (:class:`Motion`): its servos then follow commands
interpolated between the deflected equilibria of operating points along a path, with the velocity
feed-forward a position servo needs to follow without lag, and the tool tip's vibration is measured
from the moving equilibrium, less what the arm does when it runs the same motion with no cut (an
open-loop rollout): the chatter verdict is about the cut, not about how the motion was
interpolated. A slow drift (the static deflection under the cutting force changes with the
posture) is removed by a quadratic trend before the chatter metrics, so that it is not read as
non-periodic motion.

Chatter (Honeycutt & Schmitz 2016): the tip displacement sampled once per tooth period repeats in
stable cutting and wanders in chatter. ``metric`` is the mean distance between consecutive samples
over the last third of the run divided by the tip's vibration amplitude there; ``growth`` the ratio
of that mean distance between the last and the middle thirds (> 1: the non-periodic motion grows).
Sampling every second tooth period tells a period-doubling (flip) chatter, whose 2T samples repeat,
from a quasi-periodic (Hopf) one. ``off_harmonic`` is the share of the tip's vibration energy off
the tooth-passing harmonics (the spectrum criterion).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import mujoco
import numpy as np

from rmbench.errors import InputError
from rmbench.stability.cutting import Cutting
from rmbench.stability.forces import tooth_force

__all__ = ["MillingRun", "Motion", "mill", "chatter_metrics", "mill_grid"]


@dataclass(frozen=True)
class MillingRun:
    """One virtual cut.

    Attributes
    ----------
    rpm, depth : float
        Spindle speed (rev/min) and axial depth (m).
    chatter : bool
    kind : str
        ``"stable"``, ``"hopf"``, ``"flip"`` or ``"runaway"`` (the vibration grew past the run's
        limit or made the integration fail: chatter).
    metric, growth, off_harmonic : float
        See the module notes.
    amplitude : float
        Peak-to-peak tip vibration over the last third, m.
    """

    rpm: float
    depth: float
    chatter: bool
    kind: str
    metric: float
    growth: float
    off_harmonic: float
    amplitude: float

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> MillingRun:
        """A run back from :meth:`to_dict` or its strict JSON, where a non-finite value is null:
        ``metric`` and ``growth`` null read back as inf (a runaway's), another float as NaN."""
        unbounded = {"metric", "growth"}
        return cls(**{k: (np.inf if k in unbounded else np.nan) if v is None else v for k, v in d.items()})


@dataclass(frozen=True)
class Motion:
    """The robot moving through a cut: what its servos hold, against time.

    The cut runs from time 0; knots may start before it (the cut then begins between two of
    them). Between knots the equilibria and the servo commands follow a cubic spline in time
    (continuous acceleration, as a machine's interpolator gives): a monotone cubic (PCHIP) steps
    the acceleration at every knot, which at a 5 mm knot spacing and 3 m/min shook the arm's
    10 Hz modes by 20-60 µm at the tip and read as chatter. The tip rows are interpolated
    linearly. After the last knot the robot holds it.

    Attributes
    ----------
    t : ndarray, shape (m,)
        Knot times, s, strictly increasing, the first at or before 0.
    qpos : ndarray, shape (m, nq)
        The deflected static equilibrium at each knot (rad, m). Hinge and slide joints only
        (nq = nv), as every rmbench robot.
    ctrl : ndarray, shape (m, nu)
        The servo commands that hold it (the actuators' units: rad for a position servo).
    rows : ndarray, shape (m, 2, nv)
        The tool tip's X and Y per generalised coordinate there, m per unit
        (``OperatingPoint.coordinate_map``).
    heading : ndarray, shape (m,), rad, optional
        The feed direction at each knot in the base XY plane (``ToolPath.heading`` of the path's
        locations), interpolated linearly in time (unwrapped, so that a heading near ±π does not
        swing round the circle) and held after the last knot. None: the cut's one heading
        (:func:`mill`'s ``heading``).
    """

    t: np.ndarray
    qpos: np.ndarray
    ctrl: np.ndarray
    rows: np.ndarray
    heading: np.ndarray | None = None

    def __post_init__(self):
        if len(self.t) < 2 or self.t[0] > 0 or self.t[-1] <= 0 or np.any(np.diff(self.t) <= 0):
            raise InputError("a motion needs at least two knots at strictly increasing times, the first at "
                             "or before 0 s and the last after it")
        if not (len(self.qpos) == len(self.ctrl) == len(self.rows) == len(self.t)):
            raise InputError("a motion needs one equilibrium, command and tip map per knot")
        if self.heading is not None and (np.shape(self.heading) != np.shape(self.t)
                                         or not np.all(np.isfinite(self.heading))):
            raise InputError("a motion's feed headings need one finite value (rad) per knot")

    @classmethod
    def through(cls, ops, times, heading=None) -> Motion:
        """The motion through operating points ``ops`` of one robot reached at ``times`` (s), the
        feed along ``heading`` (rad, one per operating point; None: the cut's one heading)."""
        return cls(np.asarray(times, float), np.array([op.data.qpos for op in ops]),
                   np.array([op.data.ctrl for op in ops]),
                   np.array([op.coordinate_map(("1X", "1Y")) for op in ops]),
                   None if heading is None else np.asarray(heading, float))

    def headings(self, times: np.ndarray) -> np.ndarray | None:
        """The feed heading at ``times`` (s), rad, shape (n,); None where the motion carries none."""
        if self.heading is None:
            return None
        return np.interp(np.asarray(times, float), self.t, np.unwrap(self.heading))

    def sample(self, model: mujoco.MjModel, times: np.ndarray):
        """Equilibrium ``qpos`` and its velocity, servo commands and tip rows at ``times`` (s).

        The commands of joint actuators carry the velocity feed-forward ``−b₂ v / g`` (bias and
        gain of the actuator, ``v`` its joint's speed along the motion; zero for an actuator
        without velocity bias): without it a position servo's damping would hold the arm back and
        start the cut with a jerk. After the last knot the motion stops at once (the velocity
        steps to zero): a motion should outlast the cut.
        """
        from scipy.interpolate import CubicSpline

        tt = np.minimum(np.asarray(times, float), self.t[-1])
        path = CubicSpline(self.t, self.qpos, axis=0)
        qpos = path(tt)
        qvel = np.where((np.asarray(times) < self.t[-1])[:, None], path.derivative()(tt), 0.0)
        ctrl = CubicSpline(self.t, self.ctrl, axis=0)(tt)
        for a in range(model.nu):
            if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT:
                dof = model.jnt_dofadr[model.actuator_trnid[a, 0]]
                gear = model.actuator_gear[a, 0]
                ctrl[:, a] -= model.actuator_biasprm[a, 2] * gear * qvel[:, dof] / model.actuator_gainprm[a, 0]
        seg = np.clip(np.searchsorted(self.t, tt, side="right") - 1, 0, len(self.t) - 2)
        w = ((tt - self.t[seg]) / (self.t[seg + 1] - self.t[seg]))[:, None]
        rows = self.rows[seg] * (1 - w[..., None]) + self.rows[seg + 1] * w[..., None]
        return qpos, qvel, ctrl, rows


def chatter_metrics(q: np.ndarray, dt: float, period: float) -> dict:
    """Once-per-period metrics of a tip displacement history ``q`` (n_step, 2) sampled every ``dt``."""
    t = np.arange(len(q)) * dt
    n_per = int(t[-1] // period)
    if n_per < 12:
        raise InputError("a chatter verdict needs at least 12 tooth periods")
    ts = np.arange(1, n_per + 1) * period
    s = np.column_stack([np.interp(ts, t, q[:, k]) for k in range(q.shape[1])])
    steps = np.linalg.norm(np.diff(s, axis=0), axis=1)
    third = len(steps) // 3
    late, mid = steps[-third:].mean(), steps[-2 * third:-third].mean()
    tail = q[t >= ts[-third]]
    amp = float(np.max(np.ptp(tail, axis=0)))
    steps2 = np.linalg.norm(s[2:] - s[:-2], axis=1)[-third:].mean()
    # spectrum of the last third: energy off the tooth-passing harmonics (± 2 bins)
    x = tail - tail.mean(axis=0)
    spec = np.sum(np.abs(np.fft.rfft(x * np.hanning(len(x))[:, None], axis=0)) ** 2, axis=1)
    f = np.fft.rfftfreq(len(x), dt)
    df = f[1]
    harm = np.abs(f / (1 / period) - np.round(f / (1 / period))) * (1 / period) <= 2.5 * df
    return {"metric": float(late / amp) if amp > 0 else 0.0, "growth": float(late / mid) if mid > 0 else 0.0,
            "flip_ratio": float(steps2 / late) if late > 0 else 1.0,
            "off_harmonic": float(spec[~harm].sum() / spec.sum()) if spec.sum() > 0 else 0.0,
            "amplitude": amp}


def mill(op, cutting: Cutting, rpm: float, depth: float, *, feed_per_tooth: float = 0.05e-3,
         periods: int = 90, dt: float | None = None, kick: float = 1e-3, runaway: float = 5e-3,
         motion: Motion | None = None, heading: float = 0.0) -> MillingRun:
    """Mill at one speed and depth and judge chatter.

    Parameters
    ----------
    op : OperatingPoint
        The robot with its tool at a posture (``Robot.at``).
    cutting : Cutting
    rpm : float
        Spindle speed, rev/min (> 0).
    depth : float
        Axial depth of cut, m (> 0).
    feed_per_tooth : float
        f_z, m.
    periods : int
        Tooth periods simulated (≥ 12).
    dt : float, optional
        Step, s (default: the stable RK4 step of the fastest mode).
    kick : float
        Initial tip velocity, m/s, that seeds any chatter.
    runaway : float
        Tip displacement, m, beyond which the run stops as ``"runaway"`` chatter (a real tool would
        break or be stopped; the small-motion cutting model no longer holds).
    motion : Motion, optional
        The robot moving through the cut (from time 0), ``op`` the operating point nearest its
        start (whose model, stiffness and fastest mode set the run up). Default: held at ``op``.
    heading : float
        The feed direction in the base XY plane, rad, from base X toward base Y (module notes); 0,
        the default, feeds along base X. A ``motion`` that carries headings feeds along those
        instead (``heading`` must then stay 0).
    """
    from rmbench.robot.simulate import stable_step, stepping_model

    if not (np.isfinite(rpm) and rpm > 0):
        raise InputError(f"spindle speed must be positive, got {rpm} rev/min")
    if not (np.isfinite(depth) and depth > 0):
        raise InputError(f"depth of cut must be positive, got {depth} m")
    dt = stable_step(op) if dt is None else float(dt)
    period = 60.0 / (cutting.teeth * rpm)
    force = tooth_force(cutting, depth, feed_per_tooth)
    m, d = stepping_model(op, dt=dt)
    n = int(np.ceil(periods * period / dt))
    # the state after each step is read against the equilibrium at that step's time
    sampled = None if motion is None else motion.sample(m, np.arange(n + 1) * dt)
    turn = _turns(heading, motion, n, dt)
    held, q0 = _start(op, m, d, force, cutting.teeth, sampled, kick, turn[0])
    q, ran_away = _cut(m, d, force, held, sampled, q0, n, dt, rpm, period, runaway, turn)
    if ran_away:
        return MillingRun(float(rpm), float(depth), True, "runaway", np.inf, np.inf, 1.0,
                          float(np.max(np.ptp(q, axis=0))))
    if motion is not None:
        q = _less_motion(q, m, op, sampled, dt)
    return _verdict(rpm, depth, q, dt, period)


def _turns(heading: float, motion: Motion | None, n: int, dt: float) -> list:
    """The feed heading's (cos ψ, sin ψ) at each of the ``n`` steps, a list of float pairs: the
    motion's headings at the step times where it carries them, else ``heading`` (rad) throughout."""
    if not np.isfinite(heading):
        raise InputError(f"the feed heading must be finite (rad), got {heading}")
    per_step = None if motion is None else motion.headings(np.arange(n) * dt)
    if per_step is None:
        return [(float(np.cos(heading)), float(np.sin(heading)))] * max(n, 1)
    if heading != 0:
        raise InputError("give the feed heading once: in the motion (per knot) or as the cut's heading")
    return list(zip(np.cos(per_step).tolist(), np.sin(per_step).tolist()))


def _start(op, m: mujoco.MjModel, d: mujoco.MjData, force, teeth: int, sampled, kick: float, turn: tuple):
    """Set ``d`` at the static deflection under the mean cutting force (no regeneration yet), on
    the equilibrium at the cut's start, with the tip kicked by ``kick`` m/s along the feed and the
    normal (the cut's frame, ``turn`` its heading's (cos ψ, sin ψ): base X and Y at ψ = 0).

    Returns the held equilibrium ``(qpos, rows)`` (``op``'s; the motion's first knot where
    ``sampled``) and the tip's static deflection, shape (2,), m: the surface the first tooth
    period's delayed position reads."""
    rows = op.coordinate_map(("1X", "1Y"))                 # (2, nv): tip X, Y per generalised coordinate
    ph = np.linspace(0, 2 * np.pi / teeth, 64, endpoint=False)
    c, s = turn
    fx, fy = np.mean([force(p, np.zeros(2)) for p in ph], axis=0)
    dq_static = np.linalg.solve(op.linear.K, rows.T @ np.array([fx * c - fy * s, fx * s + fy * c]))
    if sampled is None:
        q_eq, v_eq, ctrl0 = op.data.qpos.copy(), np.zeros(m.nv), op.data.ctrl
    else:
        q_eq, v_eq, ctrl0, rows = (a[0] for a in sampled)
    d.qpos[:] = q_eq + dq_static
    d.qvel[:] = v_eq + np.linalg.pinv(rows) @ np.array([kick * c - kick * s, kick * s + kick * c])
    d.ctrl[:] = ctrl0
    return (q_eq, rows), rows @ dq_static


def _cut(m: mujoco.MjModel, d: mujoco.MjData, force, held, sampled, q0: np.ndarray, n: int, dt: float,
         rpm: float, period: float, runaway: float, turn: list) -> tuple[np.ndarray, bool]:
    """Step the cut ``n`` times, the regenerative force applied at the tip through its rows
    (``held``'s equilibrium and rows, or the motion's ``sampled`` ones at each step), the chip
    taken in the cut's frame: ``turn[i]`` is the feed heading's (cos ψ, sin ψ) at step ``i``.

    Returns the tip's X, Y against the equilibrium before each step, shape (n, 2), m, and whether
    the vibration ran away (then the history up to the step where it did)."""
    q_eq, rows = held
    omega = 2 * np.pi * rpm / 60
    lag = period / dt
    q = np.empty((n, 2))
    # the history again as Python floats for the delayed reads (the same arithmetic per component,
    # without an array operation's overhead at every step); MjData's arrays and warning counters
    # are live views, bound once
    hist, q0 = [], (float(q0[0]), float(q0[1]))
    qpos, ctrl, qfrc = d.qpos, d.ctrl, d.qfrc_applied
    bad_qacc, step, isfinite = d.warning[mujoco.mjtWarning.mjWARN_BADQACC], mujoco.mj_step, np.isfinite
    for i in range(n):
        if sampled is not None:
            q_eq, rows = sampled[0][i], sampled[3][i]
            ctrl[:] = sampled[2][i]
        qi = rows @ (qpos - q_eq)
        q[i] = qi
        x, y = qi.tolist()
        hist.append((x, y))
        px, py = _delayed(hist, i, lag, q0)
        # base to cut frame, R(ψ) (x − px, y − py); the force back, R(ψ)ᵀ f: exact at ψ = 0
        c, s = turn[i]
        dx, dy = x - px, y - py
        fx, fy = force(omega * i * dt, (c * dx + s * dy, c * dy - s * dx))
        qfrc[:] = rows.T @ np.array([fx * c - fy * s, fx * s + fy * c])
        step(m, d)
        # a bad acceleration or a non-finite state: the vibration ran away (MuJoCo would reset the
        # state), chatter beyond the model's validity that only the tool leaving the cut limited
        if bad_qacc.number or not isfinite(qpos).all() or abs(x) > runaway or abs(y) > runaway:
            return q[:i + 1], True
    return q, False


def _delayed(hist: list, i: int, lag: float, q0: tuple) -> tuple:
    """The tip's (x, y), m, one tooth period (``lag`` steps) before step ``i``, interpolated
    linearly in the history ``hist`` (a list of (x, y), up to step ``i``); ``q0`` (the static
    deflection) before the run began."""
    k = i - lag
    if k < 0:
        return q0
    k0 = int(k)
    w = k - k0
    (x0, y0), (x1, y1) = hist[k0], hist[min(k0 + 1, i)]
    return x0 * (1 - w) + x1 * w, y0 * (1 - w) + y1 * w


def _less_motion(q: np.ndarray, m: mujoco.MjModel, op, sampled, dt: float) -> np.ndarray:
    """A moving cut's tip history, shape (n, 2), m, less what the arm does along the motion with no
    cut and less a quadratic trend (the static deflection under the cutting force changes slowly
    with the posture): the cut's own vibration (module notes)."""
    n = len(q)
    q = q - _uncut(m, op, sampled, n)
    t = np.arange(n) * dt
    return q - np.polynomial.polynomial.polyval(t, np.polynomial.polynomial.polyfit(t, q, 2)).T


def _verdict(rpm: float, depth: float, q: np.ndarray, dt: float, period: float) -> MillingRun:
    """The run's chatter verdict from its tip history ``q`` (n, 2), m (:func:`chatter_metrics`)."""
    met = chatter_metrics(q - q.mean(axis=0), dt, period)
    chatter = met["growth"] > 1.0 or met["off_harmonic"] > 0.5
    kind = "stable" if not chatter else ("flip" if met["flip_ratio"] < 0.3 else "hopf")
    return MillingRun(float(rpm), float(depth), bool(chatter), kind, met["metric"], met["growth"],
                      met["off_harmonic"], met["amplitude"])


def _uncut(m: mujoco.MjModel, op, motion_state, n: int) -> np.ndarray:
    """The tool tip's X, Y against the moving equilibrium, shape (n, 2), m, when the robot runs the
    same motion with no cut (from the equilibrium at rest on it): the sway the interpolated
    reference leaves where the joint path's curvature changes. One open-loop rollout in C."""
    from mujoco import rollout

    q_eq_t, v_eq_t, ctrl_t, rows_t = motion_state
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, _state(op), mujoco.mjtState.mjSTATE_FULLPHYSICS)
    d.qpos[:], d.qvel[:], d.ctrl[:] = q_eq_t[0], v_eq_t[0], ctrl_t[0]
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    x0 = np.zeros(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, x0, spec)
    if n > 1:
        states, _ = rollout.rollout(m, d, x0[None], ctrl_t[None, :n - 1])
        qpos = np.vstack([q_eq_t[:1], states[0, :, 1:1 + m.nq]])      # before each step (time first)
    else:
        qpos = q_eq_t[:1].copy()
    return np.einsum("tij,tj->ti", rows_t[:n], qpos - q_eq_t[:n])


def _state(op) -> np.ndarray:
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    s = np.zeros(mujoco.mj_stateSize(op.robot.model, spec))
    mujoco.mj_getState(op.robot.model, op.data, s, spec)
    return s


_OPS: dict = {}


def _grid_task(args) -> dict:
    robot, tool, posture, cutting, rpm, depth, kw = args
    key = (robot, tool, posture)
    if key not in _OPS:   # one operating point per worker process
        from rmbench.robot import Posture, Robot

        _OPS[key] = Robot.load(robot, tool=tool).at(Posture(*posture))
    return mill(_OPS[key], cutting, rpm, depth, **kw).to_dict()


def mill_grid(robot: str, tool: str | None, posture, cutting: Cutting, speeds_rpm, depths, *,
              workers: int = 1, out=None, progress: bool = False, **kw) -> list[MillingRun]:
    """Virtual milling on a grid of speeds × depths, in parallel and resumable.

    Parameters
    ----------
    robot, tool : str
        Bundled names or MJCF paths (each worker process loads its own copy).
    posture : Posture
    speeds_rpm, depths : sequence of float
        rev/min and m; every pair is milled. ``depths`` may also be a 2-D array (n_speed, n_depth)
        of depths per speed.
    workers : int
        Processes.
    out : str or Path, optional
        JSON-lines file of finished runs, in the order they finish (strict JSON: a runaway's
        unbounded metric and growth are null): a rerun skips the pairs already there.

    Returns
    -------
    list of MillingRun
        One per pair, speeds outer, depths inner.
    """
    from rmbench.io.strict_json import strict_dumps
    from rmbench.parallel import map_cases

    speeds = np.atleast_1d(np.asarray(speeds_rpm, float))
    dep = np.asarray(depths, float)
    dep = np.broadcast_to(dep, (len(speeds), dep.shape[-1])) if dep.ndim == 1 else dep
    pairs = [(float(s), float(a)) for s, row in zip(speeds, dep) for a in row]
    done = _finished(out)
    todo = [p for p in pairs if _key(*p) not in done]
    post = (posture.x, posture.y, posture.theta)
    tasks = [(robot, tool, post, cutting, s, a, kw) for s, a in todo]
    sink = open(out, "a") if out is not None else None
    try:
        from tqdm import tqdm

        bar = tqdm(total=len(pairs), initial=len(pairs) - len(todo), disable=not progress, unit="cut")
        # written as each finishes, so that a killed run resumes from what was written
        for _, r in map_cases(_grid_task, tasks, workers=max(int(workers), 1)):
            done[_key(r["rpm"], r["depth"])] = r
            if sink:
                sink.write(strict_dumps(r) + "\n")
                sink.flush()
            bar.update()
        bar.close()
    finally:
        if sink:
            sink.close()
    return [MillingRun.from_dict(done[_key(s, a)]) for s, a in pairs]


def _key(rpm: float, depth: float) -> tuple:
    """A grid pair's key, rounded so that it survives a JSON round trip."""
    return round(rpm, 6), round(depth, 12)


def _finished(out) -> dict:
    """The runs already in the JSON-lines file ``out`` (none without one), by :func:`_key`."""
    import json
    from pathlib import Path

    done: dict = {}
    if out is not None and Path(out).is_file():
        for line in Path(out).read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                done[_key(r["rpm"], r["depth"])] = r
    return done
