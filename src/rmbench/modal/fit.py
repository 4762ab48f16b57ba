"""`ModalFit`: blind MDOF modal fitting of one band's 4x4 receptance matrix (METHODS §2).

Three steps, no human in the loop:

1. pLSCF poles at orders ``1..max_order``, a stabilisation diagram and automatic selection of the
   stable pole clusters (:mod:`rmbench.modal.plscf`, :mod:`rmbench.modal.stabilization`);
2. a nonlinear least-squares fit of all 16 FRFs together with shared poles, per-mode φR and φL
   (general non-symmetric case, ``φL[ref] = 1``) and optional residual terms, by variable
   projection from LSFD starting values, inside a model-order selection that merges, adds and
   removes poles by the information criterion (:mod:`rmbench.modal._select`);
3. standard errors from ``σ² (JᵀJ)⁻¹`` of the full problem (:mod:`rmbench.modal._uncertainty`),
   per-mode evidence and the band's verdict (:mod:`rmbench.modal.quality`): a failed fit says so
   (``fit_ok_``, ``fit_reason_``, a :class:`ModalFitWarning` naming the modes).

A fitted band describes itself: :meth:`ModalFit.summary`, :meth:`ModalFit.to_dict`,
:meth:`ModalFit.plot`.

Vocabulary: ``freq`` in Hz, ``omega`` and poles in rad/s, receptance in m/N, φR in s/kg.
"""

import warnings
from typing import Literal

import numpy as np

from rmbench.errors import InputError, RmbenchError
from rmbench.io.strict_json import jsonable
from rmbench.modal import mdof
from rmbench.modal._select import SelectionSettings, select_modes
from rmbench.modal._uncertainty import covariance, mac_losses, parameters, renormalisation
from rmbench.modal._varpro import Problem
from rmbench.modal.plscf import plscf
from rmbench.modal.quality import QualityCriteria, assess
from rmbench.modal.stabilization import StabilityCriteria, stabilize

__all__ = ["ModalFit", "ModalFitWarning", "NotFittedError", "PARAM_NAMES", "fit_weights"]

PARAM_NAMES = ("f_n", "zeta",
               "phiL_1X_re", "phiL_1X_im", "phiL_1aX_re", "phiL_1aX_im", "phiL_1Y_re", "phiL_1Y_im",
               "phiR_1X_re", "phiR_1X_im", "phiR_1aX_re", "phiR_1aX_im", "phiR_1Y_re", "phiR_1Y_im",
               "phiR_1aY_re", "phiR_1aY_im")
"""The 16 per-mode parameters in DATA.md order (same as ``rmbench.robot.modes.PARAMS``)."""
COORDS = ("1X", "1Y", "1aX", "1aY")
_COHERENCE_CAP = 0.99       # weight w² = γ²/(1 − γ²) is capped at 99
_REF_WARN = 0.05            # warn when |φL[ref]| < 5 % of the mode's largest |φL|


class NotFittedError(RmbenchError, AttributeError):
    """A learned attribute or ``predict`` was used before ``fit``."""


class ModalFitWarning(UserWarning):
    """The fit ran but its result needs a look (no convergence, ill-chosen normalisation, ...)."""


