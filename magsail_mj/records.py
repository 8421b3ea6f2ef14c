"""Records of a run: a fixed-size chunk buffer per variable, streamed to a Zarr store.

A :class:`Recorder` receives one record at a time (:meth:`Recorder.append`, a value per probe
and the time ``t`` [s]) or a block of records (:meth:`Recorder.extend`). The first record fixes
each variable's shape and dtype and the chunk length ``C`` (records per chunk, chosen so that a
chunk of the widest variable holds about ``chunk_bytes``, between ``min_chunk`` and
``max_chunk``); each variable then has one preallocated buffer of ``C`` records. A full buffer

* goes to the Zarr store (:meth:`Recorder.create_store`, ``timeseries.zarr`` of a run folder)
  at its chunk-aligned place, so the memory of the records stays ``C`` records whatever the
  run's length;
* or, without a store (``magsail_mj.load(...).step(n)``, environments, tests), is kept in
  memory as a list of chunks.

The store is a Zarr (format 3) group readable by :func:`xarray.open_zarr`: every variable has
the dimension ``time`` first (record index; the coordinate ``t`` holds the record times in s),
then dimensions named per variable (:func:`dims_of`); its attributes ``units`` and
``long_name`` come from the SI suffix of its name (:func:`units_of`); the group's attributes
hold what the caller gives (config hash, package versions, status). A checkpoint stores only
the record count; a resume truncates the store to it (:meth:`Recorder.open_store`).

Integrity: every chunk of every variable is digested as it is written (:func:`rows_digest` of
its rows: dtype, shape and bytes; :meth:`Recorder.digest_table`, and the return value of
:func:`write_group`). Checkpoints and the run's manifest carry these digests, and
:func:`verify_digests` reads a store back against them, so a chunk that was deleted (Zarr would
read it as the fill value, zeros), truncated or edited is refused with the variable and the
records it holds, never read as data.

:class:`StoreRecords` is the read-only mapping name → array of a store that reads each
variable on first access (post-processing, plots and export read lazily).
"""

from __future__ import annotations

import hashlib
import shutil
import warnings
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import zarr

from magsail_mj.units_grammar import split_unit

__all__ = [
    "Recorder",
    "StoreRecords",
    "RecordStoreError",
    "dims_of",
    "units_of",
    "open_records",
    "write_group",
    "update_attrs",
    "store_length",
    "lazy_record",
    "row_blocks",
    "chunk_block_bytes",
    "rows_digest",
    "verify_digests",
    "STORE_NAME",
    "SERIES_GROUP",
]

#: the record store of a run folder
STORE_NAME = "timeseries.zarr"
#: the group of a run's store holding the derived series of post-processing
SERIES_GROUP = "series"
_FORMAT = "magsail_mj records 1"

#: the most bytes of a block of rows that :func:`row_blocks` reads at once
BLOCK_BYTES = 8 * 2**20

#: variables whose name carries no suffix
_KNOWN = {
    "t": ("s", "simulated time"),
    "qpos": (
        "m, rad, 1 (per joint: slide position, hinge angle, free-joint quaternion)",
        "MuJoCo generalised positions qpos",
    ),
    "qvel": ("m/s, rad/s (per degree of freedom)", "MuJoCo generalised velocities qvel"),
}
_KNOWN_DIMS = {"qpos": ("qpos_index",), "qvel": ("qvel_index",)}


class RecordStoreError(RuntimeError):
    """A record store is missing, unreadable or shorter than a checkpoint says."""


def units_of(name: str) -> tuple[str, str]:
    """``(units, long_name)`` of a variable from its SI suffix.

    The suffix is the unit suffix of the project's naming grammar
    (:func:`magsail_mj.units_grammar.split_unit`): ``omega_body_rad_s`` → ``("rad/s", "omega body")``,
    ``torque_gg_world_Nm`` → ``("N m", …)``, ``psi_ddot_ref_rad_s2`` → ``("rad/s²", …)``,
    ``angmom_Nms`` → ``("N m s", …)``, ``dipole_cmd_Am2`` → ``("A m²", …)``; the factors of a
    product are separated by spaces.
    A name without a suffix has units ``"1"`` (dimensionless, a count or a flag); ``t``,
    ``qpos`` and ``qvel`` are named explicitly.
    """
    if name in _KNOWN:
        return _KNOWN[name]
    quantity, unit = split_unit(name)
    if unit is None:
        return "1", name.replace("_", " ")
    return unit.label(product=" "), quantity.replace("_", " ")


