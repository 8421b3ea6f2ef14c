r"""Unit quaternions, scalar first ``q = [w, x, y, z]`` (MuJoCo's order), body → world.

The one home of the quaternion algebra (controllers, loads, estimators, metrics, model builders):

- :func:`quat_mul` — Hamilton product ``p ⊗ q`` (as ``mju_mulQuat``);
- :func:`quat_conj` — ``q* = [w, −x, −y, −z]``, the inverse of a unit quaternion;
- :func:`quat_to_matrix` — the rotation matrix ``R(q)`` with ``x_world = R x_body`` (as
  ``mju_quat2Mat``): ``R = (w² − v·v) I + 2 v vᵀ + 2 w [v]×`` with ``v = [x, y, z]``;
- :func:`quat_from_matrix` — the inverse map, ``w ≥ 0`` (Shepperd / Bar-Itzhack);
- :func:`quat_from_axis_angle` — ``q = [cos(θ/2), sin(θ/2) n̂]``, rotation by ``θ`` [rad] about
  the unit axis ``n̂`` (right hand);
- :func:`quat_to_axis_angle` — its inverse, ``θ = 2 atan2(|v|, w) ∈ [0, π]`` after ``w ≥ 0``;
- :func:`quat_z_to` — the shortest rotation taking ``+z`` onto a direction (geom orientation);
  :func:`direction_quaternions` — the same for a ``(T, 3)`` series of directions (markers);
- :func:`error_quaternion` — ``q_e = q_ref* ⊗ q`` with ``q_{e,0} ≥ 0`` (shortest rotation from the
  reference to the current attitude; its angle is ``2 atan2(|q_e,vec|, q_e,0)``).

``q`` and ``−q`` are the same rotation. A single ``(4,)`` quaternion takes a plain-float path
(these run inside control loops, where NumPy's per-call overhead on 4-vectors dominates);
``(..., 4)`` stacks broadcast. Both paths do the same IEEE operations in the same order, so they
agree bit for bit.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "quat_mul",
    "quat_conj",
    "quat_to_matrix",
    "quat_from_matrix",
    "quat_from_axis_angle",
    "quat_to_axis_angle",
    "quat_z_to",
    "direction_quaternions",
    "error_quaternion",
    "quat_angle",
]


def quat_mul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p ⊗ q``; ``(4,)`` or broadcasting ``(..., 4)``."""
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    if p.shape == (4,) and q.shape == (4,):
        w1, x1, y1, z1 = p.tolist()
        w2, x2, y2, z2 = q.tolist()
        return np.array(
            [
                w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
            ]
        )
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ],
        axis=-1,
    )


def quat_conj(q: np.ndarray) -> np.ndarray:
    """``q* = [w, −x, −y, −z]``; ``(..., 4)``."""
    return np.asarray(q, dtype=float) * np.array([1.0, -1.0, -1.0, -1.0])


def _matrix_rows(w, x, y, z) -> list:
    """Rows of ``R(q)`` from the four components (floats or arrays of one shape)."""
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]


def quat_to_matrix(q: np.ndarray, *, normalise: bool = False) -> np.ndarray:
    """Rotation matrix ``(..., 3, 3)`` of quaternions ``(..., 4)`` (body → world, ``xmat`` layout).

    With ``normalise`` the quaternions are divided by their norm first (a ``ValueError`` naming
    ``q`` when a norm is zero or not finite); without it ``q`` is taken to be unit.
    """
    q = np.asarray(q, dtype=float)
    if q.shape[-1:] != (4,):
        raise ValueError(f"q: expected shape (..., 4) [w, x, y, z], got {q.shape}")
    if normalise:
        nrm = np.linalg.norm(q, axis=-1, keepdims=True)
        if not np.all(np.isfinite(nrm) & (nrm > 0)):
            raise ValueError("q: quaternions must have a finite, non-zero norm")
        q = q / nrm
    if q.ndim == 1:
        return np.array(_matrix_rows(*q.tolist()))
    rows = _matrix_rows(*np.moveaxis(q, -1, 0))
    return np.stack([np.stack(row, -1) for row in rows], axis=-2)


def quat_from_matrix(R: np.ndarray) -> np.ndarray:
    r"""Unit quaternion ``[w, x, y, z]`` (``(..., 4)``, ``w ≥ 0``) of rotation matrices ``(..., 3, 3)``.

    Uses the symmetric 4×4 matrix :math:`K = 4\,q q^{\mathsf T}` built from the entries of ``R``
    (Shepperd / Bar-Itzhack) and its column with the largest diagonal entry, which is
    well-conditioned for every rotation. The sign is fixed so that ``w ≥ 0``.
    """
    R = np.asarray(R, dtype=float)
    if R.ndim < 2 or R.shape[-2:] != (3, 3):
        raise ValueError(f"R: expected shape (..., 3, 3), got {R.shape}")
    r00, r01, r02 = R[..., 0, 0], R[..., 0, 1], R[..., 0, 2]
    r10, r11, r12 = R[..., 1, 0], R[..., 1, 1], R[..., 1, 2]
    r20, r21, r22 = R[..., 2, 0], R[..., 2, 1], R[..., 2, 2]
    K = np.stack(
        [
            np.stack([1 + r00 + r11 + r22, r21 - r12, r02 - r20, r10 - r01], -1),
            np.stack([r21 - r12, 1 + r00 - r11 - r22, r01 + r10, r02 + r20], -1),
            np.stack([r02 - r20, r01 + r10, 1 - r00 + r11 - r22, r12 + r21], -1),
            np.stack([r10 - r01, r02 + r20, r12 + r21, 1 - r00 - r11 + r22], -1),
        ],
        axis=-2,
    )
    m = np.argmax(np.diagonal(K, axis1=-2, axis2=-1), axis=-1)
    col = np.take_along_axis(K, m[..., None, None].repeat(4, axis=-2), axis=-1)[..., 0]
    q = col / np.linalg.norm(col, axis=-1, keepdims=True)
    return np.where(q[..., :1] < 0, -q, q)