class ModalFit:
    """Blind MDOF modal fit of one band of a 4x4 receptance matrix.

    Parameters
    ----------
    n_modes : int, optional
        Number of modes; ``None`` lets the data decide (stabilisation diagram, then poles merged,
        added and removed by the information criterion). Given, exactly ``n_modes`` modes: the
        largest stabilisation clusters, then poles added or removed to reach the count.
    max_order : int
        Highest pLSCF polynomial order (each order has ``4 * order`` poles; 20 gives up to 40
        conjugate pairs, more than a band holds; the eigenvalue cost of the diagram grows as
        order⁴, and the selection adds what the diagram misses).
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
        Largest number of Levenberg–Marquardt iterations of each nonlinear fit.
    max_added : int
        Most poles the residual scan may add to those of the stabilisation diagram (modes that
        pLSCF misses or merges, e.g. two heavily damped modes 2 % apart). When more seem to be
        needed the fit is flagged.
    quality : QualityCriteria, optional
        The accuracy a mode's standard errors must support for the fit to be ``fit_ok_``.

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
    outside_ : dict
        Out-of-band poles the model needed for the tails of modes just outside the band:
        ``{"poles": (k,) complex rad/s, "phi_r": (k, 4) s/kg, "phi_l": (k, 4)}`` (k may be 0).
        Part of :meth:`predict`, not modes of the band.
    stabilization_ : Stabilization
        The stabilisation diagram and the selected poles.
    n_modes_ : int
    cost_ : float
        Half the weighted sum of squared errors at the solution.
    fit_ok_ : bool
        False when the fit should not be trusted without a look (:mod:`rmbench.modal.quality`).
    fit_reason_ : str
        One line naming what is wrong and where ("" when ``fit_ok_``).
    quality_ : FitQuality
        The verdict with per-mode evidence (stable orders, share of the reconstruction, the
        information criterion's case for each mode, standard errors) and notes on merged or
        dropped poles.
    """

    def __init__(self, n_modes: int | None = None, max_order: int = 20,
                 weighting: Literal["coherence", "magnitude", "uniform"] = "coherence",
                 residuals: bool = True, *, ref=3, criteria: StabilityCriteria | None = None,
                 max_iter: int = 100, max_added: int = 12,
                 quality: QualityCriteria | None = None):
        self.n_modes = n_modes
        self.max_order = max_order
        self.weighting = weighting
        self.residuals = residuals
        self.ref = ref
        self.criteria = criteria
        self.max_iter = max_iter
        self.max_added = max_added
        self.quality = quality

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
            ``self``, fitted. A fit that ran but should not be trusted has ``fit_ok_`` False and
            warns (:class:`ModalFitWarning`).

        Raises
        ------
        InputError
            Malformed input, or no modes in the band.
        """
        self._check_settings()
        freq, H, coherence = _check_data(freq, H, coherence)
        crit = self.criteria if self.criteria is not None else StabilityCriteria()
        W = fit_weights(H, coherence, self.weighting)
        stab, problem, sel, ws, hs = self._select_poles(freq, H, W, crit)
        n_band = int(sel.in_band.sum())
        if self.n_modes is not None and n_band < self.n_modes:
            warnings.warn(f"asked for {self.n_modes} modes, the data gave {n_band}; fitting "
                          "those", ModalFitWarning, stacklevel=2)
        band, mac_loss = self._store(problem, sel, n_band, ws, hs)
        self.stabilization_ = stab
        model = self.predict(freq)
        err = np.sum(np.abs(model - H) ** 2, axis=0)
        self.nmse_ = err / np.sum(np.abs(H) ** 2, axis=0)
        self.quality_ = assess(
            sel, sel.delta_bic[band], self.std_, self.params_, mac_loss[band],
            _stable_orders(stab, self.poles_), _shares(freq, self, W),
            _residual_correlation(W * (model - H)), sel.sol.converged,
            self.quality if self.quality is not None else QualityCriteria(),
            (freq[0], freq[-1]), self.outside_["poles"])
        self.fit_ok_ = self.quality_.ok
        self.fit_reason_ = self.quality_.reason
        if not self.fit_ok_:
            warnings.warn(f"modal fit of {freq[0]:g}-{freq[-1]:g} Hz needs a look: "
                          f"{self.fit_reason_}", ModalFitWarning, stacklevel=2)
        self._warn_ref()
        return self

    def _select_poles(self, freq, H, W, crit: StabilityCriteria):
        """Steps 1 and 2: the stabilisation diagram and the model-order selection on the band's
        scaled problem, ``(stab, problem, selection, ws, hs)`` with ws (rad/s) and hs (m/N) the
        scales of frequency and receptance; raises when no mode is left in the band."""
        orders = range(1, self.max_order + 1)
        w_out = np.sqrt(np.mean(W**2, axis=2))  # (n_freq, 4) per-output weight for pLSCF
        stab = stabilize(plscf(freq, H, orders, weights=w_out), (freq[0], freq[-1]),
                         criteria=crit, n_modes=self.n_modes)
        omega = 2 * np.pi * freq
        ws = float(np.mean(omega))
        hs = float(np.max(np.abs(H)))
        problem = Problem(omega / ws, H / hs, W, self.residuals)
        settings = SelectionSettings(zeta_max=crit.zeta_max, max_added=self.max_added,
                                     max_iter=self.max_iter)
        sel = select_modes(problem, freq, ws, stab.selected, stab.weak, n_modes=self.n_modes,
                           settings=settings)
        if sel.sol is None or not sel.in_band.any():
            raise InputError(f"no modes found in the band {freq[0]:g}-{freq[-1]:g} Hz: "
                             f"{len(stab.selected)} stable poles in pLSCF orders "
                             f"1-{self.max_order}, and no pole lowers the information criterion "
                             "of the fit")
        return stab, problem, sel, ws, hs

    def _store(self, problem: Problem, sel, n_band: int, ws: float, hs: float):
        """The selection's solution in SI and the user's normalisation, as the learnt attributes
        (modes, out-of-band poles, residual terms, parameters and standard errors, cost);
        returns the band modes' indices into the solution and every pole's MAC loss."""
        sol = sel.sol
        phi_r, phi_l, refs, cov, mac_loss, r = self._normalised(problem, sol, sel, n_band)
        lam = sol.lam
        # back to SI; one pole per pair with Im > 0, sorted by frequency
        flip = lam.imag < 0
        lam = np.where(flip, lam.conj(), lam) * ws
        phi_r = np.where(flip[:, None], phi_r.conj(), phi_r) * hs * ws
        phi_l = np.where(flip[:, None], phi_l.conj(), phi_l)
        params, std = parameters(lam, phi_r, phi_l, cov, refs, flip, ws, hs)
        order = np.argsort(np.abs(lam))
        band = order[sel.in_band[order]]
        outside = order[~sel.in_band[order]]
        self.poles_ = lam[band]
        self.f_n_ = np.abs(self.poles_) / (2 * np.pi)
        self.zeta_ = -self.poles_.real / np.abs(self.poles_)
        self.phi_r_, self.phi_l_ = phi_r[band], phi_l[band]
        self.refs_ = refs[band]
        self.ref_ = self.ref
        self.params_, self.std_ = params[band], std[band]
        self.residual_ = ({"lower": sol.lower * hs * ws**2, "upper": sol.upper * hs}
                          if self.residuals else {})
        self.outside_ = {"poles": lam[outside], "phi_r": phi_r[outside], "phi_l": phi_l[outside]}
        self.n_modes_ = n_band
        self.cost_ = 0.5 * float(r @ r)
        return band, mac_loss

    def _normalised(self, problem: Problem, sol, sel, n_band: int):
        """The solution's eigenvectors in the user's φL normalisation, with the parameters'
        covariance there: ``(phi_r, phi_l, refs, cov, mac_loss, r)``, r the weighted residual.

        The fit normalised each φL on its largest element (best conditioned), which is also where
        the eigenvector's standard errors are judged (``mac_loss``); the parameters are reported
        with the user's normalisation, φR rescaled so that the model is unchanged.
        """
        args = (problem.omega, problem.H, problem.W, sol.n)
        x = mdof._pack(sol.lam, sol.phi_r, sol.phi_l, sol.lower, sol.upper, sol.refs,
                       self.residuals)
        r = mdof._residual(x, *args, sol.refs, self.residuals)
        cov_fit = covariance(mdof._jacobian(x, *args, sol.refs, self.residuals), r)
        mac_loss = mac_losses(cov_fit, sol)
        refs = np.full(sol.n, int(self.ref) if np.ndim(self.ref) == 0 else 3)
        if np.ndim(self.ref) == 1:
            refs[sel.in_band] = self._refs(n_band)
        piv = sol.phi_l[np.arange(sol.n), refs]
        if np.all(np.abs(piv) > 0):
            # the user's normalisation is a smooth reparametrisation of the fit's: its covariance
            # is the fit's carried through the change of variables (T C Tᵀ), to rounding what a
            # second Jacobian there would give, at a fraction of the cost
            T = renormalisation(sol.phi_r, sol.phi_l, sol.refs, refs, len(x))
            cov = T @ cov_fit @ T.T
        piv = np.where(np.abs(piv) > 0, piv, 1.0)
        phi_l, phi_r = sol.phi_l / piv[:, None], sol.phi_r * piv[:, None]
        phi_l[np.arange(sol.n), refs] = 1.0  # exactly, not to rounding
        if not np.all(np.abs(sol.phi_l[np.arange(sol.n), refs]) > 0):
            # a zero reference entry: no change of variables reaches that normalisation; the
            # covariance at the forced one
            x = mdof._pack(sol.lam, phi_r, phi_l, sol.lower, sol.upper, refs, self.residuals)
            cov = covariance(mdof._jacobian(x, *args, refs, self.residuals), r)
        return phi_r, phi_l, refs, cov, mac_loss, r

    def predict(self, freq) -> np.ndarray:
        """Model receptance including the out-of-band poles and the residual terms.

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
        if len(self.outside_["poles"]):
            H = H + mdof.synthesize(freq, self.outside_["poles"], self.outside_["phi_r"],
                                    self.outside_["phi_l"])
        if self.residual_:
            omega = 2 * np.pi * freq
            H = H - self.residual_["lower"] / omega[:, None, None] ** 2 + self.residual_["upper"]
        return H

    # -- what the fit is -------------------------------------------------------------------
    def summary(self) -> str:
        """A few readable lines: the modes' natural frequencies (Hz), the verdict and the notes
        the verdict does not already say."""
        lines = [f"{self.n_modes_} modes at {', '.join(f'{f:.2f}' for f in self.f_n_)} Hz; "
                 + ("fit ok" if self.fit_ok_ else f"needs a look: {self.fit_reason_}")]
        lines += [f"  note: {note}" for note in self.quality_.notes if note not in self.fit_reason_]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """Strict JSON types: the verdict (``fit_ok``, ``fit_reason``, ``notes``), each band mode's
        f_n (Hz), ζ, their standard errors, evidence, φL and φR (``[re, im]`` per coordinate),
        the out-of-band poles' frequencies (Hz), the NMSE per FRF (a fraction) and ``units``."""
        ev = self.quality_.evidence
        modes = [{"f_n": self.f_n_[r], "zeta": self.zeta_[r], "f_n_std": self.std_[r, 0],
                  "zeta_std": self.std_[r, 1], "uncertain": ev.uncertain[r], "delta_bic": ev.delta_bic[r],
                  "share": ev.share[r], "stable_orders": ev.n_orders[r], "source": ev.source[r],
                  "phiL": {c: [v.real, v.imag] for c, v in zip(COORDS, self.phi_l_[r])},
                  "phiR": {c: [v.real, v.imag] for c, v in zip(COORDS, self.phi_r_[r])}}
                 for r in range(self.n_modes_)]
        return jsonable({"fit_ok": self.fit_ok_, "fit_reason": self.fit_reason_, "notes": list(self.quality_.notes),
                         "modes": modes, "outside_f": np.abs(self.outside_["poles"]) / (2 * np.pi),
                         "nmse": self.nmse_, "residual_correlation": self.quality_.residual_correlation,
                         "units": {"f_n": "Hz", "zeta": "ratio", "phiR": "s/kg", "phiL": "1",
                                   "outside_f": "Hz", "nmse": "fraction"}})

    def plot(self, ax=None, *, freq=None, H=None):
        """The band's stabilisation diagram with the fitted modes and the verdict
        (:func:`~rmbench.modal.plot.plot_stabilisation`); ``freq`` (Hz) and ``H`` (m/N), the
        measured receptance, draw it under the diagram. Returns the matplotlib Axes (``ax`` or a
        new figure's)."""
        from rmbench.modal.plot import plot_stabilisation

        return plot_stabilisation(self, ax, freq=freq, H=H)

    # -- helpers ----------------------------------------------------------------------------
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


