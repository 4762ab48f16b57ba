"""The API reference (``make docs``, docs/api) has something to say about every public name.

Read from the code, without sphinx: each stage's page documents the names in its ``__all__``, so
each of them has a docstring (a constant: a ``#:`` comment or a docstring where it is assigned),
and a function that takes arrays says their shape or unit (STYLE.md: "shape and SI unit of every
array"). No known gaps: every public name is documented.
"""

import ast
import functools
import importlib
import inspect
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "rmbench"

# the packages with a page in docs/api; a re-exported object counts under the package it lives in
PACKAGES = ("robot", "impact", "modal", "predict", "rcsa", "stability", "path", "tracker", "calibrate",
            "gap", "gap.frf", "gap.tracker", "control", "report", "io", "errors", "parallel", "threads",
            "modeshape", "plotting")

# parameters that hold arrays when not annotated as such (frequency lines, FRFs, joint angles, ...)
ARRAY_NAMES = {"freq", "freqs", "H", "h", "h_ref", "h_alone", "h_coupled", "h_part", "h_robot", "h_target",
               "r33", "t_ref", "q", "q_cmd", "q_grid", "q_ref", "phi_r", "phi_l", "poles", "residues",
               "coherence", "X", "positions", "postures_xyt", "locations", "depths", "speeds",
               "speeds_rpm", "shapes_a", "shapes_b"}
# a shape: the word, or a tuple of names and numbers with a dimension among them: (n_freq, 4, 4),
# (posture, freq, 4, 4), (6,); not a tuple of values like (x, y, theta), nor an equation's "(1)"
_TUPLE = re.compile(r"\(([\w.\s]*,[\w.\s,]*)\)")
_DIM = re.compile(r"\d+|n\w*|\w*freq\w*|\w*posture\w*|\w*mode\w*|\w*joint\w*|\w*sample\w*|\.\.\.")
UNIT = re.compile(r"m/N|\bHz\b|\brad\b|rad/s|\bkg\b|N·?m|N/m|m/s|\brpm\b|\bPa\b|\bSI\b"
                  r"|\b(?:metres?|seconds?|radians?|degrees?|newtons?)\b"
                  r"|(?<![\w'’])(?:m|s|N)(?=[,;.)]|$)", re.MULTILINE)   # "depth, m;", "(s)", "in m."
UNIT_SUFFIX = re.compile(r"_(?:m|mm|s|hz|rpm|deg|rad|n)$", re.IGNORECASE)   # speeds_rpm: the name says it


def _module(package):
    return importlib.import_module(f"rmbench.{package}")


def _is_routine_or_class(obj) -> bool:
    return inspect.isclass(obj) or inspect.isroutine(obj)


def _exported():
    """(public name, object) of every name in the pages' ``__all__``, each object once: under the
    package it lives in (``gap`` re-exports ``gap.frf.Diagnosis``: it counts as ``gap.frf``'s)."""
    out, seen = [], {}
    for package in PACKAGES:
        for name in _module(package).__all__:
            obj = getattr(_module(package), name)
            home = _home(package, name, obj)
            key = id(obj) if _is_routine_or_class(obj) else (home, name)
            if key not in seen:
                seen[key] = f"{home}.{name}"
                out.append((seen[key], obj))
    return out


def _home(package, name, obj) -> str:
    defined = getattr(obj, "__module__", "") if _is_routine_or_class(obj) else _assigned_in(package, name)[0]
    homes = [p for p in PACKAGES if f"rmbench.{p}" == defined or defined.startswith(f"rmbench.{p}.")]
    homes = [p for p in homes if getattr(_module(p), name, None) is obj and name in _module(p).__all__]
    return max(homes, key=len, default=package)


def _assigned_in(package, name) -> tuple[str, str]:
    """The module that assigns a constant and the name it has there, following ``from x import``."""
    module = f"rmbench.{package}"
    for _ in range(10):
        tree = ast.parse(inspect.getsource(importlib.import_module(module)))
        imported = [(node.module, alias.name) for node in tree.body if isinstance(node, ast.ImportFrom)
                    for alias in node.names if (alias.asname or alias.name) == name]
        if not imported:
            return module, name
        module, name = imported[0]
    return module, name


def _constant_doc(package, name) -> str:
    """A constant's ``#:`` comment (above or trailing) or the docstring after its assignment."""
    module, name = _assigned_in(package, name)
    source = inspect.getsource(importlib.import_module(module))
    lines = source.splitlines()
    body = ast.parse(source).body
    for i, node in enumerate(body):
        targets = node.targets if isinstance(node, ast.Assign) else [getattr(node, "target", None)]
        if not any(isinstance(t, ast.Name) and t.id == name for t in targets):
            continue
        after = body[i + 1] if i + 1 < len(body) else None
        if isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant) and isinstance(after.value.value, str):
            return after.value.value.strip()
        above, row = [], node.lineno - 2
        while row >= 0 and lines[row].lstrip().startswith("#:"):
            above.insert(0, lines[row].lstrip()[2:].strip())
            row -= 1
        trailing = lines[node.lineno - 1].partition("#:")[2]
        return " ".join(above).strip() or trailing.strip()
    return ""


