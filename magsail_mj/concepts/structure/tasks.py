"""Tasks of the ``structure`` concept: one class per scenario kind.

:class:`StructureTask` is the shared base (model, environment, loads, rigid initial state, probes,
runner, summary, plots, render and manifest entries); each subclass adds what its kind needs and
is registered by name (:func:`magsail_mj.concepts.register_task`):

============  ====================  =========================================================
``scenario``  class                 what it runs
============  ====================  =========================================================
``free``      :class:`FreeTask`     no actuator (momentum and energy in free space, libration)
``detumble``  :class:`DetumbleTask` rods on a member set and/or current loops under B-dot
``slew``      :class:`SlewTask`     the same under quaternion PD on the best-fit rigid attitude
============  ====================  =========================================================

Loads (:mod:`magsail_mj.concepts.structure.loads`): tidal gravity on every node when
``orbit.enabled`` and ``gravity.tidal``; solar pressure and drag on the panels when
``srp.enabled`` or ``drag.enabled``; the rods and the current loops when the kind has a
controller. Frames: world =
the orbit-following frame (axes = ECI) or free space; body = the best-fit rotation of the nodes
(the structure frame at the reference). Units SI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import mujoco
import numpy as np

from magsail_mj.concepts import register_structure, register_task
from magsail_mj.concepts.structure.config import StructureConfig
from magsail_mj.structure.model import Structure
from magsail_mj.concepts.structure.control import DipoleAllocation, StructureRodController
from magsail_mj.concepts.structure.loads import LoopLorentzLoad, NodeTidalLoad, PanelSurfaceLoad, RodDipoleLoad
from magsail_mj.concepts.structure.metrics import (
    StructureMonitor,
    actuator_keys,
    detumble_keys,
    panel_keys,
    slew_keys,
    structure_summary,
)
from magsail_mj.concepts.structure.model import StructureModel, make_structure_model, rigid_initial_state
from magsail_mj.concepts.structure.plots import rod_plots, slew_plot, structure_plots
from magsail_mj.environment.environment import Environment
from magsail_mj.sim import RunResult, Simulation

__all__ = ["StructureTask", "FreeTask", "ActuatedTask", "DetumbleTask", "SlewTask"]

Summary = tuple[dict[str, Any], dict[str, np.ndarray]]

#: readable names of the overlay series (units come from their suffixes)
OVERLAY_NAMES = {
    "omega_norm_rad_s": "body rate |ω|",
    "shape_rms_m": "RMS shape deviation",
    "error_angle_deg": "attitude error",
}


@dataclass
class StructureTask:
    """A run of a structure: the model, its loads, probes and post-processing (base of every kind).

    Subclasses override :meth:`make_controller`, :meth:`kind_loads`, :meth:`kind_probes`,
    :meth:`kind_summary` and :meth:`kind_plots` where the kind has them, and :attr:`OVERLAY` /
    :attr:`INSET` for the video.
    """

    cfg: StructureConfig
    sm: StructureModel = field(init=False)

    OVERLAY: ClassVar[tuple[str, ...]] = ("omega_norm_rad_s", "shape_rms_m")
    """Series printed on each video frame."""
    INSET: ClassVar[str | None] = None
    """Series drawn as the video's inset plot (``None``: none)."""

    def __post_init__(self) -> None:
        self.sm = make_structure_model(self.cfg)
        self.spec = self.sm.spec
        self.model = self.sm.model
        self.environment: Environment | None = None
        if self.cfg.environment_needed:
            self.environment = Environment.from_config(
                self.cfg.environment_config(), duration_s=self.cfg.sim.duration_s
            )
        self.monitor: StructureMonitor | None = None
        self.tidal_load: NodeTidalLoad | None = None
        self.panel_load: PanelSurfaceLoad | None = None
        self.rod_load: RodDipoleLoad | None = None
        self.loop_load: LoopLorentzLoad | None = None
        self.controller: StructureRodController | None = None

    @classmethod
    def from_config(cls, cfg: StructureConfig) -> StructureTask:
        """The task of a validated config, with its model."""
        return cls(cfg=cfg)

    @property
    def title(self) -> str:
        """``"<scenario>: <description>"`` (plots and videos)."""
        return f"{self.cfg.scenario}: {self.cfg.description}".strip(": ")

    # -------------------------------------------------------------- runner
    def environment_loads(self) -> list:
        """Tidal gravity on every mass point, when the orbit and ``gravity.tidal`` are on; solar
        pressure and drag on the panels, when ``srp.enabled`` or ``drag.enabled``."""
        loads: list = []
        if self.environment is None:
            return loads
        if self.cfg.orbit.enabled and self.cfg.gravity.tidal:
            self.tidal_load = NodeTidalLoad(self.sm.mass_points, **self.environment.gravity_params)
            loads.append(self.tidal_load)
        if self.cfg.srp.enabled or self.cfg.drag.enabled:
            self.panel_load = PanelSurfaceLoad(
                self.sm.nodes, self.sm.structure.panels, srp=self.cfg.srp.enabled, drag=self.cfg.drag.enabled
            )
            loads.append(self.panel_load)
        return loads

    def panel_probes(self) -> dict[str, Any]:
        """The panels' net SRP and drag force [N] and their moments about the centre of mass
        [N m], world axes (``srp_wrench_world``, ``drag_wrench_world``: force then moment), for
        those that are on."""
        load, points = self.panel_load, self.sm.mass_points
        if load is None:
            return {}

        def wrench(state: Any, *, srp: bool) -> np.ndarray:
            com = points.center_of_mass(points.frames.positions(state.pos, state.xquat))
            return load.wrench(state, com, srp=srp, drag=not srp)

        probes: dict[str, Any] = {}
        if load.srp:
            probes["srp_wrench_world"] = lambda s, d: wrench(s, srp=True)
        if load.drag:
            probes["drag_wrench_world"] = lambda s, d: wrench(s, srp=False)
        return probes

    def kind_loads(self) -> list:
        """The kind's own loads (after the environment's); none by default."""
        return []

    def make_controller(self) -> StructureRodController | None:
        """The run's controller (none by default)."""
        return None

    def kind_probes(self) -> dict[str, Any]:
        """The kind's recorder probes, besides ``qpos`` and the monitor's."""
        return {}

    def init_state(self, data: mujoco.MjData) -> None:
        """The rigid initial state of ``[initial]``
        (:func:`~magsail_mj.concepts.structure.model.rigid_initial_state`)."""
        i = self.cfg.initial
        rigid_initial_state(self.sm, data, q0_wxyz=i.q0_wxyz, omega0_body_rad_s=i.omega0_rad_s)

    def simulation(self) -> Simulation:
        """The runner: loads, controller, probes and the members' strain check."""
        loads = [*self.environment_loads(), *self.kind_loads()]
        self.controller = self.make_controller()
        self.monitor = StructureMonitor(self.sm, max_strain=self.cfg.sim.max_strain)
        probes: dict[str, Any] = {
            "qpos": lambda s, d: d.qpos,
            **self.monitor.probes(),
            **self.panel_probes(),
            **self.kind_probes(),
        }
        return Simulation(
            model=self.model,
            duration_s=self.cfg.sim.duration_s,
            loads=loads,
            controller=self.controller,
            probes=probes,
            record_every=self.cfg.sim.record_every,
            strain_check=self.monitor.strain_check,
            max_strain=math.inf,  # the monitor raises on each member's own limit
            environment=self.environment,
            checkpoint_every_s=self.cfg.sim.checkpoint_every_s,
            init=self.init_state,
        )

    # -------------------------------------------------------------- outputs
    def kind_summary(self, records: Any, series: dict[str, np.ndarray]) -> Summary:
        """The kind's own ``(keys, series)``; none by default."""
        return {}, {}

    def postprocess(self, result: RunResult) -> Summary:
        """Summary keys and series of the run (:func:`~magsail_mj.concepts.structure.metrics.structure_summary`
        and the kind's)."""
        keys, series = structure_summary(
            self.sm, result.records, omega0_body=np.asarray(self.cfg.initial.omega0_rad_s, dtype=float)
        )
        keys.update(panel_keys(result.records))
        more_keys, more_series = self.kind_summary(result.records, {"t": result.records["t"], **series})
        keys.update(more_keys)
        series.update(more_series)
        if self.environment is not None:
            keys.update(self.environment.summary())
        return keys, series

    def kind_plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        """The kind's own figures; none by default."""
        return []

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        """Write the run's figures into ``run_dir``; returns their paths."""
        return [
            *structure_plots(run_dir, series, result.records, title=self.title),
            *self.kind_plots(run_dir, result, series),
        ]

    def top_nodes(self) -> list[int] | None:
        """The structure's node set ``top`` as the video's top layer (its height colours, and the
        exaggeration applied about each layer rather than across the plate's depth), when it has
        one and node ``i`` is body ``i + 1`` (particles only); else ``None``."""
        top = self.sm.structure.node_sets.get("top")
        body = np.asarray(self.sm.index.node_body, dtype=np.int64)
        if top is None or len(top) < 3 or not np.array_equal(body, np.arange(body.size) + 1):
            return None
        return [int(i) for i in top]

    def render_info(self) -> dict[str, Any]:
        """The manifest's ``render`` entry: title, overlay, camera framed on the structure's extent."""
        r = self.cfg.render
        return {
            "title": self.title,
            "overlay": list(self.OVERLAY),
            **({"inset": self.INSET} if self.INSET is not None else {}),
            "camera": {
                "azimuth_deg": r.azimuth_deg,
                "elevation_deg": r.elevation_deg,
                "distance_m": r.distance_factor * self.sm.extent_m,
            },
            "exaggeration": r.exaggeration,
            **({"top_nodes": top} if (top := self.top_nodes()) is not None else {}),
            "fps": r.fps,
            "max_frames": r.max_frames,
            "overlay_names": {k: v for k, v in OVERLAY_NAMES.items() if k in self.OVERLAY},
        }

    def task_manifest(self) -> dict[str, Any]:
        """The kind's manifest entries; none by default."""
        return {}

    def manifest_extra(self) -> dict[str, Any]:
        """Manifest entries: the structure's source and size, the kind's, integrator and step."""
        s, table = self.sm.structure, self.cfg.structure
        return {
            **self.task_manifest(),
            "structure": {
                "name": s.name,
                "file": table.file,
                "sha256": dict(table.source.sha256),
            },
            "model_size": {
                "nodes": s.n_nodes,
                "members": s.n_members,
                "panels": len(s.panels),
                "rigid_parts": len(s.rigid_parts),
                "bodies": int(self.model.nbody),
                "dofs": int(self.model.nv),
                "tendons": int(self.model.ntendon),
            },
            "total_mass_kg": self.sm.total_mass_kg,
            "integrator": self.cfg.sim.integrator,
            "timestep_s": self.cfg.sim.timestep_s,
        }