def dims_of(name: str, shape: tuple[int, ...]) -> tuple[str, ...]:
    """Dimension names of one record of ``name`` with ``shape`` (without ``time``): ``qpos`` →
    ``qpos_index``, ``qvel`` → ``qvel_index``, a last axis of length 3 → ``axis`` (x, y, z),
    any other axis ``i`` → ``<name>_dim<i>``."""
    if name in _KNOWN_DIMS and len(shape) == 1:
        return _KNOWN_DIMS[name]
    return tuple("axis" if (i == len(shape) - 1 and n == 3) else f"{name}_dim{i}" for i, n in enumerate(shape))


def _attributes(name: str, *, timed: bool) -> dict[str, str]:
    units, long_name = units_of(name)
    attrs = {"units": units, "long_name": long_name}
    if timed and name != "t":
        attrs["coordinates"] = "t"
    return attrs


def _consolidate(path: Path) -> None:
    """Write the store's consolidated metadata (what :func:`xarray.open_zarr` reads first)."""
    with warnings.catch_warnings():  # zarr: consolidated metadata is not yet in the format-3 spec
        warnings.simplefilter("ignore")
        zarr.consolidate_metadata(str(path))


def _open_group(path: Path, mode: str) -> zarr.Group:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return zarr.open_group(str(path), mode=mode, use_consolidated=False)


def rows_digest(rows: np.ndarray) -> str:
    """BLAKE2b (128 bit) of a block of rows: its dtype, shape and bytes (text: shape and values), hex."""
    rows = np.ascontiguousarray(rows)
    h = hashlib.blake2b(digest_size=16)
    if rows.dtype.kind in "biufc":
        h.update(f"{rows.dtype.str}{rows.shape}".encode())
        h.update(rows.tobytes())
    else:  # text: by value (Zarr may read it back in another string dtype)
        h.update(f"text{rows.shape}".encode())
        h.update("\0".join(map(str, rows.ravel().tolist())).encode())
    return h.hexdigest()


def _digest_entry(array: Any, rows: int, n: int) -> dict[str, Any]:
    """The digest entry of the first ``n`` rows of ``array``, in blocks of ``rows`` rows (of a
    0-d array: ``rows`` 0 and one digest of the whole value)."""
    if not array.shape:
        return {"rows": 0, "n": 0, "chunks": [rows_digest(np.asarray(array[...]))]}
    return {
        "rows": int(rows),
        "n": int(n),
        "chunks": [rows_digest(np.asarray(array[a : min(a + rows, n)])) for a in range(0, n, rows)],
    }


