"""Tasks of the current-loops concept (``current_loops``): one class per scenario kind.

Spec: current-loops.md. :class:`LoopsScenario` is the shared base (model, environment, fixed
field, runner, outputs); :class:`FlexibleLoopsTask` adds the flexible plate's loads (Lorentz
forces (Eq. 16), tidal gravity, Caughey modal damping (Eq. 15), work ledger), strain check and structural
post-processing. Each kind is registered by name (:func:`magsail_mj.concepts.register_task`):

==============  ======================  ===================================================
``scenario``    class                   what it runs
==============  ======================  ===================================================
``sweep``       :class:`LoopsSweepTask`      free flexible plate, constant currents, fixed field
``slew``        :class:`LoopsSlewTask`       flexible plate in orbit under quaternion PD
``slew_rigid``  :class:`LoopsRigidSlewTask`  the rigid-body surrogate of the slew
==============  ======================  ===================================================

Registration is :func:`magsail_mj.concepts.register_task` keyed by ``("current_loops", scenario)``;
:func:`magsail_mj.concepts.build_task` (and :func:`build_loops_scenario`) looks the class up once; nothing
else dispatches on the scenario name. Frames: world = free space or the orbit-following frame (axes =
ECI); body = the best-fit rotation (flexible) or the rigid body's frame. Units SI.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections import ChainMap
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import mujoco
import numpy as np

from magsail_mj.lattice.modes import Modes, damping_ratios, lattice_modes
from magsail_mj.concepts.current_loops.attitude import LoopAttitudeController
from magsail_mj.concepts import build_task, register_structure, register_task
from magsail_mj.environment.constants import MU_EARTH
from magsail_mj.environment.environment import Environment
from magsail_mj.estimation.attitude import matrix_from_quat, particle_inertia
from magsail_mj.geometry.current_loops import AXIS_OF
from magsail_mj.lattice.geometry import make_lattice, strain_check
from magsail_mj.lattice.properties import _ratio_formula, strut_stiffness
from magsail_mj.concepts.current_loops.lorentz import CircuitSegments, LorentzLoad
from magsail_mj.lattice.linear_stiffness import LinearStiffnessLoad
from magsail_mj.lattice.modal_damping import ModalDampingLoad
from magsail_mj.loads.tidal import GravityGradientTorqueLoad, TidalGravityLoad
from magsail_mj.lattice.mjcf import node_positions_from_qpos
from magsail_mj.lattice.trajectory import NodeTrajectory
from magsail_mj.records import lazy_record
from magsail_mj.concepts.current_loops.config import CurrentLoopsConfig
from magsail_mj.concepts.current_loops.metrics import (
    base_summary,
    dominant_modes,
    first_modes_share_keys,
    flexible_probes,
    flexible_torque_probe,
    rigid_probes,
    rigid_torque_probe,
    modal_energy_summary,
    saturation_keys,
    slew_metrics,
    slew_probes,
    slew_structure,
    structural_series,
    sweep_metrics,
)
from magsail_mj.concepts.current_loops.model import (
    HeldForces,
    LoopsModel,
    RigidLoopTorqueLoad,
    WorkLedger,
    make_loops_model,
    rigid_plate_spec,
    loops_structure,
)
from magsail_mj.structure.model import Structure
from magsail_mj.concepts.current_loops.plots import slew_plots, structural_plots, sweep_plots
from magsail_mj.sim import RunResult, Simulation

__all__ = [
    "build_loops_scenario",
    "LoopsScenario",
    "FlexibleLoopsTask",
    "LoopsSweepTask",
    "LoopsSlewTask",
    "LoopsRigidSlewTask",
    "slew_controller",
]

Summary = tuple[dict[str, Any], dict[str, np.ndarray]]


class _RigidWrapper:
    """Runs a :class:`LoopAttitudeController` on a free body's pose and rate (``slew_rigid``)."""

    def __init__(self, ctrl):
        self.ctrl = ctrl
        self.period_s = ctrl.period_s

    def update(self, state):
        q = np.asarray(state.xquat[1], dtype=float)
        if q @ self.ctrl._q_prev < 0:
            q = -q
        self.ctrl._q_prev = q
        R = matrix_from_quat(q)
        omega_body = self.ctrl.body_rate(R, t=state.t, measured_body=R.T @ state.omega[1])
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


