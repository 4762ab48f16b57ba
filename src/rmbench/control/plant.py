"""Proof-mass plants (METHODS.md §8): the robot with its reaction masses, as a linear system.

A plant maps forces to measurements of a suppressor with ``n`` axes:

    inputs  [d_1 … d_n, u_1 … u_n]    d: disturbance force on the robot along axis i, N
                                       u: voice-coil force, +u on the reaction mass, −u on the robot, N
    outputs [a_1 … a_n, p_1 … p_n]    a: robot acceleration at the accelerometer along axis i, m/s²
                                       p: reaction-mass position relative to the robot (encoder), m

Axis i's direction is its voice-coil slide in the world frame at the operating point, so ``a_i``
and ``u_i`` act along the same line, as in METHODS.md §8. Three ways to get one:

- :func:`robot_plant`: the robot's exact multi-mode linearisation with the reaction masses (and the
  shakers' moving masses) attached, so the axes couple through the robot; optionally reduced by
  balanced truncation;
- :func:`two_mass_plant`: METHODS.md §8's single-axis model (robot mode M, K, B; reaction mass m, k, b);
- :func:`modal_plant`: its multi-axis form, the robot as real normal modes seen at the suppressor
  (one participation vector per mode, so the axes couple) carrying one reaction mass per axis;
- :func:`measured_plant` (in :mod:`rmbench.control.experiments`): the robot's mode identified from a
  simulated (or real) shaker FRF measurement, then :func:`two_mass_plant`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import control as ct
import mujoco
import numpy as np

from rmbench.control.response import frequency_response
from rmbench.errors import InputError

__all__ = ["AXES", "Plant", "robot_plant", "two_mass_plant", "modal_plant", "first_strong_mode", "ReactionMass", "reaction_mass",
           "axis_directions", "parse_axes"]

AXES = ("tangential", "axial", "radial")
"""Suppressor axes of the MH180 stand-in: joints ``pm_<axis>``, actuators ``vc_<axis>``."""


@dataclass(frozen=True)
class Plant:
    """A proof-mass plant in continuous time (SI units; layout in the module docstring).

    Attributes
    ----------
    axes : tuple of str
    A, B, C, D : ndarray
        State space, shapes (n_x, n_x), (n_x, 2n), (2n, n_x), (2n, 2n).
    source : str
        ``"linearisation"``, ``"two-mass"`` or ``"measured"``.
    mode_hz : tuple of float
        The robot mode each axis targets (its largest accelerance peak below 40 Hz), Hz.
    """

    axes: tuple[str, ...]
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    source: str
    mode_hz: tuple[float, ...]
    info: dict = field(default_factory=dict, compare=False)

    @property
    def n_axes(self) -> int:
        """Axes ``n`` (each a disturbance, a force, an acceleration and a position)."""
        return len(self.axes)

    @property
    def order(self) -> int:
        """States ``n_x``."""
        return self.A.shape[0]

    def ss(self) -> ct.StateSpace:
        """The plant as a python-control state space with named signals."""
        n = self.n_axes
        return ct.ss(self.A, self.B, self.C, self.D,
                     inputs=[f"d_{a}" for a in self.axes] + [f"u_{a}" for a in self.axes],
                     outputs=[f"acc_{a}" for a in self.axes] + [f"pos_{a}" for a in self.axes],
                     name=f"plant_{n}axis")

    def frf(self, freq) -> np.ndarray:
        """Frequency response, shape (n_freq, 2n, 2n): rows outputs, columns inputs (SI)."""
        return frequency_response(self.A, self.B, self.C, self.D, freq)

    def select(self, axes) -> "Plant":
        """The plant restricted to some of its axes (the other inputs off, outputs unread)."""
        idx = [self.axes.index(a) for a in axes]
        n = self.n_axes
        cols = idx + [n + i for i in idx]
        return Plant(tuple(axes), self.A, self.B[:, cols], self.C[cols], self.D[np.ix_(cols, cols)],
                     self.source, tuple(self.mode_hz[i] for i in idx), dict(self.info))


@dataclass(frozen=True)
class ReactionMass:
    """A voice-coil stage as the MJCF declares it: mass kg, centring stiffness N/m, damping N·s/m,
    stroke ±m, peak force N."""

    mass: float
    stiffness: float
    damping: float
    stroke: float
    force_peak: float


def reaction_mass(model: mujoco.MjModel, axis: str) -> ReactionMass:
    """The reaction-mass stage ``pm_<axis>`` / ``vc_<axis>`` of a MuJoCo model."""
    jid = _joint_id(model, f"pm_{axis}")
    aid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"vc_{axis}")
    if aid < 0:
        raise InputError(f"the robot has no voice coil 'vc_{axis}'")
    body = model.jnt_bodyid[jid]
    return ReactionMass(mass=float(model.body_subtreemass[body]),
                        stiffness=float(model.jnt_stiffness[jid]),
                        damping=float(model.dof_damping[model.jnt_dofadr[jid]]),
                        stroke=float(max(abs(model.jnt_range[jid])) if model.jnt_limited[jid] else np.inf),
                        force_peak=float(max(abs(model.actuator_ctrlrange[aid]))))


def axis_directions(op, axes) -> np.ndarray:
    """World unit vectors of the axes' voice-coil slides at the operating point, shape (n, 3)."""
    m, d = op.robot.model, op.data
    return np.array([d.xaxis[_joint_id(m, f"pm_{a}")] for a in axes])


