"""Linear closed-loop analysis: stability, acceleration sensitivity, reduction at the mode.

"Reduction" is the seed's figure (Fig. 9): ``1 − controlled peak / uncontrolled peak`` of the
acceleration sensitivity |a_i / d_i| near the axis's mode (within ``±window`` of it). What the
reduction costs elsewhere (issue 83): the largest amplification above twice the mode
(:func:`amplification_db`) and the full-band RMS ratio under a white force (:func:`fullband_ratio`).
"""

from __future__ import annotations

import numpy as np

from rmbench.control.controller import Controller
from rmbench.control.plant import Plant

__all__ = ["closed_loop_matrix", "is_stable", "sensitivity", "reduction", "peak_near", "amplification_db",
           "rms_ratio", "fullband_ratio"]


def closed_loop_matrix(plant: Plant, controller: Controller) -> np.ndarray:
    """State matrix of plant and controller in feedback (``u = K y``), shape (n_x + n_k,)*2."""
    n = plant.n_axes
    A, Bu = plant.A, plant.B[:, n:]
    Cy, Du = plant.C, plant.D[:, n:]
    Ak, Bk, Ck, Dk = controller.A, controller.B, controller.C, controller.D
    # u = Ck xk + Dk (Cy x + Du u)  →  u = E (Ck xk + Dk Cy x)
    E = np.linalg.inv(np.eye(n) - Dk @ Du)
    ux, uk = E @ Dk @ Cy, E @ Ck
    yx, yk = Cy + Du @ ux, Du @ uk
    return np.block([[A + Bu @ ux, Bu @ uk], [Bk @ yx, Ak + Bk @ yk]])


def is_stable(plant: Plant, controller: Controller) -> bool:
    """Whether the closed loop's poles all lie in the open left half-plane."""
    return bool(np.all(np.linalg.eigvals(closed_loop_matrix(plant, controller)).real < 0))


def sensitivity(plant: Plant, controller: Controller | None, freq) -> dict:
    """Closed-loop responses to the disturbances, per frequency.

    Returns
    -------
    dict
        ``acc`` (n_freq, n, n) m/s²/N, ``pos`` (n_freq, n, n) m/N, ``force`` (n_freq, n, n) N/N:
        row the measured axis, column the disturbed axis. Without a controller: open loop.
    """
    n = plant.n_axes
    G = plant.frf(freq)
    Gyd, Gyu = G[:, :, :n], G[:, :, n:]
    if controller is None:
        y = Gyd
        u = np.zeros((len(G), n, n), complex)
    else:
        K = controller.frf(freq)
        eye = np.eye(2 * n)
        y = np.linalg.solve(eye - Gyu @ K, Gyd)
        u = K @ y
    return {"acc": y[:, :n], "pos": y[:, n:], "force": u}


def peak_near(freq, mag, f0: float, window: float = 0.25) -> tuple[float, float]:
    """Largest value of ``mag`` within ``f0·(1 ± window)`` and its frequency.

    Parameters
    ----------
    freq : array_like, shape (n_freq,), Hz
    mag : array_like, shape (n_freq,)
        Magnitudes at ``freq``, in any unit (|a/d| in m/s²/N, say).
    f0 : float
        Centre frequency, Hz.
    window : float
        Relative half-width of the window (dimensionless; 0.25: ±25 %).

    Returns
    -------
    (float, float)
        The largest magnitude, in ``mag``'s unit, and its frequency, Hz.

    Raises
    ------
    ValueError
        No line of ``freq`` within the window.
    """
    freq = np.asarray(freq, float)
    sel = np.abs(freq - f0) <= window * f0
    if not np.any(sel):
        raise ValueError(f"no frequency within {window:.0%} of {f0:g} Hz")
    i = np.flatnonzero(sel)[np.argmax(np.asarray(mag)[sel])]
    return float(mag[i]), float(freq[i])


def reduction(freq, open_mag, closed_mag, f0: float, window: float = 0.25) -> float:
    """``1 − max closed / max open`` within ``f0·(1 ± window)``: dimensionless (0.8: the peak
    reduced by 80 %).

    Parameters
    ----------
    freq : array_like, shape (n_freq,), Hz
    open_mag, closed_mag : array_like, shape (n_freq,)
        Magnitudes without and with control, in one unit (|a/d| in m/s²/N, say).
    f0 : float
        Centre frequency (the axis's mode), Hz.
    window : float
        Relative half-width of the window, dimensionless.
    """
    return 1.0 - peak_near(freq, closed_mag, f0, window)[0] / peak_near(freq, open_mag, f0, window)[0]


