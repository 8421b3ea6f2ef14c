"""The flexible truss concept (``truss_magnetorquer``): config schema and scenario wiring.

Spec: truss-magnetorquer-array.md. Scenarios handled here:

- ``dist_vs_central`` (§6): open-loop torque profile about x1, distributed over all top-layer
  y1-struts or concentrated in the central cube, free space;
- ``cantilever`` (§2.7): linear static solve and a MuJoCo settle of the clamped lattice;
- ``free``: the lattice with no actuator (momentum/energy checks, environment-only runs);
- ``detumble`` (§9.3) and ``slew`` (§9.4–9.6): the 75 m truss in orbit with magnetorquer rods in
  its top-layer struts (``actuators.kind = "magnetorquer"``) under B-dot or quaternion feedback
  (``[control]``, ``[maneuver]``); loads, controller, probes, metrics and plots in
  :mod:`magsail_mj.scenarios.truss_orbital`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import mujoco
import numpy as np
from pydantic import Field, model_validator

from magsail_mj.config import (
    MJ_MINVAL,
    ConfigProblem,
    LatticeRenderConfig,
    SimConfig,
    StrictModel,
    check_lattice_numbers,
    finite_product,
    register_concept,
)
from magsail_mj.control.profiles import torque_profile
from magsail_mj.environment.config import (
    AtmosphereConfig,
    DragConfig,
    EnvironmentConfig,
    FieldConfig,
    GravityConfig,
    OrbitConfig,
    SRPConfig,
    SunConfig,
)
from magsail_mj.geometry.lattice import Lattice, make_lattice, strain_check
from magsail_mj.geometry.truss_properties import (
    clamped_nodes,
    loaded_nodes,
    node_masses,
    strut_damping,
    strut_stiffness,
)
from magsail_mj.loads.point_force import NodeForceLoad
from magsail_mj.loads.strut_torque import StrutTorqueLoad
from magsail_mj.mjcf.truss import TrussModelOptions, build_truss_spec
from magsail_mj.scenarios import register_builder
from magsail_mj.sim import RunResult, Simulation

__all__ = ["TrussConfig", "TrussScenario", "build_truss_scenario", "TrussModel", "make_truss_model"]

Vec3 = tuple[float, float, float]

ORBITAL_SCENARIOS = ("detumble", "slew")
"""Scenario kinds driven by the magnetorquer rod array in orbit (spec §9.3–9.6)."""


class LatticeConfig(StrictModel):
    """``[lattice]``: ``units`` cubes per side (N = units + 1 nodes per side, spec §12 E2)."""

    units: int = Field(ge=1, le=200)
    side_m: float = Field(gt=0)
    diagonals: Literal["parity", "X"] = "parity"


class PointMass(StrictModel):
    """An extra particle mass ``kg`` [kg] on lattice node ``node`` (0 .. n_nodes − 1)."""

    node: int = Field(ge=0)
    kg: float = Field(gt=MJ_MINVAL)


class MassConfig(StrictModel):
    """``[mass]``: total mass (``total_kg`` or ``areal_density_kg_m2`` × side²), spec §2.3."""

    total_kg: float | None = Field(default=None, gt=0)
    areal_density_kg_m2: float | None = Field(default=None, gt=0)
    central_fraction: float = Field(default=0.0, ge=0, lt=1)
    central_nodes: Literal["cube8"] = "cube8"
    point_masses: list[PointMass] = Field(default_factory=list)

    @model_validator(mode="after")
    def _one_mass(self) -> MassConfig:
        if (self.total_kg is None) == (self.areal_density_kg_m2 is None):
            raise ConfigProblem("total_kg", "give exactly one of total_kg and areal_density_kg_m2",
                                others=("areal_density_kg_m2",))
        return self


class StiffnessConfig(StrictModel):
    """``[stiffness]``: target plate bending stiffness and its mapping (spec §2.5, §2.7)."""

    EI_Nm2: float = Field(gt=0)
    calibration: Literal["cantilever", "formula"] = "cantilever"


class DampingConfig(StrictModel):
    """``[damping]``: strut damping ratio ζ_s (spec §2.6, §12 S5)."""

    zeta_strut: float = Field(default=0.1, ge=0)


class ActuatorsConfig(StrictModel):
    """``[actuators]``: generic strut torquers (spec §3.1, §6.2) or magnetorquer rods (§3.2, §9.1).

    ``kind = "generic"`` uses ``placement``, ``central_pair``, ``torque_axis``.
    ``kind = "magnetorquer"``: rods in every top-layer x1- and y1-strut (§7.1, §12 O5), dipole
    from ``kappa_Am2_per_kg`` [A m²/kg] × ``rod_mass_kg`` [kg] shared per ``rod_dipole_basis``
    (``"per_family"``: κ_τ M_τ per family, 26.32 A m² per rod for the §9.1 truss; ``"total"``: κ_τ M_τ
    over both families, 13.16 A m²; §12 item O4). The rod mass is part of ``mass.total_kg``,
    spread uniformly over the particles (§12 item S4).
    """

    kind: Literal["generic", "magnetorquer"] = "generic"
    placement: Literal["distributed", "central"] = "distributed"
    central_pair: Literal["top", "diagonal"] = "top"
    torque_axis: Literal["local", "bestfit"] = "local"
    kappa_Am2_per_kg: float = Field(default=100.0, gt=0)
    rod_mass_kg: float | None = Field(default=None, gt=0)
    rod_dipole_basis: Literal["per_family", "total"] = "per_family"

    @model_validator(mode="after")
    def _rods(self) -> ActuatorsConfig:
        if self.kind == "magnetorquer":
            if self.rod_mass_kg is None:
                raise ValueError("rod_mass_kg is required when kind = 'magnetorquer'")
            if self.placement != "distributed":
                raise ValueError("placement: magnetorquer rods sit in every top-layer strut; "
                                 f"only 'distributed' is allowed, got {self.placement!r}")
        return self


class LloydConfig(StrictModel):
    """``[control.lloyd]``: rod selection (spec §7.4); ``seed`` absent = ``sim.seed``."""

    seed: int | None = Field(default=None, ge=0)
    tol_rel: float = Field(default=1e-6, gt=0, lt=1)
    max_iter: int = Field(default=10_000, ge=1)


class ControlConfig(StrictModel):
    """``[control]`` of the orbital rod-array scenarios (spec §9.3–9.4, §11).

    ``kind``: ``"bdot"`` (§9.3, gain ``k_bdot_Nms_per_T2``), ``"quat_pd"`` (§9.4: diagonal gains
    ``Pq_Nm``, ``Pw_Nms``; gravity-gradient compensation ``gg_comp`` with the Eq. 21 inertia, or
    ``gg_comp_inertia_kgm2`` when given, e.g. the printed ``[1893, 1893, 2867]``, §12 O3) or
    ``"open_loop"`` (the ``[profile]`` torque through the allocation).
    ``period_s``: control period (absent = every integration step, §12 O6).
    ``rate_method``: backward-difference form of §4.2. ``allocation``: §7.3 mode (§12 T5).
    ``cache_dir``: on-disk Lloyd cache (relative paths from the working directory; ``""`` = none);
    a count missing there costs one Lloyd run (~1.4 s) the first time it is commanded.
    ``low_authority_threshold_Nm``: |T_ref| above which low delivered torque is reported (§9.4).
    """

    kind: Literal["bdot", "quat_pd", "open_loop"]
    period_s: float | None = Field(default=None, gt=0)
    rate_method: Literal["log", "first_order"] = "log"
    k_bdot_Nms_per_T2: float = Field(default=1e12, ge=0)
    Pq_Nm: Vec3 = (10.0, 50.0, 1.0)
    Pw_Nms: Vec3 = (1600.0, 8000.0, 800.0)
    gg_comp: bool = True
    gg_comp_inertia_kgm2: Vec3 | None = None
    allocation: Literal["paper", "exact"] = "paper"
    lloyd: LloydConfig = LloydConfig()
    cache_dir: str = "runs/lloyd_cache"
    low_authority_threshold_Nm: float = Field(default=0.02, ge=0)

    @model_validator(mode="after")
    def _gains(self) -> ControlConfig:
        for name in ("Pq_Nm", "Pw_Nms"):
            if any(not (g >= 0) for g in getattr(self, name)):
                raise ValueError(f"{name}: gains must be >= 0, got {getattr(self, name)!r}")
        if self.gg_comp_inertia_kgm2 is not None and any(not (v > 0) for v in self.gg_comp_inertia_kgm2):
            raise ValueError(f"gg_comp_inertia_kgm2: moments must be > 0 kg m², got {self.gg_comp_inertia_kgm2!r}")
        return self


Quat = tuple[float, float, float, float]


def _check_unit_quat(q: Quat | None, name: str) -> None:
    if q is not None and abs(math.hypot(*q) - 1.0) > 1e-4:
        raise ValueError(f"{name}: must be a unit quaternion [w, x, y, z] (|q| within 1e-4 of 1), "
                         f"got norm {math.hypot(*q):.6g}")


class ManeuverConfig(StrictModel):
    """``[maneuver]`` (spec §9.4, §11): initial and target attitude, body → inertial, scalar first.

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
    """``[profile]``: open-loop torque about body ``axis`` (spec §6.3–6.4)."""

    kind: Literal["bang_bang_off", "versine"]
    tau_max_Nm: float = Field(ge=0)
    t_end_s: float = Field(gt=0)
    t_v_s: float | None = Field(default=None, gt=0)
    axis: Literal["x1", "y1", "z1"] = "x1"


