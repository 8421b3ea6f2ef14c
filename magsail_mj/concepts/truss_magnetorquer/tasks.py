"""Tasks of the flexible truss concept (``truss_magnetorquer``): one class per scenario kind.

Robb et al. 2022a. :class:`TrussScenario` is the shared base (model, environment
loads, rigid initial state, runner, render and manifest entries); each subclass adds what its
kind needs and is registered by name (:func:`magsail_mj.concepts.register_task`):

============================  ==========================  ===========================================
``scenario``                  class                       what it runs
============================  ==========================  ===========================================
``dist_vs_central``           :class:`DistVsCentralTask`  open-loop strut torque profile (Robb et al. 2022a, Sec. 2)
``cantilever``                :class:`CantileverTask`     clamped lattice, tip load, settle
``free``                      :class:`FreeTask`           no actuator (momentum/energy, libration)
``detumble``                  :class:`DetumbleTask`       rod array under B-dot in orbit
``slew``                      :class:`SlewTask`           rod array under quaternion PD
============================  ==========================  ===========================================

Registration is :func:`magsail_mj.concepts.register_task` keyed by ``("truss_magnetorquer", scenario)``;
:func:`magsail_mj.concepts.build_task` (and :func:`build_truss_scenario`) looks the class up once; nothing
else dispatches on the scenario name. Frames: world = the orbit-following frame (axes = ECI) or free
space; body = the best-fit rotation of the lattice. Units SI.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, ClassVar

import mujoco
import numpy as np

from magsail_mj.control.profiles import torque_profile
from magsail_mj.control.rod_attitude import RodAttitudeController
from magsail_mj.concepts import build_task, register_structure, register_task
from magsail_mj.environment.environment import Environment
from magsail_mj.environment.surfaces import lattice_top_cells
from magsail_mj.estimation.attitude import BestFitRotation, matrix_from_quat, particle_inertia
from magsail_mj.lattice.geometry import make_lattice, strain_check
from magsail_mj.lattice.properties import clamped_nodes, loaded_nodes
from magsail_mj.loads.base import StepState
from magsail_mj.loads.drag import LatticeDragLoad
from magsail_mj.loads.magnetorquer_rods import MagnetorquerRodLoad
from magsail_mj.loads.point_force import NodeForceLoad
from magsail_mj.loads.srp import LatticeSRPLoad
from magsail_mj.loads.strut_torque import StrutTorqueLoad
from magsail_mj.loads.tidal import TidalGravityLoad
from magsail_mj.lattice.mjcf import node_positions_from_qpos
from magsail_mj.lattice.trajectory import NodeTrajectory
from magsail_mj.concepts.truss_magnetorquer.config import TrussConfig
from magsail_mj.concepts.truss_magnetorquer.metrics import (
    PROFILE_AXES,
    cantilever_summary,
    commanded_impulse_Nms,
    delivered_impulse_keys,
    dynamic_summary,
    profile_response,
    strut_tilt_keys,
    strut_tilt_rad,
)
from magsail_mj.concepts.truss_magnetorquer.model import (
    TrussModel,
    actuated_struts,
    make_cantilever_model,
    make_truss_model,
    truss_structure,
)
from magsail_mj.structure.model import Structure
from magsail_mj.concepts.truss_magnetorquer.orbital import (
    detumble_keys,
    make_rod_load,
    orbital_manifest,
    orbital_plots,
    orbital_probes,
    orbital_summary,
    rod_controller,
    slew_keys,
)
from magsail_mj.concepts.truss_magnetorquer.plots import cantilever_plot, truss_plots
from magsail_mj.records import lazy_record
from magsail_mj.sim import RunResult, Simulation

__all__ = [
    "build_truss_scenario",
    "TrussScenario",
    "DistVsCentralTask",
    "CantileverTask",
    "FreeTask",
    "OrbitalTrussTask",
    "DetumbleTask",
    "SlewTask",
    "DeliveredTorqueMeter",
    "perturbed_positions",
]

Summary = tuple[dict[str, Any], dict[str, np.ndarray]]


#: readable names of the truss's overlay series (units come from their suffixes)
OVERLAY_NAMES = {
    "surface_sd_m": "surface SD",
    "torque_cmd_x1_Nm": "commanded torque about x₁",
    "tip_deflection_m": "tip deflection",
    "omega_body_rad_s": "body rates",
    "omega_norm_rad_s": "body rate |ω|",
    "error_angle_deg": "attitude error",
    "N1": "active rods, family 1",
    "N2": "active rods, family 2",
}


def perturbed_positions(
    positions: np.ndarray, masses: np.ndarray, *, sigma_m: float, seed: int
) -> tuple[np.ndarray, float]:
    """``positions`` (n, 3) [m] plus the small asymmetric perturbation of ``initial.node_perturbation_m``:
    ``δ_i = σ g_i − Σ_k m_k σ g_k / Σ m`` with ``g`` standard normal draws of
    ``numpy.random.default_rng(seed)`` (the centre of mass stays put). Returns the new positions and
    the RMS displacement [m]."""
    g = np.random.default_rng(seed).standard_normal(np.shape(positions))
    delta = sigma_m * g
    delta -= np.average(delta, axis=0, weights=masses)
    return positions + delta, float(np.sqrt(np.mean(np.sum(delta**2, axis=1))))


class DeliveredTorqueMeter:
    """A load that applies nothing and integrates what the strut-torque load applied: the couple
    ``τ_ac = Σ_s (r_j − r_i) × F_j`` [N m] (world; the pairs have zero net force, so it is the
    same about every point) of each step, held over the step ``δt`` as the runner holds the
    forces, accumulated as the world impulse ``Σ τ_ac δt`` and, in best-fit body axes ``R`` of
    the same state, ``Σ Rᵀ τ_ac δt`` [N m s]. It must follow the torque load in the load
    list (it reads the forces that load has just set)."""

    name = "delivered_torque_meter"

    def __init__(self, torque_load: StrutTorqueLoad, reference_nodes: np.ndarray, *, timestep_s: float) -> None:
        self.load = torque_load
        self.fit = BestFitRotation(reference_nodes)
        self.n_nodes = int(np.shape(reference_nodes)[0])
        self.timestep_s = float(timestep_s)
        self.impulse_world_Nms = np.zeros(3)
        self.impulse_body_Nms = np.zeros(3)
        self.torque_body_Nm = np.zeros(3)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        F = self.load.last_force_j
        if not np.any(F):
            self.torque_body_Nm = np.zeros(3)
            return
        pos = state.pos
        tau = np.cross(pos[self.load.j] - pos[self.load.i], F).sum(axis=0)
        R, _ = self.fit(pos[1 : 1 + self.n_nodes])
        self.torque_body_Nm = R.T @ tau
        self.impulse_world_Nms = self.impulse_world_Nms + tau * self.timestep_s
        self.impulse_body_Nms = self.impulse_body_Nms + self.torque_body_Nm * self.timestep_s


@dataclass
class TrussScenario(ABC):
    """A truss run: the model plus its loads, probes and post-processing (base of every task).

    Subclasses implement the abstract :meth:`postprocess` and :meth:`task_plots` (a subclass
    without one of them cannot be instantiated: ``TypeError`` naming it), override the hooks
    :meth:`task_loads`, :meth:`make_controller`, :meth:`task_probes`, :meth:`task_manifest` and
    the render overlay :attr:`OVERLAY` / :attr:`INSET` where the kind has them; :meth:`simulation`,
    :meth:`plots`, :meth:`render_info` and :meth:`manifest_extra` are the same for every kind.
    """

    cfg: TrussConfig
    tm: TrussModel
    spec: mujoco.MjSpec = field(init=False)

    OVERLAY: ClassVar[tuple[str, ...]] = ("surface_sd_m",)
    """Series printed on each video frame."""
    INSET: ClassVar[str | None] = None
    """Series drawn as the video's inset plot (``None``: no inset)."""
    ACTIVITY_LABELS: ClassVar[dict[str, str]] = {}
    """Meaning of the strut activity colours ``"1"``/``"-1"`` (empty: the renderer's default)."""

    def __post_init__(self) -> None:
        self.spec = self.tm.spec
        self.model = self.spec.compile()
        self.torque_load: StrutTorqueLoad | None = None
        self.rod_load: MagnetorquerRodLoad | None = None
        self.tidal_load: TidalGravityLoad | None = None
        self.controller: RodAttitudeController | None = None
        self.environment: Environment | None = None
        if self.cfg.orbit.enabled:
            self.environment = Environment.from_config(
                self.cfg.environment_config(), duration_s=self.cfg.sim.duration_s
            )

    @classmethod
    def build_model(cls, cfg: TrussConfig) -> TrussModel:
        """The free lattice of the config (:func:`~magsail_mj.concepts.truss_magnetorquer.model.make_truss_model`)."""
        return make_truss_model(cfg)

    @classmethod
    def from_config(cls, cfg: TrussConfig) -> TrussScenario:
        """The task of a validated config, with its model."""
        return cls(cfg=cfg, tm=cls.build_model(cfg))

    @property
    def title(self) -> str:
        """``"<scenario>: <description>"`` (plots and videos)."""
        return f"{self.cfg.scenario}: {self.cfg.description}".strip(": ")

    # -------------------------------------------------------------- runner
    def environment_loads(self) -> list:
        """Tidal gravity, SRP and drag on the lattice, as the environment tables ask."""
        if self.environment is None:
            return []
        cfg, lat = self.cfg, self.tm.lattice
        out: list = []
        if cfg.gravity.tidal:
            self.tidal_load = TidalGravityLoad.from_environment(
                self.environment, np.arange(lat.n_nodes) + 1, self.tm.masses
            )
            out.append(self.tidal_load)
        cells = lattice_top_cells(lat.nodes_per_side)
        if cfg.srp.enabled:
            out.append(LatticeSRPLoad(cells))
        if cfg.drag.enabled:
            out.append(LatticeDragLoad(cells, drag_coefficient=cfg.drag.drag_coefficient))
        return out

    def task_loads(self) -> list:
        """The kind's own loads (after the environment's); none by default."""
        return []

    def loads(self) -> list:
        """Every load of the run, built afresh: environment loads, then the kind's."""
        return [*self.environment_loads(), *self.task_loads()]

    def make_controller(self) -> RodAttitudeController | None:
        """The run's controller (none by default)."""
        return None

    def task_probes(self) -> dict[str, Any]:
        """The kind's recorder probes, besides ``qpos``."""
        return {}

    def initial_rotation(self) -> np.ndarray:
        """Body → world rotation matrix of the initial attitude (``maneuver.q0_wxyz`` or
        ``initial.q0_wxyz``)."""
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
        x = (p - pc) @ R.T + pc
        sigma = self.cfg.initial.node_perturbation_m
        if sigma > 0:
            x, _ = perturbed_positions(x, self.tm.masses, sigma_m=sigma, seed=self.perturbation_seed)
        data.qpos[:] = (x - p).ravel()
        data.qvel[:] = (np.cross(w, p - pc) @ R.T).ravel()

    @property
    def perturbation_seed(self) -> int:
        """Seed of the initial node perturbation: ``initial.perturbation_seed``, else ``sim.seed``."""
        seed = self.cfg.initial.perturbation_seed
        return int(self.cfg.sim.seed if seed is None else seed)

    def perturbation_manifest(self) -> dict[str, Any]:
        """The manifest's ``initial_perturbation`` entry: σ [m], seed and the RMS displacement [m]."""
        sigma = self.cfg.initial.node_perturbation_m
        rms = 0.0
        if sigma > 0 and not self.tm.fixed_nodes:
            _, rms = perturbed_positions(
                self.tm.lattice.nodes, self.tm.masses, sigma_m=sigma, seed=self.perturbation_seed
            )
        return {"node_perturbation_m": sigma, "seed": self.perturbation_seed, "rms_displacement_m": rms}

    def simulation(self) -> Simulation:
        """The runner: loads, controller and probes of the kind, the lattice strain check."""
        loads = self.loads()
        self.controller = self.make_controller()
        probes: dict[str, Any] = {"qpos": lambda s, d: d.qpos, **self.task_probes()}
        return Simulation(
            model=self.model,
            duration_s=self.cfg.sim.duration_s,
            loads=loads,
            controller=self.controller,
            probes=probes,
            record_every=self.cfg.sim.record_every,
            strain_check=strain_check(self.tm.lattice),
            max_strain=self.cfg.sim.max_strain,
            environment=self.environment,
            checkpoint_every_s=self.cfg.sim.checkpoint_every_s,
            init=self.init_state,
        )

    # -------------------------------------------------------------- outputs
    def node_positions(self, qpos: np.ndarray) -> np.ndarray:
        """(T, n, 3) node positions from recorded qpos (clamped nodes stay at reference)."""
        return node_positions_from_qpos(self.model, qpos, n_nodes=self.tm.lattice.n_nodes)

    def trajectory(self, records: Mapping[str, Any]) -> NodeTrajectory:
        """The run's node positions, read from the recorded qpos block by block (a run's store is
        never loaded whole)."""
        return NodeTrajectory(lazy_record(records, "qpos"), self.node_positions)

    @abstractmethod
    def postprocess(self, result: RunResult) -> Summary:
        """Summary keys and derived series of the run (the kind's)."""

    @abstractmethod
    def task_plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        """The kind's PNG figures."""

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        """Write the run's figures into ``run_dir``; returns their paths."""
        return self.task_plots(run_dir, result, series)

    def render_info(self) -> dict[str, Any]:
        """The manifest's ``render`` entry: title, top-layer nodes, overlay, camera, frames."""
        r = self.cfg.render
        return {
            "title": self.title,
            "top_nodes": self.tm.lattice.top_nodes.tolist(),
            "overlay": list(self.OVERLAY),
            **({"inset": self.INSET} if self.INSET is not None else {}),
            "camera": {
                "azimuth_deg": r.azimuth_deg,
                "elevation_deg": r.elevation_deg,
                "distance_m": r.distance_factor * self.cfg.lattice.side_m,
            },
            "exaggeration": r.exaggeration,
            "fps": r.fps,
            "max_frames": r.max_frames,
            "overlay_names": dict(OVERLAY_NAMES),
            "overlay_units": {"N1": "rods", "N2": "rods"},
            **({"activity_labels": dict(self.ACTIVITY_LABELS)} if self.ACTIVITY_LABELS else {}),
        }

    def task_manifest(self) -> dict[str, Any]:
        """The kind's manifest entries (before the model's)."""
        return {}

    def manifest_extra(self) -> dict[str, Any]:
        """Manifest entries: the kind's, model size, damping and stiffness calibration, integrator."""
        lat = self.tm.lattice
        return {
            **self.task_manifest(),
            "initial_perturbation": self.perturbation_manifest(),
            "model_size": {"nodes": lat.n_nodes, "struts": lat.n_struts, "dofs": int(self.model.nv)},
            "zeta_strut": self.cfg.damping.zeta_strut,
            "gamma_Ns_m": self.tm.gamma,
            "stiffness_calibration": self.cfg.stiffness.calibration,
            "stiffness_calibration_factor": self.tm.calibration_factor,
            "integrator": self.cfg.sim.integrator,
            "timestep_s": self.cfg.sim.timestep_s,
        }

    # -------------------------------------------------------------- shared post-processing
    def _dynamic_summary(self, result: RunResult) -> Summary:
        cfg = self.cfg
        return dynamic_summary(
            self.tm,
            self.trajectory(result.records),
            result,
            omega0_body=np.asarray(cfg.initial.omega0_rad_s),
            max_strain=cfg.sim.max_strain,
            zeta_strut=cfg.damping.zeta_strut,
            environment=self.environment,
        )


