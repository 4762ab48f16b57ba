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

__all__ = ["LinearModel", "ComplexModes", "equilibrium", "linearize", "complex_modes", "perturbed_modes",
           "perturbed_modes_many"]

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

    def nearest(self, f_hz: float) -> int:
        """Index of the mode whose natural frequency is nearest ``f_hz`` (Hz); the first of a tie."""
        return int(np.argmin(np.abs(self.f_n - f_hz)))

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
        """Degrees of freedom: the size of M, C and K."""
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
                tol: float = 1e-10, max_iter: int = 30, stiffness: np.ndarray | None = None) -> None:
    """Settle the passive joints of ``data`` at static equilibrium, in place.

    The held degrees of freedom keep their ``qpos``; the others are solved by Newton's method on
    the inverse-dynamics residual at zero acceleration. Velocities in ``data.qvel`` are kept (a
    spinning spindle stays spinning). On return ``data.ctrl`` holds the actuator commands that hold
    the held joints at rest (the servos' integral action).

    Parameters
    ----------
    held : ndarray of int
        Indices of the held degrees of freedom (actuated joints).
    stiffness : ndarray, shape (nv, nv), optional
        The stiffness of a nearby equilibrium (its :attr:`LinearModel.K`), with ``data`` started
        there: every step uses it (a chord iteration, one inverse dynamics a step) instead of
        differencing anew; a step that does not shrink the residual falls back to Newton.

    Raises
    ------
    RmbenchError
        If the iteration does not converge (the posture cannot be held: a passive joint without
        stiffness under load, or a collapse).
    """
    free = np.setdiff1d(np.arange(model.nv), held)
    data.qacc[:] = 0
    scale = max(1.0, float(np.abs(model.jnt_stiffness).max()) * 1e-12)
    chord = None if stiffness is None else np.asarray(stiffness)[np.ix_(free, free)]
    last = np.inf
    for _ in range(max_iter):
        mujoco.mj_inverse(model, data)
        r = data.qfrc_inverse[free].copy()
        size = np.max(np.abs(r), initial=0.0)
        if size < tol * scale:
            break
        if chord is not None and size > 0.5 * last:
            chord = None                 # the nearby stiffness is not near enough: Newton
        last = size
        k = chord if chord is not None else _central_fd(model, data, free, velocity=False, actuation=False)[free]
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


def linearize(model: mujoco.MjModel, data: mujoco.MjData, damping: np.ndarray | None = None, *,
              differences: str = "central") -> LinearModel:
    """M, C, K of ``model`` about the state in ``data`` (call after :func:`equilibrium`).

    ``damping`` (shape (nv, nv)) is C where it is already known: at rest the velocity terms are the
    joints' and servos' damping alone, which a change of masses leaves as they are.
    ``differences="forward"`` takes K by one-sided differences (half the inverse dynamics). Its
    error is of the order of the step (10⁻⁶) times K's own slope, and nearly the same for two
    models at the same state, so it is meant for a *difference* of two such linearisations (a
    sensitivity), not for modes.
    """
    if differences not in ("central", "forward"):
        raise ValueError(f"differences must be 'central' or 'forward', got {differences!r}")
    nv = model.nv
    every = np.arange(nv)
    sides = (_FD_EPS, -_FD_EPS) if differences == "central" else (_FD_EPS,)
    k = _central_fd(model, data, every, velocity=False, actuation=True, sides=sides)
    if damping is None:
        c = _central_fd(model, data, every, velocity=True, actuation=True)
    else:
        c = np.array(damping, float)
    m = np.zeros((nv, nv))
    mujoco.mj_forward(model, data)
    mujoco.mj_fullM(model, data, m)
    names = tuple(model.joint(model.dof_jntid[i]).name for i in range(nv))
    return LinearModel(dof_names=names, M=m, C=c, K=k)


def _central_fd(model, data, dofs, *, velocity: bool, actuation: bool,
                sides: tuple = (_FD_EPS, -_FD_EPS)) -> np.ndarray:
    """∂f/∂q (or ∂f/∂q') of the force that holds the state at zero acceleration, shape (nv, len(dofs)).

    ``f = qfrc_inverse`` at ``qacc = 0`` (else M(q)·qacc leaks into K), less the actuator forces
    when ``actuation`` (so that servo gains enter K and C). Central differences in MuJoCo's C code:
    :func:`mujoco.mjd_inverseFD` takes forward differences, so it runs once forward and once
    backward and the two are averaged (``sides``: the steps taken; a single one gives forward
    differences). It keeps ``data``'s state and zeroes its ``qacc``; the derived quantities are
    left at a perturbed state, so a caller runs ``mj_forward`` or ``mj_inverse`` before reading
    them.
    """
    nv = model.nv
    work = data
    work.qacc[:] = 0
    out = np.zeros((nv, nv))
    part = np.zeros((nv, nv))
    integrator = model.opt.integrator
    # inverse dynamics integrates nothing; mjd_inverseFD refuses a model set to RK4 all the same
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    try:
        for eps in sides:
            if velocity:
                mujoco.mjd_inverseFD(model, work, eps, int(actuation), None, part, None, None, None, None, None)
            else:
                mujoco.mjd_inverseFD(model, work, eps, int(actuation), part, None, None, None, None, None, None)
            out += part
    finally:
        model.opt.integrator = integrator
    # MuJoCo's derivative matrices are transposed (row: the perturbed coordinate)
    return out.T[:, np.asarray(dofs)] / len(sides)


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


