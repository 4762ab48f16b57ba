"""A structural effect fitted jointly with the calibrated ordinary parameters.

After a calibration (:mod:`rmbench.calibrate`) the ordinary parameters (gearboxes, masses, ...)
have already taken up what they can of any structural effect: a flange carrying 40 % more mass
is partly "explained" by softer gearboxes. Searching the structural effects on the calibrated
model as it stands would then see only what the ordinary parameters could not imitate, and fit a
shrunken effect to it. So each candidate is fitted with the ordinary parameters free to move
back, to first order: with ``e(θ)`` the gap vector of the candidate at ``θ``, ``J`` its
sensitivity to the ordinary parameters in prior standard deviations (at the calibration) and
``z`` their calibrated values in the same units (the prior pulls toward 0),

    δz(θ) = argmin ‖e(θ) + J δz‖² + ‖z + δz‖²,

and the candidate's training residual is ``[e + J δz ; z + δz]`` (variable projection: the
ordinary parameters are eliminated in closed form). On held-out postures the candidate is scored
with the ``δz`` its training fit chose, never one refitted to them.

The ordinary parameters follow the modal residuals (the calibration's, so the two fits agree at
``θ = 0``); the FRF segment residuals of the gap vector are evaluated as they are, without them
following: a ×2.5 tool holder whose modal signature the gearboxes can imitate still shows in
the FRFs between the modes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.calibrate.residual import FRF_SEGMENTS
from rmbench.gap.frf.search import Objective

__all__ = ["Ordinary", "JointObjective"]


@dataclass(frozen=True)
class Ordinary:
    """The calibrated ordinary parameters, linearised.

    Attributes
    ----------
    blocks : dict
        ``{(posture, band): J}``, the sensitivity of that posture's and band's modal residual to
        the parameters, per prior standard deviation, shape (size, n_params); postures and bands
        absent here have none (a band without measured modes).
    z : ndarray, shape (n_params,)
        Calibrated values in prior standard deviations.
    names : tuple of str
    """

    blocks: dict
    z: np.ndarray
    names: tuple

    def jacobian(self, objective: Objective) -> np.ndarray:
        """The sensitivity of ``objective``'s vector, shape (len(vector), n_params)."""
        rows = []
        k = len(self.z)
        for p in objective.postures:
            for b in objective.bands:
                size = 4 * len(objective.meas[p][b]) + 1
                J = self.blocks.get((p, b))
                rows.append(J if J is not None and J.shape[0] == size else np.zeros((size, k)))
                if objective._target(p, b) is not None:     # FRF segments: not followed
                    rows.append(np.zeros((FRF_SEGMENTS * 16, k)))
        return np.vstack(rows) if rows else np.zeros((0, k))

    def step(self, e: np.ndarray, J: np.ndarray, gram: np.ndarray | None = None) -> np.ndarray:
        """``δz`` minimising ``‖e + J δz‖² + ‖z + δz‖²`` (``gram``: ``JᵀJ + I``, where already formed)."""
        if gram is None:
            gram = J.T @ J + np.eye(len(self.z))
        return np.linalg.solve(gram, -(J.T @ e + self.z))


class JointObjective(Objective):
    """An :class:`~rmbench.gap.frf.search.Objective` (modal residuals only) whose ordinary parameters
    follow every change to first order.

    Parameters
    ----------
    bench, meas, frf, bands, postures
        As :class:`Objective`.
    ordinary : Ordinary
    fitted_on : JointObjective, optional
        For held-out postures: the training objective whose ``δz`` they are scored with. Without
        it the objective fits ``δz`` itself and appends the prior's rows.
    """

    def __init__(self, bench, meas, frf, bands, postures, ordinary: Ordinary, fitted_on=None):
        super().__init__(bench, meas, frf, bands, postures)
        self.ordinary = ordinary
        self.fitted_on = fitted_on
        self._J = ordinary.jacobian(self)
        # the normal matrix of every step: J is fixed, only the gap vector changes
        self._gram = self._J.T @ self._J + np.eye(len(ordinary.z))
        self._last = None          # (key of a change, δz) of the last training evaluation

    def subset(self, postures) -> "JointObjective":
        return JointObjective(self.bench, self.meas, self.frf, self.bands, postures, self.ordinary)

    def rebound(self, bench, fitted_on=None) -> "JointObjective":
        return JointObjective(bench, self.meas, self.frf, self.bands, self.postures, self.ordinary,
                              fitted_on=fitted_on if self.fitted_on is not None else None)

    def delta(self, change) -> np.ndarray:
        """The ordinary parameters' move (prior σ) with ``change`` (this objective's fit)."""
        key = repr(change)
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        e = Objective.vector(self, change)
        dz = self.ordinary.step(e, self._J, self._gram)
        self._last = (key, dz)
        return dz

    def _joined(self, e: np.ndarray, change) -> np.ndarray:
        if self.fitted_on is not None:
            return e + self._J @ self.fitted_on.delta(change)
        dz = self.ordinary.step(e, self._J, self._gram)
        self._last = (repr(change), dz)
        return np.concatenate([e + self._J @ dz, self.ordinary.z + dz])

    def vector(self, change) -> np.ndarray:
        return self._joined(Objective.vector(self, change), change)

    def vector_fast(self, base, delta) -> np.ndarray:
        if not self.bench.fast(delta):
            return self.vector(base + delta)
        return self._joined(Objective.vector_fast(self, base, delta), base + delta)

    def per_posture(self, change) -> np.ndarray:
        e = self.vector(change)[:len(self._J)]
        sizes = [self._size(p) for p in self.postures]
        return np.array([float(x @ x) for x in np.split(e, np.cumsum(sizes)[:-1])])
