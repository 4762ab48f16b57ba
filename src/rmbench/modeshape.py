"""Mode shapes compared: the Modal Assurance Criterion and the pairing of two sets of modes.

Every stage that compares modes (the campaign's mode tracking, the modal fit's pole selection and
scoring, the calibration's residual, the gap diagnosis) uses these two, so that a MAC and a pair
mean the same everywhere:

- :func:`mac`: ``MAC(φ, ψ) = |φᴴ ψ|² / (φᴴ φ · ψᴴ ψ)`` between the rows of two sets of shapes;
- :func:`pair_modes`: one-to-one pairs of two sets of modes at minimum total cost
  ``(1 − MAC) + frequency distance / freq_scale`` (Hungarian assignment), pairs beyond a gate
  dropped.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

__all__ = ["mac", "pair_modes"]

_TIE = 1e-6          # weight of the tie-breaking squared distance
_IMPOSSIBLE = 1e12   # cost of a pair outside the window


def mac(a, b, *, zero: float = np.nan) -> np.ndarray:
    """Modal Assurance Criterion between the rows of ``a`` and the rows of ``b``.

    ``MAC(φ, ψ) = |φᴴ ψ|² / (φᴴ φ · ψᴴ ψ)``: 1 for shapes equal up to a complex factor, 0 for
    orthogonal ones.

    Parameters
    ----------
    a : array_like, shape (n, k) or (k,)
        Shapes, one a row; complex allowed.
    b : array_like, shape (m, k) or (k,)
    zero : float
        The MAC given where a row has zero norm (``0 / 0``); NaN by default. A row holding NaN
        gives NaN whatever ``zero``.

    Returns
    -------
    ndarray, shape (n, m)
        ``MAC(a[i], b[j])``; a 1-D argument is one shape and drops its axis (shape (m,), (n,) or
        a scalar for two vectors).
    """
    a, b = np.asarray(a), np.asarray(b)
    a2, b2 = np.atleast_2d(a), np.atleast_2d(b)
    num = np.abs(a2.conj() @ b2.T) ** 2
    den = np.outer(np.sum(np.abs(a2) ** 2, axis=1), np.sum(np.abs(b2) ** 2, axis=1))
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(den == 0, zero, num / den)
    return out[0 if a.ndim == 1 else slice(None), 0 if b.ndim == 1 else slice(None)]


def pair_modes(f_a, f_b, shapes_a, shapes_b, *, freq_scale: float, freq: str = "log",
               max_cost: float | None = None, window: float | None = None,
               zero: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Pair two sets of modes one to one by shape and frequency (Hungarian assignment).

    The pairs minimise the total cost ``(1 − MAC(a_i, b_j)) + d(f_a_i, f_b_j) / freq_scale``: a
    frequency distance of ``freq_scale`` weighs as much as the MAC falling from 1 to 0. A MAC that
    is NaN (a mode without shape, e.g. a table of frequencies and dampings) counts as 1: such a
    mode pairs by frequency alone.

    Parameters
    ----------
    f_a : array_like, shape (n,)
        Natural frequencies of the first set, Hz.
    f_b : array_like, shape (m,)
        Natural frequencies of the second set (the reference for ``freq="relative"``), Hz.
    shapes_a : array_like, shape (n, ...)
        Shapes of the first set (complex allowed), each flattened to a row of ``k`` entries (e.g.
        residue matrices, shape (n, n_out, n_in)).
    shapes_b : array_like, shape (m, ...)
    freq_scale : float
        The frequency distance that weighs as much as a MAC of 0 (dimensionless).
    freq : {"log", "relative"}
        The frequency distance: ``|ln(f_b / f_a)|``, or ``|f_a / f_b − 1|`` (relative to the
        second set).
    max_cost : float, optional
        The gate: a mode left unpaired costs this much, so no pair costing more is made, and a
        pair beyond it never displaces a closer one.
    window : float, optional
        Pairs whose frequencies differ by this factor or more (``|ln(f_b / f_a)| ≥ ln(window)``)
        are not made.
    zero : float
        MAC of a shape of zero norm (see :func:`mac`).

    Returns
    -------
    rows : ndarray of int, shape (n_pairs,)
        Index in the first set of each pair, ascending.
    cols : ndarray of int, shape (n_pairs,)
        Index in the second set of each pair.
    """
    f_a, f_b = np.asarray(f_a, float), np.asarray(f_b, float)
    if not len(f_a) or not len(f_b):
        return np.zeros(0, int), np.zeros(0, int)
    m = mac(np.reshape(shapes_a, (len(f_a), -1)), np.reshape(shapes_b, (len(f_b), -1)), zero=zero)
    m = np.where(np.isfinite(m), m, 1.0)
    if freq == "log":
        dist = _dist_log(f_a, f_b)
    elif freq == "relative":
        dist = np.abs(f_a[:, None] / f_b[None, :] - 1)
    else:
        raise ValueError(f"freq must be 'log' or 'relative', not {freq!r}")
    cost = (1 - m) + dist / freq_scale
    n, k = cost.shape
    allowed = np.ones(cost.shape, bool) if window is None else _dist_log(f_a, f_b) < np.log(window)
    gate = np.inf if max_cost is None else max_cost
    # Leaving a mode unpaired costs the gate (a dummy partner each), so a pair beyond the gate
    # never displaces a closer one: with the assignment forced on every row, a mode that cannot
    # pair within the gate used to take a partner all the same, and the sum of |ln| distances,
    # linear on either side, made such choices exact ties. The small squared term breaks the
    # remaining ties (two modes on the same side of two partners) towards the order-preserving pairs.
    work = np.where(allowed, cost + _TIE * (dist / freq_scale) ** 2, _IMPOSSIBLE)
    dummy = np.full((n, n), min(gate, _IMPOSSIBLE / 2))
    rows, cols = linear_sum_assignment(np.hstack([work, dummy]))
    keep = (cols < k)
    keep[keep] &= allowed[rows[keep], cols[keep]] & (cost[rows[keep], cols[keep]] <= gate)
    return rows[keep], cols[keep]


def _dist_log(f_a, f_b) -> np.ndarray:
    """``|ln(f_b / f_a)|`` between every mode of two sets, shape (n, m)."""
    return np.abs(np.log(np.asarray(f_b, float)[None, :] / np.asarray(f_a, float)[:, None]))
