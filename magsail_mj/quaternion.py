r"""Unit quaternions, scalar first ``q = [w, x, y, z]`` (MuJoCo's order), body → world.

One home for the small quaternion algebra the controllers and scenarios share:

- :func:`quat_mul` — Hamilton product ``p ⊗ q`` (as ``mju_mulQuat``);
- :func:`quat_conj` — ``q* = [w, −x, −y, −z]``, the inverse of a unit quaternion;
- :func:`quat_to_matrix` — the rotation matrix ``R(q)`` with ``x_world = R x_body`` (as
  ``mju_quat2Mat``);
- :func:`error_quaternion` — ``q_e = q_ref* ⊗ q`` with ``q_{e,0} ≥ 0`` (shortest rotation from the
  reference to the current attitude; its angle is ``2 atan2(|q_e,vec|, q_e,0)``).

A single ``(4,)`` quaternion takes a plain-float path (these run inside control loops, where
NumPy's per-call overhead on 4-vectors dominates); ``(..., 4)`` stacks broadcast.
"""

from __future__ import annotations

import numpy as np

__all__ = ["quat_mul", "quat_conj", "quat_to_matrix", "error_quaternion"]


def quat_mul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p ⊗ q``; ``(4,)`` or broadcasting ``(..., 4)``."""
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    if p.shape == (4,) and q.shape == (4,):
        w1, x1, y1, z1 = p.tolist()
        w2, x2, y2, z2 = q.tolist()
        return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                         w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                         w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                         w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack([pw * qw - px * qx - py * qy - pz * qz,
                     pw * qx + px * qw + py * qz - pz * qy,
                     pw * qy - px * qz + py * qw + pz * qx,
                     pw * qz + px * qy - py * qx + pz * qw], axis=-1)


def quat_conj(q: np.ndarray) -> np.ndarray:
    """``q* = [w, −x, −y, −z]``; ``(..., 4)``."""
    return np.asarray(q, dtype=float) * np.array([1.0, -1.0, -1.0, -1.0])


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix ``(3, 3)`` of a unit quaternion ``(4,)`` (body → world)."""
    w, x, y, z = np.asarray(q, dtype=float).tolist()
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def error_quaternion(q_ref: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``q_e = q_ref* ⊗ q`` with a non-negative scalar part; ``(4,)`` or ``(..., 4)``."""
    qe = quat_mul(quat_conj(q_ref), q)
    if qe.ndim == 1:
        return -qe if qe[0] < 0.0 else qe
    return np.where(qe[..., :1] < 0.0, -qe, qe)