class InitialConfig(StrictModel):
    """``[initial]``: rigid initial attitude (body → world, scalar-first) and body rate."""

    q0_wxyz: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    omega0_rad_s: Vec3 = (0.0, 0.0, 0.0)

    @model_validator(mode="after")
    def _unit_quaternion(self) -> InitialConfig:
        if abs(math.hypot(*self.q0_wxyz) - 1.0) > 1e-6:
            raise ValueError(f"q0_wxyz: must be a unit quaternion, got norm {math.hypot(*self.q0_wxyz):.6g}")
        return self


class CantileverConfig(StrictModel):
    """``[cantilever]`` (spec §2.7): tip load and the settle damping (default 2 ω₁)."""

    load_N: float = Field(gt=0)
    settle_damping_1_s: float | None = Field(default=None, gt=0)


class RenderConfig(LatticeRenderConfig):
    """``[render]``: video options."""


@register_concept("truss_magnetorquer")
class TrussConfig(StrictModel):
    """A truss scenario config (``models/truss_magnetorquer/*.toml``)."""

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
    initial: InitialConfig = InitialConfig()
    cantilever: CantileverConfig | None = None
    control: ControlConfig | None = None
    maneuver: ManeuverConfig = ManeuverConfig()
    render: RenderConfig = RenderConfig()
    orbit: OrbitConfig = OrbitConfig(enabled=False)
    field: FieldConfig = FieldConfig(model="none")
    atmosphere: AtmosphereConfig = AtmosphereConfig(model="none")
    sun: SunConfig = SunConfig(model="none")
    srp: SRPConfig = SRPConfig()
    drag: DragConfig = DragConfig()
    gravity: GravityConfig = GravityConfig(tidal=False)

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
        want = {"detumble": ("bdot", "open_loop"), "slew": ("quat_pd", "open_loop")}[sc]
        if self.control.kind not in want:
            raise ValueError(f"control.kind: scenario {sc!r} takes {list(want)}, got {self.control.kind!r}")
        if self.control.kind == "open_loop" and self.profile is None:
            raise ValueError("control.kind: 'open_loop' needs the [profile] table")
        if sc == "slew" and self.maneuver.q_ref_wxyz is None:
            raise ValueError("scenario 'slew' needs maneuver.q_ref_wxyz (target attitude)")
        if self.control.period_s is not None and self.control.period_s < self.sim.timestep_s * (1 - 1e-9):
            raise ValueError(f"control.period_s: must be >= sim.timestep_s = {self.sim.timestep_s} s, "
                             f"got {self.control.period_s}")

    def environment_config(self) -> EnvironmentConfig:
        """The environment tables as one validated :class:`EnvironmentConfig`."""
        return EnvironmentConfig(orbit=self.orbit, field=self.field, atmosphere=self.atmosphere, sun=self.sun,
                                 srp=self.srp, drag=self.drag, gravity=self.gravity)

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
            raise ValueError(f"control: the [control] table is used by the scenarios {list(ORBITAL_SCENARIOS)}, "
                             f"not {self.scenario!r}")
        if self.actuators is not None and self.actuators.kind == "magnetorquer":
            if self.scenario not in ORBITAL_SCENARIOS:
                raise ValueError(f"actuators.kind: 'magnetorquer' needs scenario in {list(ORBITAL_SCENARIOS)}, "
                                 f"got {self.scenario!r}")
            total = self.total_mass_kg
            if self.actuators.rod_mass_kg > total:
                raise ConfigProblem("actuators.rod_mass_kg", f"{self.actuators.rod_mass_kg} kg exceeds the total "
                                    f"mass {total} kg (the rods are part of it, §12 S4)", others=(self._mass_key,))
            finite_product("actuators.kappa_Am2_per_kg", self.actuators.kappa_Am2_per_kg, self.actuators.rod_mass_kg,
                           what="rod dipole κ M", others=("actuators.rod_mass_kg",))
        if (self.maneuver.q0_wxyz is not None and "q0_wxyz" in self.initial.model_fields_set
                and not np.allclose(self.maneuver.q0_wxyz, self.initial.q0_wxyz)):
            raise ValueError("maneuver.q0_wxyz and initial.q0_wxyz differ: give the initial attitude once")
        from magsail_mj.environment.config import environment_problems

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
        check_lattice_numbers(units=self.lattice.units, side_m=self.lattice.side_m, total_kg=total,
                              EI_Nm2=self.stiffness.EI_Nm2, zeta=self.damping.zeta_strut,
                              node_mass_fraction=fraction,
                              keys={"side": "lattice.side_m", "mass": self._mass_key, "EI": "stiffness.EI_Nm2",
                                    "zeta": "damping.zeta_strut"})
        n_nodes = 2 * (self.lattice.units + 1) ** 2
        for i, p in enumerate(self.mass.point_masses):
            if p.node >= n_nodes:
                raise ConfigProblem(f"mass.point_masses[{i}].node", f"must be a node index below {n_nodes} "
                                    f"(the lattice's nodes), got {p.node}")
        if self.scenario == "cantilever" and self.cantilever is not None:
            c = self.cantilever
            omega = first_cantilever_omega(self) if c.settle_damping_1_s is None else c.settle_damping_1_s
            finite_product("cantilever.settle_damping_1_s", 2.0 * omega, total, what="node damping",
                           minimum=-1.0, others=("stiffness.EI_Nm2", self._mass_key))
        return self