def fit_weights(H, coherence=None, weighting: Literal["coherence", "magnitude", "uniform"] = "coherence"
                ) -> np.ndarray:
    """Weight of each FRF line in the nonlinear fit: :class:`ModalFit`'s ``weighting`` rule.

    Parameters
    ----------
    H : ndarray, shape (n_freq, 4, 4), complex, m/N
        Receptance of one band (any common scale: only ratios between FRFs matter).
    coherence : ndarray, shape (n_freq, 4, 4), optional
        Ordinary coherence of each FRF, in [0, 1]; only ``"coherence"`` reads it.
    weighting : {"coherence", "magnitude", "uniform"}
        ``"uniform"``: all ones. ``"magnitude"``: each FRF divided by its RMS magnitude over the
        band, times the largest RMS (the strongest FRF weighs 1). ``"coherence"``: the same times
        ``sqrt(γ²/(1 − γ²))``, ``γ²`` capped at 0.99; without coherence, ``"magnitude"``.

    Returns
    -------
    ndarray, shape (n_freq, 4, 4), float
        Real weights multiplying each line's complex error (dimensionless).
    """
    if weighting == "uniform":
        return np.ones(H.shape)
    level = np.sqrt(np.mean(np.abs(H) ** 2, axis=0))
    W = np.broadcast_to(level.max() / level, H.shape).copy()
    if weighting == "coherence" and coherence is not None:
        c = np.minimum(coherence, _COHERENCE_CAP)
        W *= np.sqrt(c / (1 - c))
    return W


