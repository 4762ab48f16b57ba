"""Validation helpers of the tracker stage: each names the argument and the value it refuses."""

from __future__ import annotations

import math

import numpy as np

from rmbench.errors import InputError

__all__ = ["check_alpha", "check_eta", "check_positive_int", "check_sigma", "check_locations",
           "check_rng", "check_finite_array"]


def check_alpha(alpha) -> float:
    """Confidence level α, strictly inside (0, 1)."""
    try:
        a = float(alpha)
    except (TypeError, ValueError):
        raise InputError(f"alpha must be a number in (0, 1), got {alpha!r}") from None
    if not 0.0 < a < 1.0:
        raise InputError(f"alpha must lie strictly between 0 and 1, got {alpha!r}")
    return a


def check_eta(eta) -> float:
    """Accuracy level η ≥ 0 (same unit as the errors)."""
    try:
        e = float(eta)
    except (TypeError, ValueError):
        raise InputError(f"eta must be a non-negative number, got {eta!r}") from None
    if not (math.isfinite(e) and e >= 0.0):
        raise InputError(f"eta must be finite and >= 0, got {eta!r}")
    return e


def check_positive_int(name: str, value) -> int:
    """An integer ≥ 1 (counts of measurements)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise InputError(f"{name} must be an integer >= 1, got {value!r}")
    return int(value)


def check_locations(locations) -> np.ndarray:
    """Locations as an array of shape (n_loc,) or (n_loc, n_coord), finite, at least one."""
    loc = np.asarray(locations, dtype=float)
    if loc.ndim not in (1, 2) or loc.shape[0] == 0:
        raise InputError(f"locations must be an array of shape (n_loc,) or (n_loc, n_coord) with "
                         f"n_loc >= 1, got shape {loc.shape}")
    if not np.all(np.isfinite(loc)):
        raise InputError("locations must be finite, got NaN or infinity")
    return loc


def check_sigma(sigma, n_loc: int, dim: int) -> np.ndarray:
    """Standard deviation of one measurement, broadcast to shape (n_loc, dim).

    ``sigma`` is a scalar, one value per location (n_loc,), or one per location and axis
    (n_loc, dim); every value finite and > 0.
    """
    s = np.asarray(sigma, dtype=float)
    if s.ndim == 0:
        s = np.full((n_loc, dim), float(s))
    elif s.shape == (n_loc,):
        s = np.repeat(s[:, None], dim, axis=1)
    elif s.shape != (n_loc, dim):
        raise InputError(f"sigma must be a scalar, shape ({n_loc},) or ({n_loc}, {dim}), "
                         f"got shape {s.shape}")
    bad = ~(np.isfinite(s) & (s > 0))
    if np.any(bad):
        raise InputError(f"sigma must be finite and > 0, got {s[bad].flat[0]!r}")
    return s


def check_rng(rng) -> np.random.Generator:
    """A numpy Generator (seeds go through ``numpy.random.default_rng`` explicitly)."""
    if not isinstance(rng, np.random.Generator):
        raise InputError(f"rng must be a numpy.random.Generator (numpy.random.default_rng(seed)), "
                         f"got {type(rng).__name__}")
    return rng


def check_finite_array(name: str, value, shape_tail: tuple = ()) -> np.ndarray:
    """A finite float array whose trailing dimensions are ``shape_tail``."""
    arr = np.asarray(value, dtype=float)
    if shape_tail and arr.shape[arr.ndim - len(shape_tail):] != shape_tail:
        raise InputError(f"{name} must end in shape {shape_tail}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} must be finite, got NaN or infinity")
    return arr
