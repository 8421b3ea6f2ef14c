r"""dm_control environments of the CNUSAIL-1 cubesat: detumble, nadir slew, deorbit slew.

Tasks (``magsail_mj.envs.load("cnusail/<task>")`` or any CNUSAIL attitude config; the task follows the
config's ``control.mode``/``control.command``):

* ``cnusail/detumble`` — default config ``detumble_post.toml`` (S2); shipped law B-dot, wheels idle
  (``control.mode = "bdot"``);
* ``cnusail/nadir`` — ``nadir_post.toml`` (S4); eigen-axis (or PD) nadir slew with unloading;
* ``cnusail/deorbit`` — ``deorbit.toml`` (S6); eigen-axis deorbit slew with unloading.

Action (``dm_env.specs.BoundedArray``, float64, bounded as the hardware is):

* detumble, ``action="dipole"`` (default): ``m`` (3,) magnetorquer dipole [A m², body axes], each
  axis within ``±actuators.mtq`` limits; the wheels are idle (current command 0: B-dot alone after deployment);
* pointing, ``action="torque_dipole"`` (default): ``u`` (3,) body-torque request of the wheels
  [N m, ±(K_M i_max + 2 K_B Ω_max), beyond which the current command saturates alike] through the
  wheel driver (``i_c = clip((−u + K_B ω_M)/K_M, ±i_max)``) and ``m`` (3,);
* any task, ``action="current_dipole"``: the wheel motor current commands ``i_c`` (3,) [A, ±i_max]
  (the motor torque commands [N m, ±τ_max] for ``actuators.wheels.model = "ideal"``) and ``m`` (3,).

The wheel command is taken at the control sample and held (the driver's per-step part, voltage clip,
back-EMF and speed limiter, runs every dynamics step); the dipole is latched at each magnetorquer
cycle boundary (every ``actuators.mtq.cycle_s``) from the latest action and is zero in the last
``blank_s`` of the cycle (magnetometer blanking), as on the spacecraft.

Observations (float64 arrays, as the flight software reads them):
``time_s`` (1,) [s since the epoch], ``attitude_wxyz`` (4,) (bus → ECI, the quaternion the controller
reads), ``body_rate_rad_s`` (3,) (gyro, with ``control.sensors.gyro_noise_rad_s`` white noise),
``field_body_T`` (3,) (magnetometer ``Aᵀ B_eci``, with ``control.sensors.magnetometer_noise_T``),
``wheel_speed_rad_s`` (3,) (rotor speeds relative to the bus), ``orbit_position_eci_m`` and
``orbit_velocity_eci_m_s`` (3,) (reference orbit, for the command frames), ``pointing_error_wxyz``
(4,) (body relative to the task's command frame; nadir for the detumble) and ``rate_error_rad_s``
(3,) (``ω_e = ω − A(q_e)[0, −ω_o, 0]ᵀ``). The cubesat is rigid: no structural-health observation.

Reward per control step: the formula of :mod:`magsail_mj.envs.core`,
``r = −(w_θ (θ/π)² + w_ω (ω/ω_s)² + w_u mean((a/a_max)²))``, with, for the detumble, ``θ = 0``,
``ω = ‖ω_body‖`` (true rate) and ``ω_s`` = ``analysis.detumble_threshold_deg_s`` (0.3 °/s); for the
pointing tasks ``θ = θ_e`` (eigen-angle of the pointing error), ``ω = ‖ω_e‖`` and ``ω_s`` =
``control.slew_rate_max_deg_s`` (0.3 °/s); ``a/a_max`` is the action normalised by its bounds.

Termination: a diverged simulation ends the episode with discount 0; the time limit (``sim.duration_s``)
with discount 1. ``control_timestep`` = the attitude-law period ``1/control.rate_Hz`` (the shipped
controller runs its wheel driver every dynamics step; the environment's plant does that part, see
:class:`CubesatActuators`).

Episode start (``randomize=True``, drawn from the task's ``random``): detumble, body rate uniform per
axis in ``±rate_range_deg_s`` (default: the largest component of ``initial.omega0_deg_s``) and the
attitude uniform over SO(3); pointing, the attitude error uniform over SO(3) with ``ω_e(0) = 0``;
the epoch is the config's unless the ``epoch_range_s`` option (> 0) draws it per episode uniformly in
``[orbit.epoch, orbit.epoch + epoch_range_s]`` (the simulation is rebuilt for it, which takes about a
second). ``randomize=False`` keeps the config's initial state, so an episode of
:func:`magsail_mj.envs.shipped_policy` equals ``magsail run``.

The records of the environment's simulation carry the probes of the scenario's own run (``qpos``,
``qvel``, ``mode``, ``p_e``, ``theta_e_rad``, ``omega_e_rad_s``, ``u_cmd_Nm``, ``T_M_Nm``,
``dipole_cmd_Am2``, ``unload_mask``, ``torque_dist_body_Nm``, ``torque_mtq_body_Nm``), so
``sim.scenario.postprocess`` applies to them; ``p_e``/``θ_e``/``ω_e`` are computed by the plant from
the true state at the control samples, ``mode`` is the task's, and ``unload_mask`` marks the wheels the
configured unloading logic would unload (above ``control.unloading.threshold_rpm``), evaluated at the
magnetorquer cycle boundaries, whatever the policy commands.
"""

