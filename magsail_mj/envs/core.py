r"""dm_control environments of the attitude scenarios: Physics, Task base, registry.

The split follows dm_control (``dm_control.rl.control``):

* :class:`SimulationPhysics` — the simulator: a :class:`magsail_mj.sim.Simulation` built by
  :func:`magsail_mj.load` from a config and re-built by :func:`magsail_mj.commands.attach` with an
  :class:`ActionController`. Every load and every probe of the scenario is kept, so the scenario's
  own post-processing (``sim.scenario.postprocess``) applies to an environment's run.
* :class:`AttitudeTask` — actions, observations, reward, termination and episode start.
* ``dm_control.rl.control.Environment`` — ``control_timestep`` (the shipped controller's period)
  and ``time_limit`` (the scenario's ``sim.duration_s``).

Timing. The simulation samples its controller at ``t_k = k · period`` (zero-order hold). An
environment step of ``control_timestep = period`` runs ``n = period/δt`` physics steps; its first
physics step samples the :class:`ActionController`, which turns the action set by
:meth:`AttitudeTask.before_step` into the scenario's own command from the state at ``t_k`` (the
state the observation of the previous time step described). The command is held over the
environment step, exactly as in ``magsail run``.

Termination. A diverged simulation (status ``"diverged"``) or a failed structure (strut strain
above ``sim.max_strain``, status ``"structure_failed"``) ends the episode with discount 0; the
time limit ends it with discount 1 (dm_control's rule). :meth:`SimulationPhysics.check_divergence`
raises :class:`dm_control.rl.control.PhysicsError` on a diverged simulation.

Reward (every task; the terms a task lacks are 0):

.. math::

   r = -\bigl(w_\theta (\theta/\pi)^2 + w_\omega (|\omega|/\omega_s)^2
        + w_u \overline{(u/u_{max})^2} + w_\varepsilon (\varepsilon_{max}/\varepsilon_{fail})^2\bigr)

with θ the pointing error angle [rad] (``2 acos |q_e,w|``, ``q_e = q_ref* ⊗ q``), ω the body
rate [rad/s] and ω_s the task's rate scale [rad/s], ``u/u_max`` the action normalised by its
bounds (mean of squares over the components), ε_max the largest strut strain and ε_fail
``sim.max_strain``; the weights ``w_*`` are task options (``reward_weights``).
"""

from __future__ import annotations

import abc
import collections
import copy
import functools
import json
import math
from dataclasses import dataclass
from datetime import timedelta
from pathlib import Path
from types import SimpleNamespace
from typing import Any, Callable, Mapping, Sequence

import dm_env
import numpy as np
from dm_control.rl import control
from dm_env import specs

import magsail_mj
from magsail_mj.checkpoint import StateWalker
from magsail_mj.commands import attach
from magsail_mj.config import apply_overrides, load_config, parse_config
from magsail_mj.environment.timeutil import parse_epoch
from magsail_mj.loads.base import StepState
from magsail_mj.quaternion import quat_from_axis_angle, quat_mul, quat_to_matrix
from magsail_mj.sim import RunResult, Simulation

__all__ = [
    "ActionController",
    "SimulationPhysics",
    "AttitudeTask",
    "RewardWeights",
    "TaskEntry",
    "register",
    "load",
    "list_tasks",
    "task_entry",
    "entry_for_config",
    "shipped_policy",
    "make_environment",
    "pointing_error_rad",
    "as_random_state",
    "set_rigid_motion",
    "random_turn",
    "draw_rigid_start",
    "REPO_ROOT",
    "run_episode",
    "run_so_far",
    "redraw_epoch",
    "summary_mismatches",
    "WALL_CLOCK_KEYS",
]

REPO_ROOT = Path(__file__).resolve().parents[2]
"""The repository root: shipped configs are ``REPO_ROOT / "magsail_mj" / "concepts" / ...``."""

ENDING_STATUSES = ("diverged", "structure_failed", "failed", "interrupted")
"""Simulation statuses that end an episode with discount 0."""

REQUEST_HEADROOM = 1e6
"""Largest ratio |request| / bound of an action component of a task that does not clip its actions
(``AttitudeTask.clip_actions`` False, e.g. a torque request through an allocation): the shipped
controllers request up to about 100 times the bound, so their runs are unchanged; a larger request is
scaled down to this ratio (:meth:`AttitudeTask.prepare_action`)."""


# =========================================================================== controller


