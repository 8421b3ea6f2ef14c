r"""Config schema of the CNUSAIL concept (``magsail_mj/concepts/cnusail/configs/<id>.toml``): pydantic models of
``[spacecraft]``, ``[actuators]`` (``mtq``, ``wheels``), ``[control]`` (``unloading``, ``modes``,
``sensors``), ``[initial]``, ``[analysis]``, ``[render]``, ``[lifetime]`` and the shared
environment tables (``[orbit]``, ``[field]``, ``[atmosphere]``, ``[sun]``, ``[srp]``, ``[drag]``,
``[gravity]``), with the cross-table checks. ``kind`` = ``"attitude"`` or ``"lifetime"``.

Units are SI unless a key's suffix says otherwise (``_deg``, ``_rpm``, ``_km``, ``_days``).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from magsail_mj.concepts import register_config
from magsail_mj.config import MJ_MINVAL, ConfigProblem, SimConfig, StrictModel, derived_quantity, normalised
from magsail_mj.control.detumble_plugins import BUILTIN_DETUMBLE_LAWS as DETUMBLE_LAWS
from magsail_mj.control.detumble_plugins import check_params, detumble_law, detumble_law_names
from magsail_mj.environment.config import (
    AtmosphereConfig,
    DragConfig,
    EnvironmentConfig,
    FieldConfig,
    GravityConfig,
    OrbitConfig,
    SRPConfig,
    SunConfig,
    environment_config_of,
    environment_problems,
)
from magsail_mj.loads.actuators_cubesat import MTQ_LIMIT_SETS, DCMotorParams

__all__ = [
    "CnusailConfig",
    "CnusailSimConfig",
    "SpacecraftConfig",
    "MtqConfig",
    "WheelsConfig",
    "ActuatorsConfig",
    "UnloadingConfig",
    "ModesConfig",
    "SensorsConfig",
    "CnusailControlConfig",
    "CnusailInitialConfig",
    "AnalysisConfig",
    "CnusailRenderConfig",
    "LifetimeConfig",
    "TABLE2_INERTIA",
    "DEFAULT_BUS_CENTROID",
]

Vec3 = tuple[float, float, float]
DEG = math.pi / 180.0
TABLE2_INERTIA: dict[str, Vec3] = {"stowed": (0.0506, 0.0506, 0.010), "deployed": (0.3104, 0.3121, 0.5757)}
"""Principal inertia [kg m²] of CNUSAIL-1 (paper Table 2), rotors included."""
DEFAULT_BUS_CENTROID: dict[str, Vec3] = {"stowed": (0.005, 0.005, -0.02), "deployed": (0.0, 0.0, -0.05)}
"""Bus centroid relative to the CM (assumed)."""


BOOM_MIN_M = 1e-12
"""Shortest boom capsule of the deployed model [m] (MuJoCo needs its end points apart by more than
mjMINVAL = 1e-15 m)."""


class SpacecraftConfig(StrictModel):
    """``[spacecraft]``: mass properties and geometry (assumed items of are keys).

    ``inertia_kgm2`` and ``bus_centroid_m`` default to the ``configuration``'s Table 2 / assumed geometry
    values. ``r_cp_m``: sail centre of pressure relative to the CM (drag and SRP lever).
    ``drag_surfaces``: ``"sail+bus"`` (default) or ``"sail"`` (paper form, Yoo et al. 2016, Eqs. 13–15).
    """

    configuration: Literal["stowed", "deployed"] = "deployed"
    mass_kg: float = Field(default=4.0, gt=MJ_MINVAL)
    inertia_kgm2: Vec3 | None = None
    r_cp_m: Vec3 = (0.01, 0.01, 0.10)
    bus_centroid_m: Vec3 | None = None
    bus_size_m: Vec3 = (0.1, 0.1, 0.3)
    sail_area_m2: float = Field(default=4.0, gt=0)
    residual_dipole_Am2: Vec3 = (2.887e-4, 2.887e-4, 2.887e-4)
    drag_surfaces: Literal["sail+bus", "sail"] = "sail+bus"

    @field_validator("inertia_kgm2")
    @classmethod
    def _positive(cls, v):
        if v is not None and min(v) <= MJ_MINVAL:
            raise ValueError(f"every principal moment must be > {MJ_MINVAL:g} kg m² (mjMINVAL)")
        return v

    @field_validator("bus_size_m")
    @classmethod
    def _bus_size(cls, v):
        if min(v) <= MJ_MINVAL:
            raise ValueError(f"every edge must be > {MJ_MINVAL:g} m (a MuJoCo box; mjMINVAL)")
        return v

    @model_validator(mode="after")
    def _booms(self) -> SpacecraftConfig:
        """The four booms of the deployed model are capsules of length √A / √2 from the sail centre
        ``r_cp_m``: MuJoCo refuses a capsule whose end points coincide in floats, so that length
        must exceed :data:`BOOM_MIN_M` and the rounding of the centre's coordinates."""
        if self.configuration == "deployed":
            ulp = 4 * 2.0**-52 * max(1.0, *map(abs, self.r_cp_m))
            derived_quantity(
                "boom length √A / √2 (a MuJoCo capsule)",
                self.sail_side_m / math.sqrt(2.0),
                keys={"sail_area_m2": self.sail_area_m2, "r_cp_m": self.r_cp_m},
                minimum=max(BOOM_MIN_M, ulp),
            )
        return self

    @property
    def inertia(self) -> Vec3:
        return self.inertia_kgm2 or TABLE2_INERTIA[self.configuration]

    @property
    def bus_centroid(self) -> Vec3:
        return self.bus_centroid_m or DEFAULT_BUS_CENTROID[self.configuration]

    @property
    def sail_side_m(self) -> float:
        return math.sqrt(self.sail_area_m2)


