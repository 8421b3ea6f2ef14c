r"""Reflector tasks: one class per scenario kind (config key ``kind``), registered by name.

=================  =====================  ==========================================================
``kind``           class                  run
=================  =====================  ==========================================================
``"detumble"``     :class:`DetumbleTask`   Scenario A: constant field, B-dot, world inertial
``"pitch"``        :class:`PitchTask`      Scenario B: dawn–dusk orbit, steering + quaternion
                                           feedback, optional gravity gradient (B5)
``"pitch_caps"``   :class:`PitchCapsTask`  case B3: the cap sweep with bisection
                                           (:class:`magsail_mj.concepts.reflector.caps.CapSweepRunner`)
=================  =====================  ==========================================================

Every task builds its plate with :class:`magsail_mj.concepts.reflector.model.ReflectorModel` and
runs through :class:`magsail_mj.sim.Simulation` (the cap sweep: one Simulation per cap). Torques
enter through ``xfrc_applied`` (:class:`magsail_mj.loads.body_torque.HeldBodyTorqueLoad`),
rewritten every step; the controller runs every integration step (zero-order hold).
Each class is registered with :func:`magsail_mj.concepts.register_task` keyed by
``("reflector", kind)``; :func:`magsail_mj.concepts.build_task` looks it up once.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from pathlib import Path
from typing import Any, Callable

import mujoco
import numpy as np

from magsail_mj.concepts.reflector.bdot import PlateBdotController
from magsail_mj.control.reflector_pitch import ReflectorPitchController
from magsail_mj.concepts import build_task, register_task
from magsail_mj.control.reflector_steering import ReflectorOrbit
from magsail_mj.loads.body_torque import HeldBodyTorqueLoad, OrbitGravityGradientLoad
from magsail_mj.concepts.reflector.mjcf import MarkerSpec
from magsail_mj.concepts.reflector.caps import CapSweepRunner, caps_outputs, caps_plots
from magsail_mj.concepts.reflector.compiled import CompiledReflector
from magsail_mj.concepts.reflector.config import ReflectorConfig
from magsail_mj.concepts.reflector.metrics import detumble_outputs, pass_table, pitch_outputs, reference_products
from magsail_mj.concepts.reflector.model import (
    ASSUMPTIONS,
    DETUMBLE_MARKERS,
    PITCH_MARKERS,
    ReflectorModel,
)
from magsail_mj.concepts.reflector.plots import detumble_plots, pitch_plots
from magsail_mj.io import write_json
from magsail_mj.sim import RunResult, Simulation

__all__ = ["ReflectorTask", "DetumbleTask", "PitchTask", "PitchCapsTask", "build_reflector_scenario"]


#: readable names of the reflector's overlay series (units come from their suffixes)
OVERLAY_NAMES = {
    "omega_norm_rad_s": "body rate |ω|",
    "torque_norm_Nm": "coil torque |T|",
    "currents_A": "path currents (x-coil, y-coil)",
    "psi_ref_deg": "pitch reference ψ_ref",
    "psi_act_deg": "pitch ψ",
    "err_deg": "pointing error",
    "torque_pitch_Nm": "pitch torque",
}


class ReflectorTask(ABC):
    """What every reflector task shares: the built plate (``plate``; ``spec``, ``model``, ``idx``,
    ``inertia``, ``mass_kg``, ``cap``, ``params`` from it), the held-torque load, the state writer
    and the manifest. Subclasses set the marker set, the probes and the outputs, and implement the
    abstract :meth:`make_controller`, :meth:`initial_state` and :meth:`render_text` (a subclass
    without one of them cannot be instantiated: ``TypeError`` naming it)."""

    markers: tuple[MarkerSpec, ...] = ()
    #: free-camera distance in plate sides
    camera_distance_sides: float = 2.4

    def __init__(self, cfg: ReflectorConfig) -> None:
        self.cfg = cfg
        self.plate = ReflectorModel(cfg, markers=self.markers)
        self.spec: mujoco.MjSpec = self.plate.spec
        self.model = self.plate.model
        self.idx = self.plate.idx
        self.params = self.plate.params
        self.cap = self.plate.cap
        self.mass_kg, self.inertia = self.plate.mass_kg, self.plate.inertia
        self.controller: Any = None

    @property
    def orbit(self) -> ReflectorOrbit:
        """Scenario B orbit of the config (see :attr:`ReflectorModel.orbit`)."""
        return self.plate.orbit

    # -------------------------------------------------------------- parts
    @abstractmethod
    def make_controller(self) -> Any:
        """The kind's controller (``update(state)`` → a command with ``torque_body`` [N·m], body axes)."""

    @abstractmethod
    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        """``(q0, ω0_body [rad/s])`` at t = 0."""

    def init_state(self, data: mujoco.MjData) -> None:
        self.plate.write_state(data, *self.initial_state())

    def loads(self) -> list[Any]:
        """The held body torque (the controller's) on the plate."""
        return [HeldBodyTorqueLoad(self.idx.plate)]

    def probes(self, loads: list[Any]) -> dict[str, Callable[[Any, mujoco.MjData], Any]]:
        """Recorded quantities common to every kind: ``qpos``, ``qvel``, ``torque_body_Nm``."""
        return {
            "qpos": lambda s, d: d.qpos,
            "qvel": lambda s, d: d.qvel,
            "torque_body_Nm": lambda s, d: s.ctrl.torque_body,
        }

    def simulation(self) -> Simulation:
        self.controller = ctl = self.make_controller()
        loads = self.loads()
        return self.make_simulation(model=self.model, loads=loads, controller=ctl, probes=self.probes(loads))

    def make_simulation(
        self,
        *,
        model: mujoco.MjModel,
        loads: list[Any],
        controller: Any,
        probes: dict[str, Callable[[Any, mujoco.MjData], Any]],
        compiled: Any = None,
    ) -> Simulation:
        """The run's :class:`Simulation` of ``model`` with the given loads, controller, probes and
        compiled loads, and the config's duration, record and checkpoint intervals and initial
        state (no environment object, as every reflector run)."""
        sim = self.cfg.sim
        return Simulation(
            model=model,
            duration_s=sim.duration_s,
            loads=loads,
            controller=controller,
            compiled=compiled,
            environment=None,
            probes=probes,
            record_every=sim.record_every,
            checkpoint_every_s=sim.checkpoint_every_s,
            init=self.init_state,
        )

    # -------------------------------------------------------------- outputs
    @abstractmethod
    def render_text(self) -> dict[str, Any]:
        """``title``, ``overlay``, ``inset`` and ``markers`` of the video."""

    def render_info(self) -> dict[str, Any]:
        r, cfg = self.cfg.render, self.cfg
        frames = int(min(r.max_frames, max(2, round(cfg.sim.duration_s / cfg.sim.timestep_s / cfg.sim.record_every))))
        cam: dict[str, float] = {
            "azimuth_deg": r.azimuth_deg,
            "elevation_deg": r.elevation_deg,
            "distance_m": r.distance_m or self.camera_distance_sides * cfg.plate.side_m,
        }
        text = self.render_text()
        return {
            "title": text["title"],
            "overlay": text["overlay"],
            "inset": text["inset"],
            "camera": cam,
            "fps": r.fps,
            "max_frames": frames,
            "markers": text["markers"],
            "overlay_names": {**OVERLAY_NAMES, **text.get("overlay_names", {})},
        }

    def manifest_kind(self) -> dict[str, Any]:
        """Manifest entries of the scenario kind."""
        return {}

    def manifest_extra(self) -> dict[str, Any]:
        m, cfg = self.model, self.cfg
        return {
            "model_size": {"bodies": int(m.nbody), "dofs": int(m.nv), "actuators": int(m.nu)},
            "integrator": cfg.sim.integrator,
            "timestep_s": cfg.sim.timestep_s,
            "variant": cfg.variant,
            "mass_kg": self.mass_kg,
            "inertia_kgm2": self.inertia.tolist(),
            "inertia_thickness_m": self.params.thickness,
            "coil_capability": self.cap.as_dict(),
            "assumptions": ASSUMPTIONS,
            **self.manifest_kind(),
        }


