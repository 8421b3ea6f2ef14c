r"""The gossamer reflector with a conducting support structure (concept ``reflector``): config
schema and scenario wiring.

Spec: ``conducting-structure-reflector.md`` (Robb, McRobb, McInnes, AIAA SciTech 2020-0714). A
rigid square plate (:mod:`magsail_mj.mjcf.plate`) whose truss carries two serpentine coils and an
in-plane loop (:mod:`magsail_mj.geometry.reflector_coil`); each path acts as an ideal dipole along
its axis limited to ``m_max = T_max / B_ref`` (§3.6; ``T_max`` from
:mod:`magsail_mj.analysis.coil_torque`). Two kinds of run (``kind``):

* ``"detumble"`` — Scenario A (§5): constant field (inertial ``+Z``, A6; body-fixed as a
  variant), B-dot law of :mod:`magsail_mj.control.reflector_bdot`, world = inertial, no orbit.
* ``"pitch"`` — Scenario B (§6): polar dawn–dusk orbit, dipole field Eq. 11, steering law
  (:mod:`magsail_mj.control.reflector_steering`), quaternion feedback with projection ⟂ B and
  saturation (:mod:`magsail_mj.control.reflector_pitch`); optional gravity-gradient torque (B5).
* ``"pitch_caps"`` — case B3: the whole cap sweep with bisection in one run
  (:mod:`magsail_mj.scenarios.reflector_caps`).

Configs live at ``models/reflector/<id>.toml`` (``detumble``, ``tracking_100g``, ``tracking_10g``
and the §8.1 variants under ``detumble/`` and ``pitch/``). Torques enter through
``xfrc_applied`` (:class:`magsail_mj.loads.body_torque.HeldBodyTorqueLoad`), rewritten every
step; the controller runs every integration step (zero-order hold, §2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Literal

import mujoco
import numpy as np
from pydantic import Field, field_validator, model_validator

from magsail_mj.config import (
    MAX_STEPS,
    MJ_MINVAL,
    ConfigProblem,
    SimConfig,
    StrictModel,
    finite_product,
    normalised,
    register_concept,
)
from magsail_mj.scenarios import register_builder
from magsail_mj.sim import RunResult, Simulation

__all__ = ["ReflectorConfig", "ReflectorScenario", "build_reflector_scenario", "ASSUMPTIONS"]

Vec3 = tuple[float, float, float]

ASSUMPTIONS = {
    "A1": "lattice depth h = L (one cell deep)",
    "A2": "coil columns one cell wide every other cell column (p = 2), d/L three-quarter turns per column, "
          "same circulation in every column, connectors along +x",
    "A3": "in-plane loop: the lattice-aligned centred square whose capability is closest to the coil path's",
    "A4": "R_e = 6371 km (mean radius)",
    "A5": "ground point rotates at the solar-day rate 2π/86400 s⁻¹ in the Sun-fixed frame",
    "A6": "detumbling field fixed in inertial space along the initial plate normal (+Z)",
    "A7": "pitch about the principal in-plane body axis y = world y (Sun line = orbit normal)",
    "Eq8": "Eq. 8 taken as the commanded dipole m = k ω × B_b (printed torque form does no work)",
    "omega0": "initial rate magnitude 0.1 rad/s, ω0 = (0.1/√2)(1, 1, 0) (printed vector has magnitude 1)",
    "Eq12": "branch jumps of Eq. 12 removed by unwrapping ε = atan2(a, b)",
    "q_err": "body-frame q_e = q_ref* ⊗ q_t, torque −P_q q_e,vec − P_ω ω (restoring)",
    "beta_ref": "reference pitch β_ref = π/2 − ψ_c about +y, body x = grey line",
    "s_path": "positive path current gives a dipole along the path's +axis (y-coil as generated: s_path = −1)",
    "zoh": "controllers run every integration step with zero-order hold; Scenario A world inertial without "
           "orbit; Scenario B world axes = the paper's xyz frame",
    "inertia": "in-plane moments carry the thickness t (default h): I1 = I2 = m(d² + t²)/12 (MuJoCo triangle "
               "inequality), I3 = m d²/6",
}


# ---------------------------------------------------------------------------------- config


class PlateConfig(StrictModel):
    """``[plate]``: side d, cell edge L, depth h (default L, A1), areal density σ, and the thickness t
    used in the in-plane moments (default h; spec §4 caution). d must be a whole number n >= 2 of
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
            raise ConfigProblem("side_m", f"side_m / cell_m = {ratio:.3g} cells per side is more than a 64-bit "
                                f"count holds, got {self.side_m!r}", others=("cell_m",))
        n = round(ratio)
        if n < 2 or abs(n * self.cell_m - self.side_m) > 1e-9 * self.side_m:
            raise ConfigProblem("side_m", f"must be a whole multiple (>= 2) of cell_m = {self.cell_m!r}, "
                                f"got {self.side_m!r}", others=("cell_m",))
        return self

    @model_validator(mode="after")
    def _mass_properties(self) -> PlateConfig:
        d = self.side_m
        t = self.depth if self.inertia_thickness_m is None else self.inertia_thickness_m
        t_key = "inertia_thickness_m" if self.inertia_thickness_m is not None else "depth_m"
        m = finite_product("areal_density_kg_m2", self.areal_density_kg_m2, d, d, minimum=MJ_MINVAL,
                           what="plate mass σ d² (MuJoCo needs > mjMINVAL)", others=("side_m",))
        finite_product("areal_density_kg_m2", m / 12.0, d * d + t * t, minimum=MJ_MINVAL,
                       what="in-plane moment m (d² + t²)/12", others=("side_m", t_key))
        finite_product("areal_density_kg_m2", m / 6.0, d, d, minimum=MJ_MINVAL,
                       what="normal moment m d²/6", others=("side_m",))
        return self

    @property
    def depth(self) -> float:
        return self.cell_m if self.depth_m is None else self.depth_m


