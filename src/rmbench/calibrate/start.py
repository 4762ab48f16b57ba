"""Where a calibration starts: a given start, the gross starts and the coarse stage, a freed
parameter's gross sizes.

A real robot can sit far from its data sheet (gearboxes ±40 %, a foundation that tilts): its modes
then lie 10-25 % from the nominal's, some pair with the wrong partner or none, and a local step
from the nominal stalls. So a fit from the nominal starts from the best of a few gross starts
(:func:`gross_start`: all gearboxes softer or stiffer together, a softer base, and a freed
structural effect's gross sizes jointly with these) and, when a mode is still unpaired or more than
3 % off there, first runs a coarse stage (:func:`coarse_start`): frequencies only, paired in a
±50 % window (:func:`~rmbench.calibrate.residual.coarse_residuals`), where losing a mode costs more
than pairing it badly. All starts are in prior standard deviations, ``z = u / σ``.
"""

from __future__ import annotations

import itertools

import numpy as np

from rmbench.calibrate.problem import Problem
from rmbench.calibrate.residual import pair
from rmbench.calibrate.solver import Bounds, SolverOptions, solve
from rmbench.errors import InputError, RmbenchError

__all__ = ["given_start", "coarse_start", "gross_start", "free_start"]


def given_start(start: dict, params, sigma, lo, hi) -> np.ndarray:
    """The scaled start ``z0`` of a given ``{name: u}`` (absent names at the nominal), kept off the
    bounds ``lo``, ``hi``."""
    unknown = set(start) - set(params.names)
    if unknown:
        raise InputError(f"no parameters {', '.join(sorted(unknown))} to start from")
    z0 = np.array([start.get(n, 0.0) for n in params.names]) / sigma
    # a start on a bound cannot leave it (trust-region steps scale with the distance)
    return np.clip(z0, lo + 0.05, hi - 0.05)



def coarse_start(problem: Problem, settings, w, lo, hi, say) -> np.ndarray:
    """The best gross start (:func:`gross_start`), then, when the model is still far from the data
    there (:func:`_far`), the coarse stage (frequencies only, in a wide window), in prior σ.

    Parameters
    ----------
    problem : Problem
        The fine problem of the calibration (its model, data and training postures).
    settings : CalibrationSettings
        Its ``free``, ``start_rank`` and ``max_iter`` (the coarse stage takes at most 10) apply.
    w : ndarray, shape (n_params,)
        The prior's weight per parameter (0: none).
    lo, hi : ndarray, shape (n_params,)
        Bounds in prior σ.
    say : callable
        ``say(message)`` after each step.
    """
    sigma = problem.sigma
    coarse = Problem(problem.mm, problem.data, problem.postures, settings, coarse=True)
    try:
        def fun_c(z):
            return np.concatenate([coarse.residuals(z * sigma), w * z])

        def many_c(zs):
            # every grid point's postures in one map: both workers busy, one round of messages
            return [np.concatenate([r, w * z]) for r, z in zip(coarse.residuals_many([z * sigma for z in zs]), zs)]

        z0 = gross_start(problem.mm.params, fun_c, lo, hi, say, free=settings.free, rank=settings.start_rank,
                         many=many_c)
        if _far(problem, z0 * sigma):
            def jac_c(z):
                _, j = coarse.jacobian(z * sigma)
                return j * sigma[None, :]

            z0 = solve(lambda z: coarse.residuals(z * sigma), jac_c, z0,
                       prior_sd=np.where(w > 0, 1.0 / np.where(w > 0, w, 1.0), np.inf), bounds=Bounds(lo, hi),
                       options=SolverOptions(max_nfev=min(10, settings.max_iter), xtol=1e-3, ftol=1e-4)).x
            say("coarse stage (frequencies in a wide window): done")
    finally:
        coarse.close()
    return z0


