"""Reference orbit: classical elements, Kepler (two-body, analytic) and J2 (numerical) propagation.

The reference orbit ``r_ref(t)`` carries the origin of the orbit-following MuJoCo world.
Frames: ECI. Units: m, s, rad.

* Kepler: mean anomaly M = M0 + n t, n = √(μ/a³); Kepler's equation E − e sin E = M solved by
  Newton iteration to machine precision, vectorised over times.
* J2: Cowell integration of r̈ = −μ r/r³ + a_J2(r) with SciPy's DOP853,
  rtol 1e-12, dense output (any time can be sampled).

Secular J2 rates (first order; Vallado):

    Ω̇ = −(3/2) n J2 (R/p)² cos i,   ω̇ = (3/4) n J2 (R/p)² (5 cos² i − 1),   p = a(1 − e²).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.integrate import solve_ivp

from magsail_mj.environment.constants import J2_EARTH, MU_EARTH, R_J2
from magsail_mj.environment.gravity import gravity_acceleration

__all__ = [
    "OrbitalElements",
    "elements_to_state",
    "state_to_elements",
    "solve_kepler",
    "kepler_propagate",
    "j2_secular_rates",
    "sun_synchronous_inclination",
    "raan_from_ltdn",
    "ReferenceOrbit",
]


@dataclass(frozen=True)
class OrbitalElements:
    """Classical elements at the epoch (angles in rad, ``a`` in m).

    ``nu0`` is the true anomaly at t = 0; for a circular orbit ω is arbitrary and the argument
    of latitude u0 = ω + ν0 fixes the start.
    """

    a: float
    e: float
    i: float
    raan: float
    argp: float
    nu0: float

    def __post_init__(self) -> None:
        if not self.a > 0:
            raise ValueError(f"a: semi-major axis must be > 0 m, got {self.a!r}")
        if not 0.0 <= self.e < 1.0:
            raise ValueError(f"e: eccentricity must be in [0, 1) (closed orbits only), got {self.e!r}")
        if not 0.0 <= self.i <= math.pi:
            raise ValueError(f"i: inclination must be in [0, π] rad, got {self.i!r}")

    @classmethod
    def circular(
        cls, *, radius: float, inclination: float, raan: float = 0.0, arg_lat0: float = 0.0
    ) -> "OrbitalElements":
        """Circular orbit of geocentric ``radius`` [m] starting at argument of latitude ``arg_lat0``."""
        return cls(a=radius, e=0.0, i=inclination, raan=raan, argp=0.0, nu0=arg_lat0)

    def mean_motion(self, mu: float = MU_EARTH) -> float:
        """n = √(μ/a³) [rad/s]."""
        return math.sqrt(mu / self.a**3)

    def period(self, mu: float = MU_EARTH) -> float:
        """Two-body period 2π √(a³/μ) [s]."""
        return 2.0 * math.pi / self.mean_motion(mu)


def _anomalies_nu_to_M(nu: np.ndarray, e: float) -> np.ndarray:
    E = 2.0 * np.arctan2(np.sqrt(1.0 - e) * np.sin(nu / 2), np.sqrt(1.0 + e) * np.cos(nu / 2))
    return E - e * np.sin(E)


def solve_kepler(M: np.ndarray, e: float, *, tol: float = 1e-15, max_iter: int = 50) -> np.ndarray:
    """Eccentric anomaly E of mean anomaly ``M`` [rad] (vectorised) for 0 ≤ e < 1 (Newton)."""
    M = np.asarray(M, dtype=float)
    Mw = np.mod(M + np.pi, 2 * np.pi) - np.pi
    E = Mw + (e * np.sin(Mw) if e < 0.8 else e * np.sign(Mw) + 0 * Mw)
    for _ in range(max_iter):
        f = E - e * np.sin(E) - Mw
        dE = f / (1.0 - e * np.cos(E))
        E = E - dE
        if np.all(np.abs(dE) < tol):
            break
    return E + (M - Mw)


def _perifocal_to_eci(el: OrbitalElements) -> np.ndarray:
    cO, sO = math.cos(el.raan), math.sin(el.raan)
    ci, si = math.cos(el.i), math.sin(el.i)
    cw, sw = math.cos(el.argp), math.sin(el.argp)
    return np.array(
        [
            [cO * cw - sO * sw * ci, -cO * sw - sO * cw * ci, sO * si],
            [sO * cw + cO * sw * ci, -sO * sw + cO * cw * ci, -cO * si],
            [sw * si, cw * si, ci],
        ]
    )


def elements_to_state(
    el: OrbitalElements, nu: np.ndarray | float | None = None, *, mu: float = MU_EARTH
) -> tuple[np.ndarray, np.ndarray]:
    """ECI position [m] and velocity [m/s] at true anomaly ``nu`` (default ``el.nu0``).

    Perifocal: r = p/(1 + e cos ν) (cos ν, sin ν, 0), v = √(μ/p) (−sin ν, e + cos ν, 0),
    rotated by R3(−Ω) R1(−i) R3(−ω).
    """
    nu = np.asarray(el.nu0 if nu is None else nu, dtype=float)
    p = el.a * (1.0 - el.e**2)
    rr = p / (1.0 + el.e * np.cos(nu))
    r_pf = np.stack([rr * np.cos(nu), rr * np.sin(nu), np.zeros_like(nu)], -1)
    vk = math.sqrt(mu / p)
    v_pf = np.stack([-vk * np.sin(nu), vk * (el.e + np.cos(nu)), np.zeros_like(nu)], -1)
    Q = _perifocal_to_eci(el)
    return r_pf @ Q.T, v_pf @ Q.T


def state_to_elements(r: np.ndarray, v: np.ndarray, *, mu: float = MU_EARTH) -> dict[str, np.ndarray]:
    """Osculating elements of ECI states (vectorised over leading axes).

    Returns a dict with ``a`` [m], ``e``, ``i``, ``raan``, ``argp``, ``nu``, ``u`` (argument of
    latitude) [rad]; angles in [0, 2π). For e → 0, ``argp`` and ``nu`` are ill-defined but ``u`` is
    not; for i → 0, ``raan`` is ill-defined.
    """
    r = np.asarray(r, dtype=float)
    v = np.asarray(v, dtype=float)
    rn = np.linalg.norm(r, axis=-1)
    vn2 = np.einsum("...i,...i->...", v, v)
    h = np.cross(r, v)
    hn = np.linalg.norm(h, axis=-1)
    nvec = np.stack([-h[..., 1], h[..., 0], np.zeros_like(hn)], -1)
    nn = np.linalg.norm(nvec, axis=-1)
    evec = ((vn2 - mu / rn)[..., None] * r - np.einsum("...i,...i->...", r, v)[..., None] * v) / mu
    e = np.linalg.norm(evec, axis=-1)
    a = 1.0 / (2.0 / rn - vn2 / mu)
    i = np.arccos(np.clip(h[..., 2] / hn, -1, 1))
    raan = np.mod(np.arctan2(nvec[..., 1], nvec[..., 0]), 2 * np.pi)
    two_pi = 2 * np.pi
    # argument of perigee, angle from node to e-vector in the orbit plane
    hx = h / hn[..., None]
    nhat = nvec / np.where(nn > 0, nn, 1.0)[..., None]
    argp = np.mod(
        np.arctan2(np.einsum("...i,...i->...", np.cross(nhat, evec), hx), np.einsum("...i,...i->...", nhat, evec)),
        two_pi,
    )
    u = np.mod(
        np.arctan2(np.einsum("...i,...i->...", np.cross(nhat, r), hx), np.einsum("...i,...i->...", nhat, r)), two_pi
    )
    nu = np.mod(u - argp, two_pi)
    return {"a": a, "e": e, "i": i, "raan": raan, "argp": argp, "nu": nu, "u": u}


def kepler_propagate(
    el: OrbitalElements, t: np.ndarray | float, *, mu: float = MU_EARTH
) -> tuple[np.ndarray, np.ndarray]:
    """Two-body ECI state at times ``t`` [s] since the epoch (vectorised): (r (..., 3), v (..., 3))."""
    t = np.asarray(t, dtype=float)
    n = el.mean_motion(mu)
    M0 = float(_anomalies_nu_to_M(np.asarray(el.nu0), el.e))
    E = solve_kepler(M0 + n * t, el.e)
    nu = 2.0 * np.arctan2(np.sqrt(1.0 + el.e) * np.sin(E / 2), np.sqrt(1.0 - el.e) * np.cos(E / 2))
    return elements_to_state(el, nu, mu=mu)


def j2_secular_rates(
    el: OrbitalElements, *, mu: float = MU_EARTH, J2: float = J2_EARTH, R: float = R_J2
) -> tuple[float, float]:
    """First-order secular rates (Ω̇, ω̇) [rad/s] of the node and perigee under J2 (module docstring)."""
    n = el.mean_motion(mu)
    p = el.a * (1.0 - el.e**2)
    k = n * J2 * (R / p) ** 2
    ci = math.cos(el.i)
    return -1.5 * k * ci, 0.75 * k * (5.0 * ci * ci - 1.0)


def sun_synchronous_inclination(
    a: float, e: float = 0.0, *, mu: float = MU_EARTH, J2: float = J2_EARTH, R: float = R_J2
) -> float:
    """Inclination [rad] whose secular Ω̇ equals the Sun's mean motion 2π/365.2422 d."""
    n = math.sqrt(mu / a**3)
    p = a * (1.0 - e**2)
    rate = 2 * math.pi / (365.2422 * 86400.0)
    c = -rate / (1.5 * n * J2 * (R / p) ** 2)
    if not -1 <= c <= 1:
        raise ValueError(f"a: no sun-synchronous inclination exists for a = {a!r} m")
    return math.acos(c)


