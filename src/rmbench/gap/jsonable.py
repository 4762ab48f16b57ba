"""JSON-ready values and whole-file writes for the gap stage's outputs.

``jsonable`` is :func:`rmbench.io.strict_json.jsonable` (numpy values as Python numbers and lists,
NaN and inf as None); files are written with :func:`rmbench.io.strict_json.strict_dumps`.
"""

from __future__ import annotations

from pathlib import Path

from rmbench.io.strict_json import jsonable

__all__ = ["jsonable", "write_whole"]


def write_whole(path: Path, text: str) -> None:
    """Write ``text`` to a sibling ``.part`` file, then rename it: never half a file."""
    path = Path(path)
    tmp = path.with_name(path.name + ".part")
    tmp.write_text(text)
    tmp.replace(path)