class ActionController:
    """The controller of an environment's simulation: it returns the task's action as the
    scenario's command.

    ``update(state)`` is called by the runner every ``period_s`` (zero-order hold); it returns
    ``convert(state, action)`` with the action last set by the task (``action``), and keeps that
    command in ``command`` (what the loads hold until the next sample).

    Args:
      period_s: sample period [s] (the shipped controller's period).
      convert: ``(state, action) → command`` of the scenario's own command type.
      action: the initial action (the task's neutral action, e.g. zero torque).
    """

    def __init__(
        self,
        *,
        period_s: float,
        convert: Callable[[StepState, np.ndarray], Any],
        action: np.ndarray,
        end_time_s: float = math.inf,
    ) -> None:
        if not (math.isfinite(period_s) and period_s > 0):
            raise ValueError(f"period_s: must be > 0 s, got {period_s!r}")
        self.period_s = float(period_s)
        self.convert = convert
        self.action = np.array(action, dtype=float, copy=True)
        self.command: Any = None
        self.end_time_s = float(end_time_s)
        # not part of the simulation's state (the checkpoint walker skips namespaces): a callable
        # ``state → action`` for the sample at the run's end (see ``update``)
        self.hooks = SimpleNamespace(final_action=None)

    def update(self, state: StepState) -> Any:
        """The command of the current action at ``state``.

        The sample at the run's end (``t = end_time_s``, followed by the final record and no
        dynamics) falls inside the last environment step, after the last action: its command is
        made from the held action, or from ``hooks.final_action(state)`` when set (the shipped
        policy sets it, so that its run records the final sample as ``magsail run`` does)."""
        final = self.hooks.final_action
        if final is not None and state.t >= self.end_time_s - 1e-9 * self.period_s:
            self.action[:] = final(state)
        self.command = self.convert(state, self.action)
        return self.command


# =========================================================================== physics


def _unaliased_probes(sim: Simulation) -> dict[str, Any]:
    """``sim``'s probes, those that reach an object already walked through a bound method's
    ``__self__`` wrapped in a :func:`functools.partial` (which the checkpoint walker does not
    enter): ``magsail_mj.checkpoint.restore_state`` cannot write such an alias back, so ``reset``
    would fail (e.g. the current-loops work probe, a closure over a load's bound method). The
    objects they reach are loads, walked through the loads."""
    nodes = StateWalker(
        {
            "controller": sim.controller,
            "loads": list(sim.loads),
            "environment": sim.environment,
            "probes": dict(sim.probes),
        }
    ).nodes()
    bad = {path for path, node in nodes.items() if node.get("kind") == "alias" and path.endswith("<__self__>")}
    return {
        name: functools.partial(probe) if any(p.startswith(f"probes{{{json.dumps(name)}}}") for p in bad) else probe
        for name, probe in sim.probes.items()
    }


