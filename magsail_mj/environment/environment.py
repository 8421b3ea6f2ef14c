"""The environment along the reference orbit: precomputed once, sampled in O(1) per step.

:class:`Environment` is built from the config tables (:mod:`magsail_mj.environment.config`) and
a run duration. At construction it

1. builds the reference orbit (Kepler or J2, :class:`~magsail_mj.environment.orbit.ReferenceOrbit`);
2. lays a uniform grid t_k = k h (h = ``field.sample_step_s``) over [0, duration + 2h];
3. evaluates on the grid, vectorised: r_ref, v_ref, a_ref (from the force model), the magnetic
   field in ECI (IGRF: one ppigrf call per ≤ 8000 points), the geocentric Sun position, and the
   MSIS density when selected;
4. stores them as piecewise cubics (:class:`~magsail_mj.environment.interp.CubicTable`):
   r by cubic Hermite with v, v by cubic Hermite with a (error ~1e-4 m and ~1e-7 m/s at h = 10 s
   in LEO), B and the Sun position by not-a-knot cubic splines, MSIS by a spline of ln ρ.

:meth:`Environment.sample` then returns an :class:`EnvSample` at any t in O(1): one Horner
evaluation of all channels, plus scalar formulas for the exponential density, the shadow and the
flow velocity. No ppigrf or integrator call happens per step.

Frames: every vector is in ECI components = world axes (the world origin rides r_ref).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime

import numpy as np

from magsail_mj.environment.atmosphere import _as_datetime64, ecef_to_geodetic, exponential_density_scalar, msis_density
from magsail_mj.environment.config import (
    AtmosphereConfig,
    DragConfig,
    EnvironmentConfig,
    FieldConfig,
    GravityConfig,
    OrbitConfig,
    SRPConfig,
    SunConfig,
    check_environment,
    environment_tables,
)
from magsail_mj.environment.constants import AU
from magsail_mj.environment.field import (
    aligned_dipole_field,
    igrf_dipole,
    igrf_eci,
    planar_dipole_field,
    tilted_dipole_field_eci,
)
from magsail_mj.environment.frames import eci_to_ecef
from magsail_mj.environment.interp import CubicTable
from magsail_mj.environment.orbit import OrbitalElements, ReferenceOrbit, raan_from_ltdn
from magsail_mj.environment.sun import sun_position_eci, sun_right_ascension
from magsail_mj.environment.timeutil import gmst_rad, gmst_rate_rad_s, julian_date, parse_epoch
from magsail_mj.checkpoint import restorable

__all__ = ["EnvSample", "Environment", "elements_from_config"]


@restorable
@dataclass(slots=True)
class EnvSample:
    """The environment at one time ``t`` [s since the epoch]; vectors in ECI = world axes.

    Attributes:
      r_ref_eci, v_ref_eci: reference-orbit position [m] and velocity [m/s] (zeros in free space).
      B_eci: magnetic field at r_ref [T]; B_dot_eci: its time derivative along the orbit [T/s].
      sun_eci: unit vector from r_ref to the Sun (zeros when there is no Sun).
      sun_distance_m: distance r_ref → Sun [m].
      in_shadow: r_ref is in the Earth's (cylindrical) shadow.
      srp_pressure_N_m2: solar pressure on an absorber at r_ref: P_1AU (1 AU/d)², 0 in shadow.
      density_kg_m3: atmospheric density at r_ref.
      v_rel_eci: velocity of r_ref relative to the atmosphere [m/s] (v − ω⊕ × r when co-rotating).
      altitude_m: |r_ref| − R_E.
      gmst_rad: Greenwich mean sidereal time (ECEF = R3(θ) ECI).
    """

    t: float
    r_ref_eci: np.ndarray
    v_ref_eci: np.ndarray
    B_eci: np.ndarray
    B_dot_eci: np.ndarray
    sun_eci: np.ndarray
    sun_distance_m: float
    in_shadow: bool
    srp_pressure_N_m2: float
    density_kg_m3: float
    v_rel_eci: np.ndarray
    altitude_m: float
    gmst_rad: float


def elements_from_config(orbit: OrbitConfig, *, jd0: float) -> OrbitalElements:
    """Epoch elements from ``[orbit]``: a from ``semi_major_axis_km`` or R_E + ``altitude_km``;
    Ω from ``raan_deg`` or from ``ltdn_h`` and the Sun's right ascension at the epoch; ν0 from
    ``true_anomaly0_deg`` or ``arg_lat0_deg`` − ω (u0 = 0 when neither is given)."""
    a = orbit.semi_major_axis_km_value * 1e3
    if orbit.ltdn_h is not None:
        raan = raan_from_ltdn(orbit.ltdn_h, sun_right_ascension(jd0))
    else:
        raan = math.radians(orbit.raan_deg or 0.0)
    argp = math.radians(orbit.arg_perigee_deg)
    if orbit.true_anomaly0_deg is not None:
        nu0 = math.radians(orbit.true_anomaly0_deg)
    else:
        nu0 = math.radians(orbit.arg_lat0_deg or 0.0) - argp
    return OrbitalElements(
        a=a, e=orbit.eccentricity, i=math.radians(orbit.inclination_deg), raan=raan, argp=argp, nu0=nu0
    )


class Environment:
    """Orbit, field, Sun and atmosphere precomputed along the reference orbit (module docstring).

    Build with :meth:`from_config` or the keyword-only constructor. ``duration_s`` is the run
    length; samples are valid on [0, ``t_max``], ``t_max = K h`` the first whole number of table
    steps ``h`` (``field.sample_step_s``, not hours) at or beyond ``duration_s + 2 h``, and at least
    ``3 h``.
    """

    def __init__(
        self,
        *,
        orbit: OrbitConfig,
        field: FieldConfig,
        atmosphere: AtmosphereConfig,
        sun: SunConfig,
        duration_s: float,
        srp: SRPConfig | None = None,
        drag: DragConfig | None = None,
        gravity: GravityConfig | None = None,
    ) -> None:
        srp = srp or SRPConfig()
        drag = drag or DragConfig()
        gravity = gravity or GravityConfig(tidal=orbit.enabled)
        problems = check_environment(
            orbit=orbit, field=field, atmosphere=atmosphere, sun=sun, srp=srp, drag=drag, gravity=gravity
        )
        if problems:
            raise ValueError("inconsistent environment config:\n  " + "\n  ".join(problems))
        if not duration_s > 0:
            raise ValueError(f"duration_s: must be > 0 s, got {duration_s!r}")
        self.cfg = EnvironmentConfig.model_construct(
            orbit=orbit, field=field, atmosphere=atmosphere, sun=sun, srp=srp, drag=drag, gravity=gravity
        )
        self.duration_s = float(duration_s)
        self.epoch: datetime = parse_epoch(orbit.epoch)
        self.jd0 = julian_date(self.epoch)
        self.R_E = orbit.R_E_km * 1e3
        self.mu = orbit.mu_m3_s2
        self.omega_earth = orbit.omega_earth_rad_s
        self.gravity = gravity
        self._gmst0 = float(gmst_rad(self.jd0))
        self._gmst_rate = gmst_rate_rad_s(self.jd0)

        h = float(field.sample_step_s)
        K = max(3, math.ceil((self.duration_s + 2.0 * h) / h))
        self.grid_step_s = h
        self.t_max = K * h
        t = h * np.arange(K + 1)
        self.t_grid = t

        # 1. reference orbit
        self.orbit: ReferenceOrbit | None = None
        if orbit.enabled:
            self.elements = elements_from_config(orbit, jd0=self.jd0)
            self.orbit = ReferenceOrbit(
                self.elements,
                mu=self.mu,
                propagator=orbit.propagator,
                duration=self.t_max,
                J2=orbit.J2,
                R_j2=orbit.j2_radius_km * 1e3,
            )
            r, v = self.orbit.state(t)
            acc = self.orbit.acceleration(r)
        else:
            self.elements = None
            r = v = acc = np.zeros((K + 1, 3))
        tables = [CubicTable.hermite(0.0, h, r, v), CubicTable.hermite(0.0, h, v, acc)]

        # 2. magnetic field
        gmst = gmst_rad(self.jd0 + t / 86400.0)
        B = self._field_on_grid(field, orbit, r, gmst)
        tables.append(CubicTable.spline(0.0, h, B))

        # 3. Sun (geocentric position; a fixed Sun sits at 1 AU along direction_eci)
        if sun.model == "ephemeris":
            S = sun_position_eci(self.jd0 + t / 86400.0)
        elif sun.model == "fixed":
            d = np.asarray(sun.direction_eci, dtype=float)
            S = np.tile(d / np.linalg.norm(d) * AU, (K + 1, 1))
        else:
            S = np.zeros((K + 1, 3))
        tables.append(CubicTable.spline(0.0, h, S))

        # 4. MSIS density (log), only when selected
        self._msis = atmosphere.model == "msis"
        if self._msis:
            lon, lat, alt_km = ecef_to_geodetic(eci_to_ecef(r, gmst))
            rho = msis_density(
                _as_datetime64(self.epoch, t),
                lon,
                lat,
                alt_km,
                f107=atmosphere.f107_sfu,
                f107a=atmosphere.f107a_sfu,
                ap=atmosphere.ap,
                version=atmosphere.msis_version,
            )
            tables.append(CubicTable.spline(0.0, h, np.log(rho)[:, None]))
        self._table = CubicTable.concat(tables)

        self._has_sun = sun.model != "none"
        self._shadow = sun.shadow == "cylindrical" and orbit.enabled and self._has_sun
        self._P = srp.pressure_N_m2 if self._has_sun else 0.0
        self._scale_distance = srp.distance_scaling
        self._atmo = atmosphere.model
        self._corot = atmosphere.corotating
        self.B_grid_eci = B

    # ------------------------------------------------------------------ construction helpers
    @classmethod
    def from_config(cls, cfg: EnvironmentConfig, *, duration_s: float) -> "Environment":
        """Build from an :class:`EnvironmentConfig` (validated tables) and the run duration [s]."""
        return cls(**environment_tables(cfg), duration_s=duration_s)

    def _field_on_grid(self, field: FieldConfig, orbit: OrbitConfig, r: np.ndarray, gmst: np.ndarray) -> np.ndarray:
        n = len(r)
        model = field.model
        if model == "none":
            return np.zeros((n, 3))
        if model == "constant":
            return np.tile(np.asarray(field.constant_T, dtype=float), (n, 1))
        date = parse_epoch(field.igrf_date) if field.igrf_date else self.epoch
        if model == "igrf":
            return igrf_eci(r, gmst, date, max_degree=field.igrf_max_degree)
        m_hat, B0, R = igrf_dipole(date)
        if field.B0_T is not None:
            B0 = field.B0_T
            R = (field.R_ref_km or orbit.R_E_km) * 1e3
        elif field.R_ref_km is not None:
            R = field.R_ref_km * 1e3
        self.dipole_B0_T, self.dipole_R_m = B0, R
        if model == "dipole":
            return aligned_dipole_field(r, B0=B0, R=R)
        if model == "tilted_dipole":
            self.dipole_m_hat_ecef = m_hat
            return tilted_dipole_field_eci(r, gmst, m_hat, B0=B0, R=R)
        if model == "planar_dipole":
            return planar_dipole_field(r, B0=B0, R=R)
        raise ValueError(f"field.model: unknown model {model!r}")  # pragma: no cover

    # ------------------------------------------------------------------ per step
    def sample(self, t: float) -> EnvSample:
        """The environment at time ``t`` [s] (O(1); see the class docstring).

        Raises ValueError naming ``t`` when it lies outside [0, t_max].
        """
        if not (-1e-9 <= t <= self.t_max + 1e-9):
            raise ValueError(
                f"t: {t!r} s is outside the precomputed span [0, {self.t_max}] s "
                "(build the Environment with a longer duration_s)"
            )
        vd = self._table.value_and_derivative_rows(t)
        val = vd[0].tolist()
        rx, ry, rz, vx, vy, vz = val[0:6]
        Sx, Sy, Sz = val[9:12]
        rn = math.sqrt(rx * rx + ry * ry + rz * rz)
        if self._has_sun:
            dx, dy, dz = Sx - rx, Sy - ry, Sz - rz
            dist = math.sqrt(dx * dx + dy * dy + dz * dz)
            sun = np.array((dx / dist, dy / dist, dz / dist))
            shadow = False
            if self._shadow:
                sn = math.sqrt(Sx * Sx + Sy * Sy + Sz * Sz)
                proj = (rx * Sx + ry * Sy + rz * Sz) / sn
                shadow = proj < 0.0 and (rn * rn - proj * proj) < self.R_E * self.R_E
            P = 0.0 if shadow else (self._P * (AU / dist) ** 2 if self._scale_distance else self._P)
        else:
            sun, dist, shadow, P = np.zeros(3), math.inf, False, 0.0
        alt = rn - self.R_E
        if self._atmo == "exponential":
            rho = exponential_density_scalar(alt) if rn > 0 else 0.0
        elif self._msis:
            rho = math.exp(val[12])
        else:
            rho = 0.0
        if self._corot:
            w = self.omega_earth
            v_rel = np.array((vx + w * ry, vy - w * rx, vz))
        else:
            v_rel = np.array((vx, vy, vz))
        return EnvSample(
            t=float(t),
            r_ref_eci=vd[0, 0:3],
            v_ref_eci=vd[0, 3:6],
            B_eci=vd[0, 6:9],
            B_dot_eci=vd[1, 6:9],
            sun_eci=sun,
            sun_distance_m=dist,
            in_shadow=shadow,
            srp_pressure_N_m2=P,
            density_kg_m3=rho,
            v_rel_eci=v_rel,
            altitude_m=alt,
            gmst_rad=(self._gmst0 + self._gmst_rate * t) % (2.0 * math.pi),
        )

    def sample_many(self, t: np.ndarray) -> dict[str, np.ndarray]:
        """Samples at many times ``t`` (n,) for analysis and plots (a loop over :meth:`sample`):
        dict of arrays keyed by the :class:`EnvSample` field names (vectors as (n, 3))."""
        t = np.asarray(t, dtype=float)
        samples = [self.sample(float(x)) for x in t]
        names = EnvSample.__slots__
        return {k: np.array([getattr(s, k) for s in samples]) for k in names}

    # ------------------------------------------------------------------ reporting
    @property
    def gravity_params(self) -> dict[str, float | bool]:
        """Keyword arguments for the gravity loads: ``mu``, ``j2``, ``J2``, ``R_j2``."""
        o = self.cfg.orbit
        return {"mu": self.mu, "j2": bool(self.gravity.j2), "J2": o.J2, "R_j2": o.j2_radius_km * 1e3}

    def summary(self) -> dict[str, object]:
        """Flat description of the orbit and models used (SI units in the keys), for summary.json."""
        o, f = self.cfg.orbit, self.cfg.field
        out: dict[str, object] = {
            "orbit_enabled": o.enabled,
            "orbit_epoch_utc": self.epoch.isoformat(),
            "orbit_propagator": o.propagator,
            "field_model": f.model,
            "field_sample_step_s": f.sample_step_s,
            "atmosphere_model": self.cfg.atmosphere.model,
            "sun_model": self.cfg.sun.model,
            "earth_radius_m": self.R_E,
            "mu_m3_s2": self.mu,
        }
        if self.elements is not None:
            el = self.elements
            out.update(
                {
                    "orbit_semi_major_axis_m": el.a,
                    "orbit_altitude_m": el.a - self.R_E,
                    "orbit_perigee_altitude_m": el.a * (1.0 - el.e) - self.R_E,
                    "orbit_apogee_altitude_m": el.a * (1.0 + el.e) - self.R_E,
                    "orbit_eccentricity": el.e,
                    "orbit_inclination_rad": el.i,
                    "orbit_raan_rad": el.raan,
                    "orbit_arg_perigee_rad": el.argp,
                    "orbit_true_anomaly0_rad": el.nu0,
                    "orbit_period_s": el.period(self.mu),
                }
            )
        if f.model == "igrf":
            out["field_igrf_max_degree"] = f.igrf_max_degree
        if hasattr(self, "dipole_B0_T"):
            out["field_dipole_B0_T"] = self.dipole_B0_T
            out["field_dipole_R_m"] = self.dipole_R_m
        return out
