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

__all__ = ["MTGP", "GroupedMTGP", "seed_groups", "split_by_postures"]


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


def split_by_postures(groups, found: np.ndarray, *, keep: float = 0.75) -> list[list[int]]:
    """``groups`` with each group whose tasks were found at different postures split, where sharing
    one model would cost a member more than a quarter of its own postures.

    An intrinsic-coregionalisation model needs all its tasks at the same postures (its covariance
    is a Kronecker product), so a group learns only where every task was found. Where a mode is
    lost at many postures (the generated Panda's 56 Hz mode, unseen along one of its test grid's two
    x lines) the modes grouped with it lose those postures too and extrapolate there: 10 % off at
    their own training postures. Such a group splits into the sets of tasks found at the same
    postures. A mode missed at a few postures costs its group-mates little, and the group keeps
    borrowing strength between them.

    Parameters
    ----------
    groups : list of list of int
        Task indices per model.
    found : ndarray of bool, shape (n_postures, n_tasks)
        Where each task has a value.
    keep : float
        The least share of a member's own postures a group may keep (its complete postures).

    Returns
    -------
    list of list of int
        Every task in exactly one group; unchanged groups keep their order.
    """
    out = []
    for g in groups:
        own = np.asarray(found)[:, g]
        if own.all(axis=1).sum() >= keep * own.sum(axis=0).max(initial=0):
            out.append(list(g))
            continue
        same: dict = {}
        for task, column in zip(g, own.T):
            same.setdefault(column.tobytes(), []).append(int(task))
        out += list(same.values())
    return out


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
        self._stack = None

    def fit(self, X, Y) -> "GroupedMTGP":
        """Fit one :class:`MTGP` per group (groups of the same task count and complete postures
        as one gpytorch batch).

        Parameters
        ----------
        X : ndarray, shape (n_postures, 3)
            Training postures: x, y (m), θ (rad).
        Y : ndarray, shape (n_postures, n_tasks)
            The tasks' values, each in its own units, NaN where missing; a group's model leaves out
            the postures where any of its tasks is NaN, and a group that would lose more than a
            quarter of a member's postures so is split first (:func:`split_by_postures`;
            ``groups`` then holds the split). A group with fewer than three complete postures is
            not learnt (``unlearnt_``: it predicts NaN).

        Returns
        -------
        GroupedMTGP
            ``self``, fitted: ``models_`` one per group, ``dropped_`` and ``retries_``,
            ``jitter_added_`` over them.
        """
        Y = np.asarray(Y, float)
        self.groups = split_by_postures(self.groups, np.isfinite(Y))
        self.n_tasks_ = Y.shape[1]
        self._stack = None
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

    def std_scale(self) -> np.ndarray:
        """Per task, the leave-one-posture-out factor that calibrates the predicted standard
        deviations (:attr:`MTGP.loo_scale_` of the task's model), shape (n_tasks,)."""
        out = np.ones(self.n_tasks_)
        for g, model in zip(self.groups, self.models_):
            out[g] = model.std_scale()
        return out

    def predict(self, X, return_std: bool = False, *, source: str = "posterior"):
        """Mean, shape (n, n_tasks), and with ``return_std`` the latent standard deviation;
        ``source`` as :meth:`MTGP.predict`'s (leave-one-out means or the data at training postures)."""
        X = np.atleast_2d(np.asarray(X, float))
        if source != "posterior":
            mu, sd = np.full((len(X), self.n_tasks_), np.nan), np.full((len(X), self.n_tasks_), np.nan)
            for g, model in zip(self.groups, self.models_):
                if model.posterior_ is not None or np.all(np.isfinite(model.constant_)):
                    mu[:, g], sd[:, g] = model.predict(X, True, source=source)
            return (mu, sd) if return_std else mu
        if self._stack is None:
            self._stack = _Stack(self.groups, self.models_, self.n_tasks_)
        return self._stack.predict(X, return_std)

    def predict_product(self, xy, theta) -> np.ndarray:
        """Means at every (location, angle) pair, shape (n * m, n_tasks), rows location-major: what
        ``predict`` gives for ``X = [repeat(xy, m), tile(theta, n)]`` (to round-off), in a
        fraction of the time (:meth:`_Stack.predict_product`)."""
        if self._stack is None:
            self._stack = _Stack(self.groups, self.models_, self.n_tasks_)
        return self._stack.predict_product(np.atleast_2d(np.asarray(xy, float)), np.atleast_1d(np.asarray(theta, float)))


