"""Best-fit registration of base and tool frames between a model and tracker readings.

The tracker measures in its own frame, and the reflector's offset on the tool is never known
exactly: before errors are judged, the model's base frame (where the robot stands in the tracker
frame) and tool offset are fitted to the readings. :func:`kabsch` gives the rigid transform from
scratch; :class:`FrameRefit` re-fits small corrections (base twist and tool offset, 9 parameters,
linearised) to the errors, and is the ``correct`` hook of :func:`~rmbench.tracker.invalidate`
("the base frame and tool frame errors were minimized after each measurement", seed Sec. 4.2).
"""

from __future__ import annotations

import numpy as np

from rmbench.errors import InputError
from rmbench.tracker._checks import check_finite_array

__all__ = ["kabsch", "FrameRefit"]


def kabsch(source, target, weights=None) -> tuple[np.ndarray, np.ndarray]:
    """Rigid transform (R, t) minimising Σ w ||R s + t − target||².

    Parameters
    ----------
    source, target : array_like, shape (n, 3), m
        Corresponding points (n ≥ 3, not collinear).
    weights : array_like, shape (n,), optional

    Returns
    -------
    R : ndarray, shape (3, 3)
        Proper rotation.
    t : ndarray, shape (3,), m
    """
    s = check_finite_array("source", source, (3,))
    d = check_finite_array("target", target, (3,))
    if s.shape != d.shape or s.ndim != 2 or len(s) < 3:
        raise InputError(f"source and target must both have shape (n >= 3, 3), got {s.shape} and "
                         f"{d.shape}")
    w = np.ones(len(s)) if weights is None else np.asarray(weights, float)
    w = w / w.sum()
    cs, cd = w @ s, w @ d
    h = (s - cs).T @ ((d - cd) * w[:, None])
    u, sv, vt = np.linalg.svd(h)
    if sv[1] < 1e-12 * max(sv[0], 1e-300):
        raise InputError("the points are collinear: the rotation is not determined")
    fix = np.diag([1.0, 1.0, np.sign(np.linalg.det(vt.T @ u.T))])
    rot = vt.T @ fix @ u.T
    return rot, cd - rot @ cs


class FrameRefit:
    """Re-fits base twist and tool offset to errors measured at known locations.

    ``refit(index, errors)`` returns the errors left after the weighted least-squares best fit of
    e ≈ δt + δω × p_j + R_j δs over the measurements taken (δt, δω: base translation and rotation
    in the tracker frame; δs: tool offset in the TCP frame); with fewer than ``min_locations``
    distinct locations, the errors are returned unchanged.

    Parameters
    ----------
    positions : array_like, shape (n_loc, 3), m
        Model TCP positions at the locations (tracker frame).
    rotations : array_like, shape (n_loc, 3, 3)
        Model TCP orientations at the locations (tracker frame).
    sigma : array_like, shape (n_loc, 3), m, optional
        Standard deviation of one reading per axis (weights); default equal weights.
    min_locations : int
        Distinct locations needed before fitting (the 9 parameters need at least 3).
    """

    def __init__(self, positions, rotations, sigma=None, *, min_locations: int = 4):
        self.positions = check_finite_array("positions", positions, (3,))
        self.rotations = check_finite_array("rotations", rotations, (3, 3))
        if len(self.rotations) != len(self.positions):
            raise InputError("positions and rotations must have the same number of locations")
        self.sigma = (np.ones_like(self.positions) if sigma is None
                      else check_finite_array("sigma", sigma, (3,)))
        if self.sigma.shape != self.positions.shape or np.any(self.sigma <= 0):
            raise InputError(f"sigma must be > 0 with shape {self.positions.shape}")
        if min_locations < 3:
            raise InputError(f"min_locations must be >= 3, got {min_locations!r}")
        self.min_locations = int(min_locations)
        p = self.positions
        skew = np.zeros((len(p), 3, 3))
        skew[:, 0, 1], skew[:, 0, 2], skew[:, 1, 2] = p[:, 2], -p[:, 1], p[:, 0]
        skew[:, 1, 0], skew[:, 2, 0], skew[:, 2, 1] = -p[:, 2], p[:, 1], -p[:, 0]
        # skew = -[p]x, so skew @ δω = δω × p; the design rows are [I, -[p]x, R]
        self._design = np.concatenate([np.broadcast_to(np.eye(3), skew.shape), skew,
                                       self.rotations], axis=2)  # (n_loc, 3, 9)
        self.params_ = np.zeros(9)

    def fit(self, index, errors) -> np.ndarray:
        """Best-fit parameters (δt m, δω rad, δs m), shape (9,); zeros below ``min_locations``."""
        idx = np.asarray(index, int)
        e = np.asarray(errors, float).reshape(len(idx), 3)
        if len(np.unique(idx)) < self.min_locations:
            return np.zeros(9)
        w = 1.0 / self.sigma[idx]
        a = (self._design[idx] * w[:, :, None]).reshape(-1, 9)
        return np.linalg.lstsq(a, (e * w).reshape(-1), rcond=1e-10)[0]

    def __call__(self, index, errors) -> np.ndarray:
        idx = np.asarray(index, int)
        e = np.asarray(errors, float).reshape(len(idx), 3)
        self.params_ = self.fit(idx, e)
        return e - self._design[idx] @ self.params_
