r"""dm_control environment of the MSAC panel cycle (``msac/cycle``, Vedant & Allison 2019).

A bus with two point-symmetric wings turns itself by bending the wings one way while extended and
back while contracted. The plant is the scenario's own native-speed runner
(:class:`~magsail_mj.concepts.msac.runner.MsacRunner`, ``drive.method = "replay"``): MuJoCo rolls
the model out (``mujoco.rollout``) over whole cycles with a periodic control table, feed-forward
torques of the settled computed-torque cycle plus the joint servos' set-point rates
(:mod:`magsail_mj.concepts.msac.drive`). The runner is stepped through ``MsacRunner.step``; no
Python runs per dynamics step. Configs: every ``scenario = "multibody"`` config of
``magsail_mj/concepts/msac/configs`` (default ``paper_1khz.toml``); ``lumped`` (no dynamics) and ``sweep`` (many runs)
have no environment.

Action (task option ``action``), applied to the next ``cycles_per_step`` cycles (both wings alike,
the shape vector ``(φ, s, φ, s)``):

* ``"joint_targets"`` (default): the cycle's joint targets ``(φa, φb, s_e, s_c)`` [rad, rad, m, m]:
  the bend angles the hinges reach while extended/contracted and the slide extension and
  contraction; bounds ``φ ∈ [−90°, 90°]``, ``s_e ∈ [0, ℓ/2]``, ``s_c ∈ [−ℓ/2, 0]`` (the config's
  ranges). The set-points follow the config's four-phase path (``cycle.pattern``, ``cycle.blend``)
  through these targets with the phase timing ``phase_fractions`` (task option; default the
  config's ``cycle.phase_fractions``);
* ``"phase_timing"``: the phase timing ``(t_be, t_c, t_bc, t_e)/Δt`` (each in ``[0.02, 1]``,
  normalised to sum 1) of the config's cycle.

A new cycle gets its replay table: the computed-torque calibration of
:func:`~magsail_mj.concepts.msac.drive.replay_table` (``drive.calibration_cycles`` cycles in Python,
cached per cycle; ``feedforward=False`` skips it and drives with the servos alone). When the
cycle's start point ``(φa, s_e)`` changes, the servo set-points move to it linearly over the next
cycle (they stay continuous).

Observations: ``time_s`` (1,); ``bus_attitude_wxyz`` (4,) (bus → world); ``bus_yaw_rad`` (1,)
(continuous yaw about world Z); ``bus_rate_rad_s`` (3,) (bus angular velocity, body axes);
``shape_qpos`` (4,) and ``shape_qvel`` (4,) (``w1_bend``, ``w1_ext``, ``w2_bend``, ``w2_ext``: rad, m,
rad/s, m/s); ``cycle_targets`` (4,) (the cycle being driven) and ``phase_fractions`` (4,). The wings
are rigid: no structural-health observation.

Reward per step: ``r = d Δψ/|θ_ref| − w_u mean(((a − a_0)/(a_max − a_min))²)``, with ``Δψ`` the yaw
turned during the step, ``d = ±1`` the task's direction (task option ``direction``; default the sign of
the configured cycle's rotation), ``θ_ref`` = ``cycles_per_step`` × the exact per-cycle rotation of the
configured cycle, so the settled shipped cycle earns 1 per step, and ``a_0`` the configured
cycle's action (``w_u`` of the task's ``reward_weights``).

Termination: a diverged rollout ends the episode with discount 0; the time limit (``sim.duration_s``)
with discount 1. ``control_timestep`` = ``cycles_per_step`` cycle periods (default 1).

Speed (``scripts/bench_envs.py``, ``paper_1khz`` over 0.2 s): one cycle per step costs 1.44× the
plain run, almost all of it the runner's cost per ``step`` call (a ``mujoco.rollout`` call and the
chunk bookkeeping: stepping the runner alone one cycle per call costs the same 1.44×); at
``cycles_per_step = 20`` the environment costs what the plain run does (0.96×).

Episode start (``randomize=True``): the bus yaw uniform in ``[−180°, 180°)``; the shape starts at
rest on the cycle's first waypoint as in the scenario (the runner keeps the total momentum zero,
so no initial rate is drawn). ``randomize=False`` keeps the scenario's start. The shipped policy
(:func:`magsail_mj.envs.shipped_policy`) returns the configured cycle every step, and the run
equals ``magsail run`` of the config.
"""

from __future__ import annotations

import dataclasses
import math
from collections import OrderedDict
from types import SimpleNamespace
from typing import Any

import numpy as np
from dm_control.rl import control

import magsail_mj
from magsail_mj.concepts.msac.metrics import yaw_from_quat
from magsail_mj.concepts.msac.cycle import CyclePath
from magsail_mj.concepts.msac.drive import ReplayTable, replay_table, servo_rates
from magsail_mj.envs.core import AttitudeTask, register, run_so_far
from magsail_mj.concepts.msac.mjcf import shape_indices
from magsail_mj.sim import RunResult

