"""Geometric and elastostatic calibration of a serial arm from tracker readings (the model under test).

The model: the nominal rigid arm with every joint placement and the TCP placement moved by an
identified twist, identified joint zero offsets, a gravity compliance per joint (the MJCF stiffness
scaled by an identified factor, acting on the gravity torque of the nominal masses), and the base
frame in the tracker frame. Gauss-Newton on all 6 (n_joint + 1) + 2 n_joint + 6 parameters; the
identifiable ones (the base parameters) are chosen by a QR decomposition with column pivoting of the
column-scaled identification Jacobian, the rest stay at zero. What the model cannot represent —
gear transmission errors, payload and mass errors beyond a per-joint scale, noise — is its error.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pinocchio as pin
from scipy import linalg

from rmbench.errors import InputError, RmbenchError
from rmbench.tracker._checks import check_finite_array
from rmbench.tracker.chain import SerialChain, skew
from rmbench.tracker.registration import kabsch

__all__ = ["CalibratedModel", "GeometricCalibration"]


@dataclass(frozen=True)
class CalibratedModel:
    """A kinematic model that predicts TCP positions in the tracker frame.

    Attributes
    ----------
    chain : SerialChain
        Identified geometry.
    offsets : ndarray, shape (n_joint,), rad
        Joint zero offsets.
    compliance : ndarray, shape (n_joint,), rad/(N·m)
        Gravity compliance per joint (0: rigid); the torques come from ``chain``'s masses (the
        nominal ones) at the deflected angles (two fixed-point steps, as the simulator).
    base_rotation : ndarray, shape (3, 3)
    base_translation : ndarray, shape (3,), m
        Tracker-frame coordinates of a base-frame point p are R p + t.
    """

    chain: SerialChain
    offsets: np.ndarray
    compliance: np.ndarray
    base_rotation: np.ndarray
    base_translation: np.ndarray

    def link_angles(self, q) -> np.ndarray:
        """Joint angles the model believes the links reach for commands q (..., n_joint), rad."""
        angles = np.asarray(q, float) + self.offsets
        deflection = np.zeros_like(angles)
        if np.any(self.compliance):
            for _ in range(2):
                deflection = self.compliance * self.chain.gravity_torque(angles + deflection)
        return angles + deflection

    def position(self, q) -> np.ndarray:
        """Predicted TCP position in the tracker frame, shape (..., 3), m."""
        return self.chain.position(self.link_angles(q)) @ self.base_rotation.T + self.base_translation

    def pose(self, q) -> tuple[np.ndarray, np.ndarray]:
        """Predicted TCP position (..., 3), m, and orientation (..., 3, 3) in the tracker frame."""
        p, r = self.chain.pose(self.link_angles(q))
        return p @ self.base_rotation.T + self.base_translation, self.base_rotation @ r

    def jacobian(self, q) -> np.ndarray:
        """∂(position)/∂(joint angle) in the tracker frame, shape (..., 3, n_joint), m/rad."""
        return self.base_rotation @ self.chain.jacobian(self.link_angles(q))


class GeometricCalibration:
    """Identify a :class:`CalibratedModel` from joint commands and tracker readings.

    Parameters
    ----------
    nominal : SerialChain
        The rigid arm as designed.
    stiffness : array_like, shape (n_joint,), N·m/rad, optional
        Nominal link-side stiffness (inf: rigid); the model identifies a factor on 1/stiffness.
        Without it the model is purely geometric (gravity deflection left unmodelled).
    iterations : int
        Gauss-Newton iterations.
    rank_tol : float
        A pivoted column is identifiable when |R_kk| > rank_tol · |R_00| (column-scaled).

    Attributes
    ----------
    model_ : CalibratedModel
    params_ : ndarray, shape (n_param,)
        Sum of the Gauss-Newton steps: placement twists (n_joint + 1) x 6 (m, rad), offsets
        (rad), compliance factors (1), base twist (m, rad); zero where not identifiable.
    identifiable_ : ndarray of int
        Indices of the base (identifiable) parameters.
    residuals_ : ndarray, shape (n_config, 3), m
        Reading minus model on the identification set.
    """

    def __init__(self, nominal: SerialChain, stiffness=None, *, identify_compliance: bool = True,
                 iterations: int = 6, rank_tol: float = 1e-6):
        self.nominal = nominal
        k = np.full(nominal.n_joint, np.inf) if stiffness is None else np.asarray(stiffness, float)
        if k.shape != (nominal.n_joint,) or not np.all(k > 0):
            raise InputError(f"stiffness must be {nominal.n_joint} values > 0, got {k!r}")
        self.nominal_compliance = 1.0 / k
        self.identify_compliance = bool(identify_compliance)
        self.iterations = int(iterations)
        self.rank_tol = float(rank_tol)

    @property
    def n_param(self) -> int:
        """Number of parameters (identifiable or not)."""
        n = self.nominal.n_joint
        return 6 * (n + 1) + 2 * n + 6

    def fit(self, q, measured) -> "GeometricCalibration":
        """Identify the model from configurations and readings.

        Gauss-Newton, re-linearised at every iteration: identified twists are folded into the
        chain and the base frame, offsets and compliance factors accumulate. The identifiable
        parameters are fixed at the first iteration.

        Parameters
        ----------
        q : array_like, shape (n_config, n_joint), rad
            Commanded joint angles.
        measured : array_like, shape (n_config, 3), m
            Tracker readings (tracker frame).

        Returns
        -------
        self
        """
        q = check_finite_array("q", q, (self.nominal.n_joint,))
        y = check_finite_array("measured", measured, (3,))
        if q.ndim != 2 or y.shape != (len(q), 3):
            raise InputError(f"q and measured must have shapes (n, {self.nominal.n_joint}) and "
                             f"(n, 3), got {q.shape} and {y.shape}")
        if 3 * len(q) < self.n_param:
            raise InputError(f"need at least {int(np.ceil(self.n_param / 3))} configurations, "
                             f"got {len(q)}")
        n = self.nominal.n_joint
        rot, trans = kabsch(self.nominal.position(q), y)
        model = CalibratedModel(self.nominal, np.zeros(n), self.nominal_compliance.copy(), rot, trans)
        total = np.zeros(self.n_param)
        keep = None
        for _ in range(self.iterations):
            jac, pred = self._linearise(model, q)
            if keep is None:
                keep = self._identifiable(jac)
            step = np.zeros(self.n_param)
            step[keep] = np.linalg.lstsq(jac[:, keep], (y - pred).reshape(-1), rcond=None)[0]
            model = self._update(model, step)
            total += step
            if np.max(np.abs(step)) < 1e-13:
                break
        self.identifiable_ = keep
        self.params_ = total
        self.model_ = model
        self.residuals_ = y - model.position(q)
        return self

    def predict(self, q) -> np.ndarray:
        """TCP positions of the identified model, tracker frame, shape (..., 3), m."""
        if not hasattr(self, "model_"):
            raise RmbenchError("this GeometricCalibration is not fitted yet: call fit(q, measured)")
        return self.model_.position(q)

    def _linearise(self, model: CalibratedModel, q):
        """Identification Jacobian (3 n_config, n_param) at zero twists, and the prediction.

        The torques are held fixed in the derivatives (their change with the parameters is of
        second order); the prediction itself is exact.
        """
        angles = model.link_angles(q)
        torque = model.chain.gravity_torque(angles)
        state = model.chain.walk(angles)
        rb = model.base_rotation
        jq = rb @ state.position_jacobian()                                # (m, 3, n)
        base = np.concatenate([np.broadcast_to(rb, (len(q), 3, 3)),
                               -rb @ skew(state.tcp)], axis=2)            # (m, 3, 6)
        cols = [rb @ state.placement_jacobian(), jq,
                jq * (self.nominal_compliance * torque)[:, None, :], base]
        jac = np.concatenate(cols, axis=2).reshape(-1, self.n_param)
        return jac, state.tcp @ rb.T + model.base_translation

    def _update(self, model: CalibratedModel, step) -> CalibratedModel:
        n = self.nominal.n_joint
        twists = step[: 6 * (n + 1)].reshape(n + 1, 6)
        offsets = step[6 * (n + 1): 6 * (n + 1) + n]
        factor = step[6 * (n + 1) + n: 6 * (n + 1) + 2 * n]
        base = (pin.SE3(model.base_rotation, model.base_translation)
                * pin.exp6(pin.Motion(step[-6:])))
        return replace(model, chain=model.chain.perturbed(twists), offsets=model.offsets + offsets,
                       compliance=model.compliance + self.nominal_compliance * factor,
                       base_rotation=base.rotation, base_translation=base.translation)

    def _identifiable(self, jac) -> np.ndarray:
        """Base parameters: pivoted QR of the column-scaled Jacobian, |R_kk| above tolerance."""
        norm = np.linalg.norm(jac, axis=0)
        n = self.nominal.n_joint
        if not self.identify_compliance:
            norm[6 * (n + 1) + n: 6 * (n + 1) + 2 * n] = 0.0
        live = np.flatnonzero(norm > 0)
        _, r, piv = linalg.qr(jac[:, live] / norm[live], mode="economic", pivoting=True)
        diag = np.abs(np.diag(r))
        rank = int(np.sum(diag > self.rank_tol * diag[0]))
        return np.sort(live[piv[:rank]])