def gross_start(params, fun, lo, hi, say, free=(), rank: int = 0, many=None) -> np.ndarray:
    """The best of a few starts (in prior σ), by the coarse residual ``fun``: the nominal, all
    gearboxes softer or stiffer together, and a softer base. Far from the truth the pairing of
    modes is ambiguous and a local step cannot tell a better pairing from a worse one; these starts
    cover the gross differences a real robot has from its data sheet. A nominal on its bound (a
    rigid base) starts a little inside: a trust-region step is scaled by the distance to the bound,
    and one that starts on it cannot leave it.

    The parameters ``free`` (a structural effect's size) are searched jointly with these, over
    their nominal and gross sizes (:func:`_gross_sizes`; a freed base tilt over both sets). Chosen
    after the ordinary starts, an ordinary parameter has already taken up the effect and the fit
    keeps it: a foundation sliding 73 µm/kN under a robot on a rigid base, its candidate started
    at the base tilt's 110 µrad/(kN·m) (a tilt mimics a slide) and ended at a training objective
    of 3,020, where the truth's parameters give 216; searched jointly, it reached 217 (calibration
    bench, seed 27994 robot 2).

    ``many(zs)``, where given, evaluates ``fun`` at every grid point at once (the same values)."""
    names = params.names
    joints = [i for i, p in enumerate(params) if p.group == "joints"]
    base = [i for i, p in enumerate(params) if p.group == "base"]
    sigma = params.sigma()
    stiff = [0.0] + ([np.log(0.7), np.log(0.85), np.log(1.2), np.log(1.4)] if joints else [])
    soft = [0.0] + ([20.0, 40.0, 70.0, 110.0] if base else [])       # µrad/(kN·m)
    # axes of the grid: (indices set together, their u values)
    axes = [(joints, stiff), (base, soft)]
    for i, p in enumerate(params):
        if p.name not in free:
            continue
        if i in base:
            axes[1] = (base, sorted(set(soft) | set(_gross_sizes(p))))
        else:
            axes.append(([i], _gross_sizes(p)))
    points = []
    for values in itertools.product(*(v for _, v in axes)):
        z = np.zeros(len(names))
        for (idx, _), u in zip(axes, values):
            if idx:
                z[idx] = u / sigma[idx]        # u of the base is in µrad/(kN·m)
        z = np.clip(z, lo + 0.05, hi - 0.05)
        if any(np.array_equal(z, t) for t in points):    # clipped onto a point already tried
            continue
        points.append(z)
    residuals = many(points) if many is not None else [fun(z) for z in points]
    tried = [(float(r @ r), z) for r, z in zip(residuals, points)]
    tried.sort(key=lambda t: t[0])          # stable: among equal costs, the grid's order
    best = tried[min(rank, len(tried) - 1)][1]
    if len(stiff) * len(soft) > 1 or rank:
        say(f"start{f' (gross start {rank + 1})' if rank else ''}: gearboxes × "
            f"{np.exp(best[joints[0]] * sigma[joints[0]]) if joints else 1:.2f}"
            + (f", base {best[base[0]] * sigma[base[0]]:.0f} µrad/(kN·m)" if base else ""))
    for i, p in enumerate(params):
        if p.name in free:
            say(f"start: {p.name} {best[i] * sigma[i]:.3g}")
    return best



def free_start(params, free, fun, z0, lo, hi, say) -> np.ndarray:
    """``z0`` with each freed parameter at the best of its gross sizes (:func:`_gross_sizes`) by
    the residual ``fun``, one parameter after the other: a freed parameter a given start lacks. A
    fit started at a rigid foundation's bound stalls there, and one started at a gross fault's size
    finds it (measured on the calibration bench's sliding foundations)."""
    sigma = params.sigma()
    z = z0.copy()
    for i, p in enumerate(params):
        if p.name not in free:
            continue
        best, best_cost = z[i], np.inf
        for u in _gross_sizes(p):
            z[i] = np.clip(u / sigma[i], lo[i] + 0.05, hi[i] - 0.05)
            r = fun(z)
            cost = float(r @ r)
            if cost < best_cost:
                best, best_cost = z[i], cost
        z[i] = best
        say(f"start: {p.name} {best * sigma[i]:.3g}")
    return z



def _far(problem, u) -> bool:
    """Whether the model at ``u`` is far from the data: a measured mode unpaired, or a paired
    frequency more than 3 % off."""
    for p, b in problem.keys:
        meas = problem.data.modes[p][b]
        try:
            model = problem.mm.modes(u, p, b)
        except RmbenchError:
            return True
        pr = pair(meas, model)
        if len(pr.unpaired_meas) or np.any(np.abs(np.log(model.f_n[pr.model] / meas.f_n[pr.meas])) > 0.03):
            return True
    return False



def _gross_sizes(p) -> list[float]:
    """A freed parameter's trial sizes in ``u``: its nominal and a structural fault's gross sizes
    (a foundation a fifth and half of its range soft, a stiffness a third or three times, a mass
    0.7 or 1.5 times): its kind's (:attr:`~rmbench.robot.kinds.Kind.gross`)."""
    return p.kind_record.gross(p)