class CoilConfig(StrictModel):
    """``[coil]``: column pitch p (A2), rows per column (default d/L), maximum current and the
    reference field of the capability metric (§3.6)."""

    pitch_cells: int = Field(default=2, ge=1)
    rows: int | None = Field(default=None, ge=1)
    I_max_A: float = Field(default=10.0, gt=0)
    B_ref_T: float = Field(default=30e-6, gt=0)


class FieldConfig(StrictModel):
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


class ControlConfig(StrictModel):
    """``[control]``: ``kind`` = ``"bdot"`` (Scenario A; ``law``, ``omega_k_rad_s``) or ``"quat_pd"``
    (Scenario B; ``omega_n_rad_s``, ``zeta``, ``rate_term``, ``feedforward``); ``saturation``
    (``"box"`` for B-dot; ``"norm"`` (baseline), ``"field_scaled"`` or ``"per_path"`` for pitch);
    ``cap_N_m`` overrides the geometric coil capability T_max."""

    kind: Literal["bdot", "quat_pd"]
    law: Literal["dipole", "printed", "norm_cap"] = "dipole"
    omega_k_rad_s: float = Field(default=0.01, gt=0)
    omega_n_rad_s: float = Field(default=0.1, gt=0)
    zeta: float = Field(default=0.7, gt=0)
    rate_term: Literal["absolute", "error"] = "absolute"
    feedforward: bool = False
    saturation: Literal["box", "norm", "field_scaled", "per_path"] | None = None
    cap_N_m: float | None = Field(default=None, gt=0)

    @property
    def saturation_mode(self) -> str:
        return self.saturation or ("box" if self.kind == "bdot" else "norm")


class OrbitConfig(StrictModel):
    """``[orbit]`` (Scenario B, §4, §6.1): altitude, Earth radius (A4), μ, ground-point rate (A5),
    nominal run length in orbits (sets the overhead time t_m = n_orbits T_orb / 2); the period and
    the run length must be finite."""

    altitude_km: float = Field(default=800.0, gt=0)
    R_e_km: float = Field(default=6371.0, gt=0)
    mu_m3_s2: float = Field(default=3.986004418e14, gt=0)
    omega_e_rad_s: float = Field(default=2 * math.pi / 86400.0, ge=0)
    n_orbits: float = Field(default=10.0, gt=0)

    @model_validator(mode="after")
    def _period(self) -> OrbitConfig:
        r = (self.altitude_km + self.R_e_km) * 1e3
        period = finite_product("altitude_km", r, r, r / self.mu_m3_s2, what="orbital period 2π √(r³/μ)",
                                others=("R_e_km", "mu_m3_s2"))
        finite_product("n_orbits", self.n_orbits, 2.0 * math.pi * math.sqrt(period), what="nominal run length",
                       others=("altitude_km", "mu_m3_s2"))
        return self