__all__ = ["MsacPhysics", "MsacCycleTask", "make_msac_environment", "ACTIONS"]

ACTIONS = ("joint_targets", "phase_timing")
"""The action kinds (module docstring)."""
MIN_FRACTION = 0.02
"""Smallest phase fraction of the ``phase_timing`` action."""


def _targets(path: CyclePath) -> np.ndarray:
    return np.array([path.phi_a_rad, path.phi_b_rad, path.s_e_m, path.s_c_m])


class MsacPhysics(control.Physics):
    """``dm_control`` physics over the MSAC scenario's runner (module docstring).

    ``set_cycle(path)`` selects the cycle the next steps drive (its replay table, cached);
    ``step(n)`` rolls out ``n`` dynamics steps natively (``MsacRunner.step``).
    """

    def __init__(self, runner: Any, *, feedforward: bool = True) -> None:
        cfg = runner.scenario.cfg
        if cfg.drive.method != "replay":
            raise ValueError(f"drive.method: the environment drives the replay rollout, got {cfg.drive.method!r}")
        self.runner, self.scenario, self.cfg = runner, runner.scenario, cfg
        self.model = runner.model
        self.feedforward = bool(feedforward)
        self.ix = shape_indices(self.model)
        self.config_path: CyclePath = self.scenario.path
        self._tables: dict[tuple, ReplayTable] = {}
        self.path = self.config_path
        self._bump: np.ndarray | None = None
        # what core's shipped policy looks for: the shipped "controller" (the configured cycle) and
        # the final-sample hook (unused: the cycle table holds to the end)
        self.base = SimpleNamespace(controller=self.config_path)
        self.controller = SimpleNamespace(hooks=SimpleNamespace(final_action=None))
        nq, nv = self.model.nq, self.model.nv
        self._q = slice(1, 1 + nq)
        self._v = slice(1 + nq, 1 + nq + nv)

    # ------------------------------------------------------------------ cycles
    def table(self, path: CyclePath) -> ReplayTable:
        """The replay table of ``path`` (built once per cycle; the configured cycle's equals the
        one ``magsail run`` builds)."""
        key = (*_targets(path).tolist(), *path.fractions)
        if key not in self._tables:
            d = self.cfg.drive
            if self.feedforward:
                self._tables[key] = replay_table(
                    self.model, path, omega_c_dt=d.omega_c_dt, calibration_cycles=d.calibration_cycles
                )
            else:
                ctrl = np.zeros((self.runner.N, self.model.nu))
                ctrl[:, self.ix["servo"]] = servo_rates(self.model, path, self.runner.N)
                self._tables[key] = ReplayTable(ctrl=ctrl, torque=np.zeros((self.runner.N, 4)), settle_change=math.nan)
        return self._tables[key]

    def set_cycle(self, path: CyclePath) -> None:
        """Drive ``path`` from the next step on. A new start point ``(φa, s_e)`` is reached smoothly:
        during the next cycle the servo set-points are the new path's plus the old-minus-new start
        offset fading linearly to zero (set-point rates ``+ (new − old)/Δt``), so they stay
        continuous."""
        (p0, s0), (q0, r0) = self.path.initial, path.initial
        if (p0, s0) != (q0, r0):
            bump = np.zeros(self.model.nu)
            bump[self.ix["servo"]] = np.array([q0 - p0, r0 - s0, q0 - p0, r0 - s0]) / path.period_s
            self._bump = bump if self._bump is None else self._bump + bump
        self.path = path
        self.runner.table = self.table(path)

    # ------------------------------------------------------------------ dm_control Physics
    def step(self, n_sub_steps: int = 1) -> None:
        n = int(n_sub_steps)
        runner = self.runner
        if self._bump is not None and runner.status == "running":
            table = runner.table
            first = dataclasses.replace(table, ctrl=table.ctrl + self._bump)
            self._bump = None
            m = min(n, runner.N - runner.step_index % runner.N)
            runner.table = first
            try:
                runner.step(m)
            finally:
                runner.table = table
            n -= m
        if n > 0:
            runner.step(n)

    def time(self) -> float:
        return self.runner.time

    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    def reset(self) -> None:
        self.runner.reset()
        self.path = self.config_path
        self._bump = None
        self.runner.table = self.table(self.config_path)

    def after_reset(self) -> None:
        pass

    def check_divergence(self) -> None:
        if self.runner.status == "diverged":
            raise control.PhysicsError(self.runner.message)

    @property
    def status(self) -> str:
        return self.runner.status

    def get_state(self) -> dict[str, Any]:
        """The runner's whole state (:meth:`MsacRunner.get_state`)."""
        return self.runner.get_state()

    def set_state(self, state: dict[str, Any]) -> None:
        self.runner.set_state(state)

    def mj_state(self) -> np.ndarray:
        """MuJoCo's full physics state of the current step (a view; ``[t, qpos, qvel, act, …]``)."""
        return self.runner._state

    def qpos(self) -> np.ndarray:
        return self.mj_state()[self._q]

    def qvel(self) -> np.ndarray:
        return self.mj_state()[self._v]

    def step_state(self) -> SimpleNamespace:
        """The time of the current step (all the shipped policy needs)."""
        return SimpleNamespace(t=self.runner.time)

    def result(self) -> RunResult:
        """The run so far as a :class:`~magsail_mj.sim.RunResult` (for ``scenario.postprocess``)."""
        return run_so_far(self.runner)

    def summary(self) -> dict[str, Any]:
        """The scenario's summary figures of the run so far."""
        return self.scenario.postprocess(self.result())[0]