# ---------------------------------------------------------------------------------- model


@dataclass
class TrussModel:
    """Everything derived from the structural tables of a config."""

    lattice: Lattice
    masses: np.ndarray
    k: np.ndarray
    gamma: float
    calibration_factor: float
    particle_mass_kg: float
    total_kg: float
    spec: mujoco.MjSpec
    fixed_nodes: tuple[int, ...] = ()


def make_truss_model(cfg: TrussConfig, *, fixed_nodes=(), node_damping_1_s: float = 0.0) -> TrussModel:
    """Lattice, masses, spring constants, damping and the MjSpec of a config."""
    lat = make_lattice(units=cfg.lattice.units, side_m=cfg.lattice.side_m, diagonals=cfg.lattice.diagonals)
    total = cfg.mass.total_kg if cfg.mass.total_kg is not None else cfg.mass.areal_density_kg_m2 * cfg.lattice.side_m**2
    masses = node_masses(lat, total_kg=total, central_fraction=cfg.mass.central_fraction,
                         point_masses=[(p.node, p.kg) for p in cfg.mass.point_masses])
    k, c = strut_stiffness(lat, EI_Nm2=cfg.stiffness.EI_Nm2, calibration=cfg.stiffness.calibration)
    m_p = total / lat.n_nodes
    gamma = strut_damping(lat, k, zeta=cfg.damping.zeta_strut, particle_mass_kg=m_p)
    opts = TrussModelOptions(timestep_s=cfg.sim.timestep_s, integrator=cfg.sim.integrator,
                             solver_tolerance=cfg.sim.solver_tolerance,
                             fixed_nodes=tuple(int(i) for i in fixed_nodes),
                             node_damping_1_s=node_damping_1_s, name=f"truss_{cfg.scenario}")
    spec = build_truss_spec(lat, masses=masses, stiffness=k, damping=gamma, options=opts)
    return TrussModel(lattice=lat, masses=masses, k=k, gamma=gamma, calibration_factor=c,
                      particle_mass_kg=m_p, total_kg=total, spec=spec, fixed_nodes=tuple(fixed_nodes))