from __future__ import annotations

import copy
import json
import math
from dataclasses import dataclass
from datetime import timedelta
from types import SimpleNamespace
from typing import Any, Callable

import mujoco
import numpy as np
from dm_control.rl import control

from magsail_mj.commands import attach
from magsail_mj.config import ConfigError
from magsail_mj.concepts.cnusail.modes import CnusailController, Mode, command_frame, command_quaternion
from magsail_mj.concepts.cnusail.eigenaxis import eigen_angle, error_quaternion, orbital_rate, rate_error
from magsail_mj.concepts.cnusail.unloading import UnloadingLogic
from magsail_mj.envs.core import ActionController, AttitudeTask, SimulationPhysics, register
from magsail_mj.environment.timeutil import parse_epoch
from magsail_mj.loads.actuators_cubesat import MagnetorquerLoad, saturate_per_axis
from magsail_mj.loads.base import StepState
from magsail_mj.quaternion import quat_mul
from magsail_mj.sim import Simulation

import magsail_mj

from magsail_mj.checkpoint import restorable

__all__ = [
    "CubesatCommand",
    "CubesatConverter",
    "CubesatActuators",
    "CubesatPhysics",
    "CubesatTask",
    "make_cubesat_environment",
    "task_mode",
    "ACTIONS",
]

DEG = math.pi / 180.0
ACTIONS = ("dipole", "torque_dipole", "current_dipole")
"""The action kinds (module docstring)."""


# ------------------------------------------------------------------------------------ plant side


@restorable
@dataclass(frozen=True, eq=False)
class CubesatCommand:
    """One action as the plant receives it: ``wheel`` (3,) in the unit of ``wheel_kind``
    (``"idle"``: ignored; ``"body_torque"``: N m; ``"current"``: A, or N m for ideal wheels) and
    ``dipole_body_Am2`` (3,) [A m², body axes]."""

    wheel: np.ndarray
    dipole_body_Am2: np.ndarray
    wheel_kind: str


class CubesatConverter:
    """Action → :class:`CubesatCommand` (a new command object at every controller sample)."""

    def __init__(self, action: str) -> None:
        self.action = action

    def command(self, state: StepState, action: np.ndarray) -> CubesatCommand:
        a = np.array(action, dtype=float)
        if self.action == "dipole":
            return CubesatCommand(np.zeros(3), a[:3], "idle")
        kind = "body_torque" if self.action == "torque_dipole" else "current"
        return CubesatCommand(a[:3].copy(), a[3:6].copy(), kind)


