"""Importing the bench's modules (bench/truth, the bench scripts) from a test."""

import sys
from contextlib import contextmanager
from pathlib import Path

BENCH = str(Path(__file__).resolve().parents[1] / "bench")


@contextmanager
def bench_on_path():
    """``bench/`` on ``sys.path`` for the imports inside the block, and ``sys.path`` restored
    whole after it (whatever the imported modules added): no bench script then shadows a library
    module for the tests collected after (bench/control.py once shadowed python-control)."""
    saved = list(sys.path)
    sys.path.insert(0, BENCH)
    try:
        yield
    finally:
        sys.path[:] = saved
