r"""Reflector pitch steering (paper Eqs. 9–13): orbit and ground-point
kinematics, the dipole field along the orbit, ψ(t) with its first two derivatives, and the
reference attitude.

Frame ``xyz`` (= the MuJoCo world axes): Earth-centred, ``+y`` towards the Sun (the orbit
normal of the dawn–dusk polar orbit), orbital plane ``xz``, Earth spin and dipole axis ``z``.

.. math::

   \mathbf r = r(\cos\theta, 0, \sin\theta),\ \theta = \theta_0 + n t \quad (9),\qquad
   \mathbf R = R_e(\cos\phi, \sin\phi, 0),\ \phi = \omega_e t + \phi_0 \quad (10),

with ``n = √(μ/r³)``, ``θ₀ = −n t_m``, ``φ₀ = −ω_e t_m`` (ground point directly below the
reflector at ``t_m``, half the nominal run). Dipole field (Eq. 11), polar components
``B_r = −2B₀(R_e/r)³ sin θ``, ``B_θ = −B₀(R_e/r)³ cos θ``; world ``B = B_r ê_r + B_θ ê_θ`` with
``ê_r = (cos θ, 0, sin θ)``, ``ê_θ = (−sin θ, 0, cos θ)``.

Steering law (Eqs. 12–13): with ``a = r cos θ − R_e cos φ``, ``b = r sin θ`` (the in-plane
components of ``r_rad = r − R``)

.. math::

   \psi = \tfrac\pi2 - \arctan(a/b),\qquad \dot\psi = P/Q,\qquad
   \ddot\psi = (\dot P Q - P\dot Q)/Q^2,

   P = -rR_e\omega_e\sin\phi\sin\theta + rn(r - R_e\cos\phi\cos\theta),\quad Q = a^2 + b^2,

   \dot P = rR_e(n^2-\omega_e^2)\sin\theta\cos\phi,\quad
   \dot Q = -R_e^2\omega_e\sin2\phi + 2rR_e(n\sin\theta\cos\phi + \omega_e\sin\phi\cos\theta).

Branch handling: ``ε = atan2(a, b)`` is unwrapped in time and ``ψ_c = π/2 − unwrap(ε)`` is the
continuous reference (``ψ_c ≡ ψ mod π``; ``dψ_c/dt`` = Eq. 13 everywhere). Reference attitude
(A7): rotation about world ``+y`` by ``β_ref = π/2 − ψ_c = unwrap(ε)``,
``q_ref = [cos(β_ref/2), 0, sin(β_ref/2), 0]`` (scalar first, body → world), so body ``x`` (the
grey line) is perpendicular to ``(a, 0, b)`` and body ``z`` (plate normal) lies along it;
``ω_ref = −ψ̇ ŷ``, ``α_ref = −ψ̈ ŷ``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from magsail_mj.quaternion import quat_from_axis_angle
from magsail_mj.checkpoint import restorable

__all__ = [
    "ReflectorOrbit",
    "SteeringState",
    "SteeringReference",
    "pitch_reference_quaternion",
    "pitch_angle_from_quaternion",
]

DAY_S = 86400.0


@dataclass(frozen=True)
class ReflectorOrbit:
    """Circular polar orbit and equatorial ground point (Robb et al. 2020, Eqs. 9–10; SI units).

    Attributes:
      r_m: orbit radius ``R_e + altitude`` [m].
      R_e_m: Earth radius (A4: 6 371 km) [m].
      mu_m3_s2: gravitational parameter [m³/s²].
      omega_e_rad_s: ground-point rate in the Sun-fixed frame (A5: 2π/86 400 s⁻¹) [rad/s].
      t_mid_s: time of the overhead pass [s] (half the nominal run, ``n_orbits T_orb / 2``).
      B0_T: dipole field at the surface on the magnetic equator [T].
    """

    r_m: float
    R_e_m: float
    mu_m3_s2: float
    omega_e_rad_s: float
    t_mid_s: float
    B0_T: float = 3.12e-5

    @classmethod
    def from_altitude(
        cls,
        *,
        altitude_m: float,
        R_e_m: float = 6.371e6,
        mu_m3_s2: float = 3.986004418e14,
        omega_e_rad_s: float = 2 * math.pi / DAY_S,
        n_orbits: float = 10.0,
        B0_T: float = 3.12e-5,
    ) -> "ReflectorOrbit":
        """Orbit of altitude ``altitude_m`` whose overhead pass is at half of ``n_orbits`` periods."""
        for name, v in (("altitude_m", altitude_m), ("R_e_m", R_e_m), ("mu_m3_s2", mu_m3_s2), ("n_orbits", n_orbits)):
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name}: must be > 0, got {v!r}")
        r = R_e_m + altitude_m
        n = math.sqrt(mu_m3_s2 / r**3)
        return cls(
            r_m=r,
            R_e_m=R_e_m,
            mu_m3_s2=mu_m3_s2,
            omega_e_rad_s=omega_e_rad_s,
            t_mid_s=0.5 * n_orbits * 2 * math.pi / n,
            B0_T=B0_T,
        )

    @property
    def n_rad_s(self) -> float:
        """Mean motion ``n = √(μ/r³)`` [rad/s]."""
        return math.sqrt(self.mu_m3_s2 / self.r_m**3)

    @property
    def period_s(self) -> float:
        """Orbital period ``T_orb = 2π/n`` [s]."""
        return 2 * math.pi / self.n_rad_s

    def theta(self, t):
        """Orbit angle from the equator ``θ = n (t − t_m)`` [rad] (≡ θ₀ + n t)."""
        return self.n_rad_s * (np.asarray(t, dtype=float) - self.t_mid_s)

    def phi(self, t):
        """Ground-point longitude in the Sun-fixed frame ``φ = ω_e (t − t_m)`` [rad]."""
        return self.omega_e_rad_s * (np.asarray(t, dtype=float) - self.t_mid_s)

    def position(self, t) -> np.ndarray:
        """Reflector position ``r`` (Eq. 9), world axes [m], (..., 3)."""
        th = self.theta(t)
        return self.r_m * np.stack([np.cos(th), np.zeros_like(th), np.sin(th)], axis=-1)

    def ground_point(self, t) -> np.ndarray:
        """Ground point ``R`` (Eq. 10), world axes [m], (..., 3)."""
        ph = self.phi(t)
        return self.R_e_m * np.stack([np.cos(ph), np.sin(ph), np.zeros_like(ph)], axis=-1)

    def field(self, t) -> np.ndarray:
        """Dipole field ``B`` at the reflector (Eq. 11), world axes [T], (..., 3)."""
        if isinstance(t, float):
            return np.array(self._field_scalar(t))
        th = self.theta(t)
        k = self.B0_T * (self.R_e_m / self.r_m) ** 3
        Br, Bt = -2.0 * k * np.sin(th), -k * np.cos(th)
        c, s = np.cos(th), np.sin(th)
        return np.stack([Br * c - Bt * s, np.zeros_like(th), Br * s + Bt * c], axis=-1)

    def rates(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(ε, ψ̇, ψ̈, Q)``: wrapped ``ε = atan2(a, b)`` [rad], Eq. 13 [rad/s], ψ̈ [rad/s²], Q [m²].

        A Python float ``t`` is evaluated with :mod:`math` (the per-step path: the same operations
        in the same order, floats returned)."""
        scalar = isinstance(t, float)
        sin, cos, atan2 = (math.sin, math.cos, math.atan2) if scalar else (np.sin, np.cos, np.arctan2)
        n = self.n_rad_s
        if scalar:
            th, ph = n * (t - self.t_mid_s), self.omega_e_rad_s * (t - self.t_mid_s)
        else:
            th, ph = self.theta(t), self.phi(t)
        r, Re, we = self.r_m, self.R_e_m, self.omega_e_rad_s
        st, ct, sp, cp = sin(th), cos(th), sin(ph), cos(ph)
        a = r * ct - Re * cp
        b = r * st
        P = -r * Re * we * sp * st + r * n * (r - Re * cp * ct)
        Q = a * a + b * b
        Pd = r * Re * (n * n - we * we) * st * cp
        Qd = -Re * Re * we * sin(2 * ph) + 2 * r * Re * (n * st * cp + we * sp * ct)
        return atan2(a, b), P / Q, (Pd * Q - P * Qd) / (Q * Q), Q

    def _field_scalar(self, t: float) -> tuple[float, float, float]:
        """:meth:`field` at one float time, with :mod:`math` (same operations)."""
        th = self.n_rad_s * (t - self.t_mid_s)
        k = self.B0_T * (self.R_e_m / self.r_m) ** 3
        s, c = math.sin(th), math.cos(th)
        Br, Bt = -2.0 * k * s, -k * c
        return (Br * c - Bt * s, 0.0, Br * s + Bt * c)

    def psi_series(self, t: np.ndarray) -> dict[str, np.ndarray]:
        """Vectorised reference over increasing times ``t``: ``psi_c`` (continuous, unwrapped),
        ``psi_wrapped`` (Eq. 12 value in [0, π)), ``psi_dot``, ``psi_ddot``, ``beta_ref``.

        The unwrapping assumes consecutive samples closer than half a turn of ε (true for any
        sampling finer than a few minutes).
        """
        t = np.asarray(t, dtype=float)
        eps, pd, pdd, _ = self.rates(t)
        beta = np.unwrap(eps)
        psi_c = 0.5 * np.pi - beta
        return {"psi_c": psi_c, "psi_wrapped": np.mod(psi_c, np.pi), "psi_dot": pd, "psi_ddot": pdd, "beta_ref": beta}


