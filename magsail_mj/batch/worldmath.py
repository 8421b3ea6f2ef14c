r"""Arithmetic over a world axis, rounded exactly as one world's run rounds it.

A batch is meant to reproduce, world by world, the run of each world's config to the last bit.
The single run evaluates its loads and controller in plain Python floats (:mod:`magsail_mj.vec3`),
in NumPy products that go to BLAS (``v @ R``, ``R.T @ v``, ``a @ b``) and in MuJoCo's utility
functions (``mju_quat2Mat``, ``mj_integratePos``). The functions here do the same on ``(N, …)``
arrays, one row per world:

* sums of products are written in the single run's order (Python evaluates ``a + b + c`` left to
  right, and NumPy's element-wise operations round each operation once, as Python does), so an
  element-wise expression over the world axis equals the scalar expression of each world;
* the BLAS products go through :func:`numpy.matmul` on stacks of the same shapes and strides, which
  calls the same BLAS routine (``gemv``, ``dot``, ``gemm``) once per world;
* MuJoCo's ``mju_quat2Mat`` and ``mju_quatIntegrate`` are written out as MuJoCo 4.0 rounds them: its
  four-term sums are evaluated in pairs, ``(a + b) + (c + d)`` (the diagonal of the rotation matrix
  as ``(q₀₀ − q₂₂) + (q₁₁ − q₃₃)``, …, the quaternion product and the norm of a quaternion
  likewise); ``tests/test_batch_worldmath.py`` compares them with MuJoCo's own functions bit for bit
  on random inputs, so a MuJoCo that rounds otherwise is caught there;
* transcendental functions (sin, cos, atan2, exp) and Python's ``x ** n`` (C ``pow``) are applied
  per world through :mod:`math` (:func:`per_world`), since NumPy's vectorised versions may differ
  from the C library in the last bit on some CPUs. This is the one per-world Python loop of a
  step: a list comprehension over N floats (≈ 0.1 µs per world and call).

Frames and conventions are the single run's: quaternions scalar-first ``[w, x, y, z]``, body →
world; a rotation matrix as its 9 row-major entries ``R = (R₀₀, R₀₁, R₀₂, R₁₀, …, R₂₂)``.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

__all__ = [
    "MJ_MINVAL",
    "per_world",
    "pow_per_world",
    "quat_to_mat",
    "normalise_quat",
    "quat_integrate",
    "mat_vec",
    "mat_t_vec",
    "cross",
    "vec_mat_blas",
    "mat_t_vec_blas",
    "dot_blas",
]

MJ_MINVAL = 1e-15
"""MuJoCo's mjMINVAL: the norm below which ``mju_normalize3``/``mju_normalize4`` give a unit vector."""


def per_world(fn: Callable[[float], float], x: np.ndarray) -> np.ndarray:
    """``fn`` (a :mod:`math` function of one float) applied to every entry of ``x`` as Python floats,
    so each world gets the C library's value, as its single run does. A value ``fn`` refuses
    (``math.sin(inf)``, ``math.exp(1e3)``) gives NaN (a world that diverged must not stop the others)."""

    def safe(v: float) -> float:
        try:
            return fn(v)
        except (ValueError, OverflowError):
            return math.nan

    flat = np.asarray(x, dtype=float).ravel().tolist()
    try:
        out = [fn(v) for v in flat]
    except (ValueError, OverflowError):
        out = [safe(v) for v in flat]
    return np.array(out, dtype=float).reshape(np.shape(x))


def pow_per_world(x: np.ndarray, p: int) -> np.ndarray:
    """``x ** p`` of every entry as Python floats (C ``pow``, as the single run's ``rn**3``), with
    ±inf where Python would raise OverflowError."""

    def power(v: float) -> float:
        try:
            return v**p
        except OverflowError:
            return math.copysign(math.inf, v) if p % 2 else math.inf

    flat = np.asarray(x, dtype=float).ravel().tolist()
    try:
        out = [v**p for v in flat]
    except OverflowError:
        out = [power(v) for v in flat]
    return np.array(out, dtype=float).reshape(np.shape(x))


def quat_to_mat(q: np.ndarray) -> np.ndarray:
    """(N, 9) rotation matrices of (N, 4) quaternions as ``mujoco.mju_quat2Mat`` computes them
    (not normalised; ``[1, 0, 0, 0]`` gives the identity exactly)."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    q00, q01, q02, q03 = w * w, w * x, w * y, w * z
    q11, q12, q13 = x * x, x * y, x * z
    q22, q23, q33 = y * y, y * z, z * z
    R = np.empty((len(q), 9))
    R[:, 0] = (q00 - q22) + (q11 - q33)
    R[:, 4] = (q00 + q22) - (q11 + q33)
    R[:, 8] = (q00 - q22) + (q33 - q11)
    R[:, 1] = 2 * (q12 - q03)
    R[:, 2] = 2 * (q13 + q02)
    R[:, 3] = 2 * (q12 + q03)
    R[:, 5] = 2 * (q23 - q01)
    R[:, 6] = 2 * (q13 - q02)
    R[:, 7] = 2 * (q23 + q01)
    unit = (w == 1.0) & (x == 0.0) & (y == 0.0) & (z == 0.0)
    if unit.any():
        R[unit] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    return R


def normalise_quat(q: np.ndarray) -> np.ndarray:
    """(N, 4) quaternions divided by their norm ``√(((w² + x²) + y²) + z²)``, as
    :class:`magsail_mj.sim.BodyKinematics` normalises a free body's ``qpos`` quaternion."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    n = np.sqrt(w * w + x * x + y * y + z * z)
    return q / n[:, None]


