r"""Records of a batch: one :class:`~magsail_mj.records.Recorder` per world, filled in blocks.

A record step gives every probe's values for all N worlds as ``(N, …)`` arrays. They go to a block
buffer of ``block`` records per probe (``(N, block, …)``, one array copy per probe and record); a
full block is handed to each live world's own :class:`~magsail_mj.records.Recorder` in one
:meth:`~magsail_mj.records.Recorder.extend` call, so the per-world Python work is one call per
``block`` records. Each world's recorder is exactly what its single run keeps: chunks in memory,
or streamed to the world's Zarr store (:meth:`WorldRecords.create_stores`), with the same
digests, truncation and non-finite checks.

Memory: the block buffer holds ``N × block`` records, and each world's recorder one chunk of
``chunk`` records (``chunk_bytes`` over the widest variable, between 16 and 4096 records; the
batch's default, 256 KiB, is a sixteenth of a single run's so that hundreds of worlds stay within a
few hundred MB); without a store the records of a whole run stay in memory.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from magsail_mj.records import Recorder

__all__ = ["WorldRecords", "BATCH_CHUNK_BYTES"]

BATCH_CHUNK_BYTES = 1 << 18
"""Target size [bytes] of one chunk of a world's widest variable in a batch."""


class WorldRecords:
    """The records of N worlds (module docstring).

    Args:
      names: the variables, ``t`` first (as :class:`~magsail_mj.records.Recorder`).
      n_worlds: N.
      block: records buffered before they are handed to the worlds' recorders.
      chunk_bytes: the worlds' recorders' chunk target [bytes].
    """

    def __init__(self, names: Sequence[str], n_worlds: int, *, block: int = 64, chunk_bytes: int = BATCH_CHUNK_BYTES):
        if block < 1:
            raise ValueError(f"block: must be >= 1, got {block}")
        self.names = list(names)
        self.recorders = [Recorder(self.names, chunk_bytes=chunk_bytes) for _ in range(n_worlds)]
        self.block = int(block)
        self.rows = 0
        self.buffers: dict[str, np.ndarray] = {}

    def append(self, values: Mapping[str, np.ndarray], live: np.ndarray) -> None:
        """Add one record of every world (``values``: name → (N, …)); a full block goes to the live
        worlds' recorders."""
        if not self.buffers:
            self.buffers = {
                k: np.zeros((len(self.recorders), self.block, *np.shape(v)[1:]), dtype=np.asarray(v).dtype)
                for k, v in ((k, np.asarray(values[k])) for k in self.names)
            }
        i = self.rows
        for name in self.names:
            self.buffers[name][:, i] = values[name]
        self.rows += 1
        if self.rows == self.block:
            self.flush(live)

    def flush(self, live: np.ndarray) -> None:
        """Hand the buffered records to the recorders of the worlds in ``live`` (the others' rows are
        dropped: they were written after those worlds stopped)."""
        m = self.rows
        if m:
            for k in np.flatnonzero(live):
                self.recorders[k].extend({name: buf[k, :m] for name, buf in self.buffers.items()})
        self.rows = 0

    def __len__(self) -> int:
        return len(self.recorders)

    def counts(self) -> np.ndarray:
        """(N,) records held by each world's recorder (after a :meth:`flush`)."""
        return np.array([len(r) for r in self.recorders], dtype=np.int64)

    def create_stores(self, paths: Sequence[str | Path], attrs: Sequence[dict[str, Any] | None]) -> None:
        """Stream each world's records to its Zarr store ``paths[k]`` with attributes ``attrs[k]``."""
        if len(paths) != len(self.recorders) or len(attrs) != len(self.recorders):
            raise ValueError(
                f"records_paths, records_attrs: need one per world ({len(self.recorders)}), "
                f"got {len(paths)} and {len(attrs)}"
            )
        for rec, path, a in zip(self.recorders, paths, attrs):
            if rec.path != Path(path):
                rec.create_store(path, attrs=a)