class CubesatActuators:
    """Wheels and magnetorquers driven by a :class:`CubesatCommand` (a load of the simulation).

    Every dynamics step ``k`` (time ``t = k δt``), before the step, with ``ω_M`` the wheel speeds:

    1. a command not seen before (a controller sample): the wheel command ``c`` is formed
       (``body_torque``: the driver's ``i_c = clip((−u + K_B ω_M)/K_M, ±i_max)``; ``current``: the
       action; ``idle``: 0) and held, and the pointing telemetry ``p_e = p_c* ⊗ p_b``, ``θ_e``,
       ``ω_e`` is computed against the task's command frame from the true state;
    2. at a magnetorquer cycle boundary the latest command's dipole, clipped per axis to the limits,
       is latched; the effective dipole is the latched one while the coils are on, 0 while blanked;
       on the pointing tasks the wheels marked for unloading are updated from ``ω_M`` by the
       configured activation logic (``control.unloading``: per axis above ``threshold_rpm``, with its
       hysteresis), a record of the wheel momentum whatever the policy commands;
    3. the motor torques ``T_M = driver.motor_torque(c, ω_M, δt)`` go to ``data.ctrl`` and the torque
       ``R m × B_eci`` (world axes) to the bus in ``xfrc_applied``.
    """

    name = "cubesat_actuators"
    #: steps 1–3 act on the state at the step's start, as the flight controller does in a run (with
    #: ``sim.load_timing = "midpoint"`` the loads see the mid-step state; the magnetorquer torque,
    #: :class:`CubesatMagnetorquerTorque`, does)
    at_step_start = True

    def __init__(self, scenario: Any, *, mode: Mode, driver: Any) -> None:
        cfg = scenario.cfg
        self.idx = scenario.idx
        self.mode = int(mode)
        self.driver = driver
        self.dt_s = float(cfg.sim.timestep_s)
        self.steps_cycle = int(round(cfg.actuators.mtq.cycle_s / self.dt_s))
        self.steps_on = self.steps_cycle - int(round(cfg.actuators.mtq.blank_s / self.dt_s))
        self.limits_Am2 = cfg.actuators.mtq.limit_vector
        self.shortest = bool(cfg.control.shortest_rotation)
        self.mtq = MagnetorquerLoad(self.idx.bus)
        u = cfg.control.unloading
        self.unload = (
            UnloadingLogic(on_rpm=u.threshold_rpm, off_rpm=u.off_rpm)
            if u.enabled and self.mode != Mode.DETUMBLE
            else None
        )
        self.unload_mask = np.zeros(3, dtype=bool)
        # the MjData and the command-frame cache live outside the checkpointed state (a namespace is
        # not walked)
        self.mj = SimpleNamespace(data=None)
        self.frames = SimpleNamespace(t=math.nan, p_c=None, w_o=0.0)
        self.last_command: CubesatCommand | None = None
        self.wheel_cmd = np.zeros(3)
        self.u = np.zeros(3)
        self.dipole_held = np.zeros(3)
        self.dipole_body = np.zeros(3)
        self.T_M = np.zeros(3)
        self.p_e = np.array([1.0, 0.0, 0.0, 0.0])
        self.theta_e = 0.0
        self.omega_e = np.zeros(3)
        self.last_cycle = -1
        self.k_done = -1

    def bind(self, data: mujoco.MjData) -> None:
        self.mj.data = data

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        """Steps 1–3 for the step starting at ``state``; the torque of step 3 is
        :class:`CubesatMagnetorquerTorque`'s."""
        self.sync(state)

    def sync(self, state: StepState) -> None:
        """Steps 1–3 of the class docstring for the step of ``state``, once per step (the probes call
        it too: a record of step k shows the values the step uses, as the flight controller's do)."""
        k = int(round(state.t / self.dt_s))
        if k == self.k_done:
            return
        self.k_done = k
        d, idx = self.mj.data, self.idx
        omega_M = d.qvel[idx.wheel_qvel]
        cmd = state.ctrl
        if cmd is not None and cmd is not self.last_command:
            self.last_command = cmd
            self._take(cmd, omega_M, state, d)
        i_cycle = k // self.steps_cycle
        if cmd is not None and i_cycle > self.last_cycle:
            self.last_cycle = i_cycle
            self.dipole_held = saturate_per_axis(cmd.dipole_body_Am2, self.limits_Am2)
            if self.unload is not None:
                self.unload_mask = self.unload.update(omega_M)
        self.dipole_body = self.dipole_held if k % self.steps_cycle < self.steps_on else np.zeros(3)
        self.T_M = self.driver.motor_torque(self.wheel_cmd, omega_M, self.dt_s)
        d.ctrl[idx.wheel_act] = self.T_M

    def _take(self, cmd: CubesatCommand, omega_M: np.ndarray, state: StepState, d: mujoco.MjData) -> None:
        if cmd.wheel_kind == "body_torque":
            self.u = cmd.wheel.copy()
            self.wheel_cmd = self.driver.command(self.u, omega_M)
        elif cmd.wheel_kind == "current":
            self.wheel_cmd = cmd.wheel.copy()
            self.u = np.zeros(3)
        else:
            self.wheel_cmd = self.driver.idle_command()
            self.u = np.zeros(3)
        p_c, w_o = self.frame(state.t, state.env.r_ref_eci, state.env.v_ref_eci)
        self.p_e = error_quaternion(p_c, d.qpos[self.idx.q_quat].copy(), shortest=self.shortest)
        self.theta_e = float(eigen_angle(self.p_e))
        self.omega_e = rate_error(d.qvel[self.idx.v_ang].copy(), self.p_e, w_o)

    def frame(self, t: float, r: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, float]:
        """The task's command quaternion ``p_c`` (command → ECI) and the orbital rate ``ω_o = |r × v|/|r|²``
        [rad/s] at time ``t`` [s] for the reference orbit ``r``, ``v`` (kept for the latest ``t``: the
        observation and the plant use the same instant)."""
        f = self.frames
        if f.t != t:
            f.t = t
            f.p_c, f.w_o = command_frame(self.mode, r, v)
        return f.p_c, f.w_o

    def probes(self) -> dict[str, Callable[[StepState, mujoco.MjData], Any]]:
        """The scenario's probe names, read from this plant (module docstring)."""
        idx = self.idx

        def mtq_body(state: StepState, d: mujoco.MjData) -> np.ndarray:
            self.sync(state)
            R = np.empty(9)
            mujoco.mju_quat2Mat(R, d.qpos[idx.q_quat])
            return np.cross(self.dipole_body, R.reshape(3, 3).T @ state.env.B_eci)

        def read(name: str) -> Callable[[StepState, mujoco.MjData], Any]:
            def probe(state: StepState, d: mujoco.MjData) -> Any:
                self.sync(state)
                return getattr(self, name)

            return probe

        return {
            "mode": read("mode"),
            "p_e": read("p_e"),
            "theta_e_rad": read("theta_e"),
            "omega_e_rad_s": read("omega_e"),
            "u_cmd_Nm": read("u"),
            "T_M_Nm": read("T_M"),
            "dipole_cmd_Am2": read("dipole_held"),
            "unload_mask": lambda s, d: read("unload_mask")(s, d).astype(np.int8),
            "torque_mtq_body_Nm": mtq_body,
        }


