"""The structure of a command's source file: a structure file, a config that models one, a gmsh
mesh or a Nastran deck (``magsail modes``, ``magsail validate``, ``magsail build``).

* a structure file: ``*.toml`` with ``format = "magsail-structure"``
  (:func:`magsail_mj.structure.fileformat.read_structure`);
* a config whose concept registers the structure it models
  (:func:`magsail_mj.concepts.structure_of`), with the ``--set`` overrides;
* a gmsh mesh (``.msh``, :func:`magsail_mj.structure.mesh.read_mesh` without properties: only a
  mesh whose elements need none);
* a Nastran bulk-data deck (``.bdf``, ``.dat``, ``.nas``,
  :func:`magsail_mj.structure.nastran.read_nastran`).

Every problem is a :class:`~magsail_mj.cli.CliInputError` naming ``SOURCE`` (or ``--set``), or the
reader's own error naming the element.
"""

from __future__ import annotations

import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from magsail_mj.cli import CliInputError
from magsail_mj.concepts import structure_of
from magsail_mj.config import load_config
from magsail_mj.structure.fileformat import FORMAT, is_structure_file, read_structure
from magsail_mj.structure.mesh import read_mesh
from magsail_mj.structure.model import Structure, StructureError
from magsail_mj.structure.nastran import read_nastran
from magsail_mj.verbs.common import STRUCTURE_ONLY_SUFFIXES, input_file

__all__ = ["NASTRAN_SUFFIXES", "is_structure_source", "read_source", "structure_of_config"]

NASTRAN_SUFFIXES = (".bdf", ".dat", ".nas")
"""Suffixes read as Nastran decks."""


def _toml_tree(path: Path) -> dict[str, Any]:
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise CliInputError(f"SOURCE: {str(path)!r} is not a UTF-8 text (TOML) file") from None
    except tomllib.TOMLDecodeError as err:
        raise CliInputError(f"SOURCE: {str(path)!r} is not valid TOML: {err}") from None


def is_structure_source(path: Path) -> bool:
    """Whether ``path`` is a structure on its own (a mesh or a Nastran deck by its suffix, a
    structure file by its ``format`` key), not a config."""
    return path.suffix.lower() in STRUCTURE_ONLY_SUFFIXES or is_structure_file(path)


def structure_of_config(cfg: Any) -> Structure:
    """The structure of a validated config (the concepts that register one:
    :func:`magsail_mj.concepts.structure_of`); CliInputError naming ``SOURCE`` otherwise."""
    try:
        return structure_of(cfg)
    except ValueError as err:
        raise CliInputError(f"SOURCE: {err}") from None


def _no_overrides(overrides: Sequence[str], path: Path, kind: str) -> None:
    """Refuse ``--set`` for a source that is not a config (CliInputError naming ``--set``)."""
    if overrides:
        raise CliInputError(
            f"--set: {overrides[0]!r} overrides a config key, but SOURCE {str(path)!r} is a {kind}, not a config; "
            "edit the file, or give a config that uses it"
        )


def _toml_structure(path: Path, overrides: Sequence[str]) -> tuple[Structure, str]:
    tree = _toml_tree(path)
    if tree.get("format") == FORMAT:
        _no_overrides(overrides, path, "structure file")
        return read_structure(path).structure, "structure file"
    if "concept" in tree:
        return structure_of_config(load_config(path, list(overrides))), "config"
    raise CliInputError(
        f'SOURCE: {str(path)!r} is neither a structure file (format = "magsail-structure") nor a config (concept = ...)'
    )


def read_source(source: str, overrides: Sequence[str] = ()) -> tuple[Structure, str]:
    """The structure of ``source`` and its kind (module docstring: ``"structure file"``, ``"config"``,
    ``"mesh"`` or ``"Nastran deck"``), a config's with the ``--set``
    ``overrides`` (``KEY=VALUE``, :func:`magsail_mj.config.load_config`; refused for the other
    sources); CliInputError naming ``SOURCE`` or ``--set``, ConfigError for a config's problems."""
    path = input_file(source, "SOURCE")
    suffix = path.suffix.lower()
    if suffix == ".toml":
        return _toml_structure(path, overrides)
    if suffix in NASTRAN_SUFFIXES:
        _no_overrides(overrides, path, "Nastran deck")
        return read_nastran(path), "Nastran deck"
    if suffix == ".msh":
        _no_overrides(overrides, path, "mesh")
        try:
            return read_mesh(path), "mesh"
        except StructureError as err:
            raise CliInputError(
                f"SOURCE: {err} (a mesh file holds no member or panel properties: give them in a structure "
                f"config, [structure] file = {str(path)!r} with a [structure.mesh.groups.<group>] table for "
                "each physical group, and give that config; or read the mesh in Python with "
                "magsail_mj.structure.mesh.read_mesh(path, groups=..., members=...), save it with "
                "magsail_mj.structure.fileformat.write_structure and give that structure file)"
            ) from None
    raise CliInputError(
        f"SOURCE: {str(path)!r} has suffix {suffix!r}; expected .toml (a structure file or a config), .msh "
        f"(a mesh) or {', '.join(NASTRAN_SUFFIXES)} (a Nastran deck)"
    )
