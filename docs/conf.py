"""Sphinx configuration of the magsail_mj documentation (MyST Markdown pages, autodoc API).

Build: ``bash scripts/build_docs.sh`` (``sphinx-build -W --keep-going -b html docs docs/_build/html``).
The config and CLI references are generated at build time by ``_ext/magsail_refs.py`` from the
pydantic schemas and the argparse parser, so they cannot drift from the code. The example gallery
(``gallery/``, generated, not in git) is built by sphinx-gallery from ``examples/gallery/plot_*.py``:
each script runs once per build (seconds: small lattices, short durations) and its figures are
captured; nothing here runs a long simulation.
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
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}  # .rst: the generated gallery pages
exclude_patterns = ["_build", "reference/_generated", "gallery/*.ipynb", "Thumbs.db", ".DS_Store"]

sphinx_gallery_conf = {
    "examples_dirs": str(DOCS.parent / "examples" / "gallery"),
    "gallery_dirs": "gallery",
    "filename_pattern": r"plot_",  # every plot_*.py runs at each build
    "ignore_pattern": r"__init__\.py",
    "within_subsection_order": "FileNameSortKey",
    "image_scrapers": ("matplotlib",),
    "download_all_examples": False,
    "remove_config_comments": True,
    "abort_on_example_error": True,  # a failing example fails the build
    "show_memory": False,
    "show_signature": False,
    "min_reported_time": 1,
    "reset_modules": ("matplotlib",),
    # the timing pages need jQuery/DataTables, which furo does not ship (a JavaScript error there)
    "write_computation_times": False,
}
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
