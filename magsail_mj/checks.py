"""Argument checks shared by the parameter dataclasses: each error names the attribute and its value."""

from __future__ import annotations

from typing import Any, Iterable

import numpy as np

__all__ = ["is_symmetric", "require_non_negative", "require_positive"]

# Relative tolerance of a symmetric tensor's check: an inertia assembled from parts (parallel-axis
# terms, rotations) is symmetric only up to a few rounding steps of its largest entry, so the
# asymmetry is compared with that entry, never with an absolute floor that a huge but valid
# inertia (a 2^31 m lattice: entries near 1e70 kg m²) exceeds in rounding alone.
SYMMETRY_RTOL = 1e-12


def require_positive(obj: Any, names: Iterable[str]) -> None:
    """Raise ``ValueError("<name>: must be > 0, got <value>")`` for the first attribute of ``obj``
    in ``names`` that is not ``> 0`` (NaN included)."""
    for name in names:
        value = getattr(obj, name)
        if not value > 0:
            raise ValueError(f"{name}: must be > 0, got {value!r}")


def require_non_negative(obj: Any, names: Iterable[str]) -> None:
    """Raise ``ValueError("<name>: must be >= 0, got <value>")`` for the first attribute of ``obj``
    in ``names`` that is not ``>= 0`` (NaN included)."""
    for name in names:
        value = getattr(obj, name)
        if not value >= 0:
            raise ValueError(f"{name}: must be >= 0, got {value!r}")


def is_symmetric(matrix: np.ndarray, rtol: float = SYMMETRY_RTOL) -> bool:
    """Whether the finite square ``matrix`` is symmetric to ``rtol`` of its scale:
    ``max|M - Mᵀ| <= rtol · max|M|`` (a zero matrix is symmetric). Scale-free, so an inertia
    of any size passes when only rounding separates it from its transpose."""
    m = np.asarray(matrix, dtype=float)
    if m.ndim != 2 or m.shape[0] != m.shape[1] or not np.all(np.isfinite(m)):
        return False
    scale = float(np.max(np.abs(m), initial=0.0))
    return float(np.max(np.abs(m - m.T), initial=0.0)) <= rtol * scale
