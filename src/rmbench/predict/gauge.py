"""A normalisation of the mode vectors that the posture predictors can learn (METHODS.md §2, §5).

A mode's φR and φL are fixed only up to a complex factor (φR c, φL / c rebuild the same FRF); the
modal stage fixes it by one φL element = 1 (DATA.md). Where that element nears zero at some posture
the other elements grow without bound there, and a smooth learner cannot follow them: on the seed's
grid a mode that turns from Y to X drops every single element to 3-5 % of the largest somewhere.

The predictors therefore learn each mode in a gauge of its own: φL scaled to unit norm and turned so
that ``vᴴ φL`` is real and positive, φR by the inverse factor. ``v`` is chosen per mode from the
training postures as the direction whose smallest projection ``|vᴴ φL| / ‖φL‖`` over them is largest,
among the mode's principal direction (the leading eigenvector of ``Σ u uᴴ``, u = φL / ‖φL‖) and the
four elements: the factor is then never divided by anything smaller than that projection. A mode
whose shape turns through a half plane (a veering pair in frequency order) has no good direction;
it keeps the best there is. Predictions go back to the dataset's normalisation (φL[phiL_ref] = 1)
after the learning, so downstream stages see a modal dataset as before.
"""

from __future__ import annotations

import functools

import numpy as np

from rmbench.modal.campaign_fit import COORDS
from rmbench.robot.modes import PARAMS

__all__ = ["gauge_directions", "to_gauge", "from_gauge", "vectors"]

_L = ("phiL_1X", "phiL_1Y", "phiL_1aX")                # φL's fourth element is ``phiL_1aY``
_R = ("phiR_1X", "phiR_1Y", "phiR_1aX", "phiR_1aY")
_I = {p: i for i, p in enumerate(PARAMS)}


