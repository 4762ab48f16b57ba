"""Model selection shared by both kinds of gap data (FRFs and tracker readings).

Candidate models are fitted on training units (postures, or tracker configurations) and scored on
held-out ones by the Bayesian information criterion ``χ²_held + k ln n_held``; a richer model must
close more of the held-out gap than its parameters are worth.

* :func:`significant`: whether normalised residuals exceed the noise (χ² and largest residual);
* :func:`selection_weights`: bootstrap model-selection frequencies over the held-out units
  (Buckland, Burnham & Augustin 1997), or over-dispersed BIC weights with fewer than four units;
* :func:`confidences`: an effect's confidence, the summed weight of the models containing it;
* :func:`bootstrap_shrink`: how much of the held-out gap a model closes, with its interval;
* :data:`Verdict`: what a diagnosis of either kind concludes.

The rules, their thresholds and the tests that specify them: docs/design.md, "Verdict rules".
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np
from scipy.stats import chi2 as chi2_dist
from scipy.stats import norm

from rmbench.errors import InputError

__all__ = ["Verdict", "VERDICTS", "SearchSettings", "significant", "bic", "selection_weights", "confidences",
           "bootstrap_shrink", "parallel_groups"]

Verdict = Literal["explained", "unexplained", "model form", "no significant gap"]
"""What a diagnosis concludes: a model of the library explains the gap; none does; none does and the
calibrated model's form is wrong (its ordinary parameters cannot explain the held-out
frequencies, :mod:`rmbench.calibrate.form`); or the data show no gap beyond the noise."""

VERDICTS: tuple = get_args(Verdict)


@dataclass(frozen=True)
class SearchSettings:
    """What every gap search shares (FRF data and tracker readings).

    Attributes
    ----------
    heldout : float
        Share of the postures or configurations held out of every fit (every other one at 0.5).
    refine : int
        Candidates refined after each screening.
    p_noise : float
        A held-out χ² whose p-value against the noise falls below this is a gap.
    bootstrap : int
        Resamples of the held-out postures or configurations for the shrink's interval.
    kinds : tuple of str or None
        Restrict the library to these kinds.
    """

    heldout: float = 0.5
    refine: int = 6
    p_noise: float = 1e-3
    bootstrap: int = 400
    kinds: tuple | None = None

    def __post_init__(self):
        if not 0 < self.heldout < 1:
            raise InputError(f"heldout must be between 0 and 1, got {self.heldout!r}")
        if not 0 < self.p_noise < 1:
            raise InputError(f"p_noise must be between 0 and 1, got {self.p_noise!r}")
        if self.refine < 1:
            raise InputError(f"refine must be 1 or more, got {self.refine!r}")
        if self.bootstrap < 0:
            raise InputError(f"bootstrap must be 0 or more, got {self.bootstrap!r}")


def significant(chi2: float, n: int, *, p: float = 1e-3, peak: float | None = None) -> bool:
    """Whether ``n`` normalised residuals exceed what noise gives, at level ``p``.

    Two tests, each at ``p/2``: the χ² of all residuals (a gap spread thinly over many), and
    the largest residual ``peak`` against the Bonferroni bound for ``n`` normal ones (a gap
    concentrated in a few — a damping change of one joint's modes, one bad configuration — that
    the χ² of thousands of residuals dilutes).
    """
    n = max(n, 1)
    if chi2_dist.sf(chi2, n) < p / 2:
        return True
    return bool(peak is not None and 2 * norm.sf(abs(peak)) * n < p / 2)


def bic(chi2: float, k: int, n: int) -> float:
    """Held-out score ``χ² + k ln n`` (k parameters, n held-out residuals)."""
    return float(chi2 + k * np.log(max(n, 2)))


def selection_weights(chi2_units, n_units, k, *, n_boot: int = 400, seed: int = 0) -> np.ndarray:
    """Weight of each model: the share of bootstrap resamples of the held-out units it wins.

    Parameters
    ----------
    chi2_units : array_like, shape (n_models, n_units)
        Held-out χ² of each model on each unit.
    n_units : array_like, shape (n_units,)
        Residuals per unit.
    k : array_like, shape (n_models,)
        Parameters per model.

    Returns
    -------
    ndarray, shape (n_models,)
        Summing to 1. With fewer than four units: BIC weights ``exp(−ΔBIC / 2ĉ)``, ``ĉ`` the best
        model's χ² per residual when above 1 (over-dispersion).
    """
    chi2 = np.atleast_2d(np.asarray(chi2_units, float))
    n_res = np.asarray(n_units, float)
    k = np.asarray(k, float)
    n_mod, n_post = chi2.shape
    if n_post < 4:
        scores = chi2.sum(axis=1) + k * np.log(max(n_res.sum(), 2))
        best = int(np.argmin(scores))
        c_hat = max(1.0, chi2[best].sum() / max(n_res.sum(), 1))
        w = np.exp(-(scores - scores.min()) / (2 * c_hat))
        return w / w.sum()
    rng = np.random.default_rng(seed)
    wins = np.zeros(n_mod)
    for _ in range(n_boot):
        idx = rng.integers(0, n_post, n_post)
        score = chi2[:, idx].sum(axis=1) + k * np.log(max(n_res[idx].sum(), 2))
        wins[int(np.argmin(score))] += 1
    return wins / n_boot


def confidences(members, weights) -> dict:
    """``{effect name: summed weight of the models containing it}``.

    ``members``: per model, the names of its effects.
    """
    out: dict[str, float] = {}
    for names, w in zip(members, weights):
        for name in names:
            out[name] = out.get(name, 0.0) + float(w)
    return out


def bootstrap_shrink(before, after, n_boot: int, seed: int = 0) -> tuple[float, tuple[float, float]]:
    """Shrink of the held-out rms gap, ``1 − √(Σ after / Σ before)``, and its 95 % bootstrap
    interval over the held-out units.

    Parameters
    ----------
    before, after : array_like, shape (n_units,)
        Per held-out unit (posture or configuration), the summed squared gap of the model
        without and with the effect (normalised residuals or pose errors in m²: the ratio is
        what counts).
    n_boot : int
        Resamples of the units.
    """
    c0, c1 = np.asarray(before, float), np.asarray(after, float)

    def shrink(idx):
        s0 = c0[idx].sum()
        return 1 - np.sqrt(c1[idx].sum() / s0) if s0 > 0 else 0.0

    rng = np.random.default_rng(seed)
    boots = [shrink(rng.integers(0, len(c0), len(c0))) for _ in range(n_boot)]
    return float(shrink(np.arange(len(c0)))), (float(np.percentile(boots, 2.5)), float(np.percentile(boots, 97.5)))


def parallel_groups(vecs, names, cos_min: float = 0.995) -> tuple:
    """Groups of names whose unit signatures ``vecs`` (one row each) are parallel, |cos| ≥ ``cos_min``:
    look-alikes the data cannot tell apart (under 1 % of either's energy, 1 − cos², left between them).
    Each name in one group at most, groups in the order of their first member."""
    if len(vecs) < 2:
        return ()
    V = np.array(vecs)
    cos = np.abs(V @ V.T)
    groups, used = [], set()
    for i in range(len(names)):
        if i in used:
            continue
        g = [j for j in range(len(names)) if cos[i, j] >= cos_min]
        if len(g) > 1:
            used.update(g)
            groups.append(tuple(names[j] for j in g))
    return tuple(groups)
