"""Tool substructures for RCSA: free-free Timoshenko beam receptances (METHODS.md §4).

Substructure A of a tool is its overhang, a free-free beam with point 1 at the tip and point 2 at
the holder face, where it couples to the robot through the contact. Its receptances come from the
finite-element model of :meth:`rmbench.robot.tool.ToolGeometry.overhang_matrices` (structural
damping as the loss factor, K(1 + iη)) by a direct solve per line; the two lateral planes are
uncoupled for a round tool, so each 4x4 block is block-diagonal in (x, θx) and (y, θy).

The shank sits in the holder and moves with it: it belongs to the robot's side of the joint. A
tool change also changes it, which :func:`shank_mass_matrix` accounts for.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError
from rmbench.robot.tool import ToolGeometry

__all__ = ["PLANE_POINTS", "ToolReceptance", "tool_receptance", "shank_mass_matrix", "planar_to_full"]

#: Translations at the tip and at point 1a, grouped by plane (the block order of the matrices).
PLANE_POINTS = ("1X", "1aX", "1Y", "1aY")


@dataclass(frozen=True)
class ToolReceptance:
    """Free-free receptances of a tool's overhang, each shape (n_freq, 4, 4), (x, θx, y, θy) order.

    Attributes
    ----------
    tool : ToolGeometry
    freq : ndarray, shape (n_freq,), Hz
    t11, t12, t21, t22 : ndarray, complex
        Tip/tip, tip/holder-end, holder-end/tip and holder-end/holder-end receptances (response
        first): m/N, m/(N·m), rad/N, rad/(N·m).
    points : tuple of ndarray or None
        With ``s_1a``: (T_mm, T_m2, T_2m), the translations at the tip and at point 1a in
        ``PLANE_POINTS`` order (1X, 1aX, 1Y, 1aY) against themselves and the holder end.
    s_1a : float or None
        Distance of point 1a up the tool from the tip, m.
    """

    tool: ToolGeometry
    freq: np.ndarray
    t11: np.ndarray
    t12: np.ndarray
    t21: np.ndarray
    t22: np.ndarray
    points: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    s_1a: float | None = None


def planar_to_full(h: np.ndarray) -> np.ndarray:
    """Put one plane's (w, θ) 2x2 receptances into both planes of a (x, θx, y, θy) 4x4, shape (..., 4, 4)."""
    out = np.zeros(h.shape[:-2] + (4, 4), dtype=h.dtype)
    out[..., 0:2, 0:2] = h
    out[..., 2:4, 2:4] = h
    return out


def tool_receptance(tool: ToolGeometry, freq: np.ndarray, *, n_el: int = 20,
                    s_1a: float | None = None) -> ToolReceptance:
    """Free-free receptances of the tool's overhang at the tip (1) and the holder face (2).

    Parameters
    ----------
    tool : ToolGeometry
    freq : ndarray, shape (n_freq,), Hz
        Frequencies, all > 0 (a free-free beam has no static receptance).
    n_el : int
        Timoshenko elements along the overhang; 20 converge the receptances below 10 kHz to well
        under 0.1 % for the bundled tools.
    s_1a : float, optional
        Also give the translational receptances at the tip and at point 1a, ``s_1a`` m up the
        tool (a node of the mesh), for coupling through measured translations only.
    """
    freq = np.atleast_1d(np.asarray(freq, float))
    if not np.all(freq > 0):
        raise InputError("tool receptances need frequencies > 0 Hz (a free-free beam has none at rest)")
    big_l = tool.overhang
    if s_1a is None:
        k, m = tool.overhang_matrices(n_el)
        a_node = None
    else:
        if not 0 < s_1a < big_l:
            raise InputError(f"point 1a must lie on the overhang: 0 < S < {big_l * 1e3:g} mm, got {s_1a * 1e3:g} mm")
        n_root = min(max(1, round(n_el * (big_l - s_1a) / big_l)), n_el - 1)
        k1, m1 = tool.overhang_segment(big_l - s_1a, n_root)
        k2, m2 = tool.overhang_segment(s_1a, n_el - n_root)
        n = 2 * (n_el + 1)
        k, m = np.zeros((n, n)), np.zeros((n, n))
        j = 2 * n_root  # first DOF of the shared node (point 1a)
        k[:j + 2, :j + 2] += k1
        m[:j + 2, :j + 2] += m1
        k[j:, j:] += k2
        m[j:, j:] += m2
        a_node = j
    k = k * (1 + 1j * tool.loss_factor)
    n = k.shape[0]
    dofs = [n - 2, n - 1, 0, 1] + ([a_node] if a_node is not None else [])
    rhs = np.zeros((n, len(dofs)))
    rhs[dofs, range(len(dofs))] = 1.0
    omega2 = (2 * np.pi * freq) ** 2
    h = np.linalg.solve(k[None] - omega2[:, None, None] * m[None], np.broadcast_to(rhs, (len(freq),) + rhs.shape))
    h = h[:, dofs, :]
    points = None
    if a_node is not None:
        # (w_1, w_1a) against (w_2, θ_2): measured translations against the interface.
        pm = [0, 4]
        points = (planar_to_full(h[:, pm][:, :, pm]), planar_to_full(h[:, pm][:, :, 2:4]),
                  planar_to_full(h[:, 2:4][:, :, pm]))
    return ToolReceptance(tool, freq, planar_to_full(h[:, 0:2, 0:2]), planar_to_full(h[:, 0:2, 2:4]),
                          planar_to_full(h[:, 2:4, 0:2]), planar_to_full(h[:, 2:4, 2:4]), points, s_1a)


def shank_mass_matrix(tool: ToolGeometry) -> np.ndarray:
    """Rigid mass matrix of the shank at the holder face, (x, θx, y, θy) order, shape (4, 4).

    The shank fills the holder bore above the holder face (x from −ℓ to 0, x running towards the
    tip), so its centre sits at x̄ = −ℓ/2: per plane [[m, m x̄], [m x̄, m x̄² + J]], kg, kg·m, kg·m².
    """
    mass, inertia = tool.shank_mass()
    x_bar = -(tool.length - tool.overhang) / 2
    block = np.array([[mass, mass * x_bar], [mass * x_bar, mass * x_bar**2 + inertia]])
    return planar_to_full(block)
