"""RCSA for a robot supporting a thin-walled part (seed 001, METHODS.md §6, Eqs. 6, 12-14, 18).

Part P and robot R are joined at the part's coupling coordinate x by a spring K_x (infinite: a
rigid joint). Every part coordinate of the assembly follows from the part's FRFs and the robot's
direct FRF at the joint alone:

    G_ab = H_ab − H_ax (H_xx + H_xx,R + 1/K_x)⁻¹ H_xb,      a, b ∈ part coordinates   (12-14)

with Eq. 6 its case a = b = x. :func:`spatial_coupling` assembles the same system from the two
M, C, K models and the spring (Eq. 18), the check that both routes agree.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError
from rmbench.rcsa.coupling import IllConditionedWarning, line_ranges

__all__ = ["couple_part", "spatial_coupling", "amplitude_reduction", "PartCoupling"]


@dataclass(frozen=True)
class PartCoupling:
    """Assembled part receptances.

    Attributes
    ----------
    freq : ndarray, shape (n_freq,), Hz
    g : ndarray, shape (n_freq, n_out, n_in), complex
        Part receptances of the assembly, m/N; NaN on ill-conditioned lines.
    ill_conditioned : ndarray, shape (n_freq,), bool
    """

    freq: np.ndarray
    g: np.ndarray
    ill_conditioned: np.ndarray


def couple_part(freq: np.ndarray, h_part: np.ndarray, h_robot: np.ndarray, k_x: float = np.inf, *,
                x_out: int = 0, x_in: int = 0, rtol: float = 1e-9) -> PartCoupling:
    """Part receptances with the robot attached at the coupling coordinate (Eqs. 6, 12-14).

    Parameters
    ----------
    freq : ndarray, shape (n_freq,), Hz
    h_part : ndarray, shape (n_freq, n_out, n_in), complex
        The part alone: responses ``a`` (rows) to forces ``b`` (columns), m/N. Row ``x_out`` and
        column ``x_in`` are the coupling coordinate; a 1-D array is the direct FRF H_xx alone.
    h_robot : ndarray, shape (n_freq,), complex
        The robot's direct FRF at the joint in the coupling direction, m/N.
    k_x : float
        Contact stiffness, N/m (``inf`` for a rigid joint).
    rtol : float
        Lines where |H_xx + H_xx,R + 1/K_x| falls below ``rtol`` times the larger of |H_xx| and
        |H_xx,R| are ill-conditioned (the two sides cancel): reported, and returned as NaN.
    """
    freq = np.asarray(freq, float)
    h = np.asarray(h_part)
    if h.ndim == 1:
        h = h[:, None, None]
    h_robot = np.asarray(h_robot)
    if h.shape[0] != len(freq) or h_robot.shape != (len(freq),):
        raise InputError(f"part FRFs (n_freq, n_out, n_in) and robot FRF (n_freq,) must share the "
                         f"{len(freq)} lines; got {h.shape} and {h_robot.shape}")
    if not (k_x > 0):
        raise InputError(f"contact stiffness K_x must be positive (inf: rigid), got {k_x}")
    h_ax, h_xb, h_xx = h[:, :, x_in], h[:, x_out, :], h[:, x_out, x_in]
    s = h_xx + h_robot + (0.0 if np.isinf(k_x) else 1 / k_x)
    bad = ~(np.abs(s) > rtol * np.maximum(np.abs(h_xx), np.abs(h_robot)))
    with np.errstate(divide="ignore", invalid="ignore"):
        g = h - h_ax[:, :, None] * h_xb[:, None, :] / s[:, None, None]
    g[bad] = np.nan
    if bad.any():
        spans = ", ".join(f"{a:g}-{b:g} Hz" if a != b else f"{a:g} Hz" for a, b in line_ranges(freq, bad))
        warnings.warn(f"{int(bad.sum())} lines where part and robot receptances cancel are left out: {spans}",
                      IllConditionedWarning, stacklevel=2)
    return PartCoupling(freq, g, bad)


def spatial_coupling(part: tuple, robot: tuple, a: np.ndarray, b: np.ndarray, k_u: float):
    """One M, C, K model of part and robot joined by a spring k_u (Eq. 18).

    Parameters
    ----------
    part, robot : tuple of three ndarray
        (M, C, K) of each, shapes (n_p, n_p) and (n_r, n_r).
    a, b : ndarray, shapes (n_p,) and (n_r,)
        The joint's coordinate in each model: u_P = a·q_P, u_R = b·q_R (a unit vector picks one
        DOF, as in Eq. 18).
    k_u : float
        Spring stiffness, N/m.

    Returns
    -------
    M, C, K : ndarray, shape (n_p + n_r, n_p + n_r)
        Part coordinates first. The spring adds k_u v vᵀ with v = [a; −b].
    """
    out = []
    for p, r in zip(part, robot):
        z = np.zeros((p.shape[0] + r.shape[0],) * 2)
        z[:p.shape[0], :p.shape[0]] = p
        z[p.shape[0]:, p.shape[0]:] = r
        out.append(z)
    v = np.concatenate([np.asarray(a, float), -np.asarray(b, float)])
    out[2] = out[2] + k_u * np.outer(v, v)
    return tuple(out)


def amplitude_reduction(freq: np.ndarray, h_alone: np.ndarray, h_coupled: np.ndarray, f_modes,
                        *, window: float = 0.02) -> np.ndarray:
    """Reduction of the part's peaks by the support, 1 − max|G| / max|H| within ±window·f_r of each mode.

    Parameters
    ----------
    freq : ndarray, shape (n_freq,), Hz
    h_alone, h_coupled : ndarray, shape (n_freq,), complex
        The part alone and supported, at the same coordinate.
    f_modes : sequence of float
        The part's natural frequencies, Hz.

    Returns
    -------
    ndarray, shape (n_modes,)
        Fractions (0.9996 is the seed's 99.96 %).
    """
    out = []
    for f in f_modes:
        sel = np.abs(freq - f) <= window * f
        if not sel.any():
            raise InputError(f"no line within {100 * window:g} % of the part mode at {f:g} Hz")
        out.append(1 - np.nanmax(np.abs(h_coupled[sel])) / np.nanmax(np.abs(h_alone[sel])))
    return np.array(out)
