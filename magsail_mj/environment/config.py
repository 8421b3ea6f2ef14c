"""Config tables of the environment: ``[orbit]``, ``[field]``, ``[atmosphere]``, ``[sun]``,
``[srp]``, ``[drag]``, ``[gravity]``.

Each table is a :class:`magsail_mj.config.StrictModel` (unknown keys are errors). Keys carry their
unit (``_km``, ``_deg``, ``_s``, ``_T``, ``_h``). A concept schema embeds the tables it needs,
e.g. ``orbit: OrbitConfig = OrbitConfig(enabled=False)``, or inherits all seven with the
free-space defaults from :class:`EnvironmentTables`; :class:`EnvironmentConfig` groups them and
checks that they fit together (:func:`check_environment`), :func:`environment_config_of` gathers
a concept config's tables into one, and :meth:`magsail_mj.environment.Environment.from_config`
builds the runtime object.

Defaults follow the truss orbit of Robb et al. 2022a (800 km polar orbit needs ``altitude_km = 800``,
``inclination_deg = 90``, ``raan_deg = 90``; R_E = 6370 km, the paper's value; epoch
2020-01-01T00:00Z, assumed; μ = 3.986004418e14). The CNUSAIL orbit is written with
``semi_major_axis_km = 6963.1``, ``eccentricity = 0.01939``, ``ltdn_h = 10.5``,
``R_E_km = 6378.137``, ``propagator = "j2"``; the reflector's with ``R_E_km = 6371``.
"""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import Field, field_validator, model_validator

from magsail_mj.config import MIN_TIMESTEP_S, ConfigProblem, StrictModel, finite_product, likeliest_key

from magsail_mj.environment.constants import J2_EARTH, MU_EARTH, OMEGA_EARTH, P_SUN_1AU
from magsail_mj.environment.timeutil import parse_epoch

__all__ = [
    "AtmosphereConfig",
    "DragConfig",
    "EnvironmentConfig",
    "EnvironmentTables",
    "ENVIRONMENT_TABLES",
    "FieldConfig",
    "GravityConfig",
    "OrbitConfig",
    "SRPConfig",
    "SunConfig",
    "check_environment",
    "environment_config_of",
    "environment_problems",
    "environment_tables",
]

Vec3 = tuple[float, float, float]

# The largest J2 acceleration relative to the central one, 3 J2 (R/r)² (at the pole), at the orbit's
# perigee: Earth's is 3.2e-3 at its surface. The propagators treat J2 as a perturbation of a
# near-Keplerian orbit; at 1.5 (J2 = 1/2, R at the perigee) a 20 000 s Cowell propagation fails
# ("required step size is less than spacing between numbers") while 0.1 propagates 10 orbits.
J2_PERTURBATION_MAX = 0.1


def _check_iso(v: str) -> str:
    try:
        parse_epoch(v)
    except ValueError:
        raise ValueError("must be an ISO 8601 UTC date-time within 1900–2100, such as '2020-01-01T00:00:00Z'") from None
    return v


