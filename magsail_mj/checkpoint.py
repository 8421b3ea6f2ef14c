"""Data-only checkpoints: the state of live Python objects as arrays and plain scalars.

A run is rebuilt from its config on resume, so every object (controller, loads, environment,
probes) exists again in its freshly built state. A checkpoint therefore stores only what the
run has *changed* since the build, as data:

* :class:`StateWalker` walks the attributes of the run's objects (objects of ``magsail_mj``
  classes, lists, tuples, dicts, NumPy arrays, Python and NumPy scalars, NumPy random
  generators). Everything else (MuJoCo model and data, configs, functions, paths, sparse
  matrices) is configuration the build recreates and is not walked. A leaf is named by its
  attribute path from the root (``controller.fit.R_prev``), and the same object reached twice
  is stored once.
* At build time :meth:`StateWalker.baseline` records a digest of every leaf; a checkpoint
  stores the leaves whose digest changed and, for the unchanged ones, only the digest, which
  the resume checks against the rebuilt object (a different build is refused, not mixed).
* :func:`restore_state` writes the stored values back into the rebuilt objects, in place
  where the shape allows (so objects sharing an array keep sharing it). It writes only into
  *state slots*: the paths the rebuilt run's own objects declare by walking them (their
  attributes as built, the items of their containers), and the children of containers and
  objects it creates itself from the file. It never follows a path of the file through an
  attribute: a path that is not a slot (``controller.__class__…``, an attribute the object
  does not have, a dunder name anywhere) is refused. A value that did not exist at build
  (``None`` then, an object now) is re-created only from a class that the rebuilt run holds
  or that is registered with :func:`restorable`, looked up in that table by its recorded
  ``module:qualname`` (nothing is imported from a name in the file), and filled slot by slot;
  no code from the file is run.
* Every checkpoint carries :func:`state_digest`, a digest of its state tree and arrays; a
  checkpoint whose contents do not match it (edited, truncated) is refused on reading.

:func:`write_checkpoint` / :func:`read_checkpoint` store a header (JSON) and arrays in one
NumPy ``.npz`` file read with ``allow_pickle=False``: a checkpoint can be opened from any
source without running its code.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import inspect
import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel

from magsail_mj.io import RunDirError, atomic_path, package_versions

__all__ = [
    "CheckpointError",
    "restorable",
    "state_digest",
    "StateWalker",
    "check_identity",
    "read_arrays",
    "read_checkpoint",
    "restore_state",
    "run_identity",
    "write_arrays",
    "write_checkpoint",
]

_FORMAT = "magsail_mj checkpoint 1"
_SCALARS = (bool, int, float, str, type(None))


class CheckpointError(RunDirError):
    """A checkpoint is missing, unreadable, or belongs to another config or build."""


#: classes a restore may create although the rebuilt run holds none of them at build (a value
#: ``None`` at build, an object later), by ``module:qualname``; see :func:`restorable`
_RESTORABLE: dict[str, type] = {}


def _class_name(cls: type) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


def restorable(cls: type) -> type:
    """Class decorator: objects of ``cls`` may be re-created by :func:`restore_state` in a slot
    that held ``None`` (or another value) at build. Only the package's own data classes belong
    here; a class the rebuilt run already holds needs no registration."""
    if not cls.__module__.startswith("magsail_mj."):
        raise TypeError(f"cls: only magsail_mj classes can be restorable, got {_class_name(cls)}")
    _RESTORABLE[_class_name(cls)] = cls
    return cls


def _is_walked_object(obj: Any) -> bool:
    """Objects of the package's own classes (configs excluded: the build recreates them)."""
    module = type(obj).__module__ or ""
    return (
        module.startswith("magsail_mj.")
        and not isinstance(obj, (type, BaseModel))
        and (hasattr(obj, "__dict__") or dataclasses.is_dataclass(obj))
    )


def _attributes(obj: Any) -> dict[str, Any]:
    if hasattr(obj, "__dict__"):
        return vars(obj)
    return {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)}


def _digest(value: Any) -> str:
    h = hashlib.blake2b(digest_size=16)
    if isinstance(value, np.ndarray):
        h.update(f"{value.dtype.str}{value.shape}".encode())
        h.update(np.ascontiguousarray(value).tobytes())
    else:
        h.update(json.dumps(value, sort_keys=True).encode())
    return h.hexdigest()


