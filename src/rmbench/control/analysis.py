"""Linear closed-loop analysis: stability, acceleration sensitivity, reduction at the mode.

"Reduction" is the seed's figure (Fig. 9): ``1 − controlled peak / uncontrolled peak`` of the
acceleration sensitivity |a_i / d_i| near the axis's mode (within ``±window`` of it).
"""

from __future__ import annotations

import numpy as np

from rmbench.control.controller import Controller
from rmbench.control.plant import Plant

__all__ = ["closed_loop_matrix", "is_stable", "sensitivity", "reduction", "peak_near"]


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