def robot_plant(op, axes=("tangential",), *, order: int | None = None, accelerometer: str = "acc",
                disturbance: str = "shaker") -> Plant:
    """The robot's exact linearisation at ``op`` as a proof-mass plant.

    Parameters
    ----------
    op : OperatingPoint
        A robot with a suppressor (joints ``pm_<axis>``, shakers ``sh_<axis>``) at equilibrium.
    axes : sequence of str
        Suppressor axes, from :data:`AXES`.
    order : int, optional
        Reduce by balanced truncation to this many states (the full model has 2 × n_dof).
    accelerometer : str
        Site of the accelerometer.
    disturbance : {"shaker", "site"}
        Where ``d`` enters: through the axis's disturbance voice coil (``−f`` on its coil, so that
        ``d`` is the force on the robot; the shaker test), or as a point force at the
        accelerometer site.

    Returns
    -------
    Plant
    """
    axes = parse_axes(axes)
    m = op.robot.model
    lin = op.linear
    e = axis_directions(op, axes)
    jac = op.point_jacobian(accelerometer)  # (3, n_dof)
    n_dof = lin.n_dof
    acc_rows = e @ jac
    pos_rows = np.array([_unit(n_dof, m.jnt_dofadr[_joint_id(m, f"pm_{a}")]) for a in axes])
    u_rows = pos_rows
    if disturbance == "shaker":
        d_rows = np.array([-_unit(n_dof, m.jnt_dofadr[_joint_id(m, f"sh_{a}")]) for a in axes])
    elif disturbance == "site":
        d_rows = acc_rows
    else:
        raise InputError(f"disturbance must be 'shaker' or 'site', got {disturbance!r}")
    inp = np.vstack([d_rows, u_rows])
    a, b, c_acc, d_acc = lin.state_space(acc_rows, inp, output="acceleration")
    _, _, c_pos, d_pos = lin.state_space(pos_rows, inp, output="displacement")
    C = np.vstack([c_acc, c_pos])
    D = np.vstack([d_acc, d_pos])
    sys = ct.ss(a, b, C, D)
    if order is not None and order < a.shape[0]:
        sys = ct.balred(sys, order, method="matchdc")
    modes = tuple(_target_mode(sys, i, len(axes)) for i in range(len(axes)))
    return Plant(axes, np.asarray(sys.A), np.asarray(sys.B), np.asarray(sys.C), np.asarray(sys.D),
                 "linearisation", modes, {"directions": e.tolist()})


