#!/usr/bin/env bash
# Install, then run the default test suite (slow reproductions are deselected; run them with
# `.venv/bin/pytest -m slow`), then build the documentation with warnings as errors
# (scripts/build_docs.sh: about a minute, the example gallery runs), check the built site
# (scripts/check_docs_site.py: links, and every page in headless Chromium; ~15 s), and lint and
# format-check with ruff (pyproject.toml). pytest's exit code 5
# ("no tests collected") is a failure here; a failed docs build or lint fails the run too.
set -uo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh || exit 1
# on every core, at most 4 workers (pytest-xdist; work stealing evens out the long sweep and
# render tests); `-n 0` as an argument runs in this process
.venv/bin/python -m pytest -q -n auto --maxprocesses 4 --dist worksteal "$@"
rc=$?
if [ "$rc" -eq 5 ]; then echo "test.sh: no tests were collected" >&2; exit 1; fi
if ! bash scripts/build_docs.sh; then echo "test.sh: the documentation build failed" >&2; exit 1; fi
# the built site: internal links and anchors; every page in headless Chromium (images, videos, scripts)
if [ -x "${CHROMIUM:-/usr/bin/chromium}" ]; then site_check=(); else
  echo "test.sh: no chromium: the site's links are checked without the browser" >&2; site_check=(--links-only); fi
if ! .venv/bin/python scripts/check_docs_site.py docs/_build/html "${site_check[@]}"; then
  echo "test.sh: the documentation site check failed" >&2; exit 1; fi
if ! .venv/bin/ruff check .; then echo "test.sh: ruff found problems" >&2; exit 1; fi
if ! .venv/bin/ruff format --check .; then echo "test.sh: files not in ruff format (run ruff format .)" >&2; exit 1; fi
exit "$rc"
