"""The MDOF model of METHODS §2 (Eqs. 14-17): synthesis, LSFD and the nonlinear fit's model.

Model of one band, entry ``(j, k)`` (response ``j``, excitation ``k``)::

    H_jk(ω) = Σ_r [ φR_jr φL_kr / (iω − λ_r) + conj(φR_jr φL_kr) / (iω − conj λ_r) ]
              − L_jk / ω² + U_jk

``L`` (complex, 1/kg) is the lower residual (mass-like, modes below the band) and ``U`` (complex,
m/N) the upper residual (stiffness-like, modes above the band). Both are complex so that they also
absorb the phase of the out-of-band modes' tails in a non-proportionally damped structure.

The nonlinear model works in scaled units: ``ω`` and ``λ`` divided by ``omega_scale``, ``H`` by
``h_scale``; then ``φR`` is divided by ``h_scale * omega_scale``, ``L`` by
``h_scale * omega_scale**2`` and ``U`` by ``h_scale``.

Parameter vector of the nonlinear fit (``x``): per mode ``[Re λ, Im λ, Re φR (4), Im φR (4),
Re φL (3 free), Im φL (3 free)]`` (16 reals), then, if residuals are fitted, ``Re L, Im L, Re U,
Im U`` (16 each, entry ``(j, k)`` at ``4 j + k``).
"""

import numpy as np

__all__ = ["synthesize", "lsfd", "residual_basis", "levenberg_marquardt"]

N_PER_MODE = 16


def synthesize(freq, poles, phi_r, phi_l) -> np.ndarray:
    """Receptance matrix of the modes (Eq. 15).

    Parameters
    ----------
    freq : array_like, shape (n_freq,), Hz
    poles : array_like, shape (n_modes,), complex, rad/s
        One pole per conjugate pair.
    phi_r : array_like, shape (n_modes, n_out), complex, s/kg
        Right eigenvectors at the response coordinates.
    phi_l : array_like, shape (n_modes, n_in), complex
        Left eigenvectors at the excitation coordinates.

    Returns
    -------
    ndarray, shape (n_freq, n_out, n_in), complex, m/N
    """
    s = 2j * np.pi * np.asarray(freq, float)[:, None]
    lam = np.asarray(poles, complex)
    phi_r, phi_l = np.asarray(phi_r, complex), np.asarray(phi_l, complex)
    g, gc = 1 / (s - lam), 1 / (s - lam.conj())
    return (np.einsum("fm,mo,mi->foi", g, phi_r, phi_l)
            + np.einsum("fm,mo,mi->foi", gc, phi_r.conj(), phi_l.conj()))


def residual_basis(omega: np.ndarray) -> np.ndarray:
    """Columns of the residual terms at ``omega`` (rad/s): ``[−1/ω², −i/ω², 1, i]``, shape (n, 4)."""
    inv = -1.0 / omega**2
    one = np.ones_like(omega)
    return np.column_stack([inv, 1j * inv, one, 1j * one])


def lsfd(freq, H, poles, *, residuals: bool = True):
    """Residues of known poles by linear least squares (least-squares frequency domain).

    Parameters
    ----------
    freq : array_like, shape (n_freq,), Hz
    H : ndarray, shape (n_freq, n_out, n_in), complex, m/N
    poles : array_like, shape (n_modes,), complex, rad/s
    residuals : bool
        Also fit a lower (``−L/ω²``) and an upper (``U``) residual per entry.

    Returns
    -------
    residues : ndarray, shape (n_modes, n_out, n_in), complex, m/(N s)
        ``φR φL^T`` of each mode.
    lower, upper : ndarray, shape (n_out, n_in), complex, 1/kg and m/N
        Residual terms (zeros when ``residuals`` is False).
    """
    omega = 2 * np.pi * np.asarray(freq, float)
    lam = np.asarray(poles, complex)
    n_f, n_out, n_in = H.shape
    g = 1 / (1j * omega[:, None] - lam)
    gc = 1 / (1j * omega[:, None] - lam.conj())
    cols = [g + gc, 1j * (g - gc)]
    if residuals:
        cols.append(residual_basis(omega))
    A = np.concatenate(cols, axis=1)
    scale = np.linalg.norm(A, axis=0)
    A = A / scale
    Ar = np.concatenate([A.real, A.imag])
    b = H.reshape(n_f, -1)
    br = np.concatenate([b.real, b.imag])
    sol = np.linalg.lstsq(Ar, br, rcond=None)[0] / scale[:, None]
    n = len(lam)
    res = (sol[:n] + 1j * sol[n:2 * n]).reshape(n, n_out, n_in)
    lower = np.zeros((n_out, n_in), complex)
    upper = np.zeros((n_out, n_in), complex)
    if residuals:
        lower = (sol[2 * n] + 1j * sol[2 * n + 1]).reshape(n_out, n_in)
        upper = (sol[2 * n + 2] + 1j * sol[2 * n + 3]).reshape(n_out, n_in)
    return res, lower, upper