class MsacCycleTask(AttitudeTask):
    """The MSAC panel-cycle task (module docstring: action, observation, reward, episode start).

    Args:
      runner: the config's runner (:func:`magsail_mj.load`).
      random, randomize, reward_weights: see :class:`~magsail_mj.envs.core.AttitudeTask` (the reward
        uses ``w_u``).
      action: ``"joint_targets"`` (default) or ``"phase_timing"``.
      phase_fractions: the phase timing of the ``joint_targets`` cycles (default the config's).
      cycles_per_step: cycles per environment step (integer ≥ 1).
      direction: +1 or −1, the sense of rotation rewarded (default the configured cycle's).
    """

    def __init__(
        self,
        runner: Any,
        random: Any = None,
        *,
        action: str = "joint_targets",
        randomize: bool = True,
        phase_fractions: Any = None,
        cycles_per_step: int = 1,
        direction: float | None = None,
        reward_weights: Any = None,
    ) -> None:
        super().__init__(random, randomize=randomize, reward_weights=reward_weights)
        if action not in ACTIONS:
            raise ValueError(f"action: must be one of {', '.join(ACTIONS)}, got {action!r}")
        if int(cycles_per_step) != cycles_per_step or cycles_per_step < 1:
            raise ValueError(f"cycles_per_step: must be an integer >= 1, got {cycles_per_step!r}")
        sc = runner.scenario
        self.scenario, self.cfg, self.action = sc, sc.cfg, action
        self.config_path: CyclePath = sc.path
        if phase_fractions is not None:
            try:
                self.config_path = dataclasses.replace(sc.path, fractions=tuple(float(f) for f in phase_fractions))
            except (TypeError, ValueError) as err:
                raise ValueError(f"phase_fractions: {err}") from None
        self.cycles_per_step = int(cycles_per_step)
        self.period_s = self.cycles_per_step * sc.path.period_s
        exact = float(sc.references()["theta_gamma_exact_rad"])
        if direction is None:
            direction = 1.0 if exact >= 0 else -1.0
        if direction not in (1, -1):
            raise ValueError(f"direction: must be +1 or -1, got {direction!r}")
        self.direction = float(direction)
        self.theta_ref_rad = max(abs(exact), 1e-12) * self.cycles_per_step
        half = math.pi / 2
        if action == "joint_targets":
            l_half = 0.5 * self.cfg.wings.length_m
            self._set_action_bounds(
                ("phi_a_rad", "phi_b_rad", "s_e_m", "s_c_m"),
                np.array([-half, -half, 0.0, -l_half]),
                np.array([half, half, l_half, 0.0]),
            )
        else:
            self._set_action_bounds(("f_be", "f_c", "f_bc", "f_e"), np.full(4, MIN_FRACTION), np.ones(4))
        self._yaw = 0.0

    # ------------------------------------------------------------------ cycles
    def cycle_of(self, action: np.ndarray) -> CyclePath:
        """The cycle an action commands (module docstring)."""
        base = self.config_path
        if self.action == "joint_targets":
            if np.array_equal(action, _targets(base)):
                return base
            a, b, e, c = (float(x) for x in action)
            return dataclasses.replace(base, phi_a_rad=a, phi_b_rad=b, s_e_m=e, s_c_m=c)
        f = tuple(float(x) for x in action)
        if f == base.fractions:
            return base
        total = sum(f)
        return dataclasses.replace(base, fractions=tuple(x / total for x in f))

    def neutral_action(self) -> np.ndarray:
        """The configured cycle (the scenario's own drive)."""
        p = self.config_path
        return _targets(p) if self.action == "joint_targets" else np.array(p.fractions)

    # ------------------------------------------------------------------ episode
    def initialize_episode(self, physics: MsacPhysics) -> None:
        self._last_action = self.neutral_action()
        physics.set_cycle(self.config_path)
        physics._bump = None
        self.start = self.draw_start(physics) if self.randomize else {}
        self._yaw = float(yaw_from_quat(physics.qpos()[3:7][None])[0])

    def draw_start(self, physics: MsacPhysics) -> dict[str, Any]:
        """The bus yaw uniform in [−π, π) (the scenario's start otherwise)."""
        yaw = float(self.random.uniform(-math.pi, math.pi))
        state = physics.get_state()
        q = state["mj_state"][physics._q]
        q[3:7] = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
        physics.set_state(state)
        return {"yaw0_rad": yaw}

    def before_step(self, action: Any, physics: MsacPhysics) -> None:
        a = self.prepare_action(action)
        self._last_action = a
        physics.set_cycle(self.cycle_of(a))

    # ------------------------------------------------------------------ observation, reward
    def get_observation(self, physics: MsacPhysics) -> OrderedDict:
        """The named arrays of :meth:`observe` (no step state: the physics is read directly)."""
        return self.observe(physics, None)

    def observe(self, physics: MsacPhysics, state: None) -> OrderedDict:
        """Time, bus attitude, unwrapped yaw (advanced here: once per step) and rate, the shape
        coordinates and the driven cycle."""
        q, v = physics.qpos(), physics.qvel()
        ix = physics.ix
        psi = float(yaw_from_quat(q[3:7][None])[0])
        self._yaw_prev = self._yaw
        self._yaw += (psi - self._yaw + math.pi) % (2 * math.pi) - math.pi
        return OrderedDict(
            [
                ("time_s", np.array([physics.time()])),
                ("bus_attitude_wxyz", q[3:7].copy()),
                ("bus_yaw_rad", np.array([self._yaw])),
                ("bus_rate_rad_s", v[3:6].copy()),
                ("shape_qpos", q[ix["qpos"]].copy()),
                ("shape_qvel", v[ix["dof"]].copy()),
                ("cycle_targets", _targets(physics.path)),
                ("phase_fractions", np.array(physics.path.fractions)),
            ]
        )

    def get_reward(self, physics: MsacPhysics) -> float:
        turned = self._yaw - self._yaw_prev
        return float(self.direction * turned / self.theta_ref_rad - self.weights.w_u * self.effort())

    def effort(self) -> float:
        """Mean of squares of the action's change from the configured cycle, normalised by the
        bounds' span (0 for the shipped cycle)."""
        span = self.action_high - self.action_low
        u = (self._last_action - self.neutral_action()) / span
        return float(np.mean(u * u))

    # ------------------------------------------------------------------ shipped cycle
    def fresh_shipped_controller(self, physics: MsacPhysics) -> CyclePath:
        return self.config_path

    def shipped_action(self, physics: MsacPhysics, controller: CyclePath, state: Any) -> np.ndarray:
        """The configured cycle (joint targets or phase timing)."""
        return _targets(controller) if self.action == "joint_targets" else np.array(controller.fractions)