@register_task("truss_magnetorquer", "free")
class FreeTask(TrussScenario):
    """The lattice with no actuator: momentum/energy checks and environment-only runs (libration)."""

    def postprocess(self, result: RunResult) -> Summary:
        return self._dynamic_summary(result)

    def task_plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        return truss_plots(run_dir, series, title=self.title)


@register_task("truss_magnetorquer", "dist_vs_central")
class DistVsCentralTask(TrussScenario):
    """Robb et al. 2022a, Sec. 2: open-loop torque profile about ``profile.axis``, distributed over every top-layer
    strut of the family or concentrated in the central cube (``actuators.placement``), compared with the
    rigid body."""

    OVERLAY = ("surface_sd_m", "torque_cmd_x1_Nm")
    ACTIVITY_LABELS = {"1": "strut couple, + sign", "-1": "strut couple, − sign"}

    def _profile_command(self) -> Callable[[Any], np.ndarray]:
        """τ(t) [N m], body components: the ``[profile]`` about its axis."""
        p = self.cfg.profile
        axis = PROFILE_AXES[p.axis]

        def command(state) -> np.ndarray:
            tau = np.zeros(3)
            tau[axis] = float(torque_profile(p.kind, state.t, tau_max=p.tau_max_Nm, t_end=p.t_end_s, t_v=p.t_v_s))
            return tau

        return command

    def task_loads(self) -> list:
        cfg = self.cfg
        struts = actuated_struts(self.tm.lattice, cfg.actuators, cfg.profile.axis)
        self.torque_load = StrutTorqueLoad(
            self.tm.lattice, struts, command=self._profile_command(), torque_axis=cfg.actuators.torque_axis
        )
        self.meter = DeliveredTorqueMeter(self.torque_load, self.tm.lattice.nodes, timestep_s=cfg.sim.timestep_s)
        return [self.torque_load, self.meter]

    def task_probes(self) -> dict[str, Any]:
        tl, nt, meter = self.torque_load, self.model.ntendon, self.meter
        return {
            "torque_cmd_body_Nm": lambda s, d: tl.last_command,
            "strut_activity": lambda s, d: tl.activity(nt),
            "torque_ac_body_Nm": lambda s, d: meter.torque_body_Nm,
            "impulse_ac_body_Nms": lambda s, d: meter.impulse_body_Nms,
            "impulse_ac_world_Nms": lambda s, d: meter.impulse_world_Nms,
        }

    def central_struts(self) -> np.ndarray:
        """(S, 2) end nodes of the central cube's torquer struts for the profile axis (the struts
        the central placement actuates, whatever this run's placement)."""
        act = self.cfg.actuators.model_copy(update={"placement": "central"})
        return self.tm.lattice.struts[actuated_struts(self.tm.lattice, act, self.cfg.profile.axis)]

    def postprocess(self, result: RunResult) -> Summary:
        summary, series = self._dynamic_summary(result)
        rec = result.records
        t = rec["t"]
        if t.size < 2:
            return summary, series
        p = self.cfg.profile
        inertia = particle_inertia(self.tm.lattice.nodes, self.tm.masses)
        more_keys, more_series = profile_response(
            p,
            t,
            series["surface_sd_m"],
            inertia_kgm2=float(inertia.moments[PROFILE_AXES[p.axis]]),
            torque_cmd_body_Nm=rec["torque_cmd_body_Nm"],
        )
        series.update(more_series)
        summary.update(more_keys)
        cmd = commanded_impulse_Nms(p, t, timestep_s=self.cfg.sim.timestep_s, load_timing=self.cfg.sim.load_timing)
        summary.update(
            delivered_impulse_keys(
                p,
                t,
                impulse_body_Nms=rec["impulse_ac_body_Nms"],
                impulse_cmd_Nms=cmd,
                torque_ac_body_Nm=rec["torque_ac_body_Nm"],
            )
        )
        tilt = strut_tilt_rad(
            self.trajectory(rec), series["R_body_to_world"], nodes=self.tm.lattice.nodes, ends=self.central_struts()
        )
        summary.update(strut_tilt_keys(t, tilt))
        series.update(impulse_cmd_Nms=cmd, central_strut_tilt_rad=tilt)
        return summary, series

    def task_plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        return truss_plots(run_dir, series, title=self.title)


