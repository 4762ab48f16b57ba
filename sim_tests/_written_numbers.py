"""Generated files compared as their generator writes them: the same text, each number to its digits.

A bundled file (an arm's MJCF, a tool's) is what a generator wrote on one machine. The generator's
arithmetic is reproducible to roundoff (~1e-15 relative), but a file holds each number rounded to the
digits it was written with (6 significant in MuJoCo's MJCF), and a value that lies on a rounding
boundary may round either way on another BLAS kernel or CPU. So a written decimal may differ by one
unit of its last digit and no more; every other character, and every bare integer (sizes, counts,
names' digits), must be the same. A stale file differs by far more: an IK seed moved by 1e-3 rad is
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
            if _is_integer(x) or _is_integer(y):
                out.append(f"line {n}: {x!r} != {y!r}")
                continue
            unit = max(_last_digit_unit(x), _last_digit_unit(y))
            if abs(Decimal(x) - Decimal(y)) > unit:
                out.append(f"line {n}: {x!r} != {y!r} (more than one unit of the last digit, {unit})")
    return out[:most]
