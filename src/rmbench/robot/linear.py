"""Static equilibrium and exact linearisation of a MuJoCo robot model.

The operating point of a posture is the deflected static equilibrium: every actuated joint is held
at its command (servos with integral action reach their set point at rest; the voice coils of a
proof-mass suppressor hold their masses centred), and every passive joint (gearbox flexibility,
bearings, tool contact and bending) settles where its spring balances gravity. There the equations
of motion are linearised into

    M q'' + C q' + K q = Bᵀ f,

with M the mass matrix including rotor armature, C the joint and servo damping plus gyroscopic
terms of a spinning spindle, and K the joint springs, servo gains and gravity's geometric stiffness.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np
from scipy import linalg

from rmbench.errors import RmbenchError

__all__ = ["LinearModel", "ComplexModes", "equilibrium", "linearize", "complex_modes"]

# Central differences of mj_inverse: step in rad, m, rad/s or m/s. MuJoCo's own mjd_inverseFD takes
# forward differences, whose error in C visibly distorts small cross FRFs at the spindle modes.
_FD_EPS = 1e-6


@dataclass(frozen=True)
class ComplexModes:
    """Complex modes of ``M q'' + C q' + K q = f`` (general non-symmetric case), METHODS.md §2.

    One pole of each complex-conjugate pair is kept (Im λ > 0); real poles, if any, once each.
    With ``A = [[C, M], [M, 0]]`` and ``B = [[K, 0], [0, -M]]`` the state eigenvectors satisfy
    ``ψLᵀ A ψR = I``; ``phi_r`` and ``phi_l`` are their displacement partitions, so that

        H(ω) = Σ_r φR_r φL_rᵀ/(iω − λ_r) + conj(φR_r) conj(φL_r)ᵀ/(iω − conj(λ_r)).

    Attributes
    ----------
    poles : ndarray, shape (n_modes,), complex, rad/s
        Sorted by natural frequency.
    phi_r, phi_l : ndarray, shape (n_dof, n_modes), complex
        Right and left eigenvectors (displacement partitions) in generalised coordinates.
    real_pole : ndarray, shape (n_modes,), bool
        True for an overdamped (real) pole that enters H once.
    """

    poles: np.ndarray
    phi_r: np.ndarray
    phi_l: np.ndarray
    real_pole: np.ndarray

    @property
    def f_n(self) -> np.ndarray:
        """Natural frequencies |λ|/2π, Hz, shape (n_modes,)."""
        return np.abs(self.poles) / (2 * np.pi)

    @property
    def zeta(self) -> np.ndarray:
        """Damping ratios −Re λ/|λ|, shape (n_modes,)."""
        return -self.poles.real / np.abs(self.poles)

    def frf(self, freq: np.ndarray, out: np.ndarray, inp: np.ndarray) -> np.ndarray:
        """Receptance by modal superposition, m/N, shape (n_freq, n_out, n_in).

        Parameters
        ----------
        freq : ndarray, shape (n_freq,), Hz
        out, inp : ndarray, shape (n_out, n_dof) and (n_in, n_dof)
            Maps from generalised displacements to output coordinates and from input forces to
            generalised forces (transposed).
        """
        return self.transfer(2j * np.pi * np.asarray(freq, float), out, inp)

    def transfer(self, s: np.ndarray, out: np.ndarray, inp: np.ndarray) -> np.ndarray:
        """Receptance at complex Laplace variables ``s`` (rad/s), shape (n_s, n_out, n_in).

        Off the imaginary axis this is what an exponentially windowed measurement sees:
        windowing by exp(−σt) evaluates the transfer function at ``s = σ + iω``.
        """
        s = np.asarray(s, complex)[:, None]
        r = out @ self.phi_r  # (n_out, n_modes)
        lt = inp @ self.phi_l  # (n_in, n_modes)
        g = 1 / (s - self.poles)  # (n_s, n_modes)
        gc = np.where(self.real_pole, 0, 1 / (s - self.poles.conj()))
        # Σ_m g_fm r_om lt_im as one product over the stacked modes and their conjugates (BLAS)
        left = np.concatenate([g[:, None, :] * r[None], gc[:, None, :] * r.conj()[None]], axis=2)
        return left @ np.concatenate([lt, lt.conj()], axis=1).T


@dataclass(frozen=True)
class LinearModel:
    """Linearised dynamics ``M q'' + C q' + K q = Q`` at an operating point, SI units.

    Attributes
    ----------
    dof_names : tuple of str, length n_dof
        The MuJoCo joint of each generalised coordinate.
    M, C, K : ndarray, shape (n_dof, n_dof)
        Mass (kg, kg·m²), damping and stiffness matrices (N·m/rad, N/m and mixed).
    """

    dof_names: tuple[str, ...]
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    _modes: list = field(default_factory=list, repr=False, compare=False)

    def __post_init__(self):
        n = len(self.dof_names)
        for name in ("M", "C", "K"):
            if getattr(self, name).shape != (n, n):
                raise ValueError(f"{name} must have shape ({n}, {n}), got {getattr(self, name).shape}")

    @property
    def n_dof(self) -> int:
        return len(self.dof_names)

    def dynamic_stiffness(self, freq: np.ndarray) -> np.ndarray:
        """``K − ω² M + iω C``, shape (n_freq, n_dof, n_dof)."""
        w = 2 * np.pi * np.asarray(freq, float)[:, None, None]
        return self.K - w**2 * self.M + 1j * w * self.C

    def frf(self, freq: np.ndarray, out: np.ndarray, inp: np.ndarray) -> np.ndarray:
        """Receptance by direct solution of the dynamic stiffness, m/N, shape (n_freq, n_out, n_in).

        ``out`` maps generalised displacements to outputs (n_out, n_dof); ``inp`` maps the
        input forces to generalised forces, transposed (n_in, n_dof).
        """
        z = self.dynamic_stiffness(freq)
        rhs = np.broadcast_to(inp.T.astype(complex), (len(z),) + inp.T.shape)
        return out @ np.linalg.solve(z, rhs)

    def modes(self) -> ComplexModes:
        """Complex modes with left and right eigenvectors, normalised ``ψLᵀ A ψR = I``."""
        if not self._modes:
            self._modes.append(_complex_modes(self.M, self.C, self.K))
        return self._modes[0]

    def state_space(self, out: np.ndarray, inp: np.ndarray, *, output: str = "displacement"):
        """Continuous-time ``(A, B, C, D)`` from input forces to outputs, state ``[q; q']``.

        Parameters
        ----------
        out, inp : ndarray, shapes (n_out, n_dof), (n_in, n_dof)
        output : {"displacement", "velocity", "acceleration"}
            Kind of the outputs (m, m/s, m/s²).
        """
        n = self.n_dof
        minv = np.linalg.inv(self.M)
        a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ self.K, -minv @ self.C]])
        b = np.vstack([np.zeros((n, inp.shape[0])), minv @ inp.T])
        zeros = np.zeros((out.shape[0], n))
        if output == "displacement":
            c, d = np.hstack([out, zeros]), np.zeros((out.shape[0], inp.shape[0]))
        elif output == "velocity":
            c, d = np.hstack([zeros, out]), np.zeros((out.shape[0], inp.shape[0]))
        elif output == "acceleration":
            c, d = out @ a[n:], out @ b[n:]
        else:
            raise ValueError(f"output must be displacement, velocity or acceleration, got {output!r}")
        return a, b, c, d


_STEP_TOL = 1e-14   # rad or m: a Newton step this small is round-off


def equilibrium(model: mujoco.MjModel, data: mujoco.MjData, held: np.ndarray, *,
                tol: float = 1e-10, max_iter: int = 30) -> None:
    """Settle the passive joints of ``data`` at static equilibrium, in place.

    The held degrees of freedom keep their ``qpos``; the others are solved by Newton's method on
    the inverse-dynamics residual at zero acceleration. Velocities in ``data.qvel`` are kept (a
    spinning spindle stays spinning). On return ``data.ctrl`` holds the actuator commands that hold
    the held joints at rest (the servos' integral action).

    Parameters
    ----------
    held : ndarray of int
        Indices of the held degrees of freedom (actuated joints).

    Raises
    ------
    RmbenchError
        If the iteration does not converge (the posture cannot be held: a passive joint without
        stiffness under load, or a collapse).
    """
    free = np.setdiff1d(np.arange(model.nv), held)
    data.qacc[:] = 0
    scale = max(1.0, float(np.abs(model.jnt_stiffness).max()) * 1e-12)
    for _ in range(max_iter):
        mujoco.mj_inverse(model, data)
        r = data.qfrc_inverse[free].copy()
        if np.max(np.abs(r), initial=0.0) < tol * scale:
            break
        k = _central_fd(model, data, free, velocity=False, actuation=False)[free]
        step = np.linalg.solve(k, r)
        data.qpos[_qpos_of(model, free)] -= step
        data.qacc[:] = 0
        # a spinning rotor's gyroscopic terms (I ω² ~ 10⁴ N·m) leave round-off in the residual
        # above the force tolerance at some postures: a step at round-off level is convergence
        if np.max(np.abs(step), initial=0.0) < _STEP_TOL:
            mujoco.mj_inverse(model, data)
            break
    else:
        raise RmbenchError("static equilibrium not found: the robot cannot hold this posture")
    _hold_with_actuators(model, data)


def linearize(model: mujoco.MjModel, data: mujoco.MjData) -> LinearModel:
    """M, C, K of ``model`` about the state in ``data`` (call after :func:`equilibrium`)."""
    nv = model.nv
    every = np.arange(nv)
    k = _central_fd(model, data, every, velocity=False, actuation=True)
    c = _central_fd(model, data, every, velocity=True, actuation=True)
    m = np.zeros((nv, nv))
    mujoco.mj_forward(model, data)
    mujoco.mj_fullM(model, data, m)
    names = tuple(model.joint(model.dof_jntid[i]).name for i in range(nv))
    return LinearModel(dof_names=names, M=m, C=c, K=k)


def _central_fd(model, data, dofs, *, velocity: bool, actuation: bool) -> np.ndarray:
    """∂f/∂q (or ∂f/∂q') of the force that holds the state at zero acceleration, shape (nv, len(dofs)).

    ``f = qfrc_inverse`` at ``qacc = 0`` (else M(q)·qacc leaks into K), less the actuator forces
    when ``actuation`` (so that servo gains enter K and C).
    """
    work = mujoco.MjData(model)
    qadr = _qpos_of(model, np.asarray(dofs))
    out = np.empty((model.nv, len(dofs)))

    def force(qpos, qvel):
        work.qpos[:] = qpos
        work.qvel[:] = qvel
        work.ctrl[:] = data.ctrl
        work.qacc[:] = 0
        mujoco.mj_inverse(model, work)
        f = work.qfrc_inverse.copy()
        if actuation:
            mujoco.mj_fwdActuation(model, work)
            f -= work.qfrc_actuator
        return f

    for col, (dof, adr) in enumerate(zip(dofs, qadr)):
        q_p, q_m = data.qpos.copy(), data.qpos.copy()
        v_p, v_m = data.qvel.copy(), data.qvel.copy()
        if velocity:
            v_p[dof] += _FD_EPS
            v_m[dof] -= _FD_EPS
        else:
            q_p[adr] += _FD_EPS
            q_m[adr] -= _FD_EPS
        out[:, col] = (force(q_p, v_p) - force(q_m, v_m)) / (2 * _FD_EPS)
    return out


def _qpos_of(model: mujoco.MjModel, dofs: np.ndarray) -> np.ndarray:
    """qpos addresses of hinge/slide dofs (the rmbench models have no ball or free joints)."""
    jnt = model.dof_jntid[dofs]
    if np.any(model.jnt_type[jnt] < int(mujoco.mjtJoint.mjJNT_SLIDE)):
        raise RmbenchError("ball and free joints are not supported in rmbench robot models")
    return model.jnt_qposadr[jnt]


def _hold_with_actuators(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Set ``data.ctrl`` so each joint actuator delivers the force its joint needs at rest."""
    mujoco.mj_inverse(model, data)
    for a in range(model.nu):
        if model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT:
            continue
        dof = model.jnt_dofadr[model.actuator_trnid[a, 0]]
        gear = model.actuator_gear[a, 0]
        force = data.qfrc_inverse[dof] / gear
        length = data.qpos[model.jnt_qposadr[model.actuator_trnid[a, 0]]] * gear
        velocity = data.qvel[dof] * gear
        bias = model.actuator_biasprm[a]
        gain = model.actuator_gainprm[a, 0]
        data.ctrl[a] = (force - bias[0] - bias[1] * length - bias[2] * velocity) / gain
    mujoco.mj_forward(model, data)


def complex_modes(m: np.ndarray, c: np.ndarray, k: np.ndarray) -> ComplexModes:
    """Complex modes of ``M q'' + C q' + K q = f`` (see :class:`ComplexModes`)."""
    return _complex_modes(m, c, k)


def _complex_modes(m: np.ndarray, c: np.ndarray, k: np.ndarray) -> ComplexModes:
    n = m.shape[0]
    # Scale coordinates to unit modal-ish mass (q = D q̃, D = diag(M)^-½) and time to the geometric
    # mean frequency: rotor armature (100 kg·m²) beside tool segments (1e-5 kg·m²) would otherwise
    # cost the eigenvectors six digits.
    d = 1 / np.sqrt(np.abs(np.diag(m)))
    ms, cs, ks = (d[:, None] * x * d[None, :] for x in (m, c, k))
    w = np.sqrt(np.abs(np.linalg.eigvals(np.linalg.solve(ms, ks))))
    w0 = float(np.exp(np.mean(np.log(w[w > 0])))) if np.any(w > 0) else 1.0
    cs, ks = cs / w0, ks / w0**2
    z = np.zeros((n, n))
    a = np.block([[cs, ms], [ms, z]])
    b = np.block([[ks, z], [z, -ms]])
    # (λA + B)ψ = 0  ⇔  B ψ = λ (−A) ψ
    lam, vl, vr = linalg.eig(b, -a, left=True, right=True)
    if not np.all(np.isfinite(lam)):
        raise RmbenchError("eigen-analysis failed: singular mass matrix")
    keep = lam.imag >= -1e-9 * np.abs(lam)
    lam, vl, vr = lam[keep], vl[:, keep], vr[:, keep]
    # scipy's left eigenvectors satisfy vlᴴ B = λ vlᴴ (−A); ψL = conj(vl) gives ψLᵀ(λA + B) = 0.
    psi_l = vl.conj()
    # ψLᵀ A ψR = I; solving against the whole Gram matrix also biorthogonalises the eigenvectors
    # of repeated poles (the X and Y bending modes of a round tool coincide)
    psi_l = psi_l @ np.linalg.inv(psi_l.T @ a @ vr).T
    order = np.argsort(np.abs(lam))
    lam, vr, psi_l = lam[order], vr[:, order], psi_l[:, order]
    real = np.abs(lam.imag) <= 1e-9 * np.abs(lam)
    # back to physical coordinates and time: ψLᵀ A ψR = I is preserved with φ = D φ̃ / √w0
    return ComplexModes(poles=lam * w0, phi_r=d[:, None] * vr[:n] / np.sqrt(w0),
                        phi_l=d[:, None] * psi_l[:n] / np.sqrt(w0), real_pole=real)