class MtqConfig(StrictModel):
    """``[actuators.mtq]`` (Yoo et al. 2016, Eqs. 5–7): ``limits`` names a limit set (``"command"`` 0.2/0.2/0.1,
    ``"half_watt"`` 0.02/0.02/0.01 A m²) unless ``dipole_max_Am2`` is given; the 2 s cycle with
    ``blank_s`` magnetometer blanking; ``power_max_W`` for the reported power."""

    limits: Literal["command", "half_watt"] = "command"
    dipole_max_Am2: Vec3 | None = None
    cycle_s: float = Field(default=2.0, gt=0)
    blank_s: float = Field(default=0.2, ge=0)
    power_max_W: float = Field(default=0.5, gt=0)

    @property
    def limit_vector(self) -> np.ndarray:
        """Per-axis dipole limits [A m²]: ``dipole_max_Am2`` or the named set ``limits``."""
        return np.asarray(self.dipole_max_Am2 or MTQ_LIMIT_SETS[self.limits], dtype=float)

    @model_validator(mode="after")
    def _check(self) -> MtqConfig:
        if self.blank_s >= self.cycle_s:
            raise ConfigProblem(
                "blank_s",
                f"must be shorter than cycle_s = {self.cycle_s!r} s, got {self.blank_s!r}",
                others=("cycle_s",),
            )
        if self.dipole_max_Am2 is not None and min(self.dipole_max_Am2) <= 0:
            raise ValueError("dipole_max_Am2: every limit must be > 0")
        return self


