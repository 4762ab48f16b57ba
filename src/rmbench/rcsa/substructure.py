"""Tool substructures for RCSA: free-free receptances of a tool's overhang (METHODS.md §4).

Substructure A of a tool is its overhang, free-free, with point 1 at the tip and point 2 at the
holder face, where it couples to the robot through the contact. Two models of it:

- ``"beam"`` (default, what a lab would use): the Timoshenko finite-element model of
  :meth:`rmbench.robot.tool.ToolGeometry.overhang_matrices` (structural damping as the loss factor,
  K(1 + iη)), solved directly per line.
- ``"lumped"``: the simulator's own tool, the two rigid segments and bending hinges of
  :func:`rmbench.robot.tool.tool_xml` with their viscous dampers, the root bending compliance
  ``c1`` as a spring between the holder face and the root segment. Coupled through the exact
  contact it rebuilds the simulated tool exactly, so it separates what the coupling and the
  contact identification can do from what the beam model's form costs (the rotational contact's
  compliance is ~2 % of ``c1``: a fitted k_r is only as good as the substructure's root
  compliance).

The two lateral planes are uncoupled for a round tool, so each 4x4 block is block-diagonal in
(x, θx) and (y, θy).

The shank sits in the holder and moves with it: it belongs to the robot's side of the joint. A
tool change also changes it, which :func:`shank_mass_matrix` accounts for.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError
from rmbench.robot.tool import ToolGeometry

__all__ = ["PLANE_POINTS", "TOOL_MODELS", "ToolReceptance", "tool_receptance", "shank_mass_matrix",
           "planar_to_full"]

#: Substructure models of a tool's overhang.
TOOL_MODELS = ("beam", "lumped")

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
                    s_1a: float | None = None, model: str = "beam",
                    masses: tuple[tuple[float, float], ...] = ()) -> ToolReceptance:
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
    model : str
        ``"beam"`` (Timoshenko elements) or ``"lumped"`` (the simulator's two-segment chain;
        ``n_el`` is then unused).
    masses : sequence of (s_up, mass)
        Point masses on the overhang (accelerometers: the tool as measured), each ``s_up`` m up the
        tool from the tip and ``mass`` kg, acting in both lateral planes. The beam takes them at the
        tip and at one other point (``s_1a`` when given), where its mesh gets a node.
    """
    freq = np.atleast_1d(np.asarray(freq, float))
    if not np.all(freq > 0):
        raise InputError("tool receptances need frequencies > 0 Hz (a free-free beam has none at rest)")
    if model not in TOOL_MODELS:
        raise InputError(f"tool model must be one of {', '.join(TOOL_MODELS)}, got {model!r}")
    big_l = tool.overhang
    if s_1a is not None and not 0 < s_1a < big_l:
        raise InputError(f"point 1a must lie on the overhang: 0 < S < {big_l * 1e3:g} mm, got {s_1a * 1e3:g} mm")
    masses = [(float(p), float(mass)) for p, mass in masses if mass > 0]
    if any(not 0 <= p < big_l for p, _ in masses):
        raise InputError(f"point masses must sit on the overhang, 0 <= s_up < {big_l * 1e3:g} mm")
    if model == "lumped":
        return _planar_receptance(tool, freq, *_lumped_system(tool, freq, s_1a, masses), s_1a)
    split = s_1a if s_1a is not None else next((p for p, _ in masses if p > 0), None)
    if any(p > 0 and abs(p - split) > 1e-9 for p, _ in masses):
        raise InputError("the beam model takes point masses at the tip and at one other point (point 1a)")
    if split is None:
        k, m = tool.overhang_matrices(n_el)
        a_node = None
    else:
        n_root = min(max(1, round(n_el * (big_l - split) / big_l)), n_el - 1)
        k1, m1 = tool.overhang_segment(big_l - split, n_root)
        k2, m2 = tool.overhang_segment(split, n_el - n_root)
        n = 2 * (n_el + 1)
        k, m = np.zeros((n, n)), np.zeros((n, n))
        j = 2 * n_root  # first DOF of the shared node (point 1a)
        k[:j + 2, :j + 2] += k1
        m[:j + 2, :j + 2] += m1
        k[j:, j:] += k2
        m[j:, j:] += m2
        a_node = j
    n = k.shape[0]
    for p, mass in masses:
        i = n - 2 if p == 0 else a_node
        m[i, i] += mass
    k = k * (1 + 1j * tool.loss_factor)
    if s_1a is None:
        a_node = None
    dofs = [n - 2, n - 1, 0, 1] + ([a_node] if a_node is not None else [])
    rhs = np.zeros((n, len(dofs)))
    rhs[dofs, range(len(dofs))] = 1.0
    omega2 = (2 * np.pi * freq) ** 2
    h = np.linalg.solve(k[None] - omega2[:, None, None] * m[None], np.broadcast_to(rhs, (len(freq),) + rhs.shape))
    return _planar_receptance(tool, freq, h[:, dofs, :], a_node is not None, s_1a)


