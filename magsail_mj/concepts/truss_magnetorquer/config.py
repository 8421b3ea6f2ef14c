"""Config schema of the flexible truss concept (``truss_magnetorquer``), Robb et al. 2022a.

Scenario kinds (``scenario``): ``dist_vs_central`` (Robb et al. 2022a, Sec. 2), ``cantilever``, ``free``,
``detumble`` and ``slew``; their tasks are in
:mod:`magsail_mj.concepts.truss_magnetorquer.tasks`. Keys in SI units (suffixes name them).
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import Field, model_validator

from magsail_mj.concepts import register_config
from magsail_mj.config import (
    MJ_MINVAL,
    ConfigProblem,
    LatticeRenderConfig,
    SimConfig,
    StrictModel,
    check_lattice_numbers,
    derived_quantity,
    finite_product,
)
from magsail_mj.control.lloyd import Symmetry
from magsail_mj.environment.config import EnvironmentTables, environment_problems

__all__ = [
    "ORBITAL_SCENARIOS",
    "ORBITAL_CONTROL_KINDS",
    "TrussConfig",
    "TrussTables",
    "LatticeConfig",
    "MassConfig",
    "PointMass",
    "StiffnessConfig",
    "DampingConfig",
    "ActuatorsConfig",
    "LloydConfig",
    "MpcConfig",
    "TrussControlConfig",
    "ManeuverConfig",
    "ProfileConfig",
    "TrussInitialConfig",
    "CantileverConfig",
    "TrussRenderConfig",
    "first_cantilever_omega",
    "PERTURBATION_MAX_EDGE_FRACTION",
]

Vec3 = tuple[float, float, float]

ORBITAL_CONTROL_KINDS = {"detumble": ("bdot", "open_loop"), "slew": ("quat_pd", "mpc", "open_loop")}
"""Scenario kinds driven by the magnetorquer rod array in orbit → the
``control.kind`` values each takes."""
ORBITAL_SCENARIOS = tuple(ORBITAL_CONTROL_KINDS)
"""Scenario kinds driven by the magnetorquer rod array in orbit."""


class LatticeConfig(StrictModel):
    """``[lattice]``: ``units`` cubes per side (N = units + 1 nodes per side)."""

    units: int = Field(ge=1, le=200)
    side_m: float = Field(gt=0)
    diagonals: Literal["parity", "X"] = "parity"


class PointMass(StrictModel):
    """An extra particle mass ``kg`` [kg] on lattice node ``node`` (0 .. n_nodes − 1)."""

    node: int = Field(ge=0)
    kg: float = Field(gt=MJ_MINVAL)


class MassConfig(StrictModel):
    """``[mass]``: total mass (``total_kg`` or ``areal_density_kg_m2`` × side²)."""

    total_kg: float | None = Field(default=None, gt=0)
    areal_density_kg_m2: float | None = Field(default=None, gt=0)
    central_fraction: float = Field(default=0.0, ge=0, lt=1)
    central_nodes: Literal["cube8"] = "cube8"
    point_masses: list[PointMass] = Field(default_factory=list)

    @model_validator(mode="after")
    def _one_mass(self) -> MassConfig:
        if (self.total_kg is None) == (self.areal_density_kg_m2 is None):
            raise ConfigProblem(
                "total_kg", "give exactly one of total_kg and areal_density_kg_m2", others=("areal_density_kg_m2",)
            )
        return self


class StiffnessConfig(StrictModel):
    """``[stiffness]``: target plate bending stiffness and its mapping.

    ``twist``: ``"lattice"`` (default) keeps every strut at the same EA, so the twist stiffness is
    whatever the strut pattern gives; ``"plate"`` (a sensitivity variant) scales the face diagonals
    against the cube edges so that the first twist mode has the frequency of a Kirchhoff plate with
    ``D = EI/d`` and Poisson's ratio ``poisson_ratio``, keeping the cantilever ``EI``
    (:mod:`~magsail_mj.concepts.truss_magnetorquer.twist`; needs ``calibration = "cantilever"``).
    """

    EI_Nm2: float = Field(gt=0)
    calibration: Literal["cantilever", "formula"] = "cantilever"
    twist: Literal["lattice", "plate"] = "lattice"
    poisson_ratio: float = Field(default=0.3, gt=-1.0, le=0.5)

    @model_validator(mode="after")
    def _twist(self) -> StiffnessConfig:
        if self.twist == "plate" and self.calibration != "cantilever":
            raise ValueError(
                f"twist: 'plate' keeps the cantilever EI and needs calibration = 'cantilever', "
                f"got calibration = {self.calibration!r}"
            )
        return self


class DampingConfig(StrictModel):
    """``[damping]``: strut damping ratio ζ_s."""

    zeta_strut: float = Field(default=0.1, ge=0)


class ActuatorsConfig(StrictModel):
    """``[actuators]``: generic strut torquers or magnetorquer rods (Robb et al. 2022a, Table 2).

    ``kind = "generic"`` uses ``placement``, ``central_pair``, ``torque_axis``.
    ``kind = "magnetorquer"``: rods in every top-layer x1- and y1-strut, dipole
    from ``kappa_Am2_kg`` [A m²/kg] × ``rod_mass_kg`` [kg] shared per ``rod_dipole_basis``
    (``"per_family"``: κ_τ M_τ per family, 26.32 A m² per rod for the Table 2 truss; ``"total"``: κ_τ M_τ
    over both families, 13.16 A m²; the paper is ambiguous between the two). The rod mass is part of ``mass.total_kg``,
    spread uniformly over the particles.
    ``force_pair``: how a rod's couple reaches the strut's end particles
    (:mod:`~magsail_mj.concepts.truss_magnetorquer.force_pair`): ``"corrected"`` (default) the pair
    perpendicular to the strut whose moment is ``m × B``; ``"printed"`` the paper's Eq. 4 as printed
    (moment ``−m × B`` and an axial tension ``−m·B / (2r)``); ``"printed_sign_fixed"`` Eq. 4 with its
    sign corrected (moment ``m × B`` and an axial tension ``+m·B / (2r)``). Paper-literal variants only.
    """

    kind: Literal["generic", "magnetorquer"] = "generic"
    placement: Literal["distributed", "central"] = "distributed"
    central_pair: Literal["top", "diagonal"] = "top"
    torque_axis: Literal["local", "bestfit"] = "local"
    kappa_Am2_kg: float = Field(default=100.0, gt=0)
    rod_mass_kg: float | None = Field(default=None, gt=0)
    rod_dipole_basis: Literal["per_family", "total"] = "per_family"
    force_pair: Literal["corrected", "printed", "printed_sign_fixed"] = "corrected"

    @model_validator(mode="after")
    def _rods(self) -> ActuatorsConfig:
        if self.kind == "magnetorquer":
            if self.rod_mass_kg is None:
                raise ValueError("rod_mass_kg is required when kind = 'magnetorquer'")
            if self.placement != "distributed":
                raise ValueError(
                    "placement: magnetorquer rods sit in every top-layer strut; "
                    f"only 'distributed' is allowed, got {self.placement!r}"
                )
        elif self.force_pair != "corrected":
            raise ValueError(
                f"force_pair: the rod force pair needs kind = 'magnetorquer', got "
                f"force_pair = {self.force_pair!r} with kind = {self.kind!r}"
            )
        return self


class LloydConfig(StrictModel):
    """``[control.lloyd]``: rod selection; ``seed`` absent = ``sim.seed``; ``symmetry``:
    ``"none"`` (the paper's selection) or ``"mirror_xy"`` (mirror-symmetric about both plate axes
    ``x1 = 0`` and ``y1 = 0``; an odd count switches on one rod fewer, see
    :mod:`magsail_mj.control.lloyd`)."""

    seed: int | None = Field(default=None, ge=0)
    tol_rel: float = Field(default=1e-6, gt=0, lt=1)
    max_iter: int = Field(default=10_000, ge=1)
    symmetry: Symmetry = "none"


class MpcConfig(StrictModel):
    """``[control.mpc]``: the receding-horizon rod control (``control.kind = "mpc"``,
    :mod:`~magsail_mj.concepts.truss_magnetorquer.mpc`): prediction horizon and step [s], RK4
    substeps per step, replan interval [s] (absent = ``step_s``), weight of the rate ``T_ω`` [s],
    of the horizon's last step, of the effort and of the plan's change, SQP iterations per replan,
    and the step of the field forecast table [s]."""

    horizon_s: float = Field(default=3600.0, gt=0)
    step_s: float = Field(default=60.0, gt=0)
    substeps: int = Field(default=3, ge=1)
    replan_s: float | None = Field(default=None, gt=0)
    rate_weight_s: float = Field(default=1000.0, gt=0)
    terminal_weight: float = Field(default=10.0, gt=0)
    effort_weight: float = Field(default=1e-4, ge=0)
    step_weight: float = Field(default=1e-3, ge=0)
    iterations: int = Field(default=1, ge=1)
    forecast_step_s: float = Field(default=10.0, gt=0)

    @model_validator(mode="after")
    def _grid(self) -> MpcConfig:
        if self.horizon_s < self.step_s:
            raise ValueError(f"horizon_s: must be >= step_s = {self.step_s} s, got {self.horizon_s!r}")
        if abs(self.horizon_s / self.step_s - round(self.horizon_s / self.step_s)) > 1e-9:
            raise ValueError(f"horizon_s: must be a whole number of step_s = {self.step_s} s, got {self.horizon_s!r}")
        return self


class TrussControlConfig(StrictModel):
    """``[control]`` of the orbital rod-array scenarios.

    ``kind``: ``"bdot"`` (gain ``k_bdot_Nms_T2``), ``"quat_pd"`` (diagonal gains
    ``Pq_Nm``, ``Pw_Nms``; gravity-gradient compensation ``gg_comp`` with the Eq. 21 inertia, or
    ``gg_comp_inertia_kgm2`` when given, e.g. the printed ``[1893, 1893, 2867]``) or
    ``"open_loop"`` (the ``[profile]`` torque through the allocation) or ``"mpc"`` (receding-horizon
    dipole plan, ``[control.mpc]``; needs ``allocation = "exact"``).
    ``period_s``: control period (absent = every integration step).
    ``rate_method``: backward-difference form. ``allocation``: ``"paper"`` or ``"exact"`` (Eqs. 11–13).
    ``cache_dir``: on-disk Lloyd cache (relative paths from the working directory; ``""`` = none);
    a count missing there costs one Lloyd run (~1.4 s) the first time it is commanded.
    ``low_authority_threshold_Nm``: |T_ref| above which low delivered torque is reported.
    """

    kind: Literal["bdot", "quat_pd", "open_loop", "mpc"]
    period_s: float | None = Field(default=None, gt=0)
    rate_method: Literal["log", "first_order"] = "log"
    k_bdot_Nms_T2: float = Field(default=1e12, ge=0)
    Pq_Nm: Vec3 = (10.0, 50.0, 1.0)
    Pw_Nms: Vec3 = (1600.0, 8000.0, 800.0)
    gg_comp: bool = True
    gg_comp_inertia_kgm2: Vec3 | None = None
    allocation: Literal["paper", "exact"] = "paper"
    lloyd: LloydConfig = LloydConfig()
    cache_dir: str = "runs/lloyd_cache"
    low_authority_threshold_Nm: float = Field(default=0.02, ge=0)
    mpc: MpcConfig = MpcConfig()

    @model_validator(mode="after")
    def _gains(self) -> TrussControlConfig:
        if self.kind == "mpc" and self.allocation != "exact":
            raise ValueError(
                f"allocation: control.kind = 'mpc' commands dipoles and needs allocation = 'exact' "
                f"(the paper's sweep does not return them), got {self.allocation!r}"
            )
        for name in ("Pq_Nm", "Pw_Nms"):
            if any(not (g >= 0) for g in getattr(self, name)):
                raise ValueError(f"{name}: gains must be >= 0, got {getattr(self, name)!r}")
        if self.gg_comp_inertia_kgm2 is not None and any(not (v > 0) for v in self.gg_comp_inertia_kgm2):
            raise ValueError(f"gg_comp_inertia_kgm2: moments must be > 0 kg m², got {self.gg_comp_inertia_kgm2!r}")
        return self


Quat = tuple[float, float, float, float]

PERTURBATION_MAX_EDGE_FRACTION = 0.05
"""``initial.node_perturbation_m`` must stay below this fraction of a cube edge."""


def _check_unit_quat(q: Quat | None, name: str) -> None:
    if q is not None and abs(math.hypot(*q) - 1.0) > 1e-4:
        raise ValueError(
            f"{name}: must be a unit quaternion [w, x, y, z] (|q| within 1e-4 of 1), got norm {math.hypot(*q):.6g}"
        )


class ManeuverConfig(StrictModel):
    """``[maneuver]``: initial and target attitude, body → inertial, scalar first.

    ``q0_wxyz`` (when given) is the initial attitude and replaces ``initial.q0_wxyz``;
    ``q_ref_wxyz`` is the slew target. Both are normalised before use.
    """

    q0_wxyz: Quat | None = None
    q_ref_wxyz: Quat | None = None

    @model_validator(mode="after")
    def _unit(self) -> ManeuverConfig:
        _check_unit_quat(self.q0_wxyz, "q0_wxyz")
        _check_unit_quat(self.q_ref_wxyz, "q_ref_wxyz")
        return self


class ProfileConfig(StrictModel):
    """``[profile]``: open-loop torque about body ``axis`` (Robb et al. 2022a, Table 1).

    ``kind``: ``"bang_bang_off"`` (Table 1), ``"versine"`` (Eq. 9 with the third line's
    denominator read as ``t_v``; rest-to-rest) or ``"versine_printed"`` (Eq. 9 exactly as
    printed, ``t`` in that denominator: the torque jumps to −τ_max at ``t₋ + t_v`` and leaves a
    net impulse, see :func:`magsail_mj.control.profiles.versine_printed`). ``"versine_printed"``
    is an option to test the paper as printed, never a default.
    """

    kind: Literal["bang_bang_off", "versine", "versine_printed"]
    tau_max_Nm: float = Field(ge=0)
    t_end_s: float = Field(gt=0)
    t_v_s: float | None = Field(default=None, gt=0)
    axis: Literal["x1", "y1", "z1"] = "x1"


class TrussInitialConfig(StrictModel):
    """``[initial]``: rigid initial attitude (body → world, scalar-first) and body rate, and an
    optional small asymmetric perturbation of the node positions.

    ``node_perturbation_m`` [m] (default 0: none): every node of a free lattice is displaced by
    ``σ g_i`` with ``g_i`` three independent standard normal draws (generator
    ``numpy.random.default_rng(perturbation_seed)``, ``perturbation_seed`` absent = ``sim.seed``),
    then the mass-weighted mean displacement is removed so the centre of mass stays put; the
    velocities are the rigid ones. ``σ`` must stay below 5 % of a cube edge (a perturbation, not
    a new shape).
    """

    q0_wxyz: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    omega0_rad_s: Vec3 = (0.0, 0.0, 0.0)
    node_perturbation_m: float = Field(default=0.0, ge=0)
    perturbation_seed: int | None = Field(default=None, ge=0)

    @model_validator(mode="after")
    def _unit_quaternion(self) -> TrussInitialConfig:
        if abs(math.hypot(*self.q0_wxyz) - 1.0) > 1e-6:
            raise ValueError(f"q0_wxyz: must be a unit quaternion, got norm {math.hypot(*self.q0_wxyz):.6g}")
        return self


class CantileverConfig(StrictModel):
    """``[cantilever]``: tip load and the settle damping (default 2 ω₁)."""

    load_N: float = Field(gt=0)
    settle_damping_1_s: float | None = Field(default=None, gt=0)


class TrussRenderConfig(LatticeRenderConfig):
    """``[render]``: video options."""


class TrussTables(StrictModel):
    """The truss's own keys and tables (:class:`TrussConfig` adds the environment tables)."""

    concept: Literal["truss_magnetorquer"]
    scenario: Literal["dist_vs_central", "cantilever", "free", "detumble", "slew"]
    description: str = ""
    sim: SimConfig
    lattice: LatticeConfig
    mass: MassConfig
    stiffness: StiffnessConfig
    damping: DampingConfig = DampingConfig()
    actuators: ActuatorsConfig | None = None
    profile: ProfileConfig | None = None
    initial: TrussInitialConfig = TrussInitialConfig()
    cantilever: CantileverConfig | None = None
    control: TrussControlConfig | None = None
    maneuver: ManeuverConfig = ManeuverConfig()
    render: TrussRenderConfig = TrussRenderConfig()


