"""Values of a structure file: each parsed by the form its slot declares, problems named by key path.

Each value is parsed by the form its slot declares (:mod:`magsail_mj.structure.fileschema`); any
value that is an array may be a companion reference ``{ file = ..., array = ... }`` or
``{ file = ..., columns = [...] }`` (:mod:`magsail_mj.structure.companion`). Numbers become float64,
indices int64; a table's element count (nodes, members of a group, panels of a group) fixes the
length of its per-element values, a single number standing for all.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from magsail_mj.structure.companion import CompanionFiles
from magsail_mj.structure.fileschema import CHOICES, MAX_COUNT, slot, table_keys
from magsail_mj.structure.model import MEMBER_KINDS, StructureError

__all__ = ["ValueReader", "member_lengths_m"]

_INT64_MAX = np.iinfo(np.int64).max
_DOFS = "123456"
_ELEMENT = {"per_node": "node", "per_member": "member", "per_member_axes": "member", "per_panel": "panel"}


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def member_lengths_m(positions_m: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """(m,) distance between each member's end nodes [m]; NaN for a member naming a missing node."""
    valid = ((pairs >= 0) & (pairs < positions_m.shape[0])).all(axis=1)
    length = np.full(pairs.shape[0], np.nan)
    ends = pairs[valid]
    length[valid] = np.linalg.norm(positions_m[ends[:, 1]] - positions_m[ends[:, 0]], axis=1)
    return length


