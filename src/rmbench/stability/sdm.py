"""Stability of milling by the zeroth-order semi-discretisation method (Insperger & Stépán 2004).

An independent check of :mod:`rmbench.stability.fdm`: over each step of a tooth period (the same
grid, aligned with tooth entry and exit) the
periodic coefficient is frozen at its step average H̄_i and the delayed displacement at the mean of
its two neighbouring samples, so the step is solved exactly,

    y_{i+1} = e^{(A + A_i)τ} y_i + ∫₀^τ e^{(A + A_i)u} du · D_i (q_{i+1−m} + q_{i−m}) / 2,

with A_i = −a_p B H̄_i C and D_i = a_p B H̄_i (one block exponential per step and depth).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm

from rmbench.errors import InputError
from rmbench.stability.cutting import Cutting
from rmbench.stability.fdm import _history, check_grid, steps_for, tooth_grid
from rmbench.stability.structure import Structure

__all__ = ["sdm_spectral_radius"]


def _step_average(structure: Structure, cutting: Cutting, nodes: np.ndarray, sub: int = 16) -> np.ndarray:
    """H averaged over each step (midpoint rule, ``sub`` points), (M, n_q, n_q)."""
    frac = (np.arange(sub) + 0.5) / sub
    phase = nodes[:-1, None] + np.diff(nodes)[:, None] * frac[None]
    h = cutting.directional(phase.ravel()).reshape(len(nodes) - 1, sub, 2, 2).mean(axis=1)
    k = len(structure.directions)
    return h[:, :k, :k]


def sdm_spectral_radius(structure: Structure, cutting: Cutting, speeds_rpm, depths, *, steps: int = 20,
                        adaptive: bool = True) -> np.ndarray:
    """Spectral radius of the semi-discretised monodromy matrix, shape (n_speed, n_depth); < 1: stable.

    The steps are those of :func:`rmbench.stability.fdm.tooth_grid` (aligned with tooth entry and
    exit), as many as :func:`rmbench.stability.fdm.steps_for` asks with ``adaptive``.
    """
    speeds, depths = check_grid(speeds_rpm, depths)
    if steps < 2:
        raise InputError(f"steps per tooth period must be at least 2, got {steps}")
    a, b, c = structure.A, structure.B, structure.C
    ns, nq = b.shape
    nd = len(depths)
    d = depths[:, None, None]
    out = np.empty((len(speeds), nd))
    counts = steps_for(structure, cutting, speeds, int(steps)) if adaptive else np.full(len(speeds), int(steps))
    for k, rpm in enumerate(speeds):
        nodes, engaged = tooth_grid(cutting, int(counts[k]))
        big_m = len(engaged)
        h = _step_average(structure, cutting, nodes)
        omega = 2 * np.pi * rpm / 60
        y, hist = _history(nd, ns, nq, big_m)
        for i in range(big_m):
            tau = (nodes[i + 1] - nodes[i]) / omega
            q_now = np.einsum("qs,dsn->dqn", c, y)
            if engaged[i]:
                big = np.zeros((nd, ns + nq, ns + nq))
                big[:, :ns, :ns] = a - d * (b @ h[i] @ c)
                big[:, :ns, ns:] = d * (b @ h[i])
                e = expm(big * tau)
                y = e[:, :ns, :ns] @ y + e[:, :ns, ns:] @ (0.5 * (hist[big_m - 2] + hist[big_m - 1]))
            else:
                y = expm(a * tau) @ y
            hist.pop()
            hist.appendleft(q_now)
        mono = np.concatenate([y] + list(hist), axis=1)
        out[k] = np.abs(np.linalg.eigvals(mono)).max(axis=1)
    return out
