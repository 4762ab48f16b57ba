"""JSON-ready values and whole-file writes for the gap stage's outputs."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["jsonable", "write_whole"]


def jsonable(o):
    """``o`` with numpy scalars and arrays as Python numbers and lists; NaN and inf as None."""
    if isinstance(o, dict):
        return {str(k): jsonable(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [jsonable(v) for v in o]
    if isinstance(o, (np.floating, float)):
        return float(o) if np.isfinite(o) else None
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.bool_):
        return bool(o)
    if isinstance(o, np.ndarray):
        return jsonable(o.tolist())
    return o


def write_whole(path: Path, text: str) -> None:
    """Write ``text`` to a sibling ``.part`` file, then rename it: never half a file."""
    path = Path(path)
    tmp = path.with_name(path.name + ".part")
    tmp.write_text(text)
    tmp.replace(path)
