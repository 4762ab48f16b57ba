"""Which postures a fit holds out: one rule for the calibration and the FRF gap diagnosis.

Held-out postures must cover the workspace as the training ones do, or the held-out score measures
an extrapolation. So the postures are ordered by (θ, x, y) and ``k`` of them are taken at even strides
through that order, each from the middle of its stride: every other posture for half held out, with
the angle, the slowest-varying coordinate of a posture grid, shared evenly.
"""

from __future__ import annotations

import numpy as np

__all__ = ["spread_held_out", "held_out_postures"]


def spread_held_out(x, y, theta, k: int) -> list[int]:
    """``k`` posture indices spread over the postures in (θ, x, y) order, sorted.

    Parameters
    ----------
    x, y : array_like, shape (n,), m
    theta : array_like, shape (n,), rad
    k : int
        How many to hold out, ``0 ≤ k ≤ n``.
    """
    n = len(x)
    if k <= 0:
        return []
    order = np.lexsort((np.asarray(y, float), np.asarray(x, float), np.asarray(theta, float)))
    step = n / k
    return sorted({int(order[int(i * step + step / 2) % n]) for i in range(k)})


def held_out_postures(data, k: int) -> list[int]:
    """``k`` posture indices of measured modes (:class:`~rmbench.calibrate.data.ModalData`) held
    out of a calibration: :func:`spread_held_out` of their postures, sorted."""
    post = data.postures
    return spread_held_out([p.x for p in post], [p.y for p in post], [p.theta for p in post], k)