def _stable_orders(stab, poles):
    """Stable orders of the stabilisation cluster each fitted pole came from (0 for none).

    A fitted pole belongs to the selected cluster whose median pole is within 1 % of it.
    """
    out = np.zeros(len(poles), int)
    for r, lam in enumerate(poles):
        if len(stab.selected):
            d = np.abs(stab.selected - lam) / np.abs(lam)
            i = int(np.argmin(d))
            if d[i] < 0.01:
                out[r] = stab.n_orders[i]
    return out


def _shares(freq, fit, W):
    """Each mode's share of the weighted energy of the fitted modes in the band."""
    total = mdof.synthesize(freq, fit.poles_, fit.phi_r_, fit.phi_l_)
    e_total = float(np.sum(np.abs(W * total) ** 2))
    out = np.empty(len(fit.poles_))
    for r in range(len(out)):
        h = mdof.synthesize(freq, fit.poles_[r:r + 1], fit.phi_r_[r:r + 1], fit.phi_l_[r:r + 1])
        out[r] = float(np.sum(np.abs(W * h) ** 2)) / e_total if e_total > 0 else 0.0
    return out


def _residual_correlation(e):
    """Mean over FRFs of the lag-1 autocorrelation of the residual ``e`` (n_freq, 4, 4)."""
    num = np.real(np.sum(e[:-1].conj() * e[1:], axis=0))
    den = np.sum(np.abs(e) ** 2, axis=0)
    return float(np.mean(num / np.where(den > 0, den, 1.0)))