class SimulationPhysics(control.Physics):
    """dm_control ``Physics`` over a :class:`magsail_mj.sim.Simulation`.

    Args:
      base: the simulation of the config as built by :func:`magsail_mj.load` (left unstepped).
      controller: the :class:`ActionController` put on the spacecraft in place of the shipped
        controller; the scenario's loads (actuators included, they read the command) and probes are
        all kept.

    ``sim`` is the simulation the environment steps; ``scenario`` and ``cfg`` are the base's. The
    base's probes that reach a load through a bound method are wrapped first
    (:func:`_unaliased_probes`), so that ``reset`` can restore the state.
    """

    _state_cache: tuple[tuple[int, float, float], StepState] | None = None

    def __init__(self, base: Simulation, controller: ActionController) -> None:
        if not isinstance(base, Simulation):
            raise TypeError(f"base: expected a stepped magsail_mj.sim.Simulation, got {type(base).__name__}")
        self.base = base
        self.controller = controller
        base.probes = _unaliased_probes(base)
        self.sim = attach(base, controller, [], keep_load=lambda load: True, keep_probes=tuple(base.probes))
        self.scenario = base.scenario
        self.cfg = base.cfg

    # ------------------------------------------------------------------ dm_control Physics
    def step(self, n_sub_steps: int = 1) -> None:
        """Advance ``n_sub_steps`` physics steps (never beyond the scenario's duration)."""
        self.sim.step(int(n_sub_steps))

    def time(self) -> float:
        """Simulated time [s]."""
        return self.sim.time

    def timestep(self) -> float:
        """Physics time step δt [s]."""
        return float(self.sim.model.opt.timestep)

    def reset(self) -> None:
        """Back to the build's initial state (t = 0, no records)."""
        self.sim.reset()

    def after_reset(self) -> None:
        """Nothing to recompute: the runner refreshes kinematics at each step."""

    def check_divergence(self) -> None:
        """Raise :class:`dm_control.rl.control.PhysicsError` when the simulation diverged."""
        if self.sim.status == "diverged":
            raise control.PhysicsError(self.sim.message)

    check_invalid_state = check_divergence

    def get_state(self) -> dict[str, Any]:
        """The simulation's whole state (:meth:`magsail_mj.sim.Simulation.get_state`, a dict)."""
        return self.sim.get_state()

    def set_state(self, state: dict[str, Any]) -> None:
        """Continue from a state of :meth:`get_state`."""
        self.sim.set_state(state)

    def flat_state(self) -> np.ndarray:
        """MuJoCo's integration state as a flat float64 array (a copy)."""
        return np.array(self.sim.get_state()["mj_state"], dtype=float)

    # ------------------------------------------------------------------ helpers
    @property
    def model(self) -> Any:
        return self.sim.model

    @property
    def data(self) -> Any:
        return self.sim.data

    @property
    def status(self) -> str:
        return self.sim.status

    def step_state(self) -> StepState:
        """What the runner's next step will see at the current time: body kinematics, the
        environment sample at ``t`` and the held command (the StepState of :mod:`magsail_mj.sim`).

        Built once per state (the policy and the observation of one step share it): it is kept
        while the step index and the sums of ``qpos`` and ``qvel`` stay the same."""
        sim = self.sim
        data = sim.data
        key = (sim.step_index, float(data.qpos.sum()), float(data.qvel.sum()))
        if self._state_cache is not None and self._state_cache[0] == key:
            state = self._state_cache[1]
            state.ctrl = self.controller.command
            return state
        sim.kin.update(data)
        t = sim.time
        env = sim.environment.sample(t) if sim.environment is not None else None
        kin = sim.kin
        state = StepState(
            t=t, pos=kin.pos, vel=kin.vel, xquat=kin.xquat, omega=kin.omega, env=env, ctrl=self.controller.command
        )
        self._state_cache = (key, state)
        return state

    def result(self) -> RunResult:
        """The run so far as a :class:`~magsail_mj.sim.RunResult` (for ``scenario.postprocess``)."""
        return run_so_far(self.sim)

    def summary(self) -> dict[str, Any]:
        """The scenario's summary figures of the run so far (``scenario.postprocess``)."""
        return self.scenario.postprocess(self.result())[0]


def run_so_far(runner: Any) -> RunResult:
    """The run of a stepped ``runner`` so far as a :class:`~magsail_mj.sim.RunResult` (what
    ``scenario.postprocess`` takes): its records, status (``"stopped"`` while still running),
    message, time [s], steps taken and wall time [s]. ``runner`` is a
    :class:`~magsail_mj.sim.Simulation` or a concept's own runner with the same attributes
    (``records()``, ``status``, ``message``, ``time``, ``step_index``, ``_wall_s``)."""
    status = runner.status if runner.status != "running" else "stopped"
    return RunResult(
        records=runner.records(),
        status=status,
        message=runner.message,
        t_end_s=runner.time,
        steps=runner.step_index,
        wall_time_s=float(runner._wall_s),
    )


# =========================================================================== episode start


def set_rigid_motion(
    physics: SimulationPhysics, *, q_wxyz: np.ndarray, omega_body_rad_s: np.ndarray, masses: np.ndarray | None = None
) -> None:
    r"""Write a rigid motion into the physics' current state (at rest otherwise, undeformed).

    Particle bodies (three slide joints): ``x_i = c + R (p_i − c)``, ``v_i = R (ω × (p_i − c))``
    with ``p_i`` the model's reference positions, ``c`` their centre of mass (``masses``, default
    the model's body masses) and ``R`` the rotation of ``q_wxyz`` (body → world). Free bodies: the
    orientation ``q_wxyz`` (position kept) and the body-axes rate ω [rad/s] (MuJoCo's free-joint
    angular velocity is in body axes), no linear velocity.
    """
    q = np.asarray(q_wxyz, dtype=float)
    q = q / np.linalg.norm(q)
    w = np.asarray(omega_body_rad_s, dtype=float)
    R = quat_to_matrix(q)
    kin, data = physics.sim.kin, physics.data
    if kin.part_body.size:
        p = kin.pos0[kin.part_body]
        m = physics.model.body_mass[kin.part_body] if masses is None else np.asarray(masses, dtype=float)
        c = np.average(p, axis=0, weights=m)
        data.qpos[kin.part_q] = (p - c) @ R.T + c - p
        data.qvel[kin.part_v] = np.cross(w, p - c) @ R.T
    for qa, va in zip(kin.free_q, kin.free_v):
        data.qpos[qa + 3 : qa + 7] = q
        data.qvel[va : va + 3] = 0.0
        data.qvel[va + 3 : va + 6] = w


