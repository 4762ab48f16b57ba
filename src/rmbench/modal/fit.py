"""`ModalFit`: blind MDOF modal fitting of one band's 4x4 receptance matrix (METHODS §2).

Three steps, no human in the loop:

1. pLSCF poles at orders ``1..max_order``, a stabilisation diagram and automatic selection of the
   stable pole clusters (:mod:`rmbench.modal.plscf`, :mod:`rmbench.modal.stabilization`);
2. LSFD residues for those poles, split into ``φR φL^T`` by a rank-one SVD (initial values);
3. a nonlinear least-squares fit of all 16 FRFs together with shared poles, per-mode φR and φL
   (general non-symmetric case, ``φL[ref] = 1``) and optional residual terms, with an analytic
   Jacobian; standard errors from ``σ² (JᵀJ)⁻¹``.

Vocabulary: ``freq`` in Hz, ``omega`` and poles in rad/s, receptance in m/N, φR in s/kg.
"""

import warnings
from typing import Literal

import numpy as np
from scipy.special import fdtrc

from rmbench.errors import InputError, RmbenchError
from rmbench.modal import mdof
from rmbench.modal.plscf import plscf
from rmbench.modal.stabilization import StabilityCriteria, stabilize

__all__ = ["ModalFit", "ModalFitWarning", "NotFittedError", "PARAM_NAMES"]

PARAM_NAMES = ("f_n", "zeta",
               "phiL_1X_re", "phiL_1X_im", "phiL_1aX_re", "phiL_1aX_im", "phiL_1Y_re", "phiL_1Y_im",
               "phiR_1X_re", "phiR_1X_im", "phiR_1aX_re", "phiR_1aX_im", "phiR_1Y_re", "phiR_1Y_im",
               "phiR_1aY_re", "phiR_1aY_im")
"""The 16 per-mode parameters in DATA.md order (same as ``rmbench.robot.modes.PARAMS``)."""
COORDS = ("1X", "1Y", "1aX", "1aY")
_PHI_L_IDX = (0, 2, 1)      # coordinate index of the φL entries of PARAM_NAMES
_PHI_R_IDX = (0, 2, 1, 3)   # coordinate index of the φR entries
_COHERENCE_CAP = 0.99       # weight w² = γ²/(1 − γ²) is capped at 99
_REF_WARN = 0.05            # warn when |φL[ref]| < 5 % of the mode's largest |φL|
_SCAN_GRID = 120            # frequencies of the missing-mode scan across the band


class NotFittedError(RmbenchError, AttributeError):
    """A learned attribute or ``predict`` was used before ``fit``."""


class ModalFitWarning(UserWarning):
    """The fit ran but its result needs a look (no convergence, ill-chosen normalisation, ...)."""


