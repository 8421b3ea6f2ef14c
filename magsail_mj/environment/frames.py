"""Frames: ECI ↔ ECEF, geocentric spherical coordinates, orbital frames, quaternions.

Conventions:

* **ECI**: Earth-centred inertial, z along the rotation axis, x to the (mean) equinox.
  Precession and nutation are neglected, so ECI is the mean equator and equinox *of date*; it is
  the frame in which the GMST rotation and the low-precision Sun ephemeris are consistent.
* **ECEF** = R_z(θ_GMST) · ECI, i.e. ``r_ecef = R3(θ) r_eci`` with the passive rotation
  ``R3(θ) = [[c, s, 0], [−s, c, 0], [0, 0, 1]]``.
* **Geocentric spherical**: radius r, colatitude θ ∈ [0, π] from +z, east longitude φ from
  ECEF +x. Unit vectors ê_r, ê_θ (south), ê_φ (east), as ``ppigrf.igrf_gc`` returns them.
* **Orbital frame R** of the CNUSAIL paper (its "LVLH"):
  ẑ_R = r̂ (zenith), ŷ_R = (v × r)/|v × r| (negative orbit normal), x̂_R = ŷ_R × ẑ_R (≈ −v̂).
* **LVLH** (common form): x̂ = r̂ (radial out), ẑ = ĥ (orbit normal), ŷ = ẑ × x̂ (≈ +v̂).
* Quaternions are scalar-first ``[w, x, y, z]`` and rotate body components into world
  components (``v_world = R(q) v_body``), as MuJoCo's ``xquat``/``xmat``.

All functions are vectorised over leading axes.
"""

from __future__ import annotations

import numpy as np

from magsail_mj.quaternion import quat_to_matrix

__all__ = [
    "rot_z",
    "eci_to_ecef",
    "ecef_to_eci",
    "cartesian_to_spherical",
    "spherical_to_cartesian",
    "spherical_vector_to_cartesian",
    "orbital_frame_R",
    "lvlh_frame",
    "quat_to_mat",
]


def rot_z(theta: float | np.ndarray) -> np.ndarray:
    """Passive rotation about z: ``R3(θ) = [[c, s, 0], [−s, c, 0], [0, 0, 1]]`` (shape (..., 3, 3)).

    ``R3(θ) v`` gives the components of ``v`` in a frame turned by +θ about z.
    """
    th = np.asarray(theta, dtype=float)
    c, s = np.cos(th), np.sin(th)
    z, o = np.zeros_like(th), np.ones_like(th)
    return np.stack([np.stack([c, s, z], -1), np.stack([-s, c, z], -1), np.stack([z, z, o], -1)], -2)


def eci_to_ecef(v_eci: np.ndarray, gmst: float | np.ndarray) -> np.ndarray:
    """ECEF components of ECI vectors: ``v_ecef = R3(θ_GMST) v_eci`` (vectorised: (..., 3), (...))."""
    v = np.asarray(v_eci, dtype=float)
    th = np.asarray(gmst, dtype=float)
    c, s = np.cos(th), np.sin(th)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([c * x + s * y, -s * x + c * y, np.broadcast_to(z, np.broadcast(x, c).shape)], -1)


def ecef_to_eci(v_ecef: np.ndarray, gmst: float | np.ndarray) -> np.ndarray:
    """ECI components of ECEF vectors: ``v_eci = R3(−θ_GMST) v_ecef`` (inverse of :func:`eci_to_ecef`)."""
    return eci_to_ecef(v_ecef, -np.asarray(gmst, dtype=float))


def cartesian_to_spherical(r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Radius [same unit as ``r``], colatitude θ [rad] in [0, π] and east longitude φ [rad] in
    (−π, π] of Cartesian points ``r`` (..., 3)."""
    r = np.asarray(r, dtype=float)
    rho = np.hypot(r[..., 0], r[..., 1])
    rad = np.hypot(rho, r[..., 2])
    colat = np.arctan2(rho, r[..., 2])
    lon = np.arctan2(r[..., 1], r[..., 0])
    return rad, colat, lon


def spherical_to_cartesian(rad: np.ndarray, colat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """Cartesian point (..., 3) of radius ``rad``, colatitude and east longitude [rad]."""
    st = np.sin(colat)
    return np.stack([rad * st * np.cos(lon), rad * st * np.sin(lon), rad * np.cos(colat)], -1)


def spherical_vector_to_cartesian(
    v_r: np.ndarray, v_theta: np.ndarray, v_phi: np.ndarray, colat: np.ndarray, lon: np.ndarray
) -> np.ndarray:
    """Cartesian components of a vector given by its (ê_r, ê_θ south, ê_φ east) components at the
    point (colat, lon):

    ê_r = (sinθ cosφ, sinθ sinφ, cosθ), ê_θ = (cosθ cosφ, cosθ sinφ, −sinθ), ê_φ = (−sinφ, cosφ, 0).
    """
    st, ct = np.sin(colat), np.cos(colat)
    sp, cp = np.sin(lon), np.cos(lon)
    x = v_r * st * cp + v_theta * ct * cp - v_phi * sp
    y = v_r * st * sp + v_theta * ct * sp + v_phi * cp
    z = v_r * ct - v_theta * st
    return np.stack([x, y, z], -1)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def orbital_frame_R(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Matrix ``R_i/o`` (..., 3, 3) whose rows are x̂_R, ŷ_R, ẑ_R in ECI components (Yoo et al. 2016,
    Eq. 4, with the normalisation the printed form lacks): ẑ_R = r̂, ŷ_R = (v × r)/|v × r|,
    x̂_R = ŷ_R × ẑ_R. ``R_i/o @ v_eci`` gives R-frame components."""
    z = _unit(np.asarray(r, dtype=float))
    y = _unit(np.cross(v, r))
    x = np.cross(y, z)
    return np.stack([x, y, z], -2)


def lvlh_frame(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rows x̂ = r̂, ŷ = ẑ × x̂ (along track), ẑ = ĥ = (r × v)/|r × v| in ECI components (..., 3, 3)."""
    x = _unit(np.asarray(r, dtype=float))
    z = _unit(np.cross(r, v))
    y = np.cross(z, x)
    return np.stack([x, y, z], -2)


def quat_to_mat(q: np.ndarray) -> np.ndarray:
    """Alias of :func:`magsail_mj.quaternion.quat_to_matrix` with ``normalise=True`` (body → world
    rotation matrices (..., 3, 3) of scalar-first quaternions (..., 4)); kept until its callers
    import the quaternion module."""
    return quat_to_matrix(q, normalise=True)
