"""The sequential model-invalidation test of METHODS.md §7 (seed 004, Paper I, Sec. 2.3).

Plug in any measurement source::

    result = invalidate(measure, locations, sigma, eta=0.375e-3, alpha=0.9, max_per_location=10)
    result.rejected, result.p_star, result.remeasured

``measure(location)`` takes one new noisy measurement of the model's error at a location: a float
for the 1-D test, an (x, y, z) vector for the 3-D test. The procedure: while P* ≤ α, explore the
next location; while P* > α, re-measure the location with the worst p*; stop when every location
has been explored (the target spatial density), when the worst location has reached its cap of
measurements (H0 rejected), or when an overall budget of measurements is spent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Literal

import numpy as np

from rmbench.errors import InputError
from rmbench.tracker._checks import (check_alpha, check_eta, check_locations, check_positive_int,
                                     check_rng, check_sigma)
from rmbench.tracker.rejection import (combined_p_star, log_acceptance, probability,
                                       rejection_statistic, scalar_log_acceptance)
from rmbench.tracker.sampling import quasi_random_order

__all__ = ["InvalidationResult", "invalidate", "run_sequential", "check_test_arguments", "Stop",
           "OnCap"]

Stop = Literal["explored", "cap", "budget"]
"""Why a test stopped: every location explored; the location to re-measure was at its cap (or,
with ``on_cap="skip"``, every location that could lower P* was); the overall budget was spent."""

OnCap = Literal["skip", "reject"]
"""What P* > α with the worst location at its cap means: ``"skip"`` (default) re-measures the
worst location still below its cap and rejects only when none that could lower P* is left;
``"reject"`` stops and rejects at once (a literal reading of the seed's robot test: "a maximum of
10 measurements per joint configuration were allowed before the model would be rejected")."""

Measure = Callable[[object], object]
Correct = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class InvalidationResult:
    """Outcome of one sequential invalidation test.

    Attributes
    ----------
    rejected : bool
        True when H0 (|e(q)| ≤ η everywhere) is rejected: P* > α at the end.
    p_star : float
        Final combined rejection probability P*.
    eta, alpha : float
        Accuracy level tested (the errors' unit) and confidence level.
    stop : {"explored", "cap", "budget"}
        Why the test stopped (:data:`Stop`).
    locations : ndarray, shape (n_loc,) or (n_loc, n_coord)
        The candidate locations, as given.
    index : ndarray of int, shape (n_meas,)
        Location of each measurement, in the order taken.
    measurements : ndarray, shape (n_meas,) or (n_meas, dim)
        The measured errors, as finally expressed (after the last ``correct``, if any).
    sigma : ndarray, shape (n_loc, dim)
        Standard deviation of one measurement per location and axis.
    n_per_location : ndarray of int, shape (n_loc,)
    mean : ndarray, shape (n_loc, dim)
        Average measured error per location (NaN where none was taken).
    p_star_per_location : ndarray, shape (n_loc,)
        Final p*_j (0 where not measured).
    max_per_location : int
    """

    rejected: bool
    p_star: float
    eta: float
    alpha: float
    stop: str
    locations: np.ndarray
    index: np.ndarray
    measurements: np.ndarray
    sigma: np.ndarray
    n_per_location: np.ndarray
    mean: np.ndarray
    p_star_per_location: np.ndarray
    max_per_location: int

    def __post_init__(self):
        if self.stop not in ("explored", "cap", "budget"):
            raise InputError(f"stop must be 'explored', 'cap' or 'budget', got {self.stop!r}")
        if len(self.index) != len(self.measurements):
            raise InputError(f"index and measurements differ in length: {len(self.index)} and "
                             f"{len(self.measurements)}")

    @property
    def n_measurements(self) -> int:
        """Measurements taken."""
        return int(len(self.index))

    @property
    def n_explored(self) -> int:
        """Locations measured at least once."""
        return int(np.count_nonzero(self.n_per_location))

    @property
    def remeasured(self) -> np.ndarray:
        """Indices of the locations measured more than once, ascending."""
        return np.flatnonzero(self.n_per_location > 1)

    @property
    def dim(self) -> int:
        """Number of error components (1 or 3)."""
        return int(self.sigma.shape[1])

    @property
    def verdict(self) -> str:
        """``"rejected"`` or ``"not rejected"``."""
        return "rejected" if self.rejected else "not rejected"

    def to_dict(self) -> dict:
        """Plain summary (verdict, P*, counts, re-measured locations) for JSON output."""
        return {"verdict": self.verdict, "rejected": self.rejected, "p_star": self.p_star,
                "eta": self.eta, "alpha": self.alpha, "stop": self.stop,
                "n_measurements": self.n_measurements, "n_explored": self.n_explored,
                "remeasured": self.remeasured.tolist(),
                "n_per_location": self.n_per_location.tolist()}

    def plot(self, path=None, *, scale: float = 1.0, unit: str = ""):
        """Measured error per location, re-measured ones marked (the seed's Fig. 7).

        See :func:`rmbench.tracker.plot.plot_invalidation`.
        """
        from rmbench.tracker.plot import plot_invalidation

        return plot_invalidation(self, path, scale=scale, unit=unit)


def invalidate(measure: Measure, locations, sigma, eta: float, alpha: float = 0.9,
               max_per_location: int = 100, rng: np.random.Generator | None = None, *,
               on_cap: OnCap = "skip", max_measurements: int | None = None,
               correct: Correct | None = None) -> InvalidationResult:
    """Run the sequential invalidation test of H0: |e(q)| ≤ η at every location.

    Parameters
    ----------
    measure : callable
        ``measure(location) -> error``: one new noisy measurement of the model error at a location
        (an element of ``locations``): a float (1-D test) or a vector of ``dim`` components
        (3-D test: x, y, z). Any unit, the same as ``sigma`` and ``eta``.
    locations : array_like, shape (n_loc,) or (n_loc, n_coord)
        Candidate locations (e.g. positions on [0, 1], or joint configurations in rad).
    sigma : float or array_like, shape (n_loc,) or (n_loc, dim)
        Standard deviation of one measurement, per location (and axis), > 0.
    eta : float
        Accuracy level η ≥ 0 on the error magnitude.
    alpha : float
        Confidence level in (0, 1): reject when P* > α.
    max_per_location : int
        Cap on the measurements at one location (the first included).
    rng : numpy.random.Generator, optional
        Explore the locations in a scrambled-Sobol order (:func:`quasi_random_order`); without it
        they are explored in the order given (already quasi-random, e.g. robot configurations).
    on_cap : {"skip", "reject"}
        What a worst location at its cap means (:data:`OnCap`).
    max_measurements : int, optional
        Overall budget; when spent, the verdict is P* > α on the data so far (stop "budget").
    correct : callable, optional
        ``correct(index, raw) -> errors``: re-expresses every measurement taken so far (index
        shape (n_meas,), raw shape (n_meas, dim)), e.g. after re-fitting base and tool frames.
        Called after each new measurement.

    Returns
    -------
    InvalidationResult

    Raises
    ------
    rmbench.errors.InputError
        On a bad argument, or a measurement that is not finite or changes shape.
    """
    eta = check_eta(eta)
    loc, alpha, cap, budget, _ = check_test_arguments(locations, sigma, alpha, max_per_location,
                                                      max_measurements, on_cap)
    order = np.arange(len(loc)) if rng is None else quasi_random_order(loc, check_rng(rng))
    return run_sequential(measure, loc, order, sigma, eta, alpha, cap, on_cap=on_cap,
                          budget=budget, correct=correct)


def run_sequential(measure, loc, order, sigma, eta, alpha, cap, *, on_cap, budget, correct):
    """The loop of :func:`invalidate` on checked arguments, exploring ``loc`` in ``order``."""
    run = _Run(measure, loc, sigma, eta, cap, correct)
    threshold = math.log1p(-alpha)
    explored = 0
    stop = "explored"
    while True:
        if budget is not None and run.n_meas >= budget:
            stop = "budget"
            break
        if run.log_accept < threshold:  # P* > α: re-measure the worst location
            j = run.worst(skip_capped=on_cap == "skip")
            if j is None:
                stop = "cap"
                break
        elif explored == len(loc):
            break
        else:
            j = int(order[explored])
            explored += 1
        run.take(j)
    return run.result(stop, alpha, threshold)


def check_test_arguments(locations, sigma, alpha, max_per_location, max_measurements, on_cap):
    """Checked (locations, alpha, cap, budget, sigma broadcast to (n_loc, dim)) of a test."""
    loc = check_locations(locations)
    cap = check_positive_int("max_per_location", max_per_location)
    budget = None if max_measurements is None else check_positive_int("max_measurements",
                                                                      max_measurements)
    if on_cap not in ("reject", "skip"):
        raise InputError(f"on_cap must be 'reject' or 'skip', got {on_cap!r}")
    sig = check_sigma(sigma, len(loc), 1 if np.ndim(sigma) < 2 else np.shape(sigma)[1])
    return loc, check_alpha(alpha), cap, budget, sig


class _Run:
    """State of one test: measurements, per-location averages, R_j and log(1 - p*_j)."""

    def __init__(self, measure, loc, sigma, eta, cap, correct):
        self.measure, self.loc, self.sigma_in, self.eta, self.cap = measure, loc, sigma, eta, cap
        self.correct = correct
        n = len(loc)
        self.n = np.zeros(n, int)
        self.stat = np.zeros(n)
        self.log_acc = np.zeros(n)
        self.log_accept = 0.0
        self.index: list[int] = []
        self.raw: list = []
        self.dim = None

    @property
    def n_meas(self) -> int:
        return len(self.index)

    def worst(self, *, skip_capped: bool) -> int | None:
        """Location with the largest R (the worst p*), or None when it may not be re-measured."""
        stat = np.where(self.n >= self.cap, -1.0, self.stat) if skip_capped else self.stat
        j = int(np.argmax(stat))
        if stat[j] <= 0.0 or self.n[j] >= self.cap:
            return None
        return j

    def take(self, j: int) -> None:
        where = float(self.loc[j]) if self.loc.ndim == 1 else self.loc[j].copy()
        x = self._checked(self.measure(where), j)
        self.index.append(j)
        self.raw.append(x)
        self.n[j] += 1
        if self.correct is None:
            self._update_one(j, x)
        else:
            self._update_all()
        self.log_accept = float(self.log_acc.sum())

    def _checked(self, x, j):
        if self.dim is None:
            self.dim = 1 if np.ndim(x) == 0 else int(np.size(x))
            self.scalar = np.ndim(x) == 0
            self.sigma = check_sigma(self.sigma_in, len(self.loc), self.dim)
            self.sums = np.zeros((len(self.loc), self.dim))
        if self.scalar:
            if isinstance(x, float):  # the common case, checked first for speed
                if math.isfinite(x):
                    return x
                raise InputError(f"measure returned a non-finite error at location {j}: {x!r}")
            if np.ndim(x) != 0:
                raise InputError(f"measure returned shape {np.shape(x)} at location {j}, "
                                 "after a scalar at the first location")
            x = float(x)
            if not math.isfinite(x):
                raise InputError(f"measure returned a non-finite error at location {j}: {x!r}")
            return x
        x = np.asarray(x, float).reshape(-1)
        if x.shape != (self.dim,):
            raise InputError(f"measure returned shape {x.shape} at location {j}, expected "
                             f"({self.dim},) like the first measurement")
        if not np.all(np.isfinite(x)):
            raise InputError(f"measure returned a non-finite error at location {j}: {x.tolist()}")
        return x

    def _update_one(self, j, x):
        self.sums[j] += x
        n = self.n[j]
        if self.scalar:
            r, la = scalar_log_acceptance(self.sums[j, 0] / n, self.sigma[j, 0] / math.sqrt(n),
                                          self.eta)
        else:
            r = float(rejection_statistic(self.sums[j] / n, self.sigma[j] / math.sqrt(n), self.eta))
            la = float(log_acceptance(r, self.dim))
        self.stat[j], self.log_acc[j] = r, la

    def _update_all(self):
        idx = np.asarray(self.index)
        raw = np.asarray(self.raw, float).reshape(len(idx), self.dim)
        err = np.asarray(self.correct(idx, raw), float)
        if err.shape != raw.shape or not np.all(np.isfinite(err)):
            raise InputError(f"correct must return finite errors of shape {raw.shape}, got "
                             f"shape {err.shape}")
        self.sums = np.stack([np.bincount(idx, err[:, a], len(self.loc))
                              for a in range(self.dim)], axis=1)
        seen = self.n > 0
        mean = self.sums[seen] / self.n[seen, None]
        sig = self.sigma[seen] / np.sqrt(self.n[seen, None])
        self.stat[:] = 0.0
        self.log_acc[:] = 0.0
        self.stat[seen] = rejection_statistic(mean, sig, self.eta)
        self.log_acc[seen] = log_acceptance(self.stat[seen], self.dim)
        self.errors = err

    def result(self, stop, alpha, threshold) -> InvalidationResult:
        idx = np.asarray(self.index, int)
        dim = self.dim or 1
        if self.correct is not None and len(idx):
            meas = self.errors
        else:
            meas = np.asarray(self.raw, float).reshape(len(idx), dim)
        sigma = self.sigma if self.dim else check_sigma(self.sigma_in, len(self.loc), 1)
        sums = self.sums if self.dim else np.zeros((len(self.loc), 1))
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.where(self.n[:, None] > 0, sums / self.n[:, None], np.nan)
        return InvalidationResult(
            rejected=bool(self.log_accept < threshold), p_star=combined_p_star(self.log_acc),
            eta=self.eta, alpha=alpha, stop=stop, locations=self.loc, index=idx,
            measurements=meas[:, 0] if (dim == 1 and getattr(self, "scalar", True)) else meas,
            sigma=sigma, n_per_location=self.n.copy(), mean=mean,
            p_star_per_location=probability(self.log_acc), max_per_location=self.cap)