def slew_controller(
    cfg: CurrentLoopsConfig, lm: LoopsModel, *, field_world_T: np.ndarray | None
) -> tuple[LoopAttitudeController, np.ndarray]:
    """The slew controller (Eq. 18 gains, corrected dipole command, per-axis current allocation)
    and the circuit index of the x, y, z axes.

    Common dipole limit m_max = μ σ D⁴ / (8 B0 R_E³) [A m²], the dipole every Eq.-9 circuit
    has at full current; per-axis current limits are the circuits' full currents [A].
    ``field_world_T``: the fixed field [T] (``None``: the orbit's ``B_eci``).
    """
    c = cfg.control
    axes = [AXIS_OF[n] for n in cfg.loops.expanded()]
    order = np.argsort(axes)  # circuit index of the x, y, z axes
    I_max = lm.currents_A[order]
    t = cfg.thermal
    mu = cfg.orbit.mu_m3_s2 if cfg.orbit.enabled else MU_EARTH
    m_max = mu * cfg.mass.areal_density_kg_m2 * cfg.lattice.side_m**4 / (8 * t.B0_T * (t.R_E_km * 1e3) ** 3)
    period = c.period_s or cfg.sim.timestep_s
    ctrl = LoopAttitudeController(
        period_s=period,
        p_ref=lm.lattice.nodes,
        masses=lm.masses,
        node_bodies=np.arange(lm.lattice.n_nodes) + 1,
        q_target=np.asarray(c.q_target),
        kp_Nm=c.kp_Nm,
        kw_Nms=c.kw_Nms,
        m_max_Am2=m_max,
        I_max_A=I_max,
        allocation=c.allocation,
        field_world=field_world_T,
        rate_estimator=c.rate_estimator,
    )
    return ctrl, order


# ---------------------------------------------------------------------------------- tasks


