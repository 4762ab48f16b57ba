"""Variable projection (Golub–Pereyra, Kaufman's Jacobian) for the MDOF model of :mod:`.mdof`.

For fixed poles ``λ`` and left eigenvectors ``φL`` the model of METHODS §2 is real-linear in the
right eigenvectors ``φR`` and in the residual terms, and each output row ``j`` of the 4x4 matrix has
its own: ``H_jk = Σ_r φR_jr B_kr(ω) + conj(...) − L_jk/ω² + U_jk``. So the linear parameters are
eliminated exactly, row by row, by a small QR (``2 n + 16`` columns), and Levenberg–Marquardt only
sees the ``8 n`` nonlinear ones (``σ, ω_d`` and the three free complex φL entries per mode) — four
times fewer for 12 modes than the joint problem with residuals, and better conditioned.

All quantities in the scaled units of :mod:`.mdof` (``ω / ω_s``, ``H / h_s``).
Nonlinear vector ``θ``: per mode ``[Re λ, Im λ, Re φL (3 free), Im φL (3 free)]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.modal import mdof

__all__ = ["Problem", "Solution", "pack_theta", "unpack_theta"]

N_THETA = 8  # nonlinear parameters per mode


def pack_theta(lam: np.ndarray, phi_l: np.ndarray, refs: np.ndarray) -> np.ndarray:
    """``θ`` of poles ``lam`` (n,) and left eigenvectors ``phi_l`` (n, 4) with ``φL[ref] = 1``."""
    rows = []
    for r in range(len(lam)):
        free = phi_l[r, np.arange(phi_l.shape[1]) != refs[r]]
        rows.append(np.concatenate([[lam[r].real, lam[r].imag], free.real, free.imag]))
    return np.concatenate(rows) if rows else np.zeros(0)


def unpack_theta(theta: np.ndarray, refs: np.ndarray, n_in: int = 4):
    """Poles (n,) and left eigenvectors (n, n_in) of ``θ``."""
    n = len(refs)
    m = theta.reshape(n, N_THETA)
    lam = m[:, 0] + 1j * m[:, 1]
    free = m[:, 2:2 + n_in - 1] + 1j * m[:, 2 + n_in - 1:]
    phi_l = np.empty((n, n_in), complex)
    for r in range(n):
        phi_l[r, refs[r]] = 1.0
        phi_l[r, np.arange(n_in) != refs[r]] = free[r]
    return lam, phi_l


@dataclass(frozen=True)
class Solution:
    """A converged (or stopped) fit in scaled units.

    Attributes
    ----------
    lam : ndarray, shape (n,), complex
    phi_r : ndarray, shape (n, 4), complex
    phi_l : ndarray, shape (n, 4), complex
    lower, upper : ndarray, shape (4, 4), complex
        Residual terms (zeros without residuals).
    refs : ndarray, shape (n,), int
    cost : float
        Half the weighted sum of squared errors.
    converged : bool
    n_iter : int
    """

    lam: np.ndarray
    phi_r: np.ndarray
    phi_l: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    refs: np.ndarray
    cost: float
    converged: bool
    n_iter: int

    @property
    def n(self) -> int:
        return len(self.lam)


class Problem:
    """One band's weighted least-squares problem: data, weights and the model's structure.

    Parameters
    ----------
    omega : ndarray, shape (n_freq,)
        Scaled angular frequencies.
    H : ndarray, shape (n_freq, 4, 4), complex
        Scaled receptance.
    W : ndarray, shape (n_freq, 4, 4), real
        Weight of each line.
    residuals : bool
        Whether the lower and upper residual terms are part of the model.
    """

    def __init__(self, omega, H, W, residuals: bool):
        self.omega = omega
        self.H = H
        self.W = W
        self.residuals = residuals
        self.n_f, self.n_out, self.n_in = H.shape
        self.Wt = np.ascontiguousarray(np.transpose(W, (1, 2, 0)))     # (j, k, f)
        # data of each output row as real vectors over (input, re/im, line)
        b = np.transpose(W * H, (1, 2, 0))                               # (j, k, f)
        self.b = np.stack([b.real, b.imag], axis=2).reshape(self.n_out, -1)
        self.resid_cols = mdof.residual_basis(omega) if residuals else np.zeros((self.n_f, 0))
        # the residual terms' columns of every row block (input k's own, zero at the other
        # inputs) do not depend on θ: built once, copied into each evaluation's basis
        R, n_res = self.resid_cols, self.resid_cols.shape[1]
        self._resid_block = np.zeros((self.n_out, self.n_in, 2, self.n_f, n_res * self.n_in))
        for k in range(self.n_in):
            cols = slice(n_res * k, n_res * (k + 1))
            self._resid_block[:, k, 0, :, cols] = self.Wt[:, k, :, None] * R.real
            self._resid_block[:, k, 1, :, cols] = self.Wt[:, k, :, None] * R.imag
        self._cache = None

    @property
    def n_data(self) -> int:
        """Number of real residuals."""
        return self.b.size

    def n_params(self, n_modes: int) -> int:
        """Number of real parameters of a model with ``n_modes`` modes (linear ones included)."""
        return n_modes * mdof.N_PER_MODE + (4 * self.n_out * self.n_in if self.residuals else 0)

    # -- the projected problem -----------------------------------------------------------------
    # Real layout of every row block: (input k, re/im, line f), i.e. 8 n_f rows per output j.
    def _evaluate(self, theta, refs):
        """Projected residual, the projector of each row's linear problem and its solution."""
        key = theta.tobytes()
        if self._cache is not None and self._cache[0] == key:
            return self._cache[1]
        lam, phi_l = unpack_theta(theta, refs, self.n_in)
        n = len(lam)
        s = 1j * self.omega[:, None]
        g, gc = 1 / (s - lam), 1 / (s - lam.conj())               # (f, n)
        n_res = self.resid_cols.shape[1]
        n_col = 2 * n + n_res * self.n_in
        if n_col == 0:
            out = (self.b.ravel(), None, np.zeros((self.n_out, 0)), lam, phi_l, g, gc)
            self._cache = (key, out)
            return out
        # basis of Re φR_jr and Im φR_jr at input k: B1 = X + Y, B2 = i (X − Y), (k, f, n)
        X = phi_l.T[:, None, :] * g[None]
        Y = phi_l.conj().T[:, None, :] * gc[None]
        S, Dd = X + Y, X - Y
        Wt = self.Wt[..., None]
        # every column written (products straight into place, no temporaries)
        A = np.empty((self.n_out, self.n_in, 2, self.n_f, n_col))
        np.multiply(Wt, S.real, out=A[:, :, 0, :, :n])
        np.multiply(Wt, S.imag, out=A[:, :, 1, :, :n])
        np.multiply(-Wt, Dd.imag, out=A[:, :, 0, :, n:2 * n])
        np.multiply(Wt, Dd.real, out=A[:, :, 1, :, n:2 * n])
        A[..., 2 * n:] = self._resid_block
        A = A.reshape(self.n_out, -1, n_col)
        proj = _Projector(A)
        c = proj.solve(self.b[..., None])[..., 0]                   # (j, c)
        r = self.b - (A @ c[..., None])[..., 0]
        out = (r.ravel(), proj, c, lam, phi_l, g, gc)
        self._cache = (key, out)
        return out

    def residual(self, theta, refs):
        """Projected weighted error (data minus model), real, length ``n_data``."""
        return self._evaluate(theta, refs)[0]

    def _blocks(self, theta, refs):
        """``(∂A/∂θ) c`` by input block, without the structural zeros.

        Rows of input ``k`` depend on every pole (σ, ω) but only on the φL entries of input
        ``k``; the other φL columns are zero there. Block ``k`` is ``(cols_k, D_k)`` with
        ``D_k`` of shape (j, 2 n_f, len(cols_k)) (rows re/im × line) and ``cols_k`` its columns
        in ``θ``.
        """
        _, proj, c, lam, phi_l, g, gc = self._evaluate(theta, refs)
        n = len(lam)
        phi_r = c[:, :n] + 1j * c[:, n:2 * n]                      # (j, n)
        g2, gc2 = g**2, gc**2
        Xr = phi_r[:, None, :] * g[None]                            # (j, f, n)
        Yr = phi_r.conj()[:, None, :] * gc[None]
        E, Ed = Xr + Yr, Xr - Yr                                    # ∂/∂Re φL_k, ∂/∂Im φL_k / i
        n_free = self.n_in - 1
        r8 = N_THETA * np.arange(n)
        blocks = []
        for k in range(self.n_in):
            modes = np.flatnonzero(refs != k)
            q = np.where(k < refs[modes], k, k - 1)                 # place of k among the free
            P = phi_r * phi_l[:, k][None, :]                        # (j, n)
            T = P[:, None, :] * g2[None]                            # (j, f, n)
            Tc = P.conj()[:, None, :] * gc2[None]
            S, Dd = T + Tc, T - Tc
            w = self.Wt[:, k, :, None]                              # (j, f, 1)
            m = len(modes)
            Em, Edm = E[..., modes], Ed[..., modes]
            D = np.empty((self.n_out, 2, self.n_f, 2 * n + 2 * m))
            np.multiply(w, S.real, out=D[:, 0, :, :n])           # ∂/∂σ: P g² + conj(P) gc²
            np.multiply(w, S.imag, out=D[:, 1, :, :n])
            np.multiply(-w, Dd.imag, out=D[:, 0, :, n:2 * n])    # ∂/∂ω: i (P g² − conj(P) gc²)
            np.multiply(w, Dd.real, out=D[:, 1, :, n:2 * n])
            np.multiply(w, Em.real, out=D[:, 0, :, 2 * n:2 * n + m])
            np.multiply(w, Em.imag, out=D[:, 1, :, 2 * n:2 * n + m])
            np.multiply(-w, Edm.imag, out=D[:, 0, :, 2 * n + m:])
            np.multiply(w, Edm.real, out=D[:, 1, :, 2 * n + m:])
            cols = np.concatenate([r8, r8 + 1, N_THETA * modes + 2 + q,
                                   N_THETA * modes + 2 + n_free + q])
            blocks.append((cols, D.reshape(self.n_out, 2 * self.n_f, -1)))
        return blocks, proj, n * N_THETA

    def _derivative(self, theta, refs):
        """``(∂A/∂θ) c`` of each row, real layout, shape (j, 8 n_f, 8 n)."""
        blocks, proj, p = self._blocks(theta, refs)
        D = np.zeros((self.n_out, self.n_in, 2 * self.n_f, p))
        for k, (cols, Dk) in enumerate(blocks):
            D[:, k, :, cols] = np.moveaxis(Dk, 2, 0)
        return D.reshape(self.n_out, -1, p), proj

    def jacobian(self, theta, refs):
        """Kaufman's Jacobian of :meth:`residual`, shape (n_data, 8 n).

        ``r = b − A c``, so ``∂r/∂θ ≈ −P⊥ (∂A/∂θ) c`` (the term Kaufman drops is orthogonal to
        ``r``, so ``Jᵀ r`` is the exact gradient of the cost).
        """
        D, proj = self._derivative(theta, refs)
        return -proj.complement(D).reshape(-1, D.shape[-1])

    def normal(self, theta, refs):
        """``(JᵀJ, Jᵀr)`` of Kaufman's Jacobian without forming it.

        ``JᵀJ = DᵀD − DᵀA (AᵀA)⁻¹ AᵀD`` and ``Jᵀr = −Dᵀr`` (``r`` is orthogonal to ``A``), with
        ``D = (∂A/∂θ) c`` taken block by block (:meth:`_blocks`).
        """
        r = self.residual(theta, refs).reshape(self.n_out, self.n_in, -1)
        if self._evaluate(theta, refs)[1].Q is not None:
            # ill-conditioned linear part (nearly coincident poles): the plain way, through QR
            J = self.jacobian(theta, refs)
            return J.T @ J, J.T @ r.ravel()
        blocks, proj, p = self._blocks(theta, refs)
        n_f2 = 2 * self.n_f
        JtJ = np.zeros((p, p))
        Jtr = np.zeros(p)
        AtD = np.zeros((self.n_out, proj.A.shape[2], p))
        for k, (cols, Dk) in enumerate(blocks):
            Ak = proj.A[:, k * n_f2:(k + 1) * n_f2]
            JtJ[np.ix_(cols, cols)] += (np.swapaxes(Dk, 1, 2) @ Dk).sum(axis=0)
            Jtr[cols] -= np.einsum("jmp,jm->p", Dk, r[:, k])
            AtD[..., cols] += np.swapaxes(Ak, 1, 2) @ Dk
        JtJ -= (np.swapaxes(AtD, 1, 2) @ proj.gram_solve(AtD)).sum(axis=0)
        return 0.5 * (JtJ + JtJ.T), Jtr

    def linear(self, theta, refs):
        """φR (n, 4), lower and upper residuals (4, 4) of the linear solution at ``θ``."""
        _, _, c, lam, _, _, _ = self._evaluate(theta, refs)
        n = len(lam)
        phi_r = (c[:, :n] + 1j * c[:, n:2 * n]).T
        lower = np.zeros((self.n_out, self.n_in), complex)
        upper = np.zeros((self.n_out, self.n_in), complex)
        if self.residuals:
            t = c[:, 2 * n:].reshape(self.n_out, self.n_in, 4)
            lower = t[..., 0] + 1j * t[..., 1]
            upper = t[..., 2] + 1j * t[..., 3]
        return phi_r, lower, upper

    def cost(self, theta, refs) -> float:
        r = self.residual(theta, refs)
        return 0.5 * float(r @ r)

    def solve(self, lam0, phi_l0, refs, *, max_iter: int = 100, watch=None, stop=None,
              hold=None) -> Solution:
        """Levenberg–Marquardt on ``θ`` from poles ``lam0`` and left eigenvectors ``phi_l0``.

        ``watch``: bool per mode, the modes whose convergence decides (default all); ``stop``:
        ``stop(cost) -> bool`` ends the fit early (see
        :func:`~rmbench.modal.mdof.levenberg_marquardt`); ``hold``: bool per mode, modes whose
        pole stays where it starts (their eigenvectors are still fitted).
        """
        refs = np.asarray(refs, int)
        theta0 = pack_theta(np.asarray(lam0, complex), np.asarray(phi_l0, complex), refs)
        free = np.ones(len(theta0), bool)
        if hold is not None:
            held = np.flatnonzero(np.asarray(hold, bool))
            free[np.concatenate([N_THETA * held, N_THETA * held + 1])] = False
        counter = {"n": 0}

        def full(x):
            th = theta0.copy()
            th[free] = x
            return th

        def fun(x, rf):
            return self.residual(full(x), rf)

        def jac(x, rf):
            counter["n"] += 1
            JtJ, Jtr = self.normal(full(x), rf)
            return JtJ[np.ix_(free, free)], Jtr[free]

        idx = None
        if watch is not None:
            w = np.repeat(np.asarray(watch, bool), N_THETA)[free]
            idx = np.flatnonzero(w)
        x, r, _, ok = mdof.levenberg_marquardt(fun, jac, theta0[free], (refs,),
                                               max_iter=max_iter, watch=idx, stop=stop)
        theta = full(x)
        lam, phi_l = unpack_theta(theta, refs, self.n_in)
        phi_r, lower, upper = self.linear(theta, refs)
        return Solution(lam=lam, phi_r=phi_r, phi_l=phi_l, lower=lower, upper=upper, refs=refs,
                        cost=0.5 * float(r @ r), converged=ok, n_iter=counter["n"])