def quat_from_axis_angle(axis: np.ndarray, angle_rad: np.ndarray | float) -> np.ndarray:
    """``q = [cos(θ/2), sin(θ/2) n̂]`` for axes ``(..., 3)`` (normalised here) and angles ``θ`` [rad].

    Axes and angles broadcast; a zero or non-finite axis is a ``ValueError`` naming ``axis``.
    """
    n = np.asarray(axis, dtype=float)
    if n.shape[-1:] != (3,):
        raise ValueError(f"axis: expected shape (..., 3), got {n.shape}")
    nrm = np.linalg.norm(n, axis=-1, keepdims=True)
    if not np.all(np.isfinite(nrm) & (nrm > 0)):
        raise ValueError("axis: rotation axes must have a finite, non-zero norm")
    half = 0.5 * np.asarray(angle_rad, dtype=float)[..., None]
    vec = np.sin(half) * (n / nrm)
    w = np.broadcast_to(np.cos(half), vec.shape[:-1] + (1,))
    return np.concatenate([w, vec], axis=-1)


def quat_to_axis_angle(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit axes ``(..., 3)`` and angles ``θ = 2 atan2(|v|, |w|) ∈ [0, π]`` [rad] of quaternions.

    The sign of ``q`` is chosen with ``w ≥ 0`` (the shortest rotation); the identity returns the
    axis ``+x`` with ``θ = 0``.
    """
    q = np.asarray(q, dtype=float)
    if q.shape[-1:] != (4,):
        raise ValueError(f"q: expected shape (..., 4) [w, x, y, z], got {q.shape}")
    q = np.where(q[..., :1] < 0, -q, q)
    s = np.linalg.norm(q[..., 1:], axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s[..., 0], q[..., 0])
    unit_x = np.broadcast_to([1.0, 0.0, 0.0], q[..., 1:].shape)
    axis = np.where(s > 0, q[..., 1:] / np.where(s > 0, s, 1.0), unit_x)
    return axis, angle


def quat_z_to(v: np.ndarray) -> list[float]:
    """Shortest rotation taking ``+z`` onto the direction of the (3,) vector ``v`` (normalised here).

    ``q = [√((1 + c)/2), (ẑ × v̂)/(2w)]`` with ``c = ẑ·v̂``; for ``v̂ = −ẑ`` (``c < −1 + 10⁻¹²``)
    the half turn about ``+x``, ``[0, 1, 0, 0]``. Returned as a list (an MjSpec ``quat``).
    """
    v = np.asarray(v, dtype=float)
    v = v / np.linalg.norm(v)
    z = np.array([0.0, 0.0, 1.0])
    c = float(z @ v)
    if c < -1.0 + 1e-12:
        return [0.0, 1.0, 0.0, 0.0]
    axis = np.cross(z, v)
    w = math.sqrt(0.5 * (1.0 + c))
    xyz = axis / (2.0 * w)
    return [w, *xyz.tolist()]


def direction_quaternions(d: np.ndarray) -> np.ndarray:
    """(T, 4) quaternions rotating ``+z`` onto the directions ``d`` (T, 3) (normalised here).

    ``q = [w, −d̂_y/(2w), d̂_x/(2w), 0]`` with ``w = √((1 + d̂_z)/2)`` (the rotation about
    ``ẑ × d̂``), renormalised; directions with ``w ≤ 10⁻⁸`` (antiparallel to ``+z``) take the half
    turn about ``+x``, ``[0, 1, 0, 0]``; a zero direction gives the identity.
    """
    d = np.asarray(d, dtype=float)
    if d.ndim != 2 or d.shape[1] != 3:
        raise ValueError(f"d: expected shape (T, 3), got {d.shape}")
    d = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
    c = d[:, 2]
    w = np.sqrt(np.maximum(0.5 * (1.0 + c), 0.0))
    q = np.zeros((len(d), 4))
    ok = w > 1e-8
    q[ok, 0] = w[ok]
    q[ok, 1] = -d[ok, 1] / (2 * w[ok])
    q[ok, 2] = d[ok, 0] / (2 * w[ok])
    q[~ok] = [0.0, 1.0, 0.0, 0.0]
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def error_quaternion(q_ref: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``q_e = q_ref* ⊗ q`` with a non-negative scalar part; ``(4,)`` or ``(..., 4)``."""
    qe = quat_mul(quat_conj(q_ref), q)
    if qe.ndim == 1:
        return -qe if qe[0] < 0.0 else qe
    return np.where(qe[..., :1] < 0.0, -qe, qe)


def quat_angle(q: np.ndarray) -> np.ndarray:
    """Rotation angle ``2 atan2(|q_xyz|, |q_w|)`` ∈ [0, π] [rad] of unit quaternions ``(..., 4)``.

    The same angle as ``2 arccos|q_w|`` but accurate at every size: near zero ``arccos`` of a
    number next to 1 keeps only about 1e-8 rad of absolute precision (a 1e-6 rad error would be
    known to 1 %), the arctangent keeps full relative precision.
    """
    q = np.asarray(q, dtype=float)
    return 2.0 * np.arctan2(np.linalg.norm(q[..., 1:], axis=-1), np.abs(q[..., 0]))
