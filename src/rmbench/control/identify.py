"""The measured-plant path: a robot mode identified from an FRF measurement (METHODS.md §8).

As in the seed's lab, the plant comes from a measurement: the disturbance voice coil shakes the
robot (band-limited random force), the accelerometer responds, and the H1 estimate gives the
accelerance ``a/d`` (the simulated shaker tests are in :mod:`rmbench.control.experiments`,
:func:`~rmbench.control.experiments.measured_plant`; this module only fits). The seed
fitted one mode near its peak — ``1/H = K − M ω² + i ω B`` is linear in (M, K, B) for the
receptance ``H = −A/ω²``; here every resonance of the band is fitted (jointly, to separate
overlapping ones) unless ``single_mode`` asks for the seed's model — and
:func:`~rmbench.control.plant.two_mass_plant` adds the reaction mass.
The same :func:`plant_from_frf` takes a real robot's measured accelerance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from rmbench.control.plant import Plant, ReactionMass, modal_plant, parse_axes, two_mass_plant
from rmbench.errors import InputError

__all__ = ["ModeFit", "fit_mode", "fit_modes", "plant_from_frf", "MatrixModes", "fit_modes_matrix",
           "plant_from_frf_matrix"]


@dataclass(frozen=True)
class ModeFit:
    """One mode as a mass-spring-damper seen at the suppressor: M kg, K N/m, B N·s/m."""

    M: float
    K: float
    B: float

    @property
    def f_n(self) -> float:
        """Undamped natural frequency ``√(K/M) / 2π``, Hz."""
        return float(np.sqrt(self.K / self.M) / (2 * np.pi))

    @property
    def zeta(self) -> float:
        """Damping ratio ``B / (2√(KM))``, dimensionless."""
        return float(self.B / (2 * np.sqrt(self.K * self.M)))


def fit_mode(freq, accelerance, f_min: float = 2.0, f_max: float = 40.0, *, band: float = 0.15) -> ModeFit:
    """Fit one mode to the largest accelerance peak in ``[f_min, f_max]`` Hz.

    Parameters
    ----------
    freq : array_like, shape (n,), Hz
    accelerance : array_like, shape (n,), complex, m/s²/N
    band : float
        Fit over ``f_peak (1 ± band)``, weighted by |H| (the peak dominates, neighbours less).
    """
    freq, acc, sel = _check_frf(freq, accelerance, f_min, f_max)
    fp = freq[np.flatnonzero(sel)[np.argmax(np.abs(acc[sel]))]]
    return _fit_peak(freq, acc, sel, fp, band)


def fit_modes(freq, accelerance, f_min: float = 2.0, f_max: float = 40.0, *, prominence: float = 0.01,
              max_modes: int = 8) -> list[ModeFit]:
    """Fit every resonance of an accelerance in ``[f_min, f_max]`` Hz together.

    Peaks of |H| with a prominence above ``prominence`` times the largest give one mode each
    (:func:`fit_mode` around each for a start); then all modes are fitted jointly,
    ``H ≈ Σ_r 1/(K_r − M_r ω² + i ω B_r)`` on the receptance over the band (least squares in the
    logarithms of M, K, B, errors relative to |H|), which separates overlapping modes. Sorted by
    frequency, after a first entry for the modes above the band: a residual mass ``M_res``
    (receptance ``−1/(M_res ω²)``), returned as a 0.2 Hz mode with ζ = 0.5, which acts as a free
    mass over the band.
    """
    from scipy.optimize import least_squares

    freq, acc, sel = _check_frf(freq, accelerance, f_min, f_max)
    mag = np.abs(acc[sel])
    peaks, _ = signal.find_peaks(mag, prominence=prominence * mag.max())
    if len(peaks) == 0:
        peaks = np.array([int(np.argmax(mag))])
    peaks = peaks[np.argsort(mag[peaks])[::-1][:max_modes]]
    fps = freq[sel][peaks]
    start = []
    for fp in fps:
        try:
            start.append(_fit_peak(freq, acc, sel, fp, 0.05))
        except InputError:
            continue
    if not start:
        raise InputError(f"no resonance could be fitted within {f_min:g}-{f_max:g} Hz")
    w = 2 * np.pi * freq[sel]
    h = -acc[sel] / w**2
    scale = np.abs(h)
    n = len(start)

    def model(p):
        M, K, B = np.exp(p[:3 * n].reshape(3, -1))
        modes = np.sum(1 / (K[:, None] - M[:, None] * w**2 + 1j * w * B[:, None]), axis=0)
        return modes - 1 / (np.exp(p[-1]) * w**2)  # + the modes above the band, as a free mass

    def resid(p):
        e = (model(p) - h) / scale
        return np.concatenate([e.real, e.imag])

    m_res0 = 1 / max(abs(acc[sel][-1]), 1e-12)  # accelerance at the top of the band ≈ 1/M_res
    p0 = np.concatenate([np.log([[m.M for m in start], [m.K for m in start], [m.B for m in start]]).ravel(),
                         [np.log(10 * m_res0)]])
    sol = least_squares(resid, p0, method="lm", max_nfev=4000)
    M, K, B = np.exp(sol.x[:3 * n].reshape(3, -1))
    fits = sorted((ModeFit(float(a), float(b), float(c)) for a, b, c in zip(M, K, B)), key=lambda m: m.f_n)
    # the residual mass as a mode far below the band (0.2 Hz, ζ 0.5): a free mass above 1 Hz
    m_res = float(np.exp(sol.x[-1]))
    k_res = m_res * (2 * np.pi * 0.2) ** 2
    return [ModeFit(m_res, k_res, np.sqrt(k_res * m_res))] + fits


def plant_from_frf(freq, accelerance, rm: ReactionMass, *, axis: str = "tangential", f_min: float = 2.0,
                   f_max: float = 40.0, single_mode: bool = False) -> Plant:
    """METHODS.md §8 plant from a measured accelerance ``a/d`` and the reaction-mass hardware.

    ``single_mode=True`` keeps only the largest resonance (the seed's model); by default every
    resonance in the band is kept, so the design knows the modes around the one it targets.

    Parameters
    ----------
    freq : array_like, shape (n_freq,), Hz
    accelerance : array_like, shape (n_freq,), complex, m/s²/N
        The robot's acceleration per disturbance force at the suppressor, along ``axis``.
    rm : ReactionMass
        The suppressor's hardware.
    axis : str
        The axis the plant acts along.
    f_min, f_max : float
        Band of the mode fit, Hz.
    single_mode : bool
        Fit only the largest resonance (:func:`fit_mode`) instead of every one (:func:`fit_modes`).

    Returns
    -------
    Plant
        Source ``measured``; ``info`` adds the targeted mode's damping ratio ``zeta`` and the
        fitted modes' frequencies ``modes_hz`` (Hz).
    """
    modes = [fit_mode(freq, accelerance, f_min, f_max)] if single_mode else fit_modes(freq, accelerance, f_min, f_max)
    p = two_mass_plant([m.M for m in modes], [m.K for m in modes], [m.B for m in modes], rm, axis=axis,
                       source="measured")
    target = int(np.argmin([abs(m.f_n - p.mode_hz[0]) for m in modes]))
    return Plant(p.axes, p.A, p.B, p.C, p.D, "measured", p.mode_hz,
                 dict(p.info, zeta=modes[target].zeta, modes_hz=[m.f_n for m in modes]))


def _check_frf(freq, accelerance, f_min, f_max):
    freq = np.asarray(freq, float)
    acc = np.asarray(accelerance, complex)
    if freq.shape != acc.shape or freq.ndim != 1:
        raise InputError(f"freq and accelerance must be 1-D arrays of one length, got {freq.shape}, {acc.shape}")
    if not (np.all(np.isfinite(freq)) and np.all(np.isfinite(acc))):
        raise InputError("the FRF has NaN or infinite values")
    sel = (freq >= f_min) & (freq <= f_max) & (freq > 0)
    if np.count_nonzero(sel) < 5:
        raise InputError(f"the FRF has fewer than 5 lines within {f_min:g}-{f_max:g} Hz")
    return freq, acc, sel


def _fit_peak(freq, acc, sel, fp, band) -> ModeFit:
    """``1/H = K − M ω² + i ω B`` by weighted linear least squares within ``fp (1 ± band)``."""
    near = sel & (np.abs(freq - fp) <= band * fp)
    if np.count_nonzero(near) < 3:
        raise InputError(f"too few lines near {fp:.3g} Hz to fit a mode")
    w = 2 * np.pi * freq[near]
    h = -acc[near] / w**2  # receptance
    y = 1 / h
    wt = np.abs(h)
    # Re: K − M ω²;  Im: B ω
    A = np.block([[np.column_stack([np.ones_like(w), -w**2, np.zeros_like(w)])],
                  [np.column_stack([np.zeros_like(w), np.zeros_like(w), w])]])
    b = np.concatenate([y.real, y.imag])
    W = np.concatenate([wt, wt])
    K, M, B = np.linalg.lstsq(A * W[:, None], b * W, rcond=None)[0]
    if M <= 0 or K <= 0 or B <= 0:
        raise InputError(f"no resonance could be fitted near {fp:.3g} Hz (M={M:.3g}, K={K:.3g}, B={B:.3g})")
    return ModeFit(float(M), float(K), float(B))


# several axes at once ----------------------------------------------------------------------------
RESIDUAL_HZ, RESIDUAL_ZETA = 0.2, 0.5
"""The modes above the band enter as pseudo-modes far below it (Hz, ζ): free masses above 1 Hz."""


@dataclass(frozen=True)
class MatrixModes:
    """Real normal modes fitted to an n × n accelerance matrix at the suppressor.

    Attributes
    ----------
    f_n, zeta : ndarray, shape (n_modes,)
        Hz and damping ratios, sorted by frequency; the first ``n_residual`` are the pseudo-modes
        of the modes above the band (:data:`RESIDUAL_HZ`).
    shapes : ndarray, shape (n, n_modes)
        Mode shapes along the axes at unit modal mass, 1/√kg.
    n_residual : int
    rel_error : float
        RMS of the fit's error relative to √(|H_ii| |H_jj|) over the band's lines and entries.
    cov : ndarray, shape (n_params, n_params), or None
        Covariance of :attr:`params` from the least-squares fit, ``σ² (JᵀJ)⁺`` (``J`` the
        residuals' Jacobian at the optimum, ``σ²`` the residual variance per degree of freedom).
        None where no fit made it (a hand-built or drawn set of modes).
    f_std, zeta_std : ndarray, shape (n_modes,), or None
        Standard errors of ``f_n`` (Hz) and ``zeta`` (first order in the log parameters: ``f σ_ln f``);
        zero for the pseudo-modes, whose frequency and damping are fixed.
    shapes_std : ndarray, shape (n, n_modes), or None
        Standard errors of ``shapes``, 1/√kg. The pseudo-modes' shapes enter the model squared:
        where they are small the linearised errors of theirs are meaningless (far above their values).
    """

    f_n: np.ndarray
    zeta: np.ndarray
    shapes: np.ndarray
    n_residual: int
    rel_error: float
    cov: np.ndarray | None = None
    f_std: np.ndarray | None = None
    zeta_std: np.ndarray | None = None
    shapes_std: np.ndarray | None = None

    @property
    def params(self) -> np.ndarray:
        """The fit's parameter vector, shape (2 m + n m + n k,) for ``m`` fitted modes and ``k =
        n_residual``: ``[ln f_n, ln zeta, shapes (n, m) row-major, residual shapes (n, k) row-major]``
        over the fitted modes (the pseudo-modes' frequency and damping are fixed)."""
        k = self.n_residual
        return np.concatenate([np.log(self.f_n[k:]), np.log(self.zeta[k:]), self.shapes[:, k:].ravel(),
                               self.shapes[:, :k].ravel()])

    def with_params(self, params) -> "MatrixModes":
        """The same modes with :attr:`params` replaced (a draw from :attr:`cov`), mode order kept;
        no covariance or standard errors (they belong to the fit)."""
        params = np.asarray(params, float)
        k, (n, N) = self.n_residual, self.shapes.shape
        m = N - k
        if params.shape != (2 * m + n * N,):
            raise InputError(f"these modes have {2 * m + n * N} parameters, got shape {params.shape}")
        shapes = np.hstack([params[2 * m + n * m:].reshape(n, k), params[2 * m:2 * m + n * m].reshape(n, m)])
        return MatrixModes(np.concatenate([self.f_n[:k], np.exp(params[:m])]),
                           np.concatenate([self.zeta[:k], np.exp(params[m:2 * m])]), shapes, k, self.rel_error)


def _fit_covariance(sol, perm) -> np.ndarray:
    """``σ² (JᵀJ)⁺`` of a least-squares solution, rows and columns reordered by ``perm``.

    The pseudo-inverse drops the directions the residuals cannot see (singular values of ``J``
    below 1e-9 of the largest): the pseudo-modes share one frequency and damping, so only ``Vr Vrᵀ``
    of their shapes enters the model and turning ``Vr`` by an orthogonal matrix changes nothing.
    """
    J = np.asarray(sol.jac, float)
    _, s, vt = np.linalg.svd(J, full_matrices=False)
    keep = s > 1e-9 * s[0] if s.size and s[0] > 0 else np.zeros(s.shape, bool)
    dof = max(J.shape[0] - int(keep.sum()), 1)
    sigma2 = float(np.sum(sol.fun**2)) / dof
    cov = (vt[keep].T / s[keep]**2) @ vt[keep] * sigma2
    return cov[np.ix_(perm, perm)]


def _matrix_model(freq, f_n, zeta, V):
    """Accelerance ``−ω² Σ_r v_r v_rᵀ / (ω_r² − ω² + 2i ζ_r ω_r ω)``, shape (n_freq, n, n)."""
    w = 2 * np.pi * np.asarray(freq)[:, None]
    wr = 2 * np.pi * f_n[None]
    g = -w**2 / (wr**2 - w**2 + 2j * zeta[None] * wr * w)  # (n_freq, n_modes)
    return np.einsum("fr,ir,jr->fij", g, V, V)


def fit_modes_matrix(freq, accelerance, f_min: float = 2.0, f_max: float = 40.0, *, prominence: float = 0.01,
                     max_modes: int = 8) -> MatrixModes:
    """Fit real normal modes to a measured n × n accelerance matrix (:func:`fit_modes` for several axes).

    Peaks of the summed direct accelerances (prominence above ``prominence`` of the largest) start
    one mode each, its shape from the imaginary part of the receptance at the peak
    (``v vᵀ = −2 ζ ω² Im R(ω_r)`` for a lightly damped mode). Then every frequency, damping and shape
    is fitted together by least squares, with ``n`` pseudo-modes at :data:`RESIDUAL_HZ` for the
    modes above the band. Errors are relative to ``√(|H_ii| |H_jj|)``, which does not vanish at a
    cross entry's anti-resonance.

    Parameters
    ----------
    freq : array_like, shape (n_freq,), Hz
    accelerance : array_like, shape (n_freq, n, n), complex, m/s²/N
        Row the measured axis, column the excited one; reciprocity is assumed (the model is symmetric).
    """
    from scipy.optimize import least_squares

    freq = np.asarray(freq, float)
    H = np.asarray(accelerance, complex)
    if H.ndim != 3 or H.shape[1] != H.shape[2] or H.shape[0] != freq.shape[0] or freq.ndim != 1:
        raise InputError(f"the accelerance matrix must have shape (n_freq, n, n) beside freq (n_freq,); "
                         f"got {H.shape} and {freq.shape}")
    n = H.shape[1]
    _check_frf(freq, H[:, 0, 0], f_min, f_max)
    if not np.all(np.isfinite(H)):
        raise InputError("the FRF has NaN or infinite values")
    sel = (freq >= f_min) & (freq <= f_max)
    fq, h = freq[sel], H[sel]
    direct = np.abs(np.diagonal(h, axis1=1, axis2=2))  # (n_freq, n)
    scale = np.sqrt(direct[:, :, None] * direct[:, None, :])
    trace = direct.sum(1)
    peaks, _ = signal.find_peaks(trace, prominence=prominence * trace.max())
    if len(peaks) == 0:
        peaks = np.array([int(np.argmax(trace))])
    peaks = np.sort(peaks[np.argsort(trace[peaks])[::-1][:max_modes]])
    f0, z0, v0 = [], [], []
    for i in peaks:
        w = 2 * np.pi * fq[i]
        z = 0.03
        R = -h[i] / w**2
        lam, U = np.linalg.eigh(-2 * z * w**2 * 0.5 * (R.imag + R.imag.T))
        f0.append(fq[i])
        z0.append(z)
        v0.append(U[:, -1] * np.sqrt(max(lam[-1], 1e-12)))
    # pseudo-modes: the mass line left at the top of the band, split into n rank-one parts
    top = 0.5 * (h[-1].real + h[-1].real.T)
    lam, U = np.linalg.eigh(top)
    res0 = U * np.sqrt(np.clip(np.abs(lam), 1e-12 * max(abs(lam).max(), 1e-30), None))
    N = len(peaks)

    def unpack(p):
        lf, lz = p[:N], p[N:2 * N]
        V = p[2 * N:2 * N + n * N].reshape(n, N)
        Vr = p[2 * N + n * N:].reshape(n, n)
        return np.exp(lf), np.exp(lz), V, Vr

    fr, zr = np.full(n, RESIDUAL_HZ), np.full(n, RESIDUAL_ZETA)

    def resid(p):
        f, z, V, Vr = unpack(p)
        model = _matrix_model(fq, np.concatenate([fr, f]), np.concatenate([zr, z]), np.hstack([Vr, V]))
        e = (model - h) / scale
        return np.concatenate([e.real.ravel(), e.imag.ravel()])

    p0 = np.concatenate([np.log(f0), np.log(z0), np.array(v0).T.ravel(), res0.ravel()])
    sol = least_squares(resid, p0, method="lm", max_nfev=200 * len(p0))
    return _sorted_modes(sol, *unpack(sol.x), fr, zr)


def _sorted_modes(sol, f, z, V, Vr, fr, zr) -> MatrixModes:
    """:func:`fit_modes_matrix`'s result: the fitted modes sorted by frequency after the pseudo-modes
    (``fr``, ``zr``, shapes ``Vr``), with the solution's covariance in that order."""
    (n, N), order = V.shape, np.argsort(f)
    rms = float(np.sqrt(np.mean(sol.fun**2) * 2))
    # the solver's parameters [ln f, ln ζ, V, Vr] permuted into the order of MatrixModes.params
    perm = np.concatenate([order, N + order, 2 * N + np.arange(n * N).reshape(n, N)[:, order].ravel(),
                           2 * N + n * N + np.arange(n * n)])
    cov = _fit_covariance(sol, perm)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    f_s, z_s = f[order], z[order]
    return MatrixModes(np.concatenate([fr, f_s]), np.concatenate([zr, z_s]), np.hstack([Vr, V[:, order]]), n, rms,
                       cov=cov, f_std=np.concatenate([np.zeros(n), f_s * sd[:N]]),
                       zeta_std=np.concatenate([np.zeros(n), z_s * sd[N:2 * N]]),
                       shapes_std=np.hstack([sd[2 * N + n * N:].reshape(n, n), sd[2 * N:2 * N + n * N].reshape(n, N)]))


def plant_from_frf_matrix(freq, accelerance, masses, axes, *, f_min: float = 2.0, f_max: float = 40.0) -> Plant:
    """Multi-axis plant from a measured accelerance matrix and the reaction-mass hardware.

    :func:`fit_modes_matrix`, then :func:`~rmbench.control.plant.modal_plant`; the fit is in
    ``info["fit"]``: the fitted modes' ``f_n`` (Hz), ``zeta`` and their standard errors ``f_std``
    (Hz), ``zeta_std``, the relative error ``rel_error``, ``n_residual`` and ``cov``, the
    covariance of :attr:`MatrixModes.params` (nested lists, for drawing plants:
    :mod:`rmbench.control.robust`).
    """
    axes = parse_axes(axes)
    fit = fit_modes_matrix(freq, accelerance, f_min, f_max)
    p = modal_plant(fit.f_n, fit.zeta, fit.shapes, list(masses), axes, source="measured")
    k = fit.n_residual
    info = dict(p.info, fit={"f_n": fit.f_n[k:].tolist(), "zeta": fit.zeta[k:].tolist(),
                             "rel_error": fit.rel_error, "f_std": fit.f_std[k:].tolist(),
                             "zeta_std": fit.zeta_std[k:].tolist(), "n_residual": k, "cov": fit.cov.tolist()})
    return Plant(p.axes, p.A, p.B, p.C, p.D, p.source, p.mode_hz, info)