def random_turn(rng: np.random.RandomState, max_angle_rad: float) -> np.ndarray:
    """Quaternion of a rotation about a uniformly drawn axis (unit sphere) through an angle uniform
    in ``[0, max_angle_rad]``."""
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    return quat_from_axis_angle(axis, rng.uniform(0.0, max_angle_rad))


def draw_rigid_start(
    rng: np.random.RandomState, *, q0_wxyz: np.ndarray, rate_range_rad_s: float, attitude_range_rad: float
) -> tuple[np.ndarray, np.ndarray]:
    """``(q, ω)``: ``q = q0 ⊗ turn`` (:func:`random_turn` within ``attitude_range_rad``) and body
    rates uniform in ``±rate_range_rad_s`` per axis [rad/s] (the rates are drawn first)."""
    omega = rng.uniform(-rate_range_rad_s, rate_range_rad_s, size=3)
    q = quat_mul(np.asarray(q0_wxyz, dtype=float), random_turn(rng, attitude_range_rad))
    return q / np.linalg.norm(q), omega


# =========================================================================== task


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the reward terms (module docstring): pointing ``w_theta``, rate ``w_omega``,
    effort ``w_u``, strain ``w_strain`` (all ≥ 0, dimensionless)."""

    w_theta: float = 1.0
    w_omega: float = 1.0
    w_u: float = 0.01
    w_strain: float = 1.0

    def __post_init__(self) -> None:
        for name in ("w_theta", "w_omega", "w_u", "w_strain"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"reward_weights.{name}: must be a finite number >= 0, got {value!r}")


def as_random_state(random: int | np.random.RandomState | None) -> np.random.RandomState:
    """dm_control's seeding: a seed, a ``RandomState`` (used as is) or ``None`` (fresh entropy)."""
    if isinstance(random, np.random.RandomState):
        return random
    if random is None or isinstance(random, (int, np.integer)):
        return np.random.RandomState(random)
    raise TypeError(f"random: expected an int seed, a numpy.random.RandomState or None, got {type(random).__name__}")


def pointing_error_rad(q_wxyz: np.ndarray, q_ref_wxyz: np.ndarray) -> float:
    """θ = 2 acos |q_e,w| with ``q_e = q_ref* ⊗ q`` [rad], in [0, π]: the scalar part of the error
    quaternion is the dot product ``q_ref · q``."""
    c = abs(float(np.dot(np.asarray(q_wxyz, dtype=float), np.asarray(q_ref_wxyz, dtype=float))))
    return 2.0 * math.acos(min(1.0, c))