# Reciprocal condition number (1-norm) of the unit-diagonal mass matrix below which it is singular:
# the models' own are 1e-3 to 1e-2; below this some combination of coordinates is massless.
_SINGULAR_MASS = 1e-12


def _complex_modes(m: np.ndarray, c: np.ndarray, k: np.ndarray) -> ComplexModes:
    n = m.shape[0]
    # Scale coordinates to unit modal-ish mass (q = D q̃, D = diag(M)^-½) and time to the geometric
    # mean frequency: rotor armature (100 kg·m²) beside tool segments (1e-5 kg·m²) would otherwise
    # cost the eigenvectors six digits.
    diag = np.abs(np.diag(m))
    if not np.all(diag > 0):
        raise RmbenchError("eigen-analysis failed: singular mass matrix")
    d = 1 / np.sqrt(diag)
    ms, cs, ks = (d[:, None] * x * d[None, :] for x in (m, c, k))
    getrf, gecon, getrs = linalg.lapack.get_lapack_funcs(("getrf", "gecon", "getrs"), (ms,))
    lu, piv, info = getrf(ms)
    if info != 0 or not gecon(lu, np.linalg.norm(ms, 1), norm="1")[0] >= _SINGULAR_MASS:
        raise RmbenchError("eigen-analysis failed: singular mass matrix")
    mi_kc = getrs(lu, piv, np.hstack([ks, cs]))[0]            # M̃⁻¹[K̃ C̃]
    w0 = _mean_frequency(ks, mi_kc[:, :n], np.sum(np.log(np.abs(np.diag(lu)))))
    # The pencil (λA + B)ψ = 0, A = [[C̃, M̃], [M̃, 0]], B = [[K̃, 0], [0, −M̃]] (C̃, K̃ time scaled
    # by w0), is the standard problem Sψ = λψ of S = (−A)⁻¹B = [[0, I], [−M̃⁻¹K̃, −M̃⁻¹C̃]]: a
    # nonsymmetric eig (geev) costs a third of the generalised one (ggev) and is more accurate
    # here (residues of near-repeated poles checked against 34-digit arithmetic).
    s = np.zeros((2 * n, 2 * n))
    s[:n, n:] = np.eye(n)
    s[n:, :n] = mi_kc[:, :n] / -w0**2
    s[n:, n:] = mi_kc[:, n:] / -w0
    lam, wl, vr = linalg.eig(s, left=True, right=True, check_finite=False)
    if not np.all(np.isfinite(lam)):
        raise RmbenchError("eigen-analysis failed: singular mass matrix")
    keep = lam.imag >= -1e-9 * np.abs(lam)
    lam, wl, vr = lam[keep], wl[:, keep], vr[:, keep]
    # A left eigenvector w of S (wᴴS = λwᴴ) gives the pencil's ψL = (−A)⁻ᵀ conj(w), with
    # ψLᵀ(λA + B) = 0, displacement partition −M̃⁻ᵀ conj(w₂), and ψLᵀ A = −wᴴ.
    u = wl[n:].conj()
    x = getrs(lu, piv, np.hstack([u.real, u.imag]), trans=1)[0]
    psi_l = -(x[:, :len(lam)] + 1j * x[:, len(lam):])
    # ψLᵀ A ψR = I; solving against the whole Gram matrix also biorthogonalises the eigenvectors
    # of repeated poles (the X and Y bending modes of a round tool coincide)
    psi_l = psi_l @ np.linalg.inv(-wl.conj().T @ vr).T
    order = np.argsort(np.abs(lam))
    lam, vr, psi_l = lam[order], vr[:, order], psi_l[:, order]
    real = np.abs(lam.imag) <= 1e-9 * np.abs(lam)
    # back to physical coordinates and time: ψLᵀ A ψR = I is preserved with φ = D φ̃ / √w0
    return ComplexModes(poles=lam * w0, phi_r=d[:, None] * vr[:n] / np.sqrt(w0),
                        phi_l=d[:, None] * psi_l / np.sqrt(w0), real_pole=real)


