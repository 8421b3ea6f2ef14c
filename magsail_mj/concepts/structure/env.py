r"""Environment of the ``structure`` concept: ``structure/detumble``, any structure with magnetorquer
rods under the config's attitude law (B-dot for ``scenario = "detumble"``, quaternion PD for
``scenario = "slew"``; both scenarios are served, ``free`` has no actuator and is refused).

Spacecraft: the config's structure (a structure file, mesh, Nastran deck or inline tables) built by
:mod:`magsail_mj.concepts.structure.model`, with one rod along each member of
``actuators.member_set``. The shipped controller
(:class:`~magsail_mj.concepts.structure.control.StructureRodController`) fits the best rigid
rotation ``R`` (body → world, Kabsch) to the node positions, differences it into the body rate,
computes a reference torque ``T_ref`` (body axes), turns it into the dipole
``m = B_b × T_ref / |B_b|²`` and shares that over the rods by the least-norm activations
``u = D⁺ m`` (``D`` the rods' largest dipoles along their reference axes), all scaled down
together when some ``|u_r|`` would pass 1 (saturated).

Actions (``action`` task option; every action goes through the same estimation, and its command is
the held :class:`~magsail_mj.concepts.structure.control.DipoleCommand` the rods, probes and records
read):

* ``"torque"`` (default) — ``T_ref`` [N m], body axes, (3,), through the shipped allocation; bounds
  ``±T_max`` per axis with ``T_max = Σ_r m_max,r · B_bound`` (the torque of every rod at full
  dipole in a field of ``B_bound`` = 1e-4 T, above any LEO field). Not clipped: the allocation
  saturates a larger request (the component along ``B_b`` cannot be made and is dropped).
* ``"dipole"`` — the total dipole ``m`` [A m²], body axes, (3,): activations ``u = D⁺ m``, scaled
  down together when one passes 1; bounds ``±Σ_r m_max,r |r̂_r,i|`` per body axis ``i`` (the
  largest dipole the rods make along it; 0 across a plane holding every rod). Not clipped: the
  allocation saturates it. The command's ``torque_ref_body`` is ``m × B_b``.
* ``"rods"`` — one activation ``u_r ∈ [−1, 1]`` per rod (member order of the set), clipped;
  the dipole is ``D u`` and ``torque_ref_body`` the torque it makes, ``(D u) × B_b``.

Observations (from the node positions ``x_i`` of the current state; reference positions ``p_i``):

* ``attitude_wxyz`` (4,) body → world quaternion of the best-fit rotation ``R`` (``w ≥ 0``);
* ``body_rate_rad_s`` (3,) ``vee(log(R_prevᵀ R)) / Δt`` over the last environment step (the
  episode's initial rate at the start), body axes;
* ``field_body_T`` (3,) the field at the reference point in body axes, ``Rᵀ B`` [T];
* ``target_wxyz`` (4,) ``control.q_ref_wxyz`` (slew configs only);
* ``shape_rms_m``, ``shape_max_m`` (1,) RMS and largest node deviation ``|x_i − (R p_i + d)|``
  from the best-fit rigid placement [m];
* ``strain_max`` (1,) largest member strain ``|l/l0 − 1|`` (a slack cable counts 0) and
  ``strain_ratio_max`` (1,) the largest ratio of a member's strain to its limit
  ``min(strain_limit, sim.max_strain)`` (1: the structure fails).

Every observation is computed at every step (one 3 × 3 SVD and one pass over the nodes and members).

Reward (:mod:`magsail_mj.envs.core`): θ the angle from the best-fit attitude to
``control.q_ref_wxyz`` (slew; 0 for a detumble), ω = ``|body_rate_rad_s|``, ω_s =
``control.rate_threshold_rad_s``, effort of the normalised action, strain = ``strain_ratio_max``
(the member nearest its limit, against that limit).

Termination: a member past its limit ends the run with status ``structure_failed`` at the next
record (the scenario's own check, every ``sim.record_every`` steps), the episode with discount 0;
a divergence likewise; the time limit ``sim.duration_s`` with discount 1.

Episode start (``randomize=True``): body rates uniform per axis in ``±rate_range_rad_s`` (detumble
default: ``|initial.omega0_rad_s|``, or 10 × ``control.rate_threshold_rad_s`` for a config that
starts at rest; slew default 1e-4 rad/s), attitude ``initial.q0_wxyz`` turned about a uniformly
drawn axis by an angle uniform in ``[0, attitude_range_deg]`` (detumble default 180°, slew 10°),
rigid and undeformed about the centre of mass as the scenario's own start
(:func:`~magsail_mj.concepts.structure.model.rigid_initial_state`). A structure with fixed
components cannot be set spinning: ``randomize=True`` is refused for it. The epoch is the config's,
or drawn with the task option ``epoch_range_s`` (orbit configs).

``control_timestep`` = ``control.period_s`` (default ``sim.timestep_s``); ``time_limit`` =
``sim.duration_s``.
"""

