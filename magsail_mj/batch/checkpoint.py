r"""Checkpoint files of a batch: the whole batch's state in one data-only file, resumable bit for bit.

A batch checkpoint is written in the single run's safe format (:func:`magsail_mj.checkpoint.write_checkpoint`:
one NumPy ``.npz`` of plain arrays with a JSON header, read with ``allow_pickle=False``, carrying
its :func:`~magsail_mj.checkpoint.state_digest`, written atomically). It holds
:meth:`~magsail_mj.batch.runner.BatchSimulation.get_state` — the step, every world's MuJoCo
integration state, which worlds run, their statuses, messages, end steps and record counts, the
stop rules' state and the plant's Python-side state — as its layout in the header (dicts, lists,
JSON scalars, and names of the arrays ``s<number>``), and, per world, its run identity
(:func:`~magsail_mj.checkpoint.run_identity`: the hash of the config keys that change the
numbers, the tree of those keys, the package versions),
the name of its run folder and record store, its record count, the count its store holds and
the digests of every record chunk there (:meth:`~magsail_mj.records.Recorder.digest_table`). The
records stay in each world's store, which a world's recorder writes a chunk at a time as it
fills; the file holds only each world's rows after them (``r<k>.<name>``: the part of its current
chunk, at most one chunk — 1 260 records, 0.8 MB of a CNUSAIL world), so writing it touches no
store and its size does not grow with the run.

On resume (:func:`restore_batch_checkpoint`) the batch is rebuilt from its configs, and the file
is accepted only when

* it reads back against its digest (an edited or truncated file is refused);
* it holds as many worlds as the batch, and world k's identity is world k's now (a refusal names
  the world, its folder and the config keys that differ, as a single run's ``--resume`` does);
* every value has the key path, type, shape and dtype of the rebuilt batch's own
  :meth:`~magsail_mj.batch.runner.BatchSimulation.get_state`, except inside a container that is
  empty there (filled while the batch runs, e.g. a law's values per world), which takes dicts,
  lists, arrays of numbers and JSON scalars (the file is data read into declared fields: nothing
  of it names a class, an attribute or a module);
* each world's store holds the records the file counts, equal to their digests, and the file's
  rows after them are every variable's, of equal length, plain numbers of the store's types.

Each world's store is then cut to its count, the file's rows are added after it, and the batch
continues from the file's step: the following steps, records and statuses are those of the
uninterrupted batch.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np
import zarr

from magsail_mj.checkpoint import CheckpointError, check_identity, read_checkpoint, write_checkpoint
from magsail_mj.records import RecordStoreError, verify_digests

__all__ = [
    "BATCH_CHECKPOINT_NAME",
    "write_batch_checkpoint",
    "read_batch_checkpoint",
    "restore_batch_checkpoint",
    "checkpoint_folders",
]

BATCH_CHECKPOINT_NAME = "checkpoint-batch.npz"
"""The file name of a batch's checkpoint (in its first world's run folder, by default)."""

_KIND = "magsail_mj batch checkpoint 1"
_STATUSES = ("running", "completed", "diverged", "structure_failed", "failed", "stopped", "interrupted")
_SCALARS = (bool, int, float, str, type(None))


# ---------------------------------------------------------------------- plain data ↔ layout and arrays
def _flatten(value: Any, path: str, arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    """The layout of ``value`` (nested dicts with string keys, lists and tuples of arrays and JSON
    scalars) as JSON: ``{"dict": {key: node}}``, ``{"list": [node, …]}``, ``{"array": name}`` (the
    array stored in ``arrays`` as ``s<number>``) or ``{"value": scalar}``."""
    if isinstance(value, dict):
        if not all(isinstance(key, str) for key in value):
            raise TypeError(f"batch state: {path or 'the root'} has a key that is not a string")
        return {"dict": {key: _flatten(item, f"{path}.{key}", arrays) for key, item in value.items()}}
    if isinstance(value, (list, tuple)):
        return {"list": [_flatten(item, f"{path}[{i}]", arrays) for i, item in enumerate(value)]}
    if isinstance(value, np.ndarray):
        if value.dtype.hasobject:
            raise TypeError(f"batch state: {path} is an object array")
        name = f"s{len(arrays):05d}"
        arrays[name] = np.array(value, copy=True)
        return {"array": name}
    if isinstance(value, np.generic):
        return {"value": value.item()}
    if isinstance(value, _SCALARS):
        return {"value": value}
    raise TypeError(f"batch state: {path} holds a {type(value).__name__}, not plain data")


def _json_type(value: Any) -> type:
    """The type a JSON round trip gives ``value`` (NumPy scalars as their Python type)."""
    return type(value.item()) if isinstance(value, np.generic) else type(value)


class _Layout:
    """Reads a layout of :func:`_flatten` back (the arrays it names are ``used``)."""

    def __init__(self, arrays: dict[str, np.ndarray], where: Path) -> None:
        self.arrays, self.where, self.used = arrays, where, set()

    def refuse(self, path: str, why: str) -> CheckpointError:
        return CheckpointError(f"checkpoint: {self.where}: batch state {path or 'root'}: {why}")

    def array(self, node: Any, path: str) -> np.ndarray:
        name = node.get("array") if isinstance(node, dict) else None
        if not isinstance(name, str) or name not in self.arrays:
            raise self.refuse(path, "names no array of the file")
        self.used.add(name)
        return np.array(self.arrays[name], copy=True)

    def read(self, template: Any, node: Any, path: str) -> Any:
        """The value at ``path`` in the form of ``template`` (the rebuilt batch's own state): the
        same keys, lengths, array shapes and dtypes and scalar types; a container that is empty in
        the template (filled while the batch runs) takes the file's plain data (:meth:`free`)."""
        if not isinstance(node, dict) or len(node) != 1:
            raise self.refuse(path, "malformed")
        if isinstance(template, (dict, list, tuple)) and not template:
            kind = "dict" if isinstance(template, dict) else "list"
            if kind not in node:
                raise self.refuse(path, f"is not a {kind}")
            return self.free(node, path)
        if isinstance(template, dict):
            items = node.get("dict")
            if not isinstance(items, dict) or set(items) != set(template):
                raise self.refuse(path, f"has the keys {sorted(items or {})}, this batch {sorted(template)}")
            return {key: self.read(sub, items[key], f"{path}.{key}") for key, sub in template.items()}
        if isinstance(template, (list, tuple)):
            items = node.get("list")
            if not isinstance(items, list) or len(items) != len(template):
                raise self.refuse(path, f"is not a list of {len(template)}")
            out = [self.read(sub, item, f"{path}[{i}]") for i, (sub, item) in enumerate(zip(template, items))]
            return out if isinstance(template, list) else tuple(out)
        if isinstance(template, np.ndarray):
            got = self.array(node, path)
            if got.shape != template.shape or got.dtype != template.dtype:
                raise self.refuse(
                    path, f"is {got.dtype}{list(got.shape)}, this batch holds {template.dtype}{list(template.shape)}"
                )
            return got
        if "value" not in node or type(node["value"]) is not _json_type(template):
            raise self.refuse(path, f"is {node.get('value', node)!r}, not of this batch's form")
        return node["value"]

    def free(self, node: Any, path: str) -> Any:
        """Plain data of the file where the build declares none: dicts with string keys, lists,
        arrays of numbers and JSON scalars."""
        if not isinstance(node, dict) or len(node) != 1:
            raise self.refuse(path, "malformed")
        if "dict" in node and isinstance(node["dict"], dict):
            return {str(key): self.free(sub, f"{path}.{key}") for key, sub in node["dict"].items()}
        if "list" in node and isinstance(node["list"], list):
            return [self.free(sub, f"{path}[{i}]") for i, sub in enumerate(node["list"])]
        if "array" in node:
            got = self.array(node, path)
            if got.dtype.kind not in "biuf":
                raise self.refuse(path, f"is an array of {got.dtype}, not of numbers")
            return got
        if "value" in node and isinstance(node["value"], _SCALARS):
            return node["value"]
        raise self.refuse(path, "malformed")


# ---------------------------------------------------------------------- writing
def _tail(rec: Any) -> tuple[int, dict[str, np.ndarray]]:
    """``(records in the store, the rows after them)`` of a world's recorder: the store holds its
    full chunks (written as they fill) and the rows of its last flush; the rest of its current
    chunk is in its buffers."""
    if rec.written < rec.base:  # never in store mode (a full chunk is written as it fills): flush then
        rec.flush()
    lo, hi = rec.written - rec.base, len(rec) - rec.base
    return rec.written, {name: np.array(buf[lo:hi], copy=True) for name, buf in rec.buffers.items() if hi > lo}


def write_batch_checkpoint(sim: Any, path: Path) -> None:
    """Write the batch ``sim`` (a :class:`~magsail_mj.batch.runner.BatchSimulation` whose worlds
    stream their records to stores) to the checkpoint ``path`` (module docstring). Nothing is
    written to the stores: the file counts the records each store holds (with their digests) and
    holds each world's rows after them (at most one chunk a world, ``r<k>.<name>``)."""
    state = sim.get_state()
    recorders = sim.recorders
    if any(rec.path is None for rec in recorders):
        raise ValueError("checkpoint_path: a batch checkpoints worlds whose records stream to stores (records_paths)")
    arrays: dict[str, np.ndarray] = {}
    layout = _flatten(state, "", arrays)
    arrays["world_steps"] = np.array(sim._world_steps, dtype=np.int64, copy=True)
    worlds = []
    for k, rec in enumerate(recorders):
        stored, tail = _tail(rec)
        arrays.update({f"r{k}.{name}": rows for name, rows in tail.items()})
        identity = sim.identities[k] if k < len(sim.identities) else {}
        worlds.append(
            {
                **identity,
                "folder": rec.path.parent.name,
                "records_store": rec.path.name,
                "n_records": len(rec),
                "n_stored": stored,
                "records_digests": rec.digest_table(),
            }
        )
    header = {
        "kind": _KIND,
        "step": int(state["step"]),
        "t_s": sim.time,
        "wall_s": float(sim._wall_s),
        "n_worlds": sim.n_worlds,
        "state": layout,
        "worlds": worlds,
    }
    write_checkpoint(Path(path), header, tree={}, arrays={}, extra_arrays=arrays)


# ---------------------------------------------------------------------- reading
def read_batch_checkpoint(
    path: Path, *, identities: Sequence[dict[str, Any]], folders: Sequence[str] | None = None
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """``(header, arrays)`` of the batch checkpoint ``path`` after its checks against the batch
    that would resume it: its digest, its kind, one world per identity and world k's identity
    equal to ``identities[k]``, and (given ``folders``) world k written into the folder named
    ``folders[k]``.

    Raises:
      CheckpointError: naming the file and, for a world that differs, the world, its folder and
        the config keys that differ.
    """
    path = Path(path)
    header, _, arrays = read_checkpoint(path)
    worlds = header.get("worlds")
    if header.get("kind") != _KIND or not isinstance(worlds, list) or not all(isinstance(w, dict) for w in worlds):
        raise CheckpointError(f"checkpoint: {path} is not a {_KIND!r} file")
    if len(worlds) != len(identities):
        raise CheckpointError(f"checkpoint: {path} holds {len(worlds)} worlds, this batch {len(identities)}")
    for k, (world, identity) in enumerate(zip(worlds, identities)):
        folder = world.get("folder")
        if folders is not None and folder != folders[k]:
            raise CheckpointError(
                f"checkpoint: {path}: world {k} ran into the folder {folder!r}, "
                f"this batch's world {k} runs into {folders[k]!r}"
            )
        try:
            check_identity(world, identity, path=path)
        except CheckpointError as err:
            raise CheckpointError(f"world {k} (folder {folder!r}): {err}") from None
    if not isinstance(header.get("state"), dict) or not isinstance(header.get("step"), int):
        raise CheckpointError(f"checkpoint: {path} has a malformed batch header")
    return header, arrays


def checkpoint_folders(path: Path) -> tuple[list[str], float] | None:
    """``(folder names of its worlds in order, simulated time [s])`` of the batch checkpoint
    ``path`` when it reads back against its digest, else None (none there, unreadable, edited, not
    a batch checkpoint). Its identities are checked by the batch that resumes it."""
    try:
        header, _, _ = read_checkpoint(Path(path))
        worlds = header["worlds"]
        folders = [w["folder"] for w in worlds]
        t_s = float(header["t_s"])
    except (CheckpointError, OSError, KeyError, TypeError, ValueError):
        return None
    if header.get("kind") != _KIND or not all(isinstance(f, str) for f in folders):
        return None
    return folders, t_s


def _read_tail(
    arrays: dict[str, np.ndarray], k: int, world: dict[str, Any], *, names: Sequence[str], where: Path
) -> dict[str, np.ndarray]:
    """World ``k``'s record rows after its store's (``r<k>.<name>``): every variable or none, of
    equal length, plain numbers, and ``world["n_stored"]`` a record count."""
    stored = world.get("n_stored")
    if not isinstance(stored, int) or isinstance(stored, bool) or stored < 0:
        raise CheckpointError(f"checkpoint: {where}: world {k} names no record count of its store")
    tail = {name: arrays[f"r{k}.{name}"] for name in names if f"r{k}.{name}" in arrays}
    if tail and (
        set(tail) != set(names)
        or len({len(v) for v in tail.values()}) != 1
        or any(v.ndim < 1 or v.dtype.kind not in "biuf" for v in tail.values())
    ):
        raise CheckpointError(f"checkpoint: {where}: world {k}'s records after its store's are malformed")
    return tail


def _check_tail_form(store: Path, tail: dict[str, np.ndarray]) -> None:
    """RecordStoreError unless every variable's rows in ``tail`` have the dtype and record shape of
    the store's array of that name."""
    group = zarr.open_group(str(store), mode="r", use_consolidated=False)
    for name, rows in tail.items():
        array = group[name]
        if array.dtype != rows.dtype or tuple(array.shape[1:]) != rows.shape[1:]:
            raise RecordStoreError(
                f"the checkpoint's records of {name!r} are {rows.dtype}{list(rows.shape[1:])}, "
                f"{store.name} holds {array.dtype}{list(array.shape[1:])}"
            )


def restore_batch_checkpoint(sim: Any, path: Path, records_paths: Sequence[str | Path]) -> None:
    """Continue the freshly built batch ``sim`` from the checkpoint ``path`` (module docstring):
    the checks of :func:`read_batch_checkpoint`, every value read into the form of the batch's own
    state, each world's store ``records_paths[k]`` read back against its digests, cut to its
    record count and continued; then :meth:`~magsail_mj.batch.runner.BatchSimulation.set_state`.

    Raises:
      CheckpointError: the file or a store is refused (nothing of the batch is changed before
        the file's checks pass).
    """
    path = Path(path)
    stores = [Path(p) for p in records_paths]
    header, arrays = read_batch_checkpoint(path, identities=sim.identities, folders=[p.parent.name for p in stores])
    template = sim.get_state()
    layout = _Layout(arrays, path)
    state = layout.read(template, header["state"], "")
    names = [sim.recorders[k].names for k in range(sim.n_worlds)]
    tails = [_read_tail(arrays, k, world, names=names[k], where=path) for k, world in enumerate(header["worlds"])]
    layout.used.update(f"r{k}.{name}" for k, tail in enumerate(tails) for name in tail)
    extra = sorted(set(arrays) - layout.used - {"world_steps"})
    if extra:
        raise CheckpointError(f"checkpoint: {path} holds arrays this batch has not: {', '.join(extra[:5])}")
    step = state["step"]
    if not 0 <= step <= sim.n_steps:
        raise CheckpointError(
            f"checkpoint: {path} is at t = {header.get('t_s')} s, beyond sim.duration_s = {sim.duration_s:g} s "
            "(a resume may extend a run, not shorten it)"
        )
    bad = [s for s in state["status"] if s not in _STATUSES]
    counts = state["n_records"]
    steps = arrays.get("world_steps")
    if bad or (counts < 0).any() or steps is None or steps.shape != (sim.n_worlds,) or steps.dtype != np.int64:
        raise CheckpointError(f"checkpoint: {path} has malformed world statuses, record counts or step counts")
    for k, (world, store, tail) in enumerate(zip(header["worlds"], stores, tails)):  # every store checked first
        n, digests = world["n_stored"], world.get("records_digests")
        rows = len(tail["t"]) if tail else 0
        if world.get("records_store") != store.name or n + rows != int(counts[k]) or not isinstance(digests, dict):
            raise CheckpointError(f"checkpoint: {path}: world {k} names no record count of {store.name}")
        try:
            if n:
                verify_digests(store, digests)
                if tail:
                    _check_tail_form(store, tail)
        except RecordStoreError as err:
            raise CheckpointError(f"checkpoint: {path}: world {k}: {err}") from None
    for k, (world, store, tail) in enumerate(zip(header["worlds"], stores, tails)):
        rec = sim.recorders[k]
        try:
            rec.open_store(store, world["n_stored"], digests=world["records_digests"])
        except RecordStoreError as err:
            raise CheckpointError(f"checkpoint: {path}: world {k}: {err}") from None
        if tail:
            rec.extend(tail)
    sim.set_state(state)
    sim._wall_s = float(header.get("wall_s", 0.0))
    sim._world_steps = np.array(steps, copy=True)
