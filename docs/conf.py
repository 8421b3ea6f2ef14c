"""Sphinx configuration of the magsail_mj documentation (MyST Markdown pages, autodoc API).

Build: ``bash scripts/build_docs.sh`` (``sphinx-build -W --keep-going -b html docs docs/_build/html``).
The config and CLI references are generated at build time by ``_ext/magsail_refs.py`` from the
pydantic schemas and the argparse parser, so they cannot drift from the code. The example gallery
(``gallery/``, generated, not in git) is built by sphinx-gallery from ``examples/gallery/plot_*.py``:
each script runs once per build (seconds: small lattices, short durations) and its figures are
captured; nothing here runs a long simulation.
"""

from __future__ import annotations

import base64
import hashlib
import io
import os
import shutil
import sys
import tarfile
import urllib.request
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))
sys.path.insert(0, str(DOCS.parent))

# MathJax ships with the site, so formulas render offline (no CDN). The npm package mathjax
# 3.2.2 is fetched once from the npm registry (or read from $MAGSAIL_MATHJAX_TGZ, a local copy of
# the tarball), its sha512 checked against the registry's published integrity, and the parts the
# pages use are unpacked into docs/_build/vendor/mathjax (git-ignored, reused by later builds):
# the combined TeX/MathML -> CommonHTML component, its fonts, the TeX extensions it may autoload,
# the accessibility and menu parts. Sphinx copies them to _static/mathjax/.
MATHJAX_VERSION = "3.2.2"
MATHJAX_URL = f"https://registry.npmjs.org/mathjax/-/mathjax-{MATHJAX_VERSION}.tgz"
MATHJAX_SHA512 = "Bt+SSVU8eBG27zChVewOicYs7Xsdt40qm4+UpHyX7k0/O9NliPc+x77k1/FEsPsjKPZGJvtRZM1vO+geW0OhGw=="
MATHJAX_PARTS = ("tex-mml-chtml.js", "input/", "output/chtml/", "a11y/", "ui/", "adaptors/")
VENDOR = DOCS / "_build" / "vendor"


def vendor_mathjax(target: Path = VENDOR / "mathjax") -> Path:
    """The folder holding MathJax's ``tex-mml-chtml.js`` and its parts (see above), unpacked
    from the checked npm tarball when missing; a failed download or a wrong digest stops the
    build with the reason."""
    stamp = target / f".mathjax-{MATHJAX_VERSION}"
    if stamp.is_file() and (target / "tex-mml-chtml.js").is_file():
        return target
    local = os.environ.get("MAGSAIL_MATHJAX_TGZ")
    try:
        if local:
            data = Path(local).read_bytes()
        else:
            with urllib.request.urlopen(MATHJAX_URL, timeout=120) as response:
                data = response.read()
    except OSError as exc:
        raise RuntimeError(
            f"docs/conf.py: cannot fetch MathJax {MATHJAX_VERSION} ({local or MATHJAX_URL}: {exc}); the site "
            "ships MathJax so that formulas render offline: give a local copy of the npm tarball in "
            "$MAGSAIL_MATHJAX_TGZ"
        ) from exc
    digest = base64.b64encode(hashlib.sha512(data).digest()).decode()
    if digest != MATHJAX_SHA512:
        raise RuntimeError(f"docs/conf.py: MathJax tarball sha512 {digest} is not the published {MATHJAX_SHA512}")
    shutil.rmtree(target, ignore_errors=True)
    target.mkdir(parents=True)
    with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as tar:
        for member in tar.getmembers():
            name = member.name.removeprefix("package/es5/")
            if member.isfile() and name != member.name and name.startswith(MATHJAX_PARTS):
                out = target / name
                out.parent.mkdir(parents=True, exist_ok=True)
                out.write_bytes(tar.extractfile(member).read())
    stamp.write_text(MATHJAX_URL + "\n")
    return target


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
# the vendored MathJax folder is copied as _static/mathjax/ (its parent is a static path)
html_static_path = ["_static", str(vendor_mathjax().parent)]
mathjax_path = "mathjax/tex-mml-chtml.js"