def raan_from_ltdn(ltdn_h: float, sun_ra: float) -> float:
    """RAAN [rad] from the local time of the descending node ``ltdn_h`` [h] and the Sun's right
    ascension ``sun_ra`` [rad] at the epoch (Yoo et al. 2016, Table 1). The ascending node lies 12 h
    later in local time, LTAN = LTDN + 12 h (mod 24), and

        Ω = α_⊙ + 15°/h · (LTAN − 12 h)   (mod 360°);   LTDN 10:30 → Ω = α_⊙ + 157.5°.
    """
    ltan = (ltdn_h + 12.0) % 24.0
    return math.radians((math.degrees(sun_ra) + 15.0 * (ltan - 12.0)) % 360.0)


class ReferenceOrbit:
    """The reference orbit r_ref(t), v_ref(t) in ECI, from epoch elements.

    Args:
      elements: classical elements at t = 0.
      mu: gravitational parameter [m³/s²].
      propagator: ``"kepler"`` (analytic two-body) or ``"j2"`` (Cowell two-body + J2, DOP853,
        dense output over [0, ``duration``]).
      duration: propagation span [s] (required for ``"j2"``; Kepler is valid at any t).
      J2, R_j2: J2 coefficient and its reference radius [m].
      rtol, atol: integrator tolerances for ``"j2"`` (atol in m and m/s for position/velocity).
    """

    def __init__(
        self,
        elements: OrbitalElements,
        *,
        mu: float = MU_EARTH,
        propagator: str = "kepler",
        duration: float | None = None,
        J2: float = J2_EARTH,
        R_j2: float = R_J2,
        rtol: float = 1e-12,
        atol: float = 1e-6,
    ) -> None:
        if propagator not in ("kepler", "j2"):
            raise ValueError(f"propagator: must be 'kepler' or 'j2', got {propagator!r}")
        self.elements = elements
        self.mu = float(mu)
        self.propagator = propagator
        self.J2 = float(J2)
        self.R_j2 = float(R_j2)
        self.r0, self.v0 = (np.asarray(a, dtype=float) for a in elements_to_state(elements, mu=mu))
        self.duration = None if duration is None else float(duration)
        self._sol = None
        if propagator == "j2":
            if duration is None or not duration > 0:
                raise ValueError(f"duration: the j2 propagator needs a duration > 0 s, got {duration!r}")
            self._sol = self._integrate(float(duration), rtol, atol)

    @property
    def mean_motion(self) -> float:
        """Two-body mean motion of the epoch elements [rad/s]."""
        return self.elements.mean_motion(self.mu)

    @property
    def period(self) -> float:
        """Two-body period of the epoch elements [s]."""
        return self.elements.period(self.mu)

    def _integrate(self, duration: float, rtol: float, atol: float):
        mu, J2, R = self.mu, self.J2, self.R_j2

        def rhs(_t: float, y: np.ndarray) -> np.ndarray:
            r = y[:3]
            return np.concatenate([y[3:], gravity_acceleration(r, mu=mu, j2=True, J2=J2, R=R)])

        y0 = np.concatenate([self.r0, self.v0])
        atol_v = np.r_[np.full(3, atol), np.full(3, atol * 1e-3)]
        sol = solve_ivp(rhs, (0.0, duration), y0, method="DOP853", rtol=rtol, atol=atol_v, dense_output=True)
        if not sol.success:  # pragma: no cover - DOP853 does not fail on this smooth problem
            raise RuntimeError(f"J2 orbit propagation failed: {sol.message}")
        return sol.sol

    def state(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """ECI position [m] and velocity [m/s] at times ``t`` [s] (vectorised: (..., 3) each).

        Raises ValueError naming ``t`` outside [0, duration] for the J2 propagator.
        """
        t = np.asarray(t, dtype=float)
        if self._sol is None:
            return kepler_propagate(self.elements, t, mu=self.mu)
        if np.any(t < -1e-9) or np.any(t > self.duration + 1e-9):
            raise ValueError(
                f"t: must lie within the propagated span [0, {self.duration}] s, got [{t.min()}, {t.max()}]"
            )
        y = self._sol(t.ravel())
        return y[:3].T.reshape(t.shape + (3,)), y[3:].T.reshape(t.shape + (3,))

    def acceleration(self, r: np.ndarray) -> np.ndarray:
        """Gravity acceleration of the propagator's force model at ECI points ``r`` [m/s²]."""
        return gravity_acceleration(r, mu=self.mu, j2=self.propagator == "j2", J2=self.J2, R=self.R_j2)

    def with_elements(self, **changes: float) -> "ReferenceOrbit":
        """A new orbit with some epoch elements replaced (same propagator and span)."""
        return ReferenceOrbit(
            replace(self.elements, **changes),
            mu=self.mu,
            propagator=self.propagator,
            duration=self.duration,
            J2=self.J2,
            R_j2=self.R_j2,
        )