def _mean_frequency(ks: np.ndarray, mi_k: np.ndarray, log_det_m: float) -> float:
    """Geometric mean of the undamped frequencies √|eig(M̃⁻¹K̃)|, rad/s (1 if there are none).

    Their product is √|det K̃ / det M̃|, which LU factorisations give; a singular K̃ (a zero
    frequency, left out of the mean) takes the eigenvalues.
    """
    sign_k, log_k = np.linalg.slogdet(ks)
    if sign_k != 0 and np.isfinite(log_k):
        return float(np.exp((log_k - log_det_m) / (2 * ks.shape[0])))
    w = np.sqrt(np.abs(np.linalg.eigvals(mi_k)))
    return float(np.exp(np.mean(np.log(w[w > 0])))) if np.any(w > 0) else 1.0


_DEGENERATE = 1e-7   # poles this close (relative) span one subspace: no rotation within it to first order


def perturbed_modes(cm: ComplexModes, dm: np.ndarray, dc: np.ndarray, dk: np.ndarray) -> ComplexModes:
    """The modes of ``(M + dM) q'' + (C + dC) q' + (K + dK) q = f`` to first order in the change.

    Analytic eigen-sensitivities (Fox-Kapoor, with Nelson's modal expansion over the complete set of
    state-space eigenvectors): no eigen-analysis of the changed matrices. With ``P_j = λ_j² dM +
    λ_j dC + dK``, the normalisation ``ψLᵀ A ψR = I`` of :class:`ComplexModes` and the poles and
    their conjugates as the basis,

        dλ_j   = −φL_jᵀ P_j φR_j
        dφR_j  = Σ_k≠j −(φL_kᵀ P_j φR_j)/(λ_j − λ_k) φR_k + c_j φR_j
        dφL_j  = Σ_k≠j −(φL_jᵀ P_j φR_k)/(λ_j − λ_k) φL_k + c_j φL_j,   c_j = −½ φL_jᵀ(dC + 2λ_j dM)φR_j,

    which keeps ``ψLᵀ A ψR = I`` to first order (the residues ``φR φLᵀ`` depend only on the sum of
    the two ``c``). Poles closer than a relative ``1e-7`` (the X and Y modes of a round tool) span a
    subspace whose rotation within itself is left out: their summed residue is still right to
    first order.

    Parameters
    ----------
    cm : ComplexModes
        The modes of ``M, C, K`` (every one: :func:`complex_modes` or :meth:`LinearModel.modes`).
    dm, dc, dk : ndarray, shape (n_dof, n_dof)
        The changes of M, C, K (SI).

    Returns
    -------
    ComplexModes
        Poles and eigenvectors moved by their first-order change; same order and layout as ``cm``.
    """
    return perturbed_modes_many(cm, dm[None], dc[None], dk[None])[0]


def perturbed_modes_many(cm: ComplexModes, dm: np.ndarray, dc: np.ndarray, dk: np.ndarray) -> list[ComplexModes]:
    """:func:`perturbed_modes` for several changes at once (one per parameter of a sensitivity).

    Parameters
    ----------
    cm : ComplexModes
    dm, dc, dk : ndarray, shape (n_change, n_dof, n_dof)

    Returns
    -------
    list of ComplexModes, one per change
    """
    lam, pr, pl = cm.poles, cm.phi_r, cm.phi_l
    cplx = ~cm.real_pole
    lam_all = np.concatenate([lam, lam[cplx].conj()])
    pr_all = np.concatenate([pr, pr[:, cplx].conj()], axis=1)
    pl_all = np.concatenate([pl, pl[:, cplx].conj()], axis=1)
    l2 = lam ** 2
    m_r, c_r_, k_r = dm @ pr, dc @ pr, dk @ pr                       # (n_change, n_dof, n_keep)
    tr = np.swapaxes
    m_l, c_l_, k_l = tr(dm, 1, 2) @ pl, tr(dc, 1, 2) @ pl, tr(dk, 1, 2) @ pl
    # P_j φR_j and P_jᵀ φL_j for every kept mode j, as columns
    g = pl_all.T @ (m_r * l2 + c_r_ * lam + k_r)      # (n_change, n_all, n_keep): φL_kᵀ P_j φR_j
    h = pr_all.T @ (m_l * l2 + c_l_ * lam + k_l)      # φL_jᵀ P_j φR_k
    gap = lam[None, :] - lam_all[:, None]
    near = np.abs(gap) <= _DEGENERATE * np.abs(lam)[None, :]
    inv = np.where(near, 0.0, -1.0 / np.where(near, 1.0, gap))
    coef_r, coef_l = g * inv, h * inv
    idx = np.arange(len(lam))
    own = -0.5 * (np.einsum("ij,cij->cj", pl, c_r_) + 2 * lam * np.einsum("ij,cij->cj", pl, m_r))
    coef_r[:, idx, idx] = own
    coef_l[:, idx, idx] = own
    d_lam = -g[:, idx, idx]
    new_r = pr + pr_all @ coef_r
    new_l = pl + pl_all @ coef_l
    return [ComplexModes(poles=lam + d_lam[i], phi_r=new_r[i], phi_l=new_l[i], real_pole=cm.real_pole)
            for i in range(len(dm))]