@register_task("truss_magnetorquer", "cantilever")
class CantileverTask(TrussScenario):
    """Cantilever: the lattice clamped along its i = 0 edge, a tip load ``cantilever.load_N`` on the free
    edge, settled with node damping; compared with the linear solve and the beam formula."""

    OVERLAY = ("tip_deflection_m",)

    @classmethod
    def build_model(cls, cfg: TrussConfig) -> TrussModel:
        return make_cantilever_model(cfg)

    def task_loads(self) -> list:
        tip = loaded_nodes(self.tm.lattice)
        force = np.zeros((tip.size, 3))
        force[:, 2] = -self.cfg.cantilever.load_N / tip.size
        return [NodeForceLoad(tip + 1, force)]

    def postprocess(self, result: RunResult) -> Summary:
        cfg = self.cfg
        return cantilever_summary(
            self.tm,
            self.trajectory(result.records),
            result,
            load_N=cfg.cantilever.load_N,
            EI_Nm2=cfg.stiffness.EI_Nm2,
            calibration=cfg.stiffness.calibration,
        )

    def task_plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        cfg = self.cfg
        return cantilever_plot(
            run_dir,
            series,
            title=self.title,
            load_N=cfg.cantilever.load_N,
            EI_Nm2=cfg.stiffness.EI_Nm2,
            side_m=cfg.lattice.side_m,
        )


