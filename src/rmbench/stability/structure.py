"""The tool tip's dynamics as a first-order state-space model for the stability solvers.

``ẋ = A x + B f``, ``q = C x``: f the cutting force on the tool tip and q its displacement, in the
milling directions (x along the feed, y normal to it; one of them for a one-degree-of-freedom
model). Built from one mode's m, ζ, f_n, from complex modes (poles with right and left
eigenvectors, METHODS.md §2: H(s) = Σ φR φLᵀ/(s − λ) + c.c., cross terms kept), or from a modal
dataset of the modal or predict stages.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError

__all__ = ["Structure"]


@dataclass(frozen=True)
class Structure:
    """State-space model of the tool tip.

    Attributes
    ----------
    A : ndarray, shape (n_s, n_s)
    B : ndarray, shape (n_s, n_q)
        Force in N to state rate.
    C : ndarray, shape (n_q, n_s)
        State to displacement in m.
    directions : tuple of str
        ``("x",)`` or ``("x", "y")``.
    f_max : float
        Highest natural frequency in the model, Hz.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    directions: tuple[str, ...]
    f_max: float

    def frf(self, freq: np.ndarray) -> np.ndarray:
        """Receptance, m/N, shape (n_freq, n_q, n_q)."""
        s = 2j * np.pi * np.asarray(freq, float)
        eye = np.eye(self.A.shape[0])
        return self.C @ np.linalg.solve(s[:, None, None] * eye - self.A, np.broadcast_to(self.B, (len(s),) + self.B.shape))

    @classmethod
    def sdof(cls, mass: float, f_n: float, zeta: float) -> "Structure":
        """One mode in x: mass (kg), natural frequency (Hz), damping ratio."""
        if not (mass > 0 and f_n > 0 and 0 <= zeta < 1):
            raise InputError(f"one-mode model needs mass > 0, f_n > 0, 0 ≤ ζ < 1; got {mass}, {f_n}, {zeta}")
        w = 2 * math.pi * f_n
        a = np.array([[0.0, 1.0], [-w * w, -2 * zeta * w]])
        return cls(a, np.array([[0.0], [1 / mass]]), np.array([[1.0, 0.0]]), ("x",), float(f_n))

    @classmethod
    def from_modes(cls, poles, phi_r, phi_l) -> "Structure":
        """Complex modes at the tool tip in x and y.

        Parameters
        ----------
        poles : ndarray, shape (n_modes,), complex, rad/s (Im > 0)
        phi_r, phi_l : ndarray, shape (n_modes, 2), complex
            Right and left eigenvector components at the tip in (x, y), normalised so that
            H(s) = Σ φR φLᵀ/(s − λ) + c.c. (m/N).
        """
        poles = np.atleast_1d(np.asarray(poles, complex))
        phi_r, phi_l = np.asarray(phi_r, complex), np.asarray(phi_l, complex)
        n = len(poles)
        if n == 0:
            raise InputError("the structure has no mode")
        if phi_r.shape != (n, 2) or phi_l.shape != (n, 2):
            raise InputError(f"eigenvector components must have shape ({n}, 2), got {phi_r.shape}, {phi_l.shape}")
        if not np.all(np.isfinite(poles)) or not np.all(poles.imag > 0) or not np.all(poles.real < 0):
            raise InputError("every pole must be finite, underdamped and stable (Re < 0 < Im)")
        a, b, c = np.zeros((2 * n, 2 * n)), np.zeros((2 * n, 2)), np.zeros((2, 2 * n))
        for r, (lam, pr, pl) in enumerate(zip(poles, phi_r, phi_l)):
            k = slice(2 * r, 2 * r + 2)
            a[k, k] = [[lam.real, -lam.imag], [lam.imag, lam.real]]
            b[k] = [pl.real, pl.imag]
            c[:, k] = np.column_stack([2 * pr.real, -2 * pr.imag])
        return cls(a, b, c, ("x", "y"), float(np.abs(poles).max() / (2 * math.pi)))

    @classmethod
    def from_operating_point(cls, op, *, f_max: float = 8000.0) -> "Structure":
        """Every mode of a simulated robot's linear model below ``f_max`` (Hz) at the tool tip (1X, 1Y).

        Unlike a band's mode table this keeps the modes no impact band sees (on the stand-in the
        tool on its holder contact near 2.7 kHz), which limit stability at high spindle speeds.
        """
        cm = op.linear.modes()
        rows = op.coordinate_map(("1X", "1Y"))
        sel = (cm.f_n < f_max) & ~cm.real_pole
        return cls.from_modes(cm.poles[sel], (rows @ cm.phi_r).T[sel], (rows @ cm.phi_l).T[sel])

    @classmethod
    def from_mode_table(cls, table) -> "Structure":
        """The modes of a :class:`rmbench.robot.modes.ModeTable` (exact modes of one band) at 1X, 1Y."""
        return cls.from_modes(table.poles, table.phi_r[:, :2], table.phi_l[:, :2])

    @classmethod
    def from_modal(cls, modal, posture: int = 0, *, band: str | None = None, variable: str = "modal") -> "Structure":
        """Tool-tip modes of one posture of a modal dataset (DATA.md ``modal`` layout).

        Parameters
        ----------
        modal : xarray.Dataset
            With ``variable`` (posture, mode, param) and ``mode_band``.
        posture : int
        band : str, optional
            Only the modes of this band (``low`` or ``high``).
        """
        if variable not in modal:
            raise InputError(f"the dataset has no {variable!r} modal parameters")
        p = modal[variable].isel(posture=posture)
        if band is not None:
            p = p.isel(mode=np.flatnonzero(modal["mode_band"].values == band))
        get = {name: p.sel(param=name).values for name in
               ("f_n", "zeta", "phiR_1X_re", "phiR_1X_im", "phiR_1Y_re", "phiR_1Y_im",
                "phiL_1X_re", "phiL_1X_im", "phiL_1Y_re", "phiL_1Y_im")}
        ok = np.all(np.isfinite(np.stack(list(get.values()))), axis=0)
        if not ok.any():
            raise InputError(f"posture {posture}: no complete mode{'' if band is None else f' in the {band} band'}")
        w = 2 * np.pi * get["f_n"][ok]
        z = get["zeta"][ok]
        poles = w * (-z + 1j * np.sqrt(1 - z**2))
        phi_r = np.column_stack([get["phiR_1X_re"] + 1j * get["phiR_1X_im"], get["phiR_1Y_re"] + 1j * get["phiR_1Y_im"]])[ok]
        phi_l = np.column_stack([get["phiL_1X_re"] + 1j * get["phiL_1X_im"], get["phiL_1Y_re"] + 1j * get["phiL_1Y_im"]])[ok]
        return cls.from_modes(poles, phi_r, phi_l)