class CubesatPhysics(SimulationPhysics):
    """:class:`~magsail_mj.envs.core.SimulationPhysics` of the cubesat: the scenario's simulation with
    its flight controller replaced by the :class:`~magsail_mj.envs.core.ActionController` and its
    magnetorquer load by :class:`CubesatActuators` (which also drives the wheel motors every step);
    the disturbance load and the ``qpos``/``qvel``/``torque_dist_body_Nm`` probes are kept."""

    def __init__(self, base: Simulation, controller: ActionController, actuators: CubesatActuators) -> None:
        if not isinstance(base, Simulation):
            raise TypeError(f"base: expected a stepped magsail_mj.sim.Simulation, got {type(base).__name__}")
        self.base = base
        self.controller = controller
        self.actuators = actuators
        self.sim = attach(
            base,
            controller,
            [actuators, CubesatMagnetorquerTorque(actuators)],
            keep_probes=("qpos", "qvel", "torque_dist_body_Nm"),
        )
        self.scenario = base.scenario
        self.cfg = base.cfg


# ------------------------------------------------------------------------------------ task


def _random_quaternion(random: np.random.RandomState) -> np.ndarray:
    """A rotation uniform over SO(3): a normalised 4-D Gaussian sample, scalar-first, w ≥ 0."""
    q = random.normal(size=4)
    q /= np.linalg.norm(q)
    return q if q[0] >= 0 else -q


