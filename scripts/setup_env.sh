#!/usr/bin/env bash
# Install everything magsail_mj needs into ./.venv (idempotent), as root or as a user with sudo:
#  - Python 3 with its venv module (Debian's python3 and python3-venv) when missing;
#  - libosmesa6 (headless OpenGL for MuJoCo rendering) when missing;
#  - chromium (Debian's package) for the headless check of the documentation site, when missing;
#  - a virtual environment with the package, its test extras and the documentation tools (Sphinx).
set -euo pipefail
cd "$(dirname "$0")/.."
SUDO=""
if [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null; then SUDO="sudo"; fi
APT_UPDATED=""
apt_install() {  # apt_install WHY PACKAGE...: from Debian's packages; returns non-zero when it cannot
  local why=$1; shift
  echo "setup: installing $* ($why)" >&2
  if [ -z "$APT_UPDATED" ]; then $SUDO apt-get update -qq || return 1; APT_UPDATED=1; fi
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null
}
PY=${PYTHON:-python3}
if ! command -v "$PY" >/dev/null || ! "$PY" -c "import venv, ensurepip" 2>/dev/null; then
  apt_install "Python and its venv module" python3 python3-venv \
    || { echo "setup: $PY with its venv module is needed (Debian: python3 python3-venv)" >&2; exit 1; }
fi
if ! { ldconfig -p || /sbin/ldconfig -p; } 2>/dev/null | grep libOSMesa >/dev/null; then  # /sbin: off a user's PATH; grep reads all (no SIGPIPE under pipefail)
  apt_install "headless rendering" libosmesa6 || echo "setup: could not install libosmesa6; rendering will try EGL instead" >&2
fi
if ! command -v chromium >/dev/null && [ ! -x /usr/bin/chromium ]; then
  apt_install "headless check of the documentation site" chromium \
    || echo "setup: could not install chromium; the site check will test links only" >&2
fi
[ -x .venv/bin/python ] || "$PY" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip 2>&1 | grep -v "^WARNING: Location" || true
.venv/bin/python -m pip install -q -e ".[dev,docs]" 2>&1 | grep -v -E "^WARNING: Location|^\s*$" || true
.venv/bin/python -c "import magsail_mj, mujoco; print('setup: magsail_mj ready, mujoco', mujoco.__version__)" >&2
