"""Config schema of the current-loops concept (``current_loops``) (Robb et al. 2022b).

Scenario kinds (``scenario``): ``sweep``, ``slew`` and ``slew_rigid`` (the rigid
surrogate); their tasks are in :mod:`magsail_mj.concepts.current_loops.tasks`. The circuit
names and axes are those of :mod:`magsail_mj.geometry.current_loops`. Also here: the Eq.-9 wire
sizing of the circuits (:func:`loop_currents`), which validation needs.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import Field, model_validator

from magsail_mj.analysis.loop_scaling import ThermalConstants, loop_sizing
from magsail_mj.concepts import register_config
from magsail_mj.config import (
    ConfigProblem,
    LatticeRenderConfig,
    SimConfig,
    StrictModel,
    check_lattice_numbers,
    finite_product,
)
from magsail_mj.environment.config import (
    EnvironmentConfig,
    FieldConfig,
    GravityConfig,
    OrbitConfig,
    environment_config_of,
    environment_problems,
)
from magsail_mj.geometry.current_loops import AXIS_OF, CIRCUIT_NAMES, COMPOSITES, DReturn

__all__ = [
    "CurrentLoopsConfig",
    "LoopsLatticeConfig",
    "LoopsMassConfig",
    "LoopsStiffnessConfig",
    "LoopsDampingConfig",
    "LoopsCircuitConfig",
    "ThermalTable",
    "LoopsControlConfig",
    "ClassificationConfig",
    "LoopsRenderConfig",
    "loop_currents",
]

Quat = tuple[float, float, float, float]
_SIZING_GEOMETRY = {"A": "A", "B": "B", "C_x": "C", "C_y": "C", "D_x": "D", "D_y": "D"}
"""Circuit name → geometry of the Eq.-9 sizing (analysis.loop_scaling)."""


class LoopsLatticeConfig(StrictModel):
    """``[lattice]``: ``units`` = N cubes per side (N + 1 nodes per side), side D [m]."""

    units: int = Field(ge=2, le=80)
    side_m: float = Field(gt=0)
    diagonals: Literal["parity", "X"] = "parity"


class LoopsMassConfig(StrictModel):
    """``[mass]``: areal density σ_A [kg/m²]; M = σ_A D² shared equally by the particles."""

    areal_density_kg_m2: float = Field(gt=0)


class LoopsStiffnessConfig(StrictModel):
    """``[stiffness]``: plate EI [N m²] and its calibration.

    ``calibration = "formula"`` (reproduction default) uses ``EA_c = 2EI/((N+1)w²)`` unchanged;
    ``"cantilever"`` scales it by EI/EI_eff of the cantilever test (sensitivity). ``form``: the
    elastic forces. ``"tendon"`` (default): exact tendon springs, which to first order equal the
    co-rotational linear form. ``"corotational"``: that linear form,
    ``F = −R̃ K [R̃ᵀ(r − c) − (r₀ − c₀)]`` (cross-check). ``"paper_literal"``: the paper's Eq. 12 as
    printed, ``F = −K (r − R̃ r₀)`` with the unrotated K of the undeformed lattice (sensitivity
    only; valid for small rotations). The two linear forms are loads
    (:class:`~magsail_mj.lattice.linear_stiffness.LinearStiffnessLoad`); the MuJoCo tendons then
    have zero stiffness.
    """

    EI_Nm2: float = Field(gt=0)
    calibration: Literal["formula", "cantilever"] = "formula"
    form: Literal["tendon", "corotational", "paper_literal"] = "tendon"


class LoopsDampingConfig(StrictModel):
    """``[damping]``: Caughey modal damping γ = M Φ diag(2 ξ ω) Φᵀ M of the free lattice.

    ``form = "dense"``: γ as a dense 3n × 3n matrix, every mode exactly on the schedule.
    ``"polynomial"``: γ ≈ M^½ p(M^-½ K M^-½) M^½ plus a low-rank correction; the rigid modes and the
    first ``n_low`` elastic modes get their ratio exactly, every higher mode within ``rtol``
    (relative); about a tenth of the dense cost at N = 27 (see the performance page).
    """

    enabled: bool = True
    schedule: Literal["paper_max", "capped_rayleigh"] = "paper_max"
    xi_low: float = Field(default=0.01, ge=0)
    n_low: int = Field(default=100, ge=1)
    xi_cap: float = Field(default=10.0, gt=0)
    frame: Literal["body", "inertial"] = "body"
    inject: Literal["xfrc"] = "xfrc"
    form: Literal["dense", "polynomial"] = "dense"
    rtol: float = Field(default=0.02, gt=0, lt=1)


class LoopsCircuitConfig(StrictModel):
    """``[loops]``: the circuits and their currents (Robb et al. 2022b, Eqs. 2–11).

    ``circuits``: names from A, B, C_x, C_y, D_x, D_y (F = B + D_x + D_y). ``sizing = "eq9"``:
    the Eq.-9 current of each circuit for this plate (A on the light branch with ``kappa``);
    ``"fixed"``: ``current_A`` (one value per circuit, or one for all). ``sizing_units``: the N
    used in the sizing (default: ``lattice.units``).

    ``d_return``: how the D windings (D_x, D_y) are closed, which the paper does not say
    (:mod:`magsail_mj.geometry.current_loops`). ``"centre"`` (default): a return along the plate's
    middle line, zero area along the plate normal. ``"edge"``: along the plate edge, a parasitic
    normal area n ⌈n/2⌉ w² (about D²/2). ``"other_layer"``: the middle-line return on the other
    layer, which turns the in-plane parasitic component from s w² to (s − n) w² (s the top-layer
    unit steps, about n/2). The Eq.-9 sizing keeps the Table-1 helix form whatever the return.
    """

    circuits: list[str] = Field(min_length=1)
    sizing: Literal["eq9", "fixed"] = "eq9"
    current_A: float | list[float] | None = None
    kappa: float = Field(default=15.0, ge=0)
    sizing_units: int | None = Field(default=None, ge=1)
    d_return: DReturn = "centre"

    @model_validator(mode="after")
    def _names(self) -> LoopsCircuitConfig:
        names = self.expanded()
        bad = [c for c in names if c not in CIRCUIT_NAMES]
        if bad:
            raise ValueError(f"circuits: unknown names {bad}; allowed {list(CIRCUIT_NAMES)} and 'F'")
        if len(set(names)) != len(names):
            raise ValueError(f"circuits: each circuit once, got {names}")
        if self.sizing == "fixed":
            if self.current_A is None:
                raise ValueError("current_A: required when sizing = 'fixed'")
            if isinstance(self.current_A, list) and len(self.current_A) != len(names):
                raise ValueError(f"current_A: one value per circuit ({len(names)}), got {len(self.current_A)}")
        elif self.current_A is not None:
            raise ValueError("current_A: only used with sizing = 'fixed'")
        return self

    def expanded(self) -> list[str]:
        """The circuit names with composites expanded (``"F"`` → B, D_x, D_y), in order."""
        out: list[str] = []
        for c in self.circuits:
            out.extend(COMPOSITES.get(c, (c,)))
        return out


class ThermalTable(StrictModel):
    """``[thermal]``: constants of the wire sizing (Table 2; Γ_r assumed)."""

    T_eq_K: float = Field(default=420.0, gt=0)
    T_ref_K: float = Field(default=293.15, gt=0)
    rho_ref_ohmm: float = Field(default=1.68e-8, gt=0)
    alpha_per_K: float = Field(default=0.00404, ge=0)
    emissivity: float = Field(default=0.7, gt=0, le=1)
    rho_c_kg_m3: float = Field(default=8960.0, gt=0)
    B0_T: float = Field(default=3.12e-5, gt=0)
    R_E_km: float = Field(default=6370.0, gt=0)


class LoopsControlConfig(StrictModel):
    """``[control]`` of the slews: Eq. 18 gains, target, allocation, sample period and the
    body-rate estimator (``"velocity_fit"``: least-squares rigid-velocity fit of the particle
    velocities, default; ``"finite_difference"``: backward difference of the estimated attitude,
    :mod:`magsail_mj.concepts.current_loops.attitude`)."""

    kp_Nm: float = Field(default=600.0, ge=0)
    kw_Nms: float = Field(default=4e5, ge=0)
    q_target: Quat = (math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0)
    allocation: Literal["paper_clip", "direction_preserving"] = "paper_clip"
    period_s: float | None = Field(default=None, gt=0)
    rate_estimator: Literal["velocity_fit", "finite_difference"] = "velocity_fit"

    @model_validator(mode="after")
    def _unit(self) -> LoopsControlConfig:
        if abs(math.hypot(*self.q_target) - 1.0) > 1e-4:
            raise ValueError(
                f"q_target: must be a unit quaternion [w, x, y, z], got norm {math.hypot(*self.q_target):.6g}"
            )
        return self


class ClassificationConfig(StrictModel):
    """``[classification]``: thresholds of the proposed run classification."""

    rigid_residual_frac: float = Field(default=0.005, gt=0)
    rigid_angle_tol_deg: float = Field(default=3.0, gt=0)
    collapse_residual_frac: float = Field(default=0.1, gt=0)
    collapse_strain: float = Field(default=0.5, gt=0)
    collapse_thickness_units: float = Field(default=5.0, gt=0)


class LoopsRenderConfig(LatticeRenderConfig):
    """``[render]``: video options."""

    azimuth_deg: float = 135.0
    elevation_deg: float = -25.0
    distance_factor: float = Field(default=1.9, gt=0)
    max_frames: int = Field(default=400, ge=2)


@register_config("current_loops")
class CurrentLoopsConfig(StrictModel):
    """A current-loops scenario config (``magsail_mj/concepts/current_loops/configs/*.toml``)."""

    concept: Literal["current_loops"]
    scenario: Literal["sweep", "slew", "slew_rigid"]
    description: str = ""
    sim: SimConfig
    lattice: LoopsLatticeConfig
    mass: LoopsMassConfig
    stiffness: LoopsStiffnessConfig
    damping: LoopsDampingConfig = LoopsDampingConfig()
    loops: LoopsCircuitConfig
    thermal: ThermalTable = ThermalTable()
    control: LoopsControlConfig | None = None
    classification: ClassificationConfig = ClassificationConfig()
    render: LoopsRenderConfig = LoopsRenderConfig()
    orbit: OrbitConfig = OrbitConfig(enabled=False)
    field: FieldConfig = FieldConfig(model="constant", constant_T=(27.7e-6, 0.0, 0.0))
    gravity: GravityConfig = GravityConfig(tidal=False)

    @model_validator(mode="after")
    def _tables(self) -> CurrentLoopsConfig:
        sc = self.scenario
        if sc == "sweep":
            if self.orbit.enabled:
                raise ValueError("scenario 'sweep' runs in free space: set orbit.enabled = false")
            if self.field.model != "constant":
                raise ValueError(
                    f"field.model: scenario 'sweep' needs 'constant' (uniform fixed field), got {self.field.model!r}"
                )
            if self.control is not None:
                raise ValueError("control: scenario 'sweep' has constant currents, no [control] table")
        else:
            if self.control is None:
                raise ValueError(f"scenario {sc!r} needs the [control] table")
            axes = sorted(AXIS_OF[c] for c in self.loops.expanded())
            if axes != [0, 1, 2]:
                raise ValueError(
                    f"loops.circuits: scenario {sc!r} needs one circuit per axis x, y, z "
                    f"(e.g. ['C_x', 'C_y', 'B']), got {self.loops.circuits}"
                )
            if self.field.model == "none":
                raise ValueError(f"field.model: scenario {sc!r} needs a field, got 'none'")
            if self.gravity.tidal and not self.orbit.enabled:
                raise ValueError("gravity.tidal: needs orbit.enabled = true")
            if self.field.model != "constant" and not self.orbit.enabled:
                raise ValueError(
                    f"field.model {self.field.model!r} is sampled along the orbit: "
                    "set orbit.enabled = true or use 'constant'"
                )
        if self.orbit.enabled:
            problems = environment_problems(self.environment_config())
            if problems:
                raise ValueError("; ".join(problems))
        return self

    @model_validator(mode="after")
    def _damped_modes(self) -> CurrentLoopsConfig:
        """The polynomial form of the modal damping fits the modes above ``damping.n_low``: the
        lattice must have at least one (``3 · 2 (units + 1)² − 6`` elastic modes). The dense form
        gives every mode ``xi_low`` when the lattice has fewer than ``n_low``."""
        d = self.damping
        if not d.enabled or d.form != "polynomial":
            return self
        elastic = 3 * 2 * (self.lattice.units + 1) ** 2 - 6
        if d.n_low > elastic - 1:
            raise ConfigProblem(
                "damping.n_low",
                f"the {self.lattice.units}-unit lattice has {elastic} elastic modes and the polynomial form fits "
                f"those above n_low, so n_low is at most {elastic - 1}, got {d.n_low}",
                others=("lattice.units", "damping.form"),
            )
        return self

    @model_validator(mode="after")
    def _numbers(self) -> CurrentLoopsConfig:
        """What MuJoCo receives (particle masses and inertias, spring constants) must be finite and
        above mjMINVAL, and the circuit currents (Eq.-9 sizing or fixed) finite."""
        side = self.lattice.side_m
        total = finite_product(
            "mass.areal_density_kg_m2",
            self.mass.areal_density_kg_m2,
            side,
            side,
            what="total mass σ D²",
            others=("lattice.side_m",),
        )
        check_lattice_numbers(
            units=self.lattice.units,
            side_m=side,
            total_kg=total,
            EI_Nm2=self.stiffness.EI_Nm2,
            zeta=0.0,
            keys={
                "side": "lattice.side_m",
                "mass": "mass.areal_density_kg_m2",
                "EI": "stiffness.EI_Nm2",
                "zeta": "stiffness.EI_Nm2",
            },
        )
        self._check_currents()
        return self

    def _check_currents(self) -> None:
        """The circuit currents must come out finite (the Eq.-9 sizing has no solution for
        geometry A beyond its fold, and extreme constants overflow)."""
        if self.loops.sizing == "fixed":
            return
        inputs = {
            "lattice.side_m": self.lattice.side_m,
            "mass.areal_density_kg_m2": self.mass.areal_density_kg_m2,
            "loops.kappa": self.loops.kappa,
            **{f"thermal.{k}": v for k, v in self.thermal.model_dump().items()},
        }
        listed = ", ".join(f"{k} = {v!r}" for k, v in inputs.items())
        try:
            with np.errstate(all="ignore"):
                currents, _ = loop_currents(self)
        except (ArithmeticError, ValueError) as err:
            raise ConfigProblem("loops.sizing", f"the Eq.-9 sizing fails ({err}) for {listed}") from None
        if not np.all(np.isfinite(currents)) or not np.all(currents > 0):
            raise ConfigProblem(
                "loops.sizing",
                f"the Eq.-9 sizing gives currents {currents.tolist()} A (must be finite and > 0) for {listed}",
            )

    def environment_config(self) -> EnvironmentConfig:
        """The environment tables as one :class:`EnvironmentConfig` (no atmosphere, sun, SRP or drag:
        their free-space defaults)."""
        return environment_config_of(self)


def loop_currents(cfg: CurrentLoopsConfig) -> tuple[np.ndarray, list[dict[str, Any]]]:
    """Full current of every circuit (A) and the sizing record of each (Robb et al. 2022b, Eqs. 2–11)."""
    names = cfg.loops.expanded()
    if cfg.loops.sizing == "fixed":
        cur = np.broadcast_to(np.asarray(cfg.loops.current_A, dtype=float), (len(names),)).copy()
        return cur, [{"circuit": n, "current_A": float(c), "sizing": "fixed"} for n, c in zip(names, cur)]
    t = cfg.thermal
    const = ThermalConstants(
        T_eq_K=t.T_eq_K,
        T_ref_K=t.T_ref_K,
        rho_ref_ohmm=t.rho_ref_ohmm,
        alpha_per_K=t.alpha_per_K,
        emissivity=t.emissivity,
        rho_c_kg_m3=t.rho_c_kg_m3,
        B0_T=t.B0_T,
        R_E_m=t.R_E_km * 1e3,
    )
    units = cfg.loops.sizing_units or cfg.lattice.units
    out, rec = [], []
    for n in names:
        s = loop_sizing(
            _SIZING_GEOMETRY[n],
            units=units,
            side_m=cfg.lattice.side_m,
            areal_density_kg_m2=cfg.mass.areal_density_kg_m2,
            kappa=cfg.loops.kappa,
            constants=const,
        )
        out.append(s["current_A"])
        rec.append(
            {"circuit": n, "sizing": "eq9", **{k: float(v) for k, v in s.items() if isinstance(v, (int, float))}}
        )
    return np.asarray(out, dtype=float), rec