def _lumped_system(tool: ToolGeometry, freq: np.ndarray, s_1a: float | None,
                   masses=()) -> tuple[np.ndarray, bool]:
    """Planar receptances of the simulator's tool chain at (w_1, θ_1, w_2, θ_2[, w_1a]), (n_freq, n, n).

    Generalised coordinates: the root segment's translation at the holder face and slope (w_r,
    θ_r), the tip segment's slope θ_b and the holder-face rotation θ_2, massless, tied to θ_r by
    the root bending spring 1/c1. Slopes are dw/dx with x from the holder face to the tip, as in
    the beam. Dampers as in :func:`rmbench.robot.tool.tool_xml`: η k / ω_1 on each bending spring.
    """
    big_l = tool.overhang
    c1, c2, d2 = tool.hinge_layout()
    x_h = big_l - d2                       # bending hinge from the holder face, m
    mu, r = tool.mass_per_length, tool.diameter / 2

    def segment(length):                   # [[m, m s̄], [m s̄, m s̄² + J]] about the segment's top end
        mass = mu * length
        j_c = mass * (3 * r**2 + length**2) / 12
        return np.array([[mass, mass * length / 2], [mass * length / 2, mass * length**2 / 4 + j_c]])

    # q = (w_r, θ_r, θ_b, θ_2); the tip segment's top end moves by w_r + x_h θ_r
    t_tip = np.array([[1.0, x_h, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    m = np.zeros((4, 4))
    m[:2, :2] = segment(x_h)
    m += t_tip.T @ segment(d2) @ t_tip
    omega_1 = 1.875**2 * np.sqrt(tool.ei / (mu * big_l**4))
    d_b = np.array([0.0, -1.0, 1.0, 0.0])  # bending hinge rotation θ_b − θ_r
    d_1 = np.array([0.0, 1.0, 0.0, -1.0])  # root bending θ_r − θ_2
    k = np.outer(d_b, d_b) / c2 + np.outer(d_1, d_1) / c1
    c = tool.loss_factor / omega_1 * k
    def at(s_up):                          # row giving the translation s_up up from the tip
        return [1.0, x_h, d2 - s_up, 0.0] if s_up < d2 else [1.0, big_l - s_up, 0.0, 0.0]

    for s_up, mass in masses:
        row = np.array(at(s_up))
        m += mass * np.outer(row, row)
    outputs = [at(0.0), [0.0, 0.0, 1.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
    if s_1a is not None:
        outputs.append(at(s_1a))
    b = np.array(outputs)
    omega = 2 * np.pi * freq
    z = k[None] + 1j * omega[:, None, None] * c[None] - omega[:, None, None] ** 2 * m[None]
    h = b @ np.linalg.solve(z, np.broadcast_to(b.T, (len(freq),) + b.T.shape))
    return h, s_1a is not None


def _planar_receptance(tool: ToolGeometry, freq: np.ndarray, h: np.ndarray, with_points: bool,
                       s_1a: float | None) -> ToolReceptance:
    """Assemble a ToolReceptance from planar receptances at (w_1, θ_1, w_2, θ_2[, w_1a])."""
    points = None
    if with_points:
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
