"""The structure file: a versioned TOML description of a :class:`~magsail_mj.structure.model.Structure`.

A structure file is TOML with ``format = "magsail-structure"`` and ``version = 1``; the same tables
may stand under ``[structure]`` in a task config (:func:`structure_from_mapping`). Every table and
key is declared once, in :data:`SLOTS` (:mod:`magsail_mj.structure.fileschema`: type, default,
meaning; the unit is read from the key's suffix by :mod:`magsail_mj.units_grammar`): the reader
refuses any key not declared there and parses each value by its declared form, and the reference
page ``docs/structure_file.md`` is written from the same table (``scripts/structure_reference.py``).
Large arrays may live in companion ``.npz``/``.csv`` files beside the structure file
(:mod:`magsail_mj.structure.companion`: data only, inside the folder, SHA-256 recorded).

Derived member properties (structure frame, SI units):

- axial rigidity ``EA = E_Pa · area_m2`` unless ``EA_N`` is given;
- bending ``EI = E_Pa · (I1_m4, I2_m4)`` and torsion ``GJ = G_Pa · J_m4`` with
  ``G = E / (2 (1 + nu))`` when ``nu`` is given instead of ``G_Pa``;
- linear density ``ρA = density_kg_m3 · area_m2`` unless ``linear_density_kg_m`` is given;
- rest length ``l0 = |x_b − x_a| / (1 + prestrain)`` unless ``rest_length_m`` is given.

Members are numbered across ``[[member_groups]]`` in file order (``members[i]`` in the checks'
messages), panels across ``[[panels]]`` likewise. Reading runs :func:`~magsail_mj.structure.checks.check_structure`;
every problem, of the schema or of the structure, is reported at once in one
:class:`~magsail_mj.structure.model.StructureError` naming its key path.
"""

from __future__ import annotations

import hashlib
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from magsail_mj.io import atomic_path
from magsail_mj.structure.checks import check_structure
from magsail_mj.structure.fileread import read_tree
from magsail_mj.structure.fileschema import FORMAT, FORMS, MAX_COUNT, MAX_FILE_BYTES, SLOTS, TABLES, VERSION, Slot
from magsail_mj.structure.filewrite import structure_tree
from magsail_mj.structure.model import Structure, StructureError
from magsail_mj.structure.tomlwrite import dumps

__all__ = [
    "FORMAT",
    "FORMS",
    "MAX_COUNT",
    "MAX_FILE_BYTES",
    "SLOTS",
    "TABLES",
    "VERSION",
    "Slot",
    "StructureSource",
    "is_structure_file",
    "read_structure",
    "structure_from_mapping",
    "write_structure",
]

#: The ways ``write_structure`` stores whole columns.
ARRAY_MODES = ("inline", "npz")


@dataclass(frozen=True)
class StructureSource:
    """A structure read from a file or a config table.

    Attributes:
      structure: the checked structure.
      sha256: SHA-256 hex digest of every file read, by its path relative to the structure's folder:
        the structure file itself (by its name; not for a config table) and each companion file (as
        its reference spells it).
    """

    structure: Structure
    sha256: dict[str, str]


def read_structure(path: str | Path) -> StructureSource:
    """The checked structure of the structure file at ``path``; :class:`StructureError` naming the
    file and every problem's key path (``boom.toml: member_groups[1].EA_N: ...``)."""
    path = Path(path)
    data = _read_file(path)
    try:
        tree = tomllib.loads(data.decode("utf-8"))
    except UnicodeDecodeError as err:
        raise StructureError(f"{path}: not UTF-8 text (byte {err.start})") from None
    except tomllib.TOMLDecodeError as err:
        raise StructureError(f"{path}: not valid TOML: {err}") from None
    except (RecursionError, ValueError) as err:
        raise StructureError(f"{path}: cannot be read as TOML ({type(err).__name__}: {err})") from None
    try:
        structure, digests = read_tree(tree, base_dir=path.parent, prefix="", in_file=True, default_name=path.stem)
    except StructureError as err:
        raise StructureError([f"{path}: {line}" for line in err.problems]) from None
    return StructureSource(structure, {path.name: hashlib.sha256(data).hexdigest(), **digests})


def is_structure_file(path: str | Path) -> bool:
    """Whether ``path`` is a structure file: TOML whose ``format`` is :data:`FORMAT` (a file that
    cannot be read or is not TOML is not one). Lets a folder of task configs hold the structure
    files they name (``*.toml`` too)."""
    try:
        tree = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError, RecursionError, ValueError):
        return False
    return tree.get("format") == FORMAT


def _read_file(path: Path) -> bytes:
    try:
        if not path.is_file():
            raise StructureError(f"{path}: {'is not a file' if path.exists() else 'does not exist'}")
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise StructureError(
                f"{path}: {size} bytes, more than {MAX_FILE_BYTES}; keep large arrays in companion files"
            )
        return path.read_bytes()
    except OSError as err:
        raise StructureError(f"{path}: cannot be read: {err.strerror or err}") from None


def structure_from_mapping(mapping: Any, *, base_dir: str | Path, key_prefix: str = "structure") -> StructureSource:
    """The checked structure of ``mapping`` (the tables of a task config's ``[structure]``; ``format``
    and ``version`` optional), companion files relative to ``base_dir``; :class:`StructureError`
    naming every problem's key path below ``key_prefix`` (``structure.members[3].EA_N: ...``)."""
    structure, digests = read_tree(
        mapping, base_dir=Path(base_dir), prefix=key_prefix, in_file=False, default_name="structure"
    )
    return StructureSource(structure, digests)


def write_structure(structure: Structure, path: str | Path, *, arrays: str = "inline") -> list[Path]:
    """Write ``structure`` (checked first) to the structure file ``path``; with ``arrays="npz"`` its
    whole columns go into the companion ``<stem>.npz`` beside it. Returns the paths written.
    Reading the file back gives the same arrays, bit for bit (node and member indices as int64)."""
    if arrays not in ARRAY_MODES:
        raise ValueError(f"arrays: must be one of {ARRAY_MODES}, got {arrays!r}")
    check_structure(structure)
    path = Path(path)
    npz_path = path.with_name(f"{path.stem}.npz")
    if npz_path == path:
        raise ValueError(f"path: {str(path)!r} would be its own companion .npz; name the structure file *.toml")
    tree, store = structure_tree(structure, arrays=arrays, npz_name=npz_path.name)
    written = []
    if store:
        with atomic_path(npz_path) as tmp:
            with open(tmp, "wb") as stream:
                np.savez_compressed(stream, **store)
        written.append(npz_path)
    with atomic_path(path) as tmp:
        tmp.write_text(dumps(tree), encoding="utf-8")
    return [path, *written]
