"""Strict JSON text: what any JSON parser reads, never a bare ``NaN`` or ``Infinity``.

Python's :func:`json.dumps` writes ``NaN``, ``Infinity`` and ``-Infinity`` for non-finite floats,
which strict parsers (JavaScript's ``JSON.parse``, ``jq``, most others) refuse. :func:`jsonable`
turns numpy scalars and arrays into Python numbers and lists and every non-finite float into
``None`` (``null``); :func:`strict_dumps` writes the result with ``allow_nan=False``, so a value
that slipped past the conversion raises instead of producing invalid JSON. Where a non-finite
value means something (no instability below the largest depth searched, say), the writer states
that meaning in a field of its own beside the ``null``.
"""

from __future__ import annotations

import json
import math

import numpy as np

__all__ = ["jsonable", "strict_dumps"]


def jsonable(obj):
    """``obj`` as plain JSON values.

    Dicts (keys as ``str``), lists and tuples are converted item by item; numpy scalars become
    Python ``int``, ``float`` or ``bool``; arrays become nested lists; NaN and ±inf (Python or
    numpy floats) become ``None``. Anything else is returned unchanged.
    """
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def strict_dumps(obj, **kwargs) -> str:
    """JSON text of ``jsonable(obj)``; raises ``ValueError`` rather than write NaN or Infinity.

    ``kwargs`` go to :func:`json.dumps` (``indent``, ``sort_keys``, ``default``, ...);
    ``allow_nan`` is always False.
    """
    if "allow_nan" in kwargs:
        raise TypeError("strict_dumps never allows NaN; do not pass allow_nan")
    return json.dumps(jsonable(obj), allow_nan=False, **kwargs)
