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
* **Non-monotonic Lyapunov law** (:func:`nonmonotonic_dipole`; Willis, Fisch, Seletskiy and
  Manchester 2024, "Building a Better B-Dot: Fast Detumbling with Non-Monotonic Lyapunov
  Functions", IEEE Aerospace Conference, arXiv 2407.02724). The stored text of the paper reaches
  only its abstract and the start of its introduction, so its equation numbers cannot be cited
  here; the law is implemented from the authors' code (repository
  ``RoboticExplorationLab/non-monotonic-detumbling``, ``src/detumble_controller.jl``:
  ``blookahead_core`` with the field table read ahead, ``setup_blookahead_control``) with the gains
  of their Monte Carlo script (``final/monte_carlo_controllers.jl``: k = 3e3, α = 100, look-ahead
  600 s). With the body momentum ``h = J ω`` [N m s], the field now B₁ and the field ahead B₂ (the
  reference orbit's field a look-ahead time T later, in today's body axes: read from the field
  table at t + T, or extrapolated as ``B(t) + T Ḃ(t)`` from the orbit field's rate at t, which is
  what the authors' Monte Carlo does — ``control.nonmonotonic_field_ahead``), ``b₁ = B₁/‖B₁‖`` and
  ``b₂ = B₂/‖B₁‖`` (both scaled by the present magnitude, as the authors' code does), the two-step
  control ``ū = (u₁, u₂)`` minimises

      ½‖ū‖² + ½‖h − [b₁]× u₁‖² + (α/2)‖h − [b₁]× u₁ − [b₂]× u₂‖²,

  a momentum ``V = ½‖h‖²`` that must fall over the two steps on average (``α`` weights the second)
  but may rise on the first: the optimum solves the 6×6 system

      (I₆ + Z b̄ b̄ᵀ Z + α b̄ b̄ᵀ) ū = (Z + α I₆) b̄ h,   b̄ = [[b₁]×ᵀ; [b₂]×ᵀ],  Z = diag(I₃, 0),

  (``b̄ h = (h × b₁, h × b₂)``) and the dipole is ``m = m_max ⊙ tanh(k u₁)`` per axis. Special case
  (tested): with α = 0 and a unit b₁, ``I₃ + [b₁]×ᵀ[b₁]× = 2 I₃ − b₁b₁ᵀ`` and ``h × b₁ ⊥ b₁``, so
  ``u₁ = ½ h × b₁`` and the law is the saturated momentum B×ω law ``m = m_max ⊙ tanh(½ k h × b̂)``,
  whose every component has the sign of ``(h × B)_i`` and so ``h·τ ≤ 0``. For any α the optimum
  does not exceed the cost of ū = 0: ``½‖ū‖² + ½‖h₁‖² + (α/2)‖h₂‖² ≤ ½ (1 + α)‖h‖²`` (tested).

  The authors' Monte Carlo numbers are not in the stored text of the paper either; their
  repository's figure files (``figs/detumble_time_cumulative_no_noise_30deg_s.tikz`` and
  ``…_noisy_30deg_s.tikz``, 100 trials, 400 km circular orbits at 20–160° inclination, 30 °/s
  initial rate, 2 h runs, detumbled when ‖h‖ falls to 1 % of its start) mark 50 % of the runs
  detumbled at 0.60 h with this law (B-dot 1.54 h, B-cross 1.78 h, projection-based 0.88 h) and
  100 % at 1.56 h without sensor noise, 1.82 h with it (B-dot 73 %, B-cross 55 % within the 2 h).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "bang_bang_dipole",
    "avanzini_giulietti_gain",
    "geomagnetic_inclination_rad",
    "bcross_dipole",
    "nonmonotonic_dipole",
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


def nonmonotonic_dipole(
    omega_rad_s: np.ndarray,
    B_now_T: np.ndarray,
    B_ahead_T: np.ndarray,
    inertia_kgm2: np.ndarray,
    *,
    gain_per_Nms: float | np.ndarray,
    alpha: float | np.ndarray,
    m_max_Am2: np.ndarray,
) -> np.ndarray:
    """Willis et al.'s non-monotonic law (module docstring) for stacks ``(N, 3)`` of body rates
    [rad/s], present fields and fields ahead [T] (body axes) and inertias ``(N, 3, 3)`` [kg m²]:
    the dipole ``m = m_max ⊙ tanh(k u₁)`` [A m²] (``(N, 3)``), zero where B₁ = 0. ``gain_per_Nms``
    (k [1/(N m s)]) and ``alpha`` (α) are scalars or ``(N, 1)``; ``m_max_Am2`` is ``(3,)`` or
    ``(N, 3)``."""
    w = np.asarray(omega_rad_s, dtype=float)
    B1 = np.asarray(B_now_T, dtype=float)
    B2 = np.asarray(B_ahead_T, dtype=float)
    J = np.asarray(inertia_kgm2, dtype=float)
    n = B1.shape[0]
    h = np.stack([J[:, i, 0] * w[:, 0] + J[:, i, 1] * w[:, 1] + J[:, i, 2] * w[:, 2] for i in range(3)], axis=-1)
    n1 = np.sqrt(_norm_sq(B1))[:, None]
    some = n1 > 0.0
    inv = np.where(some, 1.0 / np.where(some, n1, 1.0), 0.0)
    b = (B1 * inv, B2 * inv)
    a = np.broadcast_to(np.asarray(alpha, dtype=float), (n, 1))[:, 0]
    # [b_i]×ᵀ... blocks of b̄ b̄ᵀ: [b_i]× [b_j]×ᵀ = (b_i·b_j) I − b_j b_iᵀ, entry (r, c)
    M = np.zeros((n, 6, 6))
    weight = ((1.0 + a, a), (a, a))  # Z b̄ b̄ᵀ Z adds the (1, 1) block once more
    for i in range(2):
        for j in range(2):
            bi, bj = b[i], b[j]
            dot = bi[:, 0] * bj[:, 0] + bi[:, 1] * bj[:, 1] + bi[:, 2] * bj[:, 2]
            for r in range(3):
                for c in range(3):
                    entry = (dot if r == c else 0.0) - bj[:, r] * bi[:, c]
                    M[:, 3 * i + r, 3 * j + c] = weight[i][j] * entry
    M[:, range(6), range(6)] += 1.0
    rhs = np.concatenate(((1.0 + a)[:, None] * _cross(h, b[0]), a[:, None] * _cross(h, b[1])), axis=1)
    u = np.linalg.solve(M, rhs[:, :, None])[:, :3, 0]
    m = np.asarray(m_max_Am2, dtype=float) * np.tanh(gain_per_Nms * u)
    return np.where(some, m, 0.0)