class AttitudeTask(control.Task):
    """Base of the attitude tasks (module docstring): seeding, episode start, termination, reward.

    Args:
      random: seed or ``numpy.random.RandomState`` (dm_control's convention) for the episode start.
      randomize: draw the episode start from the task's documented ranges (True) or keep the
        config's initial state (False).
      reward_weights: :class:`RewardWeights` or a mapping of its fields.

    Subclasses set ``action_names``, ``action_low``, ``action_high`` (``_set_action_bounds``) and
    ``converter`` (over a :class:`SimulationPhysics`: ``command(state, action)`` gives the
    scenario's command), implement the abstract methods :meth:`observe` (named arrays) and
    :meth:`shipped_action` (the shipped controller's command as an action) — a subclass without
    either cannot be instantiated (``TypeError`` naming the method) — and override
    :meth:`reward_terms` and :meth:`draw_start` (write a drawn initial state into the physics)
    where the task has them.
    """

    rate_scale_rad_s: float = 1e-2

    def __init__(
        self,
        random: int | np.random.RandomState | None = None,
        *,
        randomize: bool = True,
        reward_weights: RewardWeights | Mapping[str, float] | None = None,
    ) -> None:
        super().__init__()
        self._random = as_random_state(random)
        self.randomize = bool(randomize)
        if reward_weights is None:
            reward_weights = RewardWeights()
        elif not isinstance(reward_weights, RewardWeights):
            reward_weights = RewardWeights(**dict(reward_weights))
        self.weights = reward_weights
        self.action_names: tuple[str, ...] = ()
        self.action_low = np.zeros(0)
        self.action_high = np.zeros(0)
        self._scale_list: list[float] = []
        self._inv_scale: list[float] = []
        self.start: dict[str, Any] = {}
        self._last_action = np.zeros(0)
        self._previous_obs: collections.OrderedDict | None = None
        self._obs_cache: tuple[int, collections.OrderedDict] | None = None
        self._handed_out: int | None = None

    @property
    def random(self) -> np.random.RandomState:
        """The task's random state (dm_control's ``Task.random``)."""
        return self._random

    # ------------------------------------------------------------------ actions
    def _set_action_bounds(self, names: Sequence[str], low: np.ndarray, high: np.ndarray) -> None:
        low, high = np.asarray(low, dtype=float), np.asarray(high, dtype=float)
        if low.shape != (len(names),) or high.shape != low.shape or np.any(~(low <= high)):
            raise ValueError(f"action bounds: expected {len(names)} pairs low <= high, got {low!r}, {high!r}")
        self.action_names = tuple(names)
        self.action_low, self.action_high = low, high
        self._low_list, self._high_list = low.tolist(), high.tolist()
        scale = np.maximum(np.abs(low), np.abs(high))
        self._scale_list = scale.tolist()
        self._inv_scale = [1.0 / x if x > 0 else 0.0 for x in self._scale_list]
        self._last_action = np.zeros(len(names))

    def neutral_action(self) -> np.ndarray:
        """The action of no actuation (zeros clipped into the bounds)."""
        return np.clip(np.zeros(len(self.action_names)), self.action_low, self.action_high)

    def action_spec(self, physics: SimulationPhysics) -> specs.BoundedArray:
        return specs.BoundedArray(
            shape=(len(self.action_names),),
            dtype=np.float64,
            minimum=self.action_low,
            maximum=self.action_high,
            name=",".join(self.action_names),
        )

    clip_actions: bool = True
    """Clip actions into the action spec's bounds (True), or hand them on as requests (False: for actions
    whose actuator saturates them itself, e.g. a torque request through an allocation; a request beyond
    :data:`REQUEST_HEADROOM` times its bounds is scaled down to that, see :meth:`prepare_action`)."""

    def before_step(self, action: Any, physics: SimulationPhysics) -> None:
        """Hand the action (:meth:`prepare_action`) to the controller."""
        a = self.prepare_action(action)
        physics.controller.action[:] = a
        self._last_action = a

    def prepare_action(self, action: Any) -> np.ndarray:
        """The action as a float array, checked and bounded: the one place every environment's
        actions pass (dm_control's convention for a ``BoundedArray`` spec).

        * A wrong shape or a non-finite component (NaN, ±inf) is refused: ``ValueError`` naming
          ``action``.
        * ``clip_actions`` True: each component is clipped into the action bounds (the hardware's
          limits).
        * ``clip_actions`` False (a request the actuator saturates itself): the request is handed
          on as given while every component stays within :data:`REQUEST_HEADROOM` times its bound
          (``max(|low|, |high|)``); a larger request is scaled down, its direction kept, until
          every component is within that limit (a component of bound 0 becomes 0). A request that
          far beyond the deliverable envelope is saturated either way, and the arithmetic
          downstream (allocation, reward effort) stays finite for any finite action.
        """
        a = np.asarray(action, dtype=float).reshape(-1)
        if a.shape != self.action_low.shape:
            raise ValueError(f"action: expected shape {self.action_low.shape}, got {np.shape(action)}")
        values = a.tolist()  # a few components: plain floats are faster than NumPy calls here
        if not all(map(math.isfinite, values)):
            raise ValueError(f"action: every component must be finite, got {action!r}")
        if self.clip_actions:
            values = [min(max(v, lo), hi) for v, lo, hi in zip(values, self._low_list, self._high_list)]
        else:
            values = [v if b > 0 else 0.0 for v, b in zip(values, self._scale_list)]
            # f = the smallest H·bound/|v| of the components beyond the limit (no product overflows)
            over = [
                REQUEST_HEADROOM * b / abs(v) for v, b in zip(values, self._scale_list) if abs(v) > REQUEST_HEADROOM * b
            ]
            if over:
                f = min(over)
                values = [v * f for v in values]
        return np.array(values)

    converter: Any = None
    """Object whose ``command(state, action)`` returns the scenario's command for ``action`` at
    ``state`` (subclasses set it). It becomes part of the simulation's controller, so its state is
    checkpointed and restored by ``reset`` with the simulation's."""

    # ------------------------------------------------------------------ episode
    def initialize_episode(self, physics: SimulationPhysics) -> None:
        """Reset has put the build's initial state back; with ``epoch_range_s`` > 0 the simulation
        is rebuilt at a drawn epoch (:func:`redraw_epoch`, drawn first); a start is drawn when
        ``randomize``."""
        epoch = redraw_epoch(self, physics) if self.epoch_range_s > 0 else None
        physics.controller.action[:] = self.neutral_action()
        physics.controller.hooks.final_action = None
        self._obs_cache = None
        self._handed_out = None
        self._last_action = self.neutral_action()
        self.start = self.draw_start(physics) if self.randomize else {}
        if epoch is not None:
            self.start["epoch"] = epoch

    def draw_start(self, physics: SimulationPhysics) -> dict[str, Any]:
        """Write a drawn initial state into ``physics`` and return what was drawn (subclass)."""
        return {}

    # ------------------------------------------------------------------ observations and reward
    needs_step_state: bool = True
    """Whether :meth:`observe` reads the runner's :class:`StepState` (body kinematics and the
    environment sample at the current time, built by :meth:`SimulationPhysics.step_state`); a task
    that reads ``physics.data`` itself sets it False and is passed ``None``."""

    @abc.abstractmethod
    def observe(self, physics: SimulationPhysics, state: StepState | None) -> dict[str, np.ndarray]:
        """Named observation arrays at ``state`` (subclass)."""

    def get_observation(self, physics: SimulationPhysics) -> collections.OrderedDict:
        """The named observation arrays (float64); after a divergence (the state is not finite) the
        previous observation's arrays filled with NaN.

        The first call of a step hands out the step's own arrays (dm_control asks for the reward
        first, so nothing of the task reads them afterwards: no copy on the per-step path); a
        further call in the same step gets copies."""
        obs = self.current_observation(physics)
        key = self._obs_cache[0]
        if self._handed_out == key:
            return collections.OrderedDict((k, v.copy()) for k, v in obs.items())
        self._handed_out = key
        return obs

    def current_observation(self, physics: SimulationPhysics) -> collections.OrderedDict:
        """The observation of the current step, computed once per step (the reward, which dm_control
        asks for first, and the observation share it)."""
        key = physics.sim.step_index
        cache = self._obs_cache
        if cache is not None and cache[0] == key:
            return cache[1]
        if physics.status == "diverged" and self._previous_obs is not None:
            out = collections.OrderedDict((k, np.full_like(v, np.nan)) for k, v in self._previous_obs.items())
        else:
            obs = self.observe(physics, physics.step_state() if self.needs_step_state else None)
            for k, v in obs.items():  # most tasks return float64 arrays already: no conversion then
                if type(v) is not np.ndarray or v.dtype != np.float64:
                    obs[k] = np.asarray(v, dtype=np.float64)
            out = collections.OrderedDict(obs)
            self._previous_obs = out
        self._obs_cache = (key, out)
        self._handed_out = None
        return out

    def reward_terms(self, physics: SimulationPhysics) -> dict[str, float]:
        """``theta_rad``, ``omega_rad_s``, ``strain`` (ε_max/ε_fail) of the current step (subclass;
        missing terms count 0). :meth:`current_observation` is already computed when it is called."""
        return {}

    def effort(self) -> float:
        """Mean of squares of the last action normalised by its bounds (``a / max(|low|, |high|)``;
        in [0, 1] for an action within its bounds)."""
        n = len(self._inv_scale)
        if not n:
            return 0.0
        return sum((a * k) ** 2 for a, k in zip(self._last_action.tolist(), self._inv_scale)) / n

    def get_reward(self, physics: SimulationPhysics) -> float:
        """The reward of the module docstring (NaN after a divergence)."""
        if physics.status == "diverged":
            return math.nan
        self.current_observation(physics)
        terms = self.reward_terms(physics)
        w = self.weights
        theta = terms.get("theta_rad", 0.0) / math.pi
        rate = terms.get("omega_rad_s", 0.0) / self.rate_scale_rad_s
        strain = terms.get("strain", 0.0)
        return -float(
            w.w_theta * theta * theta + w.w_omega * rate * rate + w.w_u * self.effort() + w.w_strain * strain * strain
        )

    def get_termination(self, physics: SimulationPhysics) -> float | None:
        """0.0 on divergence or structural failure, 1.0 when the simulation reached its duration,
        else None (the time limit itself is the Environment's)."""
        status = physics.status
        if status == "running":
            return None
        if status in ENDING_STATUSES or status == "structure_failed":
            return 0.0
        if status == "completed":
            return 1.0
        return None

    # ------------------------------------------------------------------ binding
    epoch_range_s: float = 0.0
    """Width of the epoch draw [s] (task option of :func:`make_environment`; 0: the config's epoch)."""

    period_s: float = 0.0
    """Controller period [s]: the shipped controller's (subclasses set it from the built simulation)."""

    def bind(self, physics: SimulationPhysics) -> None:
        """Called once the physics exists (subclasses may keep references)."""
        self.physics = physics

    # ------------------------------------------------------------------ shipped controller
    def fresh_shipped_controller(self, physics: SimulationPhysics) -> Any:
        """A copy of the shipped controller as built (the base simulation is never stepped, so its
        controller is in its initial state)."""
        return copy.deepcopy(physics.base.controller)

    @abc.abstractmethod
    def shipped_action(self, physics: SimulationPhysics, controller: Any, state: StepState) -> np.ndarray:
        """The action that makes :meth:`convert` give the shipped controller's command at
        ``state`` (subclass; ``controller`` is a fresh copy of the shipped controller)."""


