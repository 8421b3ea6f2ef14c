r"""Environment of the ``structure`` concept: ``structure/detumble``, any structure with magnetorquer
rods and/or current loops under the config's attitude law (B-dot for ``scenario = "detumble"``,
quaternion PD for ``scenario = "slew"``; both scenarios are served, ``free`` has no actuator and is
refused).

Spacecraft: the config's structure (a structure file, mesh, Nastran deck or inline tables) built by
:mod:`magsail_mj.concepts.structure.model`, with one rod along each member of
``actuators.member_set`` and one current loop along each member set of ``loops.member_sets``
(either or both). The shipped controller
(:class:`~magsail_mj.concepts.structure.control.StructureRodController`) fits the best rigid
rotation ``R`` (body → world, Kabsch) to the node positions, differences it into the body rate,
computes a reference torque ``T_ref`` (body axes), turns it into the dipole
``m = B_b × T_ref / |B_b|²`` and shares that over the actuators by the least-norm activations
``v = D⁺ m``, all scaled down together when some ``|v_k|`` would pass 1 (saturated). ``D``
(3 × (R + L)) holds the rods' largest dipoles ``m_max,r r̂_r`` along their reference axes, then the
loops' ``I_max,L Rᵀ a_L`` with their vector areas ``a_L = ½ Σ x_a × x_b`` at the sampled node
positions (``v_L = I_L / I_max,L``); with loops ``D⁺`` is formed at every sample and leaves out the
directions ``D`` makes at under
:data:`~magsail_mj.concepts.structure.control.LOOP_PINV_RCOND` of its strongest
(:meth:`~magsail_mj.concepts.structure.control.StructureRodController.actuator_matrix`).

Actions (``action`` task option; every action goes through the same estimation, and its command is
the held :class:`~magsail_mj.concepts.structure.control.DipoleCommand` the rods, loops, probes and
records read). ``D_0`` below is ``D`` at the reference shape and attitude (``a_L`` of the
undeformed structure, body axes):

* ``"torque"`` (default) — ``T_ref`` [N m], body axes, (3,), through the shipped allocation over
  rods and loops; bounds ``±T_max`` per axis with
  ``T_max = (Σ_r m_max,r + Σ_L I_max,L |a_L|) · B_bound`` (the torque of every actuator at full
  dipole in a field of ``B_bound`` = 1e-4 T, above any LEO field). Not clipped: the allocation
  saturates a larger request (the component along ``B_b`` cannot be made and is dropped).
* ``"dipole"`` — the total dipole ``m`` [A m²], body axes, (3,): activations ``v = D⁺ m`` (the
  shipped pseudo-inverse), scaled down together when one passes 1; bounds ``±Σ_k |D_0,ik|`` per
  body axis ``i`` (the largest dipole the actuators make along it; 0 along an axis none makes a
  dipole along: across a plane holding every rod, in the plane of a flat structure's loops — a
  bound under :data:`DIPOLE_BOUND_RTOL` of the largest is rounding and set to 0 — and a request
  along it dropped). Not clipped: the allocation saturates it. The command's ``torque_ref_body`` is ``m × B_b``.
* ``"rods"`` (rods and no loops) — one activation ``u_r ∈ [−1, 1]`` per rod (member order of the
  set), clipped; the dipole is ``D u`` and ``torque_ref_body`` the torque it makes,
  ``(D u) × B_b``. Refused for a config without rods, and for one with loops (they would stay
  off; ``"currents"`` sets both).
* ``"currents"`` (configs with loops) — one value ``I_L / I_max,L ∈ [−1, 1]`` per loop (order of
  ``loops.member_sets``), then, with rods, one activation ``u_r ∈ [−1, 1]`` per rod (as
  ``"rods"``), clipped; the loop currents are ``I_L = value · I_max,L`` [A], the dipole ``D v``
  and ``torque_ref_body`` the torque it makes. Refused for a config without loops.

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
  ``min(strain_limit, sim.max_strain)`` (1: the structure fails);
* ``loop_currents_A`` (L,) (configs with loops) the loop currents ``I_L`` [A] of the held command,
  the ones that flowed over the last environment step (zero at the episode's start).

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

from magsail_mj.concepts.structure.control import (
    LOOP_PINV_RCOND,
    DipoleCommand,
    StructureRodController,
    least_norm_activations,
)
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

__all__ = [
    "StructureRodsTask",
    "ActionDipoleConverter",
    "B_BOUND_T",
    "DIPOLE_BOUND_RTOL",
    "ACTIONS",
    "SERVED_SCENARIOS",
]

B_BOUND_T = 1e-4
"""Field magnitude bounding the torque action [T] (above any LEO geomagnetic field)."""

DIPOLE_BOUND_RTOL = 1e-9
"""A dipole bound below this fraction of the largest is rounding and taken as 0: the in-plane
components of a flat structure's loop vector areas, sums of products of node coordinates (measured:
7e-13 A m² against 1.6e5 A m² on the 100 m reflector, 4e-18)."""

ACTIONS = ("torque", "dipole", "rods", "currents")
"""The action modes (module docstring)."""

SERVED_SCENARIOS = ("detumble", "slew")
"""The scenarios with actuators (rods, current loops) and a controller, which the environment serves."""

_IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


class ActionDipoleConverter:
    """The held rod and loop command of an action (module docstring), through a private copy of
    the shipped controller's estimation (best-fit rotation, backward-difference rate, centre of
    mass) and allocation.

    Args:
      shipped: the scenario's controller in its initial state (copied: the copy's rate memory and
        sample counts are the converter's, part of the simulation's checkpointed state).
      mode: ``"torque"``, ``"dipole"``, ``"rods"`` or ``"currents"``.
    """

    def __init__(self, *, shipped: StructureRodController, mode: str) -> None:
        if mode not in ACTIONS:
            raise ValueError(f"action: must be one of {', '.join(map(repr, ACTIONS))}, got {mode!r}")
        self.law = copy.deepcopy(shipped)
        self.mode = mode
        self.n_rods = int(self.law.allocation.D.shape[1])
        loops = self.law.loops
        self.current_max_A = np.zeros(0) if loops is None else np.asarray(loops.loops.current_max_A, dtype=float)

    @staticmethod
    def dipole_activations(D_pinv: np.ndarray, dipole_body_Am2: np.ndarray) -> tuple[np.ndarray, bool]:
        """``(v, saturated)``: the least-norm activations ``v = D⁺ m`` of the dipole ``m`` [A m²],
        all divided by ``max |v_k|`` when that passes 1."""
        v = D_pinv @ np.asarray(dipole_body_Am2, dtype=float)
        v_max = float(np.max(np.abs(v))) if v.size else 0.0
        if v_max > 1.0:
            return v / v_max, True
        return v, False

    def command(self, state: StepState, action: np.ndarray) -> DipoleCommand:
        """The :class:`DipoleCommand` of ``action`` at ``state`` (one control sample)."""
        law = self.law
        if state.env is None:
            raise ValueError("state.env: the rod command needs an environment sample (B_eci)")
        R, omega, com = law.estimate(state)
        B_body = R.T @ np.asarray(state.env.B_eci, dtype=float)
        q_e = _IDENTITY.copy() if law.q_ref is None else error_quaternion(law.q_ref, quat_from_matrix(R))
        a = np.array(action, dtype=float)
        looped = law.loops is not None
        D = law.actuator_matrix(state, R)  # the rods' D alone without loops
        if self.mode == "torque":
            T_ref = a
            if looped:
                v, saturated = least_norm_activations(np.linalg.pinv(D, rcond=LOOP_PINV_RCOND), T_ref, B_body)
            else:
                v, saturated = law.allocation(T_ref, B_body)
        elif self.mode == "dipole":
            T_ref = cross3(a, B_body)
            D_pinv = np.linalg.pinv(D, rcond=LOOP_PINV_RCOND) if looped else law.allocation.D_pinv
            v, saturated = self.dipole_activations(D_pinv, a)
        elif self.mode == "rods":
            v, saturated = a, False
        else:  # currents: the loops' values first, then the rods'
            n_loops = self.current_max_A.size
            v, saturated = np.concatenate([a[n_loops:], a[:n_loops]]), False
        dipole = D @ v
        torque = cross3(dipole, B_body)
        if self.mode in ("rods", "currents"):
            T_ref = torque.copy()
        u, currents = v[: self.n_rods], v[self.n_rods :] * self.current_max_A
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
            currents_A=currents,
        )


class StructureRodsTask(AttitudeTask):
    """Detumble or slew of a structure through its rods and current loops (module docstring:
    action, observation, reward, termination, episode start).

    Args:
      base: the config's simulation (:func:`magsail_mj.load`).
      random, randomize, reward_weights: see :class:`~magsail_mj.envs.core.AttitudeTask`.
      action: ``"torque"`` (default), ``"dipole"``, ``"rods"`` (rods, no loops) or ``"currents"``
        (loops, and the rods after them).
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
                f"config: scenario {self.cfg.scenario!r} has no actuator controller; the environment serves "
                f"{', '.join(map(repr, SERVED_SCENARIOS))}"
            )
        self.converter = ActionDipoleConverter(shipped=shipped, mode=action)
        loops = sc.sm.loops
        n_rods = int(np.asarray(sc.sm.rod_members).size)
        if action == "rods" and not n_rods:
            raise ValueError(
                "action: 'rods' drives magnetorquer rods and the config has none (actuators.member_set); "
                "use 'currents' for its current loops"
            )
        if action == "rods" and loops is not None:
            raise ValueError(
                "action: 'rods' would leave the config's current loops ([loops]) off; use 'currents', "
                "which sets the loops' currents and then the rods' activations"
            )
        if action == "currents" and loops is None:
            raise ValueError(
                "action: 'currents' sets current loops and the config has none ([loops]); use 'rods' for its rods"
            )
        self.n_loops = 0 if loops is None else int(loops.n_loops)
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
        D_ref = self.converter.law.allocation.D
        dipole_max = np.asarray(sc.sm.rod_dipole_max_Am2, dtype=float)
        loop_dipole_max = np.zeros(0)
        if loops is not None:  # the loops' columns I_max,L a_L at the reference shape, body axes
            loop_columns = (loops.vector_areas(sc.sm.structure.positions_m) * loops.current_max_A[:, None]).T
            D_ref = np.hstack([D_ref, loop_columns])
            loop_dipole_max = np.linalg.norm(loop_columns, axis=0)
        rod_names = tuple(f"u_member{j}" for j in np.asarray(sc.sm.rod_members).tolist())
        if action == "torque":
            self.clip_actions = False
            t_max = (float(dipole_max.sum()) + float(loop_dipole_max.sum())) * B_BOUND_T
            self._set_action_bounds(("T_x_Nm", "T_y_Nm", "T_z_Nm"), np.full(3, -t_max), np.full(3, t_max))
        elif action == "dipole":
            self.clip_actions = False
            m_max = np.abs(D_ref).sum(axis=1)
            m_max[m_max <= DIPOLE_BOUND_RTOL * m_max.max(initial=0.0)] = 0.0
            self._set_action_bounds(("m_x_Am2", "m_y_Am2", "m_z_Am2"), -m_max, m_max)
        else:
            loop_names = () if action == "rods" else tuple(f"u_loop_{name}" for name in loops.names)
            names = loop_names + rod_names
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
        if self.n_loops:
            ctrl = state.ctrl
            held = None if ctrl is None else ctrl.currents_A
            obs["loop_currents_A"] = np.zeros(self.n_loops) if held is None else np.array(held, dtype=float)
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
        """Torque mode: the shipped ``T_ref``; dipole mode: the shipped dipole ``D v``; rods mode:
        the shipped activations ``u``; currents mode: the shipped ``I_L / I_max,L``, then ``u``."""
        cmd = controller.update(state)
        if self.mode == "torque":
            return np.asarray(cmd.torque_ref_body, dtype=float)
        if self.mode == "dipole":
            return np.asarray(cmd.dipole_body, dtype=float)
        if self.mode == "currents":
            return np.concatenate([cmd.currents_A / self.converter.current_max_A, cmd.activation])
        return np.asarray(cmd.activation, dtype=float)


def _serves(cfg: Any) -> bool:
    return getattr(cfg, "concept", None) == "structure" and getattr(cfg, "scenario", None) in SERVED_SCENARIOS


@register(
    "structure/detumble",
    config="magsail_mj/concepts/structure/configs/sail_detumble.toml",
    matches=_serves,
)
def structure_detumble(cfg: Any, *, random: Any = None, **options: Any):
    """Any structure through its rods and current loops under B-dot (detumble configs) or
    quaternion PD (slew configs) (:class:`StructureRodsTask`)."""
    return make_environment(cfg, StructureRodsTask, random=random, **options)
