"""Sphinx configuration of rmbench's API reference (``make docs``).

Built from the docstrings (numpydoc style, read by napoleon) with no network access: no
intersphinx, no remote themes. ``make docs`` runs ``sphinx -W``, so any warning fails the build.
"""

import os
import sys

# The package is installed editable in .venv; the path makes a plain `sphinx-build` work from a
# checkout too.
sys.path.insert(0, os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", "src")))
# apipage: one page per subpackage, each object described once; `|H|` in docstrings escaped
sys.path.insert(0, os.path.abspath(os.path.join(os.path.dirname(__file__), "_ext")))

from rmbench import __version__  # noqa: E402

project = "rmbench"
author = "rmbench contributors"
copyright = "rmbench contributors"
version = release = __version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.viewcode",
    "apipage",
]

# numpydoc docstrings only; Parameters/Returns as field lists, Attributes as ivar fields so a
# dataclass's documented attributes are not described twice (once by napoleon, once by autodoc).
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_ivar = True
napoleon_use_param = True
napoleon_use_rtype = True

# Each page documents one subpackage's `__all__` (its public API, re-exports included), in the order
# the package lists it; classes with their public methods.
autodoc_default_options = {
    "members": True,
    "member-order": "bysource",
    "show-inheritance": True,
}
autodoc_typehints = "signature"
autodoc_class_signature = "mixed"
autodoc_preserve_defaults = True
autodoc_inherit_docstrings = True

nitpicky = False
exclude_patterns = ["_build"]
templates_path = []
source_suffix = {".rst": "restructuredtext"}
root_doc = "index"

html_theme = "alabaster"
html_title = f"rmbench {release} API reference"
html_static_path = []
html_theme_options = {"page_width": "1200px", "sidebar_width": "260px"}
