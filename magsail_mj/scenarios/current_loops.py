"""Current loops built into the flexible truss (``current_loops``): config schema and wiring.

Spec: current-loops.md. Scenarios:

- ``sweep`` (§5, S4): the free flexible plate in a uniform constant field, one circuit at a
  constant current (the Eq.-9 sizing by default), Caughey damping, no other load;
- ``slew`` (§6, S5): the 250 m plate in an 800 km polar orbit (orbit-following world, tidal
  gravity on every particle, IGRF along the reference orbit) under quaternion PD with the
  corrected dipole command and per-axis current allocation over the circuits ``[C_x, C_y, B]``;
- ``slew_rigid`` (§6): the rigid-body surrogate of the slew (one body with the undeformed
  lattice's inertia, dipole torque Σ I_L a_L × B_b, classical gravity-gradient torque).

The lattice, masses and tendon springs are those of the truss concept (§1: uniform particle
masses, ``EA_c = 2 EI / ((N+1) w²)``, ``calibration = "formula"`` by default). Elastic forces
are MuJoCo spring tendons (no tendon damping); Lorentz forces (§4.5), modal damping (§4.4) and
tidal gravity are loads written into ``xfrc_applied``. Post-processing in
:mod:`magsail_mj.scenarios.current_loops_metrics`, plots in
:mod:`magsail_mj.scenarios.current_loops_plots`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import mujoco
import numpy as np
from pydantic import Field, model_validator

from magsail_mj.config import ConfigProblem, LatticeRenderConfig, SimConfig, StrictModel, register_concept
from magsail_mj.config import check_lattice_numbers, finite_product
from magsail_mj.environment.config import EnvironmentConfig, FieldConfig, GravityConfig, OrbitConfig
from magsail_mj.geometry.lattice import Lattice, make_lattice, strain_check
from magsail_mj.geometry.truss_properties import strut_stiffness
from magsail_mj.mjcf.truss import TrussModelOptions, build_truss_spec
from magsail_mj.scenarios import register_builder
from magsail_mj.sim import RunResult, Simulation

__all__ = ["CurrentLoopsConfig", "LoopsScenario", "build_loops_scenario", "CIRCUIT_NAMES"]

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
CIRCUIT_NAMES = ("A", "B", "C_x", "C_y", "D_x", "D_y")
_SIZING_GEOMETRY = {"A": "A", "B": "B", "C_x": "C", "C_y": "C", "D_x": "D", "D_y": "D"}


class LoopsLatticeConfig(StrictModel):
    """``[lattice]``: ``units`` = N cubes per side (N + 1 nodes per side), side D [m]."""

    units: int = Field(ge=2, le=80)
    side_m: float = Field(gt=0)
    diagonals: Literal["parity", "X"] = "parity"


class LoopsMassConfig(StrictModel):
    """``[mass]``: areal density σ_A [kg/m²]; M = σ_A D² shared equally by the particles (§1)."""

    areal_density_kg_m2: float = Field(gt=0)


class LoopsStiffnessConfig(StrictModel):
    """``[stiffness]``: plate EI [N m²] and its calibration (§1; §9 item 12).

    ``calibration = "formula"`` (reproduction default) uses ``EA_c = 2EI/((N+1)w²)`` unchanged;
    ``"cantilever"`` scales it by EI/EI_eff of the cantilever test (sensitivity). The elastic
    forces are exact tendon springs (``form = "tendon"``), which to first order equal the
    co-rotational linear form of §4.1.
    """

    EI_N_m2: float = Field(gt=0)
    calibration: Literal["formula", "cantilever"] = "formula"
    form: Literal["tendon"] = "tendon"


class LoopsDampingConfig(StrictModel):
    """``[damping]``: Caughey modal damping (§4.4; schedule switch of §9 item 6)."""

    enabled: bool = True
    schedule: Literal["paper_max", "capped_rayleigh"] = "paper_max"
    xi_low: float = Field(default=0.01, ge=0)
    n_low: int = Field(default=100, ge=1)
    xi_cap: float = Field(default=10.0, gt=0)
    frame: Literal["body", "inertial"] = "body"
    inject: Literal["xfrc"] = "xfrc"


class LoopsCircuitConfig(StrictModel):
    """``[loops]``: the circuits and their currents (§2, §3).

    ``circuits``: names from A, B, C_x, C_y, D_x, D_y (F = B + D_x + D_y). ``sizing = "eq9"``:
    the Eq.-9 current of each circuit for this plate (A on the light branch with ``kappa``);
    ``"fixed"``: ``current_A`` (one value per circuit, or one for all). ``sizing_units``: the N
    used in the sizing (default: ``lattice.units``).
    """

    circuits: list[str] = Field(min_length=1)
    sizing: Literal["eq9", "fixed"] = "eq9"
    current_A: float | list[float] | None = None
    kappa: float = Field(default=15.0, ge=0)
    sizing_units: int | None = Field(default=None, ge=1)

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
        out: list[str] = []
        for c in self.circuits:
            out.extend(["B", "D_x", "D_y"] if c == "F" else [c])
        return out


class ThermalTable(StrictModel):
    """``[thermal]``: constants of the wire sizing (§3, Table 2; Γ_r assumed, §9 item 13)."""

    T_eq_K: float = Field(default=420.0, gt=0)
    T_ref_K: float = Field(default=293.15, gt=0)
    rho_ref_ohm_m: float = Field(default=1.68e-8, gt=0)
    alpha_per_K: float = Field(default=0.00404, ge=0)
    emissivity: float = Field(default=0.7, gt=0, le=1)
    rho_c_kg_m3: float = Field(default=8960.0, gt=0)
    B0_T: float = Field(default=3.12e-5, gt=0)
    R_E_km: float = Field(default=6370.0, gt=0)


class LoopsControlConfig(StrictModel):
    """``[control]`` of the slews (§6): Eq. 18 gains, target, allocation, sample period."""

    kp_N_m: float = Field(default=600.0, ge=0)
    kw_N_m_s: float = Field(default=4e5, ge=0)
    q_target: Quat = (math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0)
    allocation: Literal["paper_clip", "direction_preserving"] = "paper_clip"
    period_s: float | None = Field(default=None, gt=0)

    @model_validator(mode="after")
    def _unit(self) -> LoopsControlConfig:
        if abs(math.hypot(*self.q_target) - 1.0) > 1e-4:
            raise ValueError(f"q_target: must be a unit quaternion [w, x, y, z], got norm "
                             f"{math.hypot(*self.q_target):.6g}")
        return self


class ClassificationConfig(StrictModel):
    """``[classification]``: thresholds of the proposed run classification (§4.6)."""

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


@register_concept("current_loops")
class CurrentLoopsConfig(StrictModel):
    """A current-loops scenario config (``models/current_loops/*.toml``)."""

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
                raise ValueError("scenario 'sweep' runs in free space (§5): set orbit.enabled = false")
            if self.field.model != "constant":
                raise ValueError(f"field.model: scenario 'sweep' needs 'constant' (uniform fixed field), "
                                 f"got {self.field.model!r}")
            if self.control is not None:
                raise ValueError("control: scenario 'sweep' has constant currents, no [control] table")
        else:
            if self.control is None:
                raise ValueError(f"scenario {sc!r} needs the [control] table")
            axes = sorted(_circuit_axis(c) for c in self.loops.expanded())
            if axes != [0, 1, 2]:
                raise ValueError(f"loops.circuits: scenario {sc!r} needs one circuit per axis x, y, z "
                                 f"(e.g. ['C_x', 'C_y', 'B']), got {self.loops.circuits}")
            if self.field.model == "constant" and self.orbit.enabled:
                pass
            if self.field.model == "none":
                raise ValueError(f"field.model: scenario {sc!r} needs a field, got 'none'")
            if self.gravity.tidal and not self.orbit.enabled:
                raise ValueError("gravity.tidal: needs orbit.enabled = true")
            if self.field.model != "constant" and not self.orbit.enabled:
                raise ValueError(f"field.model {self.field.model!r} is sampled along the orbit: "
                                 "set orbit.enabled = true or use 'constant'")
        if self.orbit.enabled:
            from magsail_mj.environment.config import environment_problems

            problems = environment_problems(self.environment_config())
            if problems:
                raise ValueError("; ".join(problems))
        return self

    @model_validator(mode="after")
    def _numbers(self) -> CurrentLoopsConfig:
        """What MuJoCo receives (particle masses and inertias, spring constants) must be finite and
        above mjMINVAL, and the circuit currents (Eq.-9 sizing or fixed) finite."""
        side = self.lattice.side_m
        total = finite_product("mass.areal_density_kg_m2", self.mass.areal_density_kg_m2, side, side,
                               what="total mass σ D²", others=("lattice.side_m",))
        check_lattice_numbers(units=self.lattice.units, side_m=side, total_kg=total, EI_Nm2=self.stiffness.EI_N_m2,
                              zeta=0.0, keys={"side": "lattice.side_m", "mass": "mass.areal_density_kg_m2",
                                              "EI": "stiffness.EI_N_m2", "zeta": "stiffness.EI_N_m2"})
        self._check_currents()
        return self

    def _check_currents(self) -> None:
        """The circuit currents must come out finite (the Eq.-9 sizing has no solution for
        geometry A beyond its fold, and extreme constants overflow)."""
        if self.loops.sizing == "fixed":
            return
        inputs = {"lattice.side_m": self.lattice.side_m, "mass.areal_density_kg_m2": self.mass.areal_density_kg_m2,
                  "loops.kappa": self.loops.kappa,
                  **{f"thermal.{k}": v for k, v in self.thermal.model_dump().items()}}
        listed = ", ".join(f"{k} = {v!r}" for k, v in inputs.items())
        try:
            with np.errstate(all="ignore"):
                currents, _ = loop_currents(self)
        except (ArithmeticError, ValueError) as err:
            raise ConfigProblem("loops.sizing", f"the Eq.-9 sizing fails ({err}) for {listed}") from None
        if not np.all(np.isfinite(currents)) or not np.all(currents > 0):
            raise ConfigProblem("loops.sizing", f"the Eq.-9 sizing gives currents {currents.tolist()} A "
                                f"(must be finite and > 0) for {listed}")

    def environment_config(self) -> EnvironmentConfig:
        from magsail_mj.environment.config import AtmosphereConfig, DragConfig, SRPConfig, SunConfig

        return EnvironmentConfig(orbit=self.orbit, field=self.field, atmosphere=AtmosphereConfig(model="none"),
                                 sun=SunConfig(model="none"), srp=SRPConfig(), drag=DragConfig(),
                                 gravity=self.gravity)


def _circuit_axis(name: str) -> int:
    return {"A": 2, "B": 2, "C_x": 0, "D_x": 0, "C_y": 1, "D_y": 1}[name]


# ---------------------------------------------------------------------------------- model


@dataclass
class LoopsModel:
    """Everything derived from the structural and loop tables of a config."""

    lattice: Lattice
    masses: np.ndarray
    k: np.ndarray
    EA_N: float
    calibration_factor: float
    circuits: list
    currents_A: np.ndarray
    sizing: list[dict[str, Any]]
    spec: mujoco.MjSpec


def loop_currents(cfg: CurrentLoopsConfig) -> tuple[np.ndarray, list[dict[str, Any]]]:
    """Full current of every circuit (A) and the sizing record of each (§3 item 1)."""
    from magsail_mj.analysis.loop_scaling import ThermalConstants, loop_sizing

    names = cfg.loops.expanded()
    if cfg.loops.sizing == "fixed":
        cur = np.broadcast_to(np.asarray(cfg.loops.current_A, dtype=float), (len(names),)).copy()
        return cur, [{"circuit": n, "current_A": float(c), "sizing": "fixed"} for n, c in zip(names, cur)]
    t = cfg.thermal
    const = ThermalConstants(T_eq_K=t.T_eq_K, T_ref_K=t.T_ref_K, rho_ref_ohm_m=t.rho_ref_ohm_m,
                             alpha_per_K=t.alpha_per_K, emissivity=t.emissivity, rho_c_kg_m3=t.rho_c_kg_m3,
                             B0_T=t.B0_T, R_E_m=t.R_E_km * 1e3)
    units = cfg.loops.sizing_units or cfg.lattice.units
    out, rec = [], []
    for n in names:
        s = loop_sizing(_SIZING_GEOMETRY[n], units=units, side_m=cfg.lattice.side_m,
                        areal_density_kg_m2=cfg.mass.areal_density_kg_m2, kappa=cfg.loops.kappa, constants=const)
        out.append(s["current_A"])
        rec.append({"circuit": n, "sizing": "eq9", **{k: float(v) for k, v in s.items()
                                                        if isinstance(v, (int, float))}})
    return np.asarray(out, dtype=float), rec


def make_loops_model(cfg: CurrentLoopsConfig) -> LoopsModel:
    """Lattice, masses, springs, circuits, currents and the MjSpec (no tendon damping)."""
    from magsail_mj.geometry.current_loops import circuits as make_circuits

    lat = make_lattice(units=cfg.lattice.units, side_m=cfg.lattice.side_m, diagonals=cfg.lattice.diagonals)
    M = cfg.mass.areal_density_kg_m2 * cfg.lattice.side_m**2
    masses = np.full(lat.n_nodes, M / lat.n_nodes)
    k, c = strut_stiffness(lat, EI_Nm2=cfg.stiffness.EI_N_m2, calibration=cfg.stiffness.calibration)
    EA = float(k[0] * lat.rest_length[0])
    circuits = make_circuits(lat, cfg.loops.expanded())
    currents, sizing = loop_currents(cfg)
    opts = TrussModelOptions(timestep_s=cfg.sim.timestep_s, integrator=cfg.sim.integrator,
                             solver_tolerance=cfg.sim.solver_tolerance,
                             name=f"current_loops_{cfg.scenario}")
    spec = build_truss_spec(lat, masses=masses, stiffness=k, damping=0.0, options=opts)
    for flag in ("CONSTRAINT", "EQUALITY", "FRICTIONLOSS", "LIMIT"):
        spec.option.disableflags |= int(getattr(mujoco.mjtDisableBit, f"mjDSBL_{flag}"))
    return LoopsModel(lattice=lat, masses=masses, k=k, EA_N=EA, calibration_factor=c, circuits=circuits,
                      currents_A=currents, sizing=sizing, spec=spec)


def rigid_plate_spec(cfg: CurrentLoopsConfig, inertia: np.ndarray, mass: float) -> mujoco.MjSpec:
    """One free body with the undeformed lattice's inertia tensor (``slew_rigid``)."""
    from magsail_mj.mjcf.common import free_space_spec

    spec = free_space_spec(name="current_loops_slew_rigid", timestep_s=cfg.sim.timestep_s,
                           integrator=cfg.sim.integrator, solver_tolerance=cfg.sim.solver_tolerance)
    D = cfg.lattice.side_m
    w = D / cfg.lattice.units
    spec.stat.extent = float(D)
    spec.visual.map.zfar = 50.0
    spec.visual.global_.offwidth = 1920
    spec.visual.global_.offheight = 1080
    spec.worldbody.add_light(name="sun", pos=[0, 0, 3 * D], dir=[0, 0, -1],
                             type=int(mujoco.mjtLightType.mjLIGHT_DIRECTIONAL), diffuse=[0.8, 0.8, 0.8])
    body = spec.worldbody.add_body(name="plate", pos=[0, 0, 0])
    body.add_freejoint(name="plate_free")
    body.explicitinertial = True
    body.ipos = [0.0, 0.0, 0.0]  # without it to_xml() drops the explicit inertial (MuJoCo 4)
    body.mass = float(mass)
    body.fullinertia = [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]]
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[D / 2, D / 2, w / 2], contype=0, conaffinity=0,
                  mass=0.0, density=0.0, rgba=[0.75, 0.75, 0.8, 0.6])
    return spec


# ---------------------------------------------------------------------------------- loads


class WorkLedger:
    """Work done by held nodal forces: ``W += F_{k−1} · (x_k − x_{k−1})`` (exact for forces held
    over the step). Put it after the loads it watches; they expose ``last_forces`` (n, 3)."""

    name = "work_ledger"

    def __init__(self, watched: dict[str, Any], node_bodies: np.ndarray):
        self.watched = watched
        self.node_bodies = node_bodies
        self.work = {k: 0.0 for k in watched}
        self._x = None
        self._f: dict[str, np.ndarray] = {}

    def add(self, state, xfrc: np.ndarray) -> None:
        x = state.pos[self.node_bodies]
        if self._x is not None:
            dx = x - self._x
            for k, f in self._f.items():
                self.work[k] += float(np.einsum("ij,ij->", f, dx))
        self._x = x.copy()
        for k, load in self.watched.items():
            f = getattr(load, "last_forces", None)
            if f is not None:
                self._f[k] = np.array(f, copy=True)

    def values(self, pos: np.ndarray | None = None) -> np.ndarray:
        """Work of every watched load up to now; with the current positions ``pos`` (all bodies)
        the last held step is included (the recorder samples before the loads run)."""
        out = np.array([self.work[k] for k in self.watched])
        if pos is not None and self._x is not None:
            dx = pos[self.node_bodies] - self._x
            out += [float(np.einsum("ij,ij->", self._f[k], dx)) if k in self._f else 0.0 for k in self.watched]
        return out


class _HeldForces:
    """Wraps a load with a ``forces(pos, vel)`` method; keeps ``last_forces`` for the ledger."""

    def __init__(self, load, body_offset: int = 1):
        self.load = load
        self.name = load.name
        self.n = load.n
        self._sl = slice(body_offset, body_offset + load.n)
        self.last_forces = np.zeros((load.n, 3))

    def add(self, state, xfrc: np.ndarray) -> None:
        self.last_forces = self.load.forces(state.pos[self._sl], state.vel[self._sl])
        xfrc[self._sl, :3] += self.last_forces


class RigidLoopTorqueLoad:
    """Dipole torque of the loops on the rigid surrogate: ``T = (R Σ_L I_L a_L) × B`` (world)."""

    name = "rigid_loop_torque"

    def __init__(self, body_id: int, areas_body: np.ndarray, field_world: np.ndarray | None = None):
        self.body_id = int(body_id)
        self.areas_body = np.asarray(areas_body, dtype=float)  # (L, 3)
        self.field_world = field_world
        self.last_torque = np.zeros(3)

    def add(self, state, xfrc: np.ndarray) -> None:
        from magsail_mj.estimation.attitude import matrix_from_quat

        cmd = state.ctrl
        if cmd is None:
            return
        R = matrix_from_quat(state.xquat[self.body_id])
        m_world = R @ (np.asarray(cmd.currents_A) @ self.areas_body)
        B = self.field_world if self.field_world is not None else state.env.B_eci
        self.last_torque = np.cross(m_world, B)
        xfrc[self.body_id, 3:] += self.last_torque


# ---------------------------------------------------------------------------------- scenario


@dataclass
class LoopsScenario:
    """A current-loops run: model, loads, controller, probes and post-processing."""

    cfg: CurrentLoopsConfig
    lm: LoopsModel
    spec: mujoco.MjSpec = field(init=False)

    def __post_init__(self) -> None:
        from magsail_mj.estimation.attitude import particle_inertia

        cfg, lat = self.cfg, self.lm.lattice
        self.rigid = cfg.scenario == "slew_rigid"
        self.inertia = particle_inertia(lat.nodes, self.lm.masses)
        self.areas0 = np.array([c.vector_area(lat.nodes) for c in self.lm.circuits])
        if self.rigid:
            self.spec = rigid_plate_spec(cfg, self.inertia.tensor, self.inertia.mass)
        else:
            self.spec = self.lm.spec
        self.model = self.spec.compile()
        self.node_bodies = np.arange(lat.n_nodes) + 1
        self.environment = None
        if cfg.orbit.enabled:
            from magsail_mj.environment.environment import Environment

            self.environment = Environment.from_config(cfg.environment_config(), duration_s=cfg.sim.duration_s)
        self.field_fixed = (np.asarray(cfg.field.constant_T, dtype=float) if cfg.field.model == "constant"
                            else None)
        self.lorentz = None
        self.damping_load = None
        self.ledger = None
        self.tidal = None
        self.controller = None
        self.rigid_torque = None
        self.gg_load = None
        self._modes = None

    # -------------------------------------------------------------- physics pieces
    def modes(self):
        """Undamped modes of the lattice (cached on disk by :mod:`magsail_mj.analysis.modes`)."""
        if self._modes is None:
            from magsail_mj.analysis.modes import lattice_modes

            lat = self.lm.lattice
            self._modes = lattice_modes(lat.nodes, lat.struts, self.lm.k, self.lm.masses)
        return self._modes

    def damping_info(self) -> dict[str, Any]:
        """Schedule, ω range and the RK4 stability products 2 ξ ω_max Δt (§4.4)."""
        from magsail_mj.analysis.modes import damping_ratios

        d = self.cfg.damping
        md = self.modes()
        omega = np.asarray(md.omega)
        xi = damping_ratios(omega, n_rigid=md.n_rigid, schedule=d.schedule, xi_low=d.xi_low, n_low=d.n_low,
                            xi_cap=d.xi_cap)
        el = omega > 0
        dt = self.cfg.sim.timestep_s
        return {
            "schedule": d.schedule, "frame": d.frame, "inject": d.inject,
            "mode_count_from": "first elastic mode (six rigid modes excluded)",
            "omega_first_elastic_rad_s": float(omega[el].min()), "omega_max_rad_s": float(omega.max()),
            "xi_max": float(np.max(xi[el])) if d.enabled else 0.0,
            "stability_product_max": float(np.max(2 * xi[el] * omega[el] * dt)) if d.enabled else 0.0,
            "omega_max_dt": float(omega.max() * dt),
        }

    def loads(self) -> list:
        cfg, lat = self.cfg, self.lm.lattice
        out: list = []
        if self.rigid:
            self.rigid_torque = RigidLoopTorqueLoad(1, self.areas0, self.field_fixed)
            out.append(self.rigid_torque)
            if cfg.gravity.tidal:
                from magsail_mj.loads.tidal import GravityGradientTorqueLoad

                self.gg_load = GravityGradientTorqueLoad(1, self.inertia.tensor, mu=cfg.orbit.mu_m3_s2)
                out.append(self.gg_load)
            return out
        from magsail_mj.loads.lorentz import CircuitSegments, LorentzLoad

        self.segments = CircuitSegments(self.lm.circuits)
        self.lorentz = LorentzLoad(self.segments, n_nodes=lat.n_nodes,
                                   currents_A=None if cfg.scenario != "sweep" else self.lm.currents_A,
                                   B_world=self.field_fixed)
        out.append(self.lorentz)
        watched = {"lorentz": self.lorentz}
        if cfg.gravity.tidal:
            from magsail_mj.loads.tidal import TidalGravityLoad

            self.tidal = TidalGravityLoad.from_environment(self.environment, self.node_bodies, self.lm.masses)
            out.append(self.tidal)
        if cfg.damping.enabled:
            from magsail_mj.loads.modal_damping import ModalDampingLoad

            d = cfg.damping
            self.damping_load = _HeldForces(ModalDampingLoad.for_lattice(
                nodes=lat.nodes, struts=lat.struts, k=self.lm.k, masses=self.lm.masses, schedule=d.schedule,
                xi_low=d.xi_low, n_low=d.n_low, xi_cap=d.xi_cap, frame=d.frame))
            out.append(self.damping_load)
            watched["damping"] = self.damping_load
        self.ledger = WorkLedger(watched, self.node_bodies)
        out.append(self.ledger)
        return out

    def make_controller(self):
        from magsail_mj.control.loop_attitude import LoopAttitudeController

        cfg, lat = self.cfg, self.lm.lattice
        c = cfg.control
        axes = [_circuit_axis(n) for n in cfg.loops.expanded()]
        order = np.argsort(axes)  # circuit index of the x, y, z axes
        self.axis_circuit = order
        I_max = self.lm.currents_A[order]
        # common m_max = μ σ D⁴ / (8 B0 R_E³) (§6), the dipole every Eq.-9 circuit has at full current
        t = cfg.thermal
        from magsail_mj.environment.constants import MU_EARTH

        mu = cfg.orbit.mu_m3_s2 if cfg.orbit.enabled else MU_EARTH
        m_max = mu * cfg.mass.areal_density_kg_m2 * cfg.lattice.side_m**4 / (8 * t.B0_T * (t.R_E_km * 1e3) ** 3)
        self.m_max = m_max
        period = c.period_s or cfg.sim.timestep_s
        ctrl = LoopAttitudeController(period_s=period, p_ref=lat.nodes, masses=self.lm.masses,
                                      node_bodies=self.node_bodies, q_target=np.asarray(c.q_target),
                                      kp_N_m=c.kp_N_m, kw_N_m_s=c.kw_N_m_s, m_max_A_m2=m_max, I_max_A=I_max,
                                      allocation=c.allocation, field_world=self.field_fixed)
        if self.rigid:
            ctrl = _RigidWrapper(ctrl)
        return _CircuitOrder(ctrl, order)

    def simulation(self) -> Simulation:
        from magsail_mj.scenarios.current_loops_metrics import probes

        loads = self.loads()
        if self.cfg.scenario != "sweep":
            self.controller = self.make_controller()
        check = None if self.rigid else strain_check(self.lm.lattice)
        sim = Simulation(model=self.model, duration_s=self.cfg.sim.duration_s, loads=loads,
                         controller=self.controller, environment=self.environment, probes=probes(self),
                         record_every=self.cfg.sim.record_every, strain_check=check,
                         max_strain=self.cfg.sim.max_strain, checkpoint_every_s=self.cfg.sim.checkpoint_every_s)
        return sim

    # -------------------------------------------------------------- outputs
    def postprocess(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        from magsail_mj.scenarios.current_loops_metrics import postprocess

        return postprocess(self, result)

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        from magsail_mj.scenarios.current_loops_plots import loops_plots

        return loops_plots(self, run_dir, {**result.records, **series}, result.records.get("qpos"))

    def render_info(self) -> dict[str, Any]:
        r = self.cfg.render
        lat = self.lm.lattice
        info = {
            "title": f"current loops {self.cfg.scenario}: {self.cfg.description}".strip(": "),
            "overlay": (["strain_energy_J", "rotation_angle_deg"] if self.cfg.scenario == "sweep"
                        else ["error_angle_deg"] if self.rigid else ["error_angle_deg", "strain_energy_J"]),
            "camera": {"azimuth_deg": r.azimuth_deg, "elevation_deg": r.elevation_deg,
                       "distance_m": r.distance_factor * self.cfg.lattice.side_m},
            "exaggeration": r.exaggeration, "fps": r.fps, "max_frames": r.max_frames,
        }
        if not self.rigid:
            info["top_nodes"] = lat.top_nodes.tolist()
            rgba = {0: [0.85, 0.15, 0.1, 1.0], 1: [0.1, 0.7, 0.2, 1.0], 2: [0.15, 0.35, 0.95, 1.0]}
            info["strut_colours"] = [{"name": c.name, "axis": int(c.axis), "rgba": rgba[int(c.axis)],
                                      "struts": [int(s) for s in np.unique(c.strut_index(lat))]}
                                     for c in self.lm.circuits]
        return info

    def manifest_extra(self) -> dict[str, Any]:
        from magsail_mj.geometry.truss_properties import _ratio_formula

        lat = self.lm.lattice
        extra: dict[str, Any] = {
            "model_size": {"nodes": lat.n_nodes, "struts": lat.n_struts, "dofs": int(self.model.nv)},
            "EA_c_N": self.lm.EA_N,
            "stiffness_calibration": self.cfg.stiffness.calibration,
            "stiffness_calibration_factor": self.lm.calibration_factor,
            "EI_eff_over_EI_formula_cantilever": float(_ratio_formula(lat.units, lat.diagonals)),
            "particle_mass_kg": float(self.lm.masses[0]),
            "circuits": [{"name": c.name, "axis": int(c.axis), "segments": int(len(c.src)),
                          "vector_area_m2": a.tolist(), "length_m": float(c.length(lat.nodes)),
                          "current_A": float(i), "dipole_A_m2": (i * a).tolist()}
                         for c, a, i in zip(self.lm.circuits, self.areas0, self.lm.currents_A)],
            "sizing": self.lm.sizing,
            "kappa": self.cfg.loops.kappa,
            "integrator": self.cfg.sim.integrator, "timestep_s": self.cfg.sim.timestep_s,
        }
        if self.cfg.damping.enabled and not self.rigid:
            extra["damping"] = self.damping_info()
        if self.rigid:
            extra["rigid_inertia_kg_m2"] = self.inertia.tensor.tolist()
        return extra


class _RigidWrapper:
    """Runs a :class:`LoopAttitudeController` on a free body's pose and rate (``slew_rigid``)."""

    def __init__(self, ctrl):
        self.ctrl = ctrl
        self.period_s = ctrl.period_s

    def update(self, state):
        from magsail_mj.estimation.attitude import matrix_from_quat

        q = np.asarray(state.xquat[1], dtype=float)
        if q @ self.ctrl._q_prev < 0:
            q = -q
        self.ctrl._q_prev = q
        R = matrix_from_quat(q)
        omega_body = R.T @ state.omega[1]
        return self.ctrl.command(R, q, omega_body, self.ctrl.field(state))


class _CircuitOrder:
    """Maps the controller's x, y, z currents onto the config's circuit order."""

    def __init__(self, ctrl, axis_circuit: np.ndarray):
        self.ctrl = ctrl
        self.period_s = ctrl.period_s
        self.inverse = np.argsort(axis_circuit)

    def update(self, state):
        cmd = self.ctrl.update(state)
        cmd.currents_axis_A = cmd.currents_A
        cmd.currents_A = cmd.currents_A[self.inverse]
        return cmd


@register_builder("current_loops")
def build_loops_scenario(cfg: CurrentLoopsConfig) -> LoopsScenario:
    return LoopsScenario(cfg=cfg, lm=make_loops_model(cfg))