def two_mass_plant(M, K, B, rm: ReactionMass, *, axis: str = "tangential",
                   source: str = "two-mass") -> Plant:
    """METHODS.md §8: robot mode(s) (M kg, K N/m, B N·s/m) carrying a reaction mass.

    With one mode this is the seed's model, whose transfer functions equal Eqs. 10-13:
    ``G_u = [s² X1/U; (X2 − X1)/U]``, ``G_d = [s² X1/D; (X2 − X1)/D]``. With several (arrays of
    equal length) the robot's point receptance is their sum, ``X1 = Σ_r F / (K_r + B_r s + M_r s²)``
    for the net force ``F`` on the robot at the suppressor: the modes a measured FRF shows around
    the targeted one.

    State ``[x_1 … x_n, x2, x_1' … x_n', x2']`` (the modal displacements, whose sum is the robot's
    displacement x1, and the reaction mass's absolute displacement; m and m/s).
    """
    M, K, B = (np.atleast_1d(np.asarray(v, float)) for v in (M, K, B))
    if not (M.shape == K.shape == B.shape) or M.ndim != 1:
        raise InputError("M, K and B must be scalars or 1-D arrays of one length")
    if np.any(M <= 0) or np.any(K <= 0) or np.any(B < 0) or rm.mass <= 0 or min(rm.stiffness, rm.damping) < 0:
        raise InputError(f"a two-mass plant needs M, K, m > 0 and B, k, b >= 0; got M={M}, K={K}, B={B}, "
                         f"m={rm.mass:g}, k={rm.stiffness:g}, b={rm.damping:g}")
    m, k, b = rm.mass, rm.stiffness, rm.damping
    n = len(M)
    # net force on the robot: F = d − u + k (x2 − Σx_r) + b (x2' − Σx_r')
    ones = np.ones(n)
    Fx = np.concatenate([-k * ones, [k]])          # dF/d[x_r, x2]
    Fv = np.concatenate([-b * ones, [b]])          # dF/d[x_r', x2']
    acc_x = np.zeros((n + 1, n + 1))
    acc_v = np.zeros((n + 1, n + 1))
    acc_in = np.zeros((n + 1, 2))                  # inputs d, u
    for r in range(n):
        acc_x[r] = Fx / M[r]
        acc_x[r, r] -= K[r] / M[r]
        acc_v[r] = Fv / M[r]
        acc_v[r, r] -= B[r] / M[r]
        acc_in[r] = [1 / M[r], -1 / M[r]]
    acc_x[n] = -Fx / m                            # m x2'' = −k (x2 − x1) − b (x2' − x1') + u
    acc_v[n] = -Fv / m
    acc_in[n] = [0, 1 / m]
    A = np.block([[np.zeros((n + 1, n + 1)), np.eye(n + 1)], [acc_x, acc_v]])
    Bm = np.vstack([np.zeros((n + 1, 2)), acc_in])
    sel = np.concatenate([ones, [0]])               # x1 = Σ x_r
    C = np.vstack([sel @ A[n + 1:], np.concatenate([-ones, [1], np.zeros(n + 1)])])
    D = np.vstack([sel @ Bm[n + 1:], [0, 0]])
    f_n = np.sqrt(K / M) / (2 * np.pi)
    target = int(np.argmax(1 / (B * np.sqrt(K / M))))  # the largest accelerance peak, 1/(2ζ M) = 1/(B ω)
    info = {"M": M.tolist(), "K": K.tolist(), "B": B.tolist(), "m": m, "k": k, "b": b}
    if n == 1:
        info.update(M=float(M[0]), K=float(K[0]), B=float(B[0]))
    return Plant((axis,), A, Bm, C, D, source, (float(f_n[target]),), info)