@dataclass
class LoopsScenario(ABC):
    """A current-loops run: model, loads, controller, probes and post-processing (base of every task).

    Subclasses provide :meth:`build_spec`, :meth:`loads`, :meth:`probes`, :meth:`metrics`,
    :meth:`task_plots` and may override :meth:`make_controller`, :meth:`strain_check`,
    :meth:`render_extra`, :meth:`manifest_more` and :attr:`OVERLAY`.
    """

    cfg: CurrentLoopsConfig
    lm: LoopsModel
    spec: mujoco.MjSpec = field(init=False)

    OVERLAY: ClassVar[tuple[str, ...]] = ()
    """Series printed on each video frame."""

    def __post_init__(self) -> None:
        cfg, lat = self.cfg, self.lm.lattice
        self.inertia = particle_inertia(lat.nodes, self.lm.masses)
        self.areas0 = np.array([c.vector_area(lat.nodes) for c in self.lm.circuits])
        self.spec = self.build_spec()
        self.model = self.spec.compile()
        self.node_bodies = np.arange(lat.n_nodes) + 1
        self.environment: Environment | None = None
        if cfg.orbit.enabled:
            self.environment = Environment.from_config(cfg.environment_config(), duration_s=cfg.sim.duration_s)
        self.field_fixed = np.asarray(cfg.field.constant_T, dtype=float) if cfg.field.model == "constant" else None
        self.controller = None

    @classmethod
    def from_config(cls, cfg: CurrentLoopsConfig) -> LoopsScenario:
        """The task of a validated config, with its model."""
        return cls(cfg=cfg, lm=make_loops_model(cfg))

    @abstractmethod
    def build_spec(self) -> mujoco.MjSpec:
        """The MjSpec the run integrates."""

    # -------------------------------------------------------------- runner
    @abstractmethod
    def loads(self) -> list:
        """Every load of the run, built afresh."""

    def make_controller(self) -> Any:
        """The run's controller (none by default: constant currents)."""
        return None

    @abstractmethod
    def probes(self) -> dict[str, Any]:
        """Recorder probes of the run."""

    def strain_check(self) -> Any:
        """The runner's strut strain check (none by default)."""
        return None

    def simulation(self) -> Simulation:
        """The runner: the kind's loads, controller, probes and strain check."""
        loads = self.loads()
        self.controller = self.make_controller()
        return Simulation(
            model=self.model,
            duration_s=self.cfg.sim.duration_s,
            loads=loads,
            controller=self.controller,
            environment=self.environment,
            probes=self.probes(),
            record_every=self.cfg.sim.record_every,
            strain_check=self.strain_check(),
            max_strain=self.cfg.sim.max_strain,
            checkpoint_every_s=self.cfg.sim.checkpoint_every_s,
        )

    # -------------------------------------------------------------- outputs
    @abstractmethod
    def metrics(self, rec: dict[str, np.ndarray]) -> Summary:
        """The kind's summary keys and series from the records (at least one sample)."""

    def postprocess(self, result: RunResult) -> Summary:
        """Status keys, then the kind's metrics (none for a run without samples)."""
        summary = base_summary(result)
        series: dict[str, np.ndarray] = {}
        if len(result.records["t"]) == 0:
            return summary, series
        s, ser = self.metrics(result.records)
        summary.update(s)
        series.update(ser)
        return summary, series

    @abstractmethod
    def task_plots(self, run_dir: Path, series: dict[str, np.ndarray], qpos: np.ndarray | None) -> list[Path]:
        """The kind's PNG figures from records and series together (``qpos``: the recorded qpos)."""

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        """Write the run's figures into ``run_dir``; returns their paths."""
        records = result.records
        qpos = lazy_record(records, "qpos") if "qpos" in records else None
        return self.task_plots(Path(run_dir), ChainMap(series, records), qpos)

    def render_extra(self) -> dict[str, Any]:
        """The kind's additions to the ``render`` entry."""
        return {}

    def render_info(self) -> dict[str, Any]:
        """The manifest's ``render`` entry: title, overlay, camera, frames (and the kind's)."""
        r = self.cfg.render
        info = {
            "title": f"current loops {self.cfg.scenario}: {self.cfg.description}".strip(": "),
            "overlay": list(self.OVERLAY),
            "camera": {
                "azimuth_deg": r.azimuth_deg,
                "elevation_deg": r.elevation_deg,
                "distance_m": r.distance_factor * self.cfg.lattice.side_m,
            },
            "exaggeration": r.exaggeration,
            "fps": r.fps,
            "max_frames": r.max_frames,
            "overlay_names": {
                "error_angle_deg": "attitude error",
                "strain_energy_J": "strain energy",
                "rotation_angle_deg": "rotation angle",
            },
        }
        info.update(self.render_extra())
        return info

    def manifest_more(self) -> dict[str, Any]:
        """The kind's manifest entries (after the common ones)."""
        return {}

    def manifest_extra(self) -> dict[str, Any]:
        """Manifest entries: model size, stiffness, circuits and their sizing, then the kind's."""
        lat = self.lm.lattice
        extra: dict[str, Any] = {
            "model_size": {"nodes": lat.n_nodes, "struts": lat.n_struts, "dofs": int(self.model.nv)},
            "EA_c_N": self.lm.EA_N,
            "stiffness_calibration": self.cfg.stiffness.calibration,
            "stiffness_calibration_factor": self.lm.calibration_factor,
            "stiffness_form": self.cfg.stiffness.form,
            "EI_eff_over_EI_formula_cantilever": float(_ratio_formula(lat.units, lat.diagonals)),
            "particle_mass_kg": float(self.lm.masses[0]),
            "circuits": [
                {
                    "name": c.name,
                    "axis": int(c.axis),
                    "segments": int(len(c.src)),
                    "vector_area_m2": a.tolist(),
                    "length_m": float(c.length(lat.nodes)),
                    "current_A": float(i),
                    "dipole_Am2": (i * a).tolist(),
                }
                for c, a, i in zip(self.lm.circuits, self.areas0, self.lm.currents_A)
            ],
            "sizing": self.lm.sizing,
            "kappa": self.cfg.loops.kappa,
            "integrator": self.cfg.sim.integrator,
            "timestep_s": self.cfg.sim.timestep_s,
        }
        extra.update(self.manifest_more())
        return extra


