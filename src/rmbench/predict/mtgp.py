"""Multi-task Gaussian processes in the seed's grouping (METHODS.md §5).

The seed groups m ≤ 3 physically similar parameters per model (:func:`seed_groups`) and fits one
intrinsic-coregionalisation GP per group (:class:`GroupedMTGP`); the single model of all parameters
and its low-rank variant are :class:`rmbench.predict.gp.MTGP` itself. Models with the same task
count and the same complete postures are fitted as one gpytorch batch.
"""

from __future__ import annotations

import numpy as np

from rmbench.errors import InputError
from rmbench.predict.gp import MTGP, fit_icm

__all__ = ["MTGP", "GroupedMTGP", "seed_groups"]


_PAIRS = (("phiL_1X_re", "phiL_1aX_re"), ("phiL_1X_im", "phiL_1aX_im"),
          ("phiL_1Y_re", "phiL_1aY_re"), ("phiL_1Y_im", "phiL_1aY_im"),
          ("phiR_1X_re", "phiR_1aX_re"), ("phiR_1X_im", "phiR_1aX_im"),
          ("phiR_1Y_re", "phiR_1aY_re"), ("phiR_1Y_im", "phiR_1aY_im"))


def seed_groups(tasks, bands=None, max_size: int = 3) -> list[list[int]]:
    """The seed's grouping of parameters into multi-task models (METHODS.md §5).

    Eigenvector parameters: same mode, same eigenvector, same direction, real and imaginary parts
    apart (1X with 1aX, 1Y with 1aY; φL's fixed element is a constant, not a task); natural
    frequencies and damping ratios:
    the same parameter across consecutive modes of one band, at most ``max_size`` per model. A task
    no rule covers is a model of its own.

    Parameters
    ----------
    tasks : sequence of str
        ``"mode{m}:{param}"``.
    bands : sequence of str, optional
        Band of each task's mode (modes of different bands are never grouped).

    Returns
    -------
    list of list of int
        Task indices per model; every task in exactly one.
    """
    tasks = list(tasks)
    bands = list(bands) if bands is not None else [""] * len(tasks)
    index = {t: i for i, t in enumerate(tasks)}
    modes = []
    for t in tasks:
        mode = t.split(":")[0]
        if mode not in modes:
            modes.append(mode)
    groups, used = [], set()
    for mode in modes:
        for pair in _PAIRS:
            g = [index[f"{mode}:{p}"] for p in pair if f"{mode}:{p}" in index]
            if g:
                groups.append(g)
                used.update(g)
    for param in ("f_n", "zeta"):
        by_band: dict = {}
        for mode in modes:
            i = index.get(f"{mode}:{param}")
            if i is not None:
                by_band.setdefault(bands[i], []).append(i)
        for members in by_band.values():
            for chunk in np.array_split(members, int(np.ceil(len(members) / max_size))):
                groups.append([int(c) for c in chunk])
                used.update(int(c) for c in chunk)
    groups += [[i] for i in range(len(tasks)) if i not in used]
    return groups


class GroupedMTGP:
    """One :class:`MTGP` (free-form K_c) per group of tasks.

    Parameters
    ----------
    groups : list of list of int
        Column indices of ``Y`` per model (:func:`seed_groups`).
    """

    def __init__(self, groups, iterations: int = 100, seed: int = 0):
        self.groups = [list(g) for g in groups]
        self.iterations, self.seed = int(iterations), int(seed)

    def fit(self, X, Y) -> "GroupedMTGP":
        Y = np.asarray(Y, float)
        self.n_tasks_ = Y.shape[1]
        self.models_ = [MTGP(iterations=self.iterations, seed=self.seed) for _ in self.groups]
        # models of the same task count and the same complete postures are fitted as one batch
        batches: dict = {}
        self.unlearnt_ = []
        for i, (g, model) in enumerate(zip(self.groups, self.models_)):
            try:
                prep = model._prepare(X, Y[:, g])
            except InputError:
                # a mode found at fewer than three postures: its group predicts NaN, the others stand
                model.constant_, model.posterior_ = np.full(len(g), np.nan), None
                self.unlearnt_.append(i)
                continue
            if prep is not None:
                key = (prep[1].shape[1], prep[2], model.rows_.tobytes())
                batches.setdefault(key, []).append((i, prep))
        for (m, rank, _), members in batches.items():
            Xs = members[0][1][0]
            fitted = fit_icm(Xs, np.stack([p[1] for _, p in members]), rank,
                             iterations=self.iterations, seed=self.seed)
            for b, (i, p) in enumerate(members):
                self.models_[i]._set(p[0], p[1], fitted, b)
        self.jitter_added_ = max(m.jitter_added_ for m in self.models_)
        self.retries_ = sum(m.retries_ for m in self.models_)
        self.dropped_ = max(m.dropped_ for m in self.models_)
        return self

    def predict(self, X, return_std: bool = False):
        n = len(np.atleast_2d(X))
        mu, sd = np.full((n, self.n_tasks_), np.nan), np.full((n, self.n_tasks_), np.nan)
        for g, model in zip(self.groups, self.models_):
            out = model.predict(X, return_std)
            if return_std:
                mu[:, g], sd[:, g] = out
            else:
                mu[:, g] = out
        return (mu, sd) if return_std else mu
