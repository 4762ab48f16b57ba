"""Specification of the source's structure (issue 78): one concept per module, readable functions.

In the stages of :data:`PACKAGES` no module is over 600 lines, no function over 80 lines, none
takes more than 8 parameters (``self``/``cls`` not counted, ``*args`` and ``**kwargs`` one each);
and no module of rmbench imports a private name (``from rmbench.x.y import _z``) of another stage
(the first component after ``rmbench``). Read by AST from the package imported, lazy imports
inside functions included.
"""

import ast
from pathlib import Path

import pytest

import rmbench

PACKAGES = ("gap", "calibrate")         # the stages issue 78 holds to the limits
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 80
MAX_PARAMETERS = 8
ROOT = Path(rmbench.__file__).resolve().parent


def long_modules(root: Path, packages) -> list:
    """A module past 600 lines is where everything goes: it holds two concepts, and a reader cannot
    guess which file holds what."""
    return [f"{path.relative_to(root.parent)}: {n} lines" for path, n in
            ((p, len(p.read_text().splitlines())) for p in _modules(root, packages)) if n > MAX_MODULE_LINES]


def long_functions(root: Path, packages) -> list:
    """A function past 80 lines is several steps without names: split it into named steps."""
    return [f"{where}: {node.name} {node.end_lineno - node.lineno + 1} lines"
            for where, node in _functions(root, packages)
            if node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES]


def wide_functions(root: Path, packages) -> list:
    """A function of more than 8 parameters is asking for a record (prepared data, settings)."""
    return [f"{where}: {node.name} {n} parameters" for where, node in _functions(root, packages)
            if (n := _n_parameters(node.args)) > MAX_PARAMETERS]


def private_imports(root: Path, stages=None) -> list:
    """A private name is a seam its stage may change at will; another stage that imports it is
    tied to it unseen: the name needs a public spelling. With ``stages``, only imports from or
    into those stages."""
    out = []
    for path in sorted(root.rglob("*.py")):
        here = path.relative_to(root).with_suffix("").parts
        package = here[:-1]
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.ImportFrom):
                continue
            if node.level:
                module = list(package[: len(package) - node.level + 1]) + (node.module.split(".") if node.module else [])
            elif node.module and node.module.startswith("rmbench."):
                module = node.module.split(".")[1:]
            else:
                continue
            if not module or module[0] == here[0] or (stages is not None and not {module[0], here[0]} & set(stages)):
                continue
            out += [f"{path.relative_to(root.parent)}:{node.lineno}: {'.'.join(module)}.{a.name}"
                    for a in node.names if a.name.startswith("_") and not a.name.startswith("__")]
    return out


CHECKS = [long_modules, long_functions, wide_functions]


@pytest.mark.parametrize("check", CHECKS, ids=["module_at_most_600_lines", "function_at_most_80_lines",
                                               "at_most_8_parameters"])
def test_the_stages_keep_to_the_limit(check):
    """One concept per module, readable functions (the reason: the check's docstring)."""
    offenders = check(ROOT, PACKAGES)
    print("\n".join(offenders))
    assert not offenders, f"{check.__doc__}\n" + "\n".join(offenders)


def test_no_stage_imports_another_stages_private_names():
    """A private name stays inside its stage (the reason: :func:`private_imports`'s docstring)."""
    offenders = private_imports(ROOT)
    print("\n".join(offenders))
    assert not offenders, f"{private_imports.__doc__}\n" + "\n".join(offenders)


def test_the_checks_find_what_they_look_for(tmp_path):
    """The checks against a package built to break each limit once, and a private import."""
    gap = tmp_path / "rmbench" / "gap"
    gap.mkdir(parents=True)
    (tmp_path / "rmbench" / "io").mkdir()
    (tmp_path / "rmbench" / "io" / "fmt.py").write_text("from rmbench.io.other import _same_stage\n")
    body = "\n".join(f"    x{i} = {i}" for i in range(80))
    (gap / "big.py").write_text(
        f"def long(a):\n{body}\n\n\n"
        "def wide(self, a, b, c, d, e, f, g, *args, **kw):\n    pass\n\n\n"
        "def fine(self, a, b, c, d, e, f, g, h):\n    from rmbench.io.fmt import _private, public\n"
        "    from ..io import _relative\n" + "\n" * 520)
    root = tmp_path / "rmbench"
    assert long_modules(root, ("gap",)) == ["rmbench/gap/big.py: 610 lines"]
    assert long_functions(root, ("gap",)) == ["rmbench/gap/big.py:1: long 81 lines"]
    assert wide_functions(root, ("gap",)) == ["rmbench/gap/big.py:84: wide 9 parameters"]
    assert private_imports(root) == ["rmbench/gap/big.py:89: io.fmt._private",
                                     "rmbench/gap/big.py:90: io._relative"]
    assert private_imports(root, ("calibrate",)) == []


def _modules(root: Path, packages):
    for package in packages:
        yield from sorted((root / package).rglob("*.py"))


def _functions(root: Path, packages):
    """``(path:line, node)`` of every function and method, nested ones included."""
    for path in _modules(root, packages):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                yield f"{path.relative_to(root.parent)}:{node.lineno}", node


def _n_parameters(args: ast.arguments) -> int:
    names = [a.arg for a in args.posonlyargs + args.args + args.kwonlyargs if a.arg not in ("self", "cls")]
    return len(names) + (args.vararg is not None) + (args.kwarg is not None)