def verify_digests(path: str | Path, table: Mapping[str, Any]) -> None:
    """Read the store at ``path`` back against a digest table (:meth:`Recorder.digest_table`,
    :func:`write_group`): ``name`` or ``group/name`` → ``{"rows", "n", "chunks"}``.

    Raises:
      RecordStoreError: a variable is missing or shorter than its digests cover, a chunk cannot be
        read (truncated, corrupt) or its rows differ from their digest (edited, or deleted: a missing
        chunk reads as zeros); the message names the variable and the records of the chunk.
    """
    path = Path(path)
    try:
        root = _open_group(path, "r")
    except (OSError, ValueError, KeyError, zarr.errors.BaseZarrError) as err:  # type: ignore[attr-defined]
        raise RecordStoreError(f"record store {path}: unreadable ({type(err).__name__}: {err})") from None
    if not isinstance(table, Mapping):
        raise RecordStoreError(f"record store {path}: its digest table is not a mapping")
    for key, entry in sorted(table.items()):
        where = f"{path.name}/{key}"
        try:
            rows, n, chunks = int(entry["rows"]), int(entry["n"]), list(entry["chunks"])
        except (KeyError, TypeError, ValueError):
            raise RecordStoreError(f"record store {path}: malformed digest entry for {key!r}") from None
        if rows < 0 or n < 0 or len(chunks) != (1 if rows == 0 else -(-n // rows)):
            raise RecordStoreError(f"record store {path}: malformed digest entry for {key!r}")
        try:
            array = root[key]
            length = array.shape[0] if rows else 0
        except (KeyError, TypeError, ValueError, IndexError, zarr.errors.BaseZarrError):  # type: ignore[attr-defined]
            raise RecordStoreError(f"{where} is missing from the record store (or changed shape)") from None
        if rows == 0:
            _check_block(where, "value", lambda: array[...], chunks[0])
            continue
        if length < n:
            raise RecordStoreError(f"{where} holds {length} records, its digests cover {n}")
        for i, expected in enumerate(chunks):
            a, b = i * rows, min((i + 1) * rows, n)
            _check_block(where, f"records {a}-{b - 1}", lambda a=a, b=b: array[a:b], expected)


def _check_block(where: str, what: str, read: Any, expected: str) -> None:
    """Read one block of a stored array and compare it with its digest."""
    try:
        block = np.asarray(read())
    except Exception as err:  # noqa: BLE001 - any read failure of a chunk is a corrupt store
        raise RecordStoreError(
            f"{where} {what} are unreadable (truncated or corrupt chunk: {type(err).__name__}: {err})"
        ) from None
    if rows_digest(block) != expected:
        raise RecordStoreError(
            f"{where} {what} differ from their digest (a chunk edited, or deleted: Zarr reads a missing chunk as zeros)"
        )


class Recorder:
    """Chunked records of a run (see module docs).

    Args:
      names: the variables, ``t`` first (the record time, s).
      chunk_bytes: target size of one chunk of the widest variable [bytes].
      min_chunk, max_chunk: bounds of the chunk length [records].
    """

    def __init__(self, names: list[str], *, chunk_bytes: int = 1 << 22, min_chunk: int = 16, max_chunk: int = 4096):
        if not names or names[0] != "t":
            raise ValueError(f"names: must start with 't', got {names[:3]!r}")
        if len(set(names)) != len(names):
            raise ValueError(f"names: repeated variable names in {names!r}")
        self.names = list(names)
        self.chunk_bytes, self.min_chunk, self.max_chunk = int(chunk_bytes), int(min_chunk), int(max_chunk)
        self.chunk = 0  # records per chunk (0: no record yet)
        self.n = 0  # records so far
        self.base = 0  # record index of the buffer's first row (a multiple of chunk)
        self.written = 0  # records in the store (store mode)
        self.checked = 0  # records checked for non-finite values
        self.buffers: dict[str, np.ndarray] = {}
        self.chunks: list[dict[str, np.ndarray]] = []  # full chunks (memory mode)
        self.first_bad: dict[str, tuple[int, float]] = {}
        self.digests: dict[str, list[str]] = {}  # store mode: per variable, of each chunk's rows in the store
        self.path: Path | None = None
        self.group: zarr.Group | None = None

    # ------------------------------------------------------------------ adding records
    def __len__(self) -> int:
        return self.n

    def append(self, values: dict[str, Any]) -> None:
        """Add one record: ``values`` maps every name (``t`` included) to its value. The record
        counts only once all its values are stored (an interrupt half-way leaves none of it)."""
        if not self.buffers:
            self._allocate({k: np.asarray(values[k]) for k in self.names})
        elif self.n - self.base == self.chunk:  # a chunk whose hand-over was interrupted
            self._chunk_full()
        i = self.n - self.base
        for name in self.names:
            value = values[name]
            buf = self.buffers[name]
            v = np.asarray(value)
            if v.dtype != buf.dtype and not np.can_cast(v.dtype, buf.dtype, "safe"):
                buf = self._promote(name, v.dtype)
            if v.shape != buf.shape[1:]:
                raise ValueError(f"probe {name!r}: a record of shape {v.shape}, earlier records {buf.shape[1:]}")
            buf[i] = v
        self.n += 1
        if self.n - self.base == self.chunk:
            self._chunk_full()

    def extend(self, columns: dict[str, np.ndarray]) -> None:
        """Add ``n`` records at once: ``columns`` maps every name to an array of ``n`` rows."""
        cols = {k: np.asarray(columns[k]) for k in self.names}
        total = len(cols["t"])
        if any(len(v) != total for v in cols.values()):
            raise ValueError(f"columns: lengths differ ({ {k: len(v) for k, v in cols.items()} })")
        if total and not self.buffers:
            self._allocate({k: v[0] for k, v in cols.items()})
        done = 0
        while done < total:
            if self.n - self.base == self.chunk:
                self._chunk_full()
            i = self.n - self.base
            take = min(self.chunk - i, total - done)
            for name, v in cols.items():
                buf = self.buffers[name]
                if v.dtype != buf.dtype and not np.can_cast(v.dtype, buf.dtype, "safe"):
                    buf = self._promote(name, v.dtype)
                if v.shape[1:] != buf.shape[1:]:
                    raise ValueError(f"columns[{name!r}]: records of shape {v.shape[1:]}, earlier {buf.shape[1:]}")
                buf[i : i + take] = v[done : done + take]
            self.n += take
            done += take
            if self.n - self.base == self.chunk:
                self._chunk_full()

    def _allocate(self, first: dict[str, np.ndarray]) -> None:
        """Buffers of ``chunk`` records shaped and typed like the first record."""
        widest = max(max(v.nbytes, 1) for v in first.values())
        self.chunk = int(np.clip(self.chunk_bytes // widest, self.min_chunk, self.max_chunk))
        self.buffers = {k: np.zeros((self.chunk, *v.shape), dtype=v.dtype) for k, v in first.items()}

    def _promote(self, name: str, dtype: np.dtype) -> np.ndarray:
        """Widen a variable's dtype (an int probe that later gives a float): buffer, memory chunks
        and store array are converted, so no value is ever cut."""
        new = np.result_type(self.buffers[name].dtype, dtype)
        self.buffers[name] = self.buffers[name].astype(new)
        for part in self.chunks:
            part[name] = part[name].astype(new)
        if self.group is not None and name in self.group:
            old = self.group[name][...]
            del self.group[name]
            arr = self._create_array(name, old.shape[1:], new, len(old))
            arr[...] = old.astype(new)
            self.digests[name] = _digest_entry(arr, self.chunk, len(old))["chunks"]
        return self.buffers[name]

    def _chunk_full(self) -> None:
        self._check_finite()
        if self.group is not None:
            self._write()
        else:
            self.chunks.append({k: b.copy() for k, b in self.buffers.items()})
        self.base += self.chunk

    def _check_finite(self) -> None:
        """Note the first non-finite value of each float variable among the rows not yet checked."""
        lo = self.checked - self.base
        hi = self.n - self.base
        if hi <= max(lo, 0):
            return
        lo = max(lo, 0)
        for name, buf in self.buffers.items():
            if name in self.first_bad or buf.dtype.kind not in "fc":
                continue
            rows = buf[lo:hi].reshape(hi - lo, -1)
            ok = np.isfinite(rows).all(axis=1)
            if not ok.all():
                j = lo + int(np.argmin(ok))
                self.first_bad[name] = (self.base + j, float(self.buffers["t"][j]))
        self.checked = self.n

    # ------------------------------------------------------------------ reading and cutting
    def arrays(self) -> Mapping[str, np.ndarray]:
        """The records so far: a dict of arrays (memory mode) or a :class:`StoreRecords` of the
        store (store mode, after a :meth:`flush`)."""
        if self.group is not None:
            self.flush()
            return StoreRecords(self.path)
        if not self.buffers:
            return {name: np.zeros(0) for name in self.names}
        tail = self.n - self.base
        return {
            name: np.concatenate([*(c[name] for c in self.chunks), self.buffers[name][:tail]]) for name in self.names
        }

    def column(self, name: str) -> np.ndarray:
        """One variable's records so far (``t`` for a search by time)."""
        if not self.buffers:
            return np.zeros(0)
        tail = self.buffers[name][: self.n - self.base]
        if self.group is not None:
            if not self.base:  # nothing handed to the store yet (its arrays may not exist)
                return tail.copy()
            return np.concatenate([self.group[name][: self.base], tail])
        return np.concatenate([*(c[name] for c in self.chunks), tail])

    def non_finite(self) -> tuple[str, float] | None:
        """``(name, t)`` of the first variable (in ``names`` order) holding a value that is not
        finite, with the time of its first such record; ``None`` when all are finite."""
        self._check_finite()
        for name in self.names:
            if name in self.first_bad:
                return name, self.first_bad[name][1]
        return None

    def truncate(self, n: int) -> None:
        """Keep the first ``n`` records (the store too); ``n`` beyond the count is an error."""
        n = int(n)
        if not 0 <= n <= self.n:
            raise ValueError(f"n: must be in 0 … {self.n} records, got {n}")
        self.first_bad = {k: v for k, v in self.first_bad.items() if v[0] < n}
        self.checked = min(self.checked, n)
        if n >= self.base:
            self.n = n
            self.written = min(self.written, n)
            if self.group is not None:
                self._resize(min(self.written, n))
                self._trim_digests()
            return
        base = n // self.chunk * self.chunk
        if self.group is not None:
            self._resize(n)
            rows = {k: self.group[k][base:n] for k in self.names}
            self.written = n
        else:
            keep = base // self.chunk
            rows = {k: self.chunks[keep][k][: n - base] for k in self.names} if keep < len(self.chunks) else {}
            del self.chunks[keep:]
        for k, buf in self.buffers.items():
            buf[: n - base] = rows[k] if rows else buf[: n - base]
        self.base, self.n = base, n
        if self.group is not None:
            self._trim_digests()

    def _trim_digests(self) -> None:
        """Digests of the chunks the store holds after a cut (the last partial one read back)."""
        keep = -(-self.written // self.chunk) if self.chunk else 0
        tail = self.written % self.chunk if self.chunk else 0
        for name in self.names:
            digests = self.digests.get(name, [])[:keep]
            if tail and name in self.group:
                start = self.written - tail
                digests[keep - 1 :] = [rows_digest(np.asarray(self.group[name][start : self.written]))]
            self.digests[name] = digests

    def digest_table(self) -> dict[str, Any]:
        """The digests of the records in the store (call after :meth:`flush`): name →
        ``{"rows": records per chunk, "n": records, "chunks": [digest of each chunk's rows]}``."""
        if self.group is None:
            return {}
        rows = self.chunk or self.min_chunk
        return {
            name: {"rows": rows, "n": self.written, "chunks": list(self.digests.get(name, []))} for name in self.names
        }

    def _note_digest(self, name: str, index: int, rows: np.ndarray) -> None:
        digests = self.digests.setdefault(name, [])
        del digests[index:]
        digests.extend([""] * (index - len(digests)))
        digests.append(rows_digest(rows))

    # ------------------------------------------------------------------ the store
    def create_store(self, path: str | Path, *, attrs: dict[str, Any] | None = None) -> None:
        """Stream the records to a new Zarr store at ``path`` (an earlier one there is removed);
        records made before are written to it."""
        path = Path(path)
        if path.exists():
            shutil.rmtree(path) if path.is_dir() else path.unlink()
        self.group = _open_group(path, "w")
        self.group.attrs.update({"format": _FORMAT, **(attrs or {})})
        self.path = path
        self.written = 0
        self.digests = {}
        if self.buffers:
            for name, buf in self.buffers.items():
                arr = self._create_array(name, buf.shape[1:], buf.dtype, self.base)
                for j, part in enumerate(self.chunks):
                    arr[j * self.chunk : (j + 1) * self.chunk] = part[name]
                    self._note_digest(name, j, part[name])
            self.chunks = []
            self.written = self.base
        _consolidate(path)

    def open_store(self, path: str | Path, n_records: int, *, digests: Mapping[str, Any] | None = None) -> None:
        """Continue the store at ``path`` from record ``n_records`` (a checkpoint's count): the
        store is cut to it and its last partial chunk is read back into the buffers. With
        ``digests`` (the checkpoint's :meth:`digest_table`) the store is first read back against
        them (:func:`verify_digests`; a :class:`RecordStoreError` names what differs)."""
        path = Path(path)
        if digests is not None and n_records:
            if set(digests) != set(self.names) or any(int(d.get("n", -1)) != n_records for d in digests.values()):
                raise RecordStoreError(
                    f"record store {path}: the digests do not describe {n_records} records of this run"
                )
            verify_digests(path, digests)
        try:
            group = _open_group(path, "r+")
            lengths = {k: group[k].shape[0] for k in self.names if k in group}
        except (OSError, ValueError, KeyError, zarr.errors.BaseZarrError) as err:  # type: ignore[attr-defined]
            raise RecordStoreError(f"record store {path}: unreadable ({type(err).__name__}: {err})") from None
        short = {k: n for k, n in lengths.items() if n < n_records}
        missing = [k for k in self.names if k not in lengths]
        if n_records and (missing or short):
            raise RecordStoreError(
                f"record store {path}: holds fewer records than the checkpoint's {n_records} "
                f"(missing {missing}, short {short})"
            )
        self.group, self.path = group, path
        self.buffers, self.chunks, self.first_bad, self.digests = {}, [], {}, {}
        self.n = self.base = self.written = self.checked = 0
        if not n_records:
            for k in list(self.group.array_keys()):
                del self.group[k]
            return
        self.chunk = int(group["t"].chunks[0])
        self.buffers = {k: np.zeros((self.chunk, *group[k].shape[1:]), dtype=group[k].dtype) for k in self.names}
        self._resize(n_records)
        self.base = n_records // self.chunk * self.chunk
        for k in self.names:
            self.buffers[k][: n_records - self.base] = group[k][self.base : n_records]
        self.n = self.written = n_records
        self.checked = 0
        if digests is not None:
            self.digests = {k: list(digests[k]["chunks"]) for k in self.names}
        else:
            self.digests = {k: _digest_entry(group[k], self.chunk, n_records)["chunks"] for k in self.names}
        self._scan_store()

    def _scan_store(self) -> None:
        """Find non-finite values already in the store (chunk by chunk)."""
        for name in self.names:
            arr = self.group[name]
            if arr.dtype.kind not in "fc":
                continue
            for a in range(0, self.written, self.chunk):
                rows = arr[a : min(a + self.chunk, self.written)]
                ok = np.isfinite(rows.reshape(len(rows), -1)).all(axis=1)
                if not ok.all():
                    j = a + int(np.argmin(ok))
                    self.first_bad[name] = (j, float(self.group["t"][j]))
                    break
        self.checked = self.n

    def _create_array(self, name: str, shape: tuple[int, ...], dtype: Any, length: int) -> Any:
        return self.group.create_array(
            name,
            shape=(length, *shape),
            chunks=(self.chunk, *(max(1, s) for s in shape)),
            dtype=dtype,
            dimension_names=("time", *dims_of(name, shape)),
            attributes=_attributes(name, timed=True),
            fill_value=np.zeros((), dtype=dtype).item(),
        )

    def _resize(self, n: int) -> None:
        for name in self.names:
            if name in self.group and self.group[name].shape[0] != n:
                arr = self.group[name]
                arr.resize((n, *arr.shape[1:]))

    def _write(self) -> None:
        """Write the buffer's rows ``written … n`` (the whole chunk when it is full)."""
        if not self.buffers:
            return
        lo = max(self.written, self.base)
        for name, buf in self.buffers.items():
            arr = self.group[name] if name in self.group else self._create_array(name, buf.shape[1:], buf.dtype, 0)
            if arr.shape[0] != self.n:
                arr.resize((self.n, *arr.shape[1:]))
            if lo == self.base and self.n - self.base == self.chunk:
                arr[self.base : self.n] = buf  # a whole chunk: written without reading it back
            else:
                arr[lo : self.n] = buf[lo - self.base : self.n - self.base]
            if self.n > self.base:
                self._note_digest(name, self.base // self.chunk, buf[: self.n - self.base])
        self.written = self.n

    def flush(self) -> None:
        """Write every record so far to the store and its consolidated metadata (store mode)."""
        if self.group is None:
            return
        if not self.buffers:
            for name in self.names:
                if name not in self.group:
                    self.group.create_array(
                        name,
                        shape=(0,),
                        chunks=(self.min_chunk,),
                        dtype="f8",
                        dimension_names=("time",),
                        attributes=_attributes(name, timed=True),
                        fill_value=0.0,
                    )
        elif self.written < self.n or any(self.group[k].shape[0] != self.n for k in self.names if k in self.group):
            self._write()
        _consolidate(self.path)

    def set_attrs(self, attrs: dict[str, Any]) -> None:
        """Add attributes to the store's root group (status at the end of a run)."""
        if self.group is not None:
            self.group.attrs.update(attrs)
            _consolidate(self.path)


class StoreRecords(Mapping):
    """Read-only mapping name → array of a record store (or one of its groups), each variable
    read from the store on first access; ``extra`` adds in-memory arrays (a runner's end-of-run
    series) after the stored ones."""

    def __init__(self, path: str | Path, *, group: str | None = None, extra: Mapping[str, Any] | None = None):
        self.path = Path(path)
        root = _open_group(self.path, "r")
        self._group = root[group] if group else root
        self._names = sorted(self._group.array_keys(), key=lambda k: (k != "t", k))
        self._extra = dict(extra or {})
        self._cache: dict[str, np.ndarray] = {}

    def __getitem__(self, name: str) -> np.ndarray:
        if name in self._extra:
            return self._extra[name]
        if name not in self._cache:
            if name not in self._names:
                raise KeyError(name)
            self._cache[name] = np.asarray(self._group[name][...])
        return self._cache[name]

    def __contains__(self, name: object) -> bool:  # without reading the variable (Mapping's default would)
        return name in self._extra or name in self._names

    def __iter__(self) -> Iterator[str]:
        yield from self._names
        yield from (k for k in self._extra if k not in self._names)

    def __len__(self) -> int:
        return len(set(self._names) | set(self._extra))

    def array(self, name: str) -> Any:
        """The stored (lazy) Zarr array of ``name`` (``shape``, ``dtype``, slicing reads)."""
        return self._group[name]

    @property
    def attrs(self) -> dict[str, Any]:
        """The attributes of the store's group."""
        return dict(self._group.attrs)

    @property
    def extra(self) -> dict[str, Any]:
        """The in-memory arrays added to the stored ones."""
        return dict(self._extra)


def open_records(run_dir: str | Path, *, group: str | None = None) -> StoreRecords:
    """The records of a run folder's ``timeseries.zarr`` (``group="series"``: the derived series)."""
    path = Path(run_dir) / STORE_NAME
    if not path.is_dir():
        raise RecordStoreError(f"run_dir: {path} is missing (not a run folder, or a run of an older version)")
    try:
        return StoreRecords(path, group=group)
    except (OSError, ValueError, KeyError, zarr.errors.BaseZarrError) as err:  # type: ignore[attr-defined]
        raise RecordStoreError(f"run_dir: {path} is unreadable ({type(err).__name__}: {err})") from None


def lazy_arrays(run_dir: str | Path) -> dict[str, Any]:
    """name → lazy Zarr array of a run folder's ``timeseries.zarr``: the records, then the derived
    series of group ``series`` (replacing records of the same name; none when the group is absent).

    Raises:
      RecordStoreError: the folder holds no readable store.
    """
    records = open_records(run_dir)
    arrays: dict[str, Any] = {name: records.array(name) for name in records}
    try:
        series = open_records(run_dir, group=SERIES_GROUP)
    except (RecordStoreError, KeyError):
        return arrays
    arrays.update({name: series.array(name) for name in series})
    return arrays


def write_group(
    path: str | Path,
    arrays: Mapping[str, Any],
    *,
    group: str | None = None,
    n_time: int | None = None,
    attrs: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Write whole arrays into the store at ``path`` (its root, or ``group`` replaced whole):
    arrays whose first axis has ``n_time`` rows get the dimension ``time`` (coordinate ``t``),
    the others ``<name>_dim<i>``; units and long names as for records. Variables already in the
    root are replaced. Returns the digest table of what was written (``[group/]name`` → entry, as
    :meth:`Recorder.digest_table`), computed from the values as they are written."""
    root = _open_group(Path(path), "a") if Path(path).is_dir() else _open_group(Path(path), "w")
    if group:
        if group in root:
            del root[group]
        target = root.create_group(group)
    else:
        target = root
    target.attrs.update(attrs or {})
    digests: dict[str, Any] = {}
    for name, value in arrays.items():
        v = np.asarray(value)
        if v.dtype.kind not in "biufc":
            v = v.astype(str) if v.dtype.kind in "SUO" else v
        timed = n_time is not None and v.ndim >= 1 and v.shape[0] == n_time
        dims = ("time", *dims_of(name, v.shape[1:])) if timed else tuple(f"{name}_dim{i}" for i in range(v.ndim))
        if name in target:
            del target[name]
        arr = target.create_array(
            name,
            shape=v.shape,
            chunks=tuple(max(1, min(s, 4096)) for s in v.shape),
            dtype=v.dtype,
            dimension_names=dims,
            attributes=_attributes(name, timed=timed and "t" in arrays),
            fill_value=None if v.dtype.kind in "U" else np.zeros((), v.dtype).item(),
        )
        arr[...] = v
        key = f"{group}/{name}" if group else name
        digests[key] = _digest_entry(v, arr.chunks[0] if v.ndim else 0, len(v) if v.ndim else 0)
    _consolidate(Path(path))
    return digests


def update_attrs(path: str | Path, attrs: dict[str, Any]) -> None:
    """Add attributes to the root group of the store at ``path`` (e.g. the run's status)."""
    _open_group(Path(path), "r+").attrs.update(attrs)
    _consolidate(Path(path))


def store_length(path: str | Path) -> int:
    """The number of records (length of ``t``) in the store at ``path``."""
    path = Path(path)
    if not path.is_dir():
        raise RecordStoreError(f"record store {path} is missing")
    try:
        group = _open_group(path, "r")
        return int(group["t"].shape[0]) if "t" in group else 0
    except (OSError, ValueError, KeyError, zarr.errors.BaseZarrError) as err:  # type: ignore[attr-defined]
        raise RecordStoreError(f"record store {path} is unreadable ({type(err).__name__}: {err})") from None


def lazy_record(records: Mapping[str, Any], name: str) -> Any:
    """``records[name]`` without reading it: the stored Zarr array of :class:`StoreRecords` (slicing
    reads), otherwise the array itself (in-memory records)."""
    return records.array(name) if isinstance(records, StoreRecords) else records[name]


def chunk_block_bytes(arrays: Mapping[str, Any]) -> float:
    """The most bytes that reading one chunk's rows of any of ``arrays`` holds [bytes]: the rows of
    a chunk along the first axis (the whole array when it is not chunked) times the bytes of a
    row, from the stores' metadata (nothing is read). Export and render read records this way, so
    their memory estimates count it; a store whose metadata declares huge chunks is refused there
    before a chunk is read."""
    largest = 0.0
    for array in arrays.values():
        shape = tuple(int(s) for s in array.shape)
        row = float(np.prod(shape[1:], dtype=float)) * np.dtype(array.dtype).itemsize
        chunks = getattr(array, "chunks", None)
        rows = shape[0] if shape else 1
        if chunks and shape:
            rows = min(rows, int(chunks[0]))
        largest = max(largest, rows * row)
    return largest


def row_blocks(array: Any, *, budget_bytes: int = BLOCK_BYTES) -> Iterator[np.ndarray]:
    """Consecutive blocks of rows of a ``(T, ...)`` array as NumPy arrays, in order, each of at most
    ``budget_bytes`` (but at least one row; for a Zarr array a whole number of its chunks when a
    chunk fits): post-processing of a long run then holds one block, not the run.

    Raises:
      ValueError: ``budget_bytes`` is not positive, or ``array`` has no rows axis.
    """
    if budget_bytes <= 0:
        raise ValueError(f"budget_bytes: must be positive, got {budget_bytes}")
    shape = tuple(array.shape)
    if not shape:
        raise ValueError("array: a block of rows needs at least one axis, got a scalar")
    row_bytes = max(1, int(np.prod(shape[1:], dtype=np.int64)) * np.dtype(array.dtype).itemsize)
    step = max(1, budget_bytes // row_bytes)
    chunk = getattr(array, "chunks", None)
    if chunk and isinstance(chunk[0], int) and chunk[0] <= step:
        step -= step % chunk[0]
    for start in range(0, shape[0], step):
        yield np.asarray(array[start : start + step])
