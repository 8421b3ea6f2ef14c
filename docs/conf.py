"""Sphinx configuration of the magsail_mj documentation (MyST Markdown pages, autodoc API).

Build: ``bash scripts/build_docs.sh`` (``sphinx-build -W --keep-going -b html docs docs/_build/html``).
The config and CLI references are generated at build time by ``_ext/magsail_refs.py`` from the
pydantic schemas and the argparse parser, so they cannot drift from the code. Nothing here runs a
simulation.
"""

from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))
sys.path.insert(0, str(DOCS.parent))

project = "magsail_mj"
author = "magsail_mj contributors"
copyright = "2026, magsail_mj contributors"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "magsail_refs",
]

source_suffix = {".md": "markdown"}
exclude_patterns = ["_build", "reference/_generated", "Thumbs.db", ".DS_Store"]
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_mock_imports: list[str] = []
napoleon_google_docstring = True
napoleon_numpy_docstring = False
# Docstrings cross-reference names the API pages do not document (NumPy, MuJoCo, private helpers):
# such references render as code, without a warning.
nitpicky = False
suppress_warnings: list[str] = []
# option names such as --set stay as typed (no en dashes)
smartquotes = False

html_theme = "furo"
html_title = "magsail_mj"
html_static_path = ["_static"]