from __future__ import annotations

import copy
import math
from types import SimpleNamespace
from typing import Any

import numpy as np

from magsail_mj.concepts.structure.control import DipoleCommand, StructureRodController
from magsail_mj.concepts.structure.model import rigid_initial_state
from magsail_mj.control.rod_attitude import step_rate
from magsail_mj.envs.core import (
    AttitudeTask,
    SimulationPhysics,
    draw_rigid_start,
    make_environment,
    pointing_error_rad,
    register,
)
from magsail_mj.loads.base import StepState
from magsail_mj.quaternion import error_quaternion, quat_from_matrix
from magsail_mj.vec3 import cross3

__all__ = ["StructureRodsTask", "ActionDipoleConverter", "B_BOUND_T", "ACTIONS", "SERVED_SCENARIOS"]

B_BOUND_T = 1e-4
"""Field magnitude bounding the torque action [T] (above any LEO geomagnetic field)."""

ACTIONS = ("torque", "dipole", "rods")
"""The action modes (module docstring)."""

SERVED_SCENARIOS = ("detumble", "slew")
"""The scenarios with rods and a controller, which the environment serves."""

_IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


class ActionDipoleConverter:
    """The held rod command of an action (module docstring), through a private copy of the shipped
    controller's estimation (best-fit rotation, backward-difference rate, centre of mass) and
    allocation.

    Args:
      shipped: the scenario's controller in its initial state (copied: the copy's rate memory and
        sample counts are the converter's, part of the simulation's checkpointed state).
      mode: ``"torque"``, ``"dipole"`` or ``"rods"``.
    """

    def __init__(self, *, shipped: StructureRodController, mode: str) -> None:
        if mode not in ACTIONS:
            raise ValueError(f"action: must be one of {', '.join(map(repr, ACTIONS))}, got {mode!r}")
        self.law = copy.deepcopy(shipped)
        self.mode = mode

    def dipole_activations(self, dipole_body_Am2: np.ndarray) -> tuple[np.ndarray, bool]:
        """``(u, saturated)``: the least-norm activations ``u = D⁺ m`` of the dipole ``m`` [A m²],
        all divided by ``max |u_r|`` when that passes 1."""
        u = self.law.allocation.D_pinv @ np.asarray(dipole_body_Am2, dtype=float)
        u_max = float(np.max(np.abs(u))) if u.size else 0.0
        if u_max > 1.0:
            return u / u_max, True
        return u, False

    def command(self, state: StepState, action: np.ndarray) -> DipoleCommand:
        """The :class:`DipoleCommand` of ``action`` at ``state`` (one control sample)."""
        law = self.law
        if state.env is None:
            raise ValueError("state.env: the rod command needs an environment sample (B_eci)")
        R, omega, com = law.estimate(state)
        B_body = R.T @ np.asarray(state.env.B_eci, dtype=float)
        q_e = _IDENTITY.copy() if law.q_ref is None else error_quaternion(law.q_ref, quat_from_matrix(R))
        a = np.array(action, dtype=float)
        if self.mode == "torque":
            T_ref = a
            u, saturated = law.allocation(T_ref, B_body)
        elif self.mode == "dipole":
            T_ref = cross3(a, B_body)
            u, saturated = self.dipole_activations(a)
        else:
            u, saturated = a, False
        dipole = law.allocation.D @ u
        torque = cross3(dipole, B_body)
        if self.mode == "rods":
            T_ref = torque.copy()
        law.stats[0] += 1
        law.stats[1] += saturated
        return DipoleCommand(
            t=float(state.t),
            activation=u,
            torque_ref_body=np.asarray(T_ref, dtype=float),
            torque_alloc_body=torque,
            dipole_body=dipole,
            saturated=bool(saturated),
            R=R,
            omega_body=omega,
            B_body=B_body,
            com_world=com,
            q_err=np.asarray(q_e, dtype=float),
            counts=law.stats.copy(),
        )


