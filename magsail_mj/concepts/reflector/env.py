r"""Environments of the gossamer reflector: ``reflector/detumble`` (Scenario A) and
``reflector/pitch_tracking`` (Scenario B, ``kind = "pitch"``).

Spacecraft: a rigid square plate whose truss carries an x-coil path, a y-coil path and an
in-plane loop, each an ideal dipole limited to ``m_max = T_max / B_ref`` (body ``z`` = normal).
Torques reach the plate through the held body torque ``T_b``.

Actions:

* detumble, ``action="currents"`` (default) — the x-coil and y-coil currents [A], bounds
  ``±I_max`` (``coil.I_max_A``): dipole ``m = (m_max I_x / I_max, m_max I_y / I_max, 0)``,
  torque ``T = m × B_b`` (what the shipped ``dipole`` B-dot law commands).
* detumble, ``action="torque"`` — a body-torque request [N m] through the coils: its part ⟂ B_b,
  norm-capped at the coil torque cap ``T_max`` (what the ``printed``/``norm_cap`` laws deliver);
  bounds ``±T_max`` per axis, not clipped (the cap saturates).
* pitch tracking, ``action="torque"`` (the only one) — ``T_ref`` [N m], body axes, through the
  shipped projection ⟂ B and saturation (``control.saturation_mode``); bounds ``±T_max``, not
  clipped.

Observations (the controllers read the plate's pose and rate exactly; no sensor model):
``attitude_wxyz`` (4,), ``body_rate_rad_s`` (3,), ``field_body_T`` (3,); pitch tracking adds
``target_wxyz`` (4,) the steering reference ``q_ref(t)`` and ``target_rate_rad_s`` (3,)
``ω_ref = −ψ̇_ref ŷ``. The plate is rigid: no structural-health observations.

Reward (``magsail_mj.envs.core``): detumble θ = 0, ω = |ω_b|, ω_s = ``control.omega_k_rad_s``
(default 0.01 rad/s); pitch tracking θ = angle to ``q_ref(t)``, ω = |ω_b − ω_ref|,
ω_s = 1e-3 rad/s; effort of the normalised action.

Episode start (``randomize=True``): detumble: rates uniform in ``±rate_range_rad_s`` per axis
(default 0.07 rad/s, the config's |ω0| = 0.1 rad/s), attitude the config's turned by up to
``attitude_range_deg`` (default 180°); pitch tracking: the reference start ``(q_ref(0), ω_ref(0))``
turned by up to ``attitude_range_deg`` (default 5°) with rates ``ω_ref(0)`` plus uniform
``±rate_range_rad_s`` (default 1e-4 rad/s). The orbit phase is the config's (the reflector's
kinematic orbit has no calendar epoch; ``epoch_range_s`` is refused).

``control_timestep`` = ``sim.timestep_s`` (the controllers run every step); ``time_limit`` =
``sim.duration_s``.
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np

from magsail_mj.concepts.reflector.bdot import BdotCommand, PlateBdotController
from magsail_mj.config import ConfigError
from magsail_mj.control.reflector_pitch import PitchCommand, ReflectorPitchController, saturate_norm
from magsail_mj.control.reflector_steering import SteeringReference
from magsail_mj.envs.core import (
    AttitudeTask,
    SimulationPhysics,
    draw_rigid_start,
    make_environment,
    pointing_error_rad,
    register,
)
from magsail_mj.loads.base import StepState
from magsail_mj.quaternion import error_quaternion, quat_to_matrix
from magsail_mj.vec3 import cross3

__all__ = ["ReflectorDetumbleTask", "ReflectorPitchTask", "ActionBdotConverter", "ActionPitchConverter"]


def _plate_pose(state: StepState, body: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(q, R, ω_b)`` of the plate body as the shipped controllers read them."""
    q = state.xquat[body]
    R = quat_to_matrix(q)
    return q, R, R.T @ state.omega[body]


