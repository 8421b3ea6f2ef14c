"""What every verb handler shares: the checks of the paths it is given, the config it loads, its
JSON output, and the exceptions that the dispatcher turns into exit statuses.

Loaded by the dispatcher of :mod:`magsail_mj.cli` before a verb's own module (its imports are the
ones every verb needs anyway: the config schema, the memory estimate, the output writer).
"""

from __future__ import annotations

import argparse
import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from magsail_mj.cli import CliInputError
from magsail_mj.config import ConfigError, load_config
from magsail_mj.io import RunDirError, to_jsonable
from magsail_mj.render.backend import GLBackendError
from magsail_mj.resources import MemoryLimitError, memory_limit, parse_memory_limit
from magsail_mj.structure.fileformat import is_structure_file

__all__ = [
    "GLBackendError",
    "REFUSED",
    "STRUCTURE_ONLY_SUFFIXES",
    "input_file",
    "load",
    "memory_limit",
    "non_empty",
    "output_dir",
    "output_file",
    "parse_memory_limit",
    "print_json",
]

STRUCTURE_ONLY_SUFFIXES = (".msh", ".bdf", ".dat", ".nas")
"""Suffixes of files that hold a structure and never a config: gmsh meshes and Nastran decks."""

REFUSED = (ConfigError, RunDirError, MemoryLimitError, CliInputError)
"""The exceptions that say an input was refused (exit status 2, their message names the key or option)."""


def non_empty(path: str | None, option: str) -> Path:
    """``path`` as a Path; CliInputError naming ``option`` when it is empty or holds a NUL."""
    if path is None or not str(path).strip():
        raise CliInputError(f"{option}: must be a path, got an empty string {path!r}")
    if "\x00" in str(path):
        raise CliInputError(f"{option}: must not contain a NUL character, got {path!r}")
    return Path(path)


def input_file(path: str, option: str) -> Path:
    """An existing, readable regular file."""
    p = non_empty(path, option)
    if not p.exists():
        raise CliInputError(f"{option}: no such file {str(p)!r}")
    if not p.is_file():
        raise CliInputError(f"{option}: {str(p)!r} is not a regular file")
    if not os.access(p, os.R_OK):
        raise CliInputError(f"{option}: {str(p)!r} is not readable (permission denied)")
    return p


def _writable_parent(p: Path, option: str) -> None:
    """The nearest existing ancestor of ``p`` is a writable folder (so ``p`` can be created)."""
    for parent in p.absolute().parents:
        if not parent.exists():
            continue
        if not parent.is_dir():
            raise CliInputError(f"{option}: {str(parent)!r} is a file, so {str(p)!r} cannot be created below it")
        if not os.access(parent, os.W_OK | os.X_OK):
            raise CliInputError(f"{option}: folder {str(parent)!r} is not writable (permission denied)")
        return


def output_dir(path: str | None, option: str) -> Path:
    """A folder that exists and is writable, or can be created."""
    p = non_empty(path, option)
    if p.exists():
        if not p.is_dir():
            raise CliInputError(f"{option}: {str(p)!r} exists and is not a folder")
        if not os.access(p, os.W_OK | os.X_OK):
            raise CliInputError(f"{option}: folder {str(p)!r} is not writable (permission denied)")
        return p
    _writable_parent(p, option)
    return p


def output_file(path: str | None, option: str) -> Path:
    """A file path that is not a folder, below a writable (or creatable) folder."""
    p = non_empty(path, option)
    if p.is_dir():
        raise CliInputError(f"{option}: {str(p)!r} is a folder; give a file path")
    _writable_parent(p, option)  # the file is replaced by a rename in its folder
    return p


def load(args: argparse.Namespace) -> Any:
    """The validated config of ``args.config`` with ``--set`` overrides (ConfigError or CliInputError)."""
    path = input_file(args.config, "config")
    if is_structure_file(path) or path.suffix.lower() in STRUCTURE_ONLY_SUFFIXES:
        raise CliInputError(
            f"config: {str(path)!r} is a structure, not a config: a run needs a task config naming it "
            f'(concept = "structure", [structure] file = {path.name!r}); magsail validate, build and modes '
            "take the structure itself"
        )
    try:
        return load_config(path, args.set)
    except UnicodeDecodeError:
        raise CliInputError(f"config: {str(path)!r} is not a UTF-8 text (TOML) file") from None


def print_json(obj: Any, *, what: str, indent: int | None = None) -> None:
    """Print ``obj`` as JSON; a non-finite number in it is an error naming ``what``."""
    bad = _non_finite(obj)
    if bad is not None:
        raise CliInputError(
            f"{what}: the result {bad[0]} is not finite ({bad[1]!r}); the inputs are outside "
            "the range where it can be computed"
        )
    print(json.dumps(to_jsonable(obj), indent=indent, allow_nan=False))


def _non_finite(obj: Any, key: str = "") -> tuple[str, float] | None:
    """``(key path, value)`` of the first non-finite float in a JSON-like tree, else None."""
    if isinstance(obj, Mapping):
        for k, v in obj.items():
            found = _non_finite(v, f"{key}.{k}" if key else str(k))
            if found:
                return found
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            found = _non_finite(v, f"{key}[{i}]")
            if found:
                return found
    elif isinstance(obj, float) and not math.isfinite(obj):
        return key, obj
    elif hasattr(obj, "dtype") and hasattr(obj, "tolist"):
        return _non_finite(obj.tolist(), key)
    return None
