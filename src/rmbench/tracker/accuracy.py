"""The identified accuracy: the smallest accuracy level η that the invalidation test does not reject.

Rejection is random, so "the smallest η not rejected" needs a rule. Each candidate η is judged by
``repeats`` fresh tests with fresh measurements (the same quasi-random visiting order throughout
one search) and counts as rejected when at least ``quorum`` of them reject.

``search="bisect"`` (default): a bracket [η_lo, η_hi] (η_lo rejected by one test, η_hi = 2 η_lo
passing the judgement) is found by doubling or halving, then bisected down to a width of
``resolution``·η_hi; η_hi is reported. With the defaults (3 tests, rejected if any rejects) this
is the η that three fresh campaigns all fail to reject: where the probability of not rejecting is
about 0.8 (0.8³ ≈ 1/2). The η where a single test is as likely to reject as not lies lower, and can
lie below the true maximum error when few locations sit near it.

``search="scan"``: the bracket is narrowed to a relative width ``bracket`` with single tests, then η
is scanned upwards from η_lo on a grid of step ``resolution``·η_hi; the first grid value that passes
the judgement is reported. With ``repeats=1`` this is the literal first η not rejected on a fine
grid: closest to the seed's Table 1, but it picks up lucky non-rejections below the truth.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from rmbench.errors import InputError, RmbenchError
from rmbench.tracker._checks import check_positive_int, check_rng
from rmbench.tracker.invalidation import InvalidationResult, check_test_arguments, run_sequential
from rmbench.tracker.sampling import quasi_random_order

__all__ = ["AccuracyLevel", "accuracy_level", "Search"]

Search = Literal["scan", "bisect"]


@dataclass(frozen=True)
class AccuracyLevel:
    """Result of an η search.

    Attributes
    ----------
    eta : float
        Identified accuracy: the smallest η not rejected (the errors' unit).
    search : {"scan", "bisect"}
    tested : ndarray, shape (n_tests,)
        η of every fresh test, in the order run.
    rejected : ndarray of bool, shape (n_tests,)
    n_measurements : ndarray of int, shape (n_tests,)
        Measurements each test took.
    final : InvalidationResult
        A test at ``eta`` that did not reject.
    """

    eta: float
    search: str
    tested: np.ndarray
    rejected: np.ndarray
    n_measurements: np.ndarray
    final: InvalidationResult

    def __post_init__(self):
        if not (np.isfinite(self.eta) and self.eta >= 0):
            raise InputError(f"eta must be finite and >= 0, got {self.eta!r}")
        if not len(self.tested) == len(self.rejected) == len(self.n_measurements):
            raise InputError("tested, rejected and n_measurements must have the same length")

    @property
    def total_measurements(self) -> int:
        """Measurements over all tests of the search."""
        return int(np.sum(self.n_measurements))

    def to_dict(self) -> dict:
        """Plain summary for JSON output."""
        return {"eta": self.eta, "search": self.search, "n_tests": int(len(self.tested)),
                "total_measurements": self.total_measurements,
                "final_n_measurements": self.final.n_measurements,
                "final_p_star": self.final.p_star}


def accuracy_level(measure, locations, sigma, alpha: float = 0.9, max_per_location: int = 100,
                   rng: np.random.Generator | None = None, *, search: Search = "bisect",
                   repeats: int = 3, quorum: int = 1, resolution: float = 0.005,
                   bracket: float = 0.1, eta_start: float | None = None, on_cap="skip",
                   max_measurements: int | None = None, correct=None) -> AccuracyLevel:
    """The smallest accuracy level η not rejected by :func:`~rmbench.tracker.invalidate`.

    Parameters
    ----------
    measure, sigma, alpha, max_per_location, rng
        As for :func:`~rmbench.tracker.invalidate` (``rng`` fixes the visiting order, shared by
        every test of the search); ``sigma`` in the errors' unit.
    locations : array_like, shape (n_loc,) or (n_loc, n_coord)
        Candidate locations, as for :func:`~rmbench.tracker.invalidate` (joint configurations in
        rad, say).
    search : {"bisect", "scan"}
        Search rule (module docstring).
    repeats : int
        Fresh tests judging each candidate of the refinement.
    quorum : int
        A candidate counts as rejected when at least this many of its tests reject (1: any).
    resolution : float
        Final bracket width (bisect) or grid step (scan), relative to the bracket's upper end.
    bracket : float
        Relative width of the coarse bracket the scan starts from.
    eta_start : float, optional
        First candidate of the bracket search (default: 3 × the median σ).
    on_cap, max_measurements, correct
        As for :func:`~rmbench.tracker.invalidate`.

    Returns
    -------
    AccuracyLevel
    """
    loc, alpha, cap, budget, sig = check_test_arguments(locations, sigma, alpha, max_per_location,
                                                        max_measurements, on_cap)
    repeats = check_positive_int("repeats", repeats)
    quorum = check_positive_int("quorum", quorum)
    if quorum > repeats:
        raise InputError(f"quorum must be <= repeats ({repeats}), got {quorum}")
    if search not in ("scan", "bisect"):
        raise InputError(f"search must be 'scan' or 'bisect', got {search!r}")
    for name, value in (("resolution", resolution), ("bracket", bracket)):
        if not (np.isfinite(value) and 0 < value < 1):
            raise InputError(f"{name} must lie in (0, 1), got {value!r}")
    if eta_start is None:
        eta_start = 3.0 * float(np.median(sig))
    elif not (np.isfinite(eta_start) and eta_start > 0):
        raise InputError(f"eta_start must be finite and > 0, got {eta_start!r}")
    order = np.arange(len(loc)) if rng is None else quasi_random_order(loc, check_rng(rng))
    log = _Log(lambda eta: run_sequential(measure, loc, order, sigma, eta, alpha, cap,
                                          on_cap=on_cap, budget=budget, correct=correct),
               repeats, quorum)
    lo, hi = _bracket(log, float(eta_start))
    if search == "scan":
        while hi / lo > 1.0 + bracket:
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if log.rejects(mid) else (lo, mid)
        step = resolution * hi
        eta = lo
        for _ in range(int(np.ceil(10.0 / resolution))):  # up to 10 × η_hi
            eta += step
            if not log.judged_rejected(eta):
                break
        else:
            raise RmbenchError(f"no accuracy level up to {eta:.6g} was accepted")
    else:
        for _ in range(60):
            if not log.judged_rejected(hi):
                break
            lo, hi = hi, 2.0 * hi
        else:
            raise RmbenchError(f"no accuracy level up to {hi:.6g} was accepted")
        while hi - lo > resolution * hi:
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if log.judged_rejected(mid) else (lo, mid)
        eta = hi
    return log.result(eta, search)


class _Log:
    """Runs fresh tests and keeps every η tried, its verdict and its measurement count."""

    def __init__(self, test, repeats: int, quorum: int):
        self.test, self.repeats, self.quorum = test, repeats, quorum
        self.runs: list[InvalidationResult] = []

    def rejects(self, eta: float) -> bool:
        """One fresh test."""
        self.runs.append(self.test(eta))
        return self.runs[-1].rejected

    def judged_rejected(self, eta: float) -> bool:
        """``repeats`` fresh tests; rejected when ``quorum`` of them reject (stops early)."""
        votes = 0
        for k in range(self.repeats):
            votes += self.rejects(eta)
            if votes >= self.quorum or votes + self.repeats - k - 1 < self.quorum:
                break
        return votes >= self.quorum

    def result(self, eta: float, search: str) -> AccuracyLevel:
        final = next((r for r in reversed(self.runs) if r.eta == eta and not r.rejected), None)
        if final is None:  # the upper end was judged by the bracket search only
            final = next(r for r in reversed(self.runs) if r.eta == eta)
        return AccuracyLevel(eta=float(eta), search=search,
                             tested=np.array([r.eta for r in self.runs]),
                             rejected=np.array([r.rejected for r in self.runs]),
                             n_measurements=np.array([r.n_measurements for r in self.runs]),
                             final=final)


def _bracket(log: _Log, eta: float, max_steps: int = 60) -> tuple[float, float]:
    """(η_lo, η_hi) with η_lo rejected and η_hi = 2 η_lo not rejected, by doubling or halving."""
    if log.rejects(eta):
        for _ in range(max_steps):
            eta *= 2.0
            if not log.rejects(eta):
                return eta / 2.0, eta
    else:
        for _ in range(max_steps):
            eta /= 2.0
            if log.rejects(eta):
                return eta, 2.0 * eta
    raise RmbenchError(f"could not bracket the accuracy level within {max_steps} doublings or "
                       f"halvings (last eta {eta:.6g})")
