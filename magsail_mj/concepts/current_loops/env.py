r"""Environment of the current-loop truss: ``current_loops/slew`` (flexible ``slew`` and the rigid
``slew_rigid`` surrogate, whichever the config asks).

Spacecraft: the 250 m plate with current circuits built into its struts (config order
``loops.circuits``, e.g. ``[C_x, C_y, B]``, one per body axis). The shipped controller
(:class:`magsail_mj.concepts.current_loops.attitude.LoopAttitudeController`) computes
``T_ref = −k_p q_ev − k_ω ω``, the dipole command ``m_d = B_b × T_ref / |B_b|²`` and per-axis
currents ``I_L = (m_d,L / m_max) I_max,L`` with the config's allocation (``paper_clip`` or
``direction_preserving``).

Actions (``action`` task option):

* ``"currents"`` (default) — the circuit currents [A], config order, bounds ``±I_max,L`` (the
  circuits' full, Eq.-9, currents); the recorded diagnostics are those of these currents:
  dipole ``m_L = m_max I_L / I_max,L``, torque ``m × B_b``, saturation ``|I_L| ≥ I_max,L``.
* ``"torque"`` — ``T_ref`` [N m], body axes, through the shipped dipole command and current
  allocation (not clipped: the allocation saturates it); bounds ``±m_max · 1e-4 T`` per axis.

Observations (the shipped estimator: best-fit rotation of the nodes and the least-squares
rigid-velocity fit ``ω = J_c⁻¹ H_c``; the rigid surrogate: its body's pose and rate):

* ``attitude_wxyz`` (4,), ``body_rate_rad_s`` (3,), ``field_body_T`` (3,), ``target_wxyz`` (4,);
* flexible only: ``surface_sd_m`` (1,) and ``strain_max`` (1,), refreshed every ``health_every``
  environment steps (default 10).

Reward (``magsail_mj.envs.core``): θ = angle to ``control.q_target``, ω_s = 1e-3 rad/s, effort,
strain (flexible).

Episode start (``randomize=True``): identity attitude (the scenario's) turned by up to
``attitude_range_deg`` (default 10°) about a uniform axis; rates uniform in ``±rate_range_rad_s``
(default 1e-4 rad/s); rigid, unstressed. The epoch is the config's, or, with the task option
``epoch_range_s`` > 0, ``orbit.epoch`` + U(0, epoch_range_s) drawn first (rebuilt each episode).

``control_timestep`` = ``control.period_s`` (default δt); ``time_limit`` = ``sim.duration_s``.
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np

from magsail_mj.analysis.flatness import surface_sd
from magsail_mj.concepts.current_loops.attitude import (
    LoopAttitudeController,
    LoopCommand,
    allocate_currents,
    rigid_velocity_fit,
)
from magsail_mj.envs.core import (
    AttitudeTask,
    SimulationPhysics,
    draw_rigid_start,
    make_environment,
    pointing_error_rad,
    register,
    set_rigid_motion,
)
from magsail_mj.estimation.attitude import BestFitRotation, matrix_from_quat
from magsail_mj.loads.base import StepState
from magsail_mj.quaternion import quat_conj, quat_from_matrix, quat_mul
from magsail_mj.vec3 import cross3

__all__ = ["LoopsSlewTask", "ActionLoopController"]

B_BOUND_T = 1e-4
"""Field magnitude bounding the torque action [T]."""


class ActionLoopController:
    """The shipped loop controller's estimation with the currents (or ``T_ref``) given.

    ``law``: a private copy of the shipped :class:`LoopAttitudeController` (its sign-continuity
    memory is this controller's own); ``inverse``: axis → config circuit order; ``rigid``: read
    the rigid surrogate's body 1.
    """

    def __init__(self, *, law: LoopAttitudeController, inverse: np.ndarray, rigid: bool, mode: str) -> None:
        self.law = copy.deepcopy(law)
        self.inverse = np.asarray(inverse, dtype=int)
        self.axis_circuit = np.argsort(self.inverse)
        self.rigid = bool(rigid)
        self.mode = mode

    def attitude(self, state: StepState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(R, q, ω_body)`` as the shipped controller estimates them (sign-continuous ``q``)."""
        law = self.law
        if not self.rigid:
            return law.attitude(state.pos[law.node_bodies], state.vel[law.node_bodies], t=state.t)
        q = np.asarray(state.xquat[1], dtype=float)
        if q @ law._q_prev < 0:
            q = -q
        law._q_prev = q
        R = matrix_from_quat(q)
        return R, q, law.body_rate(R, t=state.t, measured_body=R.T @ state.omega[1])

    def command(self, state: StepState, action: np.ndarray) -> LoopCommand:
        """The :class:`LoopCommand` of ``action`` (currents in config order, or ``T_ref``)."""
        law = self.law
        R, q, w = self.attitude(state)
        B_b = R.T @ law.field(state)
        q_err = quat_mul(quat_conj(law.q_target), q)
        if q_err[0] < 0:
            q_err = -q_err
        if self.mode == "torque":
            T_ref = np.array(action, dtype=float)
            b2 = B_b @ B_b
            m_cmd = np.cross(B_b, T_ref) / b2 if b2 > 0 else np.zeros(3)
            currents, sat = allocate_currents(m_cmd, m_max=law.m_max, I_max=law.I_max, mode=law.allocation)
        else:
            currents = np.asarray(action, dtype=float)[self.axis_circuit]
            sat = np.abs(currents) >= law.I_max
            m_cmd = law.m_max * currents / law.I_max
            T_ref = cross3(m_cmd, B_b)
        cmd = LoopCommand(
            currents_A=currents,
            saturated=sat,
            q=q,
            q_err=q_err,
            omega_body=w,
            torque_ref_body=T_ref,
            dipole_cmd_body=m_cmd,
            B_body=B_b,
            R=R,
        )
        cmd.currents_axis_A = cmd.currents_A
        cmd.currents_A = cmd.currents_A[self.inverse]
        return cmd


class LoopsSlewTask(AttitudeTask):
    """Slew of the current-loop plate (module docstring: action, observation, reward, start).

    Args:
      base: the config's simulation (:func:`magsail_mj.load`).
      random, randomize, reward_weights: see :class:`~magsail_mj.envs.core.AttitudeTask`.
      action: ``"currents"`` (default) or ``"torque"``.
      rate_range_rad_s, attitude_range_deg: episode-start ranges.
      health_every: environment steps between refreshes of the structural-health observations.
    """

    rate_scale_rad_s = 1e-3

    def __init__(
        self,
        base: Any,
        random: Any = None,
        *,
        action: str = "currents",
        randomize: bool = True,
        rate_range_rad_s: float = 1e-4,
        attitude_range_deg: float = 10.0,
        health_every: int = 10,
        reward_weights: Any = None,
    ) -> None:
        super().__init__(random, randomize=randomize, reward_weights=reward_weights)
        if action not in ("currents", "torque"):
            raise ValueError(f"action: must be 'currents' or 'torque', got {action!r}")
        if int(health_every) != health_every or health_every < 1:
            raise ValueError(f"health_every: must be an integer >= 1, got {health_every!r}")
        for name, value in (("rate_range_rad_s", rate_range_rad_s), ("attitude_range_deg", attitude_range_deg)):
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name}: must be a finite number >= 0, got {value!r}")
        self.cfg, self.scenario = base.cfg, base.scenario
        self.rigid = self.cfg.scenario == "slew_rigid"
        shipped = base.controller
        law = shipped.ctrl.ctrl if self.rigid else shipped.ctrl
        self.period_s = float(shipped.period_s)
        self.mode = action
        self.converter = ActionLoopController(law=law, inverse=shipped.inverse, rigid=self.rigid, mode=action)
        self.q_ref = np.array(law.q_target, dtype=float)
        self.rate_range = float(rate_range_rad_s)
        self.attitude_range = math.radians(attitude_range_deg)
        self.health_every = int(health_every)
        lat = self.scenario.lm.lattice
        self.masses = np.asarray(self.scenario.lm.masses, dtype=float)
        self.nodes = np.asarray(law.node_bodies, dtype=int)
        self.fit = BestFitRotation(lat.nodes)
        self.top = np.asarray(lat.top_nodes) + 1
        if action == "currents":
            i_max = np.asarray(law.I_max, dtype=float)[self.converter.inverse]
            names = tuple(f"I_{name}_A" for name in self.cfg.loops.expanded())
            self._set_action_bounds(names, -i_max, i_max)
        else:
            self.clip_actions = False
            t_max = law.m_max * B_BOUND_T
            self._set_action_bounds(("T_x_Nm", "T_y_Nm", "T_z_Nm"), np.full(3, -t_max), np.full(3, t_max))
        self._memory: dict[str, Any] = {}

    # ------------------------------------------------------------------ episode start
    def initialize_episode(self, physics: SimulationPhysics) -> None:
        super().initialize_episode(physics)
        self._memory = {"q_prev": np.array([1.0, 0.0, 0.0, 0.0]), "health": None, "n": 0}

    def draw_start(self, physics: SimulationPhysics) -> dict[str, Any]:
        """Attitude and rates drawn (module docstring); rigid, unstressed start."""
        q, omega = draw_rigid_start(
            self.random,
            q0_wxyz=np.array([1.0, 0.0, 0.0, 0.0]),
            rate_range_rad_s=self.rate_range,
            attitude_range_rad=self.attitude_range,
        )
        set_rigid_motion(physics, q_wxyz=q, omega_body_rad_s=omega, masses=None if self.rigid else self.masses)
        return {"omega0_body_rad_s": omega, "q0_wxyz": q}

    # ------------------------------------------------------------------ observations
    def _attitude(self, state: StepState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        mem = self._memory
        if self.rigid:
            q = np.asarray(state.xquat[1], dtype=float).copy()
            R = matrix_from_quat(q)
            w = R.T @ state.omega[1]
        else:
            x, v = state.pos[self.nodes], state.vel[self.nodes]
            R, _ = self.fit(x)
            q = quat_from_matrix(R)
            w = R.T @ rigid_velocity_fit(x, v, self.masses)
        if q @ mem["q_prev"] < 0:
            q = -q
        mem["q_prev"] = q
        return R, q, w

    def observe(self, physics: SimulationPhysics, state: StepState) -> dict[str, np.ndarray]:
        R, q, w = self._attitude(state)
        obs = {
            "attitude_wxyz": q.copy(),
            "body_rate_rad_s": np.array(w, dtype=float),
            "field_body_T": R.T @ self.converter.law.field(state),
            "target_wxyz": self.q_ref.copy(),
        }
        if not self.rigid:
            mem = self._memory
            if mem["health"] is None or mem["n"] % self.health_every == 0:
                strain, _ = physics.sim.strain_check(state.pos)
                mem["health"] = (surface_sd(state.pos[self.top]), float(strain))
            mem["n"] += 1
            obs["surface_sd_m"] = np.array([mem["health"][0]])
            obs["strain_max"] = np.array([mem["health"][1]])
        return obs

    def reward_terms(self, physics: SimulationPhysics) -> dict[str, float]:
        obs = self.current_observation(physics)
        terms = {
            "theta_rad": pointing_error_rad(obs["attitude_wxyz"], self.q_ref),
            "omega_rad_s": float(np.linalg.norm(obs["body_rate_rad_s"])),
        }
        if "strain_max" in obs:
            terms["strain"] = float(obs["strain_max"][0]) / physics.sim.max_strain
        return terms

    # ------------------------------------------------------------------ shipped controller
    def shipped_action(self, physics: SimulationPhysics, controller: Any, state: StepState) -> np.ndarray:
        """Currents mode: the shipped currents (config order); torque mode: the shipped ``T_ref``."""
        cmd = controller.update(state)
        if self.mode == "torque":
            return np.asarray(cmd.torque_ref_body, dtype=float)
        return np.asarray(cmd.currents_A, dtype=float)


def _is_loops_slew(cfg: Any) -> bool:
    return getattr(cfg, "concept", None) == "current_loops" and getattr(cfg, "scenario", None) in ("slew", "slew_rigid")


@register("current_loops/slew", config="magsail_mj/concepts/current_loops/configs/slew.toml", matches=_is_loops_slew)
def current_loops_slew(cfg: Any, *, random: Any = None, **options: Any):
    """Slew of the current-loop plate (:class:`LoopsSlewTask`)."""
    return make_environment(cfg, LoopsSlewTask, random=random, **options)