class ModalFit:
    """Blind MDOF modal fit of one band of a 4x4 receptance matrix.

    Parameters
    ----------
    n_modes : int, optional
        Number of modes; ``None`` lets the stabilisation diagram decide (every cluster of stable
        poles present in at least 20 % of the orders). Given, the ``n_modes`` largest clusters.
    max_order : int
        Highest pLSCF polynomial order (each order has ``4 * order`` poles; 30 gives up to 60
        conjugate pairs, far more than a band holds, and the eigenvalue cost grows as order⁴).
    weighting : {"coherence", "magnitude", "uniform"}
        Weight of each FRF line in the nonlinear fit. ``"magnitude"``: each FRF divided by its RMS
        magnitude over the band, so that weak cross FRFs count as much as strong direct ones
        (right for noise proportional to each FRF's level). ``"coherence"``: the same times
        ``sqrt(γ²/(1 − γ²))`` with ``γ²`` capped at 0.99 (the inverse relative standard deviation
        of an H1 estimate); without coherence it is ``"magnitude"``. ``"uniform"``: no weights.
    residuals : bool
        Fit a lower residual ``−L_jk/ω²`` (1/kg) and an upper residual ``U_jk`` (m/N), both
        complex, per FRF entry, for the modes outside the band.
    ref : int or sequence of int
        Element of φL fixed to 1 (0..3 for 1X, 1Y, 1aX, 1aY; default 3 = 1aY, METHODS §2), for
        all modes or one per mode (then its length must equal the number of modes found).
    criteria : StabilityCriteria, optional
        Tolerances of the stabilisation diagram.
    max_iter : int
        Largest number of Levenberg–Marquardt iterations of the nonlinear fit.
    max_added : int
        Most modes the greedy step may add to those of the stabilisation diagram (modes that
        pLSCF merges, e.g. two heavily damped modes 2 % apart, are split by the nonlinear fit:
        a mode is added while it lowers the weighted cost significantly, F-test at
        ``p < 1e-6``, and stays physical and distinct).

    Attributes
    ----------
    poles_ : ndarray, shape (n_modes,), complex, rad/s
        One pole per conjugate pair, ``Im > 0``, sorted by frequency.
    f_n_ : ndarray, shape (n_modes,), Hz
    zeta_ : ndarray, shape (n_modes,)
    phi_r_ : ndarray, shape (n_modes, 4), complex, s/kg
    phi_l_ : ndarray, shape (n_modes, 4), complex
        ``phi_l_[r, refs_[r]] == 1``.
    ref_ : int or ndarray
        The ``ref`` used (as given).
    refs_ : ndarray, shape (n_modes,), int
        The normalisation element of each mode.
    params_, std_ : ndarray, shape (n_modes, 16)
        Parameters in :data:`PARAM_NAMES` order (f_n in Hz, φR in s/kg) and their standard errors.
        The φL entries are those of 1X, 1aX, 1Y; with ``ref != 3`` the fixed entry reads 1 ± 0 and
        φL at 1aY is only in ``phi_l_``.
    nmse_ : ndarray, shape (4, 4)
        ``Σ|H_model − H|² / Σ|H|²`` of each FRF over the band (a fraction, not %).
    residual_ : dict
        ``{"lower": (4, 4) complex 1/kg, "upper": (4, 4) complex m/N}``; empty without residuals.
    stabilization_ : Stabilization
        The stabilisation diagram and the selected poles.
    n_modes_ : int
    cost_ : float
        Half the weighted sum of squared errors at the solution.
    """

    def __init__(self, n_modes: int | None = None, max_order: int = 30,
                 weighting: Literal["coherence", "magnitude", "uniform"] = "coherence",
                 residuals: bool = True, *, ref=3, criteria: StabilityCriteria | None = None,
                 max_iter: int = 100, max_added: int = 4):
        self.n_modes = n_modes
        self.max_order = max_order
        self.weighting = weighting
        self.residuals = residuals
        self.ref = ref
        self.criteria = criteria
        self.max_iter = max_iter
        self.max_added = max_added

    def __getattr__(self, name):
        # only reached when normal lookup fails: a learned attribute before fit
        if name.endswith("_") and not name.startswith("_"):
            raise NotFittedError(f"this ModalFit is not fitted yet (no {name!r}); call "
                                 "fit(freq, H) first")
        raise AttributeError(name)

    def fit(self, freq, H, coherence=None) -> "ModalFit":
        """Fit the modes of one band.

        Parameters
        ----------
        freq : array_like, shape (n_freq,), Hz
            Uniformly spaced, positive, increasing lines of one band.
        H : array_like, shape (n_freq, 4, 4), complex, m/N
            Receptance, row = response, column = excitation, coordinates 1X, 1Y, 1aX, 1aY.
        coherence : array_like, shape (n_freq, 4, 4), optional
            Ordinary coherence of each FRF, in [0, 1].

        Returns
        -------
        ModalFit
            ``self``, fitted.

        Raises
        ------
        InputError
            Malformed input, or no stable poles in the band.
        """
        self._check_settings()
        freq, H, coherence = _check_data(freq, H, coherence)
        crit = self.criteria if self.criteria is not None else StabilityCriteria()
        W = _weights(H, coherence, self.weighting)
        orders = range(1, self.max_order + 1)
        w_out = np.sqrt(np.mean(W**2, axis=2))  # (n_freq, 4) per-output weight for pLSCF
        stab = stabilize(plscf(freq, H, orders, weights=w_out), (freq[0], freq[-1]),
                         criteria=crit, n_modes=self.n_modes)
        if len(stab.selected) == 0:
            raise InputError(f"no stable poles found in the band {freq[0]:g}-{freq[-1]:g} Hz "
                             f"(pLSCF orders 1-{self.max_order}): no modes to fit")
        if self.n_modes is not None and len(stab.selected) < self.n_modes:
            warnings.warn(f"asked for {self.n_modes} modes, the stabilisation diagram has "
                          f"{len(stab.selected)} clusters; fitting those", ModalFitWarning,
                          stacklevel=2)
        omega = 2 * np.pi * freq
        ws = float(np.mean(omega))
        hs = float(np.max(np.abs(H)))
        scaled = (omega / ws, H / hs, W)
        sol = self._solve(freq, H, scaled, stab.selected, ws, hs)
        sol = self._extend(freq, H, scaled, sol, ws, hs)
        n, refs = sol["n"], sol["refs"]
        if not sol["converged"]:
            warnings.warn("modal fit did not converge within max_iter iterations",
                          ModalFitWarning, stacklevel=2)
        lam, phi_r, phi_l, lower, upper = mdof._unpack(sol["x"], n, refs, self.residuals)
        cov = _covariance(sol["J"], sol["r"])

        # back to SI; one pole per pair with Im > 0, sorted by frequency
        flip = lam.imag < 0
        lam = np.where(flip, lam.conj(), lam) * ws
        phi_r = np.where(flip[:, None], phi_r.conj(), phi_r) * hs * ws
        phi_l = np.where(flip[:, None], phi_l.conj(), phi_l)
        params, std = _params(lam, phi_r, phi_l, cov, refs, flip, ws, hs)
        order = np.argsort(np.abs(lam))
        self.poles_ = lam[order]
        self.f_n_ = np.abs(self.poles_) / (2 * np.pi)
        self.zeta_ = -self.poles_.real / np.abs(self.poles_)
        self.phi_r_, self.phi_l_ = phi_r[order], phi_l[order]
        self.refs_ = refs[order]
        self.ref_ = self.ref
        self.params_, self.std_ = params[order], std[order]
        self.residual_ = ({"lower": lower * hs * ws**2, "upper": upper * hs}
                          if self.residuals else {})
        self.stabilization_ = stab
        self.n_modes_ = n
        self.cost_ = sol["cost"]
        err = np.sum(np.abs(self.predict(freq) - H) ** 2, axis=0)
        self.nmse_ = err / np.sum(np.abs(H) ** 2, axis=0)
        self._warn_outside(freq)
        self._warn_ref()
        return self

    def predict(self, freq) -> np.ndarray:
        """Model receptance including the residual terms.

        Parameters
        ----------
        freq : array_like, shape (n_freq,), Hz
            Positive frequencies.

        Returns
        -------
        ndarray, shape (n_freq, 4, 4), complex, m/N
        """
        poles = self.poles_  # NotFittedError before fit
        freq = np.asarray(freq, float)
        if freq.ndim != 1 or not np.all(np.isfinite(freq)) or np.any(freq <= 0):
            raise InputError(f"freq must be a 1-D array of positive finite Hz values, got shape "
                             f"{freq.shape}")
        H = mdof.synthesize(freq, poles, self.phi_r_, self.phi_l_)
        if self.residual_:
            omega = 2 * np.pi * freq
            H = H - self.residual_["lower"] / omega[:, None, None] ** 2 + self.residual_["upper"]
        return H

    # -- helpers ----------------------------------------------------------------------------
    def _solve(self, freq, H, scaled, poles, ws, hs, max_iter=None):
        """LSFD start and Levenberg–Marquardt fit for the given initial poles (rad/s)."""
        n = len(poles)
        refs = self._refs(n)
        res, lower, upper = mdof.lsfd(freq, H, poles, residuals=self.residuals)
        phi_r0, phi_l0 = _split_residues(res, refs)
        x0 = mdof._pack(poles / ws, phi_r0 / (hs * ws), phi_l0, lower / (hs * ws**2),
                        upper / hs, refs, self.residuals)
        args = scaled + (n, refs, self.residuals)
        x, r, J, ok = mdof.levenberg_marquardt(mdof._residual, mdof._jacobian, x0, args,
                                               max_iter=max_iter or self.max_iter)
        return {"x": x, "r": r, "J": J, "converged": ok, "n": n, "refs": refs,
                "cost": 0.5 * float(r @ r), "poles": (x[0::16][:n] + 1j * x[1::16][:n]) * ws}

    def _extend(self, freq, H, scaled, sol, ws, hs):
        """Add modes one at a time while the cost drops significantly (F-test)."""
        target = self.n_modes
        for _ in range(self.max_added if target is None else max(target - sol["n"], 0)):
            if target is not None and sol["n"] >= target:
                break
            if isinstance(self.ref, (list, tuple, np.ndarray)) and np.ndim(self.ref) == 1:
                break  # one ref per mode: the count is fixed by the caller
            lam = sol["poles"]
            cand, p_lin = _scan_missing(freq, H, scaled[2], lam, self.residuals)
            if target is None and p_lin > 1e-6:
                break  # no candidate explains a significant part of the error, even linearly
            if target is None and _at_edge(cand, freq):
                break  # the error is the tail of an out-of-band mode, which the residuals model
            best = self._solve(freq, H, scaled, np.append(lam, cand), ws, hs)
            m = len(best["r"])
            dof = m - len(best["x"])
            F = (sol["cost"] - best["cost"]) / 16 / (best["cost"] / dof)
            p = fdtrc(16, dof, F) if F > 0 else 1.0
            if target is None and (p > 1e-6 or not _physical_distinct(best["poles"], freq)):
                break
            sol = best
        return sol

    def _check_settings(self):
        if self.n_modes is not None and (not isinstance(self.n_modes, (int, np.integer))
                                         or self.n_modes < 1):
            raise InputError(f"n_modes must be a positive int or None, got {self.n_modes!r}")
        if not isinstance(self.max_order, (int, np.integer)) or self.max_order < 2:
            raise InputError(f"max_order must be an int >= 2, got {self.max_order!r}")
        if self.weighting not in ("coherence", "magnitude", "uniform"):
            raise InputError(f"weighting must be 'coherence', 'magnitude' or 'uniform', got "
                             f"{self.weighting!r}")
        ref = np.atleast_1d(np.asarray(self.ref))
        if ref.ndim != 1 or ref.dtype.kind not in "iu" or np.any((ref < 0) | (ref > 3)):
            raise InputError(f"ref must be an int 0..3 (1X, 1Y, 1aX, 1aY) or one per mode, got "
                             f"{self.ref!r}")

    def _refs(self, n: int) -> np.ndarray:
        ref = np.asarray(self.ref)
        if ref.ndim == 0:
            return np.full(n, int(ref))
        if len(ref) != n:
            raise InputError(f"ref has {len(ref)} entries but {n} modes were found; give one "
                             "int, or fix n_modes")
        return ref.astype(int)

    def _warn_outside(self, freq):
        out = (self.f_n_ < freq[0]) | (self.f_n_ > freq[-1]) | (self.zeta_ <= 0)
        if np.any(out):
            warnings.warn(f"fitted modes at {np.round(self.f_n_[out], 3).tolist()} Hz left the "
                          "band or have zeta <= 0", ModalFitWarning, stacklevel=3)

    def _warn_ref(self):
        big = np.abs(self.phi_l_).max(axis=1)
        bad = np.flatnonzero(1.0 < _REF_WARN * big)
        if len(bad):
            warnings.warn(f"phi_L[{COORDS[self.refs_[bad[0]]]}] is below {_REF_WARN:.0%} of the "
                          f"largest element for modes at {np.round(self.f_n_[bad], 3).tolist()} "
                          "Hz; their parameters are ill-conditioned, pass another ref",
                          ModalFitWarning, stacklevel=3)


