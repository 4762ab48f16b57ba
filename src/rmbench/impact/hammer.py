"""The impact hammer: force pulses shaped by the tip, with hit-to-hit scatter.

A tip of contact stiffness k on a hammer head of mass m gives a half-sine pulse of duration
``π √(m/k)``: a soft tip (ms) excites the low band, a hard tip (0.1-0.3 ms) reaches the kHz band.
Each hit scatters in peak force, in location along the tool axis and in direction in the base XY
plane; an optional double hit adds a smaller second pulse, as when the hammer bounces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import norm

__all__ = ["Hit", "draw_hit", "pulse", "mean_hit_point"]


@dataclass(frozen=True)
class Hit:
    """One hammer hit as it actually happened.

    Attributes
    ----------
    coordinate : str
        Nominal coordinate hit (``1X``, ``1Y``, ``1aX``, ``1aY``).
    peak : float
        Peak force, N.
    duration : float
        Pulse duration, s.
    location_error : float
        Shift of the impact point along the tool axis (up positive), m.
    direction_error : float
        Rotation of the force direction about the tool axis, rad.
    second_delay : float or None
        Delay of a double hit's second pulse, s (None: a clean hit).
    second_ratio : float
        Peak of the second pulse over the first.
    """

    coordinate: str
    peak: float
    duration: float
    location_error: float = 0.0
    direction_error: float = 0.0
    second_delay: float | None = None
    second_ratio: float = 0.0


def mean_hit_point(s_nominal: float, location_scatter: float) -> float:
    """Mean impact point along the tool axis of hits aimed at ``s_nominal`` m up from the tip, m.

    A hit cannot land beyond the tool's end, so the scattered point ``s + σ z`` is clipped at the
    tip (:func:`rmbench.impact.measure.hammer_rows`): its mean ``s Φ(s/σ) + σ φ(s/σ)`` lies above
    the aim, by ``σ/√(2π)`` at the tip itself (0.08 mm for σ = 0.2 mm) and by nothing a few σ up.

    Parameters
    ----------
    s_nominal : float
        Aimed point, m up from the tip (≥ 0).
    location_scatter : float
        Standard deviation σ of the hit location, m.
    """
    if location_scatter <= 0:
        return float(s_nominal)
    u = s_nominal / location_scatter
    return float(s_nominal * norm.cdf(u) + location_scatter * norm.pdf(u))


def draw_hit(coordinate: str, hammer, rng: np.random.Generator) -> Hit:
    """Draw one hit of ``hammer`` (a HammerConfig, file units) on ``coordinate``."""
    peak = hammer.peak_n * max(0.2, 1 + hammer.force_scatter * rng.standard_normal())
    loc = 1e-3 * hammer.location_scatter_mm * rng.standard_normal()
    direction = np.radians(hammer.direction_scatter_deg) * rng.standard_normal()
    double = rng.random() < hammer.double_hit_probability
    return Hit(coordinate=coordinate, peak=peak, duration=1e-3 * hammer.pulse_ms,
               location_error=loc, direction_error=direction,
               second_delay=1e-3 * hammer.double_hit_delay_ms if double else None,
               second_ratio=hammer.double_hit_ratio if double else 0.0)


def pulse(hit: Hit, t: np.ndarray) -> np.ndarray:
    """Force history of a hit at times ``t`` (s), N, shape like ``t``.

    Values are the pulse's mean over each interval ``[t_k, t_k + dt]`` (``dt`` the spacing of
    ``t``), which is what a zero-order-hold simulator should apply.
    """
    dt = t[1] - t[0]

    def half_sine_mean(t0, peak):
        a = np.clip(t - t0, 0, hit.duration)
        b = np.clip(t + dt - t0, 0, hit.duration)
        w = np.pi / hit.duration
        return peak * (np.cos(w * a) - np.cos(w * b)) / (w * dt)

    f = half_sine_mean(0.0, hit.peak)
    if hit.second_delay is not None:
        f += half_sine_mean(hit.second_delay, hit.second_ratio * hit.peak)
    return f