def _unpack(x, n_modes, ref, residuals, n_out=4, n_in=4):
    """Split the scaled parameter vector into poles, φR, φL, lower and upper residuals."""
    m = x[:n_modes * N_PER_MODE].reshape(n_modes, N_PER_MODE)
    lam = m[:, 0] + 1j * m[:, 1]
    phi_r = m[:, 2:2 + n_out] + 1j * m[:, 2 + n_out:2 + 2 * n_out]
    free = m[:, 2 + 2 * n_out:2 + 2 * n_out + n_in - 1] + 1j * m[:, 2 + 2 * n_out + n_in - 1:]
    phi_l = np.empty((n_modes, n_in), complex)
    for r in range(n_modes):
        phi_l[r, ref[r]] = 1.0
        phi_l[r, np.arange(n_in) != ref[r]] = free[r]
    if residuals:
        t = x[n_modes * N_PER_MODE:].reshape(4, n_out * n_in)
        lower = (t[0] + 1j * t[1]).reshape(n_out, n_in)
        upper = (t[2] + 1j * t[3]).reshape(n_out, n_in)
    else:
        lower = upper = np.zeros((n_out, n_in), complex)
    return lam, phi_r, phi_l, lower, upper


def _pack(lam, phi_r, phi_l, lower, upper, ref, residuals):
    """Inverse of :func:`_unpack`."""
    n_in = phi_l.shape[1]
    rows = []
    for r in range(len(lam)):
        free = phi_l[r, np.arange(n_in) != ref[r]]
        rows.append(np.concatenate([[lam[r].real, lam[r].imag], phi_r[r].real, phi_r[r].imag,
                                    free.real, free.imag]))
    x = [np.concatenate(rows)] if rows else [np.zeros(0)]
    if residuals:
        x += [lower.real.ravel(), lower.imag.ravel(), upper.real.ravel(), upper.imag.ravel()]
    return np.concatenate(x)


def _model(x, omega, n_modes, ref, residuals):
    """Scaled model FRF, shape (n_freq, n_out, n_in), and the pieces its Jacobian needs."""
    lam, phi_r, phi_l, lower, upper = _unpack(x, n_modes, ref, residuals)
    s = 1j * omega[:, None]
    g, gc = 1 / (s - lam), 1 / (s - lam.conj())
    Hm = (np.einsum("fm,mo,mi->foi", g, phi_r, phi_l)
          + np.einsum("fm,mo,mi->foi", gc, phi_r.conj(), phi_l.conj()))
    if residuals:
        Hm = Hm - lower / omega[:, None, None] ** 2 + upper
    return Hm, (lam, phi_r, phi_l, g, gc)


def _residual(x, omega, Hs, W, n_modes, ref, residuals):
    """Weighted error, real vector of length ``2 * n_freq * n_out * n_in``."""
    Hm, _ = _model(x, omega, n_modes, ref, residuals)
    e = (W * (Hm - Hs)).ravel()
    return np.concatenate([e.real, e.imag])


def _jacobian(x, omega, Hs, W, n_modes, ref, residuals):
    """Analytic Jacobian of :func:`_residual`, shape (2 * n_freq * n_out * n_in, len(x))."""
    _, (lam, phi_r, phi_l, g, gc) = _model(x, omega, n_modes, ref, residuals)
    n_f = len(omega)
    n_out, n_in = phi_r.shape[1], phi_l.shape[1]
    J = np.zeros((n_f, n_out, n_in, len(x)), complex)
    for r in range(n_modes):
        b0 = N_PER_MODE * r
        a, b, gr, gcr = phi_r[r], phi_l[r], g[:, r, None, None], gc[:, r, None, None]
        Q = np.outer(a, b)
        J[..., b0] = Q * gr**2 + Q.conj() * gcr**2
        J[..., b0 + 1] = 1j * (Q * gr**2 - Q.conj() * gcr**2)
        # ∂H_jk/∂Re a_j = b_k g + conj(b_k) gc; ∂/∂Im a_j = i (b_k g − conj(b_k) gc)
        cb = b * gr[:, 0] + b.conj() * gcr[:, 0]                  # (n_f, n_in)
        cbi = 1j * (b * gr[:, 0] - b.conj() * gcr[:, 0])
        for j in range(n_out):
            J[:, j, :, b0 + 2 + j] = cb
            J[:, j, :, b0 + 2 + n_out + j] = cbi
        ca = a * gr[:, 0] + a.conj() * gcr[:, 0]                  # (n_f, n_out)
        cai = 1j * (a * gr[:, 0] - a.conj() * gcr[:, 0])
        free = [k for k in range(n_in) if k != ref[r]]
        for q, k in enumerate(free):
            J[:, :, k, b0 + 2 + 2 * n_out + q] = ca
            J[:, :, k, b0 + 2 + 2 * n_out + len(free) + q] = cai
    if residuals:
        n_e = n_out * n_in
        b0 = N_PER_MODE * n_modes
        inv = -1.0 / omega**2
        for e in range(n_e):
            j, k = divmod(e, n_in)
            J[:, j, k, b0 + e] = inv
            J[:, j, k, b0 + n_e + e] = 1j * inv
            J[:, j, k, b0 + 2 * n_e + e] = 1.0
            J[:, j, k, b0 + 3 * n_e + e] = 1j
    J *= W[..., None]
    J = J.reshape(-1, J.shape[-1])
    return np.concatenate([J.real, J.imag])


