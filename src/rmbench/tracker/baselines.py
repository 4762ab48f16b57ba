"""The seed's three common ways of identifying accuracy, beside model invalidation (Sec. 3.2).

* **Largest Error**: one measurement per location; the accuracy is the largest error magnitude.
* **Outlier Rejection**: one measurement per location; measurements outside mean ± k·std
  (k = 1.96, a 95 % interval) of all measurements are discarded and the largest remaining error
  magnitude is the accuracy. The seed does not define its rule; this is ours. The statistic is the
  signed error in 1-D and the error magnitude ||x|| in 3-D (a vector has no signed value).
* **Mean Error**: ``n_per_location`` (10) measurements per location; the accuracy is the largest
  magnitude of the per-location average.

Every function takes the same ``measure(location) -> error`` as
:func:`~rmbench.tracker.invalidate`, explores in the same (quasi-random) order and stops at an
optional overall budget, which is how the seed's Fig. 5 compares methods at equal effort.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError
from rmbench.tracker._checks import check_locations, check_positive_int, check_rng
from rmbench.tracker.sampling import quasi_random_order

__all__ = ["BaselineResult", "largest_error", "outlier_rejection", "mean_error", "BASELINES"]

BASELINES = ("largest_error", "outlier_rejection", "mean_error")


@dataclass(frozen=True)
class BaselineResult:
    """Accuracy identified by a baseline method.

    Attributes
    ----------
    method : {"largest_error", "outlier_rejection", "mean_error"}
    accuracy : float
        Identified accuracy (the errors' unit).
    index : ndarray of int, shape (n_meas,)
        Location of each measurement, in the order taken.
    measurements : ndarray, shape (n_meas,) or (n_meas, dim)
        Measured errors (after ``correct``, if any).
    kept : ndarray of bool, shape (n_meas,)
        Measurements the method used (all but the outliers).
    """

    method: str
    accuracy: float
    index: np.ndarray
    measurements: np.ndarray
    kept: np.ndarray

    def __post_init__(self):
        if self.method not in BASELINES:
            raise InputError(f"method must be one of {BASELINES}, got {self.method!r}")
        if not len(self.index) == len(self.measurements) == len(self.kept):
            raise InputError("index, measurements and kept must have the same length")

    @property
    def n_measurements(self) -> int:
        """Measurements taken."""
        return int(len(self.index))

    def to_dict(self) -> dict:
        """Plain summary for JSON output."""
        return {"method": self.method, "accuracy": self.accuracy,
                "n_measurements": self.n_measurements,
                "n_discarded": int(np.count_nonzero(~self.kept))}


def largest_error(measure, locations, rng: np.random.Generator | None = None, *,
                  max_measurements: int | None = None, correct=None) -> BaselineResult:
    """Largest error magnitude of one measurement per location.

    Parameters
    ----------
    measure : callable
        ``measure(location) -> error`` (float or vector), as for
        :func:`~rmbench.tracker.invalidate`.
    locations : array_like, shape (n_loc,) or (n_loc, n_coord)
    rng : numpy.random.Generator, optional
        Visit in a scrambled-Sobol order (else in the order given).
    max_measurements : int, optional
        Stop after this many measurements (the first locations of the order).
    correct : callable, optional
        ``correct(index, raw) -> errors`` applied once to all measurements (frame re-fit).

    Returns
    -------
    BaselineResult
    """
    idx, x = _collect(measure, locations, rng, 1, max_measurements, correct)
    return BaselineResult("largest_error", float(np.max(_magnitude(x))), idx, x,
                          np.ones(len(idx), bool))


def outlier_rejection(measure, locations, rng: np.random.Generator | None = None, *,
                      k: float = 1.96, max_measurements: int | None = None,
                      correct=None) -> BaselineResult:
    """Largest error magnitude after discarding measurements outside mean ± k·std.

    Parameters
    ----------
    measure, rng, max_measurements, correct
        As for :func:`largest_error`.
    locations : array_like, shape (n_loc,) or (n_loc, n_coord)
        Candidate locations, as for :func:`largest_error` (joint configurations in rad, say).
    k : float
        Half-width of the kept interval in standard deviations of all measurements (> 0).

    Returns
    -------
    BaselineResult
    """
    if not (np.isfinite(k) and k > 0):
        raise InputError(f"k must be finite and > 0, got {k!r}")
    idx, x = _collect(measure, locations, rng, 1, max_measurements, correct)
    value = x if x.ndim == 1 else np.linalg.norm(x, axis=1)
    kept = np.abs(value - value.mean()) <= k * value.std()
    return BaselineResult("outlier_rejection", float(np.max(_magnitude(x)[kept])), idx, x, kept)


def mean_error(measure, locations, rng: np.random.Generator | None = None, *,
               n_per_location: int = 10, max_measurements: int | None = None,
               correct=None) -> BaselineResult:
    """Largest magnitude of the per-location average of ``n_per_location`` measurements.

    Parameters
    ----------
    measure, rng, max_measurements, correct
        As for :func:`largest_error`; with a budget, the last location may have fewer.
    locations : array_like, shape (n_loc,) or (n_loc, n_coord)
        Candidate locations, as for :func:`largest_error` (joint configurations in rad, say).
    n_per_location : int
        Measurements averaged at each location.

    Returns
    -------
    BaselineResult
    """
    n_per = check_positive_int("n_per_location", n_per_location)
    idx, x = _collect(measure, locations, rng, n_per, max_measurements, correct)
    flat = x.reshape(len(idx), -1)
    counts = np.bincount(idx)
    seen = np.flatnonzero(counts)
    means = np.stack([np.bincount(idx, flat[:, a]) for a in range(flat.shape[1])], axis=1)
    means = means[seen] / counts[seen, None]
    return BaselineResult("mean_error", float(np.max(np.linalg.norm(means, axis=1))), idx, x,
                          np.ones(len(idx), bool))


def _magnitude(x: np.ndarray) -> np.ndarray:
    return np.abs(x) if x.ndim == 1 else np.linalg.norm(x, axis=1)


def _collect(measure, locations, rng, n_per, budget, correct):
    """Measure ``n_per`` times at each location in order, up to ``budget`` measurements."""
    loc = check_locations(locations)
    order = np.arange(len(loc)) if rng is None else quasi_random_order(loc, check_rng(rng))
    total = len(loc) * n_per
    if budget is not None:
        total = min(total, check_positive_int("max_measurements", budget))
    idx = np.repeat(order, n_per)[:total]
    raw = [measure(float(loc[j]) if loc.ndim == 1 else loc[j].copy()) for j in idx]
    x = np.asarray(raw, float)
    if x.ndim not in (1, 2) or len(x) != total:
        raise InputError(f"measure must return floats or equal-length vectors, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise InputError("measure returned a non-finite error")
    if correct is not None:
        x = np.asarray(correct(idx, x.reshape(total, -1)), float).reshape(x.shape)
    return idx, x
