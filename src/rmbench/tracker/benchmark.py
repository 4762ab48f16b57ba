"""The seed's 1-D benchmark (Sec. 3): a known error profile measured with Gaussian noise.

Table 1: e(q) = sin(2π(q + 0.1)) on 1000 evenly spaced locations of [0, 1], noise σ = 0.1, 0.5,
1.0, at most 100 measurements per location; every method's identified accuracy against the true
1.0. :func:`table1` runs it over several seeds; :func:`accuracy_vs_measurements` is the Fig. 5
comparison at equal numbers of measurements; Fig. 4 is :func:`table1` on a finer noise grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import xarray as xr

from rmbench.errors import InputError
from rmbench.tracker._checks import check_alpha, check_positive_int
from rmbench.tracker.accuracy import accuracy_level
from rmbench.tracker.baselines import largest_error, mean_error, outlier_rejection

__all__ = ["ErrorProfile", "NoisyMeasure", "sine_profile", "Table1", "table1",
           "accuracy_vs_measurements", "METHODS", "SEED_TABLE1"]

#: The accuracy-identification methods the benchmark compares, in the order of its tables'
#: ``estimator`` dimension: the three baselines and model invalidation.
METHODS = ("largest_error", "outlier_rejection", "mean_error", "model_invalidation")

#: Seed 004 (Paper I), Table 1: each method's identified accuracy at noise σ = 0.1, 0.5 and 1.0 on
#: the sine profile (true accuracy 1); dimensionless, the profile's unit.
SEED_TABLE1 = {  # seed 004, Paper I, Table 1: identified accuracy at noise 0.1 / 0.5 / 1.0
    "noise": (0.1, 0.5, 1.0),
    "largest_error": (1.21, 2.49, 3.85),
    "outlier_rejection": (0.63, 0.99, 1.48),
    "mean_error": (1.08, 1.53, 1.78),
    "model_invalidation": (1.01, 1.04, 1.06),
}


@dataclass(frozen=True)
class ErrorProfile:
    """A 1-D error profile e(q) on [lower, upper] whose maximum |e| is known.

    Attributes
    ----------
    func : callable
        e(q), vectorised over q.
    true_max : float
        max |e(q)| over [lower, upper]: the true accuracy.
    lower, upper : float
        Range of q.
    name : str
    """

    func: Callable
    true_max: float
    lower: float = 0.0
    upper: float = 1.0
    name: str = ""

    def __post_init__(self):
        if not (math.isfinite(self.true_max) and self.true_max > 0):
            raise InputError(f"true_max must be finite and > 0, got {self.true_max!r}")
        if not self.lower < self.upper:
            raise InputError(f"lower must be < upper, got {self.lower!r} and {self.upper!r}")

    def locations(self, n: int = 1000) -> np.ndarray:
        """``n`` evenly spaced locations on [lower, upper], shape (n,)."""
        return np.linspace(self.lower, self.upper, check_positive_int("n", n))


def sine_profile() -> ErrorProfile:
    """The seed's benchmark profile e(q) = sin(2π(q + 0.1)), q ∈ [0, 1], true accuracy 1."""
    return ErrorProfile(lambda q: np.sin(2.0 * np.pi * (q + 0.1)), 1.0, name="sin(2π(q + 0.1))")


@dataclass
class NoisyMeasure:
    """``measure(q)``: e(q) plus Gaussian noise of standard deviation ``sigma``.

    Attributes
    ----------
    profile : ErrorProfile
    sigma : float
    rng : numpy.random.Generator
    count : int
        Measurements taken so far.
    """

    profile: ErrorProfile
    sigma: float
    rng: np.random.Generator
    count: int = field(default=0)

    def __call__(self, q: float) -> float:
        self.count += 1
        return float(self.profile.func(q)) + self.sigma * self.rng.standard_normal()


@dataclass(frozen=True)
class Table1:
    """Identified accuracy of every method over noise levels and seeds.

    Attributes
    ----------
    accuracy : xarray.DataArray, dims (estimator, noise, seed)
        Identified accuracy (the profile's unit).
    measurements : xarray.DataArray, dims (estimator, noise, seed)
        Measurements each method took (model invalidation: the final, non-rejected test).
    true_accuracy : float
    settings : dict
        alpha, max_per_location, n_locations, n_mean, search, on_cap.
    """

    accuracy: xr.DataArray
    measurements: xr.DataArray
    true_accuracy: float
    settings: dict

    def mean(self) -> xr.DataArray:
        """Accuracy averaged over seeds, dims (estimator, noise)."""
        return self.accuracy.mean("seed")

    def to_dict(self) -> dict:
        """Means over seeds per method, and the seed's figures, for JSON output."""
        mean = self.mean()
        out = {"noise": mean.noise.values.tolist(), "true_accuracy": self.true_accuracy}
        out.update({m: mean.sel(estimator=m).values.tolist() for m in METHODS})
        out["measurements"] = {m: self.measurements.sel(estimator=m).mean("seed").values.tolist()
                               for m in METHODS}
        out["settings"] = dict(self.settings)
        return out


