"""Judging readings already taken on a robot: no new measurement is possible.

The readings (joint angles, measured and model positions; :mod:`rmbench.io.tracker_csv`) are
registered (a rigid best fit of the model positions to the measured ones, then the linearised base
and tool re-fit), averaged per location, and the invalidation statistic is evaluated once. If
P* > α, the sequential procedure would re-measure the worst locations: those whose p* would have to
fall for P* ≤ α are listed, worst first; a listed location already at the per-location cap means
the procedure would stop and reject.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError
from rmbench.tracker._checks import check_alpha, check_eta, check_positive_int
from rmbench.tracker.invalidation import InvalidationResult
from rmbench.tracker.registration import FrameRefit, kabsch
from rmbench.tracker.rejection import (combined_p_star, log_acceptance, probability,
                                       rejection_statistic)

__all__ = ["ReadingsJudgement", "judge_readings", "register_readings", "reading_errors"]


@dataclass(frozen=True)
class ReadingsJudgement:
    """Verdict on a fixed set of readings.

    Attributes
    ----------
    result : InvalidationResult
        Statistic of all readings (stop "explored": nothing more can be taken).
    labels : ndarray of int, shape (n_loc,)
        The readings' location labels, in the order of ``result``'s locations.
    to_remeasure : ndarray of int
        Labels of the locations the sequential procedure would re-measure, worst first (empty
        when P* ≤ α).
    at_cap : ndarray of bool
        For each of ``to_remeasure``: already at ``max_per_location`` readings.
    """

    result: InvalidationResult
    labels: np.ndarray
    to_remeasure: np.ndarray
    at_cap: np.ndarray

    @property
    def conclusive(self) -> bool:
        """True when no re-measurement could change the verdict: P* ≤ α, or every location
        that would need re-measuring is at the cap."""
        return (not self.result.rejected) or bool(len(self.at_cap) and np.all(self.at_cap))

    def worst_location(self) -> tuple:
        """``(label, error)``: the location whose mean error is largest in magnitude, and that
        magnitude (the errors' unit, m for positions)."""
        mag = np.linalg.norm(self.result.mean, axis=1)
        j = int(np.argmax(mag))
        return self.labels[j], float(mag[j])

    def to_dict(self) -> dict:
        """Plain summary for JSON output."""
        out = self.result.to_dict()
        out.pop("remeasured")
        out["locations"] = self.labels.tolist()
        out["to_remeasure"] = self.to_remeasure.tolist()
        out["at_cap"] = self.at_cap.tolist()
        out["conclusive"] = self.conclusive
        return out


def register_readings(measured, nominal, rotations=None, sigma=None) -> np.ndarray:
    """Errors (measured − registered model) after a best fit of base and tool frames, (n, 3), m.

    Parameters
    ----------
    measured, nominal : array_like, shape (n, 3), m
        Readings (tracker frame) and model predictions (any frame).
    rotations : array_like, shape (n, 3, 3), optional
        Model TCP orientations in the model's frame; with them the tool offset is fitted too.
    sigma : array_like, shape (n, 3), optional
        Per-axis standard deviations (weights).
    """
    measured = np.asarray(measured, float)
    nominal = np.asarray(nominal, float)
    rot, t = kabsch(nominal, measured)
    placed = nominal @ rot.T + t
    if rotations is None:
        rotations = np.zeros((len(placed), 3, 3))  # base only: tool columns vanish
    refit = FrameRefit(placed, rot @ np.asarray(rotations, float), sigma, min_locations=3)
    return refit(np.arange(len(placed)), measured - placed)


def reading_errors(measured, nominal, rotations=None, sigma=None, *, register: bool = True) -> np.ndarray:
    """Errors of the readings, (n, 3), m: after the best-fit registration of base and tool frames
    (:func:`register_readings`), or with ``register=False`` plain measured − nominal, for readings
    whose model positions are already in the tracker's frame.

    Parameters
    ----------
    measured, nominal : array_like, shape (n, 3), m
        Readings (tracker frame) and model predictions.
    rotations : array_like, shape (n, 3, 3), optional
        Model TCP orientations (registration only: the tool offset is fitted too).
    sigma : array_like, shape (n, 3), optional
        Per-axis standard deviations, m (registration weights).
    register : bool
        Register first (default) or take the difference as it stands.
    """
    if register:
        return register_readings(measured, nominal, rotations, sigma)
    return np.asarray(measured, float) - np.asarray(nominal, float)


def judge_readings(location, errors, sigma, eta: float, alpha: float = 0.9,
                   max_per_location: int | None = None) -> ReadingsJudgement:
    """Invalidation verdict on readings already taken.

    Parameters
    ----------
    location : array_like of int, shape (n,)
        Location label of each reading.
    errors : array_like, shape (n,) or (n, dim)
        Measured model errors (registered).
    sigma : array_like, shape (n,) or (n, dim)
        Standard deviation of each reading (per axis); must agree within a location.
    eta, alpha : float
        Accuracy level (errors' unit) and confidence level.
    max_per_location : int, optional
        Cap of the campaign; locations at it cannot be re-measured.

    Returns
    -------
    ReadingsJudgement
    """
    eta, alpha = check_eta(eta), check_alpha(alpha)
    cap = None if max_per_location is None else check_positive_int("max_per_location",
                                                                   max_per_location)
    labels, idx = np.unique(np.asarray(location), return_inverse=True)
    e = np.asarray(errors, float)
    e2 = e.reshape(len(idx), -1)
    s = np.asarray(sigma, float).reshape(len(idx), -1)
    if s.shape != e2.shape:
        raise InputError(f"sigma must have the shape of errors {e2.shape}, got {s.shape}")
    if not (np.all(np.isfinite(e2)) and np.all(np.isfinite(s)) and np.all(s > 0)):
        raise InputError("errors must be finite and sigma finite and > 0")
    n = np.bincount(idx, minlength=len(labels))
    dim = e2.shape[1]
    mean = np.stack([np.bincount(idx, e2[:, a]) for a in range(dim)], axis=1) / n[:, None]
    sig = np.zeros((len(labels), dim))
    sig[idx] = s
    stat = rejection_statistic(mean, sig / np.sqrt(n)[:, None], eta)
    log_acc = log_acceptance(stat, dim)
    threshold = np.log1p(-alpha)
    rejected = bool(log_acc.sum() < threshold)
    worst = np.argsort(log_acc, kind="stable")
    need = []
    remaining = log_acc.sum()
    for j in worst:
        if remaining >= threshold or log_acc[j] == 0.0:
            break
        need.append(j)
        remaining -= log_acc[j]
    need = np.array(need, int)
    result = InvalidationResult(
        rejected=rejected, p_star=combined_p_star(log_acc), eta=eta, alpha=alpha, stop="explored",
        locations=labels.astype(float), index=idx, measurements=e, sigma=sig, n_per_location=n,
        mean=mean, p_star_per_location=probability(log_acc),
        max_per_location=cap if cap is not None else int(n.max()))
    at_cap = (n[need] >= cap) if cap is not None else np.zeros(len(need), bool)
    return ReadingsJudgement(result, labels, labels[need], at_cap)
