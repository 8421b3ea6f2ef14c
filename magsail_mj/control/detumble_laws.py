r"""Magnetic detumble laws beside the proportional B-dot (:mod:`magsail_mj.control.bdot`).

Every function works on stacks of body-axis vectors (``(..., 3)``, one row per spacecraft) with
component arithmetic only (no reductions through BLAS), so a batch of worlds and a single run that
calls it with one row get the same bits. The torque of a dipole m [A m²] in the field B [T] is
``τ = m × B`` (body axes); a stationary field seen from a body turning at ω has ``Ḃ_B = −ω × B_B``.

* **Bang-bang B-dot** (:func:`bang_bang_dipole`): ``m_i = −m_max,i sign(Ḃ_i)`` per axis, with the
  Ḃ estimate of the proportional law (finite difference or filtered). For the exact Ḃ = −ω × B,
  ``τ·ω = m·(B × ω) = −Σ m_max,i |(ω × B)_i| ≤ 0``: the coils take kinetic energy out at every
  instant, at full dipole on every axis where Ḃ is not zero.
* **B×ω law with Avanzini & Giulietti's gain** (:func:`bcross_dipole`, :func:`avanzini_giulietti_gain`;
  Avanzini and Giulietti 2012, "Magnetic detumbling of a rigid spacecraft", JGCD 35(4), the law as
  Markley and Crassidis 2014 write it, Eq. 7.48): ``m = (k/‖B‖) ω × b̂ = k (ω × B)/‖B‖²``, so that
  ``τ = m × B = −k (ω − (ω·b̂) b̂)`` and ``τ·ω = −k (|ω|² − (ω·b̂)²) ≤ 0``. The gain of their
  criterion for a quasi-minimum detumble time is ``k = 2 n (1 + sin ξ_m) J_min`` [N m s], n the
  orbital mean motion [rad/s], ξ_m the inclination of the orbit to the geomagnetic equator and
  J_min the smallest principal moment of inertia [kg m²]. (Written ``(k/‖B‖) b̂ × ω`` the law has
  the other torque sign for ``τ = m × B``; the sign here is the dissipative one.) The caller clips
  each axis to its limit, as the proportional law; clipping keeps the sign of every component, so
  ``τ·ω ≤ 0`` still holds.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "bang_bang_dipole",
    "avanzini_giulietti_gain",
    "geomagnetic_inclination_rad",
    "bcross_dipole",
]


def bang_bang_dipole(B_dot: np.ndarray, m_max_Am2: np.ndarray) -> np.ndarray:
    """Bang-bang B-dot ``m_i = −m_max,i sign(Ḃ_i)`` [A m²] for the field rate ``B_dot`` [T/s]
    (body axes, ``(..., 3)``): full dipole on every axis whose Ḃ is not zero, none where it is."""
    return -np.asarray(m_max_Am2, dtype=float) * np.sign(B_dot)


def avanzini_giulietti_gain(*, mean_motion_rad_s: float, xi_m_rad: float, J_min_kgm2: float) -> float:
    """Avanzini & Giulietti's gain ``k = 2 n (1 + sin ξ_m) J_min`` [N m s] for the B×ω law
    (module docstring): n the mean motion [rad/s], ξ_m the orbit's inclination to the geomagnetic
    equator [rad], J_min the smallest principal moment of inertia [kg m²]."""
    for name, value in (("mean_motion_rad_s", mean_motion_rad_s), ("J_min_kgm2", J_min_kgm2)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name}: must be a finite number > 0, got {value!r}")
    if not math.isfinite(xi_m_rad):
        raise ValueError(f"xi_m_rad: must be finite, got {xi_m_rad!r}")
    return 2.0 * mean_motion_rad_s * (1.0 + math.sin(xi_m_rad)) * J_min_kgm2


def geomagnetic_inclination_rad(r_m: np.ndarray, v_m_s: np.ndarray, dipole_axis: np.ndarray) -> float:
    """Inclination ξ_m ∈ [0, π/2] [rad] of the orbit plane (position ``r_m`` [m], velocity ``v_m_s``
    [m/s]) to the magnetic equator of a dipole whose axis is ``dipole_axis`` (same frame, any
    length): ``cos ξ_m = |ĥ·â|`` with ĥ the orbit normal r × v."""
    h = np.cross(np.asarray(r_m, dtype=float), np.asarray(v_m_s, dtype=float))
    a = np.asarray(dipole_axis, dtype=float)
    hn, an = float(np.linalg.norm(h)), float(np.linalg.norm(a))
    if not (hn > 0 and an > 0):
        raise ValueError(f"r_m, v_m_s, dipole_axis: need a non-zero orbit normal and axis, got |h| = {hn}, |a| = {an}")
    return math.acos(min(1.0, abs(float(h @ a)) / (hn * an)))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a × b`` per row of ``(..., 3)`` stacks, by components."""
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    return np.stack((ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx), axis=-1)


def _norm_sq(a: np.ndarray) -> np.ndarray:
    return a[..., 0] * a[..., 0] + a[..., 1] * a[..., 1] + a[..., 2] * a[..., 2]


def bcross_dipole(omega_rad_s: np.ndarray, B_T: np.ndarray, *, k_Nms: float | np.ndarray) -> np.ndarray:
    """B×ω law ``m = k (ω × B)/‖B‖²`` [A m²] (unsaturated; module docstring) for body rates
    ``omega_rad_s`` and fields ``B_T`` (``(..., 3)``, body axes) and gain ``k_Nms`` [N m s]
    (scalar, or ``(..., 1)`` per row); zero where B = 0."""
    omega = np.asarray(omega_rad_s, dtype=float)
    B = np.asarray(B_T, dtype=float)
    n2 = _norm_sq(B)[..., None]
    some = n2 > 0.0
    scale = np.where(some, k_Nms / np.where(some, n2, 1.0), 0.0)
    return _cross(omega, B) * scale