class ActionBdotConverter:
    """Detumble command of an action: coil currents, or a torque request (module docstring)."""

    def __init__(self, *, shipped: PlateBdotController, mode: str) -> None:
        self.law = copy.deepcopy(shipped)
        self.mode = mode

    def command(self, state: StepState, action: np.ndarray) -> BdotCommand:
        law = self.law
        B_b = law.field_body(state.t, quat_to_matrix(state.xquat[law.body_id]))
        if self.mode == "currents":
            currents = np.array(action, dtype=float)
            m = np.array([law.m_max * currents[0] / law.I_max, law.m_max * currents[1] / law.I_max, 0.0])
            return BdotCommand(
                torque_body=cross3(m, B_b),
                dipole_body=m,
                dipole_cmd_body=m.copy(),
                currents_A=currents,
                saturated=np.abs(currents) >= law.I_max,
                B_body=B_b,
            )
        T, clipped = _perp_capped(np.asarray(action, dtype=float), B_b, law.T_max)
        b2 = float(B_b @ B_b)
        m = cross3(B_b, T) / b2 if b2 > 0 else np.zeros(3)
        return BdotCommand(torque_body=T, dipole_cmd_body=m, saturated=np.array([clipped, clipped]), B_body=B_b)


def _perp_capped(T: np.ndarray, B: np.ndarray, cap: float) -> tuple[np.ndarray, bool]:
    """``sat_cap(T − b (b·T))`` with ``b = B/|B|`` (zero torque in a zero field)."""
    b2 = float(B @ B)
    if not b2 > 0:
        return np.zeros(3), bool(np.any(T != 0))
    b = B / math.sqrt(b2)
    return saturate_norm(T - b * float(b @ T), cap)


class ActionPitchConverter:
    """Pitch-tracking command of a ``T_ref`` action: the shipped projection and saturation, with
    the steering reference's diagnostics (a private copy of the shipped steering state)."""

    def __init__(self, *, shipped: ReflectorPitchController) -> None:
        self.law = copy.deepcopy(shipped)

    def command(self, state: StepState, action: np.ndarray) -> PitchCommand:
        law = self.law
        q, R, _ = _plate_pose(state, law.body_id)
        ref = law.steering.at(state.t)
        q_e = error_quaternion(ref.q_ref, q)
        T_ref = np.array(action, dtype=float)
        return law.saturated_command(T_ref, R=R, t=state.t, q_e=q_e, ref=ref)


