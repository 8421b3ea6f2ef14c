"""Small shape/dtype checks shared by the estimation and analysis modules.

Every public function validates its array arguments with these helpers so that a wrong shape is
reported as ``ValueError("<argument>: expected shape ..., got ...")`` naming the argument.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "as_points",
    "as_point_series",
    "as_rotations",
    "as_index_array",
    "as_masses",
    "time_chunks",
    "map_time_blocks",
]


def as_points(x: object, name: str, *, min_points: int = 1) -> np.ndarray:
    """Return ``x`` as a float64 array of shape ``(n, 3)``."""
    a = np.asarray(x, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name}: expected shape (n, 3), got {a.shape}")
    if a.shape[0] < min_points:
        raise ValueError(f"{name}: need at least {min_points} points, got {a.shape[0]}")
    return a


def as_point_series(x: object, name: str, *, n: int | None = None, min_points: int = 1) -> np.ndarray:
    """Return ``x`` as float64 of shape ``(n, 3)`` or ``(T, n, 3)``; check ``n`` if given."""
    a = np.asarray(x, dtype=float)
    if a.ndim not in (2, 3) or a.shape[-1] != 3:
        raise ValueError(f"{name}: expected shape (n, 3) or (T, n, 3), got {a.shape}")
    if n is not None and a.shape[-2] != n:
        raise ValueError(f"{name}: expected {n} points (shape (..., {n}, 3)), got {a.shape}")
    if a.shape[-2] < min_points:
        raise ValueError(f"{name}: need at least {min_points} points, got {a.shape[-2]}")
    return a


def as_rotations(x: object, name: str) -> np.ndarray:
    """Return ``x`` as float64 of shape ``(..., 3, 3)``."""
    a = np.asarray(x, dtype=float)
    if a.ndim < 2 or a.shape[-2:] != (3, 3):
        raise ValueError(f"{name}: expected shape (..., 3, 3), got {a.shape}")
    return a


def as_index_array(x: object, name: str, *, width: int, n_nodes: int) -> np.ndarray:
    """Return ``x`` as an int64 array ``(m, width)`` of node indices in ``[0, n_nodes)``."""
    a = np.asarray(x)
    if a.ndim != 2 or a.shape[1] != width:
        raise ValueError(f"{name}: expected shape (m, {width}), got {a.shape}")
    if a.size and not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"{name}: expected integer node indices, got dtype {a.dtype}")
    a = a.astype(np.int64, copy=False)
    if a.size and (a.min() < 0 or a.max() >= n_nodes):
        raise ValueError(f"{name}: node indices must lie in [0, {n_nodes}), got range [{a.min()}, {a.max()}]")
    return a


def as_masses(x: object, name: str, n: int, *, sign_error: str | None = None) -> np.ndarray:
    """Return ``x`` (a scalar for all, or ``(n,)``) as float64 masses ``(n,)``, all ``>= 0`` with a
    positive sum; ``sign_error`` replaces the message ``<name>: must be >= 0 with a positive total``."""
    m = np.asarray(x, dtype=float)
    if m.ndim == 0:
        m = np.full(n, float(m))
    if m.shape != (n,):
        raise ValueError(f"{name}: expected a scalar or shape ({n},), got {m.shape}")
    if np.any(m < 0) or not m.sum() > 0:
        raise ValueError(sign_error or f"{name}: must be >= 0 with a positive total")
    return m


def time_chunks(n_steps: int, per_step_elems: int, *, max_elems: int = 1 << 22) -> list[slice]:
    """Split ``range(n_steps)`` into blocks whose temporaries stay below ``max_elems`` elements.

    Used where a time series would otherwise create ``(T, n_struts, 3)`` temporaries of several
    gigabytes; each block is still processed fully vectorised (a loop over blocks, not steps).
    """
    block = max(1, max_elems // max(1, per_step_elems))
    return [slice(s, min(s + block, n_steps)) for s in range(0, n_steps, block)]


def map_time_blocks(fn, arrays: tuple[np.ndarray, ...], per_step_elems: int, *, max_elems: int = 1 << 22):
    """Apply ``fn(*arrays)`` to blocks of the leading (time) axis and concatenate the results.

    ``arrays`` are either all single configurations (no time axis; ``fn`` is called once, with
    ``arrays[0].ndim == 2``) or all share the leading time axis. ``fn`` returns an array or a
    tuple/NamedTuple of arrays with the time axis first; tuples are concatenated field-wise.
    """
    if arrays[0].ndim == 2:
        return fn(*arrays)
    T = arrays[0].shape[0]
    blocks = time_chunks(T, per_step_elems, max_elems=max_elems)
    if len(blocks) <= 1:
        return fn(*arrays)
    parts = [fn(*(a[b] for a in arrays)) for b in blocks]
    first = parts[0]
    if isinstance(first, tuple):
        cols = [np.concatenate([p[i] for p in parts], axis=0) for i in range(len(first))]
        return type(first)(*cols) if hasattr(first, "_fields") else tuple(cols)
    return np.concatenate(parts, axis=0)
