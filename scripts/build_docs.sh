#!/usr/bin/env bash
# Build the documentation site (Sphinx, MyST Markdown) into docs/_build/html, warnings as errors.
# The config and CLI references are generated from the code at build time (docs/_ext/magsail_refs.py);
# the example gallery runs examples/gallery/plot_*.py (short runs, seconds each; sphinx-gallery keeps
# the results in docs/gallery and reruns only changed examples). No long simulation runs here.
# MathJax ships with the site (formulas render offline): docs/conf.py fetches the npm package
# mathjax 3.2.2 once (sha512-checked) into docs/_build/vendor/mathjax, or reads the tarball named
# by $MAGSAIL_MATHJAX_TGZ on a machine without network; later builds reuse it.
# Check the built site afterwards: .venv/bin/python scripts/check_docs_site.py (scripts/test.sh does).
# Needs the docs extra: pip install -e ".[dev,docs]" (scripts/setup_env.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-.venv/bin/python}
exec "$PY" -m sphinx -W --keep-going -q -b html docs docs/_build/html "$@"