# pydantic lists the fields of the last base first: the truss's own keys, then the environment
# tables (the order of the keys in dumps, the config reference and the validation messages)
@register_config("truss_magnetorquer")
class TrussConfig(EnvironmentTables, TrussTables):
    """A truss scenario config (``magsail_mj/concepts/truss_magnetorquer/configs/*.toml``): the keys
    of :class:`TrussTables`, then the environment tables ``[orbit]`` … ``[gravity]``
    (:class:`~magsail_mj.environment.config.EnvironmentTables`: free space unless set)."""

    @property
    def total_mass_kg(self) -> float:
        """Total mass [kg] (``total_kg`` or areal density × side²)."""
        m = self.mass
        side = self.lattice.side_m
        return m.total_kg if m.total_kg is not None else m.areal_density_kg_m2 * side * side

    @property
    def q0_wxyz(self) -> Quat:
        """Initial attitude: ``maneuver.q0_wxyz`` when given, else ``initial.q0_wxyz``."""
        return self.maneuver.q0_wxyz if self.maneuver.q0_wxyz is not None else self.initial.q0_wxyz

    def _check_orbital(self) -> None:
        sc = self.scenario
        if self.actuators is None or self.actuators.kind != "magnetorquer":
            raise ValueError(f"scenario {sc!r} needs [actuators] with kind = 'magnetorquer'")
        if self.control is None:
            raise ValueError(f"scenario {sc!r} needs the [control] table")
        if not self.orbit.enabled or self.field.model == "none":
            raise ValueError(f"scenario {sc!r} needs orbit.enabled = true and a field model other than 'none'")
        want = ORBITAL_CONTROL_KINDS[sc]
        if self.control.kind not in want:
            raise ValueError(f"control.kind: scenario {sc!r} takes {list(want)}, got {self.control.kind!r}")
        if self.control.kind == "open_loop" and self.profile is None:
            raise ValueError("control.kind: 'open_loop' needs the [profile] table")
        if sc == "slew" and self.maneuver.q_ref_wxyz is None:
            raise ValueError("scenario 'slew' needs maneuver.q_ref_wxyz (target attitude)")
        if self.control.period_s is not None and self.control.period_s < self.sim.timestep_s * (1 - 1e-9):
            raise ValueError(
                f"control.period_s: must be >= sim.timestep_s = {self.sim.timestep_s} s, got {self.control.period_s}"
            )

    @model_validator(mode="after")
    def _tables_for_scenario(self) -> TrussConfig:
        if self.scenario == "dist_vs_central" and (self.actuators is None or self.profile is None):
            raise ValueError("scenario 'dist_vs_central' needs the [actuators] and [profile] tables")
        if self.scenario == "cantilever" and self.cantilever is None:
            raise ValueError("scenario 'cantilever' needs the [cantilever] table")
        if self.scenario == "cantilever" and self.orbit.enabled:
            raise ValueError("scenario 'cantilever' runs in free space: set orbit.enabled = false")
        if self.scenario in ORBITAL_SCENARIOS:
            self._check_orbital()
        elif self.control is not None:
            raise ValueError(
                f"control: the [control] table is used by the scenarios {list(ORBITAL_SCENARIOS)}, "
                f"not {self.scenario!r}"
            )
        if self.actuators is not None and self.actuators.kind == "magnetorquer":
            if self.scenario not in ORBITAL_SCENARIOS:
                raise ValueError(
                    f"actuators.kind: 'magnetorquer' needs scenario in {list(ORBITAL_SCENARIOS)}, got {self.scenario!r}"
                )
            total = self.total_mass_kg
            if self.actuators.rod_mass_kg > total:
                raise ConfigProblem(
                    "actuators.rod_mass_kg",
                    f"{self.actuators.rod_mass_kg} kg exceeds the total mass {total} kg (the rods are part of it)",
                    others=(self._mass_key,),
                )
            finite_product(
                "actuators.kappa_Am2_kg",
                self.actuators.kappa_Am2_kg,
                self.actuators.rod_mass_kg,
                what="rod dipole κ M",
                others=("actuators.rod_mass_kg",),
            )
        if (
            self.maneuver.q0_wxyz is not None
            and "q0_wxyz" in self.initial.model_fields_set
            and not np.allclose(self.maneuver.q0_wxyz, self.initial.q0_wxyz)
        ):
            raise ValueError("maneuver.q0_wxyz and initial.q0_wxyz differ: give the initial attitude once")
        problems = environment_problems(self)
        if problems:
            raise ValueError("; ".join(problems))
        return self

    @property
    def _mass_key(self) -> str:
        return "mass.total_kg" if self.mass.total_kg is not None else "mass.areal_density_kg_m2"

    @model_validator(mode="after")
    def _numbers(self) -> TrussConfig:
        """What MuJoCo receives (particle masses and inertias, spring and dashpot constants) must
        be finite and above mjMINVAL; so must the cantilever settle damping."""
        total = finite_product(self._mass_key, self.total_mass_kg, what="total mass", others=("lattice.side_m",))
        fraction = 1.0 - self.mass.central_fraction
        check_lattice_numbers(
            units=self.lattice.units,
            side_m=self.lattice.side_m,
            total_kg=total,
            EI_Nm2=self.stiffness.EI_Nm2,
            zeta=self.damping.zeta_strut,
            node_mass_fraction=fraction,
            keys={
                "side": "lattice.side_m",
                "mass": self._mass_key,
                "EI": "stiffness.EI_Nm2",
                "zeta": "damping.zeta_strut",
            },
        )
        n_nodes = 2 * (self.lattice.units + 1) ** 2
        edge_m = self.lattice.side_m / self.lattice.units
        if not self.initial.node_perturbation_m < PERTURBATION_MAX_EDGE_FRACTION * edge_m:
            raise ConfigProblem(
                "initial.node_perturbation_m",
                f"must be below {PERTURBATION_MAX_EDGE_FRACTION:g} of a cube edge "
                f"({PERTURBATION_MAX_EDGE_FRACTION * edge_m:.6g} m), got {self.initial.node_perturbation_m!r}",
                others=("lattice.side_m", "lattice.units"),
            )
        for i, p in enumerate(self.mass.point_masses):
            if p.node >= n_nodes:
                raise ConfigProblem(
                    f"mass.point_masses[{i}].node",
                    f"must be a node index below {n_nodes} (the lattice's nodes), got {p.node}",
                )
        if self.scenario == "cantilever" and self.cantilever is not None:
            c = self.cantilever
            omega = first_cantilever_omega(self) if c.settle_damping_1_s is None else c.settle_damping_1_s
            finite_product(
                "cantilever.settle_damping_1_s",
                2.0 * omega,
                total,
                what="node damping",
                minimum=-1.0,
                others=("stiffness.EI_Nm2", self._mass_key),
            )
        return self

    @model_validator(mode="after")
    def _derived_quantities(self) -> TrussConfig:
        """The controller numbers the build derives, checked finite so that ``validate`` and
        ``run`` agree: the gravity-gradient compensation ``3 μ/r⁵ r × (J r)`` forms ``r × J r`` with J
        the Eq. 21 inertia (at most M d², the lattice lying within d × d × d/units) or
        ``control.gg_comp_inertia_kgm2``, and r up to the apoapsis 2a. (The rod allocation is
        scale-free: any finite rod dipole allocates.)"""
        c = self.control
        if c is None or not c.gg_comp or not self.orbit.enabled:
            return self
        a_m = self.orbit.semi_major_axis_km_value * 1e3
        keys: dict[str, Any] = {"lattice.side_m": self.lattice.side_m}
        if c.gg_comp_inertia_kgm2 is not None:
            inertia = max(c.gg_comp_inertia_kgm2)
            keys["control.gg_comp_inertia_kgm2"] = c.gg_comp_inertia_kgm2
        else:
            inertia = self.total_mass_kg * self.lattice.side_m * self.lattice.side_m
            keys[self._mass_key] = (
                self.mass.total_kg if self.mass.total_kg is not None else self.mass.areal_density_kg_m2
            )
        orbit_key = "orbit.semi_major_axis_km" if self.orbit.semi_major_axis_km is not None else "orbit.altitude_km"
        keys[orbit_key] = getattr(self.orbit, orbit_key.split(".")[1])
        derived_quantity(
            "gravity-gradient compensation term r × J r (Eq. 21 inertia, r up to 2a)",
            inertia,
            2 * a_m,
            2 * a_m,
            keys=keys,
        )
        return self


def first_cantilever_omega(cfg: TrussConfig) -> float:
    """ω₁ = 1.875² √(EI / (ρ_L L⁴)) with ρ_L = M/d [rad/s]."""
    total = cfg.total_mass_kg
    L = cfg.lattice.side_m
    return 1.875**2 * math.sqrt(cfg.stiffness.EI_Nm2 / (total / L) / L / L / L / L)