class OrbitConfig(StrictModel):
    """``[orbit]``: the reference orbit the world origin rides.

    Size: ``altitude_km`` (a = R_E + altitude) **or** ``semi_major_axis_km``. Orientation:
    ``inclination_deg``, ``raan_deg`` **or** ``ltdn_h`` (local time of the descending node at
    the epoch, Yoo et al. 2016, Table 1), ``arg_perigee_deg``. Start: ``arg_lat0_deg`` (argument of
    latitude u0 = ω + ν0) **or** ``true_anomaly0_deg``; neither means u0 = 0 (ascending node).
    ``enabled = false`` means free space (no orbit; the world is inertial). Every number is
    finite; the orbit's perigee must clear ``R_E_km`` and its period 2π √(a³/μ) must be a finite
    number of seconds. ``J2`` is at most 1/2 and the J2 acceleration at the perigee relative to the
    central one, 3 J2 (R/r_p)² with R = ``j2_radius_km``, at most :data:`J2_PERTURBATION_MAX`.
    """

    enabled: bool = True
    altitude_km: float | None = Field(default=None, gt=0)
    semi_major_axis_km: float | None = Field(default=None, gt=0)
    eccentricity: float = Field(default=0.0, ge=0, lt=1)
    inclination_deg: float = Field(default=0.0, ge=0, le=180)
    raan_deg: float | None = None
    ltdn_h: float | None = Field(default=None, ge=0, lt=24)
    arg_perigee_deg: float = 0.0
    arg_lat0_deg: float | None = None
    true_anomaly0_deg: float | None = None
    epoch: str = "2020-01-01T00:00:00Z"
    R_E_km: float = Field(default=6370.0, gt=0)
    mu_m3_s2: float = Field(default=MU_EARTH, gt=0)
    propagator: Literal["kepler", "j2"] = "kepler"
    J2: float = Field(
        default=J2_EARTH,
        ge=0,
        le=0.5,
        description="J2 = (C - A)/(M R²) <= 1/2 for any axisymmetric body within its reference radius "
        "(the bound of an equatorial ring); Earth 1.08e-3",
    )
    j2_radius_km: float = Field(
        default=6378.137,
        gt=0,
        description="the J2 reference radius [km]; 3 J2 (R/r_perigee)² must not exceed J2_PERTURBATION_MAX",
    )
    omega_earth_rad_s: float = Field(default=OMEGA_EARTH, ge=0)

    @field_validator("epoch")
    @classmethod
    def _epoch_iso(cls, v: str) -> str:
        return _check_iso(v)

    @model_validator(mode="after")
    def _consistent(self) -> OrbitConfig:
        if self.altitude_km is not None and self.semi_major_axis_km is not None:
            raise ConfigProblem(
                "altitude_km",
                "altitude_km and semi_major_axis_km both given: give exactly one",
                others=("semi_major_axis_km",),
            )
        if self.raan_deg is not None and self.ltdn_h is not None:
            raise ConfigProblem("raan_deg", "raan_deg and ltdn_h both given: give exactly one", others=("ltdn_h",))
        if self.arg_lat0_deg is not None and self.true_anomaly0_deg is not None:
            raise ConfigProblem(
                "arg_lat0_deg",
                "arg_lat0_deg and true_anomaly0_deg both given: give exactly one",
                others=("true_anomaly0_deg",),
            )
        if not self.enabled:
            return self
        if self.altitude_km is None and self.semi_major_axis_km is None:
            raise ConfigProblem(
                "altitude_km",
                "altitude_km or semi_major_axis_km is required when enabled = true",
                others=("semi_major_axis_km",),
            )
        size = "semi_major_axis_km" if self.semi_major_axis_km is not None else "altitude_km"
        a = finite_product(size, self.semi_major_axis_km_value, what="semi-major axis", others=("R_E_km",))
        if a * (1.0 - self.eccentricity) <= self.R_E_km:
            raise ConfigProblem(
                size,
                f"the perigee radius a(1 - e) = {a * (1 - self.eccentricity):.6g} km must "
                f"exceed R_E_km = {self.R_E_km:.6g} km",
                others=("eccentricity", "R_E_km"),
            )
        a_m = a * 1e3
        finite_product(size, a_m, a_m, a_m / self.mu_m3_s2, what="orbital period 2π √(a³/μ)", others=("mu_m3_s2",))
        r_j2 = self.j2_radius_km * 1e3
        finite_product(
            "j2_radius_km",
            self.J2 + 1.0,
            self.mu_m3_s2,
            r_j2,
            r_j2,
            minimum=-1.0,
            what="J2 term J2 μ R²",
            others=("J2", "mu_m3_s2"),
        )
        self._check_j2_perturbation(size, a_m * (1.0 - self.eccentricity), r_j2)
        return self

    def _check_j2_perturbation(self, size: str, perigee_m: float, r_j2_m: float) -> None:
        """A :class:`ConfigProblem` when the J2 acceleration at the perigee, relative to the
        central one, 3 J2 (R/r_p)², exceeds :data:`J2_PERTURBATION_MAX` (the propagators take J2
        as a perturbation). Reported on the most extreme of the keys involved, naming the others."""
        ratio = 3.0 * self.J2 * (r_j2_m / perigee_m) ** 2
        if ratio <= J2_PERTURBATION_MAX:
            return
        keys = {
            "J2": self.J2,
            "j2_radius_km": self.j2_radius_km,
            size: getattr(self, size),
            "eccentricity": self.eccentricity,
        }
        if size == "altitude_km":
            keys["R_E_km"] = self.R_E_km
        primary = likeliest_key(keys)
        raise ConfigProblem(
            primary,
            f"the J2 acceleration at the perigee, 3 J2 (R/r_p)² = {ratio:.6g} (R = j2_radius_km, r_p = "
            f"{perigee_m / 1e3:.6g} km), must be <= {J2_PERTURBATION_MAX:g}: J2 is a perturbation of a "
            f"near-Keplerian orbit (Earth: 3.2e-3 at its surface)",
            others=tuple(k for k in keys if k != primary),
        )

    @property
    def semi_major_axis_km_value(self) -> float:
        """Semi-major axis [km] from whichever of the two size keys is given."""
        if self.semi_major_axis_km is not None:
            return self.semi_major_axis_km
        return self.R_E_km + (self.altitude_km or 0.0)


