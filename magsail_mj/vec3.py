"""Small 3-vector helpers for the per-step paths.

``np.cross`` on two 3-vectors costs ~10 µs of argument handling; a controller or probe that
calls it every step spends more there than in its arithmetic. These helpers compute the same
quantities with scalar arithmetic (one 3-vector) or one matrix product (sums over many points);
tests compare them with ``np.cross`` on random inputs.
"""

from __future__ import annotations

import numpy as np

__all__ = ["cross3", "moment_sum"]


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a × b`` of two (3,) vectors (as ``np.cross``, without its broadcasting machinery)."""
    a0, a1, a2 = a.tolist() if isinstance(a, np.ndarray) else a
    b0, b1, b2 = b.tolist() if isinstance(b, np.ndarray) else b
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def moment_sum(d: np.ndarray, F: np.ndarray) -> np.ndarray:
    r"""``Σ_i d_i × F_i`` for (n, 3) lever arms ``d`` and forces ``F`` → (3,).

    With ``M = dᵀ F`` (``M_jk = Σ_i d_ij F_ik``) the sum is ``(M₁₂ − M₂₁, M₂₀ − M₀₂, M₀₁ − M₁₀)``:
    one (3 × n)(n × 3) product instead of n cross products.
    """
    M = d.T @ F
    return np.array([M[1, 2] - M[2, 1], M[2, 0] - M[0, 2], M[0, 1] - M[1, 0]])
