"""The tracker diagnosis's least-squares engine: source models and the base registration fitted
together by the calibration stage's regularised solver, scored on held-out configurations, and
the helpers the search steps with (first-order screening, signatures, pruning)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from rmbench.gap.selection import bic, parallel_groups
from rmbench.gap.tracker.data import TrackerData
from rmbench.gap.tracker.sources import PoseModel, Source, remember
from rmbench.tracker.chain import skew

__all__ = ["Fit", "Engine", "stepped", "signatures", "pruned"]


@dataclass(frozen=True)
class Fit:
    """One fitted model: its sources and values, the registration, and its training and
    held-out χ² (per held-out configuration too)."""

    sources: tuple
    values: tuple          # one array per source
    rotation: np.ndarray   # registration: tracker = R p + t
    translation: np.ndarray
    chi2_train: float
    n_train: int
    chi2_held: float
    n_held: int
    chi2_held_unit: tuple  # per held-out configuration
    peak_held: float
    chi2_prior: float = 0.0  # Σ (v/σ)² of the parameters with a prior (the calibrated ones)

    @property
    def k(self) -> int:
        return sum(s.n_params for s in self.sources)

    @property
    def score(self) -> float:
        # the prior's term too: a calibrated parameter pulled far beyond its tolerance to mimic a
        # structural source (a 2 mm reflector offset as a j6 zero offset of 9σ, its first-order
        # look-alike) costs what the prior says it is worth
        return bic(self.chi2_held + self.chi2_prior, self.k, self.n_held)

    @property
    def names(self) -> tuple:
        return tuple(s.name for s in self.sources)

    @property
    def name(self) -> str:
        return " + ".join(self.names) if self.sources else "nominal"


class Engine:
    """Fits source models to the readings: Gauss-Newton on the sources and the registration."""

    def __init__(self, model: PoseModel, data: TrackerData, train: np.ndarray, held: np.ndarray):
        self.model, self.data = model, data
        self._recent = {}          # the last few positions and columns (see positions, columns)
        self._fits = {}            # the fits made (see fit)
        self.train, self.held = train, held          # reading indices
        self.white = data.whitening()
        if data.covariance is not None:   # the base frame's covariance turned into the tracker's
            self.white = data.whitening(self.register((), [])[0])
        self.held_units = np.unique(data.location[held])
        self.prior = {}        # {source name: prior σ per parameter}: a Gaussian prior at zero
        self.held_chol = None      # the held-out residuals' whitening once a calibration is carried (see carry)

    def prior_rows(self, sources, values) -> tuple[np.ndarray, np.ndarray]:
        """The prior's residuals ``−v/σ`` and their columns (one row per prior parameter, one
        column per parameter of ``sources``)."""
        rows, res = [], []
        n = sum(s.n_params for s in sources)
        off = 0
        for s, v in zip(sources, values):
            sd = self.prior.get(s.name)
            if sd is not None:
                for k in range(s.n_params):
                    row = np.zeros(n)
                    row[off + k] = 1.0 / sd[k]
                    rows.append(row)
                    res.append(-np.atleast_1d(v)[k] / sd[k])
            off += s.n_params
        return np.array(res), (np.array(rows) if rows else np.zeros((0, n)))

    def positions(self, sources, values, idx, *, keep: bool = True) -> np.ndarray:
        """The model's positions at readings ``idx`` (read-only). The last few asked with
        ``keep`` are kept: the solver asks for the residual at a point and then, after the
        columns' finite differences (not kept), for the registration's columns at the same
        point, which need the same positions."""
        if not keep:
            return self.model.positions(self.data.q[idx], sources, values, drive=self.data.drive(idx))
        return self._kept(("positions", _key(sources, values, idx)),
                          lambda: self.model.positions(self.data.q[idx], sources, values, drive=self.data.drive(idx)))

    def _kept(self, key, compute) -> np.ndarray:
        """``compute()``, read-only, or the same array where it was asked with ``key`` lately."""
        out = self._recent.get(key)
        if out is None:
            out = compute()
            out.flags.writeable = False
            remember(self._recent, key, out, 8)
        return out

    def residual(self, sources, values, rot, trans, idx) -> np.ndarray:
        """Normalised residuals (reading − model) / σ, shape (len(idx), 3)."""
        p = self.positions(sources, values, idx) @ rot.T + trans
        return np.einsum("nij,nj->ni", self.white[idx], self.data.measured[idx] - p)

    def error(self, sources, values, rot, trans, idx) -> np.ndarray:
        """Reading − model, m, shape (len(idx), 3)."""
        return self.data.measured[idx] - (self.positions(sources, values, idx) @ rot.T + trans)

    def columns(self, sources, values, rot, idx, *, of=None) -> np.ndarray:
        """∂(model position)/∂(parameter) / σ for the parameters of ``of`` (default: all of
        ``sources``), by forward differences, shape (3 len(idx), n_params), read-only. The last
        few are kept: a calibration's carry, its account and the first screening all ask for
        the calibrated model's columns at the training readings."""
        key = ("columns", _key(sources, values, idx), np.asarray(rot, float).tobytes(),
               None if of is None else tuple(s.name for s in of))
        return self._kept(key, lambda: self._columns(sources, values, rot, idx, sources if of is None else of))

    def _columns(self, sources, values, rot, idx, of) -> np.ndarray:
        cols = []
        w = self.white[idx]
        # forward differences from the point's own positions (kept: the solver asked for its
        # residual there first), half the evaluations of central ones. The step, 1e-3 of a
        # parameter's unit, is tiny beside the scale on which a column changes (a unit moves the
        # TCP by tens of µm and the columns change over radians and kilograms), so the columns
        # agree with central differences to about 1e-6 relative, far below the noise's share
        at = self.positions(sources, values, idx)
        for s in of:
            k_src = list(sources).index(s) if s in sources else None
            for k in range(s.n_params):
                h = 1e-3 * s.parameters[k].unit      # 1e-3 of the parameter's u
                vp, _ = stepped(sources, values, s, k, h, k_src)
                srcs = sources if k_src is not None else tuple(sources) + (s,)
                dp = (self.positions(srcs, vp, idx, keep=False) - at) @ rot.T / h
                cols.append(np.einsum("nij,nj->ni", w, dp).ravel())
        return np.column_stack(cols) if cols else np.zeros((3 * len(idx), 0))

    def registration_columns(self, sources, values, rot, idx) -> np.ndarray:
        p = self.positions(sources, values, idx) @ rot.T
        n = len(idx)
        cols = np.zeros((n, 3, 6))
        cols[:, :, :3] = np.eye(3)
        # small rotation ω of the registered points: d p = ω × p = −[p]x ω
        cols[:, :, 3:] = -skew(p)
        return np.einsum("nij,njk->nik", self.white[idx], cols).reshape(3 * n, 6)

    def prior_sd(self, sources) -> np.ndarray:
        """The prior's standard deviation per parameter of ``sources`` (inf where none)."""
        return np.concatenate([self.prior.get(s.name, np.full(s.n_params, np.inf)) for s in sources]
                              or [np.zeros(0)])

    def fit(self, sources, start=None, *, iterations: int = 6) -> Fit:
        """The sources and the base registration fitted together on the training readings, with
        the prior of the calibrated parameters: the calibration stage's regularised least squares
        (:func:`rmbench.calibrate.solver.solve`), in x = (source values, registration translation
        and small rotation about the start's). A fit asked again from the same start, with the
        same priors and held-out whitening, is the one already made (the shares' account refits
        the last pruning's models)."""
        sources = tuple(sources)
        values = [np.zeros(s.n_params) for s in sources] if start is None else \
            [np.array(v, float) for v in start]
        key = (tuple(s.name for s in sources), tuple(v.tobytes() for v in values), iterations,
               self.prior_sd(sources).tobytes())
        made = self._fits.get(key)
        if made is not None and made[0] is self.held_chol:
            return made[1]
        fit = self._fit(sources, values, iterations)
        remember(self._fits, key, (self.held_chol, fit), 256)
        return fit

    def _fit(self, sources: tuple, values: list, iterations: int) -> Fit:
        from rmbench.calibrate.solver import SolverOptions, solve

        rot0, trans0 = self.register(sources, values)
        idx = self.train
        sizes = np.cumsum([0] + [s.n_params for s in sources])
        k = int(sizes[-1])

        def unpack(x):
            vals = [x[a:b] for a, b in zip(sizes[:-1], sizes[1:])]
            return vals, Rotation.from_rotvec(x[k + 3:]).as_matrix() @ rot0, trans0 + x[k:k + 3]

        def residuals(x):
            vals, rot, trans = unpack(x)
            return self.residual(sources, vals, rot, trans, idx).ravel()

        def jacobian(x):
            # the residual is reading − model: its sensitivity is minus the model's
            vals, rot, _ = unpack(x)
            return -np.hstack([self.columns(sources, vals, rot, idx),
                               self.registration_columns(sources, vals, rot, idx)])

        x0 = np.concatenate(values + [np.zeros(6)])
        sol = solve(residuals, jacobian, x0, prior_sd=np.concatenate([self.prior_sd(sources), np.full(6, np.inf)]),
                    options=SolverOptions(max_nfev=2 * iterations, x_scale="jac", xtol=1e-8, ftol=1e-9, gtol=1e-10))
        vals, rot, trans = unpack(sol.x)
        return self.score(sources, vals, rot, trans)

    def register(self, sources, values) -> tuple[np.ndarray, np.ndarray]:
        """Weighted rigid best fit of the model's positions to the training readings."""
        from rmbench.tracker.registration import kabsch

        idx = self.train
        w = 1.0 / np.mean(self.data.sigma[idx] ** 2, axis=1)
        return kabsch(self.positions(sources, values, idx), self.data.measured[idx], w)

    def held_residual(self, sources, values, rot, trans) -> np.ndarray:
        """Normalised held-out residuals, shape (len(held), 3): over the readings' σ and, once
        :meth:`carry` has run, whitened by the calibrated parameters' own uncertainty too."""
        r = self.residual(sources, values, rot, trans, self.held)
        if self.held_chol is None:
            return r
        from scipy.linalg import solve_triangular

        return solve_triangular(self.held_chol, r.ravel(), lower=True, check_finite=False).reshape(-1, 3)

    def carry(self, fit: Fit) -> None:
        """Carry the uncertainty of ``fit``'s parameters (a calibration's, fitted on the training
        readings with their prior) into the held-out residuals: a held-out reading is predicted
        with the parameters' error as well as measured with noise, so the normalised held-out
        residuals have covariance ``C = I + J Σ Jᵀ``, and :meth:`held_residual` returns
        ``L⁻¹ r`` (``C = L Lᵀ``): independent unit normals where the model is right. Without the
        carry a calibration of 40-odd parameters on a few hundred readings leaves held-out χ²
        10-30 % above the noise on a robot that differs only in its ordinary parameters. Carried
        as a per-residual σ² (1 + j Σ jᵀ) instead, the mean is right but the parameters' error
        is one draw shared by every held-out reading: the χ² of one spread robot over seven noise
        draws ran from 684 to 997 on 750 residuals (χ²(750) spreads by ±39), read as gaps and as
        structural sources."""
        from scipy.linalg import cholesky

        from rmbench.calibrate.solver import posterior

        sd = self.prior_sd(fit.sources)
        prec = np.concatenate([np.where(np.isfinite(sd), 1.0 / np.where(np.isfinite(sd), sd, 1.0) ** 2, 0.0),
                               np.zeros(6)])

        def jac(idx):
            return np.hstack([self.columns(fit.sources, fit.values, fit.rotation, idx),
                              self.registration_columns(fit.sources, fit.values, fit.rotation, idx)])

        # the model is taken as right here (unscaled covariance): the test is whether it is
        cov = posterior(jac(self.train), prec, 0.0, 1).cov
        j_h = jac(self.held)
        c = np.eye(len(j_h)) + j_h @ cov @ j_h.T
        self.held_chol = cholesky(0.5 * (c + c.T), lower=True, check_finite=False)

    def score(self, sources, values, rot, trans) -> Fit:
        e_tr = self.residual(sources, values, rot, trans, self.train)
        e_he = self.held_residual(sources, values, rot, trans)
        loc = self.data.location[self.held]
        per = tuple(float(np.sum(e_he[loc == u] ** 2)) for u in self.held_units)
        r_p, _ = self.prior_rows(sources, values)
        return Fit(tuple(sources), tuple(np.asarray(v, float) for v in values), rot, trans,
                    float(np.sum(e_tr ** 2)), e_tr.size, float(np.sum(e_he ** 2)), e_he.size, per,
                    float(np.max(np.abs(e_he))) if e_he.size else 0.0, float(r_p @ r_p) if len(r_p) else 0.0)

    def screen(self, base: Fit, candidates) -> list[tuple[float, Source, np.ndarray]]:
        """Training χ² of ``base`` plus each candidate after one linearised step; sorted."""
        idx = self.train
        r = self.residual(base.sources, base.values, base.rotation, base.translation, idx).ravel()
        j_base = np.hstack([self.columns(base.sources, base.values, base.rotation, idx),
                            self.registration_columns(base.sources, base.values, base.rotation, idx)])
        r_p, j_p = self.prior_rows(base.sources, base.values)
        if len(r_p):        # the calibrated parameters follow a candidate only as their prior lets them
            r = np.concatenate([r, r_p])
            j_base = np.vstack([j_base, np.hstack([j_p, np.zeros((len(r_p), 6))])])
        out = []
        for s in candidates:
            j_s = self.columns(base.sources, base.values, base.rotation, idx, of=(s,))
            j_s = np.vstack([j_s, np.zeros((len(r_p), s.n_params))])
            jac = np.hstack([j_s, j_base])
            scale = np.linalg.norm(jac, axis=0)
            scale[scale == 0] = 1.0
            x = np.linalg.lstsq(jac / scale, r, rcond=1e-10)[0] / scale
            res = r - jac @ x
            out.append((float(res @ res), s, x[: s.n_params]))
        return sorted(out, key=lambda c: c[0])