@restorable
@dataclass
class SteeringState:
    """Reference at one time: ``beta_ref`` (unwrapped) [rad], ``psi_c`` [rad], ``psi_dot`` [rad/s],
    ``psi_ddot`` [rad/s²], ``q_ref`` (4,) scalar first."""

    beta_ref: float
    psi_c: float
    psi_dot: float
    psi_ddot: float
    q_ref: np.ndarray


class SteeringReference:
    """Online, unwrapped steering reference: call :meth:`at` with non-decreasing times.

    Each call unwraps ``ε = atan2(a, b)`` against the previous call (adds the multiple of 2π that
    keeps the jump below π), so ``β_ref`` is continuous; the state pickles with the controller,
    so a resumed run continues the same branch.
    """

    def __init__(self, orbit: ReflectorOrbit) -> None:
        self.orbit = orbit
        self._beta: float | None = None

    def at(self, t: float) -> SteeringState:
        eps, pd, pdd, _ = self.orbit.rates(t)
        eps = float(eps)
        if self._beta is None:
            beta = eps
        else:
            beta = eps + 2 * math.pi * round((self._beta - eps) / (2 * math.pi))
        self._beta = beta
        return SteeringState(
            beta_ref=beta,
            psi_c=0.5 * math.pi - beta,
            psi_dot=float(pd),
            psi_ddot=float(pdd),
            q_ref=pitch_reference_quaternion(beta),
        )


def pitch_reference_quaternion(beta):
    """``q = [cos(β/2), 0, sin(β/2), 0]``: rotation by β about +y (scalar first), (..., 4)."""
    if isinstance(beta, float):  # the per-step path: as quat_from_axis_angle, without array overhead
        h = 0.5 * beta
        s = math.sin(h)
        return np.array((math.cos(h), s * 0.0, s * 1.0, s * 0.0))
    return quat_from_axis_angle(np.array([0.0, 1.0, 0.0]), beta)


def pitch_angle_from_quaternion(q: np.ndarray) -> np.ndarray:
    """Unwrapped pitch ``β = atan2(R₁₃, R₁₁)`` of ``R(q)`` (1-based indices), (T,) from (T, 4)."""
    q = np.asarray(q, dtype=float)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R11 = 1 - 2 * (y * y + z * z)
    R13 = 2 * (x * z + w * y)
    return np.unwrap(np.arctan2(R13, R11))