def task_mode(cfg: Any) -> Mode:
    """The task of a CNUSAIL attitude config: B-dot → DETUMBLE, else its pointing command."""
    c = cfg.control
    if c.mode == "bdot":
        return Mode.DETUMBLE
    return Mode.DEORBIT if c.command == "deorbit" else Mode.NADIR


class CubesatTask(AttitudeTask):
    """Detumble or pointing task of the cubesat (module docstring: action, observation, reward).

    Args:
      base: the config's simulation (:func:`magsail_mj.load`).
      random, randomize, reward_weights: see :class:`~magsail_mj.envs.core.AttitudeTask`.
      action: ``"dipole"`` (detumble default), ``"torque_dipole"`` (pointing default) or
        ``"current_dipole"``.
      rate_range_deg_s: detumble start rate range per axis [°/s] (None: the largest component of
        ``initial.omega0_deg_s``).
    """

    def __init__(
        self,
        base: Any,
        random: Any = None,
        *,
        action: str | None = None,
        randomize: bool = True,
        rate_range_deg_s: float | None = None,
        reward_weights: Any = None,
    ) -> None:
        super().__init__(random, randomize=randomize, reward_weights=reward_weights)
        cfg = base.cfg
        self.cfg, self.scenario = cfg, base.scenario
        self.mode = task_mode(cfg)
        action = action or ("dipole" if self.mode == Mode.DETUMBLE else "torque_dipole")
        if action not in ACTIONS:
            raise ValueError(f"action: must be one of {', '.join(ACTIONS)}, got {action!r}")
        if rate_range_deg_s is None:
            omega0 = cfg.initial.omega0_deg_s
            rate_range_deg_s = float(np.max(np.abs(omega0))) if omega0 is not None else 0.0
        if not (math.isfinite(rate_range_deg_s) and rate_range_deg_s >= 0):
            raise ValueError(f"rate_range_deg_s: must be a finite number >= 0, got {rate_range_deg_s!r}")
        self.action, self.rate_range_deg_s = action, float(rate_range_deg_s)
        self.period_s = 1.0 / cfg.control.rate_Hz
        self.rate_scale_rad_s = (
            cfg.analysis.detumble_threshold_deg_s if self.mode == Mode.DETUMBLE else cfg.control.slew_rate_max_deg_s
        ) * DEG
        self.converter = CubesatConverter(action)
        m_max = cfg.actuators.mtq.limit_vector
        m_names = ("m_x_Am2", "m_y_Am2", "m_z_Am2")
        motor = cfg.actuators.wheels.motor_params()
        if action == "dipole":
            self._set_action_bounds(m_names, -m_max, m_max)
            return
        if action == "torque_dipole":
            # beyond K_M i_max + K_B |ω_M| the driver's current command saturates alike (|ω_M| stays
            # near Ω_max under the speed limiter; 2 Ω_max leaves margin), so clipping there changes nothing
            t_max = (
                motor.torque_max_Nm if cfg.actuators.wheels.model == "ideal" else motor.K_M_Nm_A * motor.current_max_A
            )
            w_max = t_max + 2.0 * motor.K_B_Nms * motor.speed_max_rad_s
            names = ("u_x_Nm", "u_y_Nm", "u_z_Nm")
        elif cfg.actuators.wheels.model == "ideal":
            w_max, names = motor.torque_max_Nm, ("T_c_1_Nm", "T_c_2_Nm", "T_c_3_Nm")
        else:
            w_max, names = motor.current_max_A, ("i_c_1_A", "i_c_2_A", "i_c_3_A")
        lo = np.concatenate([np.full(3, -w_max), -m_max])
        self._set_action_bounds(names + m_names, lo, -lo)

    # -------------------------------------------------------------- episode start
    epoch_draw: tuple[float, Any, dict[str, Any]] | None = None
    """``(epoch_range_s, config, task options)`` when the epoch is drawn per episode."""

    def initialize_episode(self, physics: SimulationPhysics) -> None:
        """With an epoch draw the simulation is first rebuilt at the drawn epoch (:meth:`redraw_epoch`);
        then the start of :class:`~magsail_mj.envs.core.AttitudeTask`."""
        epoch = self.redraw_epoch(physics) if self.epoch_draw is not None else None
        super().initialize_episode(physics)
        if epoch is not None:
            self.start["epoch"] = epoch

    def redraw_epoch(self, physics: SimulationPhysics) -> str:
        """Rebuild ``physics`` (in place: the Environment keeps the object) for the epoch
        ``orbit.epoch + U(0, epoch_range_s)`` drawn with the task's random state; returns it (ISO 8601)."""
        width, cfg0, options = self.epoch_draw
        epoch = parse_epoch(cfg0.orbit.epoch) + timedelta(seconds=float(self.random.uniform(0.0, width)))
        iso = epoch.isoformat()
        base = magsail_mj.load(cfg0, [f"orbit.epoch={json.dumps(iso)}"])
        fresh = CubesatTask(base, random=self.random, **options)
        self.__dict__.update({k: v for k, v in fresh.__dict__.items() if k not in ("_random", "epoch_draw")})
        self._truth_cache = None
        physics.__init__(base, *_parts(base, self))
        self.bind(physics)
        return iso

    def draw_start(self, physics: SimulationPhysics) -> dict[str, Any]:
        """Attitude uniform over SO(3) relative to the task's command frame at t = 0; detumble: rates
        uniform per axis in ±rate_range_deg_s; pointing: ω_e(0) = 0. Wheel speeds as configured."""
        sc = self.scenario
        _, _, wM = sc.initial_state()
        env0 = sc.environment.sample(0.0)
        r, v = env0.r_ref_eci, env0.v_ref_eci
        p_e = _random_quaternion(self.random)
        p_b = quat_mul(command_quaternion(self.mode, r, v), p_e)
        p_b = p_b / np.linalg.norm(p_b)
        if self.mode == Mode.DETUMBLE:
            w = self.random.uniform(-self.rate_range_deg_s, self.rate_range_deg_s, 3) * DEG
        else:
            w = -rate_error(np.zeros(3), p_e, orbital_rate(r, v))
        d, idx = physics.data, sc.idx
        d.qpos[idx.q_quat] = p_b
        d.qvel[idx.v_ang] = w
        d.qvel[idx.wheel_qvel] = wM
        return {"q0_wxyz": p_b, "omega0_body_rad_s": w}

    # -------------------------------------------------------------- observation, reward
    def _truth(self, physics: SimulationPhysics, state: StepState) -> dict[str, Any]:
        """The true attitude quantities of ``state`` (once per state: the reward and the observation
        of a time step share them)."""
        d, idx = physics.data, self.scenario.idx
        key = (physics.sim.step_index, float(d.qpos.sum()), float(d.qvel.sum()))
        if self._truth_cache is not None and self._truth_cache[0] == key:
            return self._truth_cache[1]
        q = d.qpos[idx.q_quat].copy()
        R = np.empty(9)
        mujoco.mju_quat2Mat(R, q)
        r, v = np.array(state.env.r_ref_eci, dtype=float), np.array(state.env.v_ref_eci, dtype=float)
        p_c, w_o = physics.actuators.frame(state.t, state.env.r_ref_eci, state.env.v_ref_eci)
        p_e = error_quaternion(p_c, q, shortest=self.cfg.control.shortest_rotation)
        omega = d.qvel[idx.v_ang].copy()
        truth = {
            "q": q,
            "omega": omega,
            "B": R.reshape(3, 3).T @ state.env.B_eci,
            "r": r,
            "v": v,
            "p_e": p_e,
            "w_o": w_o,
            "omega_e": rate_error(omega, p_e, w_o),
        }
        self._truth_cache = (key, truth)
        return truth

    _truth_cache: tuple[tuple[int, float, float], dict[str, Any]] | None = None

    def observe(self, physics: SimulationPhysics, state: StepState) -> dict[str, np.ndarray]:
        x = self._truth(physics, state)
        omega, B, omega_e = x["omega"], x["B"], x["omega_e"]
        s = self.cfg.control.sensors
        if s.gyro_noise_rad_s > 0:
            omega = omega + self.random.normal(0.0, s.gyro_noise_rad_s, 3)
            omega_e = rate_error(omega, x["p_e"], x["w_o"])
        if s.magnetometer_noise_T > 0:
            B = B + self.random.normal(0.0, s.magnetometer_noise_T, 3)
        return {
            "time_s": np.array([state.t]),
            "attitude_wxyz": x["q"].copy(),
            "body_rate_rad_s": omega.copy(),
            "field_body_T": B.copy(),
            "wheel_speed_rad_s": physics.data.qvel[self.scenario.idx.wheel_qvel].copy(),
            "orbit_position_eci_m": x["r"].copy(),
            "orbit_velocity_eci_m_s": x["v"].copy(),
            "pointing_error_wxyz": x["p_e"].copy(),
            "rate_error_rad_s": omega_e.copy(),
        }

    def reward_terms(self, physics: SimulationPhysics) -> dict[str, float]:
        """θ_e and ‖ω‖ (detumble) or ‖ω_e‖ (pointing) of the true state after the step."""
        x = self._truth(physics, physics.step_state())
        if self.mode == Mode.DETUMBLE:
            return {"theta_rad": 0.0, "omega_rad_s": float(np.linalg.norm(x["omega"]))}
        return {"theta_rad": float(eigen_angle(x["p_e"])), "omega_rad_s": float(np.linalg.norm(x["omega_e"]))}

    # -------------------------------------------------------------- shipped controller
    def fresh_shipped_controller(self, physics: SimulationPhysics) -> CnusailController:
        """A copy of the scenario's flight controller as built; it becomes ``scenario.controller``, so
        the scenario's post-processing reads its events (manoeuvre starts, gain recalculations)."""
        ctl = copy.deepcopy(physics.base.controller)
        self.scenario.controller = ctl
        return ctl

    def shipped_action(self, physics: SimulationPhysics, controller: CnusailController, state: StepState) -> np.ndarray:
        """The flight controller's samples due at ``state`` (attitude law, B-dot/unloading), from the
        state it reads in ``magsail run`` (true attitude, rate and wheel speeds with its own sensor
        noise), as this task's action: the held dipole, with the body-torque request ``u`` for
        ``torque_dipole``."""
        ctl, d, p = controller, physics.data, controller.p
        if self.action == "current_dipole":
            raise ValueError(
                "action: the shipped law commands body torques; use action='torque_dipole' "
                "(pointing) or 'dipole' (detumble) to run it"
            )
        k = int(round(state.t / p.timestep_s))
        omega_M = d.qvel[ctl.wheel_qvel]
        i_att, i_mtq = k // ctl.n_att, k // p.mtq_cycle.steps_per_cycle
        att, mtq = i_att > ctl._last_att, i_mtq > ctl._last_mtq
        ctl._last_att, ctl._last_mtq = max(ctl._last_att, i_att), max(ctl._last_mtq, i_mtq)
        q = d.qpos[ctl.q_quat].copy()
        if att:
            omega = d.qvel[ctl.v_ang].copy()
            if p.gyro_noise_rad_s > 0:
                omega = omega + ctl.rng.normal(0.0, p.gyro_noise_rad_s, 3)
            ctl._attitude_sample(state.t, q, omega, omega_M, state.env)
        if mtq:
            mujoco.mju_quat2Mat(ctl._R, q)
            ctl._mtq_sample(state.t, ctl._R.reshape(3, 3), omega_M, state.env, d.qvel[ctl.v_ang].copy())
        if self.action == "dipole":
            return ctl.dipole_held.copy()
        return np.concatenate([ctl.u, ctl.dipole_held])