def _check_data(freq, H, coherence):
    """Validate and convert the data of one band; return float/complex arrays."""
    freq = np.asarray(freq, dtype=float)
    if freq.ndim != 1 or len(freq) < 8:
        raise InputError(f"freq must be a 1-D array of at least 8 lines, got shape {freq.shape}")
    if not np.all(np.isfinite(freq)) or freq[0] <= 0:
        raise InputError("freq must be finite and positive (Hz)")
    df = np.diff(freq)
    if np.any(df <= 0) or np.ptp(df) > 1e-6 * np.mean(df):
        raise InputError("freq must be uniformly spaced and increasing")
    H = np.asarray(H)
    if H.ndim != 3:
        raise InputError(f"H must have shape (n_freq, 4, 4), got {H.shape}")
    if H.shape[1] != H.shape[2]:
        raise InputError(f"H must be a square matrix per line (n_freq, 4, 4), got {H.shape}")
    if H.shape[1:] != (4, 4):
        raise InputError(f"H must be 4x4 per line (1X, 1Y, 1aX, 1aY), got {H.shape}")
    if H.shape[0] != len(freq):
        raise InputError(f"H has {H.shape[0]} lines but freq has {len(freq)}")
    H = H.astype(complex)
    if not np.all(np.isfinite(H)):
        raise InputError(f"H has {np.count_nonzero(~np.isfinite(H))} NaN or infinite values")
    zero = np.all(H == 0, axis=0)
    if np.all(zero):
        raise InputError("H is all zeros")
    if np.any(zero):
        j, k = np.argwhere(zero)[0]
        raise InputError(f"FRF H[{COORDS[j]}, {COORDS[k]}] is all zeros")
    if coherence is not None:
        coherence = np.asarray(coherence, dtype=float)
        if coherence.shape != H.shape:
            raise InputError(f"coherence must have the shape of H {H.shape}, got "
                             f"{coherence.shape}")
        if not np.all(np.isfinite(coherence)) or np.any((coherence < 0) | (coherence > 1)):
            raise InputError("coherence must be finite and within [0, 1]")
    if 2 * H.size < 16 * 2:
        raise InputError("too few lines to fit")
    return freq, H, coherence


