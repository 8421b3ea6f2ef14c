"""Compiled loads: C sources of the package built into shared libraries on first use
(:mod:`magsail_mj.compiled.build`). ``cubesat_loads.c`` is the CNUSAIL cubesat's loads, a MuJoCo
plugin (:mod:`magsail_mj.concepts.cnusail.compiled` builds its model data and runs it);
``reflector_loads.c`` is the reflector's pitch tracking (controller, coil torque, gravity
gradient), a MuJoCo plugin (:mod:`magsail_mj.concepts.reflector.compiled`);
``dipole_in_field.c`` is a body-fixed dipole in a uniform field, a MuJoCo plugin any rigid model
can carry (:mod:`magsail_mj.compiled.dipole`); ``lattice_rk4.c`` is the spring–dashpot lattice's
RK4 reference, called through ``ctypes`` (:mod:`magsail_mj.reference.compiled_rk4`). The two
loads plugins share ``plugin_common.h`` (C; its plugin registration serves every plugin here) and
:mod:`magsail_mj.compiled.plugin` (their Python side's common parts)."""

from __future__ import annotations

from magsail_mj.compiled.build import (
    SOURCE_DIR,
    CompiledLoadsError,
    build_library,
    cache_dir,
    compiler,
    library_path,
    load_plugin,
)

__all__ = ["SOURCE_DIR", "CompiledLoadsError", "build_library", "cache_dir", "compiler", "library_path", "load_plugin"]