@register_task("structure", "free")
class FreeTask(StructureTask):
    """The structure with no actuator (rods, if any, carry their mass and stay off): angular
    momentum and energy in free space, libration under tidal gravity in orbit."""


class ActuatedTask(StructureTask):
    """The structure with magnetorquer rods on ``actuators.member_set`` and current loops on
    ``loops.member_sets`` (either or both) under the ``[control]`` law
    (:mod:`magsail_mj.concepts.structure.control`)."""

    def rods(self) -> RodDipoleLoad | None:
        """The rod load (built once: the controller and the probes share it); ``None`` without rods."""
        if self.rod_load is None and self.sm.rod_members.size:
            ends = self.sm.structure.members.nodes[self.sm.rod_members]
            self.rod_load = RodDipoleLoad(self.sm.nodes, ends, self.sm.rod_dipole_max_Am2)
        return self.rod_load

    def loops(self) -> LoopLorentzLoad | None:
        """The current loops' load (built once, shared likewise); ``None`` without loops."""
        if self.loop_load is None and self.sm.loops is not None:
            self.loop_load = LoopLorentzLoad(self.sm.nodes, self.sm.loops)
        return self.loop_load

    def kind_loads(self) -> list:
        return [load for load in (self.rods(), self.loops()) if load is not None]

    def allocation(self) -> DipoleAllocation:
        """The rods' allocation on their reference axes (of no rods when there are none)."""
        p = self.sm.structure.positions_m
        ends = self.sm.structure.members.nodes[self.sm.rod_members]
        axes = p[ends[:, 1]] - p[ends[:, 0]]
        axes /= np.linalg.norm(axes, axis=1, keepdims=True)
        return DipoleAllocation(axes, self.sm.rod_dipole_max_Am2)

    def make_controller(self) -> StructureRodController:
        c, cfg = self.cfg.control, self.cfg
        mu = self.environment.mu if (cfg.orbit.enabled and c.gg_comp) else None
        return StructureRodController(
            nodes=self.sm.nodes,
            reference_m=self.sm.structure.positions_m,
            masses=self.sm.mass_points,
            allocation=self.allocation(),
            law=c.kind,
            period_s=c.period_s if c.period_s is not None else cfg.sim.timestep_s,
            omega0_body=np.asarray(cfg.initial.omega0_rad_s, dtype=float),
            k_bdot_Nms_T2=c.k_bdot_Nms_T2,
            q_ref_wxyz=None if c.q_ref_wxyz is None else np.asarray(c.q_ref_wxyz, dtype=float),
            Pq_Nm=np.asarray(c.Pq_Nm, dtype=float),
            Pw_Nms=np.asarray(c.Pw_Nms, dtype=float),
            inertia_kgm2=self.sm.inertia_kg_m2,
            mu_m3_s2=mu,
            loops=self.loops(),
        )

    def kind_probes(self) -> dict[str, Any]:
        """The held command's values (read from ``state.ctrl``, so they stay right after a resume),
        the rods' actual torque ``Rᵀ Σ m_r × B`` on the deformed members and the loops' actual
        torque ``Rᵀ Σ I_L a_L × B`` on the deformed loops, body axes."""
        probes: dict[str, Any] = {
            "omega_est_body_rad_s": lambda s, d: s.ctrl.omega_body,
            "B_body_T": lambda s, d: s.ctrl.B_body,
            "torque_ref_body_Nm": lambda s, d: s.ctrl.torque_ref_body,
            "torque_alloc_body_Nm": lambda s, d: s.ctrl.torque_alloc_body,
            "dipole_body_Am2": lambda s, d: s.ctrl.dipole_body,
            "saturated": lambda s, d: np.bool_(s.ctrl.saturated),
            "control_counts": lambda s, d: s.ctrl.counts,
            "q_err": lambda s, d: s.ctrl.q_err,
        }
        rods, loops = self.rods(), self.loops()
        if rods is not None:
            probes["torque_rod_body_Nm"] = lambda s, d: s.ctrl.R.T @ rods.torque_world(s)
            probes["rod_activation"] = lambda s, d: s.ctrl.activation
        if loops is not None:
            probes["torque_loop_body_Nm"] = lambda s, d: s.ctrl.R.T @ loops.torque_world(s)
            probes["loop_currents_A"] = lambda s, d: s.ctrl.currents_A
            probes["loop_vector_area_body_m2"] = lambda s, d: loops.vector_areas(loops.node_positions(s)) @ s.ctrl.R
        return probes

    def kind_summary(self, records: Any, series: dict[str, np.ndarray]) -> Summary:
        return actuator_keys(records), {}

    def kind_plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        return rod_plots(run_dir, series, result.records, title=self.title)

    def task_manifest(self) -> dict[str, Any]:
        c, cfg = self.cfg.control, self.cfg
        out: dict[str, Any] = {}
        if cfg.actuators is not None:
            out["rods"] = {
                "member_set": cfg.actuators.member_set,
                "count": int(self.sm.rod_members.size),
                "dipole_max_total_Am2": float(self.sm.rod_dipole_max_Am2.sum()),
            }
        if self.sm.loops is not None:
            loops = self.sm.loops
            areas = loops.vector_areas(self.sm.structure.positions_m)
            out["loops"] = {
                "member_sets": list(loops.names),
                "members": np.bincount(loops.loop, minlength=loops.n_loops).tolist(),
                "current_max_A": loops.current_max_A.tolist(),
                "vector_area_m2": areas.tolist(),
                "dipole_max_Am2": (loops.current_max_A * np.linalg.norm(areas, axis=1)).tolist(),
            }
        return {
            **out,
            "control_kind": c.kind,
            "control_period_s": c.period_s if c.period_s is not None else cfg.sim.timestep_s,
        }