# ------------------------------------------------------------------------------------ building


class CubesatMagnetorquerTorque:
    """The torque ``R m × B_eci`` [N m, world axes] of the effective dipole that
    :class:`CubesatActuators` set for the step, at the state the loads see (the step's start, or
    its mid-point with ``sim.load_timing = "midpoint"``, as the magnetorquer load of a run)."""

    name = "cubesat_magnetorquer_torque"

    def __init__(self, actuators: CubesatActuators) -> None:
        # a namespace is not walked by the checkpoint: the actuators are the simulation's own load
        self.of = SimpleNamespace(actuators=actuators)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        act = self.of.actuators
        act.mtq.add(SimpleNamespace(ctrl=act, xquat=state.xquat, env=state.env), xfrc)


def _parts(base: Simulation, task: CubesatTask) -> tuple[ActionController, CubesatActuators]:
    controller = ActionController(
        period_s=task.period_s,
        convert=task.converter.command,
        action=task.neutral_action(),
        end_time_s=base.n_steps * float(base.model.opt.timestep),
    )
    return controller, CubesatActuators(base.scenario, mode=task.mode, driver=base.controller.driver)


def make_cubesat_environment(
    cfg: Any, *, random: Any = None, epoch_range_s: float = 0.0, **options: Any
) -> control.Environment:
    """The environment of a CNUSAIL attitude config (``options`` go to :class:`CubesatTask`):
    ``control_timestep`` = ``1/control.rate_Hz``, ``time_limit`` = ``sim.duration_s``.
    ``epoch_range_s`` > 0: each episode starts at the epoch ``orbit.epoch + U(0, epoch_range_s)``
    (drawn first, from the task's ``random``; the simulation is rebuilt for it, its orbit, field and
    Sun tables being built for the epoch). A config with ``sim.loads = "compiled"`` is refused
    (:class:`~magsail_mj.config.ConfigError` naming the key): the environment's plant runs in Python."""
    if getattr(cfg, "concept", None) != "cnusail" or getattr(cfg, "kind", None) != "attitude":
        raise ValueError(
            f"config: expected a CNUSAIL attitude config, got concept {getattr(cfg, 'concept', None)!r}, "
            f"kind {getattr(cfg, 'kind', None)!r}"
        )
    if getattr(cfg.sim, "loads", "python") == "compiled":
        raise ConfigError(
            [
                "sim.loads: the environment drives the cubesat's actuators from Python each step and "
                "keeps the loads there; use sim.loads = 'python', got 'compiled'"
            ]
        )
    epoch_range_s = float(epoch_range_s)
    if not (math.isfinite(epoch_range_s) and epoch_range_s >= 0):
        raise ValueError(f"epoch_range_s: must be a finite number >= 0 s, got {epoch_range_s!r}")
    base = magsail_mj.load(cfg)
    task = CubesatTask(base, random=random, **options)
    task.epoch_draw = (epoch_range_s, cfg, dict(options)) if epoch_range_s > 0 else None
    physics = CubesatPhysics(base, *_parts(base, task))
    task.bind(physics)
    return control.Environment(physics, task, time_limit=float(base.duration_s), control_timestep=task.period_s)


