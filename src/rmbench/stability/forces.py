"""Cutting forces of a straight-fluted cutter: per tooth from its chip, and their history for a
rigid tool.

Tooth j sits at φ_j = Ω t + 2π j/N and cuts while φ_j lies within the immersion [φ_st, φ_ex]
(:attr:`Cutting.angles <rmbench.stability.cutting.Cutting.angles>`). Its chip is

    h_j = f_z sin φ_j + Δx sin φ_j + Δy cos φ_j + r_j − r_{j+1}   (≥ 0: otherwise it cuts nothing)

with (Δx, Δy) the tip's displacement from where the previous tooth left the surface (the
regeneration :mod:`rmbench.stability.milling` feeds in; zero for a rigid tool) and r_j the radial
runout of tooth j (tooth j + 1 is the one that passed before it). The forces F_t = K_t a_p h,
F_n = K_n a_p h give, in the feed (x) and normal (y) directions,

    F_x = −F_t cos φ − F_n sin φ,   F_y = F_t sin φ − F_n cos φ   (Altintas, Manufacturing Automation, ch. 2).

Runout here is one tooth (tooth 0) standing out by ρ: it takes a chip thicker by ρ and the tooth
after it (N − 1) one thinner by ρ, so the force repeats once per revolution, not once per tooth,
and carries lines at the spindle frequency and its harmonics: what excites a robot's low modes at a
low spindle speed. The chip is first order in ρ: with ρ above the thinner tooth's f_z sin φ that
tooth leaves the cut and the next takes a double chip, which this model does not carry.
"""

from __future__ import annotations

import numpy as np

from rmbench.errors import InputError
from rmbench.stability.cutting import Cutting

__all__ = ["tooth_force", "cutting_force"]


def tooth_force(cutting: Cutting, depth: float, feed_per_tooth: float, *, runout: float = 0.0):
    """``force(phase, dq)``: the cutting force on the tool tip, shape (2,), N, in the feed and
    normal directions, at cutter angle ``phase`` (tooth 0's angle, rad) with the tip displaced by
    ``dq`` (m, a pair (x, y)) from where the previous tooth left the surface; a tooth whose chip
    vanishes cuts nothing. ``depth`` (axial, m), ``feed_per_tooth`` (m) and ``runout`` (tooth 0's
    radius above the others', m) as in the module notes."""
    st, ex = cutting.angles
    n = cutting.teeth
    # each tooth's angle behind the first and its chip's runout share, and the force coefficients,
    # as the loop would compute them (a share of 0.0 leaves the chip's arithmetic exact)
    teeth = [(2 * np.pi * j / n, runout * ((j == 0) - ((j + 1) % n == 0))) for j in range(n)]
    kt, kn, turn = cutting.k_t * depth, cutting.k_n * depth, 2 * np.pi
    sin, cos = np.sin, np.cos

    def force(phase, dq=(0.0, 0.0)):
        fx = fy = 0.0
        dx, dy = dq
        for off, bump in teeth:
            phi = (phase + off) % turn
            if st <= phi <= ex:
                s, c = sin(phi), cos(phi)
                h = feed_per_tooth * s + dx * s + dy * c + bump
                if h > 0:
                    ft, fn = kt * h, kn * h
                    fx += -ft * c - fn * s
                    fy += ft * s - fn * c
        return np.array([fx, fy])

    return force


def cutting_force(cutting: Cutting, rpm: float, depth: float, times, *, feed_per_tooth: float = 0.05e-3,
                  runout: float = 0.0) -> np.ndarray:
    """The cutting force of a rigid tool (static chip, no regeneration) at ``times``.

    Parameters
    ----------
    cutting : Cutting
    rpm : float
        Spindle speed, rev/min (> 0); tooth 0 at angle 0 at time 0.
    depth : float
        Axial depth of cut, m (> 0).
    times : array_like, shape (n,)
        s.
    feed_per_tooth : float
        f_z, m (> 0).
    runout : float
        Tooth 0's radius above the other teeth's, m (module notes; 0: none).

    Returns
    -------
    ndarray, shape (n, 2)
        Force on the tool tip in the feed and normal directions, N.
    """
    if not (np.isfinite(rpm) and rpm > 0):
        raise InputError(f"spindle speed must be positive, got {rpm} rev/min")
    if not (np.isfinite(depth) and depth > 0):
        raise InputError(f"depth of cut must be positive, got {depth} m")
    if not (np.isfinite(feed_per_tooth) and feed_per_tooth > 0):
        raise InputError(f"feed per tooth must be positive, got {feed_per_tooth} m")
    if not np.isfinite(runout):
        raise InputError(f"runout must be finite, got {runout} m")
    t = np.asarray(times, float)
    if t.ndim != 1:
        raise InputError(f"times must be one-dimensional (s), got shape {t.shape}")
    force = tooth_force(cutting, depth, feed_per_tooth, runout=runout)
    omega = 2 * np.pi * rpm / 60
    return np.array([force(omega * ti) for ti in t.tolist()]).reshape(len(t), 2)
