"""Laser-tracker readings as CSV: one reading per row, SI units (rad, m), '#' comment lines.

Columns (order free, names fixed):

* ``location``: integer label of the commanded configuration (repeats share it);
* ``q_<joint>``: commanded joint angles, rad, one column per joint in chain order;
* ``x, y, z``: measured reflector position, m, in the tracker frame (tracker head at the origin);
* ``x_nom, y_nom, z_nom``: the model under test's prediction, m (any frame: judging registers it);
* optional ``sigma_x, sigma_y, sigma_z``: standard deviation of one reading per axis, m.

The file is parsed with the csv module; nothing in it is ever evaluated.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rmbench.errors import InputError

__all__ = ["TrackerReadings", "read_tracker_csv", "write_tracker_csv", "REQUIRED_COLUMNS"]

REQUIRED_COLUMNS = ("location", "x", "y", "z", "x_nom", "y_nom", "z_nom")
_SIGMA = ("sigma_x", "sigma_y", "sigma_z")


@dataclass(frozen=True)
class TrackerReadings:
    """Readings of a tracker campaign.

    Attributes
    ----------
    location : ndarray of int, shape (n,)
    joints : tuple of str
        Joint names (from the ``q_<joint>`` columns).
    q : ndarray, shape (n, n_joint), rad
    measured : ndarray, shape (n, 3), m
    nominal : ndarray, shape (n, 3), m
    sigma : ndarray, shape (n, 3), m, or None
    comments : tuple of str
        Header comment lines (without '#').
    """

    location: np.ndarray
    joints: tuple
    q: np.ndarray
    measured: np.ndarray
    nominal: np.ndarray
    sigma: np.ndarray | None = None
    comments: tuple = field(default=())

    def __post_init__(self):
        n = len(self.location)
        if n == 0:
            raise InputError("readings must hold at least one row")
        for name, shape in (("q", (n, len(self.joints))), ("measured", (n, 3)),
                            ("nominal", (n, 3))):
            arr = getattr(self, name)
            if arr.shape != shape:
                raise InputError(f"readings {name} must have shape {shape}, got {arr.shape}")
            if not np.all(np.isfinite(arr)):
                raise InputError(f"readings {name} must be finite, got NaN or infinity")
        if self.sigma is not None:
            if self.sigma.shape != (n, 3):
                raise InputError(f"readings sigma must have shape {(n, 3)}, got {self.sigma.shape}")
            bad = ~(np.isfinite(self.sigma) & (self.sigma > 0))
            if np.any(bad):
                raise InputError(f"readings sigma must be finite and > 0, got {self.sigma[bad][0]!r}")
        for loc in np.unique(self.location):
            rows = self.q[self.location == loc]
            if np.max(np.abs(rows - rows[0])) > 1e-9:
                raise InputError(f"location {loc} has readings with different joint angles")


def read_tracker_csv(path) -> TrackerReadings:
    """Read tracker readings (module docstring for the columns).

    Raises
    ------
    rmbench.errors.InputError
        Missing file or column, a non-numeric or NaN value (with its line), no joint columns.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"readings file {str(path)!r} not found")
    with path.open(newline="") as f:
        lines = f.read().splitlines()
    comments = tuple(line.lstrip("#").strip() for line in lines if line.startswith("#"))
    numbered = [(k + 1, line) for k, line in enumerate(lines)
                if line.strip() and not line.startswith("#")]
    if not numbered:
        raise InputError(f"{path}: no header row")
    rows = list(csv.reader(line for _, line in numbered))
    header = [h.strip() for h in rows[0]]
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    joints = tuple(h[2:] for h in header if h.startswith("q_"))
    if missing:
        raise InputError(f"{path}: missing column(s) {', '.join(missing)}")
    if not joints:
        raise InputError(f"{path}: no joint columns (q_<joint>)")
    has_sigma = [c in header for c in _SIGMA]
    if any(has_sigma) and not all(has_sigma):
        raise InputError(f"{path}: give all of sigma_x, sigma_y, sigma_z or none")
    wanted = list(REQUIRED_COLUMNS) + [f"q_{j}" for j in joints] + (list(_SIGMA) if all(has_sigma) else [])
    col = {name: header.index(name) for name in wanted}
    values = {name: [] for name in wanted}
    for (lineno, _), row in zip(numbered[1:], rows[1:]):
        if len(row) != len(header):
            raise InputError(f"{path}, line {lineno}: {len(row)} fields, expected {len(header)}")
        for name in wanted:
            text = row[col[name]].strip()
            try:
                v = float(text)
            except ValueError:
                raise InputError(f"{path}, line {lineno}: column {name} is not a number: "
                                 f"{text!r}") from None
            if not math.isfinite(v):
                raise InputError(f"{path}, line {lineno}: column {name} is {text!r}, not finite")
            values[name].append(v)
    if not values["location"]:
        raise InputError(f"{path}: no readings")
    loc = np.asarray(values["location"])
    if np.any(loc != np.round(loc)):
        raise InputError(f"{path}: location must be integer labels")

    def stack(names):
        return np.column_stack([values[n] for n in names])

    return TrackerReadings(loc.astype(int), joints, stack([f"q_{j}" for j in joints]),
                           stack(["x", "y", "z"]), stack(["x_nom", "y_nom", "z_nom"]),
                           stack(list(_SIGMA)) if all(has_sigma) else None, comments)


def write_tracker_csv(path, readings: TrackerReadings) -> None:
    """Write readings (with their comment lines) to ``path``; written whole, then renamed."""
    path = Path(path)
    header = (["location"] + [f"q_{j}" for j in readings.joints] + ["x", "y", "z", "x_nom", "y_nom",
                                                                     "z_nom"]
              + (list(_SIGMA) if readings.sigma is not None else []))
    tmp = path.with_name(path.name + ".part")
    with tmp.open("w", newline="") as f:
        for line in readings.comments:
            f.write(f"# {line}\n")
        w = csv.writer(f)
        w.writerow(header)
        for k in range(len(readings.location)):
            row = [int(readings.location[k])] + [repr(float(v)) for v in readings.q[k]]
            row += [repr(float(v)) for v in readings.measured[k]]
            row += [repr(float(v)) for v in readings.nominal[k]]
            if readings.sigma is not None:
                row += [repr(float(v)) for v in readings.sigma[k]]
            w.writerow(row)
    tmp.replace(path)