def quat_integrate(q: np.ndarray, omega: np.ndarray, scale: float) -> np.ndarray:
    """``mujoco.mju_quatIntegrate`` of (N, 4) quaternions by (N, 3) local angular velocities over
    ``scale`` [s]: ``q ← normalise₄(q) ⊗ (cos(θ/2), â sin(θ/2))`` with ``θ = scale·|ω|``, ``â = ω/|ω|``
    (``â = x̂`` when ``|ω| < mjMINVAL``; no rotation when ``θ = 0``); a new array."""
    vx, vy, vz = omega[:, 0], omega[:, 1], omega[:, 2]
    norm = np.sqrt((vx * vx + vy * vy) + vz * vz)
    small = norm < MJ_MINVAL
    if small.any():
        inv = 1 / np.where(small, 1.0, norm)
        ax = np.where(small, 1.0, vx * inv)
        ay = np.where(small, 0.0, vy * inv)
        az = np.where(small, 0.0, vz * inv)
    else:
        inv = 1 / norm
        ax, ay, az = vx * inv, vy * inv, vz * inv
    angle = scale * norm
    half = angle * 0.5
    s, c = per_world(math.sin, half), per_world(math.cos, half)
    r1, r2, r3 = ax * s, ay * s, az * s
    still = angle == 0
    if still.any():
        c = np.where(still, 1.0, c)
        r1, r2, r3 = (np.where(still, 0.0, r) for r in (r1, r2, r3))
    r0 = c
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    n4 = np.sqrt((w * w + x * x) + (y * y + z * z))
    tiny = n4 < MJ_MINVAL
    scaled = ~tiny & (np.abs(n4 - 1) > MJ_MINVAL)
    if tiny.any() or not scaled.all():
        inv4 = 1 / np.where(scaled, n4, 1.0)
        w = np.where(tiny, 1.0, np.where(scaled, w * inv4, w))
        x = np.where(tiny, 0.0, np.where(scaled, x * inv4, x))
        y = np.where(tiny, 0.0, np.where(scaled, y * inv4, y))
        z = np.where(tiny, 0.0, np.where(scaled, z * inv4, z))
    else:
        inv4 = 1 / n4
        w, x, y, z = w * inv4, x * inv4, y * inv4, z * inv4
    out = np.empty((len(q), 4))
    out[:, 0] = (w * r0 - x * r1) + (-y * r2 - z * r3)
    out[:, 1] = (w * r1 + x * r0) + (y * r3 - z * r2)
    out[:, 2] = (w * r2 - x * r3) + (y * r0 + z * r1)
    out[:, 3] = (w * r3 + x * r2) + (-y * r1 + z * r0)
    return out


def mat_vec(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R v`` of (N, 9) row-major matrices and (N, 3) vectors, each row summed left to right
    (:func:`magsail_mj.vec3.mat_vec_f`)."""
    v0, v1, v2 = v[:, 0], v[:, 1], v[:, 2]
    out = np.empty((len(v), 3))
    out[:, 0] = R[:, 0] * v0 + R[:, 1] * v1 + R[:, 2] * v2
    out[:, 1] = R[:, 3] * v0 + R[:, 4] * v1 + R[:, 5] * v2
    out[:, 2] = R[:, 6] * v0 + R[:, 7] * v1 + R[:, 8] * v2
    return out


def mat_t_vec(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``Rᵀ v`` of (N, 9) row-major matrices and (N, 3) vectors (:func:`magsail_mj.vec3.mat_t_vec_f`)."""
    v0, v1, v2 = v[:, 0], v[:, 1], v[:, 2]
    out = np.empty((len(v), 3))
    out[:, 0] = R[:, 0] * v0 + R[:, 3] * v1 + R[:, 6] * v2
    out[:, 1] = R[:, 1] * v0 + R[:, 4] * v1 + R[:, 7] * v2
    out[:, 2] = R[:, 2] * v0 + R[:, 5] * v1 + R[:, 8] * v2
    return out


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a × b`` of (N, 3) rows (:func:`magsail_mj.vec3.cross_f`, and ``numpy.cross``'s rounding)."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    out = np.empty((len(a), 3))
    out[:, 0] = a1 * b2 - a2 * b1
    out[:, 1] = a2 * b0 - a0 * b2
    out[:, 2] = a0 * b1 - a1 * b0
    return out


def vec_mat_blas(v: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``v @ R`` per world for (N, 3) vectors and (N, 9) row-major matrices: one BLAS ``gemv`` per
    world, as the single run's ``v @ R.reshape(3, 3)``."""
    return np.matmul(v[:, None, :], R.reshape(-1, 3, 3))[:, 0, :]


def mat_t_vec_blas(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R.T @ v`` per world for (N, 9) row-major matrices and (N, 3) vectors (BLAS ``gemv`` per
    world, as the single run's ``R.reshape(3, 3).T @ v``)."""
    return np.matmul(R.reshape(-1, 3, 3).transpose(0, 2, 1), v[:, :, None])[:, :, 0]


def dot_blas(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` per world for (N, 3) rows (BLAS ``dot`` per world, as the single run's ``a @ b``)."""
    return np.matmul(a[:, None, :], b[:, :, None])[:, 0, 0]