def actuated_struts(lat: Lattice, act: ActuatorsConfig, axis: str) -> np.ndarray:
    """Struts carrying torquers (spec §6.2): a family of top-layer edges, or the central cube's.

    Torque about x1 comes from y1-struts and about y1 from x1-struts (§12 S6); about z1 both
    families act. ``central_pair="diagonal"`` takes the i0 top strut and the i0+1 bottom strut.
    """
    kinds = {"x1": ["y_edge"], "y1": ["x_edge"], "z1": ["x_edge", "y_edge"]}[axis]
    if act.placement == "distributed":
        return np.concatenate([lat.struts_of_kind(kd, layer=1) for kd in kinds])
    n = lat.units
    i0 = (n - 1) // 2
    out = []
    for kd in kinds:
        for s in lat.struts_of_kind(kd):
            a, b = lat.ijk[lat.struts[s]]
            lo = np.minimum(a, b)
            if kd == "y_edge" and lo[1] == i0 and lo[0] in (i0, i0 + 1):
                want_k = 1 if act.central_pair == "top" or lo[0] == i0 else 0
                if lo[2] == want_k:
                    out.append(s)
            if kd == "x_edge" and lo[0] == i0 and lo[1] in (i0, i0 + 1):
                want_k = 1 if act.central_pair == "top" or lo[1] == i0 else 0
                if lo[2] == want_k:
                    out.append(s)
    return np.array(sorted(out), dtype=int)


