"""Arrays with JSON metadata in one ``.npz``: written atomically, read without unpickling.

The container of every saved model and plan (predictors, plans): named arrays plus a ``meta``
entry, a JSON object whose ``format`` names what the file holds.
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np

__all__ = ["write_npz", "read_npz"]


def write_npz(path, meta: dict, arrays: dict) -> Path:
    """Write ``arrays`` and ``meta`` (JSON-serialisable, with a ``format`` entry) to ``path``
    through a temporary file, so that a reader never sees half a file."""
    path = Path(path)
    tmp = path.with_name(path.name + ".part")
    with open(tmp, "wb") as fh:
        np.savez(fh, meta=np.array(json.dumps(meta)), **arrays)
    tmp.replace(path)
    return path


def read_npz(path, fmt: str) -> tuple[dict, dict]:
    """The metadata and arrays of a file :func:`write_npz` wrote with ``meta["format"] == fmt``.

    Raises
    ------
    FileNotFoundError
        No such file.
    ValueError
        Not an ``.npz``, no metadata, or another format (the message names it).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(str(path))
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        meta = json.loads(str(arrays.pop("meta")))
    except (OSError, KeyError, ValueError, zipfile.BadZipFile) as e:
        raise ValueError(f"not an rmbench file ({type(e).__name__})") from None
    if not isinstance(meta, dict) or meta.get("format") != fmt:
        raise ValueError(f"format {meta.get('format') if isinstance(meta, dict) else '?'}")
    return meta, arrays