# =========================================================================== registry


@dataclass(frozen=True)
class TaskEntry:
    """A registered task: its name, shipped config, the factory and which configs it serves."""

    name: str
    config: Path
    factory: Callable[..., control.Environment]
    matches: Callable[[Any], bool]
    doc: str = ""


_REGISTRY: dict[str, TaskEntry] = {}


def register(name: str, *, config: str | Path, matches: Callable[[Any], bool]) -> Callable:
    """Decorator registering ``factory(cfg, overrides, random, **options) → Environment`` as task
    ``name`` with its shipped ``config`` (relative to the repository root) and the predicate of
    the configs it serves (a config's concept/scenario)."""
    if "/" not in name:
        raise ValueError(f"name: expected '<concept>/<task>', got {name!r}")

    def wrap(factory: Callable[..., control.Environment]) -> Callable[..., control.Environment]:
        _REGISTRY[name] = TaskEntry(
            name=name, config=REPO_ROOT / config, factory=factory, matches=matches, doc=(factory.__doc__ or "").strip()
        )
        return factory

    return wrap


def list_tasks() -> list[str]:
    """Names of the registered tasks (``<concept>/<task>``), sorted."""
    return sorted(_REGISTRY)


def task_entry(name: str) -> TaskEntry:
    """The registered task ``name`` (``ValueError`` naming the known ones otherwise)."""
    if name not in _REGISTRY:
        raise ValueError(f"task: unknown environment {name!r}; known: {', '.join(list_tasks())}")
    return _REGISTRY[name]