def _public_methods(cls):
    for name, attr in vars(cls).items():
        function = attr.__func__ if isinstance(attr, (classmethod, staticmethod)) else attr
        if (not name.startswith("_") or name == "__init__") and inspect.isfunction(function):
            yield name, function


def _routines():
    """(public name, function, docstring that documents it, whether a method) of every exported
    function and method; a constructor is documented by its class's docstring."""
    for public, obj in _exported():
        if inspect.isfunction(obj):
            yield public, obj, obj.__doc__ or "", False
        elif inspect.isclass(obj):
            for name, function in _public_methods(obj):
                if name == "__init__":
                    yield public, function, (obj.__doc__ or "") + (function.__doc__ or ""), False
                else:
                    yield f"{public}.{name}", function, function.__doc__ or "", True


def _own_docstring(obj) -> str:
    doc = (obj.__doc__ or "").strip()
    # a dataclass without a docstring gets its signature as one: "Name(field: type, ...)"
    if inspect.isclass(obj) and doc.startswith(f"{obj.__name__}("):
        return ""
    return doc


def _methods_without_docstring() -> set[str]:
    return {public for public, _, doc, method in _routines() if method and not doc.strip()}


def _properties_without_docstring() -> set[str]:
    return {f"{public}.{name}" for public, obj in _exported() if inspect.isclass(obj)
            for name, attr in vars(obj).items()
            if isinstance(attr, (property, functools.cached_property)) and not name.startswith("_")
            and not (attr.__doc__ or "").strip()}


def _constants_without_doc() -> set[str]:
    return {public for public, obj in _exported() if not _is_routine_or_class(obj) and not inspect.ismodule(obj)
            and not _constant_doc(*public.rsplit(".", 1))}


def _array_parameters(function) -> list[str]:
    return [name for name, p in inspect.signature(function).parameters.items()
            if re.search(r"ndarray|ArrayLike|NDArray", str(p.annotation)) or name in ARRAY_NAMES]


def _states_shape(doc: str) -> bool:
    return bool(re.search(r"\bshape\b", doc)) or any(
        any(_DIM.fullmatch(e.strip()) for e in t.split(",")) for t in _TUPLE.findall(doc))


def _arrays_without_shape_or_unit() -> set[str]:
    out = set()
    for public, function, doc, _ in _routines():
        arrays = [a for a in _array_parameters(function) if not UNIT_SUFFIX.search(a)]
        if arrays and not (_states_shape(doc) or UNIT.search(doc)):
            out.add(public)
    return out


def test_every_stage_has_its_page_in_the_api_reference():
    stages = {p.name for p in SRC.iterdir() if (p / "__init__.py").is_file()} - {"cli"}
    pages = set(re.findall(r"^\.\. apipage:: rmbench\.([\w.]+)$",
                           "\n".join(f.read_text(encoding="utf-8") for f in (ROOT / "docs" / "api").glob("*.rst")),
                           re.MULTILINE))
    assert stages <= set(PACKAGES)
    assert pages == set(PACKAGES)


@pytest.mark.parametrize("package", PACKAGES)
def test_every_exported_class_and_function_has_a_docstring(package):
    module = _module(package)
    missing = {f"{_home(package, name, obj)}.{name}" for name, obj in vars(module).items()
               if name in module.__all__ and _is_routine_or_class(obj) and not _own_docstring(obj)}
    assert missing == set()


def test_every_public_method_has_a_docstring():
    assert _methods_without_docstring() == set()


def test_every_public_property_has_a_docstring():
    assert _properties_without_docstring() == set()


def test_every_exported_constant_has_a_doc_comment():
    assert _constants_without_doc() == set()


def test_every_function_taking_arrays_states_a_shape_or_unit():
    assert _arrays_without_shape_or_unit() == set()


def test_the_shape_and_unit_rule_reads_what_docstrings_write():
    # the rule itself: what counts as a shape or a unit, and what does not
    assert _states_shape("freq : ndarray, shape (n_freq,)") and _states_shape("H of (posture, freq, 4, 4)")
    assert _states_shape("positions (..., 3)") and _states_shape("a (6,) vector")
    assert UNIT.search("receptance in m/N") and UNIT.search("depth, m;") and UNIT.search("in rad")
    assert not _states_shape("postures (x, y, theta)") and not _states_shape("Eq. (1)")
    assert not UNIT.search("a matrix of the modes")
    assert not UNIT.search("the tool's, in N postures")