class WheelsConfig(StrictModel):
    """``[actuators.wheels]``: rotor (Table 4), limits, DC-motor constants
    (assumed) and the driver model. Rotor masses and inertias exceed mjMINVAL (1e-15)."""

    model: Literal["dc_motor", "ideal"] = "dc_motor"
    electrical: Literal["quasi_static", "substep"] = "quasi_static"
    rotor_inertia_kgm2: float = Field(default=4.5e-6, gt=MJ_MINVAL)
    rotor_transverse_inertia_kgm2: float = Field(default=2.25e-6, gt=MJ_MINVAL)
    rotor_mass_kg: float = Field(default=0.03, gt=MJ_MINVAL)
    torque_max_Nm: float = Field(default=1.96e-4, gt=0)
    speed_max_rpm: float = Field(default=7000.0, gt=0)
    K_M_Nm_A: float = Field(default=6.0e-3, gt=0)
    K_b_Vs_rad: float = Field(default=6.0e-3, gt=0)
    R_ohm: float = Field(default=10.0, gt=0)
    L_H: float = Field(default=1.0e-3, ge=0)
    K_B_Nms: float = Field(default=1.0e-8, ge=0)
    V_max_V: float = Field(default=5.0, gt=0)
    i_max_A: float | None = Field(default=None, gt=0)

    def motor_params(self) -> DCMotorParams:
        """The DC-motor constants of the wheel driver."""
        return DCMotorParams(
            spin_inertia_kgm2=self.rotor_inertia_kgm2,
            torque_max_Nm=self.torque_max_Nm,
            speed_max_rpm=self.speed_max_rpm,
            K_M_Nm_A=self.K_M_Nm_A,
            K_b_Vs_rad=self.K_b_Vs_rad,
            R_ohm=self.R_ohm,
            L_H=self.L_H,
            K_B_Nms=self.K_B_Nms,
            V_max_V=self.V_max_V,
            i_max_A=self.i_max_A,
        )


class ActuatorsConfig(StrictModel):
    """``[actuators]``: ``mtq`` and ``wheels`` sub-tables."""

    mtq: MtqConfig = MtqConfig()
    wheels: WheelsConfig = WheelsConfig()


class UnloadingConfig(StrictModel):
    """``[control.unloading]`` (Yoo et al. 2016, Eq. 39): gain k_rw [1/s], per-axis activation above
    ``threshold_rpm`` (a wheel speed), optional hysteresis ``off_rpm``."""

    enabled: bool = True
    k_rw_per_s: float = Field(default=0.005, gt=0)
    threshold_rpm: float = Field(default=3000.0, gt=0)
    off_rpm: float | None = Field(default=None, ge=0)


class ModesConfig(StrictModel):
    """``[control.modes]``: mode switching (off for the stand-alone scenarios)."""

    enabled: bool = False
    detumble_entry_deg_s: float = Field(default=1.0, gt=0)
    detumble_exit_deg_s: float = Field(default=0.3, gt=0)
    dwell_s: float = Field(default=60.0, ge=0)
    deorbit_at_s: float | None = Field(default=None, ge=0)


class SensorsConfig(StrictModel):
    """``[control.sensors]``: white-noise σ per axis (0 = ideal sensors, the paper's case)."""

    magnetometer_noise_T: float = Field(default=0.0, ge=0)
    gyro_noise_rad_s: float = Field(default=0.0, ge=0)


