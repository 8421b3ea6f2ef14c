r"""Config schema of the reflector concept (``magsail_mj/concepts/reflector/configs/<id>.toml``): pydantic models of the
tables ``[sim]``, ``[plate]``, ``[coil]``, ``[field]``, ``[control]``, ``[orbit]``, ``[initial]``,
``[gravity]`` and ``[render]``, and the cross-table checks of a scenario kind (``kind`` =
``"detumble"``, ``"pitch"`` or ``"pitch_caps"``).

Units are SI unless a key's suffix says otherwise (``_km``, ``_deg``); paper:
Robb et al. 2020.
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, field_validator, model_validator

from magsail_mj.concepts import register_config
from magsail_mj.config import (
    MAX_STEPS,
    MJ_MINVAL,
    ConfigProblem,
    SimConfig,
    StrictModel,
    derived_quantity,
    finite_product,
    normalised,
)

__all__ = [
    "ReflectorConfig",
    "PlateConfig",
    "CoilConfig",
    "ReflectorFieldConfig",
    "ReflectorControlConfig",
    "ReflectorOrbitConfig",
    "ReflectorInitialConfig",
    "ReflectorGravityConfig",
    "ReflectorRenderConfig",
]

Vec3 = tuple[float, float, float]

COIL_AREA_MARGIN = 1e3
"""Factor bracketing a coil path's dipole per ampere G [m²] around d² in the validation of the
derived controller numbers (G = 0.75 d² / p for the serpentine coils, p >= 1 the column pitch)."""


class PlateConfig(StrictModel):
    """``[plate]``: side d, cell edge L, depth h (default L, A1), areal density σ, and the thickness t
    used in the in-plane moments (default h; caution). d must be a whole number n >= 2 of
    cells L; the plate mass σ d² and its moments σ d² (d² + t²)/12, σ d⁴/6 must be finite and above
    mjMINVAL (1e-15)."""

    side_m: float = Field(default=100.0, gt=0)
    cell_m: float = Field(default=1.0, gt=0)
    depth_m: float | None = Field(default=None, gt=0)
    areal_density_kg_m2: float = Field(default=0.1, gt=0)
    inertia_thickness_m: float | None = Field(default=None, gt=0)

    @model_validator(mode="after")
    def _whole_cells(self) -> PlateConfig:
        ratio = self.side_m / self.cell_m
        if not ratio < MAX_STEPS:
            raise ConfigProblem(
                "side_m",
                f"side_m / cell_m = {ratio:.3g} cells per side is more than a 64-bit count holds, got {self.side_m!r}",
                others=("cell_m",),
            )
        n = round(ratio)
        if n < 2 or abs(n * self.cell_m - self.side_m) > 1e-9 * self.side_m:
            raise ConfigProblem(
                "side_m",
                f"must be a whole multiple (>= 2) of cell_m = {self.cell_m!r}, got {self.side_m!r}",
                others=("cell_m",),
            )
        return self

    @model_validator(mode="after")
    def _mass_properties(self) -> PlateConfig:
        d = self.side_m
        t = self.depth if self.inertia_thickness_m is None else self.inertia_thickness_m
        t_key = "inertia_thickness_m" if self.inertia_thickness_m is not None else "depth_m"
        m = finite_product(
            "areal_density_kg_m2",
            self.areal_density_kg_m2,
            d,
            d,
            minimum=MJ_MINVAL,
            what="plate mass σ d² (MuJoCo needs > mjMINVAL)",
            others=("side_m",),
        )
        finite_product(
            "areal_density_kg_m2",
            m / 12.0,
            d * d + t * t,
            minimum=MJ_MINVAL,
            what="in-plane moment m (d² + t²)/12",
            others=("side_m", t_key),
        )
        finite_product(
            "areal_density_kg_m2", m / 6.0, d, d, minimum=MJ_MINVAL, what="normal moment m d²/6", others=("side_m",)
        )
        return self

    @property
    def depth(self) -> float:
        return self.cell_m if self.depth_m is None else self.depth_m


class CoilConfig(StrictModel):
    """``[coil]``: column pitch p (A2), rows per column (default d/L), maximum current and the
    reference field of the capability metric (Robb et al. 2020, Eqs. 1–4)."""

    pitch_cells: int = Field(default=2, ge=1)
    rows: int | None = Field(default=None, ge=1)
    I_max_A: float = Field(default=10.0, gt=0)
    B_ref_T: float = Field(default=30e-6, gt=0)


class ReflectorFieldConfig(StrictModel):
    """``[field]``: ``"constant"`` (Scenario A: magnitude, fixed ``frame`` = inertial or body,
    ``direction``) or ``"dipole"`` (Scenario B, Eq. 11 with ``B0_T``)."""

    model: Literal["constant", "dipole"]
    magnitude_T: float | None = Field(default=None, gt=0)
    frame: Literal["inertial", "body"] = "inertial"
    direction: Vec3 = (0.0, 0.0, 1.0)
    B0_T: float = Field(default=3.12e-5, gt=0)

    @field_validator("direction")
    @classmethod
    def _unit(cls, v):
        return normalised(v, "vector")


class ReflectorControlConfig(StrictModel):
    """``[control]``: ``kind`` = ``"bdot"`` (Scenario A; ``law``, ``omega_k_rad_s``) or ``"quat_pd"``
    (Scenario B; ``omega_n_rad_s``, ``zeta``, ``rate_term``, ``feedforward``); ``saturation``
    (``"box"`` for B-dot; ``"norm"`` (baseline), ``"field_scaled"`` or ``"per_path"`` for pitch);
    ``cap_Nm`` overrides the geometric coil capability T_max."""

    kind: Literal["bdot", "quat_pd"]
    law: Literal["dipole", "printed", "norm_cap"] = "dipole"
    omega_k_rad_s: float = Field(default=0.01, gt=0)
    omega_n_rad_s: float = Field(default=0.1, gt=0)
    zeta: float = Field(default=0.7, gt=0)
    rate_term: Literal["absolute", "error"] = "absolute"
    feedforward: bool = False
    saturation: Literal["box", "norm", "field_scaled", "per_path"] | None = None
    cap_Nm: float | None = Field(default=None, gt=0)

    @property
    def saturation_mode(self) -> str:
        return self.saturation or ("box" if self.kind == "bdot" else "norm")


class ReflectorOrbitConfig(StrictModel):
    """``[orbit]`` (Scenario B, Robb et al. 2020, Table 1): altitude, Earth radius (A4), μ, ground-point rate (A5),
    nominal run length in orbits (sets the overhead time t_m = n_orbits T_orb / 2); the period and
    the run length must be finite."""

    altitude_km: float = Field(default=800.0, gt=0)
    R_e_km: float = Field(default=6371.0, gt=0)
    mu_m3_s2: float = Field(default=3.986004418e14, gt=0)
    omega_e_rad_s: float = Field(default=2 * math.pi / 86400.0, ge=0)
    n_orbits: float = Field(default=10.0, gt=0)

    @model_validator(mode="after")
    def _period(self) -> ReflectorOrbitConfig:
        r = (self.altitude_km + self.R_e_km) * 1e3
        period = finite_product(
            "altitude_km", r, r, r / self.mu_m3_s2, what="orbital period 2π √(r³/μ)", others=("R_e_km", "mu_m3_s2")
        )
        finite_product(
            "n_orbits",
            self.n_orbits,
            2.0 * math.pi * math.sqrt(period),
            what="nominal run length",
            others=("altitude_km", "mu_m3_s2"),
        )
        return self


class ReflectorInitialConfig(StrictModel):
    """``[initial]`` (Scenario A): body rate and attitude (Scenario B starts on the reference)."""

    omega0_rad_s: Vec3 = (0.1 / math.sqrt(2.0), 0.1 / math.sqrt(2.0), 0.0)
    q0_wxyz: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)

    @field_validator("q0_wxyz")
    @classmethod
    def _normalise(cls, v):
        return normalised(v, "quaternion [w, x, y, z]")


class ReflectorGravityConfig(StrictModel):
    """``[gravity]``: ``gg_torque`` adds the classical gravity-gradient torque (case B5)."""

    gg_torque: bool = False


class ReflectorRenderConfig(StrictModel):
    """``[render]``: video frames (``max_frames`` at ``fps``) and the free camera in world axes."""

    fps: int = Field(default=30, ge=1, le=120)
    max_frames: int = Field(default=600, ge=2)
    azimuth_deg: float = 60.0
    elevation_deg: float = -20.0
    distance_m: float | None = Field(default=None, gt=0)


@register_config("reflector", kind_key="kind")
class ReflectorConfig(StrictModel):
    """A reflector scenario config (``magsail_mj/concepts/reflector/configs/<id>.toml``)."""

    concept: Literal["reflector"]
    scenario: str = Field(pattern=r"^[a-z0-9_]+(/[a-z0-9_]+)*$")
    kind: Literal["detumble", "pitch", "pitch_caps"]
    description: str = ""
    variant: str = "baseline"
    sim: SimConfig
    plate: PlateConfig = PlateConfig()
    coil: CoilConfig = CoilConfig()
    field: ReflectorFieldConfig
    control: ReflectorControlConfig
    orbit: ReflectorOrbitConfig = ReflectorOrbitConfig()
    initial: ReflectorInitialConfig = ReflectorInitialConfig()
    gravity: ReflectorGravityConfig = ReflectorGravityConfig()
    render: ReflectorRenderConfig = ReflectorRenderConfig()

    @model_validator(mode="after")
    def _consistent(self) -> ReflectorConfig:
        problems = []
        c = self.control
        if self.kind == "detumble":
            if c.kind != "bdot":
                problems.append(f"control.kind: a detumble run uses 'bdot', got {c.kind!r}")
            if self.field.model != "constant":
                problems.append(f"field.model: a detumble run uses 'constant', got {self.field.model!r}")
            if c.saturation_mode != "box":
                problems.append(f"control.saturation: B-dot uses 'box' (per-path clip), got {c.saturation!r}")
            if self.gravity.gg_torque:
                problems.append("gravity.gg_torque: Scenario A has no orbit; must be false")
        else:
            if c.kind != "quat_pd":
                problems.append(f"control.kind: a pitch run uses 'quat_pd', got {c.kind!r}")
            if self.field.model != "dipole":
                problems.append(f"field.model: a pitch run uses 'dipole', got {self.field.model!r}")
            if c.saturation_mode == "box":
                problems.append("control.saturation: pitch uses 'norm', 'field_scaled' or 'per_path', got 'box'")
            if self.field.frame != "inertial":
                problems.append("field.frame: the orbit field is inertial; 'body' is a detumble variant")
        n = round(self.plate.side_m / self.plate.cell_m)
        if self.coil.rows is not None and self.coil.rows > n + 1:
            problems.append(f"coil.rows: at most n + 1 = {n + 1} row planes, got {self.coil.rows}")
        if self.coil.pitch_cells > n:
            problems.append(f"coil.pitch_cells: at most the {n} cells per side, got {self.coil.pitch_cells}")
        if problems:
            raise ValueError("; ".join(problems))
        return self

    @model_validator(mode="after")
    def _derived_quantities(self) -> ReflectorConfig:
        """The controller numbers the build derives (:mod:`magsail_mj.concepts.reflector.model`),
        checked finite and > 0 so that ``validate`` and ``run`` agree: each coil path's dipole limit
        ``m_max = T_max / B_ref = I_max G`` with G its dipole per ampere (0.75 d² / p for the
        serpentine coils: computing it builds the coil, O(n²), so G is bracketed by d² within a
        margin of :data:`COIL_AREA_MARGIN` either way), its capability ``T_max = m_max B_ref``, the
        B-dot gain ``k = m_max / (B_ref ω_k)`` (detumble) or the pitch gains ``2 I_jj ω_n²`` and
        ``2 ζ ω_n I_jj`` (exact plate inertia)."""
        d, c, k, p = self.plate.side_m, self.coil, self.control, self.plate
        keys = {"coil.I_max_A": c.I_max_A, "plate.side_m": d}
        for margin in (COIL_AREA_MARGIN, 1.0 / COIL_AREA_MARGIN):
            m = derived_quantity("coil dipole limit m_max = I_max G", c.I_max_A, margin * d * d, keys=keys)
            keys_T = {**keys, "coil.B_ref_T": c.B_ref_T}
            derived_quantity("coil capability T_max = m_max B_ref", m, c.B_ref_T, keys=keys_T)
            if self.kind == "detumble":
                derived_quantity(
                    "B-dot gain k = m_max / (B_ref ω_k)",
                    m,
                    1.0 / c.B_ref_T,
                    1.0 / k.omega_k_rad_s,
                    keys={**keys_T, "control.omega_k_rad_s": k.omega_k_rad_s},
                )
        if self.kind != "detumble":
            t = p.depth if p.inertia_thickness_m is None else p.inertia_thickness_m
            mass = p.areal_density_kg_m2 * d * d
            keys = {
                "control.omega_n_rad_s": k.omega_n_rad_s,
                "plate.side_m": d,
                "plate.areal_density_kg_m2": p.areal_density_kg_m2,
            }
            for inertia in (mass / 12.0 * (d * d + t * t), mass / 6.0 * d * d):
                derived_quantity(
                    "pitch gain P_q = 2 I_jj ω_n²", 2.0 * inertia, k.omega_n_rad_s, k.omega_n_rad_s, keys=keys
                )
                derived_quantity(
                    "pitch gain P_ω = 2 ζ ω_n I_jj",
                    2.0 * k.zeta,
                    k.omega_n_rad_s,
                    inertia,
                    keys={**keys, "control.zeta": k.zeta},
                )
        return self
