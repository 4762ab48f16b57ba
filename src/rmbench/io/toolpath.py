"""Tool paths in: cutter locations on the workpiece plane, from a CSV or a G-code subset.

**CSV** (``#`` comment lines, a header row, columns in any order, names fixed):

* ``x_mm, y_mm``: the cutter location on the workpiece plane, mm (required);
* optional ``z_mm`` (height, mm), ``feed_mm_min`` (feed, mm/min), ``rpm`` (spindle speed, rev/min).

**G-code**, the subset a 2½-D contour or pocket needs, one block per line:

* ``G0`` (rapid) and ``G1`` (linear cut) moves, modal, with ``X Y Z`` in mm, absolute;
* ``F`` feed (mm/min), ``S`` spindle speed (rev/min), ``N`` block numbers;
* ``G17`` (XY plane), ``G21`` (mm), ``G90`` (absolute), ``G94`` (feed per minute);
* ``M3``, ``M4``, ``M5`` (spindle), ``M2``, ``M30`` (end of program) are accepted and do nothing
  here; comments in ``( )`` or after ``;``, ``%`` lines.

Any other word (arcs ``G2``/``G3``, inches ``G20``, incremental ``G91``, cutter compensation, ...) is
a one-line error naming the file, the line and the word. Both files are parsed as text; nothing in
them is evaluated. Inside, everything is SI (m, m/s).
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rmbench.errors import InputError

__all__ = ["ToolPath", "read_toolpath", "read_cl_csv", "read_gcode", "write_cl_csv", "GCODE_WORDS"]

#: G-code words accepted (letter and value; X, Y, Z, F, S, N take any number)
GCODE_WORDS = ("G0", "G1", "G17", "G21", "G90", "G94", "M2", "M3", "M4", "M5", "M30")
_WORD = re.compile(r"([A-Za-z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")
_COMMENT = re.compile(r"\([^)]*\)")


@dataclass(frozen=True)
class ToolPath:
    """Cutter locations on the workpiece plane, in order.

    Attributes
    ----------
    xy : ndarray, shape (n, 2), m
        Tool-tip positions on the plane (the robot's posture x, y).
    z : ndarray, shape (n,), m
        Height as programmed (NaN where never given).
    feed : ndarray, shape (n,), m/s
        Programmed feed (NaN where not given).
    rpm : ndarray, shape (n,), rev/min
        Programmed spindle speed (NaN where not given).
    cutting : ndarray of bool, shape (n,)
        Whether the move *into* each point cuts (a G1 move; False for a rapid and for the first
        point).
    line : ndarray of int, shape (n,)
        Source line of each point (1-based; interpolated points keep their move's line).
    source : str
        The file read.
    """

    xy: np.ndarray
    z: np.ndarray
    feed: np.ndarray
    rpm: np.ndarray
    cutting: np.ndarray
    line: np.ndarray
    source: str = ""

    def __len__(self) -> int:
        return len(self.xy)

    def arc_length(self) -> np.ndarray:
        """Distance travelled to each point along the path, m, shape (n,)."""
        steps = np.linalg.norm(np.diff(self.xy, axis=0), axis=1)
        return np.concatenate([[0.0], np.cumsum(steps)])

    def heading(self) -> np.ndarray:
        """Feed direction at each point, rad in (−π, π], shape (n,): the direction of travel of the
        move *into* the point, from base X toward base Y (the move that cuts it, as
        :attr:`cutting` counts moves). The first point takes the direction of the first move that
        goes anywhere; a point reached by a move of no length keeps the direction of the move
        before it. Rapid moves have a heading too (where they head), though nothing is cut there.
        """
        step = np.diff(self.xy, axis=0) + 0.0      # no −0.0: a move along −X heads +π, not −π
        moved = np.any(step != 0, axis=1)
        if not moved.any():
            raise InputError("the tool path never moves: no feed direction")
        into = np.arctan2(step[:, 1], step[:, 0])
        # a zero-length move carries the last real direction; the first point the first real one
        last = np.maximum.accumulate(np.where(moved, np.arange(len(step)), -1))
        into = into[np.where(last >= 0, last, int(np.argmax(moved)))]
        return np.concatenate([into[:1], into])

    def cut_length(self) -> float:
        """Length of the cutting moves, m."""
        steps = np.linalg.norm(np.diff(self.xy, axis=0), axis=1)
        return float(np.sum(steps[self.cutting[1:]]))

    def resampled(self, spacing: float) -> "ToolPath":
        """The path with every cutting move divided into steps of at most ``spacing`` (m); rapid
        moves keep their end points only (nothing is cut along them)."""
        if not spacing > 0:
            raise InputError(f"the cutter-location spacing must be > 0 mm, got {1e3 * spacing!r}")
        keep = [0]
        weights = [(0, 0.0)]           # (segment start index, fraction) per output point
        for i in range(1, len(self.xy)):
            n = 1
            if self.cutting[i]:
                n = max(1, int(math.ceil(np.linalg.norm(self.xy[i] - self.xy[i - 1]) / spacing - 1e-9)))
            for k in range(1, n + 1):
                weights.append((i - 1, k / n))
                keep.append(i)
        start = np.array([w[0] for w in weights])
        frac = np.array([w[1] for w in weights])[:, None]
        end = np.array(keep)
        xy = self.xy[start] * (1 - frac) + self.xy[end] * frac
        z = self.z[start] * (1 - frac[:, 0]) + self.z[end] * frac[:, 0]
        return ToolPath(xy, z, self.feed[end], self.rpm[end], self.cutting[end], self.line[end], self.source)


def read_toolpath(path) -> ToolPath:
    """A tool path from a CSV (``.csv``) or G-code file (any other suffix)."""
    path = Path(path)
    return read_cl_csv(path) if path.suffix.lower() == ".csv" else read_gcode(path)


def _text(path: Path) -> str:
    if not path.is_file():
        raise InputError(f"tool path not found: {path}")
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise InputError(f"cannot read tool path {path}: {err}") from None


def read_cl_csv(path) -> ToolPath:
    """Cutter locations from a CSV (module docstring); every row a cutting move but the first."""
    path = Path(path)
    rows = [(k + 1, r) for k, r in enumerate(csv.reader(_text(path).splitlines()))
            if r and not r[0].lstrip().startswith("#") and any(c.strip() for c in r)]
    if not rows:
        raise InputError(f"{path}: no header row")
    head_line, header = rows[0]
    names = [h.strip() for h in header]
    for need in ("x_mm", "y_mm"):
        if need not in names:
            raise InputError(f"{path}:{head_line}: the header needs column {need!r} (has {', '.join(names)})")
    unknown = [n for n in names if n not in ("x_mm", "y_mm", "z_mm", "feed_mm_min", "rpm")]
    if unknown:
        raise InputError(f"{path}:{head_line}: unknown column {unknown[0]!r} "
                         "(columns: x_mm, y_mm, optional z_mm, feed_mm_min, rpm)")
    col = {n: i for i, n in enumerate(names)}
    data, lines = [], []
    for lineno, r in rows[1:]:
        if len(r) != len(names):
            raise InputError(f"{path}:{lineno}: {len(r)} values, the header has {len(names)}")
        vals = {}
        for n, i in col.items():
            text = r[i].strip()
            if text == "" and n not in ("x_mm", "y_mm"):
                vals[n] = math.nan
                continue
            try:
                v = float(text)
            except ValueError:
                raise InputError(f"{path}:{lineno}: {n} must be a number, got {text!r}") from None
            if not math.isfinite(v):
                raise InputError(f"{path}:{lineno}: {n} must be finite, got {text!r}")
            vals[n] = v
        data.append(vals)
        lines.append(lineno)
    if len(data) < 2:
        raise InputError(f"{path}: a tool path needs at least 2 cutter locations, got {len(data)}")

    def column(n, scale):
        return np.array([scale * d.get(n, math.nan) for d in data])

    feed = column("feed_mm_min", 1e-3 / 60)
    if np.any(feed <= 0):
        raise InputError(f"{path}: feed_mm_min must be > 0")
    rpm = column("rpm", 1.0)
    if np.any(rpm <= 0):
        raise InputError(f"{path}: rpm must be > 0")
    cutting = np.ones(len(data), bool)
    cutting[0] = False
    return ToolPath(np.column_stack([column("x_mm", 1e-3), column("y_mm", 1e-3)]), column("z_mm", 1e-3),
                    feed, rpm, cutting, np.array(lines), str(path))


def read_gcode(path) -> ToolPath:
    """Cutter locations from the G-code subset of the module docstring: one point per move's end
    (a block that moves only in Z adds none)."""
    path = Path(path)
    state = {"motion": None, "x": math.nan, "y": math.nan, "z": math.nan, "f": math.nan, "s": math.nan}
    pts = []          # (x, y, z, feed, rpm, cutting, line)
    for lineno, raw in enumerate(_text(path).splitlines(), start=1):
        text = _COMMENT.sub(" ", raw).split(";", 1)[0].strip()
        if not text or text.startswith("%"):
            continue
        if "(" in text or ")" in text:
            raise InputError(f"{path}:{lineno}: unclosed comment")
        rest = _WORD.sub(" ", text).strip()
        if rest:
            raise InputError(f"{path}:{lineno}: cannot read {rest.split()[0]!r} as a G-code word")
        moved = False
        for letter, value in _WORD.findall(text):
            letter = letter.upper()
            v = float(value)
            if letter in "GM":
                word = f"{letter}{int(v)}" if v == int(v) else f"{letter}{value}"
                if word not in GCODE_WORDS:
                    raise InputError(f"{path}:{lineno}: unsupported G-code word {letter}{value} "
                                     f"(supported: {', '.join(GCODE_WORDS)}, X Y Z F S N)")
                if word in ("G0", "G1"):
                    state["motion"] = word
            elif letter in "XYZ":
                state[letter.lower()] = 1e-3 * v
                moved |= letter in "XY"
            elif letter == "F":
                if not v > 0:
                    raise InputError(f"{path}:{lineno}: the feed F must be > 0, got {value}")
                state["f"] = 1e-3 * v / 60
            elif letter == "S":
                if not v > 0:
                    raise InputError(f"{path}:{lineno}: the spindle speed S must be > 0, got {value}")
                state["s"] = v
            elif letter != "N":
                raise InputError(f"{path}:{lineno}: unsupported G-code word {letter}{value} "
                                 f"(supported: {', '.join(GCODE_WORDS)}, X Y Z F S N)")
        if moved:
            if state["motion"] is None:
                raise InputError(f"{path}:{lineno}: a move before any G0 or G1")
            if math.isnan(state["x"]) or math.isnan(state["y"]):
                raise InputError(f"{path}:{lineno}: the first move must give both X and Y")
            pts.append((state["x"], state["y"], state["z"], state["f"], state["s"],
                        state["motion"] == "G1" and bool(pts), lineno))
    if len(pts) < 2:
        raise InputError(f"{path}: a tool path needs at least 2 moves in X or Y, got {len(pts)}")
    a = np.array([p[:5] for p in pts], float)
    cutting = np.array([p[5] for p in pts], bool)
    if not cutting.any():
        raise InputError(f"{path}: no cutting (G1) move")
    return ToolPath(a[:, :2], a[:, 2], a[:, 3], a[:, 4], cutting, np.array([p[6] for p in pts]), str(path))


def write_cl_csv(toolpath: ToolPath, path) -> Path:
    """Write the cutter locations as the CSV :func:`read_cl_csv` reads (mm, mm/min)."""
    path = Path(path)
    rows = ["x_mm,y_mm,z_mm,feed_mm_min,rpm"]
    for (x, y), z, f, s in zip(toolpath.xy, toolpath.z, toolpath.feed, toolpath.rpm):
        rows.append(",".join("" if not math.isfinite(v) else f"{v:.10g}"
                             for v in (1e3 * x, 1e3 * y, 1e3 * z, 6e4 * f, s)))
    path.write_text("\n".join(rows) + "\n")
    return path