def make_msac_environment(
    cfg: Any, *, random: Any = None, feedforward: bool = True, **options: Any
) -> control.Environment:
    """The environment of an MSAC multibody config (``options`` go to :class:`MsacCycleTask`):
    ``control_timestep`` = ``cycles_per_step`` cycle periods, ``time_limit`` = ``sim.duration_s``.
    Its actions are joint targets, so it always drives the servo ``replay`` (``drive.method`` of
    the config is replaced; ``magsail run`` of the same config with ``drive.method = "replay"`` gives
    the same numbers)."""
    if getattr(cfg, "concept", None) != "msac" or getattr(cfg, "scenario", None) != "multibody":
        raise ValueError(
            f"config: expected an MSAC multibody config, got concept {getattr(cfg, 'concept', None)!r}, "
            f"scenario {getattr(cfg, 'scenario', None)!r}"
        )
    if cfg.drive.method != "replay":  # the actions are joint targets: the servo replay drives them
        cfg = cfg.model_copy(update={"drive": cfg.drive.model_copy(update={"method": "replay"})})
    runner = magsail_mj.load(cfg)
    physics = MsacPhysics(runner, feedforward=feedforward)
    task = MsacCycleTask(runner, random=random, **options)
    return control.Environment(physics, task, time_limit=float(cfg.sim.duration_s), control_timestep=task.period_s)


def _is_multibody(cfg: Any) -> bool:
    return getattr(cfg, "concept", None) == "msac" and getattr(cfg, "scenario", None) == "multibody"


@register("msac/cycle", config="magsail_mj/concepts/msac/configs/paper_1khz.toml", matches=_is_multibody)
def cycle(cfg: Any, *, random: Any = None, **options: Any) -> control.Environment:
    """MSAC panel cycle: joint targets (or phase timing) of the wings' shape cycle."""
    return make_msac_environment(cfg, random=random, **options)