class ValueReader:
    """Reads the values of one structure tree: companion files below ``base_dir``, key paths below
    ``prefix``, problems collected in :attr:`problems`."""

    def __init__(self, base_dir, *, prefix: str):
        self.files = CompanionFiles(base_dir)
        self.prefix = prefix
        self.problems: list[str] = []

    # -- key paths and problems ---------------------------------------------------------------
    def at(self, path: str) -> str:
        """``path`` below the prefix (``structure.member_groups[0].EA_N``)."""
        if not self.prefix:
            return path
        return f"{self.prefix}.{path}" if path else self.prefix

    def fail(self, path: str, text: str) -> None:
        self.problems.append(f"{self.at(path)}: {text}")

    def guard(self, parse, *args) -> Any:
        """``parse(*args)``; ``None`` and its problems recorded when it raises StructureError."""
        try:
            return parse(*args)
        except StructureError as err:
            self.problems += err.problems
            return None

    def error(self, path: str, text: str) -> StructureError:
        return StructureError(f"{self.at(path)}: {text}")

    def unknown(self, table: dict, name: str, path: str) -> list[str]:
        """Record (and return) a problem for each key of ``table`` that the table ``name`` does not declare."""
        known = table_keys(name)
        found = [
            f"{self.at(_join(path, str(key)))}: unknown key (the keys here: {', '.join(known)})"
            for key in table
            if key not in known
        ]
        self.problems += found
        return found

    # -- values ---------------------------------------------------------------------------------
    def numbers(self, value: Any, path: str, *, integer: bool = False) -> np.ndarray:
        """``value`` (a number, nested arrays or a companion reference) as a float64 or int64 array
        of at most :data:`MAX_COUNT` rows."""
        array = self._numbers(value, path, integer)
        if array.ndim and array.shape[0] > MAX_COUNT:
            raise self.error(path, f"{array.shape[0]} rows, more than {MAX_COUNT}")
        return array

    def _numbers(self, value: Any, path: str, integer: bool) -> np.ndarray:
        if isinstance(value, dict):
            return self._from_file(self.companion(value, path), path, integer)
        if isinstance(value, list) and len(value) > MAX_COUNT:
            raise self.error(path, f"{len(value)} entries, more than {MAX_COUNT}")
        try:
            array = np.asarray(value)
        except (ValueError, OverflowError):
            raise self.error(
                path, f"rows of different lengths or values that are not numbers: {_show(value)}"
            ) from None
        if array.size == 0:
            return np.zeros(array.shape, dtype=np.int64 if integer else float)
        if array.dtype.kind not in "iuf" or (integer and array.dtype.kind == "f"):
            what = "integers" if integer else "numbers"
            raise self.error(path, f"must be {what}, got {_show(value)}")
        if array.dtype.kind == "u" and array.max() > _INT64_MAX:
            raise self.error(path, f"integers beyond 64 bits: {_show(value)}")
        return array.astype(np.int64 if integer else float)

    def _from_file(self, array: np.ndarray, path: str, integer: bool) -> np.ndarray:
        if array.dtype.kind not in "iuf":
            raise self.error(path, f"the companion array holds {array.dtype}, not numbers")
        if not integer:
            return array.astype(float)
        if array.dtype.kind == "f":
            whole = np.isfinite(array) & (array == np.round(array)) & (np.abs(array) <= 2.0**62)
            if not whole.all():
                raise self.error(
                    path, f"must be integers, got {float(array[~whole].ravel()[0])!r} in the companion array"
                )
        elif array.dtype.kind == "u" and array.size and array.max() > _INT64_MAX:
            raise self.error(path, "integers beyond 64 bits in the companion array")
        return array.astype(np.int64)

    def companion(self, ref: dict, path: str) -> np.ndarray:
        """The array a companion reference ``{ file, array | columns }`` names."""
        unknown = self.unknown(ref, "file", path)
        if unknown:
            del self.problems[-len(unknown) :]
            raise StructureError(unknown)
        if "file" not in ref:
            raise self.error(f"{path}.file", "required (a table here is a companion reference)")
        key, _ = self.files.resolve(ref["file"], self.at(f"{path}.file"))
        if key.lower().endswith(".npz"):
            if "columns" in ref:
                raise self.error(f"{path}.columns", f"{key!r} is an .npz file: name an array with 'array'")
            if "array" not in ref:
                raise self.error(f"{path}.array", f"required for the .npz file {key!r}")
            return self.files.npz_array(ref["file"], ref["array"], self.at(path))
        if "array" in ref:
            raise self.error(f"{path}.array", f"{key!r} is a .csv file: name its columns with 'columns'")
        table = self.files.csv_table(ref["file"], self.at(path))
        columns = ref.get("columns")
        if columns is None:
            return table.values[:, 0] if table.values.shape[1] == 1 else table.values
        if isinstance(columns, str):
            return table.columns([columns], self.at(f"{path}.columns"))[:, 0]
        if not isinstance(columns, list) or not columns or not all(isinstance(c, str) for c in columns):
            raise self.error(f"{path}.columns", f"a column name or an array of them, got {_show(columns)}")
        return table.columns(columns, self.at(f"{path}.columns"))

    def form(self, value: Any, form: str, path: str, count: int | None, node_sets: dict | None = None) -> Any:
        """``value`` parsed as ``form`` (see ``fileschema.FORMS``); ``count``: the group's element count."""
        if form in ("string", "kind", "dofs", "path"):
            if not isinstance(value, str):
                raise self.error(path, f"must be a string, got {_show(value)}")
            if form == "kind" and value not in MEMBER_KINDS:
                raise self.error(path, f"must be one of {', '.join(MEMBER_KINDS)}, got {value!r}")
            if form == "dofs" and (not value or set(value) - set(_DOFS) or len(set(value)) != len(value)):
                raise self.error(path, f"must be distinct digits 1-6 (1-3 translations, 4-6 rotations), got {value!r}")
            return value
        if form in CHOICES:
            if not isinstance(value, str) or value not in CHOICES[form]:
                raise self.error(path, f"must be one of {', '.join(CHOICES[form])}, got {_show(value)}")
            return value
        if form == "integer":
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise self.error(path, f"must be an integer >= 1, got {_show(value)}")
            return int(value)
        if form == "number":
            array = self.numbers(value, path)
            if array.ndim:
                raise self.error(path, f"must be one number, got {_show(value)}")
            return float(array)
        if form == "node_refs" and isinstance(value, str):
            if value not in (node_sets or {}):
                raise self.error(path, f"no node set named {value!r} (sets: {', '.join(node_sets or {}) or 'none'})")
            return np.array(node_sets[value])
        integer = form in ("pairs", "corners", "node_refs", "indices")
        return self._shaped(self.numbers(value, path, integer=integer), form, path, count)

    def _shaped(self, a: np.ndarray, form: str, path: str, count: int | None) -> np.ndarray:
        if form in ("positions", "pairs", "corners"):
            width = {"positions": 3, "pairs": 2, "corners": 4}[form]
            if a.size == 0:
                a = a.reshape(0, width)
            if a.ndim != 2 or a.shape[1] not in ((3, 4) if form == "corners" else (width,)):
                rows = "3 or 4" if form == "corners" else str(width)
                raise self.error(path, f"rows of {rows} numbers are needed, got shape {a.shape}")
            if form == "corners" and a.shape[1] == 3:
                a = np.concatenate([a, np.full((a.shape[0], 1), -1, dtype=np.int64)], axis=1)
            return a
        if form in ("node_refs", "indices"):
            if a.ndim != 1:
                raise self.error(path, f"a flat array of indices is needed, got shape {a.shape}")
            return a
        if form == "vector":
            if a.shape != (3,):
                raise self.error(path, f"3 numbers [x, y, z] are needed, got shape {a.shape}")
            return a
        if form == "inertia":
            return self._inertia(a, path)
        return self._per_element(a, form, path, count)

    def _per_element(self, a: np.ndarray, form: str, path: str, count: int) -> np.ndarray:
        if form in ("vector_per_member", "triple_per_panel"):
            if a.ndim == 0 and a == 0:
                a = np.zeros(3)
            if a.shape == (3,):
                return np.tile(a, (count, 1))
            if a.shape == (count, 3):
                return a
            raise self.error(path, f"3 numbers or {count} rows of 3 are needed, got shape {a.shape}")
        element = _ELEMENT[form]
        if form == "per_member_axes":
            if a.ndim == 0 or a.shape == (count,):
                return np.array(np.broadcast_to(a.reshape(-1, 1) if a.ndim else a, (count, 2)))
            if a.shape == (count, 2):
                return a
            raise self.error(
                path, f"one number, {count} numbers or {count} rows of 2 (one per {element}), got shape {a.shape}"
            )
        if a.ndim == 0:
            return np.full(count, float(a))
        if a.shape == (count,):
            return a
        raise self.error(path, f"one number or {count} numbers (one per {element}) are needed, got shape {a.shape}")

    def _inertia(self, a: np.ndarray, path: str) -> np.ndarray:
        flat = a.ravel()
        if a.ndim not in (1, 2) or flat.size not in (3, 6, 9) or (a.ndim == 2 and a.shape != (3, 3)):
            raise self.error(path, f"3, 6 or 9 numbers (or 3 rows of 3) are needed, got shape {a.shape}")
        if flat.size == 3:
            return np.diag(flat)
        if flat.size == 6:
            xx, yy, zz, xy, xz, yz = flat
            return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        return flat.reshape(3, 3).copy()

    def field(self, table: dict, name: str, key: str, path: str, count: int | None, node_sets: dict | None = None):
        """The parsed value of ``key`` of ``table`` (a table of kind ``name``), its default when
        absent (``None`` when it has none)."""
        declared = slot(name, key)
        if key in table:
            return self.form(table[key], declared.form, _join(path, key), count, node_sets)
        if declared.default is None:
            return None
        return self.form(declared.default, declared.form, _join(path, key), count, node_sets)

    def required(self, table: dict, name: str, key: str, path: str, count: int | None, node_sets: dict | None = None):
        if key not in table:
            raise self.error(_join(path, key), "required")
        return self.field(table, name, key, path, count, node_sets)

    def tables(self, tree: dict, key: str) -> list[dict]:
        """The array of tables ``key`` of the top level (``[]`` when absent)."""
        value = tree.get(key, [])
        if not isinstance(value, list) or not all(isinstance(item, dict) for item in value):
            self.fail(key, f"an array of tables ([[{key}]]) is needed, got {_show(value)}")
            return []
        return value