def table1(noise=(0.1, 0.5, 1.0), seeds=range(5), *, profile: ErrorProfile | None = None,
           n_locations: int = 1000, alpha: float = 0.9, max_per_location: int = 100,
           n_mean: int = 10, search: str = "bisect", on_cap: str = "skip") -> Table1:
    """Run every method on the benchmark profile at each noise level and seed.

    Parameters
    ----------
    noise : sequence of float
        Noise standard deviations (> 0).
    seeds : sequence of int
        One independent run per seed (noise, visiting order).
    profile : ErrorProfile, optional
        Default :func:`sine_profile`.
    n_locations : int
        Evenly spaced locations, all of which every method explores.
    alpha, max_per_location : float, int
        Model invalidation's confidence level and per-location cap.
    n_mean : int
        Measurements per location of Mean Error.
    search, on_cap : str
        η search and cap rule of model invalidation (:func:`~rmbench.tracker.accuracy_level`).

    Returns
    -------
    Table1
    """
    profile = profile or sine_profile()
    noise = _check_noise(noise)
    seeds = [int(s) for s in seeds]
    if not seeds:
        raise InputError("seeds must name at least one seed")
    alpha = check_alpha(alpha)
    loc = profile.locations(n_locations)
    acc = np.zeros((len(METHODS), len(noise), len(seeds)))
    count = np.zeros_like(acc, dtype=int)
    settings = {"alpha": alpha, "max_per_location": max_per_location, "n_locations": n_locations,
                "n_mean": n_mean, "search": search, "on_cap": on_cap, "profile": profile.name}
    for i, sigma in enumerate(noise):
        for k, seed in enumerate(seeds):
            acc[:, i, k], count[:, i, k] = _run_methods(profile, loc, sigma, seed, settings)
    coords = {"estimator": list(METHODS), "noise": noise, "seed": seeds}
    dims = ("estimator", "noise", "seed")
    return Table1(xr.DataArray(acc, coords, dims), xr.DataArray(count, coords, dims),
                  profile.true_max, settings)


def accuracy_vs_measurements(budgets, noise: float = 0.5, seeds=range(5), *,
                             profile: ErrorProfile | None = None, n_locations: int = 1000,
                             alpha: float = 0.9, max_per_location: int = 100, n_mean: int = 10,
                             search: str = "bisect", on_cap: str = "skip") -> xr.DataArray:
    """Identified accuracy when every method may take at most N measurements (seed Fig. 5).

    Parameters
    ----------
    budgets : sequence of int
        Measurement budgets N.
    noise : float
        Noise standard deviation.
    seeds, profile, n_locations, alpha, max_per_location, n_mean, search, on_cap
        As for :func:`table1`.

    Returns
    -------
    xarray.DataArray, dims (estimator, budget, seed)
    """
    profile = profile or sine_profile()
    sigma = _check_noise([noise])[0]
    budgets = [check_positive_int("budget", int(b)) for b in budgets]
    seeds = [int(s) for s in seeds]
    loc = profile.locations(n_locations)
    acc = np.zeros((len(METHODS), len(budgets), len(seeds)))
    settings = {"alpha": check_alpha(alpha), "max_per_location": max_per_location,
                "n_mean": n_mean, "search": search, "on_cap": on_cap}
    for b, budget in enumerate(budgets):
        for k, seed in enumerate(seeds):
            acc[:, b, k] = _run_methods(profile, loc, sigma, seed, settings, budget=budget)[0]
    return xr.DataArray(acc, {"estimator": list(METHODS), "budget": budgets, "seed": seeds},
                        ("estimator", "budget", "seed"), attrs={"noise": sigma})


def _run_methods(profile, loc, sigma, seed, settings, *, budget=None):
    """(accuracy, measurements) of every method in METHODS order for one (noise, seed) cell."""
    acc, count = np.zeros(len(METHODS)), np.zeros(len(METHODS), int)
    for m, (method, rng) in enumerate(zip(METHODS, _rngs(seed, sigma, len(METHODS)))):
        measure = NoisyMeasure(profile, sigma, rng)
        if method == "model_invalidation":
            level = accuracy_level(measure, loc, sigma, settings["alpha"],
                                   settings["max_per_location"], rng, search=settings["search"],
                                   on_cap=settings["on_cap"], max_measurements=budget)
            acc[m], count[m] = level.eta, level.final.n_measurements
        else:
            kwargs = {"n_per_location": settings["n_mean"]} if method == "mean_error" else {}
            res = _BASELINE_FUNCS[method](measure, loc, rng, max_measurements=budget, **kwargs)
            acc[m], count[m] = res.accuracy, res.n_measurements
    return acc, count


_BASELINE_FUNCS = {"largest_error": largest_error, "outlier_rejection": outlier_rejection,
                   "mean_error": mean_error}


def _check_noise(noise) -> list[float]:
    values = [float(s) for s in np.atleast_1d(noise)]
    if not values or not all(math.isfinite(s) and s > 0 for s in values):
        raise InputError(f"noise must be one or more finite values > 0, got {noise!r}")
    return values


def _rngs(seed: int, sigma: float, n: int) -> list[np.random.Generator]:
    """Generators per method for one (seed, noise) cell: Largest Error and Outlier Rejection get
    the same stream (one data set, two analyses, as on the robot); the others independent ones.
    Each comes from its own SeedSequence (scipy's Sobol spawns from a generator's sequence)."""
    keys = [0 if m == 1 else m for m in range(n)]
    return [np.random.default_rng(np.random.SeedSequence([seed, round(sigma * 1e6), k]))
            for k in keys]