def _weights(H, coherence, weighting):
    """Real weights of each FRF line, shape (n_freq, 4, 4), relative to the scaled H."""
    if weighting == "uniform":
        return np.ones(H.shape)
    level = np.sqrt(np.mean(np.abs(H) ** 2, axis=0))
    W = np.broadcast_to(level.max() / level, H.shape).copy()
    if weighting == "coherence" and coherence is not None:
        c = np.minimum(coherence, _COHERENCE_CAP)
        W *= np.sqrt(c / (1 - c))
    return W


def _split_residues(res, refs):
    """Rank-one split ``R_r ≈ φR φL^T`` with ``φL[ref] = 1`` (SVD)."""
    n = len(res)
    phi_r = np.empty((n, res.shape[1]), complex)
    phi_l = np.empty((n, res.shape[2]), complex)
    for r in range(n):
        U, s, Vh = np.linalg.svd(res[r])
        v = Vh[0]
        piv = v[refs[r]] if abs(v[refs[r]]) > 1e-6 * np.abs(v).max() else np.abs(v).max()
        phi_l[r] = v / piv
        phi_r[r] = s[0] * U[:, 0] * piv
    return phi_r, phi_l


def _covariance(J, r):
    """``σ² (JᵀJ)⁻¹`` with ``σ²`` the residual variance (pseudo-inverse, column-scaled eigh).

    The eigen-decomposition of the scaled normal matrix costs a fraction of an SVD of the tall
    ``J``; scaling the columns to unit norm first keeps its conditioning that of ``J`` squared
    only within the parameters' own spread, well inside double precision here.
    """
    m, n = J.shape
    sigma2 = float(r @ r) / max(m - n, 1)
    d = np.linalg.norm(J, axis=0)
    d = np.where(d > 0, d, 1.0)
    Js = J / d
    w, V = np.linalg.eigh(Js.T @ Js)
    inv = np.where(w > w[-1] * 1e-24, 1 / np.where(w > 0, w, 1.0), 0.0)
    return sigma2 * ((V * inv) @ V.T) / np.outer(d, d)


