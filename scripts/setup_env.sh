#!/usr/bin/env bash
# Install everything magsail_mj needs into ./.venv (idempotent):
#  - libosmesa6 (headless OpenGL for MuJoCo rendering) from Debian when it is missing;
#  - chromium (Debian's package) for the headless check of the built documentation site, when missing;
#  - a virtual environment with the package, its test extras and the documentation tools (Sphinx).
set -euo pipefail
cd "$(dirname "$0")/.."
if ! ldconfig -p 2>/dev/null | grep -q libOSMesa; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null && SUDO="sudo"
  echo "setup: installing libosmesa6 (headless rendering)" >&2
  ($SUDO apt-get update -qq && $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libosmesa6 >/dev/null) \
    || echo "setup: could not install libosmesa6; rendering will try EGL instead" >&2
fi
if ! command -v chromium >/dev/null && [ ! -x /usr/bin/chromium ]; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null && SUDO="sudo"
  echo "setup: installing chromium (headless check of the documentation site)" >&2
  ($SUDO apt-get update -qq && $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null) \
    || echo "setup: could not install chromium; the site check will test links only" >&2
fi
PY=${PYTHON:-python3}
[ -x .venv/bin/python ] || "$PY" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip 2>&1 | grep -v "^WARNING: Location" || true
.venv/bin/python -m pip install -q -e ".[dev,docs]" 2>&1 | grep -v -E "^WARNING: Location|^\s*$" || true
.venv/bin/python -c "import magsail_mj, mujoco; print('setup: magsail_mj ready, mujoco', mujoco.__version__)" >&2