class FlexibleLoopsTask(LoopsScenario):
    """The flexible plate: tendon springs (or the linear stiffness load of ``stiffness.form``),
    Lorentz forces on the circuits' struts, tidal gravity
    (``gravity.tidal``), Caughey modal damping (``[damping]``) and the work ledger; structural
    series (strain energy, best fit, thickness, residual, modal amplitudes) and plots."""

    def __post_init__(self) -> None:
        self.lorentz: LorentzLoad | None = None
        self.damping_load: HeldForces | None = None
        self.stiffness_load: LinearStiffnessLoad | None = None
        self.ledger: WorkLedger | None = None
        self.tidal: TidalGravityLoad | None = None
        self._modes: Modes | None = None
        self.segments = CircuitSegments(self.lm.circuits)
        super().__post_init__()

    def build_spec(self) -> mujoco.MjSpec:
        return self.lm.spec

    def lorentz_currents(self) -> np.ndarray | None:
        """Constant circuit currents [A] of the Lorentz load (``None``: the controller's command)."""
        return None

    def modes(self) -> Modes:
        """Undamped modes of the lattice (cached on disk by :mod:`magsail_mj.lattice.modes`)."""
        if self._modes is None:
            lat = self.lm.lattice
            self._modes = lattice_modes(lat.nodes, lat.struts, self.lm.k, self.lm.masses)
        return self._modes

    def damping_info(self) -> dict[str, Any]:
        """Schedule, ω range and the RK4 stability products 2 ξ ω_max Δt (Robb et al. 2022b, Eq. 15)."""
        d = self.cfg.damping
        md = self.modes()
        omega = np.asarray(md.omega)
        xi = damping_ratios(
            omega, n_rigid=md.n_rigid, schedule=d.schedule, xi_low=d.xi_low, n_low=d.n_low, xi_cap=d.xi_cap
        )
        el = omega > 0
        dt = self.cfg.sim.timestep_s
        return {
            "schedule": d.schedule,
            "frame": d.frame,
            "inject": d.inject,
            "mode_count_from": "first elastic mode (six rigid modes excluded)",
            "omega_first_elastic_rad_s": float(omega[el].min()),
            "omega_max_rad_s": float(omega.max()),
            "xi_max": float(np.max(xi[el])) if d.enabled else 0.0,
            "stability_product_max": float(np.max(2 * xi[el] * omega[el] * dt)) if d.enabled else 0.0,
            "omega_max_dt": float(omega.max() * dt),
            **self.damping_form_info(),
        }

    def damping_form_info(self) -> dict[str, Any]:
        """The damping form; for ``polynomial`` its degree and the largest per-mode ratio error."""
        d = self.cfg.damping
        if d.form == "dense" or not d.enabled:
            return {"form": d.form}
        low = self.damping_load.load.polynomial if self.damping_load is not None else None
        if low is None:  # the load is built in loads(); before that only the form is known
            return {"form": d.form, "rtol": d.rtol}
        return {
            "form": d.form,
            "rtol": d.rtol,
            "polynomial_degree": int(low.degree),
            "ratio_error_max": float(np.max(low.ratio_error)),
        }

    def loads(self) -> list:
        cfg, lat = self.cfg, self.lm.lattice
        self.lorentz = LorentzLoad(
            self.segments, n_nodes=lat.n_nodes, currents_A=self.lorentz_currents(), B_world=self.field_fixed
        )
        out: list = [self.lorentz]
        watched: dict[str, Any] = {"lorentz": self.lorentz}
        if cfg.stiffness.form != "tendon":
            self.stiffness_load = LinearStiffnessLoad(
                nodes=lat.nodes, struts=lat.struts, k=self.lm.k, masses=self.lm.masses, form=cfg.stiffness.form
            )
            out.append(self.stiffness_load)
            watched["stiffness"] = self.stiffness_load
        if cfg.gravity.tidal:
            self.tidal = TidalGravityLoad.from_environment(self.environment, self.node_bodies, self.lm.masses)
            out.append(self.tidal)
        if cfg.damping.enabled:
            d = cfg.damping
            self.damping_load = HeldForces(
                ModalDampingLoad.for_lattice(
                    nodes=lat.nodes,
                    struts=lat.struts,
                    k=self.lm.k,
                    masses=self.lm.masses,
                    schedule=d.schedule,
                    xi_low=d.xi_low,
                    n_low=d.n_low,
                    xi_cap=d.xi_cap,
                    form=d.form,
                    rtol=d.rtol,
                    frame=d.frame,
                )
            )
            out.append(self.damping_load)
            watched["damping"] = self.damping_load
        self.ledger = WorkLedger(watched, self.node_bodies)
        out.append(self.ledger)
        return out

    def probes(self) -> dict[str, Any]:
        return flexible_probes(self.node_bodies, self.lm.masses, self.ledger)

    def strain_check(self) -> Any:
        return strain_check(self.lm.lattice)

    def node_positions(self, qpos: np.ndarray) -> np.ndarray:
        """(…, n, 3) node positions [m] from recorded qpos."""
        return node_positions_from_qpos(self.model, qpos, n_nodes=self.lm.lattice.n_nodes)

    def structure(self, rec: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """:func:`~magsail_mj.concepts.current_loops.metrics.structural_series` of the recorded positions,
        read block by block from the records (a run's store is never loaded whole)."""
        return structural_series(
            self.lm, NodeTrajectory(lazy_record(rec, "qpos"), self.node_positions), modes=self.modes
        )

    def structural_figures(self, run_dir: Path, series: dict[str, np.ndarray], qpos: np.ndarray | None) -> list[Path]:
        """Structural plots and the snapshot at the time of maximum strain energy."""
        if "strain_energy_J" not in series:
            return []
        x, title = None, ""
        if "snapshot_index" in series and qpos is not None:
            i = int(series["snapshot_index"])
            x = self.node_positions(qpos[i])
            title = f"{self.cfg.description or self.cfg.scenario}: max strain energy at t = {series['t'][i]:.0f} s"
        return structural_plots(
            run_dir, series, lattice=self.lm.lattice, circuits=self.lm.circuits, snapshot_x=x, snapshot_title=title
        )

    def render_extra(self) -> dict[str, Any]:
        lat = self.lm.lattice
        rgba = {0: [0.85, 0.15, 0.1, 1.0], 1: [0.1, 0.7, 0.2, 1.0], 2: [0.15, 0.35, 0.95, 1.0]}
        return {
            "top_nodes": lat.top_nodes.tolist(),
            "strut_colours": [
                {
                    "name": c.name,
                    "axis": int(c.axis),
                    "rgba": rgba[int(c.axis)],
                    "struts": [int(s) for s in np.unique(c.strut_index(lat))],
                }
                for c in self.lm.circuits
            ],
        }

    def manifest_more(self) -> dict[str, Any]:
        return {"damping": self.damping_info()} if self.cfg.damping.enabled else {}


@register_task("current_loops", "sweep")
class LoopsSweepTask(FlexibleLoopsTask):
    """Sweep: the free flexible plate in a uniform constant field, constant circuit currents (the
    Eq.-9 sizing by default), compared with the rigid body carrying the realised dipole."""

    OVERLAY = ("strain_energy_J", "rotation_angle_deg")

    def lorentz_currents(self) -> np.ndarray:
        return self.lm.currents_A

    def metrics(self, rec: dict[str, np.ndarray]) -> Summary:
        cfg = self.cfg
        st = self.structure(rec)
        stability = self.damping_info()["stability_product_max"] if cfg.damping.enabled else 0.0
        return sweep_metrics(
            self.lm,
            rec,
            st,
            inertia_kgm2=self.inertia.tensor,
            areas_body_m2=self.areas0,
            field_world_T=self.field_fixed,
            work_names=list(self.ledger.watched) if self.ledger is not None else [],
            segments=self.segments,
            stability_product_max=stability,
            classification=cfg.classification,
            side_m=cfg.lattice.side_m,
            units=cfg.lattice.units,
        )

    def task_plots(self, run_dir: Path, series: dict[str, np.ndarray], qpos: np.ndarray | None) -> list[Path]:
        return [*self.structural_figures(run_dir, series, qpos), *sweep_plots(run_dir, series)]


@register_task("current_loops", "slew")
class LoopsSlewTask(FlexibleLoopsTask):
    """Slew: the flexible plate in orbit under quaternion PD with the corrected dipole command and
    per-axis current allocation over the circuits (one per axis)."""

    OVERLAY = ("error_angle_deg", "strain_energy_J")

    def make_controller(self) -> _CircuitOrder:
        ctrl, order = slew_controller(self.cfg, self.lm, field_world_T=self.field_fixed)
        return _CircuitOrder(ctrl, order)

    def probes(self) -> dict[str, Any]:
        torque = flexible_torque_probe(self.node_bodies, self.lm.masses, self.lorentz, self.segments, self.tidal)
        return {**super().probes(), **slew_probes(torque)}

    def metrics(self, rec: dict[str, np.ndarray]) -> Summary:
        summary, series = slew_metrics(rec, areas_body_m2=self.areas0)
        more_keys, more_series = slew_structure(rec["t"], self.structure(rec))
        summary.update(more_keys)
        series.update(more_series)
        summary.update(saturation_keys(rec["t"], rec["saturated"], t_peak_s=summary["t_strain_energy_max_s"]))
        summary.update(self.dominant_mode_keys(rec, int(series["snapshot_index"])))
        return summary, series

    def dominant_mode_keys(self, rec: Mapping[str, Any], index: int) -> dict[str, Any]:
        """The :data:`~magsail_mj.concepts.current_loops.metrics.N_DOMINANT` modes of largest strain
        energy at record ``index`` (the maximum of U), over the run and over its last
        :data:`~magsail_mj.concepts.current_loops.metrics.LAST_WINDOW_S` (``dominant_modes_at_Umax_*``,
        ``dominant_modes_mean_*``, ``dominant_modes_last2000s_*``), and the share of the first ten
        elastic modes in the modal strain energy at the same three (``modal_energy_share_first10_*``,
        :func:`~magsail_mj.concepts.current_loops.metrics.first_modes_share_keys`); none when the
        modes cannot be had."""
        try:
            md = self.modes()
        except Exception:  # noqa: BLE001 - the modes are a diagnostic; never lose a run for them
            return {}
        traj = NodeTrajectory(lazy_record(rec, "qpos"), self.node_positions)
        s = modal_energy_summary(md, self.lm.lattice.nodes, traj, t=rec["t"], index=index)
        omega = md.omega[md.elastic]
        return {
            **dominant_modes(omega, s.at, prefix="dominant_modes_at_Umax"),
            **dominant_modes(omega, s.mean, prefix="dominant_modes_mean"),
            **dominant_modes(omega, s.window_mean, prefix=f"dominant_modes_last{s.window_s:g}s"),
            **first_modes_share_keys(s),
        }

    def task_plots(self, run_dir: Path, series: dict[str, np.ndarray], qpos: np.ndarray | None) -> list[Path]:
        return [*self.structural_figures(run_dir, series, qpos), *slew_plots(run_dir, series)]


@register_task("current_loops", "slew_rigid")
class LoopsRigidSlewTask(LoopsScenario):
    """Rigid slew: the rigid-body surrogate of the slew: one body with the undeformed lattice's inertia,
    dipole torque (R Σ I_L a_L) × B, classical gravity-gradient torque (``gravity.tidal``)."""

    OVERLAY = ("error_angle_deg",)

    def __post_init__(self) -> None:
        self.rigid_torque: RigidLoopTorqueLoad | None = None
        self.gg_load: GravityGradientTorqueLoad | None = None
        super().__post_init__()

    def build_spec(self) -> mujoco.MjSpec:
        return rigid_plate_spec(self.cfg, self.inertia.tensor, self.inertia.mass)

    def loads(self) -> list:
        self.rigid_torque = RigidLoopTorqueLoad(1, self.areas0, self.field_fixed)
        out: list = [self.rigid_torque]
        if self.cfg.gravity.tidal:
            self.gg_load = GravityGradientTorqueLoad(1, self.inertia.tensor, mu=self.cfg.orbit.mu_m3_s2)
            out.append(self.gg_load)
        return out

    def make_controller(self) -> _CircuitOrder:
        ctrl, order = slew_controller(self.cfg, self.lm, field_world_T=self.field_fixed)
        return _CircuitOrder(_RigidWrapper(ctrl), order)

    def probes(self) -> dict[str, Any]:
        torque = rigid_torque_probe(self.areas0, self.field_fixed, self.gg_load)
        return {**rigid_probes(), **slew_probes(torque)}

    def metrics(self, rec: dict[str, np.ndarray]) -> Summary:
        return slew_metrics(rec, areas_body_m2=self.areas0)

    def task_plots(self, run_dir: Path, series: dict[str, np.ndarray], qpos: np.ndarray | None) -> list[Path]:
        return slew_plots(run_dir, series)

    def manifest_more(self) -> dict[str, Any]:
        return {"rigid_inertia_kgm2": self.inertia.tensor.tolist()}


def build_loops_scenario(cfg: CurrentLoopsConfig) -> LoopsScenario:
    """The task of a current-loops config: the class registered for ``(cfg.concept, cfg.scenario)`` in
    :data:`magsail_mj.concepts.TASKS` (:func:`magsail_mj.concepts.build_task`)."""
    return build_task(cfg)


@register_structure("current_loops")
def config_structure(cfg: CurrentLoopsConfig) -> Structure:
    """The lattice a config models as a structure (:func:`loops_structure`: uniform particles,
    the calibrated struts, the stiffness form and the modal damping)."""
    lat = make_lattice(units=cfg.lattice.units, side_m=cfg.lattice.side_m, diagonals=cfg.lattice.diagonals)
    total = cfg.mass.areal_density_kg_m2 * cfg.lattice.side_m**2
    _, c = strut_stiffness(lat, EI_Nm2=cfg.stiffness.EI_Nm2, calibration=cfg.stiffness.calibration)
    return loops_structure(cfg, lat, masses=np.full(lat.n_nodes, total / lat.n_nodes), calibration_factor=c)