class OrbitalTrussTask(TrussScenario):
    """The 75 m truss in orbit with magnetorquer rods in its top-layer struts (Robb et al. 2022a, Sec. 4.2–4.3):
    the rod load, the ``[control]`` law through the allocation (Eqs. 11–13), the orbital probes, summary and plots
    (:mod:`magsail_mj.concepts.truss_magnetorquer.orbital`). Subclasses add the kind's own metrics
    (the abstract :meth:`kind_metrics`)."""

    ACTIVITY_LABELS = {"1": "rod on, dipole along the strut", "-1": "rod on, dipole reversed"}

    def rods(self) -> MagnetorquerRodLoad:
        """The rod load (built once and kept: the controller and the probes share it)."""
        if self.rod_load is None:
            self.rod_load = make_rod_load(self.cfg.actuators, self.tm)
        return self.rod_load

    def task_loads(self) -> list:
        self.rod_load = make_rod_load(self.cfg.actuators, self.tm)
        return [self.rod_load]

    def make_controller(self) -> RodAttitudeController:
        """The ``[control]`` law feeding the rod allocation
        (:func:`~magsail_mj.concepts.truss_magnetorquer.orbital.rod_controller`); builds the rod load if absent."""
        return rod_controller(
            self.cfg, self.tm, self.rods(), mu_m3_s2=self.environment.mu, environment=self.environment
        )

    def task_probes(self) -> dict[str, Any]:
        return orbital_probes(
            self.tm,
            self.rods(),
            self.tidal_load,
            ntendon=self.model.ntendon,
            mu_m3_s2=self.environment.mu,
            q_err=self.cfg.control.kind == "quat_pd",
        )

    @abstractmethod
    def kind_metrics(self, records: dict[str, np.ndarray], series: dict[str, np.ndarray]) -> Summary:
        """The kind's own ``(keys, series)`` from the records and the common series."""

    def postprocess(self, result: RunResult) -> Summary:
        summary, series = orbital_summary(
            self.cfg, self.tm, self.trajectory(result.records), result, environment=self.environment, rod=self.rods()
        )
        if result.records["t"].size < 2:
            return summary, series
        more_keys, more_series = self.kind_metrics(result.records, series)
        series.update(more_series)
        summary.update(more_keys)
        return summary, series

    def task_plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        return orbital_plots(
            run_dir,
            result.records,
            series,
            title=self.title,
            nodes_per_side=self.tm.lattice.nodes_per_side,
            side_m=self.cfg.lattice.side_m,
        )

    def task_manifest(self) -> dict[str, Any]:
        return orbital_manifest(self.cfg, self.tm, self.rods())


