"""Quasi-random sampling: Sobol points in a joint box, and a quasi-random visiting order.

The seed explores with a quasi-random pattern because it "avoids masking periodic errors while
providing low discrepancies". Both helpers draw scrambled Sobol points from
:class:`scipy.stats.qmc.Sobol` seeded by the caller's generator, so a seed fixes them.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree
from scipy.stats import qmc

from rmbench.errors import InputError
from rmbench.tracker._checks import check_locations, check_positive_int, check_rng

__all__ = ["sobol_points", "quasi_random_order"]


def sobol_points(n: int, lower, upper, rng: np.random.Generator) -> np.ndarray:
    """The first ``n`` points of a scrambled Sobol sequence in the box [lower, upper].

    Parameters
    ----------
    n : int
        Number of points (need not be a power of two; the sequence is simply truncated).
    lower, upper : array_like, shape (dim,)
        Box corners (e.g. joint ranges in rad), lower < upper.
    rng : numpy.random.Generator
        Seeds the scrambling.

    Returns
    -------
    ndarray, shape (n, dim)
    """
    n = check_positive_int("n", n)
    lo, hi = np.atleast_1d(np.asarray(lower, float)), np.atleast_1d(np.asarray(upper, float))
    if lo.shape != hi.shape or lo.ndim != 1 or not np.all(lo < hi):
        raise InputError(f"lower and upper must be same-length vectors with lower < upper, got "
                         f"{lo.tolist()} and {hi.tolist()}")
    sobol = qmc.Sobol(len(lo), scramble=True, seed=check_rng(rng))
    m = int(np.ceil(np.log2(n)))
    return qmc.scale(sobol.random_base2(m)[:n], lo, hi)


def quasi_random_order(locations, rng: np.random.Generator) -> np.ndarray:
    """A visiting order of given locations that follows a scrambled Sobol sequence.

    Each Sobol point in the locations' bounding box takes the nearest location not yet taken, so
    the first k locations of the order are spread like the first k Sobol points (greedy matching,
    with a k-d tree).

    Parameters
    ----------
    locations : array_like, shape (n_loc,) or (n_loc, n_coord)
    rng : numpy.random.Generator

    Returns
    -------
    ndarray of int, shape (n_loc,)
        A permutation of ``range(n_loc)``.
    """
    loc = check_locations(locations)
    pts = loc.reshape(len(loc), -1)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    unit = (pts - lo) / span
    sobol = qmc.Sobol(unit.shape[1], scramble=True, seed=check_rng(rng))
    points = sobol.random_base2(int(np.ceil(np.log2(len(unit)))))[:len(unit)]
    tree = cKDTree(unit)
    near = tree.query(points, k=min(8, len(unit)))[1].reshape(len(points), -1)
    taken = np.zeros(len(unit), bool)
    order = np.empty(len(unit), int)
    for k, p in enumerate(points):
        j = next((int(i) for i in near[k] if not taken[i]), None)
        if j is None:  # all 8 neighbours taken: search among every free location
            free = np.flatnonzero(~taken)
            j = int(free[np.argmin(np.sum((unit[free] - p) ** 2, axis=1))])
        order[k] = j
        taken[j] = True
    return order
