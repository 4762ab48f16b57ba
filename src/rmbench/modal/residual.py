"""Out-of-band terms of a band's fit, in a form that can be stored and learnt per posture.

A band's modes alone do not rebuild its receptance: the modes below the band leave a mass line and
those above it a stiffness line, and the modal fit models them with residual terms and, where the
data need it, with out-of-band poles (:class:`~rmbench.modal.ModalFit`'s ``residual_`` and
``outside_``). Their number varies from posture to posture, so they are projected, per entry, on
three fixed functions over the band's lines,

    H_out(ω) ≈ −L/ω² + U + V (ω/ω_max)²,

(``lower`` L in 1/kg, ``upper`` U and ``quadratic`` V in m/N; ω_max the band's top line, rad/s) —
the mass line, the stiffness line and the first term of the stiffness line's growth towards a mode
above the band. On the IRB6660 stand-in the tool-holder modes near 2.6 kHz contribute ~16 % of the
high band's direct receptances; the projection keeps them to ~1.5 % of their own size (0.25 % of
the band's), against ~4 % with L and U alone.
"""

from __future__ import annotations

import numpy as np

__all__ = ["RESIDUAL_TERMS", "residual_basis", "out_of_band_terms", "project_terms", "residual_frf"]

#: Names of the three terms, in storage order.
RESIDUAL_TERMS = ("lower", "upper", "quadratic")


def residual_basis(freq, f_max: float) -> np.ndarray:
    """The three functions at ``freq`` (Hz), shape (n_freq, 3): −1/ω², 1, (f/f_max)²."""
    freq = np.asarray(freq, float)
    omega = 2 * np.pi * freq
    return np.column_stack([-1 / omega**2, np.ones_like(freq), (freq / f_max) ** 2])


def out_of_band_terms(fit, freq) -> np.ndarray:
    """Project a fitted band's residual terms and out-of-band poles on :func:`residual_basis`.

    Parameters
    ----------
    fit : rmbench.modal.ModalFit
        A fitted band.
    freq : ndarray, shape (n_freq,), Hz
        The band's lines.

    Returns
    -------
    ndarray, shape (3, 4, 4), complex
        L (1/kg), U (m/N), V (m/N); zeros when the fit has neither residuals nor outside poles.
    """
    from rmbench.modal import mdof

    freq = np.asarray(freq, float)
    omega = 2 * np.pi * freq
    h = np.zeros((len(freq), 4, 4), complex)
    if fit.residual_:
        h += -fit.residual_["lower"] / omega[:, None, None] ** 2 + fit.residual_["upper"]
    if len(fit.outside_["poles"]):
        h += mdof.synthesize(freq, fit.outside_["poles"], fit.outside_["phi_r"], fit.outside_["phi_l"])
    return project_terms(h, freq)


def project_terms(h: np.ndarray, freq) -> np.ndarray:
    """Least-squares terms of an out-of-band receptance ``h`` (n_freq, 4, 4) over the band's lines
    ``freq`` (Hz; f_max is their top), shape (3, 4, 4) complex."""
    freq = np.asarray(freq, float)
    if not np.any(h):
        return np.zeros((3, 4, 4), complex)
    basis = residual_basis(freq, freq.max())
    # columns scaled to unit norm: −1/ω² and 1 differ by ~1e7 on the high band
    scale = np.linalg.norm(basis, axis=0)
    coef, *_ = np.linalg.lstsq(basis / scale, np.asarray(h).reshape(len(freq), -1), rcond=None)
    return (coef / scale[:, None]).reshape(3, 4, 4)


def residual_frf(terms: np.ndarray, freq, f_max: float) -> np.ndarray:
    """Receptance of the stored terms at ``freq`` (Hz), m/N, shape (..., n_freq, 4, 4).

    ``terms`` has shape (..., 3, 4, 4); ``f_max`` is the band's top line the terms were fitted
    with (Hz). Valid within the band only: V (ω/ω_max)² grows without bound above it.
    """
    basis = residual_basis(freq, f_max)                        # (n_freq, 3)
    return np.einsum("ft,...tij->...fij", basis, np.asarray(terms))