class InitialConfig(StrictModel):
    """``[initial]`` (Scenario A, §5.4): body rate and attitude (Scenario B starts on the reference)."""

    omega0_rad_s: Vec3 = (0.1 / math.sqrt(2.0), 0.1 / math.sqrt(2.0), 0.0)
    q0_wxyz: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)

    @field_validator("q0_wxyz")
    @classmethod
    def _normalise(cls, v):
        return normalised(v, "quaternion [w, x, y, z]")


class GravityConfig(StrictModel):
    """``[gravity]``: ``gg_torque`` adds the classical gravity-gradient torque (case B5)."""

    gg_torque: bool = False


class RenderConfig(StrictModel):
    """``[render]``: video frames (``max_frames`` at ``fps``) and the free camera in world axes."""

    fps: int = Field(default=30, ge=1, le=120)
    max_frames: int = Field(default=600, ge=2)
    azimuth_deg: float = 60.0
    elevation_deg: float = -20.0
    distance_m: float | None = Field(default=None, gt=0)


@register_concept("reflector")
class ReflectorConfig(StrictModel):
    """A reflector scenario config (``models/reflector/<id>.toml``)."""

    concept: Literal["reflector"]
    scenario: str = Field(pattern=r"^[a-z0-9_]+(/[a-z0-9_]+)*$")
    kind: Literal["detumble", "pitch", "pitch_caps"]
    description: str = ""
    variant: str = "baseline"
    sim: SimConfig
    plate: PlateConfig = PlateConfig()
    coil: CoilConfig = CoilConfig()
    field: FieldConfig
    control: ControlConfig
    orbit: OrbitConfig = OrbitConfig()
    initial: InitialConfig = InitialConfig()
    gravity: GravityConfig = GravityConfig()
    render: RenderConfig = RenderConfig()

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


# ---------------------------------------------------------------------------------- scenario


@dataclass(frozen=True)
class CoilCapability:
    """Geometric actuator figures of a config (§3.6): ``T_max`` of the coil paths and the in-plane
    loop [N m], its side [m], the per-path dipole limits [A m²] and the cap used by the controller."""

    T_max_ycoil_N_m: float
    T_max_xcoil_N_m: float
    T_max_zloop_N_m: float
    zloop_side_m: float
    m_max_A_m2: np.ndarray
    cap_N_m: float


def coil_capability(cfg: ReflectorConfig) -> CoilCapability:
    """Capability of the config's coil paths at ``coil.I_max_A``, ``coil.B_ref_T``."""
    from magsail_mj.analysis.coil_torque import capability, loop_side_for_capability
    from magsail_mj.geometry.reflector_coil import CoilPath, coil_x, coil_y

    p, c = cfg.plate, cfg.coil
    kw = dict(current_A=c.I_max_A, field_T=c.B_ref_T)
    y = CoilPath("ycoil", coil_y(p.side_m, p.cell_m, p.depth, p=c.pitch_cells, n_row=c.rows), axis=1, s_path=-1)
    x = CoilPath("xcoil", coil_x(p.side_m, p.cell_m, p.depth, p=c.pitch_cells, n_row=c.rows), axis=0, s_path=1)
    Ty, Tx = capability(y, **kw), capability(x, **kw)
    side, Tz = loop_side_for_capability(Ty, side_m=p.side_m, segment_m=p.cell_m, depth_m=p.depth, **kw)
    m_max = np.array([Tx, Ty, Tz]) / c.B_ref_T
    return CoilCapability(T_max_ycoil_N_m=Ty, T_max_xcoil_N_m=Tx, T_max_zloop_N_m=Tz, zloop_side_m=side,
                          m_max_A_m2=m_max, cap_N_m=cfg.control.cap_N_m or Ty)


