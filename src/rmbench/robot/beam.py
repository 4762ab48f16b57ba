"""Timoshenko beam finite elements (shear deformation and rotary inertia), SI units.

Used as the reference for the lumped tool models and for tool substructure receptances (RCSA).
Element matrices: the interdependent-interpolation element of Friedman & Kosmatka (1993), exact
in statics, with consistent translational and rotary mass.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["timoshenko_matrices", "section_matrices", "cantilever_frequencies"]


def timoshenko_matrices(length: float, n_el: int, *, E: float, G: float, kappa: float, rho: float,
                        diameter: float) -> tuple[np.ndarray, np.ndarray]:
    """Free-free stiffness and mass matrices of a solid round Timoshenko beam in one plane.

    Returns
    -------
    K, M : ndarray, shape (2(n_el+1), 2(n_el+1))
        DOFs ordered ``[w_0, θ_0, w_1, θ_1, ...]`` from node 0 (x = 0) to node n_el (x = length);
        w in m, θ in rad (θ = dw/dx for a shear-rigid beam).
    """
    area = math.pi * diameter**2 / 4
    inertia = math.pi * diameter**4 / 64
    return section_matrices(length, n_el, ei=E * inertia, kappa_ga=kappa * G * area, rho_a=rho * area,
                            rho_i=rho * inertia)


def section_matrices(length: float, n_el: int, *, ei: float, kappa_ga: float, rho_a: float,
                     rho_i: float) -> tuple[np.ndarray, np.ndarray]:
    """Free-free stiffness and mass matrices of a uniform Timoshenko beam given its section values.

    Parameters
    ----------
    length : float
        Beam length, m.
    n_el : int
        Number of elements.
    ei, kappa_ga : float
        Bending stiffness EI (N·m²) and shear stiffness κGA (N).
    rho_a, rho_i : float
        Mass per length ρA (kg/m) and rotary inertia per length ρI (kg·m).

    Returns
    -------
    K, M : ndarray, shape (2(n_el+1), 2(n_el+1))
        As :func:`timoshenko_matrices`.
    """
    le = length / n_el
    phi = 12 * ei / (kappa_ga * le**2)
    k = ei / ((1 + phi) * le**3) * np.array([
        [12, 6 * le, -12, 6 * le],
        [6 * le, (4 + phi) * le**2, -6 * le, (2 - phi) * le**2],
        [-12, -6 * le, 12, -6 * le],
        [6 * le, (2 - phi) * le**2, -6 * le, (4 + phi) * le**2]])
    p2 = phi**2
    mt = rho_a * le / (210 * (1 + phi) ** 2) * np.array([
        [70 * p2 + 147 * phi + 78, (35 * p2 + 77 * phi + 44) * le / 4,
         35 * p2 + 63 * phi + 27, -(35 * p2 + 63 * phi + 26) * le / 4],
        [0, (7 * p2 + 14 * phi + 8) * le**2 / 4, (35 * p2 + 63 * phi + 26) * le / 4,
         -(7 * p2 + 14 * phi + 6) * le**2 / 4],
        [0, 0, 70 * p2 + 147 * phi + 78, -(35 * p2 + 77 * phi + 44) * le / 4],
        [0, 0, 0, (7 * p2 + 14 * phi + 8) * le**2 / 4]])
    mr = rho_i / (30 * (1 + phi) ** 2 * le) * np.array([
        [36, -(15 * phi - 3) * le, -36, -(15 * phi - 3) * le],
        [0, (10 * p2 + 5 * phi + 4) * le**2, (15 * phi - 3) * le, (5 * p2 - 5 * phi - 1) * le**2],
        [0, 0, 36, (15 * phi - 3) * le],
        [0, 0, 0, (10 * p2 + 5 * phi + 4) * le**2]])
    m = mt + mr
    m = np.triu(m) + np.triu(m, 1).T
    n = 2 * (n_el + 1)
    big_k, big_m = np.zeros((n, n)), np.zeros((n, n))
    for e in range(n_el):
        s = slice(2 * e, 2 * e + 4)
        big_k[s, s] += k
        big_m[s, s] += m
    return big_k, big_m


def cantilever_frequencies(length: float, *, E: float, G: float, kappa: float, rho: float,
                           diameter: float, n_el: int = 60) -> np.ndarray:
    """Natural frequencies (Hz) of a Timoshenko cantilever clamped at x = 0, ascending."""
    from scipy.linalg import eigh

    k, m = timoshenko_matrices(length, n_el, E=E, G=G, kappa=kappa, rho=rho, diameter=diameter)
    free = slice(2, None)
    w2 = eigh(k[free, free], m[free, free], eigvals_only=True)
    return np.sqrt(np.abs(w2)) / (2 * np.pi)
