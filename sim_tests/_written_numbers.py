"""Generated files compared as their generator writes them: the same text, each number to its digits.

A bundled file (an arm's MJCF, a tool's) is what a generator wrote on one machine. The generator's
arithmetic is reproducible to roundoff (~1e-15 relative), but a file holds each number rounded to the
digits it was written with (6 significant in MuJoCo's MJCF), and a value that lies on a rounding
boundary may round either way on another BLAS kernel or CPU. So a written number may differ by one
unit of its finer last digit and no more (-0 and 0 are one value); every other character, every
small bare integer (sizes, counts) and names' digits must be the same. A stale file differs by far more: an IK seed moved by 1e-3 rad is
1000 units of its last written digit.
"""

import re
from decimal import Decimal

# a decimal number standing alone: not the digits of a name (j1_flex, 1aX) nor a dotted version
_NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?(?![\w.])")


def _last_digit_unit(token: str) -> Decimal:
    exponent = Decimal(token).as_tuple().exponent
    return Decimal(1).scaleb(exponent)


def _is_integer(token: str) -> bool:
    return not any(c in token for c in ".eE")


def _rounding(x: str, y: str) -> Decimal:
    """How far two written forms of one value may lie apart: one unit of the finer last digit
    (a writer drops trailing zeros, so "0.3" stands for 0.300000, not 0.3 ± 0.05); nothing for
    bare integers below 100000, which are counts and sizes (a 6-digit writer rounds only larger
    ones, "33291" for 33290.95)."""
    if _is_integer(x) and _is_integer(y) and max(abs(int(x)), abs(int(y))) < 100000:
        return Decimal(0)
    return min(_last_digit_unit(x), _last_digit_unit(y))


def written_differences(a: str, b: str, *, most: int = 10) -> list[str]:
    """The places where ``b`` differs from ``a`` beyond one unit of a number's last written digit.

    Returns at most ``most`` lines ``line N: 'x' != 'y'``; empty when the texts agree.
    """
    out = []
    lines_a, lines_b = a.splitlines(), b.splitlines()
    if len(lines_a) != len(lines_b):
        out.append(f"{len(lines_a)} lines != {len(lines_b)} lines")
    for n, (la, lb) in enumerate(zip(lines_a, lines_b), 1):
        if la == lb:
            continue
        if _NUMBER.split(la) != _NUMBER.split(lb):
            out.append(f"line {n}: {la.strip()!r} != {lb.strip()!r}")
            continue
        for x, y in zip(_NUMBER.findall(la), _NUMBER.findall(lb)):
            if x == y:
                continue
            if abs(Decimal(x) - Decimal(y)) > _rounding(x, y):
                out.append(f"line {n}: {x!r} != {y!r} (more than one unit of the last digit written)")
    return out[:most]
