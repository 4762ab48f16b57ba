"""The next postures to test: those that would shrink the parameters' uncertainty most (D-optimal).

With ``J`` the sensitivity of the measured modes' residuals to the parameters (in prior standard
deviations), the posterior precision is ``P = JᵀJ + I``. A candidate posture, measured, would add
the sensitivity rows ``J_c`` of the modes a test would see there (the model's own modes inside a band
and above 1 % of its peak, with the residual floors for their uncertainty), so the postures are
picked greedily, each maximising ``ln det(P + J_cᵀ J_c)``: the volume of the parameters' confidence
region shrinks by ``exp(−gain / 2)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.calibrate.data import ModalData
from rmbench.calibrate.fit import CalibrationSettings
from rmbench.calibrate.measured import MeasuredModes
from rmbench.calibrate.model import ModalModel
from rmbench.calibrate.problem import Problem
from rmbench.errors import InputError, RmbenchError, UnreachablePosture
from rmbench.robot.parameters import parameter_set

__all__ = ["Suggestion", "suggest_postures"]


@dataclass(frozen=True)
class Suggestion:
    """Postures ranked by the information they would add.

    Attributes
    ----------
    postures : tuple of Posture
        Best first.
    gain : tuple of float
        ``ln det`` of the posterior precision gained by each, in the order picked (nats).
    skipped : tuple of str
        Candidates left out (unreachable, or the model cannot hold them), with why.
    sd_before, sd_after : dict
        Posterior over prior standard deviation of each parameter, with the data so far and with
        the suggested postures added.
    """

    postures: tuple
    gain: tuple
    skipped: tuple
    sd_before: dict
    sd_after: dict

    @property
    def volume_factors(self) -> tuple:
        """Factor ``exp(−gain / 2)`` by which each posture, added in turn, shrinks the volume of
        the parameters' confidence region (below 1; best first)."""
        return tuple(float(np.exp(-g / 2)) for g in self.gain)

    def best_determined(self, n: int = 5) -> list[str]:
        """The ``n`` parameters whose posterior over prior standard deviation the suggested
        postures would make smallest relative to now (``sd_after / sd_before``), best first."""
        return sorted(self.sd_before, key=lambda k: self.sd_after[k] / self.sd_before[k])[:n]

    def to_json(self) -> dict:
        return {"postures": [{"x_mm": 1e3 * p.x, "y_mm": 1e3 * p.y, "theta_deg": float(np.degrees(p.theta)),
                              "gain_nats": g} for p, g in zip(self.postures, self.gain)],
                "skipped": list(self.skipped), "posterior_over_prior_sd": {"before": self.sd_before,
                                                                          "after": self.sd_after}}


def _predicted(mm: ModalModel, u, p: int, bands) -> dict:
    out = {}
    for b in bands:
        m = mm.modes(u, p, b)
        keep = (m.peak >= 0.01) & m.inside
        n = int(keep.sum())
        out[b] = MeasuredModes(f_n=m.f_n[keep], zeta=m.zeta[keep], f_std=np.zeros(n), zeta_std=np.zeros(n),
                               residue=m.residue[keep], residue_std=np.zeros(n), mode_id=np.arange(n))
    return out


def suggest_postures(robot, data: ModalData, candidates, n: int = 4, *,
                     settings: CalibrationSettings = CalibrationSettings(), progress=None) -> Suggestion:
    """Rank candidate postures for the next test (D-optimal, greedy).

    Parameters
    ----------
    robot : Robot
        The model (a calibrated one, or the nominal).
    data : ModalData
        The measurements so far (may be empty of postures).
    candidates : sequence of Posture
    n : int
        Postures to suggest.

    Raises
    ------
    InputError
        ``n`` below 1, or no candidate the robot can reach and hold.
    """
    say = progress or (lambda msg: None)
    if n < 1:
        raise InputError(f"-n must be at least 1, got {n}")
    rob, params = parameter_set(robot, settings.groups)
    reach, q, skipped = _reachable(robot, data, candidates)
    mm = ModalModel(rob, params, data.design, np.array(q), data.bands)
    u0 = np.zeros(len(params))
    n_data = len(data)
    modes = list(data.modes)
    usable = []
    for k in range(n_data, len(reach)):
        try:
            modes.append(_predicted(mm, u0, k, data.bands))
            usable.append(k)
        except RmbenchError as err:
            modes.append({})
            skipped.append(f"{reach[k].label()}: {err}")
    if not usable:
        raise InputError("no candidate posture can be reached and held by this robot")
    full = ModalData(tuple(reach), tuple(modes), data.bands, data.design, data.source)
    info = np.zeros((len(params), len(params)))
    if n_data:
        js = np.vstack(list(_rows(mm, full, range(n_data), settings).values()))
        info = js.T @ js
    say(f"sensitivities of {len(usable)} candidates")
    cand = _rows(mm, full, usable, settings)
    precision = info + np.eye(len(params))
    sd_before = np.sqrt(np.diag(np.linalg.inv(precision)))
    picked, gains, precision = _greedy(precision, cand, n)
    sd_after = np.sqrt(np.diag(np.linalg.inv(precision)))
    return Suggestion(postures=tuple(reach[p] for p in picked), gain=tuple(gains), skipped=tuple(skipped),
                      sd_before=dict(zip(params.names, sd_before.tolist())),
                      sd_after=dict(zip(params.names, sd_after.tolist())))


def _reachable(robot, data: ModalData, candidates) -> tuple[list, list, list]:
    """``(postures, q, skipped)``: the data's postures and the candidates the robot reaches, their
    joint angles, and the unreachable candidates named; a data posture it cannot reach is an error."""
    reach, q, skipped = [], [], []
    for post in list(data.postures) + list(candidates):
        try:
            q.append(robot.ik(post).q)
            reach.append(post)
        except UnreachablePosture as err:
            if post in data.postures:
                raise InputError(f"the data's postures are not this robot's: {err}") from None
            skipped.append(f"{post.label()}: unreachable")
    return reach, q, skipped


def _rows(mm: ModalModel, data: ModalData, postures, settings) -> dict:
    """``{posture: J}``: the sensitivity rows of each posture's modes at the nominal, per prior
    standard deviation, shape (n_rows, n_params)."""
    sigma = mm.params.sigma()
    prob = Problem(mm, data, postures, settings)
    try:
        _, j = prob.jacobian(np.zeros(len(mm.params)))
    finally:
        prob.close()
    rows, start = {}, 0
    for (p, _), size in zip(prob.keys, prob.sizes):
        rows.setdefault(p, []).append(j[start:start + size] * sigma[None, :])
        start += size
    return {p: np.vstack(r) for p, r in rows.items()}


def _greedy(precision: np.ndarray, cand: dict, n: int) -> tuple[list, list, np.ndarray]:
    """Up to ``n`` postures of ``cand`` (``{posture: J}``) picked one after the other, each the
    one that raises ``ln det`` of the precision most: ``(picked, gains in nats, precision after)``."""
    picked, gains = [], []
    _, logdet = np.linalg.slogdet(precision)
    for _ in range(min(n, len(cand))):
        best, best_val = None, -np.inf
        for p, jc in cand.items():
            if p in picked:
                continue
            val = np.linalg.slogdet(precision + jc.T @ jc)[1]
            if val > best_val:
                best, best_val = p, val
        picked.append(best)
        gains.append(float(best_val - logdet))
        precision = precision + cand[best].T @ cand[best]
        logdet = best_val
    return picked, gains, precision
