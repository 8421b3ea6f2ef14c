"""Compiled loads: C sources of the package built into MuJoCo plugin libraries on first use
(:mod:`magsail_mj.compiled.build`). ``cubesat_loads.c`` is the CNUSAIL cubesat's loads
(:mod:`magsail_mj.concepts.cnusail.compiled` builds its model data and runs it)."""

from __future__ import annotations

from magsail_mj.compiled.build import SOURCE_DIR, CompiledLoadsError, cache_dir, compiler, library_path, load_plugin

__all__ = ["SOURCE_DIR", "CompiledLoadsError", "cache_dir", "compiler", "library_path", "load_plugin"]
