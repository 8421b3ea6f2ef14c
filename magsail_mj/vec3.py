"""Small 3-vector helpers for the per-step paths.

``np.cross`` on two 3-vectors costs ~10 µs of argument handling; a controller or probe that
calls it every step spends more there than in its arithmetic. These helpers compute the same
quantities with scalar arithmetic (one 3-vector) or one matrix product (sums over many points);
tests compare them with ``np.cross`` on random inputs.

The ``*_f`` functions take and return plain Python floats (3-tuples; a 3 × 3 matrix as the 9
entries of its rows, e.g. ``R.ravel().tolist()`` or the buffer of ``mujoco.mju_quat2Mat``): on
a 3-vector a NumPy call costs ~1 µs of overhead and a float operation ~30 ns, so the loads that
run every step of a small model (the cubesat) work in floats and touch NumPy only to read the
state and to write ``xfrc_applied``. Sums are evaluated left to right (``a₀b₀ + a₁b₁ + a₂b₂``);
they equal the NumPy products to the rounding of the largest term (tests: 1e-15 relative to it).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

__all__ = ["cross3", "moment_sum", "Vec3", "cross_f", "dot_f", "norm_f", "mat_vec_f", "mat_t_vec_f"]

Vec3 = tuple[float, float, float]
"""A 3-vector as plain floats."""


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


def cross_f(a: Sequence[float], b: Sequence[float]) -> Vec3:
    """``a × b = (a₁b₂ − a₂b₁, a₂b₀ − a₀b₂, a₀b₁ − a₁b₀)`` of two 3-sequences of floats."""
    a0, a1, a2 = a
    b0, b1, b2 = b
    return (a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0)


def dot_f(a: Sequence[float], b: Sequence[float]) -> float:
    """``a · b = a₀b₀ + a₁b₁ + a₂b₂``."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def norm_f(a: Sequence[float]) -> float:
    """``|a| = √(a · a)``."""
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def mat_vec_f(R: Sequence[float], v: Sequence[float]) -> Vec3:
    """``R v`` for the row-major entries ``R = (R₀₀, R₀₁, R₀₂, R₁₀, …, R₂₂)``: ``(R v)_i = Σ_j R_ij v_j``
    (body → world for the rotation of a body's quaternion)."""
    v0, v1, v2 = v
    return (R[0] * v0 + R[1] * v1 + R[2] * v2, R[3] * v0 + R[4] * v1 + R[5] * v2, R[6] * v0 + R[7] * v1 + R[8] * v2)


def mat_t_vec_f(R: Sequence[float], v: Sequence[float]) -> Vec3:
    """``Rᵀ v`` (``= v R``, world → body for a rotation): ``(Rᵀ v)_j = Σ_i R_ij v_i``."""
    v0, v1, v2 = v
    return (R[0] * v0 + R[3] * v1 + R[6] * v2, R[1] * v0 + R[4] * v1 + R[7] * v2, R[2] * v0 + R[5] * v1 + R[8] * v2)