FieldModel = Literal["igrf", "dipole", "tilted_dipole", "planar_dipole", "constant", "none"]


class FieldConfig(StrictModel):
    """``[field]``: geomagnetic field model along the reference orbit.

    * ``igrf``: IGRF-14 via ppigrf, up to ``igrf_max_degree``, coefficients at the epoch (or
      ``igrf_date``), sampled every ``sample_step_s`` along the orbit and interpolated (cubic
      spline of the ECI components).
    * ``dipole``: centred dipole aligned with −z; ``tilted_dipole``: IGRF degree-1 dipole fixed
      in ECEF; ``planar_dipole``: Robb et al. 2020, Eq. 11. ``B0_T`` [T] is the equatorial field at
      ``R_ref_km``; when ``B0_T`` is absent the IGRF degree-1 value at the epoch is used with
      R = 6371.2 km; ``R_ref_km`` absent means the orbit's ``R_E_km``.
    * ``constant``: ``constant_T`` (3 components in world = ECI axes [T]).
    * ``none``: B = 0.

    ``sample_step_s`` is the step of the environment's precompute grid for every channel
    (orbit, field, Sun, MSIS density), between 1e-9 s and 600 s. ``B0_T`` R³ (R in m) must be
    a finite number.
    """

    model: FieldModel = "igrf"
    constant_T: Vec3 | None = None
    B0_T: float | None = Field(default=None, gt=0)
    R_ref_km: float | None = Field(default=None, gt=0)
    igrf_max_degree: int = Field(default=13, ge=1, le=13)
    igrf_date: str | None = None
    sample_step_s: float = Field(default=10.0, gt=0, le=600)

    @field_validator("sample_step_s")
    @classmethod
    def _step_not_tiny(cls, v: float) -> float:
        if v < MIN_TIMESTEP_S:
            raise ValueError(f"must be a number >= {MIN_TIMESTEP_S:g} s")
        return v

    @field_validator("igrf_date")
    @classmethod
    def _date_iso(cls, v: str | None) -> str | None:
        return None if v is None else _check_iso(v)

    @model_validator(mode="after")
    def _consistent(self) -> FieldConfig:
        if self.model == "constant" and self.constant_T is None:
            raise ValueError("constant_T (3 components in tesla) is required when model = 'constant'")
        if self.model != "constant" and self.constant_T is not None:
            raise ValueError(f"constant_T is only used with model = 'constant', not {self.model!r}")
        dipoles = ("dipole", "tilted_dipole", "planar_dipole")
        if self.model not in dipoles and (self.B0_T is not None or self.R_ref_km is not None):
            raise ConfigProblem(
                "B0_T" if self.B0_T is not None else "R_ref_km",
                f"B0_T and R_ref_km are only used with model in {list(dipoles)}, not {self.model!r}",
                others=("model",),
            )
        if self.R_ref_km is not None:
            r = self.R_ref_km * 1e3
            finite_product("R_ref_km", self.B0_T or 1.0, r, r, r, what="dipole moment B0 R³", others=("B0_T",))
        return self