def _params(lam, phi_r, phi_l, cov, refs, flip, ws, hs):
    """Parameters in PARAM_NAMES order and their standard errors (delta method)."""
    n = len(lam)
    params = np.zeros((n, 16))
    std = np.zeros((n, 16))
    var = np.diag(cov)
    for r in range(n):
        b = 16 * r
        sig, wd = lam[r].real, lam[r].imag
        mag = abs(lam[r])
        params[r, 0] = mag / (2 * np.pi)
        params[r, 1] = -sig / mag
        # (σ, ω_d) in scaled units; conjugating flips the sign of ω_d only
        # d(f_n, ζ)/d(σ', ω') with σ = ws σ', ω_d = ws ω' (scaled fit variables)
        g = ws * np.array([[sig / (2 * np.pi * mag), wd / (2 * np.pi * mag)],
                           [-(wd**2) / mag**3, sig * wd / mag**3]])
        if flip[r]:
            g[:, 1] *= -1
        c2 = cov[b:b + 2, b:b + 2]
        std[r, :2] = np.sqrt(np.maximum(np.diag(g @ c2 @ g.T), 0))
        free = [i for i in range(4) if i != refs[r]]
        for t, i in enumerate(_PHI_L_IDX):
            params[r, 2 + 2 * t] = phi_l[r, i].real
            params[r, 3 + 2 * t] = phi_l[r, i].imag
            if i in free:
                q = free.index(i)
                std[r, 2 + 2 * t] = np.sqrt(max(var[b + 10 + q], 0))
                std[r, 3 + 2 * t] = np.sqrt(max(var[b + 13 + q], 0))
        for t, i in enumerate(_PHI_R_IDX):
            params[r, 8 + 2 * t] = phi_r[r, i].real
            params[r, 9 + 2 * t] = phi_r[r, i].imag
            std[r, 8 + 2 * t] = np.sqrt(max(var[b + 2 + i], 0)) * hs * ws
            std[r, 9 + 2 * t] = np.sqrt(max(var[b + 6 + i], 0)) * hs * ws
    return params, std


