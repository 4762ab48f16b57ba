"""The posture table ``postures.csv`` that travels with a directory of UFF58 files.

One row a posture, in the campaign's order, with the user-interface units (mm and degrees)::

    index,stem,x_mm,y_mm,theta_deg,bands,ok,reason
    0,posture_0000,1800.0,-200.0,0.0,low;high,true,
    1,posture_0001,1900.0,300.0,60.0,,false,IK: beyond joint limit

``stem`` names the posture's files (``{stem}_{band}.uff``), ``bands`` lists the bands written
(``;``-separated, empty for a posture that failed), ``ok``/``reason`` say whether it was measured.
Numbers are written with Python's shortest round-trip representation (``repr``).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

from rmbench.errors import InputError

__all__ = ["PostureRow", "COLUMNS", "format_table", "read_table"]

COLUMNS = ("index", "stem", "x_mm", "y_mm", "theta_deg", "bands", "ok", "reason")
_REQUIRED = ("index", "x_mm", "y_mm", "theta_deg")
_BANDS = ("low", "high")
_TRUE = {"true", "1", "yes"}
_FALSE = {"false", "0", "no"}


@dataclass(frozen=True)
class PostureRow:
    """One posture of the table, in SI units.

    Attributes
    ----------
    index : int
        Position of the posture in its campaign.
    stem : str
        File-name stem of its UFF files (``{stem}_{band}.uff``).
    x, y : float
        Tool-tip position in the robot base frame, m (NaN when unknown).
    theta : float
        Redundant angle about base +Z, rad (NaN when unknown).
    bands : tuple of str or None
        Bands written for it; None when the table has no ``bands`` column.
    ok : bool
        Whether the posture was measured.
    reason : str
        Why not, empty when ok.
    """

    index: int
    stem: str
    x: float
    y: float
    theta: float
    bands: tuple[str, ...] | None
    ok: bool
    reason: str


def format_table(rows: list[PostureRow]) -> str:
    """The CSV text of a posture table (header line first)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(COLUMNS)
    for row in rows:
        writer.writerow([row.index, row.stem, repr(row.x * 1000.0), repr(row.y * 1000.0),
                         repr(math.degrees(row.theta)), ";".join(row.bands or ()),
                         "true" if row.ok else "false", row.reason])
    return out.getvalue()


def read_table(path: Path) -> list[PostureRow]:
    """Read a posture table; columns ``index``, ``x_mm``, ``y_mm``, ``theta_deg`` are required.

    Raises
    ------
    InputError
        The file cannot be read, lacks a required column, or a row holds a malformed value
        (the message names the file and its line).
    """
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"posture table {path} cannot be read: {exc}") from None
    reader = csv.DictReader(io.StringIO(text))
    missing = [c for c in _REQUIRED if c not in (reader.fieldnames or ())]
    if missing:
        raise InputError(f"posture table {path} lacks the column(s) {', '.join(missing)}; "
                         f"expected {','.join(COLUMNS)}")
    rows = [_row(record, f"posture table {path}, line {reader.line_num}") for record in reader]
    indices = [row.index for row in rows]
    if len(set(indices)) != len(indices):
        raise InputError(f"posture table {path} lists an index twice")
    return rows


def _row(record: dict, where: str) -> PostureRow:
    try:
        index = int(record["index"])
        x, y, theta = (float(record[c]) for c in ("x_mm", "y_mm", "theta_deg"))
    except (TypeError, ValueError):
        raise InputError(f"{where}: index, x_mm, y_mm and theta_deg must be numbers, got "
                         f"{[record.get(c) for c in _REQUIRED]}") from None
    bands = None
    if record.get("bands") is not None:
        bands = tuple(b for b in record["bands"].replace(";", " ").split())
        unknown = [b for b in bands if b not in _BANDS]
        if unknown:
            raise InputError(f"{where}: unknown band(s) {unknown}; bands are 'low' and 'high'")
    ok_text = (record.get("ok") or "true").strip().lower()
    if ok_text not in _TRUE | _FALSE:
        raise InputError(f"{where}: ok must be true or false, got {record.get('ok')!r}")
    stem = (record.get("stem") or "").strip() or f"posture_{index:04d}"
    return PostureRow(index=index, stem=stem, x=x / 1000.0, y=y / 1000.0, theta=math.radians(theta),
                      bands=bands, ok=ok_text in _TRUE, reason=record.get("reason") or "")