def amplification_db(freq, open_mag, closed_mag, f0: float, above: float = 2.0) -> float:
    """Largest amplification of the closed loop over the open one above ``above × f0``, dB.

    ``max 20 log10(closed / open)`` over the lines ``freq > above · f0`` (negative: the loop
    reduces everywhere there).

    Parameters
    ----------
    freq, open_mag, closed_mag : array_like, shape (n_freq,)
        Lines (Hz) and the magnitudes at them, as :func:`reduction` takes them.
    f0 : float
        The axis's mode, Hz.
    above : float
        Where the band starts, as a multiple of ``f0`` (dimensionless).

    Raises
    ------
    ValueError
        No line of ``freq`` above ``above · f0``.
    """
    freq = np.asarray(freq, float)
    sel = freq > above * f0
    if not np.any(sel):
        raise ValueError(f"no frequency above {above:g} x {f0:g} Hz")
    ratio = np.asarray(closed_mag, float)[sel] / np.asarray(open_mag, float)[sel]
    return float(20 * np.log10(np.max(ratio)))


def rms_ratio(freq, open_mag, closed_mag) -> float:
    """``sqrt(∫ closed² df / ∫ open² df)`` over ``freq``: the RMS ratio, closed over open, of a
    response to a flat (white) input, integrated on the linear frequency axis (trapezoids on
    ``freq``'s own spacing, so a log-spaced grid is weighted properly). Dimensionless.

    Parameters
    ----------
    freq : array_like, shape (n_freq,), Hz
        Increasing, at least two lines, fine enough to resolve the peaks.
    open_mag, closed_mag : array_like, shape (n_freq,) or (n_freq, k)
        Magnitudes without and with control, in one unit; with ``k`` columns, one ratio each.

    Returns
    -------
    float or ndarray of shape (k,)
    """
    freq = np.asarray(freq, float)
    if freq.ndim != 1 or len(freq) < 2 or np.any(np.diff(freq) <= 0):
        raise ValueError("an RMS over a band needs an increasing frequency grid of at least two lines")
    power_open = np.abs(np.asarray(open_mag)) ** 2
    power_closed = np.abs(np.asarray(closed_mag)) ** 2
    return np.sqrt(np.trapezoid(power_closed, freq, axis=0) / np.trapezoid(power_open, freq, axis=0))


def fullband_ratio(plant: Plant, controller: Controller, freq) -> np.ndarray:
    """RMS acceleration with control over without it, per axis, under a white force over ``freq``.

    Axis i is driven by a flat (white) force ``d_i`` and its own acceleration ``a_i`` read (the
    diagonal of the acceleration sensitivity): ``sqrt(∫ |a_i/d_i|²_closed df / ∫ |a_i/d_i|²_open df)``
    on the linear frequency axis (:func:`rms_ratio`). The band is ``freq``'s span: pass the band the
    broadband force covers. Above the modes |a/d| is the flat mass line (≈ 0.02 m/s²/N on the
    MH180), which the loop cannot change, so the wider the band the nearer the ratio is to 1: on
    the nominal MH180 1-100 Hz reads about 0.05 higher than 1-40 Hz (the schedule bench's random
    force reaches 40 Hz; its frequency grid, 1-100 Hz).

    Parameters
    ----------
    plant : Plant
    controller : Controller
    freq : array_like, shape (n_freq,), Hz
        Increasing; at least two lines, fine enough to resolve the modes' peaks.

    Returns
    -------
    ndarray, shape (n_axes,)
        Dimensionless ratios (< 1: less acceleration with control over the band).
    """
    idx = np.arange(plant.n_axes)
    open_mag = np.abs(sensitivity(plant, None, freq)["acc"][:, idx, idx])
    closed_mag = np.abs(sensitivity(plant, controller, freq)["acc"][:, idx, idx])
    return np.atleast_1d(rms_ratio(freq, open_mag, closed_mag))
