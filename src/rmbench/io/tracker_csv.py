"""Laser-tracker readings as CSV: one reading per row, SI units (rad, m), '#' comment lines.

Columns (order free, names fixed):

* ``location``: integer label of the commanded configuration (repeats share it);
* ``q_<joint>``: commanded joint angles, rad, one column per joint in chain order;
* ``x, y, z``: measured reflector position, m, in the tracker frame (tracker head at the origin);
* ``x_nom, y_nom, z_nom``: the model under test's prediction, m (any frame: judging registers it);
  needed to judge readings, optional for the gap diagnosis (which predicts them itself);
* optional ``sigma_x, sigma_y, sigma_z``: standard deviation of one reading per axis, m;
* optional ``t``: time stamp, s; optional ``temperature``: the robot's temperature, °C.

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

REQUIRED_COLUMNS = ("location", "x", "y", "z")
_NOMINAL = ("x_nom", "y_nom", "z_nom")
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
    nominal : ndarray, shape (n, 3), m, or None
    sigma : ndarray, shape (n, 3), m, or None
    comments : tuple of str
        Header comment lines (without '#').
    t : ndarray, shape (n,), s, or None
    temperature : ndarray, shape (n,), °C, or None
    """

    location: np.ndarray
    joints: tuple
    q: np.ndarray
    measured: np.ndarray
    nominal: np.ndarray | None
    sigma: np.ndarray | None = None
    comments: tuple = field(default=())
    t: np.ndarray | None = None
    temperature: np.ndarray | None = None

    def __post_init__(self):
        n = len(self.location)
        if n == 0:
            raise InputError("readings must hold at least one row")
        for name, shape in (("q", (n, len(self.joints))), ("measured", (n, 3)),
                            ("nominal", (n, 3)), ("t", (n,)), ("temperature", (n,))):
            arr = getattr(self, name)
            if arr is None and name in ("nominal", "t", "temperature"):
                continue
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
    optional = []
    for group in (_NOMINAL, _SIGMA):
        has = [c in header for c in group]
        if any(has) and not all(has):
            raise InputError(f"{path}: give all of {', '.join(group)} or none")
        optional += list(group) if all(has) else []
    optional += [c for c in ("t", "temperature") if c in header]
    wanted = list(REQUIRED_COLUMNS) + [f"q_{j}" for j in joints] + optional
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

    def maybe(names):
        return stack(list(names)) if names[0] in values else None

    return TrackerReadings(loc.astype(int), joints, stack([f"q_{j}" for j in joints]),
                           stack(["x", "y", "z"]), maybe(_NOMINAL), maybe(_SIGMA), comments,
                           np.asarray(values["t"]) if "t" in values else None,
                           np.asarray(values["temperature"]) if "temperature" in values else None)


def write_tracker_csv(path, readings: TrackerReadings) -> None:
    """Write readings (with their comment lines) to ``path``; written whole, then renamed."""
    path = Path(path)
    extra = [(list(_NOMINAL), readings.nominal), (list(_SIGMA), readings.sigma),
             (["t"], None if readings.t is None else readings.t[:, None]),
             (["temperature"], None if readings.temperature is None else readings.temperature[:, None])]
    extra = [(names, arr) for names, arr in extra if arr is not None]
    header = (["location"] + [f"q_{j}" for j in readings.joints] + ["x", "y", "z"]
              + [n for names, _ in extra for n in names])
    tmp = path.with_name(path.name + ".part")
    with tmp.open("w", newline="") as f:
        for line in readings.comments:
            f.write(f"# {line}\n")
        w = csv.writer(f)
        w.writerow(header)
        for k in range(len(readings.location)):
            row = [int(readings.location[k])] + [repr(float(v)) for v in readings.q[k]]
            row += [repr(float(v)) for v in readings.measured[k]]
            for _, arr in extra:
                row += [repr(float(v)) for v in arr[k]]
            w.writerow(row)
    tmp.replace(path)