@register_task("structure", "detumble")
class DetumbleTask(ActuatedTask):
    """B-dot detumble from the initial rate; done when ``|ω|`` stays below ``control.rate_threshold_rad_s``."""

    INSET = "omega_norm_rad_s"

    def kind_summary(self, records: Any, series: dict[str, np.ndarray]) -> Summary:
        keys, more = super().kind_summary(records, series)
        t = np.asarray(records["t"], dtype=float)
        threshold = self.cfg.control.rate_threshold_rad_s
        keys.update(detumble_keys(t, series["omega_norm_rad_s"], threshold_rad_s=threshold))
        return keys, more


@register_task("structure", "slew")
class SlewTask(ActuatedTask):
    """Quaternion PD from ``initial.q0_wxyz`` to ``control.q_ref_wxyz`` on the best-fit attitude."""

    OVERLAY = ("error_angle_deg", "omega_norm_rad_s", "shape_rms_m")
    INSET = "error_angle_deg"

    def kind_summary(self, records: Any, series: dict[str, np.ndarray]) -> Summary:
        keys, _ = super().kind_summary(records, series)
        t = np.asarray(records["t"], dtype=float)
        more, err = slew_keys(
            t,
            np.asarray(records["R_fit"], dtype=float),
            q0_wxyz=self.cfg.initial.q0_wxyz,
            q_ref_wxyz=self.cfg.control.q_ref_wxyz,
        )
        keys.update(more)
        return keys, {"error_angle_rad": err, "error_angle_deg": np.degrees(err)}

    def kind_plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        return [*super().kind_plots(run_dir, result, series), *slew_plot(run_dir, series, title=self.title)]


@register_structure("structure")
def config_structure(cfg: StructureConfig) -> Structure:
    """The structure a config models: its structure source with the rods' mass on their members."""
    return cfg.structure_with_rods()