def entry_for_config(cfg: Any, source: str) -> TaskEntry:
    """The task serving the validated config ``cfg`` (``ValueError`` naming ``source`` and the
    known tasks when none does)."""
    for name in list_tasks():
        if _REGISTRY[name].matches(cfg):
            return _REGISTRY[name]
    raise ValueError(
        f"config: {source} (concept {getattr(cfg, 'concept', None)!r}, scenario "
        f"{getattr(cfg, 'scenario', None)!r}) has no environment; known tasks: {', '.join(list_tasks())}"
    )


def load(
    config: str | Path | Any,
    overrides: Sequence[str] = (),
    random: int | np.random.RandomState | None = None,
    **task_options: Any,
) -> control.Environment:
    """The environment of ``config``: a registered task name (``"cnusail/detumble"`` → its shipped
    config), a config file path or a validated config; ``overrides`` as ``--set``; ``random`` seeds
    the task; ``task_options`` go to the task (see each task's docstring)."""
    if isinstance(config, str) and (config in _REGISTRY or not (config.endswith(".toml") or Path(config).exists())):
        entry = task_entry(config)
        cfg = load_config(entry.config, list(overrides))
    elif isinstance(config, (str, Path)):
        cfg = load_config(config, list(overrides))
        entry = entry_for_config(cfg, str(config))
    else:
        cfg = parse_config(apply_overrides(config.model_dump(mode="json"), list(overrides))) if overrides else config
        entry = entry_for_config(cfg, "the given config")
    return entry.factory(cfg, random=random, **task_options)


def make_environment(
    cfg: Any,
    task_cls: type[AttitudeTask],
    *,
    random: Any = None,
    period_s: float | None = None,
    time_limit_s: float | None = None,
    **task_options: Any,
) -> control.Environment:
    """Build ``cfg``'s simulation, the task and the Environment (``control_timestep`` = the
    controller period, ``time_limit`` = ``sim.duration_s`` unless given)."""
    epoch_range_s = float(task_options.pop("epoch_range_s", 0.0))
    if not (math.isfinite(epoch_range_s) and epoch_range_s >= 0):
        raise ValueError(f"epoch_range_s: must be a finite number >= 0 s, got {epoch_range_s!r}")
    if epoch_range_s > 0 and not getattr(getattr(cfg, "orbit", None), "enabled", False):
        raise ValueError("epoch_range_s: this config has no orbit (orbit.enabled = true) whose epoch could be drawn")
    base = magsail_mj.load(cfg)
    task = task_cls(base, random=random, **task_options)
    task.epoch_range_s = epoch_range_s
    task._build = (cfg, task_cls, dict(task_options), period_s)
    period = float(period_s if period_s is not None else task.period_s)
    physics = SimulationPhysics(base, _action_controller(task, base, period))
    task.bind(physics)
    limit = float(time_limit_s if time_limit_s is not None else base.duration_s)
    return control.Environment(physics, task, time_limit=limit, control_timestep=period)