class AtmosphereConfig(StrictModel):
    """``[atmosphere]``: density model and flow.

    ``exponential``: Vallado's exponential table (0–1000 km); ``msis``: pymsis (optional extra),
    precomputed along the orbit, with ``f107_sfu``, ``f107a_sfu``, ``ap`` passed explicitly
    (``msis_version`` 0 = NRLMSISE-00); ``none``: ρ = 0. ``corotating``: flow velocity relative
    to an atmosphere turning with the Earth, v_rel = v − ω⊕ × r (default), else inertial v.
    """

    model: Literal["exponential", "msis", "none"] = "exponential"
    corotating: bool = True
    f107_sfu: float = Field(default=150.0, gt=0)
    f107a_sfu: float = Field(default=150.0, gt=0)
    ap: float = Field(default=15.0, ge=0)
    msis_version: Literal[0, 2] = 0


class SunConfig(StrictModel):
    """``[sun]``: Sun direction and shadow.

    ``ephemeris``: low-precision solar ephemeris (≈0.01°); ``fixed``: a fixed direction
    ``direction_eci`` at 1 AU (e.g. the reflector's +y); ``none``: no Sun.
    ``shadow``: ``cylindrical`` Earth shadow or ``none``.
    """

    model: Literal["ephemeris", "fixed", "none"] = "ephemeris"
    direction_eci: Vec3 | None = None
    shadow: Literal["cylindrical", "none"] = "cylindrical"

    @model_validator(mode="after")
    def _consistent(self) -> SunConfig:
        if self.model == "fixed":
            if self.direction_eci is None:
                raise ValueError("direction_eci is required when model = 'fixed'")
            if not math.hypot(*self.direction_eci) > 0:
                raise ValueError("direction_eci: must not be the zero vector")
        elif self.direction_eci is not None:
            raise ValueError(f"direction_eci is only used with model = 'fixed', not {self.model!r}")
        return self


class SRPConfig(StrictModel):
    """``[srp]``: solar radiation pressure. ``pressure_N_m2`` at 1 AU (4.563e-6),
    scaled by (1 AU/d)² when ``distance_scaling``; zero in shadow."""

    enabled: bool = False
    pressure_N_m2: float = Field(default=P_SUN_1AU, ge=0)
    distance_scaling: bool = True


class DragConfig(StrictModel):
    """``[drag]``: aerodynamic drag, flat-plate free-molecular coefficient ``drag_coefficient``."""

    enabled: bool = False
    drag_coefficient: float = Field(default=2.2, gt=0)


class GravityConfig(StrictModel):
    """``[gravity]``: ``tidal``: exact tidal acceleration on every body (orbit-following world);
    ``j2``: include J2 in it (needs ``orbit.propagator = "j2"``); ``classical_torque``: the
    classical gravity-gradient torque on a single rigid body instead."""

    tidal: bool = True
    j2: bool = False
    classical_torque: bool = False


ENVIRONMENT_TABLES = ("orbit", "field", "atmosphere", "sun", "srp", "drag", "gravity")
"""The names of the environment tables (fields of :class:`EnvironmentTables`)."""


