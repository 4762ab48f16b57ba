"""Joint trajectories the robot's servos follow during a closed-loop run.

CSV (SI time, degrees at the interface)::

    t_s,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg
    0.0,0,-5,-5,0,100,0
    ...

The joint columns are named as the path stage writes them (``rmbench path plan --csv``); other
columns are ignored. Times strictly increase; between rows the commands are interpolated by a
monotone cubic (PCHIP): the velocity stays continuous, where a straight line between rows would
jerk the arm at every row (a step of velocity through the servos excites the modes the
suppressor damps, and can drive its stage into saturation).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rmbench.errors import InputError

__all__ = ["Trajectory", "load_trajectory", "linear_move"]


@dataclass(frozen=True)
class Trajectory:
    """Arm joint commands against time.

    Attributes
    ----------
    t : ndarray, shape (m,)
        Times, s, strictly increasing, from 0.
    q : ndarray, shape (m, n_arm)
        Joint commands, rad.
    """

    t: np.ndarray
    q: np.ndarray

    def __post_init__(self):
        if self.t.ndim != 1 or len(self.t) < 2 or self.q.shape[0] != len(self.t) or self.q.ndim != 2:
            raise InputError(f"a trajectory needs at least two rows of times (m,) and joints (m, n); got "
                             f"{self.t.shape} and {self.q.shape}")
        if not (np.all(np.isfinite(self.t)) and np.all(np.isfinite(self.q))):
            raise InputError("the trajectory has NaN or infinite values")
        if np.any(np.diff(self.t) <= 0):
            i = int(np.flatnonzero(np.diff(self.t) <= 0)[0]) + 1
            raise InputError(f"trajectory times must increase; row {i + 1} is at {self.t[i]:g} s after "
                             f"{self.t[i - 1]:g} s")

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    def at(self, time) -> np.ndarray:
        """Joint commands at ``time`` (s; clamped to the trajectory's span), rad, shape (..., n_arm)."""
        from scipy.interpolate import PchipInterpolator

        time = np.clip(np.asarray(time, float), self.t[0], self.t[-1])
        return PchipInterpolator(self.t, self.q, axis=0)(time)


def linear_move(q_start, q_end, duration: float, *, hold: float = 0.0) -> Trajectory:
    """From ``q_start`` to ``q_end`` (rad) in ``duration`` s with a smooth (cosine) speed profile,
    after ``hold`` s at the start."""
    q0, q1 = np.asarray(q_start, float), np.asarray(q_end, float)
    if duration <= 0 or hold < 0:
        raise InputError(f"a move needs a positive duration and a non-negative hold, got {duration}, {hold}")
    tau = np.linspace(0.0, 1.0, 201)
    t = hold + duration * tau
    frac = 0.5 - 0.5 * np.cos(np.pi * tau)
    q = q0 + frac[:, None] * (q1 - q0)
    if hold > 0:
        t, q = np.concatenate([[0.0], t]), np.vstack([q0, q])
    return Trajectory(t, q)


def load_trajectory(path, n_joints: int) -> Trajectory:
    """Read a trajectory CSV (module docstring); one-line errors name the file, row and column."""
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise InputError(f"no trajectory file {path}") from None
    except (OSError, UnicodeDecodeError) as err:
        raise InputError(f"{path}: cannot be read as text ({err})") from None
    rows = list(csv.reader(line for line in text.splitlines() if line.strip() and not line.startswith("#")))
    if not rows:
        raise InputError(f"{path}: empty trajectory file")
    header = [h.strip() for h in rows[0]]
    want = ["t_s"] + [f"q{k + 1}_deg" for k in range(n_joints)]
    missing = [c for c in want if c not in header]
    if missing:
        hint = " (a path plan gives s_mm: add a time column t_s)" if "t_s" in missing and "s_mm" in header else ""
        raise InputError(f"{path}: missing column(s) {', '.join(missing)}{hint}; expected {','.join(want)}")
    cols = [header.index(c) for c in want]
    values = []
    for r, row in enumerate(rows[1:], start=2):
        try:
            values.append([float(row[c]) for c in cols])
        except (ValueError, IndexError):
            raise InputError(f"{path}, row {r}: every one of {', '.join(want)} must be a number") from None
    a = np.array(values)
    if len(a) < 2:
        raise InputError(f"{path}: a trajectory needs at least two rows")
    traj = Trajectory(a[:, 0] - a[0, 0], np.radians(a[:, 1:]))
    return traj