class StructureRodsTask(AttitudeTask):
    """Detumble or slew of a structure through its rods (module docstring: action, observation,
    reward, termination, episode start).

    Args:
      base: the config's simulation (:func:`magsail_mj.load`).
      random, randomize, reward_weights: see :class:`~magsail_mj.envs.core.AttitudeTask`.
      action: ``"torque"`` (default), ``"dipole"`` or ``"rods"``.
      rate_range_rad_s: half-width of the initial rate draw per axis [rad/s].
      attitude_range_deg: largest angle of the initial attitude turn [deg].
    """

    def __init__(
        self,
        base: Any,
        random: Any = None,
        *,
        action: str = "torque",
        randomize: bool = True,
        rate_range_rad_s: float | None = None,
        attitude_range_deg: float | None = None,
        reward_weights: Any = None,
    ) -> None:
        super().__init__(random, randomize=randomize, reward_weights=reward_weights)
        sc = base.scenario
        self.cfg, self.scenario = base.cfg, sc
        shipped = base.controller
        if not isinstance(shipped, StructureRodController):
            raise ValueError(
                f"config: scenario {self.cfg.scenario!r} has no rod controller; the environment serves "
                f"{', '.join(map(repr, SERVED_SCENARIOS))}"
            )
        if getattr(self.cfg, "loops", None) is not None:
            raise ValueError(
                "config: loops: the environment drives the rods only; a config with current loops "
                "([loops]) would run with its loops switched off"
            )
        self.converter = ActionDipoleConverter(shipped=shipped, mode=action)
        self.mode = action
        self.period_s = float(shipped.period_s)
        self.slew = shipped.q_ref is not None
        self.q_ref = None if shipped.q_ref is None else np.array(shipped.q_ref, dtype=float)
        self.rate_scale_rad_s = float(self.cfg.control.rate_threshold_rad_s)
        omega0 = float(np.linalg.norm(self.cfg.initial.omega0_rad_s))
        detumble_rate = omega0 if omega0 > 0 else 10.0 * self.rate_scale_rad_s
        default_rate, default_angle = (1e-4, 10.0) if self.slew else (detumble_rate, 180.0)
        self.rate_range = float(default_rate if rate_range_rad_s is None else rate_range_rad_s)
        angle_deg = float(default_angle if attitude_range_deg is None else attitude_range_deg)
        for name, value in (("rate_range_rad_s", self.rate_range), ("attitude_range_deg", angle_deg)):
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name}: must be a finite number >= 0, got {value!r}")
        self.attitude_range = math.radians(angle_deg)
        if self.randomize and np.any(sc.sm.structure.fixed_dofs):
            raise ValueError(
                "randomize: the structure holds components in place (structure.fixed), so its start "
                "cannot be drawn spinning or turned; use randomize=False"
            )
        self.monitor = sc.monitor  # its fit, strain and limits (pure functions of a state)
        allocation = self.converter.law.allocation
        dipole_max = np.asarray(sc.sm.rod_dipole_max_Am2, dtype=float)
        if action == "torque":
            self.clip_actions = False
            t_max = float(dipole_max.sum()) * B_BOUND_T
            self._set_action_bounds(("T_x_Nm", "T_y_Nm", "T_z_Nm"), np.full(3, -t_max), np.full(3, t_max))
        elif action == "dipole":
            self.clip_actions = False
            m_max = np.abs(allocation.D).sum(axis=1)
            self._set_action_bounds(("m_x_Am2", "m_y_Am2", "m_z_Am2"), -m_max, m_max)
        else:
            names = tuple(f"u_member{j}" for j in np.asarray(sc.sm.rod_members).tolist())
            self._set_action_bounds(names, -np.ones(len(names)), np.ones(len(names)))
        self._memory = SimpleNamespace(R=None, t=0.0, omega=np.zeros(3))

    # ------------------------------------------------------------------ episode start
    def initialize_episode(self, physics: SimulationPhysics) -> None:
        super().initialize_episode(physics)
        omega0 = self.start.get("omega0_body_rad_s", np.asarray(self.cfg.initial.omega0_rad_s, dtype=float))
        self._memory = SimpleNamespace(R=None, t=0.0, omega=np.array(omega0, dtype=float))

    def draw_start(self, physics: SimulationPhysics) -> dict[str, Any]:
        """Rates uniform in ±rate_range per axis, attitude q0 ⊗ turn; the rigid, undeformed start of
        the scenario (:func:`~magsail_mj.concepts.structure.model.rigid_initial_state`)."""
        q, omega = draw_rigid_start(
            self.random,
            q0_wxyz=np.asarray(self.cfg.initial.q0_wxyz, dtype=float),
            rate_range_rad_s=self.rate_range,
            attitude_range_rad=self.attitude_range,
        )
        rigid_initial_state(self.scenario.sm, physics.data, q0_wxyz=q, omega0_body_rad_s=omega)
        self.converter.law.omega0_body[:] = omega
        return {"omega0_body_rad_s": omega, "q0_wxyz": q}

    # ------------------------------------------------------------------ observations
    def observe(self, physics: SimulationPhysics, state: StepState) -> dict[str, np.ndarray]:
        mon, mem = self.monitor, self._memory
        x = mon.node_positions(state)
        R, d = mon.fit(x)
        t = float(state.t)
        if mem.R is not None and t > mem.t:
            mem.omega = step_rate(mem.R, R, t - mem.t, "log")
        if mem.R is None or t > mem.t:
            mem.R, mem.t = R, t
        e = x - (mon.reference_m @ R.T + d)
        dev = np.sqrt(np.einsum("ij,ij->i", e, e))
        strain = mon.strains(x)
        counted = np.where(mon.cable, np.maximum(strain, 0.0), np.abs(strain))
        q = quat_from_matrix(R)
        obs = {
            "attitude_wxyz": -q if q[0] < 0 else q,
            "body_rate_rad_s": np.array(mem.omega, dtype=float),
            "field_body_T": R.T @ np.asarray(state.env.B_eci, dtype=float),
        }
        if self.slew:
            obs["target_wxyz"] = self.q_ref.copy()
        obs["shape_rms_m"] = np.array([math.sqrt(float(np.mean(dev * dev)))])
        obs["shape_max_m"] = np.array([float(dev.max())])
        obs["strain_max"] = np.array([float(counted.max()) if counted.size else 0.0])
        obs["strain_ratio_max"] = np.array([float((counted / mon.limit).max()) if counted.size else 0.0])
        return obs

    def reward_terms(self, physics: SimulationPhysics) -> dict[str, float]:
        obs = self.current_observation(physics)
        theta = pointing_error_rad(obs["attitude_wxyz"], self.q_ref) if self.slew else 0.0
        return {
            "theta_rad": theta,
            "omega_rad_s": float(np.linalg.norm(obs["body_rate_rad_s"])),
            "strain": float(obs["strain_ratio_max"][0]),
        }

    # ------------------------------------------------------------------ shipped controller
    def shipped_action(self, physics: SimulationPhysics, controller: Any, state: StepState) -> np.ndarray:
        """Torque mode: the shipped ``T_ref``; dipole mode: the shipped dipole ``D u``; rods mode:
        the shipped activations ``u``."""
        cmd = controller.update(state)
        if self.mode == "torque":
            return np.asarray(cmd.torque_ref_body, dtype=float)
        if self.mode == "dipole":
            return np.asarray(cmd.dipole_body, dtype=float)
        return np.asarray(cmd.activation, dtype=float)


def _serves(cfg: Any) -> bool:
    return getattr(cfg, "concept", None) == "structure" and getattr(cfg, "scenario", None) in SERVED_SCENARIOS


@register(
    "structure/detumble",
    config="magsail_mj/concepts/structure/configs/sail_detumble.toml",
    matches=_serves,
)
def structure_detumble(cfg: Any, *, random: Any = None, **options: Any):
    """Any structure through its rods under B-dot (detumble configs) or quaternion PD (slew
    configs) (:class:`StructureRodsTask`)."""
    return make_environment(cfg, StructureRodsTask, random=random, **options)