def _scan_missing(freq, H, W, lam, residuals, n_grid=_SCAN_GRID, zetas=(0.005, 0.015, 0.04, 0.1)):
    """The pole on a (frequency, damping) grid whose LSFD column pair best explains the error.

    Returns the candidate pole (rad/s) and the p-value of its F-test (linear model, 32 extra
    parameters: one complex residue per FRF).

    With the current poles fixed, the data are projected off their LSFD basis; each candidate's
    two real basis columns are projected the same way, and the candidate whose columns capture
    the most of the remaining (per-FRF weighted) error wins. Linear algebra only, no refit.
    """
    omega = 2 * np.pi * freq
    level = W.mean(axis=0).ravel()  # per-FRF weights (the pointwise coherence part is ignored)

    def basis(poles):
        g = 1 / (1j * omega[:, None] - poles)
        gc = 1 / (1j * omega[:, None] - poles.conj())
        return g + gc, 1j * (g - gc)

    cols = list(basis(lam))
    if residuals:
        cols.append(mdof.residual_basis(omega))
    A = np.concatenate(cols, axis=1)
    A = np.concatenate([A.real, A.imag])
    Q, _ = np.linalg.qr(A / np.linalg.norm(A, axis=0))
    b = H.reshape(len(freq), -1) * level
    b = np.concatenate([b.real, b.imag])
    r0 = b - Q @ (Q.T @ b)
    f = np.linspace(freq[0], freq[-1], n_grid + 2)[1:-1]
    z = np.asarray(zetas)
    wn = 2 * np.pi * np.repeat(f, len(z))
    zz = np.tile(z, len(f))
    cand = -zz * wn + 1j * wn * np.sqrt(1 - zz**2)
    c1, c2 = basis(cand)
    C = np.stack([np.concatenate([c1.real, c1.imag]), np.concatenate([c2.real, c2.imag])], -1)
    C = C - np.einsum("nk,kcj->ncj", Q, np.einsum("nk,ncj->kcj", Q, C))  # (2 n_f, n_cand, 2)
    G = np.einsum("ncj,nci->cji", C, C)               # (n_cand, 2, 2)
    P = np.einsum("ncj,ne->cje", C, r0)              # (n_cand, 2, n_entries)
    sol = np.linalg.solve(G + 1e-300, P)
    gain = np.einsum("cje,cje->c", P, sol)
    best = int(np.argmax(gain))
    n_e = b.shape[1]
    dof = b.size - n_e * (Q.shape[1] + 2)
    rest = float(np.sum(r0**2)) - gain[best]
    F = (gain[best] / (2 * n_e)) / (rest / dof) if rest > 0 else np.inf
    return cand[best], float(fdtrc(2 * n_e, dof, F))


def _at_edge(pole, freq, n_grid=_SCAN_GRID) -> bool:
    """Whether a scanned candidate pole lies on the first or last frequency of the scan grid."""
    step = (freq[-1] - freq[0]) / (n_grid + 1)
    f = abs(pole) / (2 * np.pi)
    return bool(min(f - freq[0], freq[-1] - f) < 1.5 * step)


def _physical_distinct(lam, freq, zeta_max=0.3, min_distance=0.005):
    """All poles inside the band with ``0 < ζ < zeta_max`` and no two within ``min_distance``."""
    lam = np.where(lam.imag < 0, lam.conj(), lam)
    f, z = np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam)
    if np.any((f < freq[0]) | (f > freq[-1]) | (z <= 0) | (z >= zeta_max)):
        return False
    d = np.abs(lam[:, None] - lam[None, :]) / np.abs(lam)[:, None]
    return bool(np.all(d[np.triu_indices(len(lam), 1)] > min_distance))