def modal_plant(f_n, zeta, shapes, masses, axes, *, source: str = "modal") -> Plant:
    """A multi-axis proof-mass plant from the robot's normal modes at the suppressor.

    The robot's receptance at the suppressor is ``X1 = Σ_r v_r v_rᵀ F / (ω_r² + 2 ζ_r ω_r s + s²)``
    (real mode shapes ``v_r`` along the axes, normalised to unit modal mass, 1/√kg), with
    ``F`` the net force on the robot along each axis; axis i carries its reaction mass
    (:class:`ReactionMass`): ``m_i x2_i'' = −k_i (x2_i − x1_i) − b_i (x2_i' − x1_i') + u_i``. With one
    axis and ``v_r = 1/√M_r`` this is :func:`two_mass_plant`.

    Parameters
    ----------
    f_n, zeta : array_like, shape (n_modes,)
        Natural frequencies (Hz) and damping ratios.
    shapes : array_like, shape (n_axes, n_modes)
        Mode shapes along the axes, normalised to unit modal mass (1/√kg).
    masses : sequence of ReactionMass, length n_axes
    axes : sequence of str

    Returns
    -------
    Plant
        State ``[q_1 … q_N, x2_1 … x2_n]`` and their rates (modal coordinates, reaction-mass
        displacements).
    """
    f_n, zeta = np.atleast_1d(np.asarray(f_n, float)), np.atleast_1d(np.asarray(zeta, float))
    V = np.atleast_2d(np.asarray(shapes, float))
    axes = parse_axes(axes)
    n, N = len(axes), len(f_n)
    if zeta.shape != f_n.shape or V.shape != (n, N) or len(masses) != n:
        raise InputError(f"modal_plant needs {N} damping ratios, shapes ({n}, {N}) and {n} reaction masses; "
                         f"got {zeta.shape}, {V.shape}, {len(masses)}")
    if np.any(f_n <= 0) or np.any(zeta < 0) or not np.all(np.isfinite(V)):
        raise InputError("modal_plant needs positive frequencies, non-negative damping and finite shapes")
    k = np.array([rm.stiffness for rm in masses])
    b = np.array([rm.damping for rm in masses])
    m = np.array([rm.mass for rm in masses])
    w = 2 * np.pi * f_n
    # net force on the robot, F = d − u + k (x2 − V q) + b (x2' − V q'), as rows over [q, x2, q', x2']
    Fz = np.hstack([-k[:, None] * V, np.diag(k), -b[:, None] * V, np.diag(b)])
    acc_q = np.hstack([-np.diag(w**2), np.zeros((N, n)), -np.diag(2 * zeta * w), np.zeros((N, n))]) + V.T @ Fz
    acc_x2 = -Fz / m[:, None]  # m x2'' = −(the spring and damper part of F) + u
    nz = N + n
    A = np.block([[np.zeros((nz, nz)), np.eye(nz)], [acc_q], [acc_x2]])
    eye = np.eye(n)
    Bm = np.vstack([np.zeros((nz, 2 * n)), np.hstack([V.T, -V.T]), np.hstack([np.zeros((n, n)), np.diag(1 / m)])])
    C_acc = V @ A[nz:nz + N]
    D_acc = V @ Bm[nz:nz + N]
    C_pos = np.hstack([-V, eye, np.zeros((n, nz))])
    C = np.vstack([C_acc, C_pos])
    D = np.vstack([D_acc, np.zeros((n, 2 * n))])
    sys = ct.ss(A, Bm, C, D)
    modes = tuple(_target_mode(sys, i, n) for i in range(n))
    info = {"f_n": f_n.tolist(), "zeta": zeta.tolist(), "shapes": V.tolist(),
            "reaction_masses": [{"m": float(a), "k": float(c), "b": float(e)} for a, c, e in zip(m, k, b)]}
    return Plant(axes, A, Bm, C, D, source, modes, info)


def first_strong_mode(plant: Plant, axis: int = 0, *, ratio: float = 0.5, f_min: float = 2.0,
                      f_max: float = 40.0) -> float:
    """The lowest resonance of ``|a_i/d_i|`` whose peak reaches ``ratio`` times the largest, Hz.

    The largest accelerance peak (``Plant.mode_hz``) can jump between two comparable peaks from one
    posture to the next (the arm's tangential mode and a wrist mode, say); a schedule must target
    one mode throughout, and the lowest strong one is the posture-dependent arm mode.
    """
    from scipy.signal import find_peaks

    f = np.geomspace(f_min, f_max, 3000)
    g = np.abs(plant.frf(f)[:, axis, axis])
    peaks, _ = find_peaks(g)
    if len(peaks) == 0:
        return float(f[int(np.argmax(g))])
    strong = peaks[g[peaks] >= ratio * g[peaks].max()]
    return float(f[strong[0]])


def _target_mode(sys, i: int, n: int, f_max: float = 40.0) -> float:
    """Frequency of the largest peak of |a_i/d_i| between 2 Hz and ``f_max``, Hz."""
    f = np.geomspace(2.0, f_max, 2000)
    s = 2j * np.pi * f
    A, B, C, D = (np.asarray(x) for x in (sys.A, sys.B, sys.C, sys.D))
    eye = np.eye(A.shape[0])
    g = np.array([C[i] @ np.linalg.solve(si * eye - A, B[:, i]) + D[i, i] for si in s])
    return float(f[int(np.argmax(np.abs(g)))])


def parse_axes(axes) -> tuple[str, ...]:
    """Axis names from a sequence or a comma-separated string, checked against :data:`AXES`."""
    if isinstance(axes, str):
        axes = tuple(a.strip() for a in axes.split(","))
    axes = tuple(axes)
    bad = [a for a in axes if a not in AXES]
    if bad or not axes or len(set(axes)) != len(axes):
        raise InputError(f"axes must be distinct names from {', '.join(AXES)}; got {', '.join(axes) or 'none'}")
    return axes


def _joint_id(model, name: str) -> int:
    jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
    if jid < 0:
        raise InputError(f"the robot has no joint {name!r} (a proof-mass suppressor is needed: "
                         "use the mh180 robot)")
    return jid


def _unit(n: int, i: int) -> np.ndarray:
    v = np.zeros(n)
    v[i] = 1.0
    return v
