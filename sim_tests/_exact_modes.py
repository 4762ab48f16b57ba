"""Noise-free modal data of a robot: the modes a perfect test would give, shared by the calibration
and truth tests."""

import numpy as np

from rmbench.calibrate import MeasuredModes, ModalData, ModalModel
from rmbench.robot.parameters import ParameterSet


def exact_modes(robot, design, postures, bands=("low", "high")) -> ModalData:
    """The modes a noise-free test of ``robot`` gives at ``postures``: those a test must see (inside
    a band, above 1 % of its peak), with no standard errors."""
    q = np.array([robot.ik(p).q for p in postures])
    mm = ModalModel(robot, ParameterSet([]), design, q, tuple(bands))
    modes = []
    for p in range(len(postures)):
        per = {}
        for b in bands:
            m = mm.modes(np.zeros(0), p, b)
            k = (m.peak >= 0.01) & m.inside
            n = int(k.sum())
            per[b] = MeasuredModes(f_n=m.f_n[k], zeta=m.zeta[k], f_std=np.zeros(n), zeta_std=np.zeros(n),
                                   residue=m.residue[k], residue_std=np.zeros(n), mode_id=np.arange(n))
        modes.append(per)
    return ModalData(tuple(postures), tuple(modes), tuple(bands), design, "exact")
