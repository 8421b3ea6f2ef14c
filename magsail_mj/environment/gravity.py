"""Gravity: point-mass and J2 accelerations, the exact tidal acceleration of the
orbit-following world, and the classical gravity-gradient torque.

Frames: all vectors in ECI components (the MuJoCo world axes are parallel to ECI).
Units: m, s, kg.
"""

from __future__ import annotations

import math

import numpy as np

from magsail_mj.vec3 import cross3

from magsail_mj.environment.constants import J2_EARTH, MU_EARTH, R_J2

__all__ = [
    "point_mass_acceleration",
    "j2_acceleration",
    "gravity_acceleration",
    "tidal_acceleration",
    "tidal_acceleration_linear",
    "gravity_gradient_torque",
]


def point_mass_acceleration(r: np.ndarray, *, mu: float = MU_EARTH) -> np.ndarray:
    """g(r) = −μ r/|r|³ for points ``r`` (..., 3) [m] → [m/s²]."""
    r = np.asarray(r, dtype=float)
    rn = np.linalg.norm(r, axis=-1, keepdims=True)
    return -mu * r / rn**3


def j2_acceleration(r: np.ndarray, *, mu: float = MU_EARTH, J2: float = J2_EARTH, R: float = R_J2) -> np.ndarray:
    """J2 part of the geopotential acceleration, ECI = Earth axes along z:

    a_J2 = (3/2) J2 μ R² / r⁵ · [x(5z²/r² − 1), y(5z²/r² − 1), z(5z²/r² − 3)].
    """
    r = np.asarray(r, dtype=float)
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    r2 = x * x + y * y + z * z
    k = 1.5 * J2 * mu * R * R / (r2 * r2 * np.sqrt(r2))
    f = 5.0 * z * z / r2
    return np.stack([k * x * (f - 1.0), k * y * (f - 1.0), k * z * (f - 3.0)], -1)


def gravity_acceleration(
    r: np.ndarray, *, mu: float = MU_EARTH, j2: bool = False, J2: float = J2_EARTH, R: float = R_J2
) -> np.ndarray:
    """Two-body acceleration, plus the J2 term when ``j2`` is true [m/s²]."""
    a = point_mass_acceleration(r, mu=mu)
    if j2:
        a = a + j2_acceleration(r, mu=mu, J2=J2, R=R)
    return a


def tidal_acceleration(
    r_ref: np.ndarray,
    x: np.ndarray,
    *,
    mu: float = MU_EARTH,
    j2: bool = False,
    J2: float = J2_EARTH,
    R: float = R_J2,
) -> np.ndarray:
    """Exact tidal acceleration a(x) = g(r_ref + x) − g(r_ref) of points at world positions
    ``x`` (n, 3) relative to the reference point ``r_ref`` (3,) [m] → (n, 3) [m/s²].

    Two-body part in a cancellation-free form (the orbit-following frame). With
    R = r + x and q = (2 r·x + |x|²)/|r|² (so |R|² = |r|²(1 + q)):

        g(R) − g(r) = −μ/|R|³ · [x − r · f(q)],   f(q) = (1 + q)^{3/2} − 1,   |R|³ = |r|³ (1 + f),

    which is exact algebra. f is evaluated without cancellation: by its binomial series when
    |q| ≤ 1e-3 (the usual case, cheaper) and as expm1(1.5·log1p(q)) otherwise; both keep full
    relative precision when |x| ≪ |r| (the naive difference of two ~8 m/s² vectors loses
    ~log10(|r|/|x|) digits). The J2 part is a
    difference of terms ~1e-3 g and is formed directly: its rounding error (~1e-18 m/s²) stays far
    below the J2 gradient itself (~1e-3 of the two-body gradient).
    """
    r = np.asarray(r_ref, dtype=float)
    x = np.asarray(x, dtype=float)
    r2 = float(r @ r)
    q, f = _q_and_f(r, x, r2)
    k = mu / (r2 * math.sqrt(r2))
    a = (k / (1.0 + f))[:, None] * (f[:, None] * r - x)  # −μ/|R|³ (x − f r), |R|³ = |r|³ (1 + f)
    if j2:
        a = a + (j2_acceleration(r + x, mu=mu, J2=J2, R=R) - j2_acceleration(r, mu=mu, J2=J2, R=R))
    return a


_ONES3 = np.ones(3)
_SERIES_Q_MAX = 1e-3


def _q_and_f(r: np.ndarray, x: np.ndarray, r2: float) -> tuple[np.ndarray, np.ndarray]:
    """q = (2 r·x + |x|²)/|r|² and f(q) = (1 + q)^{3/2} − 1 for points ``x`` (n, 3).

    For max|q| ≤ 1e-3 (|x| ≲ 3 km in LEO) f is the binomial series to q⁵,
    1.5 q + 0.375 q² − 0.0625 q³ + 0.0234375 q⁴ − 0.01171875 q⁵, whose truncation error
    (< 0.007 q⁶ < 1e-20) is far below double rounding; otherwise expm1(1.5 log1p(q)).
    """
    q = (2.0 * (x @ r) + (x * x) @ _ONES3) * (1.0 / r2)
    qmax = max(float(q.max()), -float(q.min())) if len(q) else 0.0
    if qmax <= _SERIES_Q_MAX:
        f = q * (1.5 + q * (0.375 + q * (-0.0625 + q * (0.0234375 - 0.01171875 * q))))
    else:
        f = np.expm1(1.5 * np.log1p(q))
    return q, f


def tidal_acceleration_linear(r_ref: np.ndarray, x: np.ndarray, *, mu: float = MU_EARTH) -> np.ndarray:
    """First-order (gravity-gradient) tidal acceleration μ/|r|³ (3 (r̂·x) r̂ − x) (n, 3) [m/s²].

    Its error relative to :func:`tidal_acceleration` is O(|x|/|r|); used for checks only.
    """
    r = np.asarray(r_ref, dtype=float)
    x = np.asarray(x, dtype=float)
    rn = np.linalg.norm(r)
    u = r / rn
    return mu / rn**3 * (3.0 * (x @ u)[:, None] * u - x)


def gravity_gradient_torque(r: np.ndarray, inertia: np.ndarray, *, mu: float = MU_EARTH) -> np.ndarray:
    """Classical gravity-gradient torque on a rigid body about its centre of mass (CNUSAIL Eq. 12):

        T = 3μ/|r|³ · û × (I û),   û = r/|r|,

    with ``r`` (3,) the geocentric position of the centre of mass and ``inertia`` (3, 3) the
    inertia tensor about the centre of mass, both in the **same** frame (e.g. world/ECI
    components with ``I_w = R I_body Rᵀ``, or body components with û in body components); the
    torque comes out in that frame [N m]. The sign of û does not matter.
    """
    r = np.asarray(r, dtype=float)
    rn = np.linalg.norm(r)
    u = r / rn
    if u.shape == (3,):
        return 3.0 * mu / rn**3 * cross3(u, np.asarray(inertia, dtype=float) @ u)
    return 3.0 * mu / rn**3 * np.cross(u, np.asarray(inertia, dtype=float) @ u)