class CnusailControlConfig(StrictModel):
    """``[control]``: ``mode`` = the law of a stand-alone run (``"bdot"`` detumbling,
    ``"eigen_axis"`` or ``"pd"`` pointing; with ``modes.enabled`` the pointing law), ``command``
    (``"nadir"`` or ``"deorbit"``), sample rate, B-dot and eigen-axis parameters, gain
    recalculation and the sub-tables ``unloading``, ``modes``, ``sensors``.

    ``bdot_law`` is the detumble mode's law (:mod:`magsail_mj.control.detumble_laws`):
    ``"proportional"`` (the paper's M = −K Ḃ, default; with ``bdot_normalised_gain_Am2s`` = k
    given, M = −k Ḃ/‖B‖ instead, the B-dot of Willis et al. 2024's code, k [A m² s]),
    ``"bang_bang"`` (−m_max sign Ḃ per axis), ``"b_cross"`` (m = k (ω × B)/‖B‖², k =
    ``bcross_gain_Nms`` or, absent, Avanzini & Giulietti's 2 n (1 + sin ξ_m) J_min) or
    ``"non_monotonic"`` (Willis et al. 2024: tanh gain ``nonmonotonic_gain_per_Nms``, second-step
    weight ``nonmonotonic_alpha``, the field ``nonmonotonic_lookahead_s`` = T ahead, clamped to the
    table's end; α at most 1e6 and the gains at most 1e12 keep the law's 6×6 system and products
    finite; ``nonmonotonic_field_ahead``: ``"table"`` reads the reference orbit's field table at
    t + T, ``"extrapolated"`` takes B(t) + T Ḃ(t), Ḃ the orbit field's rate at t, as their Monte
    Carlo's law does), or the name of a detumble law
    plug-in (:mod:`magsail_mj.control.detumble_plugins`: registered in the process or installed as
    an entry point; an unknown name is refused naming the laws known) with its parameters
    ``bdot_law_params`` (names → finite numbers, passed to the law; a shipped law takes none)."""

    mode: Literal["bdot", "eigen_axis", "pd"]
    command: Literal["nadir", "deorbit"] = "nadir"
    rate_Hz: float = Field(default=1.0, gt=0)
    bdot_gain_Am2s_T: float = Field(default=5.0e4, gt=0)
    bdot_form: Literal["finite_difference", "filtered"] = "finite_difference"
    bdot_omega_c_rad_s: float = Field(default=0.5, gt=0)
    bdot_normalised_gain_Am2s: float | None = Field(default=None, gt=0, le=1e12)
    bdot_law: str = "proportional"
    bdot_law_params: dict[str, float] = {}
    bcross_gain_Nms: float | None = Field(default=None, gt=0, le=1e12)
    nonmonotonic_gain_per_Nms: float = Field(default=3.0e3, gt=0, le=1e12)
    nonmonotonic_alpha: float = Field(default=100.0, ge=0, le=1e6)
    nonmonotonic_lookahead_s: float = Field(default=600.0, gt=0)
    nonmonotonic_field_ahead: Literal["table", "extrapolated"] = "table"
    slew_rate_max_deg_s: float = Field(default=0.3, gt=0)
    omega_n_rad_s: float = Field(default=0.02, gt=0)
    zeta: float = Field(default=0.9, gt=0)
    gain_clamp_min: float = Field(default=0.1, ge=0, lt=1)
    gyro_comp: Literal["Iw", "Iw+hw", "none"] = "Iw"
    shortest_rotation: bool = True
    gain_recalc: bool = False
    recalc_margin_deg: float = Field(default=20.0, gt=0)
    unloading: UnloadingConfig = UnloadingConfig()
    modes: ModesConfig = ModesConfig()
    sensors: SensorsConfig = SensorsConfig()

    @field_validator("bdot_law")
    @classmethod
    def _known_law(cls, v: str) -> str:
        if v in DETUMBLE_LAWS:  # shipped: no look through the installed entry points (a sweep
            return v  # validates thousands of configs, and that look is most of a validation)
        known = detumble_law_names()
        if v not in known:
            raise ValueError(f"unknown detumble law; known are {', '.join(known)}")
        detumble_law(v)  # loads an installed plug-in now, so a broken one is refused here
        return v

    @field_validator("bdot_law_params")
    @classmethod
    def _finite_params(cls, v: dict[str, float]) -> dict[str, float]:
        return check_params(v)

    @model_validator(mode="after")
    def _params_for_plugins(self):
        if self.bdot_law_params and self.bdot_law in DETUMBLE_LAWS:
            raise ValueError(f"bdot_law_params: the shipped law {self.bdot_law!r} takes none; they are a plug-in's")
        return self


class CnusailInitialConfig(StrictModel):
    """``[initial]``: body attitude relative to the initial command frame (``q_err0_wxyz``,
    scalar-first, normalised on load; identity = aligned with it), body rate ``omega0_deg_s``
    (absent: ω_e(0) = 0, i.e. ω(0) = A(q_e)[0, −ω_o, 0]) and wheel speeds [rpm]."""

    q_err0_wxyz: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    omega0_deg_s: Vec3 | None = None
    wheel_speed_rpm: Vec3 = (0.0, 0.0, 0.0)

    @field_validator("q_err0_wxyz")
    @classmethod
    def _normalise(cls, v):
        return normalised(v, "quaternion [w, x, y, z]")


