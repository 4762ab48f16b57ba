"""Specification: the command line computes no physical quantity (issue 81).

A command parses its arguments, calls the library, converts units for display (mm, degrees, %) and
prints or writes what the library returned. A quantity worked out in ``rmbench.cli`` is out of
reach of the library's users and of its tests, so it goes into the library, next to the result it
belongs to. Read by AST from every module of ``rmbench.cli`` (lazy imports and nested functions
included).

What counts as computing (:data:`NUMPY_CALLS`, :data:`NUMPY_PACKAGES`, :data:`ARRAY_METHODS`):

- a numpy reduction or array math called as ``np.<name>`` / ``numpy.<name>``: statistics (mean,
  median, percentile, std, ...), extrema and their positions (max, min, argmax, ...), sums and
  products, magnitudes and roots (abs, sqrt, hypot), interpolation, differences and integrals,
  dot products, logarithms and exponentials, fits;
- anything of ``np.linalg`` or ``np.fft``;
- the same reductions as array methods (``a.mean()``, ``a.max()``, ...), whatever the receiver.

Allowed: building and shaping arrays (``np.asarray``, ``np.array``, ``np.round`` for display),
unit conversions (``* 1e-3``, ``np.radians``, ``np.deg2rad``, ``np.degrees``), Python's built-in
``min``/``max``/``sum`` over the library's numbers (counting, choosing a column width).
"""

import ast
from pathlib import Path

import rmbench

CLI = Path(rmbench.__file__).resolve().parent / "cli"

NUMPY_CALLS = frozenset({
    # statistics
    "mean", "average", "median", "percentile", "quantile", "std", "var", "nanmean", "nanmedian",
    "nanpercentile", "nanquantile", "nanstd", "nanvar", "cov", "corrcoef", "histogram",
    # extrema and where they are
    "max", "min", "amax", "amin", "nanmax", "nanmin", "maximum", "minimum", "argmax", "argmin",
    "nanargmax", "nanargmin", "ptp", "argsort", "sort",
    # sums and products
    "sum", "nansum", "prod", "cumsum", "cumprod", "dot", "vdot", "matmul", "einsum", "inner", "outer",
    "cross", "tensordot",
    # magnitudes, roots, logarithms, exponentials
    "abs", "absolute", "fabs", "sqrt", "hypot", "square", "power", "log", "log10", "log2", "exp",
    # interpolation, differences, integrals, fits
    "interp", "diff", "gradient", "trapz", "trapezoid", "polyfit", "polyval", "convolve",
})
"""Functions of numpy that compute (``np.<name>(...)``)."""

NUMPY_PACKAGES = frozenset({"linalg", "fft"})
"""Packages of numpy any call into which computes (``np.linalg.norm(...)``)."""

ARRAY_METHODS = frozenset({"mean", "max", "min", "sum", "prod", "std", "var", "argmax", "argmin",
                           "ptp", "cumsum", "cumprod", "dot", "median", "quantile"})
"""Reductions called as a method (``a.mean()``); the receiver's type is not known from the AST."""

def _dotted(node) -> list:
    """``np.linalg.norm`` -> ``["np", "linalg", "norm"]``; [] for a call of anything else."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if isinstance(node, ast.Name):
        parts.append(node.id)
        return parts[::-1]
    return []


def computing_call(call: ast.Call) -> str | None:
    """The name of what ``call`` computes (``"np.mean"``, ``"np.linalg.norm"``, ``".max()"``), or
    None where it computes nothing of :data:`NUMPY_CALLS`, :data:`NUMPY_PACKAGES` or
    :data:`ARRAY_METHODS`."""
    parts = _dotted(call.func)
    if len(parts) >= 2 and parts[0] in ("np", "numpy"):
        if parts[1] in NUMPY_PACKAGES or (len(parts) == 2 and parts[1] in NUMPY_CALLS):
            return ".".join(["np"] + parts[1:])
        return None
    if isinstance(call.func, ast.Attribute) and call.func.attr in ARRAY_METHODS:
        return f".{call.func.attr}()"
    return None


def computing_calls(root: Path = CLI) -> dict:
    """``{(module, call): [line, ...]}`` of every computing call in the modules under ``root``."""
    found: dict = {}
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and (name := computing_call(node)):
                found.setdefault((path.name, name), []).append(node.lineno)
    return found


def _calls(source: str) -> list:
    return [computing_call(n) for n in ast.walk(ast.parse(source)) if isinstance(n, ast.Call)]


def test_numpy_reductions_linear_algebra_and_array_methods_count_as_computing():
    got = _calls("np.mean(a); numpy.max(a); np.linalg.norm(v); np.fft.rfft(x); a.argmax(); "
                 "np.sqrt(s); np.interp(x, xp, fp)")
    assert got == ["np.mean", "np.max", "np.linalg.norm", "np.fft.rfft", ".argmax()", "np.sqrt", "np.interp"]


def test_unit_conversions_array_building_and_builtins_do_not_count():
    src = ("np.radians(t); np.deg2rad(t); np.degrees(t); np.asarray(x, float) * 1e-3; np.round(v, 1); "
           "max(len(n) for n in names); sum(1 for p in params if p.ok); d.get('k'); np.random.default_rng(0)")
    assert all(c is None for c in _calls(src))


def test_no_command_computes_a_physical_quantity():
    found = computing_calls()
    offenders = [f"cli/{module}:{','.join(map(str, sorted(set(lines))))}: {call}"
                 for (module, call), lines in sorted(found.items())]
    assert not offenders, ("the command line computes; move it into the library (the result's own "
                           "method or a function beside it):\n" + "\n".join(offenders))
