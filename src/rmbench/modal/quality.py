"""Does a band's modal fit know what it is worth: per-mode evidence and the band's verdict.

A fit is flagged (``ok = False``, with a one-line reason naming the modes) when

- a mode's standard errors do not support the accuracy asked of it: ``n_sigma`` standard errors
  of the natural frequency exceed ``f_tol`` of it, of the damping ratio ``zeta_tol`` of it, or the
  MAC that the eigenvectors' standard errors allow at the same confidence falls below ``mac_min``;
- two close poles with alike shapes were both kept because the data need both (one mode split in
  two, or two modes the band cannot separate);
- the add move hit its cap with significant structure left in the residual;
- the optimiser did not converge, or a mode left the band.

Notes, not failures: poles merged into one mode and poles dropped as unneeded (the merged model is
the one the data support), out-of-band poles, and residual structure that only an unphysical pole
would take (smooth non-modal error, a sensor's or the estimator's, does that).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["QualityCriteria", "ModeEvidence", "FitQuality"]


@dataclass(frozen=True)
class QualityCriteria:
    """The accuracy a fitted mode must be known to, and how many standard errors make it known.

    Attributes
    ----------
    f_tol : float
        Relative accuracy of the natural frequency.
    zeta_tol : float
        Relative accuracy of the damping ratio.
    mac_min : float
        MAC that the fitted φR and φL must keep with the true ones.
    n_sigma : float
        A mode is uncertain when ``n_sigma`` standard errors exceed a tolerance.
    """

    f_tol: float = 0.005
    zeta_tol: float = 0.10
    mac_min: float = 0.98
    n_sigma: float = 2.0

    def __post_init__(self):
        for name in ("f_tol", "zeta_tol", "n_sigma"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)!r}")
        if not 0 < self.mac_min < 1:
            raise ValueError(f"mac_min must lie in (0, 1), got {self.mac_min!r}")


@dataclass(frozen=True)
class ModeEvidence:
    """Why each fitted mode is believed (arrays of shape (n_modes,), modes by frequency).

    Attributes
    ----------
    f_n : ndarray, Hz
    n_orders : ndarray, int
        Model orders at which its stabilisation cluster held a stable pole (0 when the mode was
        added by the residual scan or came from a merge).
    source : tuple of str
        ``"stabilisation"``, ``"scan"`` or ``"merged"``.
    share : ndarray
        Its share of the fitted model's weighted energy in the band (the modes' shares need not
        add to 1: modes interfere).
    delta_bic : ndarray
        How much the information criterion rises when the mode is removed with the others held
        (larger is stronger evidence; the penalty of one mode is ``16 ln m``).
    f_std_rel, zeta_std_rel : ndarray
        Standard errors of the natural frequency and the damping ratio, relative.
    mac_loss : ndarray
        ``1 − MAC`` that the standard errors of φR and φL allow (the larger of the two), at one
        standard error.
    uncertain : ndarray, bool
        ``n_sigma`` standard errors exceed a tolerance of :class:`QualityCriteria`.
    """

    f_n: np.ndarray
    n_orders: np.ndarray
    source: tuple
    share: np.ndarray
    delta_bic: np.ndarray
    f_std_rel: np.ndarray
    zeta_std_rel: np.ndarray
    mac_loss: np.ndarray
    uncertain: np.ndarray

    def __post_init__(self):
        n = len(self.f_n)
        for name in ("n_orders", "source", "share", "delta_bic", "f_std_rel", "zeta_std_rel",
                     "mac_loss", "uncertain"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"{name} must have one entry per mode ({n})")


@dataclass(frozen=True)
class FitQuality:
    """The verdict on one band's fit.

    Attributes
    ----------
    ok : bool
        False when the fit should not be trusted without a look (see the module docstring).
    reason : str
        One line naming what is wrong and where ("" when ok).
    notes : tuple of str
        Everything worth knowing, failures and harmless changes alike (merges, dropped poles),
        one sentence each, naming the modes by frequency.
    evidence : ModeEvidence
    residual_correlation : float
        Lag-1 autocorrelation of the weighted residual along frequency, averaged over the FRFs
        (about 0 for white noise; near 1 when structure is left, or when the measurement error
        itself is smooth, as a mis-scaled sensor's is).
    """

    ok: bool
    reason: str
    notes: tuple
    evidence: ModeEvidence
    residual_correlation: float

    def __post_init__(self):
        if self.ok and self.reason:
            raise ValueError("a fit that is ok has no reason")
        if not self.ok and not self.reason:
            raise ValueError("a fit that is not ok needs a reason")


def assess(selection, delta_bic, std, params, mac_loss, stab_orders, share, corr, converged,
           criteria: QualityCriteria, f_band, outside) -> FitQuality:
    """Evidence and verdict of a fitted band (used by :class:`~rmbench.modal.ModalFit`).

    Parameters
    ----------
    selection : rmbench.modal._select.Selection
    delta_bic : ndarray, shape (n,)
        The information criterion's case for each band mode.
    std, params : ndarray, shape (n, 16)
        Parameters (PARAM_NAMES order) and standard errors, SI.
    mac_loss : ndarray, shape (n,)
        ``1 − MAC`` that the eigenvectors' standard errors allow (mean), the larger of φR, φL.
    stab_orders : ndarray, shape (n,), int
        Stable orders of each mode's stabilisation cluster (0 for none).
    share : ndarray, shape (n,)
    corr : float
        Lag-1 residual autocorrelation.
    converged : bool
    criteria : QualityCriteria
    f_band : (float, float), Hz
    outside : ndarray, complex, rad/s
        Out-of-band poles of the model.
    """
    evidence = _evidence(selection, delta_bic, std, params, mac_loss, stab_orders, share, criteria)
    fail = _failures(evidence, params[:, 1], selection, converged, criteria, f_band)
    notes = _notes(selection, outside)
    reason = "; ".join(fail)
    return FitQuality(ok=not fail, reason=reason, notes=tuple(fail + notes), evidence=evidence,
                      residual_correlation=float(corr))


def _mac_quantile(criteria: QualityCriteria) -> float:
    """The factor on a mode's mean MAC loss for its ``n_sigma`` quantile.

    1 − MAC of an estimate is about a χ² with 6-8 degrees of freedom scaled by mac_loss (its
    mean); its 95th percentile is about twice the mean, which n_sigma = 2 stands for."""
    return criteria.n_sigma**2 / 2


def _evidence(selection, delta_bic, std, params, mac_loss, stab_orders, share,
              criteria: QualityCriteria) -> ModeEvidence:
    """Each band mode's evidence (arguments as :func:`assess`'s)."""
    f_n, zeta = params[:, 0], params[:, 1]
    f_rel = std[:, 0] / f_n
    z_rel = std[:, 1] / np.abs(zeta)
    k, mac_q = criteria.n_sigma, _mac_quantile(criteria)
    uncertain = ((k * f_rel > criteria.f_tol) | (k * z_rel > criteria.zeta_tol)
                 | (mac_q * mac_loss > 1 - criteria.mac_min) | ~np.isfinite(f_rel + z_rel + mac_loss))
    merged_f = [0.5 * (a + b) for a, b in selection.merged]
    source = []
    for r in range(len(f_n)):
        if stab_orders[r] > 0:
            source.append("stabilisation")
        elif any(abs(f_n[r] - m) < 0.02 * m for m in merged_f):
            source.append("merged")
        else:
            source.append("scan")
    return ModeEvidence(f_n=f_n, n_orders=np.asarray(stab_orders, int), source=tuple(source),
                        share=share, delta_bic=delta_bic, f_std_rel=f_rel,
                        zeta_std_rel=z_rel, mac_loss=mac_loss, uncertain=uncertain)


def _failures(ev: ModeEvidence, zeta, selection, converged, criteria: QualityCriteria, f_band) -> list:
    """What makes the fit need a look, one sentence each (empty when ok)."""
    f_n, k, mac_q = ev.f_n, criteria.n_sigma, _mac_quantile(criteria)
    fail = []
    if not converged:
        fail.append("the optimiser did not converge")
    out = (f_n < f_band[0]) | (f_n > f_band[1]) | (zeta <= 0)
    if out.any():
        fail.append(f"modes at {_hz(f_n[out])} left the band or have zeta <= 0")
    if ev.uncertain.any():
        bits = []
        for r in np.flatnonzero(ev.uncertain):
            what = []
            if k * ev.f_std_rel[r] > criteria.f_tol:
                what.append(f"f ±{ev.f_std_rel[r]:.2%}")
            if k * ev.zeta_std_rel[r] > criteria.zeta_tol:
                what.append(f"zeta ±{ev.zeta_std_rel[r]:.1%}")
            if mac_q * ev.mac_loss[r] > 1 - criteria.mac_min:
                what.append(f"shape MAC loss {ev.mac_loss[r]:.3f}")
            bits.append(f"{f_n[r]:.4g} Hz ({', '.join(what) or 'no standard errors'})")
        fail.append("uncertain mode" + ("s " if len(bits) > 1 else " ") + "; ".join(bits))
    for a, b in selection.unresolved:
        fail.append(f"poles at {a:.4g} and {b:.4g} Hz are close and alike but the data need both "
                    "(one mode split, or two the band cannot separate)")
    if selection.capped:
        fail.append("more modes than the add move's cap (max_added) seem to be in the band")
    return fail


def _notes(selection, outside) -> list:
    """What is worth knowing but harmless, one sentence each."""
    notes = []
    if selection.leftover:
        # smooth non-modal error (a sensor's, the estimator's) does this too: worth a note, not a
        # failure, since every pole that a mode would be was tried and is in
        f0, _, why = selection.leftover
        notes.append(f"structure near {f0:.4g} Hz that the modes do not explain ({why})")
    if len(outside):
        notes.append(f"out-of-band poles at {_hz(np.abs(outside) / (2 * np.pi))} model the tails "
                     "of modes outside the band")
    for a, b in selection.merged:
        notes.append(f"poles at {a:.4g} and {b:.4g} Hz merged into one mode")
    if selection.removed:
        notes.append(f"poles at {_hz(np.array(selection.removed))} dropped (not needed by the "
                     "data, or unphysical)")
    return notes


def _hz(f):
    return ", ".join(f"{x:.4g}" for x in np.atleast_1d(f)) + " Hz"