class _Projector:
    """Least squares on the columns of ``A`` (stacked rows, shape (j, m, c)).

    The normal equations through BLAS, on the Gram matrix scaled to a unit diagonal, are ten
    times faster than a QR here; when that scaled matrix is too ill-conditioned for them (nearly
    coincident poles), a QR of the scaled columns takes over.
    """

    def __init__(self, A):
        self.A = A
        G = np.swapaxes(A, 1, 2) @ A
        d = np.sqrt(np.diagonal(G, axis1=1, axis2=2))
        self.d = np.where(d > 0, d, 1.0)                            # column norms (j, c)
        self.Gs = G / (self.d[:, :, None] * self.d[:, None, :])
        self.Q = None
        try:
            L = np.linalg.cholesky(self.Gs)
            piv = np.abs(np.diagonal(L, axis1=1, axis2=2))
            ok = bool(np.all(piv.min(axis=1) > 1e-5 * piv.max(axis=1)))
        except np.linalg.LinAlgError:
            ok = False
        if not ok:
            self.Q, self.R = np.linalg.qr(A / self.d[:, None, :])

    def gram_solve(self, z):
        """``(AᵀA)⁻¹ z`` for ``z`` of shape (j, c, p)."""
        return np.linalg.solve(self.Gs, z / self.d[..., None]) / self.d[..., None]

    def solve(self, y):
        """Least-squares coefficients of ``y`` (j, m, p): shape (j, c, p)."""
        if self.Q is None:
            return self.gram_solve(np.swapaxes(self.A, 1, 2) @ y)
        return np.linalg.solve(self.R, np.swapaxes(self.Q, 1, 2) @ y) / self.d[..., None]

    def complement(self, y):
        """``y`` minus its projection on the columns of ``A``."""
        if self.Q is None:
            return y - self.A @ self.solve(y)
        return y - self.Q @ (np.swapaxes(self.Q, 1, 2) @ y)