def _key_text(key: Any) -> str | None:
    """A dict key as JSON text (str, int, float, bool, None and tuples of them), else None."""

    def plain(k: Any) -> bool:
        return isinstance(k, _SCALARS) or (isinstance(k, tuple) and all(plain(x) for x in k))

    if not plain(key):
        return None
    # braces inside string keys are escaped so that a path's {…} segments nest unambiguously
    return json.dumps(key).replace("{", "\\u007b").replace("}", "\\u007d")


def _key_value(text: str) -> Any:
    def tup(v: Any) -> Any:
        return tuple(tup(x) for x in v) if isinstance(v, list) else v

    return tup(json.loads(text))


class StateWalker:
    """The walkable state below named roots (see module docs).

    Args:
      roots: name → object (e.g. ``{"controller": ctl, "loads": [...], "probes": [...]}``);
        functions among them are walked through their closure cells.
    """

    def __init__(self, roots: dict[str, Any]):
        self.roots = roots
        self._base: dict[str, str] = {}
        self._base_values: dict[str, Any] = {}

    # ------------------------------------------------------------------ walking
    def nodes(self) -> dict[str, dict[str, Any]]:
        """Path → node description; leaves carry ``value`` (array or JSON scalar)."""
        return self._nodes_and_slots()[0]

    def _nodes_and_slots(self) -> tuple[dict[str, dict[str, Any]], dict[str, Any]]:
        """The node descriptions and the *slots*: path → the live object at that path, for every
        path the walk reaches (the only places :func:`restore_state` may write into or through)."""
        out: dict[str, dict[str, Any]] = {}
        seen: dict[int, str] = {}
        slots: dict[str, Any] = {}
        for name, root in self.roots.items():
            self._walk(root, name, out, seen, slots)
        return out, slots

    def _walk(self, obj: Any, path: str, out: dict, seen: dict[int, str], slots: dict[str, Any]) -> None:
        slots[path] = obj
        if (
            isinstance(obj, (np.ndarray, list, tuple, dict))
            or _is_walked_object(obj)
            or isinstance(obj, np.random.Generator)
            or callable(obj)
        ):
            if id(obj) in seen:
                out[path] = {"kind": "alias", "of": seen[id(obj)]}
                return
            seen[id(obj)] = path
        if isinstance(obj, np.ndarray):
            if obj.dtype.hasobject:
                return
            out[path] = {"kind": "array", "value": obj}
        elif isinstance(obj, np.generic):
            out[path] = {"kind": "scalar", "value": obj.item()}
        elif isinstance(obj, _SCALARS):
            out[path] = {"kind": "scalar", "value": obj}
        elif isinstance(obj, np.random.Generator):
            out[path] = {"kind": "rng", "value": _jsonable_rng(obj.bit_generator.state)}
        elif isinstance(obj, (list, tuple)):
            out[path] = {"kind": "list" if isinstance(obj, list) else "tuple", "len": len(obj)}
            if type(obj) not in (list, tuple):
                out[path]["class"] = f"{type(obj).__module__}:{type(obj).__qualname__}"
            for i, item in enumerate(obj):
                self._walk(item, f"{path}[{i}]", out, seen, slots)
        elif isinstance(obj, dict):
            keys = [_key_text(k) for k in obj]
            if None in keys:
                return
            out[path] = {"kind": "dict", "keys": keys}
            for text, item in zip(keys, obj.values()):
                self._walk(item, f"{path}{{{text}}}", out, seen, slots)
        elif _is_walked_object(obj):
            cls = type(obj)
            out[path] = {"kind": "object", "class": f"{cls.__module__}:{cls.__qualname__}"}
            for attr, item in _attributes(obj).items():
                self._walk(item, f"{path}.{attr}", out, seen, slots)
        elif inspect.ismethod(obj):
            self._walk(obj.__self__, f"{path}<__self__>", out, seen, slots)
        elif callable(obj) and getattr(obj, "__closure__", None):
            names = obj.__code__.co_freevars
            for cell_name, cell in zip(names, obj.__closure__):
                try:
                    value = cell.cell_contents
                except ValueError:
                    continue
                self._walk(value, f"{path}<{cell_name}>", out, seen, slots)

    # ------------------------------------------------------------------ baseline and snapshot
    def baseline(self) -> None:
        """Record every leaf as built, its digest and a copy (call right after building): a
        snapshot then stores only what changed, and a restore can put back what changed later."""
        leaves = {p: n["value"] for p, n in self.nodes().items() if "value" in n}
        self._base = {p: _digest(v) for p, v in leaves.items()}
        self._base_values = {p: copy.deepcopy(v) for p, v in leaves.items()}

    def snapshot(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """``(tree, arrays)``: the node descriptions (JSON-able) and the changed arrays."""
        tree, arrays = {}, {}
        for path, node in self.nodes().items():
            node = dict(node)
            if "value" in node:
                value = node.pop("value")
                digest = _digest(value)
                if self._base.get(path) == digest:
                    node["same_as_built"] = digest
                elif node["kind"] == "array":
                    node["array"] = f"s{len(arrays):05d}"
                    arrays[node["array"]] = np.array(value, copy=True)
                else:
                    node["value"] = value
            tree[path] = node
        return tree, arrays


def _jsonable_rng(state: Any) -> Any:
    if isinstance(state, dict):
        return {k: _jsonable_rng(v) for k, v in state.items()}
    if isinstance(state, np.ndarray):
        return {"__array__": state.tolist(), "dtype": state.dtype.str}
    return state


def _rng_state(data: Any) -> Any:
    if isinstance(data, dict) and "__array__" in data:
        return np.array(data["__array__"], dtype=data["dtype"])
    if isinstance(data, dict):
        return {k: _rng_state(v) for k, v in data.items()}
    return data


# ---------------------------------------------------------------------- restoring
def _split(path: str) -> list[tuple[str, Any]]:
    """``a.b[2]{"k"}<c>`` → [("root","a"), ("attr","b"), ("item",2), ("key","k"), ("cell","c")]."""
    try:
        return _split_parts(path)
    except (ValueError, TypeError) as err:  # an unclosed bracket, a bad index or key text
        raise CheckpointError(f"checkpoint: malformed state path {path!r} ({err})") from None


def _split_parts(path: str) -> list[tuple[str, Any]]:
    parts: list[tuple[str, Any]] = []
    i, n = 0, len(path)
    j = i
    while j < n and path[j] not in ".[{<":
        j += 1
    parts.append(("root", path[:j]))
    i = j
    while i < n:
        c = path[i]
        if c == ".":
            j = i + 1
            while j < n and path[j] not in ".[{<":
                j += 1
            parts.append(("attr", path[i + 1 : j]))
        elif c == "[":
            j = path.index("]", i)
            parts.append(("item", int(path[i + 1 : j])))
            j += 1
        elif c == "{":
            j = path.index("}", i)  # key texts hold no braces (escaped by _key_text)
            parts.append(("key", _key_value(path[i + 1 : j])))
            j += 1
        elif c == "<":
            j = path.index(">", i)
            parts.append(("cell", path[i + 1 : j]))
            j += 1
        else:
            raise CheckpointError(f"checkpoint: malformed state path {path!r}")
        i = j
    return parts


def _get(parent: Any, part: tuple[str, Any]) -> Any:
    kind, key = part
    if kind == "attr":
        return getattr(parent, key)
    if kind in ("item", "key"):
        return parent[key]
    if key == "__self__":
        return parent.__self__
    names = parent.__code__.co_freevars
    return parent.__closure__[names.index(key)].cell_contents


def _set(parent: Any, part: tuple[str, Any], value: Any) -> None:
    kind, key = part
    if kind == "attr":
        object.__setattr__(parent, key, value)
    elif kind in ("item", "key"):
        parent[key] = value
    else:
        names = parent.__code__.co_freevars
        parent.__closure__[names.index(key)].cell_contents = value


def _known_classes(slots: dict[str, Any]) -> dict[str, type]:
    """The classes a restore may create: those of the rebuilt run's own objects and named tuples,
    and the ones registered with :func:`restorable`, by ``module:qualname``."""
    table = dict(_RESTORABLE)
    for obj in slots.values():
        cls = type(obj)
        if _is_walked_object(obj) or (isinstance(obj, tuple) and cls is not tuple and hasattr(cls, "_make")):
            table.setdefault(_class_name(cls), cls)
    return table


def _class_from(table: dict[str, type], class_name: Any, *, path: str) -> type:
    """The class recorded at ``path``, looked up in ``table`` (never imported)."""
    cls = table.get(class_name) if isinstance(class_name, str) else None
    if cls is None:
        raise CheckpointError(
            f"checkpoint: {path}: refuses to create an object of {class_name!r} (not a class of this run's state)"
        )
    return cls


def _fresh(node: dict[str, Any], arrays: dict[str, np.ndarray], table: dict[str, type], path: str) -> Any:
    kind = node["kind"]
    if kind == "object":
        cls = _class_from(table, node.get("class"), path=path)
        return cls.__new__(cls)
    if kind in ("list", "tuple"):  # a tuple is filled as a list, then frozen by the restore
        return [None] * _length(node, path)
    if kind == "dict":
        return {_key_value(k): None for k in _keys(node, path)}
    if kind == "array":
        return np.array(_array_of(node, arrays, path), copy=True)
    if kind == "rng":
        rng = np.random.default_rng()
        rng.bit_generator.state = _rng_state(node["value"])
        return rng
    return node.get("value")


def _length(node: dict[str, Any], path: str) -> int:
    n = node.get("len")
    if not isinstance(n, int) or isinstance(n, bool) or not 0 <= n <= 10**8:
        raise CheckpointError(f"checkpoint: {path}: invalid length {n!r}")
    return n


def _keys(node: dict[str, Any], path: str) -> list[str]:
    keys = node.get("keys")
    if not isinstance(keys, list) or not all(isinstance(k, str) for k in keys):
        raise CheckpointError(f"checkpoint: {path}: invalid keys {keys!r}")
    return keys


def _array_of(node: dict[str, Any], arrays: dict[str, np.ndarray], path: str) -> np.ndarray:
    name = node.get("array")
    if name not in arrays:
        raise CheckpointError(f"checkpoint: {path}: its array {name!r} is missing")
    return arrays[name]


def _check_part(path: str, part: tuple[str, Any]) -> None:
    """No path element may name a dunder attribute (``__class__``, ``__globals__`` …)."""
    kind, key = part
    if kind in ("root", "attr") and (not isinstance(key, str) or not key.isidentifier() or key.startswith("__")):
        raise CheckpointError(f"checkpoint: {path}: {key!r} is not a state slot name")


def restore_state(walker: StateWalker, tree: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
    """Write a :meth:`StateWalker.snapshot` back into the walker's roots.

    The roots may be freshly built (a resume) or live objects of the same build that ran on (a
    ``set_state``): leaves the snapshot records as unchanged since the build get their build
    values back where they changed since. Only state slots are written (see the module docs):
    every path of ``tree`` is one the rebuilt objects reach themselves, or a child of a container
    or object that this restore made from ``tree``.

    Raises:
      CheckpointError: a leaf recorded as unchanged differs from this walker's build (another build
        or config), a path of the checkpoint is not a state slot of the rebuilt run, or a class it
        names is not one of the run's.
    """
    if not isinstance(tree, dict):
        raise CheckpointError(f"checkpoint: the state tree is not a mapping ({type(tree).__name__})")
    if not walker._base:  # never baselined: the objects as they are now are the build
        walker.baseline()
    built, slots = walker._nodes_and_slots()
    table = _known_classes(slots)
    live_groups, saved_groups = _alias_groups(built), _alias_groups(tree)

    def sole_owner(path: str) -> bool:
        """True when writing in place into the live object at ``path`` changes nothing the
        snapshot holds apart (the live object is shared only by paths the snapshot also shares)."""
        return live_groups.get(path, {path}) <= saved_groups.get(path, {path})

    roots = dict(walker.roots)
    placed: dict[str, Any] = {}
    open_for: dict[str, str] = {}  # path placed from the file → the children it takes: "items", "attrs"
    tuples: list[str] = []
    for path, node in tree.items():  # parents come before children (walk order)
        if not isinstance(path, str) or not isinstance(node, dict):
            raise CheckpointError(f"checkpoint: malformed state node {path!r}")
        parts = _split(path)
        for part in parts:
            _check_part(path, part)
        if len(parts) == 1:
            if parts[0][1] not in walker.roots:
                raise CheckpointError(f"checkpoint: {path} is not a state slot of this run")
            parent, part = roots, ("key", parts[0][1])
        else:
            parent_path = path[: len(path) - len(_last_text(path))]
            part = parts[-1]
            parent = _slot_parent(path, parent_path, part, placed, slots, open_for)
        if "same_as_built" in node:
            if path not in walker._base or walker._base[path] != node["same_as_built"]:
                raise CheckpointError(f"checkpoint: {path} differs from the rebuilt run (another build or config)")
            have = built.get(path)
            if have is None or "value" not in have or _digest(have["value"]) != node["same_as_built"]:
                _put_back(parent, part, walker._base_values[path], in_place=sole_owner(path))  # changed since
            placed[path] = _try_get(parent, part)  # an alias of it must reach the value now there
            continue
        kind = node.get("kind")
        if kind == "alias":
            target = node.get("of")
            if target in placed:
                value = placed[target]
            elif target in slots:
                value = slots[target]
            else:
                raise CheckpointError(f"checkpoint: {path} is an alias of {target!r}, not a state slot of this run")
            _set(parent, part, value)
            continue
        current = _try_get(parent, part)
        if kind == "array":
            new = _array_of(node, arrays, path)
            if (
                isinstance(current, np.ndarray)
                and current.shape == new.shape
                and current.dtype == new.dtype
                and current.flags.writeable
                and sole_owner(path)
            ):
                np.copyto(current, new)
                placed[path] = current
                continue
            value = _fresh(node, arrays, table, path)
        elif kind == "scalar":
            value = node.get("value")
            if not isinstance(value, _SCALARS):
                raise CheckpointError(f"checkpoint: {path}: a scalar of type {type(value).__name__}")
        elif kind == "rng":
            if isinstance(current, np.random.Generator):
                current.bit_generator.state = _rng_state(node["value"])
                placed[path] = current
                continue
            value = _fresh(node, arrays, table, path)
        elif kind == "object":
            cls = node.get("class")
            if current is not None and _class_name(type(current)) == cls:
                placed[path] = current  # a live object: only its own slots are written
                continue
            value = _fresh(node, arrays, table, path)
            open_for[path] = "attrs"
        elif kind in ("list", "dict"):
            if isinstance(current, (list, dict)) and kind == type(current).__name__:
                _reshape_container(current, node, path)
                placed[path] = current
                open_for[path] = "items"
                continue
            value = _fresh(node, arrays, table, path)
            open_for[path] = "items"
        elif kind == "tuple":
            value = _fresh(node, arrays, table, path)
            if isinstance(current, tuple) and len(current) == len(value):
                value[:] = list(current)
            tuples.append(path)
            open_for[path] = "items"
        else:
            raise CheckpointError(f"checkpoint: unknown node kind {kind!r} at {path}")
        _set(parent, part, value)
        placed[path] = value
    for path in reversed(tuples):  # innermost first
        parts = _split(path)
        if len(parts) == 1:
            parent, part = roots, ("key", parts[0][1])
        else:
            parent_path = path[: len(path) - len(_last_text(path))]
            parent, part = placed.get(parent_path, slots.get(parent_path)), parts[-1]
        cls_name = tree[path].get("class")
        items = placed[path]
        if cls_name:
            cls = _class_from(table, cls_name, path=path)
            if not (issubclass(cls, tuple) and hasattr(cls, "_make")):
                raise CheckpointError(f"checkpoint: {path}: {cls_name!r} is not a named tuple")
            _set(parent, part, cls._make(items))
        else:
            _set(parent, part, tuple(items))
    walker.roots.update(roots)


def _data_attribute(cls: type, name: str) -> bool:
    """Whether ``name`` can be a data attribute of a ``cls`` object: a dataclass field, a
    ``__slots__`` entry, or a name the class does not define (never a method or a property)."""
    if dataclasses.is_dataclass(cls) and name in {f.name for f in dataclasses.fields(cls)}:
        return True
    if any(name in getattr(k, "__slots__", ()) for k in cls.__mro__):
        return True
    return not hasattr(cls, name)


def _slot_parent(
    path: str,
    parent_path: str,
    part: tuple[str, Any],
    placed: dict[str, Any],
    slots: dict[str, Any],
    open_for: dict[str, str],
) -> Any:
    """The live parent of ``path``, when ``path`` is a state slot: a path the rebuilt objects
    reach, or a new child of a container (an item, a key) or of an object (an attribute the class
    does not define) that this restore placed from the file."""
    if parent_path in placed:
        parent = placed[parent_path]
    elif parent_path in slots:
        parent = slots[parent_path]
    else:
        raise CheckpointError(f"checkpoint: {path} is not a state slot of this run (no parent {parent_path})")
    if path in slots:
        return parent
    kind, key = part
    grows = open_for.get(parent_path)
    if grows == "items" and kind in ("item", "key"):
        return parent
    if grows == "attrs" and kind == "attr" and _data_attribute(type(parent), key):
        return parent
    raise CheckpointError(f"checkpoint: {path} is not a state slot of this run")


def _alias_groups(nodes: dict[str, dict[str, Any]]) -> dict[str, set[str]]:
    """Path → the set of paths that reach the same object (an object and its aliases)."""
    members: dict[str, set[str]] = {}
    for path, node in nodes.items():
        members.setdefault(node["of"] if node.get("kind") == "alias" else path, set()).add(path)
    return {path: group for group in members.values() for path in group}


def _put_back(parent: Any, part: tuple[str, Any], value: Any, *, in_place: bool) -> None:
    """Write a leaf's value as built (in place for an array of the same shape when ``in_place``)."""
    current = _try_get(parent, part)
    if (
        in_place
        and isinstance(value, np.ndarray)
        and isinstance(current, np.ndarray)
        and current.shape == value.shape
        and current.dtype == value.dtype
        and current.flags.writeable
    ):
        np.copyto(current, value)
    elif isinstance(value, dict) and isinstance(current, np.random.Generator):  # an RNG's state
        current.bit_generator.state = _rng_state(value)
    else:
        _set(parent, part, copy.deepcopy(value))


def _last_text(path: str) -> str:
    """The text of the last path element (``.attr``, ``[i]``, ``{key}`` or ``<cell>``)."""
    if path.endswith("]"):
        return path[path.rindex("[") :]
    if path.endswith(">"):
        return path[path.rindex("<") :]
    if path.endswith("}"):
        return path[path.rindex("{") :]
    cut = max(path.rfind("."), 0)
    return path[cut:] if path[cut] == "." else path


def _try_get(parent: Any, part: tuple[str, Any]) -> Any:
    try:
        return _get(parent, part)
    except (AttributeError, KeyError, IndexError, TypeError, ValueError):
        return None


def _reshape_container(current: Any, node: dict[str, Any], path: str) -> None:
    """Make a rebuilt list/dict the length/key set of the checkpoint before its items are set."""
    if isinstance(current, list):
        n = _length(node, path)
        del current[n:]
        current.extend([None] * (n - len(current)))
    else:
        keys = [_key_value(k) for k in _keys(node, path)]
        for k in [k for k in current if k not in keys]:
            del current[k]
        for k in keys:
            current.setdefault(k, None)


# ---------------------------------------------------------------------- files
def write_arrays(path: Path, arrays: dict[str, np.ndarray], *, header: dict[str, Any] | None = None) -> None:
    """Write arrays (and an optional JSON header) to an ``.npz``, atomically, without pickles."""
    payload = {k: np.asarray(v) for k, v in arrays.items()}
    for k, v in payload.items():
        if v.dtype.hasobject:
            raise TypeError(f"arrays[{k!r}]: object arrays cannot be stored data-only")
    if header is not None:
        payload["__header__"] = np.array(json.dumps(header))
    with atomic_path(path, suffix=".npz") as tmp, open(tmp, "wb") as fh:
        np.savez(fh, **payload)


def read_arrays(path: Path) -> tuple[dict[str, Any] | None, dict[str, np.ndarray]]:
    """Read an ``.npz`` written by :func:`write_arrays` (``allow_pickle=False``).

    Raises:
      CheckpointError: the file is missing, truncated or not such a file.
    """
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {k: npz[k] for k in npz.files}
    except FileNotFoundError:
        raise CheckpointError(f"checkpoint: {path} does not exist") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as err:
        raise CheckpointError(f"checkpoint: {path} is unreadable or truncated ({type(err).__name__}: {err})") from None
    header = None
    if "__header__" in arrays:
        try:
            header = json.loads(str(arrays.pop("__header__")))
        except ValueError as err:
            raise CheckpointError(f"checkpoint: {path} has a corrupt header ({err})") from None
    return header, arrays


def state_digest(header: dict[str, Any], arrays: dict[str, np.ndarray]) -> str:
    """BLAKE2b (128 bit) of a checkpoint's contents: its header (JSON, keys sorted; the digest
    itself left out) and every array by name, dtype, shape and bytes."""
    h = hashlib.blake2b(digest_size=16)
    h.update(json.dumps({k: v for k, v in header.items() if k != "state_digest"}, sort_keys=True).encode())
    for name in sorted(arrays):
        h.update(f"\0{name}\0{_digest(np.asarray(arrays[name]))}".encode())
    return h.hexdigest()


def write_checkpoint(
    path: Path,
    header: dict[str, Any],
    *,
    tree: dict[str, Any],
    arrays: dict[str, np.ndarray],
    extra_arrays: dict[str, np.ndarray],
) -> None:
    """Write a checkpoint: ``header`` (JSON scalars), a :meth:`StateWalker.snapshot` (``tree``,
    ``arrays``) and ``extra_arrays`` (e.g. MuJoCo's state), with their :func:`state_digest`."""
    stored = {**arrays, **{f"x_{k}": v for k, v in extra_arrays.items()}}
    full = {"format": _FORMAT, **header, "state_tree": tree}
    full["state_digest"] = state_digest(full, stored)
    write_arrays(path, stored, header=full)


def read_checkpoint(path: Path) -> tuple[dict[str, Any], dict[str, np.ndarray], dict[str, np.ndarray]]:
    """``(header, state_arrays, extra_arrays)`` of a checkpoint written by :func:`write_checkpoint`."""
    header, arrays = read_arrays(path)
    if (
        not isinstance(header, dict)
        or header.get("format") != _FORMAT
        or not isinstance(header.get("state_tree"), dict)
    ):
        raise CheckpointError(f"checkpoint: {path} is not a {_FORMAT!r} file")
    if "state_digest" not in header:
        raise CheckpointError(f"checkpoint: {path} carries no state digest (a checkpoint of an older version)")
    if state_digest(header, arrays) != header["state_digest"]:
        raise CheckpointError(f"checkpoint: {path} differs from its state digest (edited or corrupt)")
    extra = {k[2:]: v for k, v in arrays.items() if k.startswith("x_")}
    state = {k: v for k, v in arrays.items() if not k.startswith("x_")}
    for node in header["state_tree"].values():
        if not isinstance(node, dict):
            raise CheckpointError(f"checkpoint: {path} has a malformed state tree")
        if node.get("kind") == "array" and "array" in node and node["array"] not in state:
            raise CheckpointError(f"checkpoint: {path} lacks array {node['array']!r} (truncated?)")
    return header, state, extra


def run_identity(numbers_hash: str | None, numbers_config: dict[str, Any] | None = None) -> dict[str, Any]:
    """What a checkpoint must match to be resumed: the hash of every config key that changes the
    numbers (see :func:`magsail_mj.config.numbers_hash`) and the versions of magsail_mj, MuJoCo
    and NumPy; ``numbers_config`` (the hashed tree) lets a refusal name the keys that differ."""
    versions = package_versions()
    out = {"numbers_hash": numbers_hash, "versions": {k: versions[k] for k in ("magsail_mj", "mujoco", "numpy")}}
    if numbers_config is not None:
        out["numbers_config"] = numbers_config
    return out


def _differing_keys(a: Any, b: Any, prefix: str = "") -> list[str]:
    """Key paths whose values differ between two JSON trees."""
    if isinstance(a, dict) and isinstance(b, dict):
        out: list[str] = []
        for key in sorted(set(a) | set(b)):
            out += _differing_keys(a.get(key), b.get(key), f"{prefix}{key}.")
        return out
    return [] if a == b else [f"{prefix.rstrip('.')} (checkpoint {a!r}, now {b!r})"]


def check_identity(header: dict[str, Any], identity: dict[str, Any], *, path: Path) -> None:
    """Raise :class:`CheckpointError` listing what differs between a checkpoint and this run."""
    problems = []
    if header.get("numbers_hash") != identity.get("numbers_hash"):
        keys = (
            _differing_keys(header.get("numbers_config"), identity.get("numbers_config"))
            if "numbers_config" in header and "numbers_config" in identity
            else []
        )
        problems.append(
            "the config differs in keys that change the numbers"
            + (f": {', '.join(keys[:10])}" if keys else "")
            + " (only sim.duration_s, sim.checkpoint_every_s, sim.progress and [render] may change "
            "on resume)"
        )
    have, want = header.get("versions") or {}, identity.get("versions") or {}
    for name in sorted(set(have) | set(want)):
        if have.get(name) != want.get(name):
            problems.append(f"{name} {have.get(name)} made the checkpoint, this is {want.get(name)}")
    if problems:
        raise CheckpointError(f"--resume: checkpoint {path} belongs to another run: " + "; ".join(problems))