def _markers(kind: str):
    from magsail_mj.mjcf.plate import MarkerSpec

    if kind == "detumble":
        return (MarkerSpec("mk_field", (0.9, 0.2, 0.9, 1.0)), MarkerSpec("mk_omega", (0.1, 0.9, 0.2, 1.0)),
                MarkerSpec("mk_torque", (0.95, 0.15, 0.1, 1.0), length_rel=0.6))
    return (MarkerSpec("mk_sun", (1.0, 0.85, 0.1, 1.0)), MarkerSpec("mk_ground", (0.2, 0.5, 1.0, 1.0)),
            MarkerSpec("mk_field", (0.9, 0.2, 0.9, 1.0), length_rel=0.6),
            MarkerSpec("mk_ref_line", (1.0, 1.0, 1.0, 1.0), kind="line", length_rel=0.65))


@dataclass
class ReflectorScenario:
    """A reflector run (detumble or pitch): model, controller, loads, probes and outputs."""

    cfg: ReflectorConfig
    spec: mujoco.MjSpec = field(init=False)

    def __post_init__(self) -> None:
        from magsail_mj.mjcf.plate import PlateModelParams, build_plate_spec, plate_indices

        cfg = self.cfg
        self.cap = coil_capability(cfg)
        self.params = PlateModelParams(
            side_m=cfg.plate.side_m, cell_m=cfg.plate.cell_m, depth_m=cfg.plate.depth_m,
            areal_density_kg_m2=cfg.plate.areal_density_kg_m2, inertia_thickness_m=cfg.plate.inertia_thickness_m,
            coil_pitch_cells=cfg.coil.pitch_cells, zloop_side_m=self.cap.zloop_side_m, timestep_s=cfg.sim.timestep_s,
            integrator=cfg.sim.integrator, solver_tolerance=cfg.sim.solver_tolerance, markers=_markers(cfg.kind),
            name=f"reflector_{cfg.scenario.replace('/', '_')}")
        self.spec = build_plate_spec(self.params)
        self.model = self.spec.compile()
        self.idx = plate_indices(self.model)
        self.mass_kg, self.inertia = self.params.mass_properties()
        self.controller = None

    # -------------------------------------------------------------- parts
    @cached_property
    def orbit(self):
        from magsail_mj.control.reflector_steering import ReflectorOrbit

        o = self.cfg.orbit
        return ReflectorOrbit.from_altitude(altitude_m=o.altitude_km * 1e3, R_e_m=o.R_e_km * 1e3, mu_m3_s2=o.mu_m3_s2,
                                            omega_e_rad_s=o.omega_e_rad_s, n_orbits=o.n_orbits,
                                            B0_T=self.cfg.field.B0_T)

    @property
    def B_magnitude_T(self) -> float:
        return self.cfg.field.magnitude_T or self.cfg.coil.B_ref_T

    def field_body_fn(self):
        """``(t, R) → B_b`` of the constant-field cases (inertial or body-fixed, §5.2)."""
        B = self.B_magnitude_T * np.asarray(self.cfg.field.direction, dtype=float)
        if self.cfg.field.frame == "body":
            return lambda t, R: B.copy()
        return lambda t, R: R.T @ B

    def bdot_gain(self) -> float:
        from magsail_mj.control.reflector_bdot import PlateBdotController

        return PlateBdotController.gain_from_omega_k(m_max_A_m2=self.cap.m_max_A_m2[1], B_ref_T=self.cfg.coil.B_ref_T,
                                                     omega_k_rad_s=self.cfg.control.omega_k_rad_s)

    def make_controller(self):
        cfg, c = self.cfg, self.cfg.control
        if cfg.kind == "detumble":
            from magsail_mj.control.reflector_bdot import PlateBdotController

            return PlateBdotController(law=c.law, m_max_A_m2=self.cap.m_max_A_m2[1], T_max_N_m=self.cap.cap_N_m,
                                       gain=self.bdot_gain(), I_max_A=cfg.coil.I_max_A,
                                       field_body=self.field_body_fn(), body_id=self.idx.plate,
                                       period_s=cfg.sim.timestep_s)
        from magsail_mj.control.reflector_pitch import ReflectorPitchController

        return ReflectorPitchController(orbit=self.orbit, inertia_kg_m2=self.inertia, omega_n_rad_s=c.omega_n_rad_s,
                                        zeta=c.zeta, rate_term=c.rate_term, feedforward=c.feedforward,
                                        saturation=c.saturation_mode, cap_N_m=self.cap.cap_N_m,
                                        B_ref_T=cfg.coil.B_ref_T, m_max_A_m2=self.cap.m_max_A_m2,
                                        body_id=self.idx.plate, period_s=cfg.sim.timestep_s)

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        """``(q0, ω0_body)``: §5.4 for detumbling; ``q_ref(0)``, ``ω_ref(0) = −ψ̇(0) ŷ`` for pitch (§6.4)."""
        if self.cfg.kind == "detumble":
            return np.asarray(self.cfg.initial.q0_wxyz, dtype=float), np.asarray(self.cfg.initial.omega0_rad_s, float)
        from magsail_mj.control.reflector_steering import SteeringReference

        ref = SteeringReference(self.orbit).at(0.0)
        return ref.q_ref, np.array([0.0, -ref.psi_dot, 0.0])

    def init_state(self, data: mujoco.MjData) -> None:
        q0, w0 = self.initial_state()
        data.qpos[:] = 0.0
        data.qvel[:] = 0.0
        data.qpos[self.idx.q_quat] = q0
        data.qvel[self.idx.v_ang] = w0
        for qa in self.idx.marker_qpos.values():
            data.qpos[qa] = 1.0

    def simulation(self) -> Simulation:
        from magsail_mj.loads.body_torque import HeldBodyTorqueLoad, OrbitGravityGradientLoad

        if self.cfg.kind == "pitch_caps":
            from magsail_mj.scenarios.reflector_caps import CapSweepRunner

            if self.cfg.gravity.gg_torque:
                raise ValueError("gravity.gg_torque: the B3 cap sweep runs without the gravity gradient")
            self.runner = CapSweepRunner(self)
            return self.runner
        self.controller = ctl = self.make_controller()
        b = self.idx.plate
        loads: list[Any] = [HeldBodyTorqueLoad(b)]
        if self.cfg.gravity.gg_torque:
            loads.append(OrbitGravityGradientLoad(b, inertia_kg_m2=self.inertia, position=self.orbit.position,
                                                  mu=self.cfg.orbit.mu_m3_s2))
        probes = {"qpos": lambda s, d: d.qpos, "qvel": lambda s, d: d.qvel,
                  "torque_body_N_m": lambda s, d: s.ctrl.torque_body}
        if self.cfg.kind == "detumble":
            probes.update({
                "dipole_body_A_m2": lambda s, d: s.ctrl.dipole_body,
                "dipole_cmd_body_A_m2": lambda s, d: s.ctrl.dipole_cmd_body,
                "currents_A": lambda s, d: s.ctrl.currents_A,
                "saturated": lambda s, d: s.ctrl.saturated.astype(np.int8),
                "B_body_T": lambda s, d: s.ctrl.B_body,
            })
        else:
            probes.update({
                "T_ref_body_N_m": lambda s, d: s.ctrl.T_ref_body,
                "saturated": lambda s, d: np.int8(s.ctrl.saturated),
                "q_e": lambda s, d: s.ctrl.q_e,
                "q_ref": lambda s, d: s.ctrl.q_ref,
                "psi_ref_rad": lambda s, d: s.ctrl.psi_ref,
                "psi_dot_ref_rad_s": lambda s, d: s.ctrl.psi_dot_ref,
                "psi_ddot_ref_rad_s2": lambda s, d: s.ctrl.psi_ddot_ref,
                "B_world_T": lambda s, d: s.ctrl.B_world,
            })
            if self.cfg.gravity.gg_torque:
                gg = loads[1]
                probes["torque_gg_world_N_m"] = lambda s, d: gg.torque_world(s)
        return Simulation(model=self.model, duration_s=self.cfg.sim.duration_s, loads=loads, controller=ctl,
                          environment=None, probes=probes, record_every=self.cfg.sim.record_every,
                          checkpoint_every_s=self.cfg.sim.checkpoint_every_s, init=self.init_state)

    # -------------------------------------------------------------- outputs
    def postprocess(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        from magsail_mj.scenarios.reflector_caps import caps_outputs
        from magsail_mj.scenarios.reflector_metrics import detumble_outputs, pitch_outputs

        fn = {"detumble": detumble_outputs, "pitch": pitch_outputs, "pitch_caps": caps_outputs}[self.cfg.kind]
        return fn(self, result)

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        from magsail_mj.scenarios.reflector_caps import caps_plots
        from magsail_mj.scenarios.reflector_plots import detumble_plots, pitch_plots

        fn = {"detumble": detumble_plots, "pitch": pitch_plots, "pitch_caps": caps_plots}[self.cfg.kind]
        return fn(self, run_dir, series)

    def render_info(self) -> dict[str, Any]:
        r, cfg = self.cfg.render, self.cfg
        frames = int(min(r.max_frames, max(2, round(cfg.sim.duration_s / cfg.sim.timestep_s / cfg.sim.record_every))))
        cam: dict[str, float] = {"azimuth_deg": r.azimuth_deg, "elevation_deg": r.elevation_deg,
                                 "distance_m": (r.distance_m
                                                or (3.0 if cfg.kind == "detumble" else 2.4) * cfg.plate.side_m)}
        if cfg.kind == "detumble":
            title = f"reflector {cfg.scenario}: B-dot ({cfg.control.law}, ω_k = {cfg.control.omega_k_rad_s:g} rad/s)"
            overlay = ["time_h", "omega_norm_rad_s", "torque_norm_Nm", "currents_A"]
            markers = {"mk_field": "magnetic field (magenta)", "mk_omega": "angular velocity (green)",
                       "mk_torque": "torque (red)", "ycoil/xcoil": "coil columns (orange/cyan, every k-th)",
                       "zloop": "in-plane loop (magenta)", "normal": "plate normal (blue)"}
        else:
            title = (f"reflector {cfg.scenario}: σ = {1e3 * cfg.plate.areal_density_kg_m2:g} g/m², "
                     f"{cfg.control.rate_term} rate term")
            overlay = ["time_h", "psi_ref_deg", "psi_act_deg", "err_deg", "torque_pitch_Nm"]
            markers = {"mk_sun": "Sun direction +y (yellow)", "mk_ground": "towards the ground point (blue)",
                       "mk_field": "magnetic field (magenta)", "mk_ref_line": "reference grey line (white)",
                       "grey_line": "actual grey line (dark grey)", "normal": "plate normal (blue)"}
        inset = "omega_norm_rad_s" if cfg.kind == "detumble" else "err_deg"   # §6.7: error inset
        return {"title": title, "overlay": overlay, "inset": inset, "camera": cam, "fps": r.fps,
                "max_frames": frames,
                "markers": markers}

    def manifest_extra(self) -> dict[str, Any]:
        m, cfg = self.model, self.cfg
        out: dict[str, Any] = {
            "model_size": {"bodies": int(m.nbody), "dofs": int(m.nv), "actuators": int(m.nu)},
            "integrator": cfg.sim.integrator,
            "timestep_s": cfg.sim.timestep_s,
            "variant": cfg.variant,
            "mass_kg": self.mass_kg,
            "inertia_kg_m2": self.inertia.tolist(),
            "inertia_thickness_m": self.params.thickness,
            "coil_capability": {"T_max_ycoil_N_m": self.cap.T_max_ycoil_N_m,
                                "T_max_xcoil_N_m": self.cap.T_max_xcoil_N_m,
                                "T_max_zloop_N_m": self.cap.T_max_zloop_N_m, "zloop_side_m": self.cap.zloop_side_m,
                                "m_max_A_m2": self.cap.m_max_A_m2.tolist(), "cap_N_m": self.cap.cap_N_m},
            "assumptions": ASSUMPTIONS,
        }
        if cfg.kind == "detumble":
            out["bdot_gain"] = self.bdot_gain()
        else:
            o = self.orbit
            out["orbit"] = {"r_m": o.r_m, "n_rad_s": o.n_rad_s, "T_orb_s": o.period_s,
                            "run_length_nominal_s": cfg.orbit.n_orbits * o.period_s, "t_m_s": o.t_m_s}
            from magsail_mj.control.reflector_pitch import pitch_gains

            Pq, Pw = pitch_gains(self.inertia, omega_n_rad_s=cfg.control.omega_n_rad_s, zeta=cfg.control.zeta)
            out["gains"] = {"P_q_N_m": Pq.tolist(), "P_omega_N_m_s": Pw.tolist()}
        return out


@register_builder("reflector")
def build_reflector_scenario(cfg: ReflectorConfig) -> ReflectorScenario:
    """Scenario object of a reflector config."""
    return ReflectorScenario(cfg)
