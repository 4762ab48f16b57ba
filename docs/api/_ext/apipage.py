"""Sphinx helpers of the API reference: one page per subpackage, each object documented once.

``.. apipage:: rmbench.gap`` documents the names in a package's ``__all__`` (automodule), except
those that another documented package exports and that live under it (``rmbench.gap`` re-exports
``rmbench.gap.frf.Diagnosis`` and ``rmbench.calibrate.TestDesign``): those are listed as links to
where they are documented. An object described twice is a duplicate-description warning, and every
short-name reference to it would be ambiguous.

Docstrings write magnitudes as ``|H|``, which reStructuredText reads as a substitution reference;
:func:`escape_bars` escapes such bars outside literals before the page is parsed.
"""

import ast
import importlib
import inspect
import re

from docutils import nodes
from docutils.statemachine import StringList
from sphinx import addnodes
from sphinx.pycode import ModuleAnalyzer
from sphinx.util.docutils import SphinxDirective
from sphinx.util.nodes import nested_parse_with_titles

# The packages with a page, deepest first: an object's home is the deepest of them that exports it
# and contains the module that defines it.
DOCUMENTED = sorted([
    "rmbench.robot", "rmbench.impact", "rmbench.modal", "rmbench.predict", "rmbench.rcsa",
    "rmbench.stability", "rmbench.path", "rmbench.tracker", "rmbench.calibrate", "rmbench.gap",
    "rmbench.gap.frf", "rmbench.gap.tracker", "rmbench.control", "rmbench.report", "rmbench.io",
    "rmbench.errors", "rmbench.parallel", "rmbench.threads", "rmbench.modeshape",
], key=lambda name: -name.count("."))

_LITERAL = re.compile(r"(``.*?``|`[^`]*`)")
# a lower-case word in a type field: a builtin (float), a word (optional) or a shape's dimension
# (n_postures), never one of rmbench's classes (CamelCase)
_NOT_A_CLASS = re.compile(r"[a-z_][a-z0-9_]*")


def defining_module(package: str, name: str) -> str:
    """The module that binds ``package.name`` first: a class's or function's ``__module__``, else
    the module its chain of ``from ... import name`` leads to (constants carry no ``__module__``)."""
    obj = getattr(importlib.import_module(package), name)
    if inspect.isclass(obj) or inspect.isfunction(obj):
        return obj.__module__
    module = package
    for _ in range(10):
        source = inspect.getsource(importlib.import_module(module))
        imported = [(node.module, alias.name) for node in ast.parse(source).body
                    if isinstance(node, ast.ImportFrom) for alias in node.names
                    if (alias.asname or alias.name) == name]
        if not imported:
            return module
        module, name = imported[0]
    return module


def attribute_doc(package: str, name: str) -> list[str]:
    """The ``#:`` comment or docstring of a constant where it is assigned (autodoc reads only the
    package's own ``__init__``, so a re-exported constant would lose it)."""
    module = defining_module(package, name)
    obj = getattr(importlib.import_module(package), name)
    for candidate in (name, *(n for n, v in vars(importlib.import_module(module)).items() if v is obj)):
        doc = ModuleAnalyzer.for_module(module).find_attr_docs().get(("", candidate))
        if doc:
            return list(doc)
    return []


def home(package: str, name: str) -> str:
    """The documented package whose page describes ``package.name``: its own unless re-exported."""
    obj = getattr(importlib.import_module(package), name)
    defined_in = defining_module(package, name)
    for candidate in DOCUMENTED:
        if not (defined_in == candidate or defined_in.startswith(candidate + ".")):
            continue
        module = importlib.import_module(candidate)
        if name in getattr(module, "__all__", ()) and getattr(module, name) is obj:
            return candidate
    return package


def escape_bars(app, what, name, obj, options, lines):
    """Escape ``|`` outside literal blocks, inline literals and roles (``|H|`` is a magnitude)."""
    indent_of_literal = None
    for i, line in enumerate(lines):
        stripped = line.lstrip()
        indent = len(line) - len(stripped)
        if indent_of_literal is not None:
            if not stripped or indent > indent_of_literal:
                continue
            indent_of_literal = None
        if stripped.startswith(">>>"):
            continue
        parts = _LITERAL.split(line)
        lines[i] = "".join(p if k % 2 else p.replace("|", r"\|") for k, p in enumerate(parts))
        if stripped.endswith("::") and not stripped.startswith(".. "):
            indent_of_literal = indent
        elif re.match(r"\.\. (code-block|code|sourcecode)::", stripped):
            indent_of_literal = indent


def unlink_words(app, doctree):
    """Keep a type field's lower-case words as text: Sphinx makes every word of a parameter's type
    a fuzzy class reference, and ``shape (n_postures, 3)`` would link ``n_postures`` to whichever
    public property of that name it finds (an ambiguity warning where several have it)."""
    for ref in list(doctree.findall(addnodes.pending_xref)):
        if (ref.get("refdomain") == "py" and ref.get("reftype") == "class"
                and _NOT_A_CLASS.fullmatch(ref.get("reftarget", ""))):
            ref.replace_self(ref.children)


class ApiPage(SphinxDirective):
    """``.. apipage:: package``: its public API, re-exports linked to their own page."""

    required_arguments = 1

    def run(self):
        package = self.arguments[0]
        module = importlib.import_module(package)
        exported = list(module.__all__)
        homes = {name: home(package, name) for name in exported}
        elsewhere = [name for name in exported if homes[name] != package]
        constants = [name for name in exported if homes[name] == package and is_constant(getattr(module, name))]
        text = [f".. automodule:: {package}"]
        if elsewhere or constants:
            text.append("   :exclude-members: " + ", ".join(elsewhere + constants))
        if constants:
            text += ["", ".. rubric:: Constants", ""]
            for name in constants:
                text += constant(package, name)
        if elsewhere:
            links = ", ".join(f":py:obj:`{name} <{homes[name]}.{name}>`" for name in elsewhere)
            text += ["", f"Also exported by ``{package}``, documented where they live: {links}."]
        node = nodes.section()
        node.document = self.state.document
        nested_parse_with_titles(self.state, StringList(text, source=self.get_source_info()[0]), node)
        return node.children


def is_constant(obj) -> bool:
    """Data, not a class, function or module: autodoc skips it unless documented in ``__init__``."""
    return not (inspect.isclass(obj) or inspect.isroutine(obj) or inspect.ismodule(obj))


def constant(package: str, name: str) -> list[str]:
    """``py:data`` lines of one constant: its value when short, its ``#:`` comment or docstring."""
    obj = getattr(importlib.import_module(package), name)
    value = repr(obj)
    lines = ["", f".. py:data:: {name}", f"   :module: {package}"]
    if len(value) <= 80 and "\n" not in value:
        lines.append(f"   :value: {value}")
    else:
        lines.append(f"   :type: {type(obj).__name__}")
    lines.append("")
    doc = attribute_doc(package, name)
    escape_bars(None, "data", name, obj, {}, doc)
    lines += ["   " + line for line in doc]
    return lines


def setup(app):
    app.connect("autodoc-process-docstring", escape_bars)
    app.connect("doctree-read", unlink_words)
    app.add_directive("apipage", ApiPage)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