class EnvironmentTables(StrictModel):
    """The seven environment tables with the defaults of free space (no orbit, field, atmosphere,
    Sun, SRP, drag or tidal gravity). A concept schema that takes all seven with these defaults
    inherits them (its TOML files then have ``[orbit]``, ``[field]``, … at the top level); the
    consistency check stays the schema's own (:func:`environment_problems`)."""

    orbit: OrbitConfig = OrbitConfig(enabled=False)
    field: FieldConfig = FieldConfig(model="none")
    atmosphere: AtmosphereConfig = AtmosphereConfig(model="none")
    sun: SunConfig = SunConfig(model="none")
    srp: SRPConfig = SRPConfig()
    drag: DragConfig = DragConfig()
    gravity: GravityConfig = GravityConfig(tidal=False)

    def environment_config(self) -> EnvironmentConfig:
        """The environment tables as one validated :class:`EnvironmentConfig`."""
        return environment_config_of(self)


class EnvironmentConfig(EnvironmentTables):
    """All environment tables together; validated for consistency (:func:`check_environment`)."""

    @model_validator(mode="after")
    def _consistent(self) -> EnvironmentConfig:
        problems = environment_problems(self)
        if problems:
            raise ValueError("; ".join(problems))
        return self


def check_environment(
    *,
    orbit: OrbitConfig,
    field: FieldConfig,
    atmosphere: AtmosphereConfig,
    sun: SunConfig,
    srp: SRPConfig,
    drag: DragConfig,
    gravity: GravityConfig,
) -> list[str]:
    """Cross-table problems as ``key.path: message`` lines (empty when consistent)."""
    out: list[str] = []
    if not orbit.enabled:
        if field.model not in ("constant", "none"):
            out.append(
                f"field.model: {field.model!r} is evaluated along an orbit; with orbit.enabled = "
                "false use 'constant' or 'none'"
            )
        if gravity.tidal or gravity.classical_torque or gravity.j2:
            out.append(
                "gravity: tidal/classical_torque/j2 need orbit.enabled = true (set them to false for free space)"
            )
        if drag.enabled:
            out.append("drag.enabled: drag needs orbit.enabled = true")
        if atmosphere.model == "msis":
            out.append("atmosphere.model: 'msis' is evaluated along an orbit; needs orbit.enabled = true")
        if sun.shadow != "none" and sun.model != "none":
            out.append("sun.shadow: the Earth shadow needs orbit.enabled = true (set sun.shadow = 'none')")
    if gravity.j2 and orbit.propagator != "j2":
        out.append("gravity.j2: the tidal J2 term needs orbit.propagator = 'j2' (the reference orbit must feel J2 too)")
    if gravity.tidal and gravity.classical_torque:
        out.append("gravity: choose tidal (every body) or classical_torque (one rigid body), not both")
    if drag.enabled and atmosphere.model == "none":
        out.append("drag.enabled: needs atmosphere.model = 'exponential' or 'msis'")
    if srp.enabled and sun.model == "none":
        out.append("srp.enabled: needs sun.model = 'ephemeris' or 'fixed'")
    return out


def environment_tables(tables: Any) -> dict[str, Any]:
    """The seven tables of :data:`ENVIRONMENT_TABLES` that ``tables`` carries as attributes (an
    :class:`EnvironmentConfig` or a concept config that holds them at its top level), by name."""
    return {name: getattr(tables, name) for name in ENVIRONMENT_TABLES}


def environment_config_of(config: Any) -> EnvironmentConfig:
    """The environment tables of ``config`` (those of :data:`ENVIRONMENT_TABLES` it has as
    attributes, such as a concept config's top-level tables) as one validated
    :class:`EnvironmentConfig`; a table ``config`` lacks takes :class:`EnvironmentTables`' default."""
    return EnvironmentConfig(**{name: getattr(config, name) for name in ENVIRONMENT_TABLES if hasattr(config, name)})


def environment_problems(tables: Any) -> list[str]:
    """:func:`check_environment` of the seven tables that ``tables`` carries as attributes
    (``orbit``, ``field``, ``atmosphere``, ``sun``, ``srp``, ``drag``, ``gravity``): an
    :class:`EnvironmentConfig` or a concept config that holds them at its top level."""
    return check_environment(**environment_tables(tables))