@register_task("reflector", "detumble")
class DetumbleTask(ReflectorTask):
    """Scenario A: constant field (inertial ``+Z``, A6; body-fixed as a variant), B-dot law of
    :mod:`magsail_mj.concepts.reflector.bdot`, world = inertial, no orbit; starts from
    ``initial.q0_wxyz``, ``initial.omega0_rad_s``."""

    markers = DETUMBLE_MARKERS
    camera_distance_sides = 3.0

    def bdot_gain(self) -> float:
        return self.plate.bdot_gain()

    def field_body_fn(self) -> Callable[[float, np.ndarray], np.ndarray]:
        return self.plate.field_body_fn()

    def make_controller(self) -> PlateBdotController:
        return self.plate.bdot_controller()

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        i = self.cfg.initial
        return np.asarray(i.q0_wxyz, dtype=float), np.asarray(i.omega0_rad_s, float)

    def probes(self, loads: list[Any]) -> dict[str, Callable[[Any, mujoco.MjData], Any]]:
        return {
            **super().probes(loads),
            "dipole_body_Am2": lambda s, d: s.ctrl.dipole_body,
            "dipole_cmd_body_Am2": lambda s, d: s.ctrl.dipole_cmd_body,
            "currents_A": lambda s, d: s.ctrl.currents_A,
            "saturated": lambda s, d: s.ctrl.saturated.astype(np.int8),
            "B_body_T": lambda s, d: s.ctrl.B_body,
        }

    def postprocess(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        return detumble_outputs(self.plate, result)

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        return detumble_plots(run_dir, series, cfg=self.cfg, cap_Nm=self.cap.cap_Nm)

    def render_text(self) -> dict[str, Any]:
        cfg = self.cfg
        return {
            "title": f"reflector {cfg.scenario}: B-dot ({cfg.control.law}, ω_k = {cfg.control.omega_k_rad_s:g} rad/s)",
            "overlay": ["omega_norm_rad_s", "torque_norm_Nm", "currents_A"],
            "inset": "omega_norm_rad_s",
            "markers": {
                "mk_field": "magnetic field (magenta)",
                "mk_omega": "angular velocity (green)",
                "mk_torque": "torque (red)",
                "ycoil/xcoil": "coil columns (orange/cyan, every k-th)",
                "zloop": "in-plane loop (violet)",
                "normal": "plate normal (blue)",
            },
        }

    def manifest_kind(self) -> dict[str, Any]:
        return {"bdot_gain": self.bdot_gain()}


@register_task("reflector", "pitch")
class PitchTask(ReflectorTask):
    """Scenario B: polar dawn–dusk orbit, dipole field Eq. 11, steering law
    (:mod:`magsail_mj.control.reflector_steering`), quaternion feedback with projection ⟂ B and
    saturation (:mod:`magsail_mj.control.reflector_pitch`); optional gravity-gradient torque (B5).
    Starts on the reference: ``q_ref(0)``, ``ω_ref(0) = −ψ̇(0) ŷ``.

    With ``sim.loads = "compiled"`` the simulation's model is the plate's with the compiled pitch
    tracking (:class:`~magsail_mj.concepts.reflector.compiled.CompiledReflector`: controller, coil
    torque and gravity gradient inside ``mj_step``; ``model`` stays the model without it), the runner
    has no Python controller or loads, and the probes record the same quantities, computed by the
    plugin's C function at the record's state."""

    markers = PITCH_MARKERS
    #: the scenario can run its loads compiled (``sim.loads = "compiled"``)
    compiled_loads = True

    def make_controller(self) -> ReflectorPitchController:
        return self.plate.pitch_controller()

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.plate.pitch_initial_state()

    def loads(self) -> list[Any]:
        loads = super().loads()
        if self.cfg.gravity.gg_torque:
            loads.append(
                OrbitGravityGradientLoad(
                    self.idx.plate, inertia_kgm2=self.inertia, position=self.orbit.position, mu=self.cfg.orbit.mu_m3_s2
                )
            )
        return loads

    def simulation(self) -> Simulation:
        if self.cfg.sim.loads != "compiled":
            return super().simulation()
        self.controller = ctl = self.make_controller()
        idx = self.idx
        compiled = CompiledReflector(
            self.spec,
            bare_model=self.model,
            controller=ctl,
            gravity_gradient_mu=self.cfg.orbit.mu_m3_s2 if self.cfg.gravity.gg_torque else None,
            plate_qpos=idx.q_quat.start - 3,
            plate_dof=idx.v_ang.start - 3,
            timing=self.cfg.sim.load_timing,
        )
        return self.make_simulation(
            model=compiled.model, loads=[], controller=None, probes=self.compiled_probes(compiled), compiled=compiled
        )

    def compiled_probes(self, compiled: CompiledReflector) -> dict[str, Callable[[Any, mujoco.MjData], Any]]:
        """The probes of :meth:`probes` read from what the plugin's C function computes at the
        record's state (:meth:`CompiledReflector.probe`): the same names, values and dtypes."""
        f = compiled.field
        out: dict[str, Callable[[Any, mujoco.MjData], Any]] = {
            "qpos": lambda s, d: d.qpos,
            "qvel": lambda s, d: d.qvel,
            "torque_body_Nm": lambda s, d: f(d, "T_ACT"),
            "T_ref_body_Nm": lambda s, d: f(d, "T_REF"),
            "saturated": lambda s, d: np.int8(f(d, "SATURATED")[0]),
            "q_e": lambda s, d: f(d, "Q_E"),
            "q_ref": lambda s, d: f(d, "Q_REF"),
            "psi_ref_rad": lambda s, d: float(f(d, "PSI")[0]),
            "psi_dot_ref_rad_s": lambda s, d: float(f(d, "PSI")[1]),
            "psi_ddot_ref_rad_s2": lambda s, d: float(f(d, "PSI")[2]),
            "B_world_T": lambda s, d: f(d, "B_WORLD"),
        }
        if self.cfg.gravity.gg_torque:
            out["torque_gg_world_Nm"] = lambda s, d: f(d, "GG_WORLD")
        return out

    def probes(self, loads: list[Any]) -> dict[str, Callable[[Any, mujoco.MjData], Any]]:
        out = {
            **super().probes(loads),
            "T_ref_body_Nm": lambda s, d: s.ctrl.T_ref_body,
            "saturated": lambda s, d: np.int8(s.ctrl.saturated),
            "q_e": lambda s, d: s.ctrl.q_e,
            "q_ref": lambda s, d: s.ctrl.q_ref,
            "psi_ref_rad": lambda s, d: s.ctrl.psi_ref,
            "psi_dot_ref_rad_s": lambda s, d: s.ctrl.psi_dot_ref,
            "psi_ddot_ref_rad_s2": lambda s, d: s.ctrl.psi_ddot_ref,
            "B_world_T": lambda s, d: s.ctrl.B_world,
        }
        for load in loads:
            if isinstance(load, OrbitGravityGradientLoad):
                out["torque_gg_world_Nm"] = lambda s, d, gg=load: gg.torque_world(s)
        return out

    def postprocess(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        ref = reference_products(self.plate)
        self.passes = pass_table(self.plate, ref)
        return pitch_outputs(self.plate, result, ref=ref)

    def data_files(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        """``passes.json``: the per-pass table (:func:`~magsail_mj.concepts.reflector.metrics.pass_table`
        of :meth:`postprocess`), the cap [N m], the orbit period [s] and the overhead time [s]."""
        o, path = self.orbit, run_dir / "passes.json"
        passes = getattr(self, "passes", [])
        write_json(
            path, {"cap_Nm": self.cap.cap_Nm, "orbit_period_s": o.period_s, "t_mid_s": o.t_mid_s, "passes": passes}
        )
        return [path]

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        return pitch_plots(run_dir, series, cfg=self.cfg, cap_Nm=self.cap.cap_Nm, orbit_period_s=self.orbit.period_s)

    def render_text(self) -> dict[str, Any]:
        cfg = self.cfg
        return {
            "title": f"reflector {cfg.scenario}: σ = {1e3 * cfg.plate.areal_density_kg_m2:g} g/m², "
            f"{cfg.control.rate_term} rate term",
            "overlay": ["psi_ref_deg", "psi_act_deg", "err_deg", "torque_pitch_Nm"],
            "inset": "err_deg",  # error inset
            "markers": {
                "mk_sun": "Sun direction +y (yellow)",
                "mk_ground": "towards the ground point (blue)",
                "mk_field": "magnetic field (magenta)",
                "mk_ref_line": "reference grey line (white)",
                "grey_line": "actual grey line (dark grey)",
                "normal": "plate normal (blue)",
            },
        }

    def manifest_kind(self) -> dict[str, Any]:
        o, cfg = self.orbit, self.cfg
        Pq, Pw = self.plate.pitch_gains()
        return {
            "orbit": {
                "r_m": o.r_m,
                "n_rad_s": o.n_rad_s,
                "T_orb_s": o.period_s,
                "run_length_nominal_s": cfg.orbit.n_orbits * o.period_s,
                "t_mid_s": o.t_mid_s,
            },
            "gains": {"P_q_Nm": Pq.tolist(), "P_omega_Nms": Pw.tolist()},
        }


@register_task("reflector", "pitch_caps")
class PitchCapsTask(PitchTask):
    """Case B3: the whole cap sweep with bisection in one run; its runner
    (:class:`magsail_mj.concepts.reflector.caps.CapSweepRunner`) runs one
    :class:`magsail_mj.sim.Simulation` per cap. No gravity gradient; no compiled loads."""

    compiled_loads = False

    def simulation(self) -> CapSweepRunner:  # type: ignore[override]
        if self.cfg.gravity.gg_torque:
            raise ValueError("gravity.gg_torque: the B3 cap sweep runs without the gravity gradient")
        self.runner = CapSweepRunner(self.plate)
        return self.runner

    def postprocess(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        return caps_outputs(self.runner, result)

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        return caps_plots(
            run_dir,
            runs=self.runner.runs,
            minimum=self.runner.minimum,
            T_max_Nm=self.cap.T_max_ycoil_Nm,
            areal_density_kg_m2=self.cfg.plate.areal_density_kg_m2,
        )


def build_reflector_scenario(cfg: ReflectorConfig) -> ReflectorTask:
    """Task object of a reflector config: the class registered for ``("reflector", cfg.kind)``
    (:func:`magsail_mj.concepts.build_task`)."""
    return build_task(cfg)