def _nan_modes_quiet(fn):
    """A mode missing at a posture is NaN there, and complex arithmetic on NaN raises numpy's
    "invalid value" warnings: the NaN is the answer, not a problem to report."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with np.errstate(invalid="ignore", divide="ignore"):
            return fn(*args, **kwargs)
    return wrapper


def vectors(modal: np.ndarray, ay: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """φL, φR of (posture, mode, 16) parameters and φL's 1aY element ``ay`` (posture, mode), each
    (posture, mode, 4) complex, 1X 1Y 1aX 1aY."""
    def part(name):
        return modal[..., _I[f"{name}_re"]] + 1j * modal[..., _I[f"{name}_im"]]
    return np.stack([part(s) for s in _L] + [ay], -1), np.stack([part(s) for s in _R], -1)


def _put(modal: np.ndarray, phi_l: np.ndarray, phi_r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    modal = modal.copy()
    for k, s in enumerate(_L):
        modal[..., _I[f"{s}_re"]], modal[..., _I[f"{s}_im"]] = phi_l[..., k].real, phi_l[..., k].imag
    for k, s in enumerate(_R):
        modal[..., _I[f"{s}_re"]], modal[..., _I[f"{s}_im"]] = phi_r[..., k].real, phi_r[..., k].imag
    return modal, phi_l[..., 3]


@_nan_modes_quiet
def gauge_directions(ds) -> tuple[np.ndarray, np.ndarray]:
    """Per mode the direction ``v`` of its gauge and its smallest projection over the postures.

    Returns
    -------
    v : ndarray, shape (n_modes, 4), complex
        Unit vectors (1X, 1Y, 1aX, 1aY); a mode found nowhere gets 1aY.
    worst : ndarray, shape (n_modes,)
        ``min |vᴴ φL| / ‖φL‖`` over the postures where the mode was found (NaN: nowhere).
    """
    phi_l, _ = vectors(ds["modal"].values, ds["phiL_1aY"].values)
    u = phi_l / np.linalg.norm(phi_l, axis=-1, keepdims=True)
    n_modes = u.shape[1]
    v, worst = np.tile(np.eye(4)[3].astype(complex), (n_modes, 1)), np.full(n_modes, np.nan)
    for m in range(n_modes):
        um = u[np.isfinite(u[:, m]).all(axis=-1), m]
        if not len(um):
            continue
        principal = np.linalg.eigh(um.T @ um.conj())[1][:, -1]
        candidates = [principal, *np.eye(4)]
        score = [float(np.abs(um @ c.conj()).min()) for c in candidates]
        best = int(np.argmax(score))
        v[m], worst[m] = candidates[best], score[best]
    return v, worst


@_nan_modes_quiet
def to_gauge(ds, v: np.ndarray):
    """A copy of the modal dataset with each mode's vectors in the gauge of direction ``v``
    (:func:`gauge_directions`): ‖φL‖ = 1, ``vᴴ φL`` real positive, φR scaled inversely."""
    out = ds.copy(deep=True)
    phi_l, phi_r = vectors(ds["modal"].values, ds["phiL_1aY"].values)
    norm = np.linalg.norm(phi_l, axis=-1)
    proj = np.einsum("pmk,mk->pm", phi_l, v.conj())
    scale = np.conj(proj) / np.abs(proj) / norm                     # (posture, mode)
    modal, ay = _put(ds["modal"].values, phi_l * scale[..., None], phi_r / scale[..., None])
    out["modal"].values[:] = modal
    out["phiL_1aY"].values[:] = ay
    return out


@_nan_modes_quiet
def from_gauge(modal: np.ndarray, ay: np.ndarray, phi_l_ref, modal_std: np.ndarray | None = None,
               ay_std: np.ndarray | None = None):
    """Gauge-normalised parameters back to the dataset's normalisation, φL[phiL_ref] = 1.

    Parameters
    ----------
    modal : ndarray, shape (n, n_modes, 16)
    ay : ndarray, shape (n, n_modes), complex
        φL at 1aY.
    phi_l_ref : sequence of str, length n_modes
        Each mode's reference element (``1X``, ``1Y``, ``1aX`` or ``1aY``).
    modal_std, ay_std : optional
        Standard deviations of the real and imaginary parts (``ay_std`` complex: real part the
        real part's, imaginary the imaginary part's); propagated to first order, the parts taken as
        independent.

    Returns
    -------
    modal, ay[, modal_std, ay_std] in the dataset's normalisation.
    """
    phi_l, phi_r = vectors(modal, ay)
    e = np.array([COORDS.index(str(r)) for r in phi_l_ref])
    b = np.take_along_axis(phi_l, np.broadcast_to(e[None, :, None], phi_l.shape[:2] + (1,)), axis=-1)
    fixed = np.arange(4)[None, None, :] == e[None, :, None]
    ratio = np.where(fixed & np.isfinite(b), 1.0 + 0j, phi_l / b)      # b / b is 1 by definition
    out_modal, out_ay = _put(modal, ratio, phi_r * b)
    if modal_std is None:
        return out_modal, out_ay
    s_l, s_r = vectors(modal_std, ay_std)
    s_b = np.take_along_axis(s_l, np.broadcast_to(e[None, :, None], s_l.shape[:2] + (1,)), axis=-1)
    # z = a / b: dz = da / b − (a / b²) db;  z = a b: dz = b da + a db
    sl = _product_std(1 / b, s_l, -phi_l / b**2, s_b)
    sl = np.where(fixed, 0.0, sl)
    sr = _product_std(b, s_r, phi_r, s_b)
    std_modal, std_ay = _put(modal_std, sl, sr)
    return out_modal, out_ay, std_modal, std_ay


def _product_std(w1, s1, w2, s2):
    """Standard deviations (real in .real, imaginary in .imag) of w1 d1 + w2 d2, d1 and d2 complex
    with independent parts of standard deviations s1 and s2 (same packing)."""
    var_re = (w1.real * s1.real) ** 2 + (w1.imag * s1.imag) ** 2 + (w2.real * s2.real) ** 2 \
        + (w2.imag * s2.imag) ** 2
    var_im = (w1.imag * s1.real) ** 2 + (w1.real * s1.imag) ** 2 + (w2.imag * s2.real) ** 2 \
        + (w2.real * s2.imag) ** 2
    return np.sqrt(var_re) + 1j * np.sqrt(var_im)
