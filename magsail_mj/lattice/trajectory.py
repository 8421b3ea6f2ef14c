"""Node positions of a recorded lattice run, read one block of records at a time.

A lattice run records ``qpos`` (T, nq); its node positions (T, n, 3) [m, world frame] are a
function of one record each (:func:`~magsail_mj.lattice.mjcf.node_positions_from_qpos`). For a
long run neither array fits comfortably in memory (a 4.2 h slew of an 800-node plate recorded
every 2 s holds 7 560 records of 19 kB each), so post-processing asks a :class:`NodeTrajectory`
for blocks of positions (:meth:`NodeTrajectory.map`) or for one record (:meth:`NodeTrajectory.at`);
the recorded array may be a lazy Zarr array of the run's store, read block by block
(:func:`~magsail_mj.records.row_blocks`). Memory then stays one block whatever the run's length.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import Any

import numpy as np

from magsail_mj import records as _records
from magsail_mj.records import row_blocks

__all__ = ["NodeTrajectory", "as_trajectory"]


class NodeTrajectory:
    """Node positions (T, n, 3) [m] of a run, computed from ``records`` (T, …) by ``to_positions``
    one block of at most ``budget_bytes`` of records at a time.

    Args:
      records: the recorded array (NumPy, or a lazy Zarr array of the run's store).
      to_positions: records (B, …) → node positions (B, n, 3) [m]; also used for one record.
      budget_bytes: the most bytes of records read at once (at least one record is read; default
        :data:`magsail_mj.records.BLOCK_BYTES`).
    """

    def __init__(
        self, records: Any, to_positions: Callable[[np.ndarray], np.ndarray], *, budget_bytes: int | None = None
    ):
        budget_bytes = _records.BLOCK_BYTES if budget_bytes is None else budget_bytes
        if budget_bytes <= 0:
            raise ValueError(f"budget_bytes: must be positive, got {budget_bytes}")
        if len(getattr(records, "shape", ())) < 1:
            raise ValueError("records: need a time axis (shape (T, ...))")
        self.records = records
        self.to_positions = to_positions
        self.budget_bytes = int(budget_bytes)

    @classmethod
    def of_positions(cls, positions: np.ndarray, *, budget_bytes: int | None = None) -> NodeTrajectory:
        """A trajectory of positions already in memory, (T, n, 3) [m]."""
        positions = np.asarray(positions)
        if positions.ndim != 3 or positions.shape[-1] != 3:
            raise ValueError(f"positions: expected shape (T, n, 3), got {positions.shape}")
        return cls(positions, np.asarray, budget_bytes=budget_bytes)

    def __len__(self) -> int:
        return int(self.records.shape[0])

    def at(self, k: int) -> np.ndarray:
        """Node positions (n, 3) [m] of record ``k`` (negative counts from the end)."""
        n = len(self)
        if not -n <= k < n:
            raise IndexError(f"k: record {k} out of range for {n} records")
        k = k % n
        return self.to_positions(np.asarray(self.records[k : k + 1]))[0]

    def blocks(self) -> Iterator[np.ndarray]:
        """Consecutive blocks of node positions (B, n, 3) [m], in order, covering every record once."""
        for block in row_blocks(self.records, budget_bytes=self.budget_bytes):
            yield self.to_positions(block)

    def map(self, fn: Callable[[np.ndarray], Any]) -> Any:
        """``fn`` of every block, joined along the time axis: ``fn`` returns an array (B, …), a tuple
        (or named tuple) of such arrays, or a mapping name → array; the result has the same form
        with the blocks concatenated. ``fn`` must treat each record on its own (no reduction
        over time), so that the result equals ``fn`` of the whole trajectory."""
        parts = [fn(x) for x in self.blocks()]
        if not parts:
            raise ValueError("records: no records to compute from")
        first = parts[0]
        if isinstance(first, Mapping):
            return {key: np.concatenate([p[key] for p in parts]) for key in first}
        if isinstance(first, tuple):
            joined = [np.concatenate([p[i] for p in parts]) for i in range(len(first))]
            return type(first)(*joined) if hasattr(first, "_fields") else tuple(joined)
        return np.concatenate(parts)


def as_trajectory(positions: NodeTrajectory | np.ndarray) -> NodeTrajectory:
    """``positions`` as a :class:`NodeTrajectory` (an in-memory (T, n, 3) array is wrapped)."""
    return positions if isinstance(positions, NodeTrajectory) else NodeTrajectory.of_positions(positions)
