"""magsail_mj: spacecraft geometry configs → MuJoCo models → attitude-control rollouts in orbit."""

import importlib as _importlib
from importlib import metadata as _metadata
from importlib import util as _util
from typing import Any

# Must run before anything imports mujoco: MuJoCo reads MUJOCO_GL when it is first imported.
from magsail_mj.render.backend import ensure_gl_backend as _ensure_gl_backend

_ensure_gl_backend()

__all__ = ["load"]
try:  # the installed distribution's version (pyproject.toml), as `magsail --version` prints it
    __version__ = _metadata.version("magsail_mj")
except _metadata.PackageNotFoundError:  # a source tree that was never installed
    __version__ = "0+unknown"


def __getattr__(name: str) -> Any:
    """``magsail_mj.load`` and the subpackages (``magsail_mj.envs``, ``magsail_mj.sweep``, ...) are
    imported on first use (PEP 562), so that importing the package for its command line stays
    light until the command has set up its signal handling and knows which verb runs."""
    if name == "load":
        from magsail_mj.api import load

        return load
    if not name.startswith("_") and _util.find_spec(f"{__name__}.{name}") is not None:
        return _importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module 'magsail_mj' has no attribute {name!r}")