def _plate_observation(physics: SimulationPhysics, idx: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(q, R, ω_b)`` of the plate read from ``qpos``/``qvel`` (the free joint's angular velocity
    is in body axes): what the controllers read, without the runner's kinematics pass."""
    data = physics.data
    q = data.qpos[idx.q_quat]
    q = q / math.sqrt(float(q @ q))
    return q, quat_to_matrix(q), data.qvel[idx.v_ang].copy()


def _check_ranges(**ranges: float) -> None:
    for name, value in ranges.items():
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{name}: must be a finite number >= 0, got {value!r}")


class ReflectorDetumbleTask(AttitudeTask):
    """Scenario A detumble of the plate (module docstring: action, observation, reward, start).

    Args:
      base: the config's simulation; random, randomize, reward_weights: see
        :class:`~magsail_mj.envs.core.AttitudeTask`; action: ``"currents"`` or ``"torque"``;
      rate_range_rad_s, attitude_range_deg: episode-start ranges.
    """

    def __init__(
        self,
        base: Any,
        random: Any = None,
        *,
        action: str = "currents",
        randomize: bool = True,
        rate_range_rad_s: float = 0.07,
        attitude_range_deg: float = 180.0,
        reward_weights: Any = None,
    ) -> None:
        super().__init__(random, randomize=randomize, reward_weights=reward_weights)
        if action not in ("currents", "torque"):
            raise ValueError(f"action: must be 'currents' or 'torque', got {action!r}")
        _check_ranges(rate_range_rad_s=rate_range_rad_s, attitude_range_deg=attitude_range_deg)
        self.cfg, self.scenario = base.cfg, base.scenario
        shipped: PlateBdotController = base.controller
        self.period_s = float(shipped.period_s)
        self.mode = action
        self.converter = ActionBdotConverter(shipped=shipped, mode=action)
        self.body = shipped.body_id
        self.rate_scale_rad_s = float(self.cfg.control.omega_k_rad_s)
        self.rate_range, self.attitude_range = float(rate_range_rad_s), math.radians(attitude_range_deg)
        if action == "currents":
            i_max = float(shipped.I_max)
            self._set_action_bounds(("I_xcoil_A", "I_ycoil_A"), np.full(2, -i_max), np.full(2, i_max))
        else:
            self.clip_actions = False
            self._set_action_bounds(
                ("T_x_Nm", "T_y_Nm", "T_z_Nm"), np.full(3, -shipped.T_max), np.full(3, shipped.T_max)
            )

    def draw_start(self, physics: SimulationPhysics) -> dict[str, Any]:
        q, omega = draw_rigid_start(
            self.random,
            q0_wxyz=np.asarray(self.cfg.initial.q0_wxyz, dtype=float),
            rate_range_rad_s=self.rate_range,
            attitude_range_rad=self.attitude_range,
        )
        self.scenario.plate.write_state(physics.data, q, omega)
        return {"omega0_body_rad_s": omega, "q0_wxyz": q}

    needs_step_state = False

    def observe(self, physics: SimulationPhysics, state: None) -> dict[str, np.ndarray]:
        q, R, w = _plate_observation(physics, self.scenario.plate.idx)
        return {
            "attitude_wxyz": q,
            "body_rate_rad_s": w,
            "field_body_T": self.converter.law.field_body(physics.sim.time, R),
        }

    def reward_terms(self, physics: SimulationPhysics) -> dict[str, float]:
        obs = self.current_observation(physics)
        w = obs["body_rate_rad_s"]
        return {"omega_rad_s": math.sqrt(float(w @ w))}

    def shipped_action(self, physics: SimulationPhysics, controller: Any, state: StepState) -> np.ndarray:
        """Currents mode: the shipped coil currents (``dipole`` law); torque mode: the shipped law's
        request before the cap (``printed``: ``k ω × B_b``; ``norm_cap``: ``k (ω × B_b) × B_b``;
        ``dipole``: the torque of its clipped dipole)."""
        cmd = controller.update(state)
        if self.mode == "currents":
            if controller.law != "dipole":
                raise ValueError(f"action: the {controller.law!r} law commands a torque; use action='torque'")
            return np.asarray(cmd.currents_A, dtype=float)
        if controller.law == "printed":
            return np.asarray(cmd.dipole_cmd_body, dtype=float)
        if controller.law == "norm_cap":
            return cross3(cmd.dipole_cmd_body, cmd.B_body)
        return np.asarray(cmd.torque_body, dtype=float)


class ReflectorPitchTask(AttitudeTask):
    """Scenario B pitch tracking (module docstring: action, observation, reward, start).

    Args:
      base: the config's simulation; random, randomize, reward_weights: see
        :class:`~magsail_mj.envs.core.AttitudeTask`; action: ``"torque"``;
      rate_range_rad_s, attitude_range_deg: episode-start ranges about the reference start.
    """

    rate_scale_rad_s = 1e-3

    def __init__(
        self,
        base: Any,
        random: Any = None,
        *,
        action: str = "torque",
        randomize: bool = True,
        rate_range_rad_s: float = 1e-4,
        attitude_range_deg: float = 5.0,
        reward_weights: Any = None,
    ) -> None:
        super().__init__(random, randomize=randomize, reward_weights=reward_weights)
        if action != "torque":
            raise ValueError(f"action: pitch tracking takes 'torque', got {action!r}")
        _check_ranges(rate_range_rad_s=rate_range_rad_s, attitude_range_deg=attitude_range_deg)
        self.cfg, self.scenario = base.cfg, base.scenario
        shipped: ReflectorPitchController = base.controller
        self.period_s = float(shipped.period_s)
        self.converter = ActionPitchConverter(shipped=shipped)
        self.body = shipped.body_id
        self.rate_range, self.attitude_range = float(rate_range_rad_s), math.radians(attitude_range_deg)
        self.clip_actions = False
        self._set_action_bounds(("T_x_Nm", "T_y_Nm", "T_z_Nm"), np.full(3, -shipped.cap), np.full(3, shipped.cap))
        self.steering = SteeringReference(shipped.orbit)

    def initialize_episode(self, physics: SimulationPhysics) -> None:
        self.steering = SteeringReference(self.converter.law.orbit)
        super().initialize_episode(physics)

    def draw_start(self, physics: SimulationPhysics) -> dict[str, Any]:
        q_ref0, w_ref0 = self.scenario.plate.pitch_initial_state()
        q, dw = draw_rigid_start(
            self.random, q0_wxyz=q_ref0, rate_range_rad_s=self.rate_range, attitude_range_rad=self.attitude_range
        )
        omega = np.asarray(w_ref0, dtype=float) + dw
        self.scenario.plate.write_state(physics.data, q, omega)
        return {"omega0_body_rad_s": omega, "q0_wxyz": q}

    needs_step_state = False

    def observe(self, physics: SimulationPhysics, state: None) -> dict[str, np.ndarray]:
        q, R, w = _plate_observation(physics, self.scenario.plate.idx)
        t = physics.time()
        ref = self.steering.at(t)
        obs = {
            "attitude_wxyz": q,
            "body_rate_rad_s": w,
            "field_body_T": R.T @ self.converter.law.orbit.field(t),
            "target_wxyz": np.array(ref.q_ref, dtype=float),
            "target_rate_rad_s": np.array([0.0, -ref.psi_dot, 0.0]),
        }
        return obs

    def reward_terms(self, physics: SimulationPhysics) -> dict[str, float]:
        obs = self.current_observation(physics)
        dw = obs["body_rate_rad_s"] - obs["target_rate_rad_s"]
        return {
            "theta_rad": pointing_error_rad(obs["attitude_wxyz"], obs["target_wxyz"]),
            "omega_rad_s": math.sqrt(float(dw @ dw)),
        }

    def shipped_action(self, physics: SimulationPhysics, controller: Any, state: StepState) -> np.ndarray:
        """The shipped ``T_ref``."""
        return np.asarray(controller.update(state).T_ref_body, dtype=float)


def _reflector_kind(kind: str):
    def matches(cfg: Any) -> bool:
        return getattr(cfg, "concept", None) == "reflector" and getattr(cfg, "kind", None) == kind

    return matches


@register(
    "reflector/detumble",
    config="magsail_mj/concepts/reflector/configs/detumble.toml",
    matches=_reflector_kind("detumble"),
)  # noqa: E501
def reflector_detumble(cfg: Any, *, random: Any = None, **options: Any):
    """Scenario A detumble (:class:`ReflectorDetumbleTask`)."""
    return make_environment(cfg, ReflectorDetumbleTask, random=random, **options)


@register(
    "reflector/pitch_tracking",
    config="magsail_mj/concepts/reflector/configs/tracking_100g.toml",
    matches=_reflector_kind("pitch"),
)  # noqa: E501
def reflector_pitch_tracking(cfg: Any, *, random: Any = None, **options: Any):
    """Scenario B pitch tracking (:class:`ReflectorPitchTask`). A config with ``sim.loads =
    "compiled"`` is refused (:class:`~magsail_mj.config.ConfigError` naming the key): the
    environment's actions are the controller, which runs in Python each step."""
    if getattr(cfg.sim, "loads", "python") == "compiled":
        raise ConfigError(
            [
                "sim.loads: the environment's actions drive the reflector's coils from Python each step "
                "and keep the loads there; use sim.loads = 'python', got 'compiled'"
            ]
        )
    return make_environment(cfg, ReflectorPitchTask, random=random, **options)