@register_task("truss_magnetorquer", "detumble")
class DetumbleTask(OrbitalTrussTask):
    """Detumbling: B-dot (or the open-loop profile) from the initial body rate; rates below 1e-3 rad/s."""

    OVERLAY = ("omega_body_rad_s", "N1", "N2", "surface_sd_m")
    INSET = "omega_norm_rad_s"

    def kind_metrics(self, records: dict[str, np.ndarray], series: dict[str, np.ndarray]) -> Summary:
        inertia = particle_inertia(self.tm.lattice.nodes, self.tm.masses).tensor
        keys = detumble_keys(
            records["t"],
            records["omega_est_body_rad_s"],
            inertia_kgm2=inertia,
            omega0_body=np.asarray(self.cfg.initial.omega0_rad_s, dtype=float),
        )
        return keys, {}


@register_task("truss_magnetorquer", "slew")
class SlewTask(OrbitalTrussTask):
    """Slew: quaternion feedback (or the open-loop profile) from ``q0`` to ``maneuver.q_ref_wxyz``."""

    OVERLAY = ("error_angle_deg", "omega_norm_rad_s", "N1", "N2", "surface_sd_m")
    INSET = "error_angle_deg"

    def kind_metrics(self, records: dict[str, np.ndarray], series: dict[str, np.ndarray]) -> Summary:
        cfg = self.cfg
        more_series, keys = slew_keys(
            records,
            q0_wxyz=cfg.q0_wxyz,
            maneuver=cfg.maneuver,
            low_authority_threshold_Nm=cfg.control.low_authority_threshold_Nm,
        )
        return keys, more_series


def build_truss_scenario(cfg: TrussConfig) -> TrussScenario:
    """The task of a truss config: the class registered for ``(cfg.concept, cfg.scenario)`` in
    :data:`magsail_mj.concepts.TASKS` (:func:`magsail_mj.concepts.build_task`)."""
    return build_task(cfg)


@register_structure("truss_magnetorquer")
def config_structure(cfg: TrussConfig) -> Structure:
    """The lattice a config models as a structure (:func:`truss_structure`; the ``cantilever``
    scenario with its ``i = 0`` edge clamped)."""
    if cfg.scenario != "cantilever":
        return truss_structure(cfg)[0]
    lat = make_lattice(units=cfg.lattice.units, side_m=cfg.lattice.side_m, diagonals=cfg.lattice.diagonals)
    return truss_structure(cfg, fixed_nodes=clamped_nodes(lat))[0]