class AnalysisConfig(StrictModel):
    """``[analysis]``: metric thresholds. ``pointing_threshold_deg`` (5°);
    ``detumble_threshold_deg_s`` for ``detumble_time_s`` (0.3 °/s, assumed: the paper does not quantify it);
    ``settle_margin_s`` after the 5° entry before the steady metrics (default 4/(ζω_n), the 2 %
    settling time of the small-angle loop); ``disturbance_orbit`` computes the one-orbit disturbance
    profile of both attitude modes (pointing runs)."""

    pointing_threshold_deg: float = Field(default=5.0, gt=0)
    detumble_threshold_deg_s: float = Field(default=0.3, gt=0)
    settle_margin_s: float | None = Field(default=None, ge=0)
    disturbance_orbit: bool = True


class CnusailRenderConfig(StrictModel):
    """``[render]``: ``time_lapse`` = simulated seconds per video second (60 for slews,
    600 for detumbling), frames capped at ``max_frames``; camera in world (ECI-parallel) axes."""

    time_lapse: float = Field(default=60.0, gt=0)
    fps: int = Field(default=30, ge=1, le=120)
    max_frames: int = Field(default=900, ge=2)
    azimuth_deg: float = 135.0
    elevation_deg: float = -25.0
    distance_m: float | None = Field(default=None, gt=0)
    markers: bool = True


class LifetimeConfig(StrictModel):
    """``[lifetime]``: regimes → drag areas, methods, atmospheres, stop altitude,
    time caps, the comparison set (generic 3U cubesats, flown sails)."""

    area_nadir_m2: float = Field(default=0.03, gt=0)
    area_deorbit_m2: float = Field(default=4.0, gt=0)
    area_tumbling_m2: float = Field(default=2.035, gt=0)
    methods_cowell: list[Literal["nadir", "deorbit", "tumbling"]] = ["deorbit", "tumbling"]
    atmospheres: list[Literal["exp", "msis_low", "msis_mid", "msis_high"]] = [
        "exp",
        "msis_low",
        "msis_mid",
        "msis_high",
    ]
    stop_altitude_km: float = Field(default=120.0, gt=0)
    cowell_max_days: float = Field(default=1000.0, gt=0)
    cowell_rtol: float = Field(default=1e-9, gt=0, lt=1e-3)
    cowell_corotating: bool = True
    averaged_init: Literal["geometric", "osculating"] = "geometric"
    generic_area_m2: float = Field(default=0.035, gt=0)
    generic_altitudes_km: list[float] = [300, 350, 400, 450, 500, 550, 600, 650, 700, 750, 800]
    references: bool = True


class CnusailSimConfig(SimConfig):
    """``[sim]`` of a CNUSAIL config: the common keys (:class:`magsail_mj.config.SimConfig`) and the
    detumble stop rule of an attitude run. With ``stop_rate_deg_s`` set, the run ends with status
    ``completed`` at the first record (every ``record_every`` steps) at which the body rate ‖ω‖ has
    stayed below ``stop_rate_deg_s`` [°/s] for ``stop_hold_s`` [s] (``t_k − t_a ≥ stop_hold_s``,
    ``t_a`` the first record of the current run of records below; 0: the first record below), so a
    detumble run costs what its detumbling takes (:class:`magsail_mj.sim.HoldBelow`). Absent (the
    default): runs go to ``duration_s``. ``stop_hold_s`` without ``stop_rate_deg_s`` is refused."""

    stop_rate_deg_s: float | None = Field(default=None, gt=0)
    stop_hold_s: float = Field(default=0.0, ge=0)

    @model_validator(mode="after")
    def _stop_rule(self) -> CnusailSimConfig:
        if self.stop_rate_deg_s is None and self.stop_hold_s > 0:
            raise ConfigProblem(
                "stop_hold_s",
                "is the hold time of the stop rule, which sim.stop_rate_deg_s switches on; give "
                f"sim.stop_rate_deg_s or leave stop_hold_s at 0, got {self.stop_hold_s!r}",
                others=("stop_rate_deg_s",),
            )
        return self