def _key(sources, values, idx) -> tuple:
    """What the model's positions at readings ``idx`` depend on, as a dictionary key."""
    idx = np.asarray(idx)
    return (idx.dtype.str, idx.shape, idx.tobytes(),
            tuple((s.name, np.asarray(v, float).tobytes()) for s, v in zip(sources, values)))


def stepped(sources, values, s, k, h, k_src):
    """Values with parameter k of source s stepped ±h (s appended at zero if not in sources)."""
    if k_src is None:
        base = [np.asarray(v, float) for v in values] + [np.zeros(s.n_params)]
        k_src = len(base) - 1
    else:
        base = [np.asarray(v, float) for v in values]
    vp = [v.copy() for v in base]
    vm = [v.copy() for v in base]
    vp[k_src][k] += h
    vm[k_src][k] -= h
    return vp, vm


def signatures(eng: Engine, fit: Fit, library, *, cos_min: float = 0.995, absorbed_at: float = 1e-3):
    """Sources the registration takes up, and groups of look-alikes, from their columns at the
    nominal model after projecting out the registration's."""
    idx = eng.train
    reg = eng.registration_columns((), [], fit.rotation, idx)
    q_reg, _ = np.linalg.qr(reg)
    absorbed, vecs, names = [], [], []
    for s in library:
        cols = eng.columns((), [], fit.rotation, idx, of=(s,))
        raw = np.linalg.norm(cols, axis=0)
        proj = cols - q_reg @ (q_reg.T @ cols)
        left = np.linalg.norm(proj, axis=0)
        if np.all(left <= absorbed_at * np.maximum(raw, 1e-300)):
            absorbed.append(s.name)
            continue
        v = proj[:, int(np.argmax(left))]
        vecs.append(v / np.linalg.norm(v))
        names.append(s.name)
    return absorbed, parallel_groups(vecs, names, cos_min)


def pruned(eng: Engine, best: Fit, scored: list, base: tuple = ()) -> Fit:
    """``best`` with each source not in ``base`` dropped in turn while that lowers the score."""
    while len(best.sources) > len(base) + 1:
        drops = []
        for i in range(len(base), len(best.sources)):
            keep = tuple(s for j, s in enumerate(best.sources) if j != i)
            vals = tuple(v for j, v in enumerate(best.values) if j != i)
            drops.append(eng.fit(keep, vals))
        scored += drops
        cand = min(drops, key=lambda f: f.score)
        if cand.score >= best.score:
            break
        best = cand
    return best