# ---------------------------------------------------------------------------------- scenario


@dataclass
class TrussScenario:
    """A truss run: the model plus its loads, probes and post-processing."""

    cfg: TrussConfig
    tm: TrussModel
    spec: mujoco.MjSpec = field(init=False)

    def __post_init__(self) -> None:
        self.spec = self.tm.spec
        self.model = self.spec.compile()
        self.torque_load: StrutTorqueLoad | None = None
        self.rod_load = None
        self.tidal_load = None
        self.controller = None
        self.environment = None
        if self.cfg.orbit.enabled:
            from magsail_mj.environment.environment import Environment

            self.environment = Environment.from_config(self.cfg.environment_config(),
                                                       duration_s=self.cfg.sim.duration_s)

    # -------------------------------------------------------------- runner
    def _profile_command(self):
        p = self.cfg.profile
        axis = {"x1": 0, "y1": 1, "z1": 2}[p.axis]

        def command(state) -> np.ndarray:
            tau = np.zeros(3)
            tau[axis] = float(torque_profile(p.kind, state.t, tau_max=p.tau_max_Nm, t_end=p.t_end_s, t_v=p.t_v_s))
            return tau

        return command

    def environment_loads(self) -> list:
        """Tidal gravity, SRP and drag on the lattice, as the environment tables ask."""
        if self.environment is None:
            return []
        from magsail_mj.environment.surfaces import lattice_top_cells
        from magsail_mj.loads.drag import LatticeDragLoad
        from magsail_mj.loads.srp import LatticeSRPLoad
        from magsail_mj.loads.tidal import TidalGravityLoad

        cfg, lat = self.cfg, self.tm.lattice
        out: list = []
        if cfg.gravity.tidal:
            self.tidal_load = TidalGravityLoad.from_environment(self.environment, np.arange(lat.n_nodes) + 1,
                                                                self.tm.masses)
            out.append(self.tidal_load)
        cells = lattice_top_cells(lat.nodes_per_side)
        if cfg.srp.enabled:
            out.append(LatticeSRPLoad(cells))
        if cfg.drag.enabled:
            out.append(LatticeDragLoad(cells, drag_coefficient=cfg.drag.drag_coefficient))
        return out

    def loads(self) -> list:
        cfg, lat = self.cfg, self.tm.lattice
        out = self.environment_loads()
        if cfg.scenario == "dist_vs_central":
            struts = actuated_struts(lat, cfg.actuators, cfg.profile.axis)
            self.torque_load = StrutTorqueLoad(lat, struts, command=self._profile_command(),
                                               torque_axis=cfg.actuators.torque_axis)
            out.append(self.torque_load)
        if cfg.scenario in ORBITAL_SCENARIOS:
            from magsail_mj.scenarios.truss_orbital import make_rod_load

            self.rod_load = make_rod_load(self)
            out.append(self.rod_load)
        if cfg.scenario == "cantilever":
            tip = loaded_nodes(lat)
            force = np.zeros((tip.size, 3))
            force[:, 2] = -cfg.cantilever.load_N / tip.size
            out.append(NodeForceLoad(tip + 1, force))
        return out

    def initial_rotation(self) -> np.ndarray:
        """Body → world rotation matrix of the initial attitude (``maneuver.q0_wxyz`` or
        ``initial.q0_wxyz``)."""
        from magsail_mj.estimation.attitude import matrix_from_quat

        return matrix_from_quat(np.asarray(self.cfg.q0_wxyz, dtype=float))

    def init_state(self, data: mujoco.MjData) -> None:
        """Rigid initial state about the centre of mass p_c: x_i = p_c + R (p_i − p_c),
        v_i = R (ω₀ × (p_i − p_c)) with ω₀ in body components (undeformed, unstressed)."""
        if self.tm.fixed_nodes:
            return
        w = np.asarray(self.cfg.initial.omega0_rad_s, dtype=float)
        R = self.initial_rotation()
        p = self.tm.lattice.nodes
        pc = np.average(p, axis=0, weights=self.tm.masses)
        data.qpos[:] = ((p - pc) @ R.T + pc - p).ravel()
        data.qvel[:] = (np.cross(w, p - pc) @ R.T).ravel()

    def simulation(self) -> Simulation:
        probes: dict[str, Any] = {"qpos": lambda s, d: d.qpos}
        loads = self.loads()
        if self.torque_load is not None:
            tl, nt = self.torque_load, self.model.ntendon
            probes["torque_cmd_body_Nm"] = lambda s, d: tl.last_command
            probes["strut_activity"] = lambda s, d: tl.activity(nt)
        if self.cfg.scenario in ORBITAL_SCENARIOS:
            from magsail_mj.scenarios.truss_orbital import make_controller, orbital_probes

            self.controller = make_controller(self)
            probes.update(orbital_probes(self))
        return Simulation(model=self.model, duration_s=self.cfg.sim.duration_s, loads=loads,
                          controller=self.controller,
                          probes=probes, record_every=self.cfg.sim.record_every,
                          strain_check=strain_check(self.tm.lattice), max_strain=self.cfg.sim.max_strain,
                          environment=self.environment,
                          checkpoint_every_s=self.cfg.sim.checkpoint_every_s, init=self.init_state)

    # -------------------------------------------------------------- outputs
    def node_positions(self, qpos: np.ndarray) -> np.ndarray:
        """(T, n, 3) node positions from recorded qpos (clamped nodes stay at reference)."""
        from magsail_mj.mjcf.truss import node_positions_from_qpos

        return node_positions_from_qpos(self.model, qpos, n_nodes=self.tm.lattice.n_nodes)

    def postprocess(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        from magsail_mj.scenarios.truss_metrics import cantilever_summary, dynamic_summary

        if self.cfg.scenario == "cantilever":
            return cantilever_summary(self, result)
        if self.cfg.scenario in ORBITAL_SCENARIOS:
            from magsail_mj.scenarios.truss_orbital import orbital_summary

            return orbital_summary(self, result)
        return dynamic_summary(self, result)

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        if self.cfg.scenario in ORBITAL_SCENARIOS:
            from magsail_mj.scenarios.truss_orbital import orbital_plots

            return orbital_plots(self, run_dir, result, series)
        from magsail_mj.scenarios.truss_plots import truss_plots

        return truss_plots(self, run_dir, series)

    def render_info(self) -> dict[str, Any]:
        r = self.cfg.render
        top = self.tm.lattice.top_nodes
        return {
            "title": f"{self.cfg.scenario}: {self.cfg.description}".strip(": "),
            "top_nodes": top.tolist(),
            "overlay": (["surface_sd_m", "torque_cmd_x1_Nm"] if self.cfg.scenario == "dist_vs_central"
                        else _orbital_overlay(self.cfg) if self.cfg.scenario in ORBITAL_SCENARIOS
                        else ["tip_deflection_m"] if self.cfg.scenario == "cantilever"
                        else ["surface_sd_m"]),
            **({"inset": "error_angle_deg" if self.cfg.scenario == "slew" else "omega_norm_rad_s"}
               if self.cfg.scenario in ORBITAL_SCENARIOS else {}),
            "camera": {"azimuth_deg": r.azimuth_deg, "elevation_deg": r.elevation_deg,
                       "distance_m": r.distance_factor * self.cfg.lattice.side_m},
            "exaggeration": r.exaggeration,
            "fps": r.fps,
            "max_frames": r.max_frames,
        }

    def manifest_extra(self) -> dict[str, Any]:
        lat = self.tm.lattice
        extra: dict[str, Any] = {}
        if self.cfg.scenario in ORBITAL_SCENARIOS:
            from magsail_mj.scenarios.truss_orbital import orbital_manifest

            extra = orbital_manifest(self)
        return {
            **extra,
            "model_size": {"nodes": lat.n_nodes, "struts": lat.n_struts, "dofs": int(self.model.nv)},
            "zeta_strut": self.cfg.damping.zeta_strut,
            "gamma_Ns_m": self.tm.gamma,
            "stiffness_calibration": self.cfg.stiffness.calibration,
            "stiffness_calibration_factor": self.tm.calibration_factor,
            "integrator": self.cfg.sim.integrator,
            "timestep_s": self.cfg.sim.timestep_s,
        }


def _orbital_overlay(cfg: TrussConfig) -> list[str]:
    """Overlay series of the orbital videos (values printed on each frame)."""
    if cfg.scenario == "slew":
        return ["error_angle_deg", "omega_norm_rad_s", "N1", "N2", "surface_sd_m"]
    return ["omega_body_rad_s", "N1", "N2", "surface_sd_m"]


@register_builder("truss_magnetorquer")
def build_truss_scenario(cfg: TrussConfig) -> TrussScenario:
    """Scenario object of a truss config (the cantilever clamps its i = 0 edge)."""
    if cfg.scenario == "cantilever":
        lat = make_lattice(units=cfg.lattice.units, side_m=cfg.lattice.side_m, diagonals=cfg.lattice.diagonals)
        c = cfg.cantilever
        damping = c.settle_damping_1_s if c.settle_damping_1_s is not None else 2.0 * first_cantilever_omega(cfg)
        tm = make_truss_model(cfg, fixed_nodes=clamped_nodes(lat), node_damping_1_s=damping)
    else:
        tm = make_truss_model(cfg)
    return TrussScenario(cfg=cfg, tm=tm)


def first_cantilever_omega(cfg: TrussConfig) -> float:
    """ω₁ = 1.875² √(EI / (ρ_L L⁴)) with ρ_L = M/d (spec §2.7) [rad/s]."""
    total = cfg.total_mass_kg
    L = cfg.lattice.side_m
    return 1.875**2 * math.sqrt(cfg.stiffness.EI_Nm2 / (total / L) / L / L / L / L)