@register_config("cnusail", kind_key="kind")
class CnusailConfig(StrictModel):
    """A CNUSAIL scenario config (``magsail_mj/concepts/cnusail/configs/<id>.toml``)."""

    concept: Literal["cnusail"]
    scenario: str = Field(pattern=r"^[a-z0-9_]+$")
    kind: Literal["attitude", "lifetime"] = "attitude"
    description: str = ""
    sim: CnusailSimConfig
    spacecraft: SpacecraftConfig = SpacecraftConfig()
    actuators: ActuatorsConfig = ActuatorsConfig()
    control: CnusailControlConfig = CnusailControlConfig(mode="eigen_axis")
    initial: CnusailInitialConfig = CnusailInitialConfig()
    analysis: AnalysisConfig = AnalysisConfig()
    render: CnusailRenderConfig = CnusailRenderConfig()
    lifetime: LifetimeConfig = LifetimeConfig()
    orbit: OrbitConfig = OrbitConfig(
        semi_major_axis_km=6963.1,
        eccentricity=0.01939,
        inclination_deg=98.0,
        ltdn_h=10.5,
        true_anomaly0_deg=0.0,
        epoch="2016-01-01T00:00:00Z",
        R_E_km=6378.137,
        propagator="j2",
    )
    field: FieldConfig = FieldConfig(model="igrf")
    atmosphere: AtmosphereConfig = AtmosphereConfig(model="exponential")
    sun: SunConfig = SunConfig(model="ephemeris")
    srp: SRPConfig = SRPConfig(enabled=True)
    drag: DragConfig = DragConfig(enabled=True)
    gravity: GravityConfig = GravityConfig(tidal=False, classical_torque=True)

    def environment_config(self) -> EnvironmentConfig:
        """The seven environment tables of this config as one :class:`EnvironmentConfig`."""
        return environment_config_of(self)

    @model_validator(mode="after")
    def _consistent(self) -> CnusailConfig:
        problems = environment_problems(self)
        if self.gravity.tidal:
            problems.append(
                "gravity.tidal: the cubesat is one rigid body at the world origin; use "
                "gravity.classical_torque = true and tidal = false"
            )
        if not self.orbit.enabled:
            problems.append("orbit.enabled: the CNUSAIL scenarios ride the reference orbit; must be true")
        if self.kind == "lifetime" and self.sim.stop_rate_deg_s is not None:
            problems.append(
                "sim.stop_rate_deg_s: the stop rule ends attitude runs; a lifetime run has no body rate to "
                f"watch, got {self.sim.stop_rate_deg_s!r}"
            )
        dt = self.sim.timestep_s
        periods = (
            ("control.rate_Hz", 1.0 / self.control.rate_Hz),
            ("actuators.mtq.cycle_s", self.actuators.mtq.cycle_s),
            ("actuators.mtq.blank_s", self.actuators.mtq.blank_s),
        )
        for key, value in periods if self.kind == "attitude" else ():
            n = value / dt
            if not math.isfinite(n) or abs(n - round(n)) > 1e-9 * max(1.0, n) or (value > 0 and round(n) < 1):
                problems.append(f"{key}: its period {value:g} s must be a whole multiple of sim.timestep_s = {dt:g} s")
        m = self.control.modes
        if m.detumble_exit_deg_s > m.detumble_entry_deg_s:
            problems.append(
                "control.modes.detumble_exit_deg_s: must not exceed "
                f"control.modes.detumble_entry_deg_s = {m.detumble_entry_deg_s!r}, "
                f"got {m.detumble_exit_deg_s!r}"
            )
        if m.enabled and self.control.mode == "bdot":
            problems.append("control.mode: with control.modes.enabled give the pointing law ('eigen_axis' or 'pd')")
        u = self.control.unloading
        if u.off_rpm is not None and u.off_rpm > u.threshold_rpm:
            problems.append(
                "control.unloading.off_rpm: must not exceed control.unloading.threshold_rpm = "
                f"{u.threshold_rpm!r}, got {u.off_rpm!r}"
            )
        problems += self._mass_problems()
        if problems:
            raise ValueError("; ".join(problems))
        self._gains()
        return self

    def _gains(self) -> None:
        """The eigen-axis gains the build derives (:func:`~magsail_mj.concepts.cnusail.eigenaxis.eigen_axis_gains`,
        Eqs. 33–36): ``k = 2 ω_n²``, ``c = 2 ζ ω_n``, ``k_i = c ω_max q_i/|q|`` with q_i/|q| between
        ``gain_clamp_min``/√3 (or the start's own error) and 1, and ``p_i = k / k_i``: finite and > 0
        for every start the clamp allows (validate and run agree)."""
        c = self.control
        w, z, r = c.omega_n_rad_s, c.zeta, math.radians(c.slew_rate_max_deg_s)
        keys = {"control.omega_n_rad_s": w, "control.zeta": z, "control.slew_rate_max_deg_s": c.slew_rate_max_deg_s}
        k = derived_quantity("eigen-axis gain k = 2 ω_n²", 2.0 * w, w, keys=keys)
        cc = derived_quantity("eigen-axis gain c = 2 ζ ω_n", 2.0 * z, w, keys=keys)
        smallest = c.gain_clamp_min / math.sqrt(3.0) if c.gain_clamp_min > 0 else 1.0
        for share in (1.0, smallest):
            k_i = derived_quantity("eigen-axis gain k_i = c ω_max q_i / |q|", cc, r, share, keys=keys)
            derived_quantity("eigen-axis gain p_i = k / k_i", k, 1.0 / k_i, keys=keys)

    def _mass_problems(self) -> list[str]:
        """The MuJoCo bodies of the attitude model: the hub carries m − 3 m_r and
        I − (J_s + 2 J_t) on every axis, which must exceed mjMINVAL and satisfy the triangle
        inequality (the rotors add their own mass and inertia)."""
        sc, w = self.spacecraft, self.actuators.wheels
        inertia_key = "spacecraft.inertia_kgm2" if sc.inertia_kgm2 is not None else "spacecraft.configuration"
        rotors = "actuators.wheels.rotor_inertia_kgm2, actuators.wheels.rotor_transverse_inertia_kgm2"
        out = []
        hub_mass = sc.mass_kg - 3.0 * w.rotor_mass_kg
        if not hub_mass > MJ_MINVAL:
            out.append(
                f"spacecraft.mass_kg: must exceed the three rotors' actuators.wheels.rotor_mass_kg × 3 = "
                f"{3.0 * w.rotor_mass_kg:g} kg by more than {MJ_MINVAL:g} kg, got {sc.mass_kg!r}"
            )
        rotor_sum = w.rotor_inertia_kgm2 + 2.0 * w.rotor_transverse_inertia_kgm2
        hub = [i - rotor_sum for i in sc.inertia]
        if not min(hub) > MJ_MINVAL:
            out.append(
                f"{inertia_key}: every moment must exceed the rotors' J_s + 2 J_t = {rotor_sum:g} kg m² "
                f"({rotors}) by more than {MJ_MINVAL:g}, got {list(sc.inertia)}"
            )
        else:
            a, b, c = hub
            if a + b < c or b + c < a or a + c < b:
                out.append(
                    f"{inertia_key}: the hub inertia (moments minus the rotors' J_s + 2 J_t, {rotors}) "
                    f"{hub} violates the triangle inequality, got {list(sc.inertia)}"
                )
        return out
