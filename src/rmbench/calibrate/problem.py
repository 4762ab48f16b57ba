"""The least-squares problem of a calibration: the residuals of measured modes (and FRFs) at a set
of postures, and their forward-difference sensitivities to the parameters, evaluated per posture and
band, in worker processes where there are several (:class:`Problem`).

The pairing of modes is held fixed while a Jacobian is taken: each stepped model's modes are tracked
to the unstepped ones by MAC and frequency, and a mode a step loses has no derivative.
"""

from __future__ import annotations

import numpy as np

from rmbench.calibrate.model import ModalModel
from rmbench.calibrate.residual import FRF_SEGMENTS, UNPAIRED, Pairing, coarse_residuals, frf_residuals, mode_residuals
from rmbench.errors import RmbenchError
from rmbench.modeshape import pair_modes

__all__ = ["Problem"]


class Problem:
    """The least-squares problem of one calibration: data residuals and their sensitivities.

    Parameters
    ----------
    mm : ModalModel
        The model, with the calibrated parameters.
    data : ModalData
    postures : sequence of int
        Posture indices into ``data`` whose residuals enter.
    settings : CalibrationSettings
        Its ``step``, ``workers`` and ``frf`` apply.
    coarse : bool
        The coarse stage's residual (:func:`~rmbench.calibrate.residual.coarse_residuals`,
        frequencies only, no FRFs) instead of :func:`~rmbench.calibrate.residual.mode_residuals`.

    Attributes
    ----------
    sigma : ndarray, shape (n_params,)
        The parameters' prior standard deviations in ``u``.
    keys : list of (int, str)
        ``(posture, band)`` of each block of residuals, in order; ``sizes`` their lengths.
    n : int
        Residuals in all.
    """

    def __init__(self, mm: ModalModel, data, postures, settings, *, coarse: bool = False):
        self.mm, self.data, self.postures = mm, data, list(postures)
        self.residual = coarse_residuals if coarse else mode_residuals
        self.sigma = mm.params.sigma()
        self.steps = settings.step * self.sigma
        self.keys = [(p, b) for p in self.postures for b in data.bands
                     if b in data.modes[p] and len(data.modes[p][b])]
        use_frf = settings.frf and not coarse and data.frf is not None
        self.targets = [data.frf[p].get(b) if use_frf else None for p, b in self.keys]
        self.sizes = [4 * len(data.modes[p][b]) + 1 + (FRF_SEGMENTS * 16 if t is not None else 0)
                      for (p, b), t in zip(self.keys, self.targets)]
        self.n = int(sum(self.sizes))
        self.workers = settings.workers
        self._pool = None
        self._scaled = {}

    def residuals(self, u) -> np.ndarray:
        """The residuals at ``u``, shape (n,)."""
        jobs = [(u, p, b, t) for (p, b), t in zip(self.keys, self.targets)]
        return np.concatenate(self._map(jobs, _residual_job))

    def residuals_many(self, us) -> list[np.ndarray]:
        """The residuals at each of ``us`` (a list of shape (n_params,)), in one map over the
        workers: each shape (n,)."""
        jobs = [(u, p, b, t) for u in us for (p, b), t in zip(self.keys, self.targets)]
        parts = self._map(jobs, _residual_job)
        k = len(self.keys)
        return [np.concatenate(parts[i * k:(i + 1) * k]) for i in range(len(us))]

    def jacobian(self, u) -> tuple[np.ndarray, np.ndarray]:
        """Residuals at ``u`` and their sensitivity, shape (n,), (n, n_params), per unit of ``u``."""
        jobs = [(u, p, b, t) for (p, b), t in zip(self.keys, self.targets)]
        parts = self._map(jobs, _sensitivity_job)
        r = np.concatenate([x[0] for x in parts])
        j = np.vstack([x[1] for x in parts])
        return r, j

    def scaled(self, z) -> tuple[np.ndarray, np.ndarray]:
        """Residuals at ``u = z σ`` and their sensitivity per prior standard deviation, shape (n,),
        (n, n_params); the last ``z``'s kept (the account asks again where the solver last took
        the Jacobian)."""
        key = z.tobytes()
        if key not in self._scaled:
            self._scaled.clear()
            r, j = self.jacobian(z * self.sigma)
            self._scaled[key] = (r, j * self.sigma[None, :])
        return self._scaled[key]

    def _map(self, jobs, task):
        """``task(self, *job)`` for each job, in worker processes where there are several."""
        from rmbench.threads import default_workers

        workers = default_workers() if self.workers is None else int(self.workers)
        if workers <= 1 or len(jobs) < 2:
            return [task(self, *job) for job in jobs]
        pool = self._executor(workers)
        return list(pool.map(_worker_job, [(task, job) for job in jobs],
                             chunksize=max(1, len(jobs) // (4 * workers))))

    def _executor(self, workers):
        if self._pool is None:
            from rmbench.parallel import worker_pool

            self._pool = worker_pool(workers, initializer=_worker_init, initargs=(self,))
        return self._pool

    def close(self):
        if self._pool is not None:
            self._pool.shutdown(cancel_futures=True)
            self._pool = None


_WORKER: dict = {}


def _worker_init(problem) -> None:
    """A worker keeps the problem it was forked with (it is not sent with every job)."""
    _WORKER["problem"] = problem


def _worker_job(item):
    task, job = item
    return task(_WORKER["problem"], *job)


def _residual_job(problem: Problem, u, p, b, target=None) -> np.ndarray:
    """The residual of one posture and band at ``u``."""
    meas = problem.data.modes[p][b]
    try:
        modes, H = problem.mm.response(u, p, b, None if target is None else target.freq)
        e, _ = problem.residual(meas, modes)
        if target is not None:
            e = np.concatenate([e, frf_residuals(target, H)])
    except RmbenchError:      # a posture these values cannot hold: every mode missing
        e = np.full(4 * len(meas) + 1 + (FRF_SEGMENTS * 16 if target is not None else 0), UNPAIRED)
    return e


def _sensitivity_job(problem: Problem, u, p, b, target=None):
    meas = problem.data.modes[p][b]
    size = 4 * len(meas) + 1
    n_frf = FRF_SEGMENTS * 16 if target is not None else 0
    try:
        (base, H0), stepped = problem.mm.sensitivity(u, p, b, problem.steps,
                                                      None if target is None else target.freq)
    except RmbenchError:
        return np.full(size + n_frf, UNPAIRED), np.zeros((size + n_frf, len(u)))
    e0, pr = problem.residual(meas, base)
    jac = np.zeros((size + n_frf, len(u)))
    f0 = frf_residuals(target, H0) if target is not None else None
    for i, (modes, H1) in enumerate(stepped):
        track = _track(base, modes)
        keep = track[pr.model] >= 0
        fixed = Pairing(pr.meas[keep], track[pr.model[keep]], pr.unpaired_meas, pr.unpaired_model)
        e1, _ = problem.residual(meas, modes, fixed)
        lost = pr.meas[~keep]
        d = (e1 - e0) / problem.steps[i]
        d[:-1].reshape(-1, 4)[lost] = 0.0     # a mode the step lost: no derivative
        jac[:size, i] = d
        if target is not None:
            jac[size:, i] = (frf_residuals(target, H1) - f0) / problem.steps[i]
    return (e0 if f0 is None else np.concatenate([e0, f0])), jac


def _track(base, stepped) -> np.ndarray:
    """Index in ``stepped`` of each mode of ``base`` (−1: not found), by MAC and frequency."""
    out = np.full(len(base), -1)
    rows, cols = pair_modes(base.f_n, stepped.f_n, base.residue, stepped.residue, freq_scale=0.05, max_cost=0.5)
    out[rows] = cols
    return out