def _is_cnusail(mode: Mode):
    def matches(cfg: Any) -> bool:
        return (
            getattr(cfg, "concept", None) == "cnusail"
            and getattr(cfg, "kind", None) == "attitude"
            and task_mode(cfg) == mode
        )

    return matches


@register(
    "cnusail/detumble",
    config="magsail_mj/concepts/cnusail/configs/detumble_post.toml",
    matches=_is_cnusail(Mode.DETUMBLE),
)  # noqa: E501
def detumble(cfg: Any, *, random: Any = None, **options: Any) -> control.Environment:
    """CNUSAIL-1 B-dot detumble (S1/S2): dipole action, wheels idle."""
    return make_cubesat_environment(cfg, random=random, **options)


@register(
    "cnusail/nadir", config="magsail_mj/concepts/cnusail/configs/nadir_post.toml", matches=_is_cnusail(Mode.NADIR)
)  # noqa: E501
def nadir(cfg: Any, *, random: Any = None, **options: Any) -> control.Environment:
    """CNUSAIL-1 nadir slew (S3–S5): body-torque request through the wheels + unloading dipole."""
    return make_cubesat_environment(cfg, random=random, **options)


@register(
    "cnusail/deorbit", config="magsail_mj/concepts/cnusail/configs/deorbit.toml", matches=_is_cnusail(Mode.DEORBIT)
)  # noqa: E501
def deorbit(cfg: Any, *, random: Any = None, **options: Any) -> control.Environment:
    """CNUSAIL-1 deorbit slew (S6/S7): body-torque request through the wheels + unloading dipole."""
    return make_cubesat_environment(cfg, random=random, **options)
