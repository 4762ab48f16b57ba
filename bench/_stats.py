"""Shared helpers of the bench scripts."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np

RMBENCH = str(Path(sys.executable).with_name("rmbench"))


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a rate ``k / n`` (95 % by default); NaN for ``n == 0``."""
    if n == 0:
        return float("nan"), float("nan")
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return max(c - h, 0.0), min(c + h, 1.0)


def rate(flags) -> str:
    """``k/n = p % (95 %: lo-hi)`` of boolean flags, or ``-`` for none."""
    flags = list(flags)
    k, n = sum(bool(f) for f in flags), len(flags)
    if n == 0:
        return "-"
    lo, hi = wilson(k, n)
    return f"{k}/{n} = {100 * k / n:.1f} % (95 %: {100 * lo:.0f}-{100 * hi:.0f})"


def blind_cases(args, *extra: str) -> list[dict]:
    """Run ``rmbench gap blind`` (``--cases``, ``--seed`` from ``args``, ``extra`` options) into the
    JSON-lines file ``args.lines`` (a killed run resumes from it) and return its first
    ``args.cases`` cases as dicts."""
    lines = Path(args.lines)
    lines.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run([RMBENCH, "gap", "blind", "--cases", str(args.cases), "--seed", str(args.seed),
                    *extra, "--out", str(lines), "--json"], check=True, stdout=subprocess.DEVNULL)
    cases = [json.loads(s) for s in lines.read_text().splitlines() if s.strip()]
    return [c for c in cases if c["index"] < args.cases]
