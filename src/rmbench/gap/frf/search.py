"""Which effect: fit every candidate on training postures, score it on held-out ones, rank.

1. **Screening** (every candidate): one finite-difference step of each parameter on the exact
   linearisation gives the first-order change of the normalised gap vector; a bounded linear
   least-squares fit of those sensitivities, and the gap on a grid of each parameter for
   effects that act far from linearly, say how far the candidate could close the gap.
2. **Refinement** (the best few): bounded nonlinear least squares (trust region) with the model
   re-simulated — re-settled and re-linearised at every posture — at every evaluation.
3. **Held-out score**: the fitted candidate's χ² on postures it never saw, plus the Bayesian
   information criterion's penalty ``k ln n`` (k its parameters, n the held-out residuals): a
   richer model must close more of the held-out gap than its parameters are worth.
4. **Pairs**, when no single effect brings the held-out gap down to the noise: every other
   candidate is screened again on top of each of the two best singles (forward selection), and
   the best few of those pairs are refined and scored the same way.

Confidences are bootstrap model-selection frequencies (Buckland, Burnham & Augustin 1997): the
held-out postures are resampled with replacement, every scored model (the nominal one, the
singles, the pairs) gets its held-out BIC on the resample, and a model's weight is the share of
resamples it wins. A model whose advantage rests on a few postures wins only some resamples,
which Gaussian BIC weights ``exp(−ΔBIC / 2)`` over residuals that are not independent noise would
not show. With fewer than four held-out postures the BIC weights are used, scaled by the
over-dispersion ``ĉ`` (the best model's held-out χ² per residual when above 1). An effect's
confidence sums the weights of the models that contain it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import lsq_linear

from rmbench.errors import RmbenchError
from rmbench.gap.frf.effects import Change, Effect
from rmbench.calibrate.residual import FRF_SEGMENTS, frf_residuals, mode_residuals, penalties
from rmbench.calibrate.solver import Bounds, SolverOptions, solve
from rmbench.gap.selection import significant
from rmbench.parallel import worker_pool

__all__ = ["Objective", "Screen", "Fitted", "Refiner", "screen", "refine", "combined_change", "significant",
           "peak_residual", "per_posture_chi2", "GRID_PAIR"]

# kinds whose parameter adds to itself rather than compounding (a second step is not a second
# factor): their Jacobian columns are re-simulated at the stepped value
_ADDITIVE = ("added_mass", "base_compliance", "non_reciprocity", "load_dependent_stiffness")
_FAILED = 30.0   # residual of a change the model cannot be evaluated with
# screening grids, as fractions of a parameter's upper (positive) or lower (negative) bound
_GRID_FAST = (-0.75, -0.45, -0.25, -0.12, 0.12, 0.25, 0.45, 0.75)
_GRID_SLOW = (-0.6, -0.2, 0.2, 0.6)
GRID_PAIR = (-0.5, -0.2, 0.2, 0.5)
_GRID_CORNER = (-0.6, -0.2, 0.2, 0.6)    # per parameter, for the corners of two-parameter effects


def _informative(meas) -> int:
    """Residual slots that carry information: 4 a mode with a measured shape, 2 without."""
    shaped = np.isfinite(meas.residue.reshape(len(meas), -1)).all(axis=1) if len(meas) else np.zeros(0, bool)
    return int(4 * shaped.sum() + 2 * (~shaped).sum())


def combined_change(effects, values) -> Change:
    """The change of several effects with their values (one array per effect)."""
    total = Change()
    for e, v in zip(effects, values):
        total = total + e.change(v)
    return total


class Objective:
    """The normalised gap vector over a set of postures, for any change of the model.

    Per posture and band: the modal residuals of every measured mode and the FRF segment
    residuals (:mod:`rmbench.calibrate.residual`).

    Parameters
    ----------
    bench : ModelBench
    meas : list of dict
        Per posture ``{band: MeasuredModes}``.
    frf : list of dict
        Per posture ``{band: FrfTarget}``.
    bands : sequence of str
    postures : sequence of int
        Indices (into ``meas`` and the bench) of the postures this objective covers.
    """

    def __init__(self, bench, meas, frf, bands, postures):
        self.bench = bench
        self.meas = meas
        self.frf = frf
        self.bands = tuple(bands)
        self.postures = tuple(int(p) for p in postures)
        self.evaluations = 0

    def subset(self, postures) -> "Objective":
        """The objective over other postures of the same bench and data."""
        return Objective(self.bench, self.meas, self.frf, self.bands, postures)

    def rebound(self, bench, fitted_on=None) -> "Objective":
        """The same objective on another bench of the same robot and design (a worker's own);
        ``fitted_on``: the training objective a held-out one is scored with, where it has one."""
        return Objective(bench, self.meas, self.frf, self.bands, self.postures)

    def _target(self, p, b):
        return self.frf[p][b] if self.frf is not None else None

    def posture_vector(self, change: Change, p: int) -> np.ndarray:
        try:
            return self._posture_vector(change, p)
        except RmbenchError:
            # a change the robot cannot hold the posture with (it sags away): as far from the
            # data as anything gets
            return np.full(self._size(p), _FAILED)

    def _size(self, p: int) -> int:
        return sum(4 * len(self.meas[p][b]) + 1
                   + (FRF_SEGMENTS * 16 if self._target(p, b) is not None else 0) for b in self.bands)

    def _posture_vector(self, change: Change, p: int) -> np.ndarray:
        parts = []
        for b in self.bands:
            parts.append(mode_residuals(self.meas[p][b], self.bench.modes(change, p, b))[0])
            t = self._target(p, b)
            if t is not None:
                parts.append(frf_residuals(t, self.bench.frf(change, p, b, t.freq)))
        return np.concatenate(parts)

    def vector(self, change: Change) -> np.ndarray:
        self.evaluations += 1
        parts = [self.posture_vector(change, p) for p in self.postures]
        return np.concatenate(parts) if parts else np.zeros(0)

    def vector_fast(self, base: Change, delta: Change) -> np.ndarray:
        """The gap vector of ``base + delta`` to first order (``delta`` on ``base``'s
        linearisation; exact for ``delta`` the fast path does not take)."""
        if not self.bench.fast(delta):
            return self.vector(base + delta)
        self.evaluations += 1
        parts = []
        for p in self.postures:
            try:
                here = []
                for b in self.bands:
                    here.append(mode_residuals(self.meas[p][b],
                                               self.bench.modes_fast(base, delta, p, b))[0])
                    t = self._target(p, b)
                    if t is not None:
                        here.append(frf_residuals(t, self.bench.frf_fast(base, delta, p, b, t.freq)))
                parts.append(np.concatenate(here))
            except RmbenchError:
                parts.append(np.full(self._size(p), _FAILED))
        return np.concatenate(parts)

    def chi2(self, change: Change) -> float:
        e = self.vector(change)
        return float(e @ e)

    def n_posture(self, p: int) -> int:
        return sum(_informative(self.meas[p][b]) + 1
                   + (FRF_SEGMENTS * 16 if self._target(p, b) is not None else 0) for b in self.bands)

    @property
    def n(self) -> int:
        return sum(self.n_posture(p) for p in self.postures)

    def per_posture(self, change: Change) -> np.ndarray:
        """χ² of each posture (all bands), shape (n_postures,)."""
        return np.array([float(np.sum(self.posture_vector(change, p) ** 2)) for p in self.postures])


@dataclass(frozen=True)
class Screen:
    """First-order screening of one effect: fitted values and the χ² they reach (linearised)."""

    effect: Effect
    values: np.ndarray
    chi2: float
    sensitivity: np.ndarray   # (n_residuals, n_params) on the screening postures


@dataclass(frozen=True)
class Fitted:
    """A candidate model (one or more effects) fitted on training postures and scored held out.

    Attributes
    ----------
    effects : tuple of Effect
    values : tuple of ndarray
        Fitted parameters, one array per effect (the parameters' units).
    chi2_train, chi2_held : float
    n_train, n_held : int
        Numbers of normalised residuals.
    peak_held : float
        Largest held-out normalised residual (absolute).
    chi2_held_posture : tuple of float
        The held-out χ² of each held-out posture (for the bootstrap of the confidences).
    score : float
        ``chi2_held + k ln n_held`` (k: parameters of all effects).
    evaluations : int
        Model re-simulations the fit took.
    """

    effects: tuple
    values: tuple
    chi2_train: float
    chi2_held: float
    n_train: int
    n_held: int
    evaluations: int = 0
    peak_held: float = 0.0
    chi2_held_posture: tuple = ()
    extra: dict = field(default_factory=dict)

    @property
    def k(self) -> int:
        return sum(e.n_params for e in self.effects)

    @property
    def score(self) -> float:
        return self.chi2_held + self.k * np.log(max(self.n_held, 2))

    @property
    def name(self) -> str:
        return " + ".join(e.name for e in self.effects) if self.effects else "nominal"

    def change(self) -> Change:
        return combined_change(self.effects, self.values)


def screen(objective: Objective, effect: Effect, e0: np.ndarray, base: Change = Change(), *,
           grid=None) -> Screen:
    """Fit one effect on top of ``base`` (whose gap vector is ``e0``), cheaply.

    Sensitivities by one step per parameter give a bounded linear least-squares estimate; since
    some effects act far from linearly (a softened servo brings a new mode into the band, a
    softer joint moves a mode past another), the gap is also evaluated at that estimate and on a
    grid of each parameter (``grid``: fractions of its bounds; by default finer for the effects
    the fast path takes), and the best evaluated point wins.
    """
    if grid is None:
        grid = _GRID_FAST if objective.bench.fast(effect.change(effect.steps())) else _GRID_SLOW
    steps = effect.steps()
    cols = []
    for k in range(effect.n_params):
        v = np.zeros(effect.n_params)
        v[k] = steps[k]
        cols.append((objective.vector_fast(base, effect.change(v)) - e0) / steps[k])
    J = np.column_stack(cols)
    lo, hi = effect.lower(), effect.upper()
    lo0, hi0 = np.minimum(lo, 0.0), np.maximum(hi, 0.0)   # the nominal (0) is always feasible
    points = [np.zeros(effect.n_params)]
    if np.any(J):
        points.append(np.clip(lsq_linear(J, -e0, bounds=(lo0, hi0)).x, lo, hi))
    axis = [[frac * (hi[k] if frac > 0 else -lo[k]) for frac in grid] for k in range(effect.n_params)]
    for k in range(effect.n_params):
        for x in axis[k]:
            if x != 0:
                v = np.zeros(effect.n_params)
                v[k] = x
                points.append(v)
    if effect.n_params == 2:
        # two parameters that trade off (a base's lateral and tilt compliance, a spindle's
        # radial and tilt stiffness): a coarse grid's corners too, or the search stays on the axes
        corner = [[f * (hi[k] if f > 0 else -lo[k]) for f in _GRID_CORNER] for k in range(2)]
        points += [np.array([a, b]) for a in corner[0] for b in corner[1] if a != 0 and b != 0]
    best, best_chi2 = points[0], float(e0 @ e0)
    for v in points[1:]:
        e = objective.vector_fast(base, effect.change(v))
        c = float(e @ e)
        if c < best_chi2:
            best, best_chi2 = v, c
    return Screen(effect, best, best_chi2, J)


def refine(train: Objective, held: Objective, effects, start, *, max_nfev: int = 25) -> Fitted:
    """Bounded nonlinear least squares of ``effects`` on ``train``, scored on ``held``.

    Parameters
    ----------
    start : sequence of ndarray
        Starting values per effect (e.g. from :func:`screen`).
    """
    effects = tuple(effects)
    sizes = [e.n_params for e in effects]
    lo = np.concatenate([e.lower() for e in effects])
    hi = np.concatenate([e.upper() for e in effects])
    scale = np.concatenate([e.steps() for e in effects])
    x0 = np.clip(np.concatenate([np.asarray(s, float) for s in start]), lo, hi)
    n0 = train.evaluations

    def split(x):
        return tuple(np.array(part) for part in np.split(x, np.cumsum(sizes)[:-1]))

    last = {}

    def fun(x):
        e = train.vector(combined_change(effects, split(x)))
        last["x"], last["e"] = x.copy(), e
        return e

    def jac(x):
        # exact residual, first-order Jacobian: each parameter's step applied to the model at x
        # through the fast path (a re-simulation per column where the effect needs one)
        e = last["e"] if "x" in last and np.array_equal(last["x"], x) else fun(x)
        base = combined_change(effects, split(x))
        cols = []
        for i, eff in enumerate(effects):
            for k in range(eff.n_params):
                h = np.zeros(eff.n_params)
                h[k] = 0.2 * eff.steps()[k]
                if x[sum(sizes[:i]) + k] + h[k] > hi[sum(sizes[:i]) + k]:
                    h[k] = -h[k]
                if eff.kind in _ADDITIVE:
                    v = split(x)[i].copy()
                    v[k] += h[k]
                    others = list(split(x))
                    others[i] = v
                    cols.append((train.vector(combined_change(effects, others)) - e) / h[k])
                else:
                    cols.append((train.vector_fast(base, eff.change(h)) - e) / h[k])
        return np.column_stack(cols)

    # the calibration's solver, without a prior (an effect's size is what the data say); x_scale:
    # one finite-difference step of each parameter is a comparable move
    sol = solve(fun, jac, x0, prior_sd=np.full(len(x0), np.inf), bounds=Bounds(lo, hi + 1e-12 * (hi == lo)),
                options=SolverOptions(max_nfev=max_nfev, x_scale=scale, xtol=1e-4, ftol=1e-4))
    values = split(sol.x)
    change = combined_change(effects, values)
    chi2_train = sol.chi2
    e_held = held.vector(change)
    return Fitted(effects, values, chi2_train, float(e_held @ e_held), train.n, held.n,
                  evaluations=train.evaluations - n0, peak_held=peak_residual(e_held),
                  chi2_held_posture=per_posture_chi2(held, e_held))


def per_posture_chi2(objective: Objective, e: np.ndarray) -> tuple:
    """χ² of each posture of ``objective`` from its whole residual vector ``e``."""
    sizes = [objective.n_posture(p) for p in objective.postures]
    parts = np.split(np.asarray(e), np.cumsum(sizes)[:-1])
    return tuple(float(x @ x) for x in parts)


def peak_residual(e: np.ndarray) -> float:
    """The largest normalised gap of a residual vector, the pairing's penalties left out
    (:func:`rmbench.calibrate.residual.penalties`): what the peak test compares with noise."""
    e = np.asarray(e, float)
    gaps = np.abs(e[~penalties(e)])
    return float(gaps.max()) if len(gaps) else 0.0


class Refiner:
    """Refines candidate models, in worker processes when there are several to do.

    Each worker rebuilds the model bench once (robot from its MJCF, test design, commands) and
    refines the candidates it is sent; in this process otherwise.

    Parameters
    ----------
    train, held : Objective
        The objectives of this process (their bench and data are sent to the workers).
    workers : int
        Processes (0 or 1: refine here).
    """

    def __init__(self, train: Objective, held: Objective, workers: int = 0):
        self.train, self.held = train, held
        self.workers = int(workers or 0)
        self._pool = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self._pool is not None:
            self._pool.shutdown(cancel_futures=True)
            self._pool = None

    def run(self, jobs) -> list[Fitted]:
        """Refine each ``(effects, start)`` of ``jobs``; results in the same order."""
        jobs = list(jobs)
        if self.workers <= 1 or len(jobs) < 2:
            return [refine(self.train, self.held, e, s) for e, s in jobs]
        return list(self._executor().map(_refine_job, jobs))

    def screen(self, effects, e0: np.ndarray, base: Change = Change(), grid=None,
               postures=None) -> list[Screen]:
        """:func:`screen` of each effect on top of ``base`` (gap vector ``e0``), in order.

        ``postures``: screen on these training postures only (``e0`` is then theirs).
        """
        effects = list(effects)
        if self.workers <= 1 or len(effects) < 2:
            obj = self.train if postures is None else self.train.subset(postures)
            return [screen(obj, e, e0, base, grid=grid) for e in effects]
        # several chunks per worker: the effects' costs differ (a re-simulation or not)
        n_chunks = min(len(effects), 4 * self.workers)
        chunks = [effects[i::n_chunks] for i in range(n_chunks)]
        done = list(self._executor().map(_screen_job, [(c, e0, base, grid, postures) for c in chunks]))
        by_name = {s.effect.name: s for part in done for s in part}
        return [by_name[e.name] for e in effects]

    def _executor(self):
        if self._pool is None:
            b = self.train.bench
            # the objectives travel whole (a forked worker inherits them) and are rebound to the
            # worker's own bench
            state = (b.robot.xml, b.robot.name, b.robot.tool, b.robot.spindle_rpm,
                     b.design.config.model_dump_json(), b.q_cmd, self.train, self.held)
            self._pool = worker_pool(self.workers, initializer=_init_worker, initargs=(state,))
        return self._pool


_WORKER: dict = {}


def _init_worker(state) -> None:
    """A worker rebuilds the model bench once and binds the objectives to it (it is single-threaded
    already: :func:`rmbench.parallel.worker_pool`)."""
    from rmbench.calibrate.design import TestDesign
    from rmbench.gap.frf.model import ModelBench
    from rmbench.impact.config import CampaignConfig
    from rmbench.robot import Robot

    xml, name, tool, rpm, design_json, q_cmd, train, held = state
    robot = Robot(xml, name=name, tool=tool, spindle_rpm=rpm)
    bench = ModelBench(robot, TestDesign(CampaignConfig.model_validate_json(design_json)), q_cmd)
    _WORKER["train"] = train.rebound(bench)
    _WORKER["held"] = held.rebound(bench, fitted_on=_WORKER["train"])


def _refine_job(job) -> Fitted:
    effects, start = job
    return refine(_WORKER["train"], _WORKER["held"], effects, start)


def _screen_job(job) -> list[Screen]:
    effects, e0, base, grid, postures = job
    obj = _WORKER["train"] if postures is None else _WORKER["train"].subset(postures)
    return [screen(obj, e, e0, base, grid=grid) for e in effects]