class _Stack:
    """The posteriors of a :class:`GroupedMTGP`'s models padded to one size and evaluated together:
    one prediction is a few batched array operations instead of a Python loop over ~100 models
    (same algebra as :meth:`KronPosterior.predict`, in the inputs' and tasks' own units). Padded
    training rows carry zero weights and zero eigenvector rows, padded tasks zero everything, so
    they contribute nothing."""

    def __init__(self, groups, models, n_tasks):
        self.mu0 = np.full(n_tasks, np.nan)           # constants, NaN for unlearnt groups
        self.sd0 = np.full(n_tasks, np.nan)
        live = []
        for g, mdl in zip(groups, models):
            self.mu0[g] = mdl.constant_
            self.sd0[g] = np.where(np.isnan(mdl.constant_), np.nan, 0.0)
            if mdl.posterior_ is not None:
                live.append((np.asarray(g)[mdl.varying_], mdl))
        M = len(live)
        n = max((len(mdl.posterior_.X) for _, mdl in live), default=0)
        m = max((len(cols) for cols, _ in live), default=0)
        self.X, self.ls = np.zeros((M, n, 3)), np.ones((M, 3))     # X: training inputs, raw
        self.W, self.G, self.Qt = np.zeros((M, n, m)), np.zeros((M, n, m)), np.zeros((M, n, n))
        self.P2, self.kc = np.zeros((M, m, m)), np.zeros((M, m))
        self.mean, self.scale = np.zeros((M, m)), np.zeros((M, m))
        self.cols, self.slots = [], []
        for b, (cols, mdl) in enumerate(live):
            p, k, j = mdl.posterior_, len(p_x := mdl.posterior_.X), len(cols)
            self.X[b, :k] = p_x * mdl.x_scale_ + mdl.x_mean_
            self.ls[b] = p.lengthscales * mdl.x_scale_
            self.W[b, :k, :j] = p.W * mdl.y_scale_
            self.G[b, :k, :j], self.Qt[b, :k, :k], self.P2[b, :j, :j] = p.G, p.Qt, p.P2
            self.kc[b, :j] = np.diag(p.Kc)
            self.mean[b, :j] = p.mean * mdl.y_scale_ + mdl.y_mean_
            self.scale[b, :j] = mdl.y_scale_
            self.cols.append(cols)
            self.slots.append(b * m + np.arange(j))
        # centred before |z|² + |x|² − 2 z·x, which would otherwise cancel metres of offset
        self.centre = live[0][1].x_mean_ if live else np.zeros(3)
        self.Xt = ((self.X - self.centre) / self.ls[:, None]).transpose(0, 2, 1)   # (M, 3, n)
        self.X2 = (self.Xt**2).sum(1)                                       # (M, n)
        self.cols = np.concatenate(self.cols) if live else np.zeros(0, int)
        self.slots = np.concatenate(self.slots) if live else np.zeros(0, int)

    def predict(self, X, return_std, chunk: int = 256):
        if len(X) > chunk:    # bounds the (models × postures × training postures) temporaries
            parts = [self.predict(X[i:i + chunk], return_std) for i in range(0, len(X), chunk)]
            return (tuple(np.concatenate(p) for p in zip(*parts)) if return_std
                    else np.concatenate(parts))
        n_out = len(X)
        mu, sd = np.tile(self.mu0, (n_out, 1)), np.tile(self.sd0, (n_out, 1))
        if len(self.cols):
            z = (X - self.centre)[None] / self.ls[:, None]                  # (M, n*, 3)
            d2 = (z**2).sum(-1)[..., None] + self.X2[:, None] - 2 * z @ self.Xt
            k = np.exp(-0.5 * np.maximum(d2, 0.0))                          # (M, n*, n)
            out = k @ self.W + self.mean[:, None]                           # (M, n*, m)
            mu[:, self.cols] = out.transpose(1, 0, 2).reshape(n_out, -1)[:, self.slots]
            if return_std:
                u2g = np.einsum("bsn,bnm->bsm", (k @ self.Qt) ** 2, self.G)
                var = self.kc[:, None] - np.einsum("bsm,bkm->bsk", u2g, self.P2)
                out = np.sqrt(np.maximum(var, 0.0)) * self.scale[:, None]
                sd[:, self.cols] = out.transpose(1, 0, 2).reshape(n_out, -1)[:, self.slots]
        return (mu, sd) if return_std else mu

    def predict_product(self, xy: np.ndarray, theta: np.ndarray, chunk: int = 512) -> np.ndarray:
        """Means over a (location, angle) product, rows location-major, shape (n * m, n_tasks).

        The squared-exponential kernel is a product over the inputs, so at a grid's poses it is
        ``k_xy(location) · k_θ(angle)`` elementwise over the training postures: two small kernels
        and one batched matrix product per model instead of one exponential per (pose, training
        posture, model), ~15× faster at a path's 480 × 37 poses.
        """
        n, m = len(xy), len(theta)
        if len(xy) > chunk:
            return np.concatenate([self.predict_product(xy[i:i + chunk], theta, chunk)
                                   for i in range(0, len(xy), chunk)])
        mu = np.tile(self.mu0, (n * m, 1))
        if not len(self.cols):
            return mu
        M, k = self.W.shape[0], self.W.shape[2]
        dxy = (xy[None, :, None, :] - self.X[:, None, :, :2]) / self.ls[:, None, None, :2]   # (M, n, n_tr, 2)
        kxy = np.exp(-0.5 * (dxy ** 2).sum(-1))                                            # (M, n, n_tr)
        dth = (theta[None, :, None] - self.X[:, None, :, 2]) / self.ls[:, None, None, 2]     # (M, m, n_tr)
        kth = np.exp(-0.5 * dth ** 2)
        # Σ_t kxy[b,i,t] kth[b,j,t] W[b,t,c]: one (n × n_tr) @ (n_tr × m·k) product per model
        right = (kth[:, :, :, None] * self.W[:, None]).transpose(0, 2, 1, 3).reshape(M, -1, m * k)
        out = (kxy @ right).reshape(M, n * m, k) + self.mean[:, None]                      # (M, n·m, k)
        mu[:, self.cols] = out.transpose(1, 0, 2).reshape(n * m, -1)[:, self.slots]
        return mu
