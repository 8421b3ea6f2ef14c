r"""Compiled loads: a C source of the package built into a MuJoCo plugin library on first use.

:func:`load_plugin` compiles ``magsail_mj/compiled/<name>.c`` with the C compiler into a shared
library and registers its plugins with MuJoCo (``mujoco.mj_loadPluginLibrary``);
:func:`build_library` builds one without registering it (C functions called through ``ctypes``). A
source may include the folder's headers (``#include "plugin_common.h"``: the pieces the loads
plugins share). The library lives in a cache folder keyed by the SHA-256 digest of the source, of
every header of the folder (``*.h``, by name and content), the MuJoCo version and the compiler (its
resolved path and its ``--version`` line), so an edited source or header, another MuJoCo or another
compiler builds anew and an unchanged one is reused across processes; a build costs 0.4 s once
(gcc 12, the cubesat loads, the compiler's version query included).

* compiler: ``$MAGSAIL_CC``, else ``$CC``, else ``cc``;
* cache folder: ``$MAGSAIL_COMPILED_CACHE``, else ``$XDG_CACHE_HOME/magsail_mj/compiled``, else
  ``~/.cache/magsail_mj/compiled``;
* flags: ``-O2 -fPIC -shared -std=c11 -ffp-contract=off`` (no fused multiply-adds, so the
  rounding follows the source's operations), the wheel's MuJoCo headers, linked against the
  wheel's ``libmujoco.so.<version>`` with its folder as the run path.

A missing compiler or a failed build raises :class:`CompiledLoadsError`, whose message names the
config key that asked for compiled loads (``sim.loads``) and the Python path that needs no
compiler; nothing switches paths silently. Registering is process-wide in MuJoCo (a plugin is
known by name); each model that uses a plugin has its own instances and each ``MjData`` its own
plugin state, so any number of simulations share a process.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import mujoco

from magsail_mj.config import ConfigError

__all__ = [
    "CompiledLoadsError",
    "SOURCE_DIR",
    "build_library",
    "compiler",
    "cache_dir",
    "library_path",
    "load_plugin",
]

SOURCE_DIR = Path(__file__).resolve().parent
"""Folder of the C sources."""

_MUJOCO_DIR = Path(mujoco.__file__).resolve().parent
_FLAGS = ("-O2", "-fPIC", "-shared", "-std=c11", "-ffp-contract=off")
_loaded: set[Path] = set()  # libraries registered with MuJoCo in this process (registration is process-wide)
_compilers: dict[str, tuple[str, str]] = {}  # compiler command → (path, version line), asked once per process


class CompiledLoadsError(ConfigError):
    """Compiled loads cannot be built or loaded (no compiler, a failed build): a config error
    (``magsail`` exits 2) whose one problem names ``sim.loads`` and the way out."""

    def __init__(self, message: str) -> None:
        super().__init__([message])


def compiler() -> str:
    """The C compiler command: ``$MAGSAIL_CC``, else ``$CC``, else ``cc``."""
    return os.environ.get("MAGSAIL_CC") or os.environ.get("CC") or "cc"


def cache_dir() -> Path:
    """The cache folder of built libraries (module docstring)."""
    explicit = os.environ.get("MAGSAIL_COMPILED_CACHE")
    if explicit:
        return Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "magsail_mj" / "compiled"


def _mujoco_library() -> Path:
    """The wheel's ``libmujoco.so.<version>``."""
    lib = _MUJOCO_DIR / f"libmujoco.so.{mujoco.__version__}"
    if not lib.is_file():
        found = sorted(_MUJOCO_DIR.glob("libmujoco.so*"))
        if not found:
            raise CompiledLoadsError(f"sim.loads: 'compiled' needs the MuJoCo library, none in {_MUJOCO_DIR}")
        lib = found[0]
    return lib


def _resolved_compiler() -> tuple[str, str]:
    """``(path, version line)`` of :func:`compiler`; :class:`CompiledLoadsError` when it is missing."""
    cc = compiler()
    if cc in _compilers:
        return _compilers[cc]
    path = shutil.which(cc)
    if path is None:
        raise CompiledLoadsError(
            f"sim.loads: 'compiled' needs a C compiler, and {cc!r} (from MAGSAIL_CC, else CC, else cc) "
            "was not found; install one (e.g. gcc) or set MAGSAIL_CC, or use sim.loads = 'python'"
        )
    try:
        out = subprocess.run([path, "--version"], capture_output=True, text=True, timeout=60, check=False)
    except OSError as err:
        raise CompiledLoadsError(
            f"sim.loads: 'compiled' cannot run the C compiler {path!r} ({err}); use sim.loads = 'python'"
        ) from None
    lines = (out.stdout or out.stderr).strip().splitlines()
    _compilers[cc] = (path, lines[0] if lines else "")
    return _compilers[cc]


def library_path(name: str) -> Path:
    """The cached library of the source ``<name>.c`` for this MuJoCo and compiler (not built); its
    key covers the folder's headers, which the source may include."""
    source = SOURCE_DIR / f"{name}.c"
    if not source.is_file():
        raise ValueError(f"name: no C source {source}")
    cc, version = _resolved_compiler()
    headers = [part for h in sorted(SOURCE_DIR.glob("*.h")) for part in (h.name, h.read_bytes())]
    key = hashlib.sha256()
    for part in (source.read_bytes(), *headers, mujoco.__version__, cc, version, " ".join(_FLAGS)):
        key.update(part if isinstance(part, bytes) else part.encode())
        key.update(b"\0")
    return cache_dir() / key.hexdigest()[:24] / f"lib{name}.so"


def _build(name: str, target: Path) -> None:
    """Compile ``<name>.c`` into ``target`` (written under a temporary name, then renamed, so a
    concurrent build never leaves half a library)."""
    cc, _ = _resolved_compiler()
    lib = _mujoco_library()
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=target.parent, suffix=".so.tmp")
    os.close(fd)
    cmd = [
        cc,
        *_FLAGS,
        f"-I{_MUJOCO_DIR / 'include'}",
        str(SOURCE_DIR / f"{name}.c"),
        "-o",
        tmp,
        str(lib),
        f"-Wl,-rpath,{lib.parent}",
        "-lm",
    ]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
        if out.returncode != 0:
            raise CompiledLoadsError(
                f"sim.loads: 'compiled' could not build {name}.c with {cc!r} (exit {out.returncode}):\n"
                f"{(out.stderr or out.stdout).strip()[-2000:]}\nuse sim.loads = 'python'"
            )
        os.replace(tmp, target)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def build_library(name: str) -> Path:
    """Build ``<name>.c`` unless its library is cached and return the library's path, registering
    nothing with MuJoCo (for C functions called through ``ctypes`` alone).

    Raises:
      CompiledLoadsError: no compiler, or the build failed (message names ``sim.loads``).
    """
    target = library_path(name)
    if not target.is_file():
        _build(name, target)
    return target


def load_plugin(name: str) -> Path:
    """Build ``<name>.c`` unless its library is cached, register its plugins with MuJoCo (once per
    process) and return the library's path.

    Raises:
      CompiledLoadsError: no compiler, or the build failed (message names ``sim.loads``).
    """
    target = library_path(name)
    if target in _loaded:
        return target
    build_library(name)
    mujoco.mj_loadPluginLibrary(str(target))
    _loaded.add(target)
    return target
