#!/usr/bin/env bash
# Build the documentation site (Sphinx, MyST Markdown) into docs/_build/html, warnings as errors.
# The config and CLI references are generated from the code at build time (docs/_ext/magsail_refs.py);
# nothing here runs a simulation. Needs the docs extra: pip install -e ".[dev,docs]" (scripts/setup_env.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-.venv/bin/python}
exec "$PY" -m sphinx -W --keep-going -q -b html docs docs/_build/html "$@"
