"""The robot-supported part on the bench: part alone, robot alone, assembly, and RCSA (METHODS.md §6).

:func:`support_study` poses the robot, builds the scene of :mod:`rmbench.robot.part`, and returns
the simulated FRFs (the part alone and the robot alone, as the seed tested them, and the assembly
as the ground truth) with the RCSA predictions from the first two: the assembled main low mode,
the amplitude reductions at the part's modes, rigid and finite contact, and the effect of a
sensor sitting 20 mm off the coupling point.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from rmbench.rcsa.part import amplitude_reduction, couple_part
from rmbench.rcsa.validate import _top
from rmbench.robot.part import Plate, support_scene

__all__ = ["SupportStudy", "support_study", "low_mode"]


@dataclass(frozen=True)
class SupportStudy:
    """Simulated and RCSA-predicted FRFs of a robot-supported plate.

    All FRFs are m/N at the plate's coupling point ``c`` unless named ``_s`` (the sensor ``s``,
    ``sensor_offset`` further along the span), shape (n_freq,).

    Attributes
    ----------
    freq : ndarray, Hz
    part_modes : ndarray, Hz
    h_part, h_part_s, h_part_sc : part alone at c, at s, and s/c
    h_robot : robot alone, ball X
    g_sim, g_sim_s : the simulated assembly (exact linearisation of the scene at its preload)
    g_rcsa, g_rcsa_rigid : Eq. 6 with K_x and with a rigid joint
    g_rcsa_s : Eqs. 12-14 at the sensor (a = b = s, x = c)
    g_offset : Eq. 6 fed the sensor's FRF as if it were at c (the seed's 594 Hz discrepancy)
    k_x, preload, contact, sensor_offset : float
    """

    freq: np.ndarray
    part_modes: np.ndarray
    h_part: np.ndarray
    h_part_s: np.ndarray
    h_part_sc: np.ndarray
    h_robot: np.ndarray
    g_sim: np.ndarray
    g_sim_s: np.ndarray
    g_rcsa: np.ndarray
    g_rcsa_rigid: np.ndarray
    g_rcsa_s: np.ndarray
    g_offset: np.ndarray
    k_x: float
    preload: float
    contact: float
    sensor_offset: float

    def reductions(self) -> dict:
        """Amplitude reduction at the part's first two modes: simulated and RCSA, fractions."""
        f = self.part_modes[:2]
        return {"sim": amplitude_reduction(self.freq, self.h_part, self.g_sim, f),
                "rcsa": amplitude_reduction(self.freq, self.h_part, self.g_rcsa, f),
                "rcsa_rigid": amplitude_reduction(self.freq, self.h_part, self.g_rcsa_rigid, f)}

    def to_dict(self) -> dict:
        red = self.reductions()
        f_sim, f_rcsa = low_mode(self.freq, self.g_sim, self.part_modes[0]), low_mode(self.freq, self.g_rcsa, self.part_modes[0])
        diff = np.abs(20 * np.log10(np.abs(self.g_offset) / np.abs(self.g_sim_s)))  # dB
        k = int(np.nanargmax(np.where(self.freq > self.part_modes[0] * 0.5, diff, 0)))
        return {"part_modes_hz": self.part_modes.tolist(), "k_x": self.k_x, "preload_n": self.preload,
                "contact_mm": 1e3 * self.contact, "robot_low_mode_hz": low_mode(self.freq, self.h_robot, np.inf),
                "low_mode_sim_hz": f_sim, "low_mode_rcsa_hz": f_rcsa, "low_mode_err": f_rcsa / f_sim - 1,
                "reduction_sim": red["sim"].tolist(), "reduction_rcsa": red["rcsa"].tolist(),
                "reduction_rcsa_rigid": red["rcsa_rigid"].tolist(),
                "reduction_err_pp": float(100 * np.max(np.abs(red["rcsa"] - red["sim"]))),
                "rcsa_vs_sim_max_rel": float(np.nanmax(np.abs(self.g_rcsa - self.g_sim)) / np.abs(self.g_sim).max()),
                "offset_mm": 1e3 * self.sensor_offset,
                "offset_worst_hz": float(self.freq[k]), "offset_worst_db": float(diff[k]),
                "offset_db_near_part_mode_2": float(np.nanmax(diff[np.abs(self.freq / self.part_modes[1] - 1) < 0.1])),
                "eq12_14_at_sensor_max_rel": float(np.nanmax(np.abs(self.g_rcsa_s - self.g_sim_s))
                                                   / np.abs(self.g_sim_s).max())}


def low_mode(freq: np.ndarray, h: np.ndarray, below: float) -> float:
    """Frequency of the largest peak of |h| below ``below`` Hz (parabolic interpolation), Hz."""
    sel = np.flatnonzero(freq < below)
    mag = np.abs(h[sel])
    k = int(np.argmax(mag[1:-1])) + 1
    return _top(freq[sel], mag, k)[0]


def support_study(robot, q_cmd: np.ndarray, *, plate: Plate = Plate(), k_x: float = 2e7,
                  preload: float = 100.0, contact: float | None = None, sensor_offset: float = 0.020,
                  freq: np.ndarray | None = None) -> SupportStudy:
    """Simulate part, robot and assembly, and predict the assembly by RCSA.

    Parameters
    ----------
    robot : Robot
        The supporting robot (its tool tip stands in for the ball caster's centre).
    q_cmd : ndarray, shape (n_arm,), rad
    plate : Plate
    k_x : float
        Contact stiffness, N/m.
    preload : float
        Contact force at rest, N.
    contact : float, optional
        m from the left clamp (default 0.4 of the span).
    sensor_offset : float
        Distance of the misplaced sensor from the coupling point along the span, m.
    freq : ndarray, optional
        Lines, Hz (default 2-800 Hz every 0.05 Hz: the part's peaks have 0.8 Hz half-power width).
    """
    freq = np.arange(2.0, 800.0, 0.05) if freq is None else np.asarray(freq, float)
    scene = support_scene(robot, q_cmd, plate, contact=contact, k_x=k_x, preload=preload)
    c, s = scene.contact, scene.contact + sensor_offset
    op = scene.robot().at(scene.q_cmd)
    rows = scene.part_rows(op, [c, s])
    g = op.linear.frf(freq, rows, rows)
    h_p = plate.receptance(freq, [c, s], [c, s])
    h_r = robot.at(np.asarray(q_cmd, float)).frf(freq, ("1X",))[:, 0, 0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        g_rcsa = couple_part(freq, h_p, h_r, k_x).g
        g_rigid = couple_part(freq, h_p[:, 0, 0], h_r).g[:, 0, 0]
        g_off = couple_part(freq, h_p[:, 1, 1], h_r, k_x).g[:, 0, 0]
    f_part, _ = plate.modes()
    return SupportStudy(freq, f_part, h_p[:, 0, 0], h_p[:, 1, 1], h_p[:, 1, 0], h_r, g[:, 0, 0], g[:, 1, 1],
                        g_rcsa[:, 0, 0], g_rigid, g_rcsa[:, 1, 1], g_off, float(k_x), float(preload), c,
                        float(sensor_offset))
