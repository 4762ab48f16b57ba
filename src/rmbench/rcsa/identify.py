"""Identify the target tool's contact from one posture where both tools were measured (METHODS.md §4).

The seed tuned the contact stiffness of the target tool by hand. Here it is fitted: with the
reference tool's tip receptance and the target tool's measured tip FRFs at the same posture, the
target contact (k_t, k_r, c_t, c_r) minimises the relative complex misfit of the predicted tip
entries H_xx, H_xy, H_yx, H_yy over the band's lines, by bounded least squares in log parameters
(scipy's trust-region reflective). With the shank correction off only ΔK⁻¹ = K_2⁻¹ − K_1⁻¹ enters;
the reference contact is then a convention and the fitted values are K_2 relative to it. By
default only the translational contact (k_t, c_t) is fitted: the rotational one is not
identifiable from measured tip FRFs (see ``free``). With the simulator's own tool as the
substructure (``tool_model="lumped"``) all four come back from exact FRFs; from measured ones
(accelerometers' mass and cross-axis sensitivity and the tip hits' mean offset taken off,
:mod:`rmbench.rcsa.tool_change`) k_r comes within 10 % in 20 of 20 calibrations, while c_r,
whose whole effect on the tip entries is 6 times below the measurement's error, does not come
back at all (bench/rcsa.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from rmbench.errors import InputError
from rmbench.rcsa.contact import Contact
from rmbench.rcsa.coupling import couple_tool, holder_receptance, with_shank_change
from rmbench.rcsa.substructure import tool_receptance
from rmbench.robot.tool import ToolGeometry

__all__ = ["ContactFit", "identify_contact"]

_NAMES = ("k_t", "k_r", "c_t", "c_r")


@dataclass(frozen=True)
class ContactFit:
    """An identified target contact.

    Attributes
    ----------
    contact : Contact
    start : Contact
        Where the search started.
    rms : float
        RMS relative misfit of the tip entries at the optimum.
    rms_start : float
        The same at the start.
    n_lines : int
        Frequency lines used.
    at_bound : tuple of str
        Parameters that ended on a bound of the search (their values are not identified).
    rel_std : dict of str to float
        Relative standard error of each fitted parameter from the Gauss-Newton covariance
        ``rms² (JᵀJ)⁻¹`` in log parameters; above ~0.1 the data barely constrain it (for the
        rotational contact, whose compliance is ~2 % of the overhang's bending compliance).
    """

    contact: Contact
    start: Contact
    rms: float
    rms_start: float
    n_lines: int
    at_bound: tuple[str, ...]
    rel_std: dict

    def identified(self, limit: float = 0.1) -> tuple[str, ...]:
        """Parameters off the bounds with a relative standard error below ``limit``."""
        return tuple(n for n in self.rel_std if n not in self.at_bound and self.rel_std[n] < limit)


def identify_contact(t_ref: np.ndarray, h_target: np.ndarray, freq: np.ndarray, reference: ToolGeometry,
                     target: ToolGeometry, *, reference_contact: Contact | None = None,
                     start: Contact | None = None, free: tuple[str, ...] = ("k_t", "c_t"), span: float = 30.0,
                     s_1a: float | None = None, shank: bool = True, n_el: int = 20,
                     tool_model: str = "beam",
                     sensor_masses: tuple[tuple[float, float], ...] = ()) -> ContactFit:
    """Fit the target tool's contact to its measured tip FRFs at one posture.

    Parameters
    ----------
    t_ref : ndarray, shape (n_freq, 4, 4), complex
        Reference tool's full tip receptance at the posture (``FULL_COORDS``), or with ``s_1a``
        its measured translations (``POINT_COORDS``), as in :func:`change_tool`.
    h_target : ndarray, shape (n_freq, 2, 2), complex
        Target tool's measured tip receptances [[H_xx, H_xy], [H_yx, H_yy]] there, m/N.
    freq : ndarray, shape (n_freq,), Hz
    reference, target : ToolGeometry
    reference_contact : Contact, optional
        The reference tool's contact (default: its catalogue value).
    start : Contact, optional
        Initial guess (default: the reference contact; damping zero is started at 1e-3 of the
        stiffness' natural scale).
    free : tuple of str
        Parameters to fit among ``k_t, k_r, c_t, c_r``; the others stay at ``start``. By default
        the translational pair: the rotational contact's compliance is ~2 % of the overhang's
        bending compliance, so tip FRFs cannot separate it from a 0.1 % error of the beam model
        (on the bench, freeing k_r moves it by a factor 2 to 27 off the truth).
    span : float
        Each parameter is searched within ``start / span … start · span``.
    s_1a : float, optional
        Spacing of point 1a, m, when ``t_ref`` holds point translations.
    shank : bool
        Account for the shank change (:func:`change_tool`).
    n_el : int
        Beam elements per overhang.
    tool_model : str
        Substructure model of both overhangs (:func:`~rmbench.rcsa.substructure.tool_receptance`):
        ``"beam"``, or ``"lumped"``, the simulator's own tool, with which the rotational contact
        becomes identifiable from exact FRFs (the bench's check of the method).
    sensor_masses : sequence of (s_up, mass)
        Accelerometers on the tools while both were measured (m up from the tip, kg): both
        substructures carry them (mass loading; :func:`tool_receptance`).
    """
    freq, t_ref, h_target = _finite_lines(freq, t_ref, h_target)
    k1 = reference_contact or Contact.of(reference)
    p0 = _log_start(start or k1, free)
    idx = [_NAMES.index(n) for n in free]
    a1 = tool_receptance(reference, freq, n_el=n_el, s_1a=s_1a, model=tool_model, masses=sensor_masses)
    a2 = tool_receptance(target, freq, n_el=n_el, model=tool_model, masses=sensor_masses)
    r33, _ = holder_receptance(t_ref, a1, k1, max_condition=np.inf)
    if shank:
        r33, _ = with_shank_change(r33, freq, reference, target, max_condition=np.inf)
    # Each entry weighted by its own peak: lines near the peaks, where the contact shows and the
    # measurement is clean, dominate; antiresonances (noisy, hammer-direction errors) do not.
    weight = 1 / np.abs(h_target).max(axis=0)

    def full(x):
        p = p0.copy()
        p[idx] = x
        return p

    def residual(x):
        t, _ = couple_tool(r33, a2, Contact(*np.exp(full(x))), max_condition=np.inf)
        r = (t[:, 0::2, 0::2] - h_target) * weight
        return np.concatenate([r.real.ravel(), r.imag.ravel()])

    x0 = p0[idx]
    lo, hi = x0 - np.log(span), x0 + np.log(span)
    sol = least_squares(residual, x0, bounds=(lo, hi), x_scale=1.0, method="trf")
    rms, at_bound, rel_std = _fit_stats(sol, residual(x0).size, free, lo, hi)
    return ContactFit(Contact(*np.exp(full(sol.x))), Contact(*np.exp(p0)), rms,
                      float(np.sqrt(np.mean(residual(x0) ** 2))), int(len(freq)), at_bound, rel_std)


def _finite_lines(freq, t_ref, h_target):
    """Check the target FRFs' shape and keep the lines where both measurements are finite."""
    freq = np.asarray(freq, float)
    h_target = np.asarray(h_target)
    if h_target.shape != (len(freq), 2, 2):
        raise InputError(f"target FRFs must have shape (n_freq, 2, 2), got {h_target.shape}")
    good = np.all(np.isfinite(h_target), axis=(1, 2)) & np.all(np.isfinite(t_ref), axis=(1, 2))
    if good.sum() < 8:
        raise InputError(f"contact identification needs at least 8 finite lines, got {int(good.sum())}")
    return freq[good], np.asarray(t_ref)[good], h_target[good]


def _log_start(x0: Contact, free: tuple[str, ...]) -> np.ndarray:
    """Log of the start contact (k_t, k_r, c_t, c_r), after checking the names in ``free``."""
    unknown = [n for n in free if n not in _NAMES]
    if unknown or not free:
        raise InputError(f"free contact parameters must be among {', '.join(_NAMES)}, got {free!r}")
    # zero damping cannot be searched in log space: start it at a loss factor of 1e-5 per rad/s
    return np.log([x0.k_t, x0.k_r, max(x0.c_t, 1e-8 * x0.k_t), max(x0.c_r, 1e-8 * x0.k_r)])


def _fit_stats(sol, n: int, free: tuple[str, ...], lo: np.ndarray, hi: np.ndarray):
    """RMS misfit, parameters on a bound and relative standard errors of a least-squares solution."""
    at_bound = tuple(free[i] for i, (v, a, b) in enumerate(zip(sol.x, lo, hi)) if min(v - a, b - v) < 1e-3)
    rms = float(np.sqrt(2 * sol.cost / n))
    jtj = sol.jac.T @ sol.jac
    with np.errstate(divide="ignore", invalid="ignore"):
        cov = rms**2 * np.linalg.pinv(jtj)
    rel_std = {name: float(np.sqrt(max(cov[i, i], 0.0))) for i, name in enumerate(free)}
    return rms, at_bound, rel_std