def levenberg_marquardt(fun, jac, x0, args=(), *, max_iter=100, xtol=1e-8, chi2_tol=1e-3,
                        watch=None, step_tol=0.01, stop=None):
    """Levenberg–Marquardt on the normal equations (Marquardt scaling, Nielsen damping update).

    Faster than MINPACK here because ``JᵀJ`` goes through BLAS. Stops when a step lowers (or is
    predicted to lower) χ² = cost / σ² by less than ``chi2_tol``, σ² = 2 cost / (m − n) being the
    residual variance — the parameters then move by a negligible fraction of their standard
    errors — or when the step is below ``xtol`` relative to ``x``.

    Parameters
    ----------
    jac : callable
        ``jac(x, *args)`` returns the Jacobian, or the pair ``(JᵀJ, Jᵀr)`` of the normal
        equations (then the returned ``J`` is None).
    watch : array_like of int, optional
        Parameters whose convergence decides: once an accepted step moves each of them by less
        than ``step_tol`` of its standard error, the fit has converged even if poorly determined
        other parameters (out-of-band poles) still creep along a flat valley.
    stop : callable, optional
        ``stop(cost) -> bool`` after each accepted step; True ends the fit there (not converged).

    Returns
    -------
    x : ndarray
    r : ndarray
        Residual at ``x``.
    J : ndarray
        Jacobian at ``x``.
    converged : bool
    """
    x = np.asarray(x0, float).copy()
    r = fun(x, *args)
    J, A, g = _normal(jac(x, *args), r)
    cost = 0.5 * float(r @ r)
    mu, nu = 1e-3, 2.0
    dof = max(len(r) - len(x), 1)
    for _ in range(max_iter):
        D = np.maximum(np.diag(A), 1e-12 * float(np.max(np.diag(A))))
        try:
            dx = -np.linalg.solve(A + mu * np.diag(D), g)
        except np.linalg.LinAlgError:
            mu, nu = mu * nu, nu * 2
            continue
        pred = -(g @ dx) - 0.5 * dx @ (A @ dx)
        tol = 0.5 * chi2_tol * 2 * cost / dof
        if pred <= tol or np.linalg.norm(dx) <= xtol * (np.linalg.norm(x) + xtol):
            return x, r, J, True
        x_new = x + dx
        r_new = fun(x_new, *args)
        cost_new = 0.5 * float(r_new @ r_new)
        rho = (cost - cost_new) / pred
        if rho > 0:
            flat = cost - cost_new <= tol
            x, r, cost = x_new, r_new, cost_new
            J, A, g = _normal(jac(x, *args), r)
            mu *= max(1 / 3, 1 - (2 * rho - 1) ** 3)
            nu = 2.0
            if flat or (watch is not None and _settled(A, dx, watch, 2 * cost / dof, step_tol)):
                return x, r, J, True
            if stop is not None and stop(cost):
                return x, r, J, False
        else:
            mu, nu = mu * nu, nu * 2
    return x, r, J, False


def _normal(out, r):
    """``(J, JᵀJ, Jᵀr)`` from a Jacobian or from a ``(JᵀJ, Jᵀr)`` pair (``J`` None)."""
    if isinstance(out, tuple):
        return None, out[0], out[1]
    return out, out.T @ out, out.T @ r


def _settled(A, dx, watch, sigma2, step_tol) -> bool:
    """Whether the last step moved every watched parameter by < ``step_tol`` standard errors."""
    watch = np.asarray(watch, int)
    if len(watch) == 0:
        return True
    try:
        var = sigma2 * np.diag(np.linalg.inv(A))[watch]
    except np.linalg.LinAlgError:
        return False
    return bool(np.all(np.abs(dx[watch]) < step_tol * np.sqrt(np.maximum(var, 1e-300))))
