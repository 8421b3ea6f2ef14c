r"""CNUSAIL tasks: one class per scenario kind (config key ``kind``), registered by name.

* ``"attitude"`` → :class:`AttitudeTask`: S1–S7, B-dot detumbling, eigen-axis / PD slews, deorbit
  attitude, mode logic (``control.mode``, ``control.command``, ``control.modes``).
* ``"lifetime"`` → :class:`magsail_mj.concepts.cnusail.lifetime.LifetimeTask`: S8, orbit decay of
  the three attitude regimes (SciPy propagators, no MuJoCo run).

Each class is registered with :func:`magsail_mj.concepts.register_task` keyed by
``("cnusail", kind)``; :func:`magsail_mj.concepts.build_task` looks it up once. The attitude task runs
through :class:`magsail_mj.sim.Simulation`; the lifetime task's runner
(:class:`magsail_mj.concepts.cnusail.lifetime.LifetimeRunner`) has the same ``run()`` interface.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from magsail_mj.concepts import build_task, register_task
from magsail_mj.concepts.cnusail.compiled import CompiledControl, CompiledCubesat
from magsail_mj.concepts.cnusail.modes import CnusailController, Mode
from magsail_mj.loads.actuators_cubesat import MagnetorquerLoad
from magsail_mj.concepts.cnusail.config import CnusailConfig
from magsail_mj.concepts.cnusail.lifetime import LifetimeTask
from magsail_mj.concepts.cnusail.metrics import attitude_outputs
from magsail_mj.concepts.cnusail.model import CnusailModel
from magsail_mj.concepts.cnusail.plots import attitude_plots
from magsail_mj.io import write_json
from magsail_mj.sim import HoldBelow, RunResult, Simulation

__all__ = ["AttitudeTask", "LifetimeTask", "build_cnusail_scenario", "stop_rule_of"]


@register_task("cnusail", "attitude")
class AttitudeTask:
    """A CNUSAIL attitude run (S1–S7): the built cubesat (``cubesat``; ``spec``, ``model``, ``idx``,
    ``environment``, ``orbit_period_s``, ``inertia``, ``disturbances`` from it), the magnetorquer
    load, the flight controller, probes and outputs.

    With ``sim.loads = "compiled"`` the simulation's model is the cubesat's with the compiled loads
    (:class:`~magsail_mj.concepts.cnusail.compiled.CompiledCubesat`; ``model`` stays the model
    without them) and the controller runs at its samples only
    (:class:`~magsail_mj.concepts.cnusail.compiled.CompiledControl`); the probes record the same
    quantities, the torques and the motor torques computed by the plugin's C function at the
    record's state (:meth:`~magsail_mj.concepts.cnusail.compiled.CompiledCubesat.probe`)."""

    #: the scenario can run its loads compiled (``sim.loads = "compiled"``)
    compiled_loads = True

    def __init__(self, cfg: CnusailConfig) -> None:
        self.cfg = cfg
        self.cubesat = c = CnusailModel(cfg)
        self.params, self.spec, self.model, self.idx = c.params, c.spec, c.model, c.idx
        self.environment, self.orbit_period_s = c.environment, c.orbit_period_s
        self.inertia, self.disturbances = c.inertia, c.disturbances
        self.controller: CnusailController | None = None

    def make_controller(self) -> CnusailController:
        return self.cubesat.make_controller()

    def stop_rule(self) -> HoldBelow | None:
        """The detumble stop rule of ``sim.stop_rate_deg_s`` and ``sim.stop_hold_s`` (``None`` when
        off): ‖ω‖ of the bus, ω the free joint's angular velocity in ``qvel`` (body axes) [rad/s],
        below ``stop_rate_deg_s · π/180`` for ``stop_hold_s``, the hold compared within 10⁻⁶ δt
        (record times are step·δt)."""
        return stop_rule_of(self.cfg, self.idx.v_ang)

    def initial_state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(p_b (4,), ω_body (3,) [rad/s], ω_M (3,) [rad/s]) at t = 0 (see :meth:`CnusailModel.initial_state`)."""
        return self.cubesat.initial_state()

    def init_state(self, data: mujoco.MjData) -> None:
        self.cubesat.init_state(data)

    def simulation(self) -> Simulation:
        self.controller = ctl = self.make_controller()
        dist = self.disturbances
        mtq = MagnetorquerLoad(self.idx.bus)
        idx = self.idx

        compiled = control = None
        if self.cfg.sim.loads == "compiled":
            compiled = CompiledCubesat(
                self.spec,
                bare_model=self.model,
                environment=self.environment,
                disturbances=dist,
                controller=ctl,
                bus_qpos=idx.q_pos.start,
                bus_dof=idx.v_lin.start,
                timing=self.cfg.sim.load_timing,
            )
            control = CompiledControl(ctl, compiled)

        def mtq_body(state, d):
            m = state.ctrl.dipole_body if state.ctrl is not None else np.zeros(3)
            R = np.empty(9)
            mujoco.mju_quat2Mat(R, d.qpos[idx.q_quat])
            return np.cross(m, R.reshape(3, 3).T @ state.env.B_eci)

        probes: dict[str, Any] = {
            "qpos": lambda s, d: d.qpos,
            "qvel": lambda s, d: d.qvel,
            "mode": lambda s, d: int(ctl.mode),
            "p_e": lambda s, d: ctl.p_e,
            "theta_e_rad": lambda s, d: ctl.theta_e,
            "omega_e_rad_s": lambda s, d: ctl.omega_e,
            "u_cmd_Nm": lambda s, d: ctl.u,
            "T_M_Nm": lambda s, d: ctl.T_M,
            "dipole_cmd_Am2": lambda s, d: ctl.dipole_held,
            "unload_mask": lambda s, d: ctl.unload_mask.astype(np.int8),
            "torque_dist_body_Nm": lambda s, d: dist.torques_body(s),
            "torque_mtq_body_Nm": mtq_body,
        }
        if compiled is not None:
            # what the plugin computes at the record's state (its C function): the same quantities
            probes["T_M_Nm"] = lambda s, d: compiled.probe(d)[15:18]
            probes["torque_dist_body_Nm"] = lambda s, d: compiled.probe(d)[:12].reshape(4, 3)
            probes["torque_mtq_body_Nm"] = lambda s, d: compiled.probe(d)[12:15]
        return Simulation(
            model=self.model if compiled is None else compiled.model,
            duration_s=self.cfg.sim.duration_s,
            loads=[dist, mtq] if compiled is None else [],
            controller=ctl if control is None else control,
            compiled=compiled,
            environment=self.environment,
            probes=probes,
            record_every=self.cfg.sim.record_every,
            checkpoint_every_s=self.cfg.sim.checkpoint_every_s,
            init=self.init_state,
            stop_rule=self.stop_rule(),
        )

    # -------------------------------------------------------------- outputs
    def postprocess(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        return attitude_outputs(self.cubesat, result, controller=self.controller)

    def data_files(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        """``events.json``: the controller's events (mode changes, manoeuvre starts, gain recalculations)."""
        events = self.controller.events if self.controller is not None else []
        return [write_json(run_dir / "events.json", {"count": len(events), "events": events})]

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        events = self.controller.events if self.controller is not None else []
        return attitude_plots(
            run_dir, series, records=result.records, cfg=self.cfg, orbit_period_s=self.orbit_period_s, events=events
        )

    def render_info(self) -> dict[str, Any]:
        r = self.cfg.render
        frames = int(min(r.max_frames, max(2, math.ceil(self.cfg.sim.duration_s / r.time_lapse * r.fps))))
        cam: dict[str, float] = {"azimuth_deg": r.azimuth_deg, "elevation_deg": r.elevation_deg}
        if r.distance_m is not None:
            cam["distance_m"] = r.distance_m
        law = {"bdot": "B-dot", "eigen_axis": "eigen-axis", "pd": "PD"}[self.cfg.control.mode]
        return {
            "title": f"CNUSAIL-1 {self.cfg.scenario} ({self.cfg.spacecraft.configuration}, {law})",
            "overlay": ["mode", "theta_e_deg", "omega_norm_deg_s", "wheel_speed_rpm"],
            "overlay_names": {
                "mode": "mode",
                "theta_e_deg": "attitude error θ_e",
                "omega_norm_deg_s": "body rate |ω|",
                "wheel_speed_rpm": "wheel speeds",
            },
            "overlay_labels": {"mode": self.mode_labels()},
            "camera": cam,
            "fps": r.fps,
            "max_frames": frames,
            "markers": {
                "mk_sun": "Sun direction",
                "mk_vel": "orbital velocity direction",
                "mk_nadir": "nadir direction",
                "mk_field": "magnetic field direction",
                "axis_x/y/z": "body axes x, y, z",
                "sail_front": "sail front face (+z side)",
                "sail_back": "sail back face",
                "boom": "sail booms",
                "bus_box": "bus (3U cubesat)",
                "rw_x_tick/y_tick/z_tick": "reaction-wheel rotor marks",
            },
        }

    def mode_labels(self) -> dict[str, str]:
        """What each value of the recorded ``mode`` (:class:`~magsail_mj.concepts.cnusail.modes.Mode`)
        means in this run, for the video overlay: 0 B-dot detumbling, 1 nadir pointing and 2 deorbit
        attitude with the configured pointing law (none named for a B-dot-only run)."""
        law = {"eigen_axis": ", eigen-axis law", "pd": ", PD law"}.get(self.cfg.control.mode, "")
        return {
            str(int(Mode.DETUMBLE)): "detumbling (B-dot, wheels idle)",
            str(int(Mode.NADIR)): f"nadir pointing{law}",
            str(int(Mode.DEORBIT)): f"deorbit attitude (sail face forward){law}",
        }

    def manifest_extra(self) -> dict[str, Any]:
        m = self.model
        return {
            "model_size": {"bodies": int(m.nbody), "dofs": int(m.nv), "actuators": int(m.nu)},
            "integrator": self.cfg.sim.integrator,
            "timestep_s": self.cfg.sim.timestep_s,
            "orbit_period_s": self.orbit_period_s,
            "composite_inertia_kgm2": list(self.cfg.spacecraft.inertia),
            "hub_inertia_kgm2": self.params.hub_inertia_kgm2.tolist(),
            "events": len(self.controller.events) if self.controller is not None else 0,
        }


def stop_rule_of(cfg: CnusailConfig, v_ang: slice) -> HoldBelow | None:
    """The stop rule of ``cfg.sim`` (:meth:`AttitudeTask.stop_rule`) on the ``qvel`` components
    ``v_ang`` of the bus's angular velocity; ``None`` when ``sim.stop_rate_deg_s`` is not set."""
    sim = cfg.sim
    if sim.stop_rate_deg_s is None:
        return None
    return HoldBelow(
        probe="qvel",
        index=v_ang,
        threshold=math.radians(sim.stop_rate_deg_s),
        hold_s=sim.stop_hold_s,
        tolerance_s=1e-6 * sim.timestep_s,
        describe=f"|ω| < {sim.stop_rate_deg_s:g} °/s (sim.stop_rate_deg_s) for {sim.stop_hold_s:g} s (sim.stop_hold_s)",
    )


def build_cnusail_scenario(cfg: CnusailConfig) -> AttitudeTask | LifetimeTask:
    """Task object of a CNUSAIL config: the class registered for ``("cnusail", cfg.kind)``
    (:func:`magsail_mj.concepts.build_task`)."""
    return build_task(cfg)