def _action_controller(task: AttitudeTask, base: Simulation, period_s: float) -> ActionController:
    return ActionController(
        period_s=period_s,
        convert=task.converter.command,
        action=task.neutral_action(),
        end_time_s=base.n_steps * float(base.model.opt.timestep),
    )


def redraw_epoch(task: AttitudeTask, physics: SimulationPhysics) -> str:
    """Rebuild the episode's simulation at an epoch ``orbit.epoch + U(0, epoch_range_s)`` drawn with
    the task's random state (the orbit, field and Sun tables are built for the epoch): the physics
    and the task are re-initialised in place (the Environment keeps both objects). Returns the
    drawn epoch (ISO 8601)."""
    cfg0, task_cls, options, period_s = task._build
    epoch = parse_epoch(cfg0.orbit.epoch) + timedelta(seconds=float(task.random.uniform(0.0, task.epoch_range_s)))
    iso = epoch.isoformat()
    cfg = parse_config(apply_overrides(cfg0.model_dump(mode="json"), [f"orbit.epoch={json.dumps(iso)}"]))
    base = magsail_mj.load(cfg)
    fresh = task_cls(base, random=task.random, **options)
    task.__dict__.update({k: v for k, v in fresh.__dict__.items() if k not in ("_random", "epoch_range_s", "_build")})
    period = float(period_s if period_s is not None else task.period_s)
    physics.__init__(base, _action_controller(task, base, period))
    task.bind(physics)
    return iso


# =========================================================================== shipped policy


class _ShippedPolicy:
    """The shipped controller as a policy: at each time step, a fresh-per-episode copy of the
    scenario's controller samples the physics state and the task maps its command to an action."""

    def __init__(self, env: control.Environment) -> None:
        self.env = env
        self.physics: SimulationPhysics = env.physics
        self.task: AttitudeTask = env.task
        self._template = self.physics.base.controller
        if self._template is None:
            raise ValueError(f"env: the scenario of {type(self.task).__name__} has no shipped controller")
        self.controller: Any = None

    def __call__(self, time_step: dm_env.TimeStep) -> np.ndarray:
        if time_step.first() or self.controller is None:
            self.controller = self.task.fresh_shipped_controller(self.physics)
            self.physics.controller.hooks.final_action = self._final_action
        return self.task.shipped_action(self.physics, self.controller, self.physics.step_state())

    def _final_action(self, state: StepState) -> np.ndarray:
        return self.task.prepare_action(self.task.shipped_action(self.physics, self.controller, state))


def shipped_policy(env: control.Environment) -> Callable[[dm_env.TimeStep], np.ndarray]:
    """The scenario's own controller as a policy ``time_step → action``: run through ``env`` it
    gives the figures of ``magsail run`` of the same config (the episode must start from the
    config's state, ``randomize=False``)."""
    return _ShippedPolicy(env)


def run_episode(env: control.Environment, policy: Callable[[dm_env.TimeStep], Any]) -> tuple[float, int]:
    """Reset ``env`` and run ``policy`` (``time_step → action``) to the episode's end; returns the
    undiscounted return and the number of environment steps."""
    time_step = env.reset()
    total, n = 0.0, 0
    while not time_step.last():
        time_step = env.step(policy(time_step))
        total += float(time_step.reward)
        n += 1
    return total, n


WALL_CLOCK_KEYS = ("wall_time_s", "step_cost_us", "wall_time_per_step_s")
"""Summary keys that measure the computer, not the run (left out of comparisons)."""


def summary_mismatches(reference: Mapping[str, Any], got: Mapping[str, Any], *, rel: float = 1e-9) -> list[str]:
    """Keys of ``reference`` whose value ``got`` lacks or differs from: numbers beyond ``rel``
    relative (``|a − b| ≤ rel · |a|``; NaN equals NaN, equal infinities match), anything else
    unequal; the wall-clock keys (:data:`WALL_CLOCK_KEYS`) are skipped."""
    out = []
    for key, a in reference.items():
        if key in WALL_CLOCK_KEYS:
            continue
        if key not in got:
            out.append(f"{key}: missing")
            continue
        b = got[key]
        if isinstance(a, (int, float, np.number)) and not isinstance(a, bool):
            a, b = float(a), float(b)
            same = a == b or (math.isnan(a) and math.isnan(b)) or abs(a - b) <= rel * abs(a)
        else:
            same = bool(np.all(np.asarray(a, dtype=object) == np.asarray(b, dtype=object))) if a is not b else True
        if not same:
            out.append(f"{key}: {a!r} != {b!r}")
    return out
