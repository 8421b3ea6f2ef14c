r"""Environments of the truss with magnetorquer rods: ``truss/detumble`` and ``truss/slew_I`` … ``IV``.

Spacecraft: the flexible 75 m truss (particles joined by struts) with magnetorquer rods in the
top-layer x1/y1 struts (``concepts/truss_magnetorquer/orbital``). The shipped controllers (B-dot, quaternion
feedback) compute a reference torque ``T_ref`` (body axes) that the allocation (Eqs. 11–13) turns into
signed rod counts ``(N1, N2)`` and the Lloyd selection into rod polarities.

Actions (``action`` task option):

* ``"torque"`` (default) — ``T_ref`` [N m], body axes, (3,), through the rod allocation; bounds
  ``±T_max`` per axis with ``T_max = (N_max,1 m_1 + N_max,2 m_2) · B_bound`` (the torque of every
  rod of both families in a field of ``B_bound = 1e-4 T``, above any LEO field). A request beyond
  the bounds is not clipped: the allocation saturates it (every rod of a family on) exactly as it
  saturates the shipped controllers' requests (the B-dot law asks for tens of N m).
* ``"rods"`` — signed rod counts ``(N1, N2)`` of the two families, bounds ``±N_max,f``; rounded
  half away from zero to integers, then the Lloyd selection gives the polarities.

Observations (flight estimator: the best-fit rotation of the particle positions, and its
backward-difference rate over the last control period):

* ``attitude_wxyz`` (4,) body → world quaternion of the best-fit frame;
* ``body_rate_rad_s`` (3,) estimated body rate (the episode's initial rate before the first period);
* ``field_body_T`` (3,) geomagnetic field at the reference point, body axes [T];
* ``target_wxyz`` (4,) the slew target (slews only);
* ``surface_sd_m`` (1,) top-surface standard deviation about its best-fit plane [m] and
  ``strain_max`` (1,) largest |strut strain| (structural health), refreshed every
  ``health_every`` environment steps (default 10) and held in between.

Reward (``magsail_mj.envs.core``): θ is the error angle to the slew target (0 for the detumble),
ω = |body_rate_rad_s|, ω_s = 1e-3 rad/s (the detumble threshold), effort of the normalised
action, strain ε_max/``sim.max_strain``.

Episode start (``randomize=True``): rates uniform per body axis in ``±rate_range_rad_s``
(default 0.01 rad/s, the detumble's initial magnitude; slews: 1e-4 rad/s); attitude: the config's
initial attitude turned by a rotation about a uniformly drawn axis through an angle uniform in
``[0, attitude_range_deg]`` (detumble default 180°, slews 10°); rigid, unstressed start as the
scenario's own. The epoch is the config's, or, with the task option ``epoch_range_s`` > 0,
``orbit.epoch`` + U(0, epoch_range_s) drawn first (the simulation is rebuilt for it each episode).

``control_timestep`` = ``control.period_s`` (default δt); ``time_limit`` = ``sim.duration_s``.
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np

from magsail_mj.analysis.flatness import surface_sd
from magsail_mj.control.allocation import Allocation, rod_torques, round_half_away
from magsail_mj.control.rod_attitude import RodAttitudeController, RodCommand, step_rate
from magsail_mj.envs.core import (
    AttitudeTask,
    SimulationPhysics,
    draw_rigid_start,
    make_environment,
    pointing_error_rad,
    register,
    set_rigid_motion,
)
from magsail_mj.estimation.attitude import BestFitRotation
from magsail_mj.loads.base import StepState
from magsail_mj.quaternion import error_quaternion, quat_from_matrix

__all__ = [
    "TrussAttitudeTask",
    "ActionRodController",
    "B_BOUND_T",
    "rate_from_rotations",
    "ReusedFit",
    "quat_of_rotation",
]

B_BOUND_T = 1e-4
"""Field magnitude bounding the torque action [T] (above any LEO geomagnetic field)."""


def rate_from_rotations(R_prev: np.ndarray, R: np.ndarray, dt: float) -> np.ndarray:
    """Backward-difference body rate [rad/s] of two body → world rotations ``dt`` apart, as the rod
    controllers estimate it (:func:`magsail_mj.control.rod_attitude.step_rate`, method ``log``:
    ``ω = θ/sin θ · vee(R_prevᵀ R)/δt``)."""
    return step_rate(R_prev, R, dt, "log")


def quat_of_rotation(R: np.ndarray) -> np.ndarray:
    """Unit quaternion ``[w, x, y, z]`` (``w ≥ 0``) of one rotation matrix: the Shepperd /
    Bar-Itzhack construction of :func:`magsail_mj.quaternion.quat_from_matrix` (the column of
    ``K = 4 q qᵀ`` with the largest diagonal entry, normalised) in scalar arithmetic, for the
    per-step observation (the vectorised function costs tens of µs on one matrix)."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R.tolist()
    K = (
        (1 + r00 + r11 + r22, r21 - r12, r02 - r20, r10 - r01),
        (r21 - r12, 1 + r00 - r11 - r22, r01 + r10, r02 + r20),
        (r02 - r20, r01 + r10, 1 - r00 + r11 - r22, r12 + r21),
        (r10 - r01, r02 + r20, r12 + r21, 1 - r00 - r11 + r22),
    )
    diag = [K[0][0], K[1][1], K[2][2], K[3][3]]
    col = K[diag.index(max(diag))]  # K is symmetric: its column m is its row m
    norm = math.sqrt(col[0] * col[0] + col[1] * col[1] + col[2] * col[2] + col[3] * col[3])
    q = [c / norm for c in col]
    return np.array([-c for c in q] if q[0] < 0 else q)


class ReusedFit:
    """A :class:`~magsail_mj.estimation.attitude.BestFitRotation` that gives its last result again
    (copies) when called with node positions equal, element for element, to the last call's.

    The truss's observation after an environment step and the rod command at the start of the
    next step fit the same state, so the SVD runs once for both. The memo lives in a namespace,
    which the simulation's checkpoint walker does not enter: it is not part of the state, and a
    stale memo is never used (the positions must be equal)."""

    def __init__(self, fit: BestFitRotation) -> None:
        self.fit = fit
        self.memo = SimpleNamespace(pos=None, R=None, d=None)

    def __call__(self, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        memo = self.memo
        last = memo.pos
        if last is None or last.shape != pos.shape or not np.array_equal(last, pos):
            memo.R, memo.d = self.fit(pos)
            memo.pos = np.array(pos)
        return memo.R.copy(), memo.d.copy()


class ActionRodController(RodAttitudeController):
    """The shipped rod controllers' estimation and allocation with the reference torque given.

    ``reference_torque`` returns ``request`` (set by :meth:`command` from the action) and, for a
    slew, ``extra["q_err"] = q_ref* ⊗ q`` as the quaternion feedback law records it. ``rods`` mode
    bypasses the allocation: the signed counts select the rods directly.
    """

    def __init__(
        self, *, shipped: RodAttitudeController, reference_nodes: np.ndarray, q_ref_wxyz: np.ndarray | None, mode: str
    ) -> None:
        super().__init__(
            reference_nodes=reference_nodes,
            masses=shipped.masses,
            node_bodies=shipped.node_bodies,
            distributor=shipped.distributor,
            period_s=shipped.period_s,
            omega0_body=shipped.omega0_body,
            rate_method=shipped.rate_method,
        )
        self.q_ref = None if q_ref_wxyz is None else np.asarray(q_ref_wxyz, dtype=float)
        self.mode = mode
        self.request = np.zeros(3)

    def reference_torque(
        self, *, t: float, R: np.ndarray, omega_body: np.ndarray, B_body: np.ndarray, com_world: np.ndarray, env: Any
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """``(request, extra)``; extra holds ``q_err`` (4,) for a slew and ``gg_comp_body`` zeros."""
        extra: dict[str, Any] = {}
        if self.q_ref is not None:
            extra = {"q_err": error_quaternion(self.q_ref, quat_from_matrix(R)), "gg_comp_body": np.zeros(3)}
        return self.request.copy(), extra

    def command(self, state: StepState, action: np.ndarray) -> RodCommand:
        """The :class:`RodCommand` of ``action`` at ``state`` (torque or signed rod counts)."""
        if self.mode == "torque":
            self.request[:] = action
            return self.update(state)
        return self._rods_command(state, action)

    def _rods_command(self, state: StepState, action: np.ndarray) -> RodCommand:
        R, omega, xc = self.estimate(state)
        B_body = R.T @ np.asarray(state.env.B_eci, dtype=float)
        n1, n2 = (int(round_half_away(float(a))) for a in action)
        t1, t2 = rod_torques(B_body, m_rod_Am2=self.distributor.m_rod_Am2)
        al = Allocation(
            N1=n1,
            N2=n2,
            x1=float(n1),
            x2=float(n2),
            mode="direct",
            clipped1=False,
            clipped2=False,
            tau1_body=tuple(t1.tolist()),
            tau2_body=tuple(t2.tolist()),
        )
        polarity = self.distributor.selector.polarity((n1, n2))
        self._count(al)
        T = al.torque_body
        extra = self.reference_torque(
            t=float(state.t), R=R, omega_body=omega, B_body=B_body, com_world=xc, env=state.env
        )[1]
        return RodCommand(
            t=float(state.t),
            polarity=polarity,
            torque_ref_body=T,
            torque_alloc_body=T.copy(),
            N1=n1,
            N2=n2,
            clipped1=False,
            clipped2=False,
            R=R,
            omega_body=omega,
            B_body=B_body,
            com_world=xc,
            extra=extra,
            counts=self.stats.copy(),
        )


class TrussAttitudeTask(AttitudeTask):
    """Detumble or slew of the truss with magnetorquer rods (module docstring: action, observation,
    reward, episode start).

    Args:
      base: the config's simulation (:func:`magsail_mj.load`).
      random, randomize, reward_weights: see :class:`~magsail_mj.envs.core.AttitudeTask`.
      action: ``"torque"`` (default) or ``"rods"``.
      rate_range_rad_s: half-width of the initial rate draw per axis [rad/s].
      attitude_range_deg: largest angle of the initial attitude turn [deg].
      health_every: environment steps between refreshes of the structural-health observations.
    """

    rate_scale_rad_s = 1e-3

    def __init__(
        self,
        base: Any,
        random: Any = None,
        *,
        action: str = "torque",
        randomize: bool = True,
        rate_range_rad_s: float | None = None,
        attitude_range_deg: float | None = None,
        health_every: int = 10,
        reward_weights: Any = None,
    ) -> None:
        super().__init__(random, randomize=randomize, reward_weights=reward_weights)
        if action not in ("torque", "rods"):
            raise ValueError(f"action: must be 'torque' or 'rods', got {action!r}")
        if int(health_every) != health_every or health_every < 1:
            raise ValueError(f"health_every: must be an integer >= 1, got {health_every!r}")
        sc = base.scenario
        self.cfg, self.scenario = base.cfg, sc
        shipped = base.controller
        self.slew = self.cfg.scenario == "slew"
        self.q_ref = np.asarray(shipped.q_ref, dtype=float) if self.slew else None
        self.period_s = float(shipped.period_s)
        self.converter = ActionRodController(
            shipped=shipped, reference_nodes=sc.tm.lattice.nodes, q_ref_wxyz=self.q_ref, mode=action
        )
        self.mode = action
        default_rate, default_angle = (1e-4, 10.0) if self.slew else (0.01, 180.0)
        self.rate_range = float(default_rate if rate_range_rad_s is None else rate_range_rad_s)
        self.attitude_range = math.radians(default_angle if attitude_range_deg is None else attitude_range_deg)
        for name, value in (("rate_range_rad_s", self.rate_range), ("attitude_range_deg", self.attitude_range)):
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name}: must be a finite number >= 0, got {value!r}")
        self.health_every = int(health_every)
        self.node_slice = slice(1, sc.tm.lattice.n_nodes + 1)
        # the same nodes: one fit serves the observation and the command (ReusedFit)
        if isinstance(self.converter._sel, slice) and self.converter._sel == self.node_slice:
            self.fit = self.converter.fit = ReusedFit(self.converter.fit)
        else:
            self.fit = BestFitRotation(sc.tm.lattice.nodes)
        self.top = np.asarray(sc.tm.lattice.top_nodes) + 1
        n_max = np.asarray(shipped.distributor.n_max, dtype=float)
        self.clip_actions = action == "rods"
        if action == "torque":
            t_max = float(n_max @ np.asarray(shipped.distributor.m_rod_Am2)) * B_BOUND_T
            self._set_action_bounds(("T_x_Nm", "T_y_Nm", "T_z_Nm"), np.full(3, -t_max), np.full(3, t_max))
        else:
            self._set_action_bounds(("N1", "N2"), -n_max, n_max)
        self._obs_memory: dict[str, Any] = {}

    # ------------------------------------------------------------------ episode start
    def initialize_episode(self, physics: SimulationPhysics) -> None:
        super().initialize_episode(physics)
        omega0 = self.start.get("omega0_body_rad_s", np.asarray(self.cfg.initial.omega0_rad_s, dtype=float))
        self._obs_memory = {"R": None, "t": 0.0, "omega": np.array(omega0, dtype=float), "health": None, "n": 0}

    def draw_start(self, physics: SimulationPhysics) -> dict[str, Any]:
        """Rates uniform in ±rate_range per axis, attitude q0 ⊗ turn; rigid start (as the scenario's
        ``init_state``: x_i = p_c + R (p_i − p_c), v_i = R (ω × (p_i − p_c)))."""
        q, omega = draw_rigid_start(
            self.random,
            q0_wxyz=np.asarray(self.cfg.q0_wxyz, dtype=float),
            rate_range_rad_s=self.rate_range,
            attitude_range_rad=self.attitude_range,
        )
        set_rigid_motion(physics, q_wxyz=q, omega_body_rad_s=omega, masses=self.scenario.tm.masses)
        self.converter.omega0_body[:] = omega
        return {"omega0_body_rad_s": omega, "q0_wxyz": q}

    # ------------------------------------------------------------------ observations
    def _estimate(self, state: StepState) -> tuple[np.ndarray, np.ndarray]:
        mem = self._obs_memory
        R, _ = self.fit(state.pos[self.node_slice])
        if mem["R"] is not None and state.t > mem["t"]:
            mem["omega"] = rate_from_rotations(mem["R"], R, state.t - mem["t"])
        if mem["R"] is None or state.t > mem["t"]:
            mem["R"], mem["t"] = R, float(state.t)
        return R, mem["omega"]

    def _health(self, physics: SimulationPhysics, state: StepState) -> tuple[float, float]:
        mem = self._obs_memory
        if mem["health"] is None or mem["n"] % self.health_every == 0:
            strain, _ = physics.sim.strain_check(state.pos)
            mem["health"] = (surface_sd(state.pos[self.top]), float(strain))
        mem["n"] += 1
        return mem["health"]

    def observe(self, physics: SimulationPhysics, state: StepState) -> dict[str, np.ndarray]:
        R, omega = self._estimate(state)
        obs = {
            "attitude_wxyz": quat_of_rotation(R),
            "body_rate_rad_s": np.array(omega),
            "field_body_T": R.T @ np.asarray(state.env.B_eci, dtype=float),
        }
        if self.slew:
            obs["target_wxyz"] = self.q_ref.copy()
        sd, strain = self._health(physics, state)
        obs["surface_sd_m"] = np.array([sd])
        obs["strain_max"] = np.array([strain])
        return obs

    def reward_terms(self, physics: SimulationPhysics) -> dict[str, float]:
        obs = self.current_observation(physics)
        theta = pointing_error_rad(obs["attitude_wxyz"], self.q_ref) if self.slew else 0.0
        return {
            "theta_rad": theta,
            "omega_rad_s": float(np.linalg.norm(obs["body_rate_rad_s"])),
            "strain": float(obs["strain_max"][0]) / physics.sim.max_strain,
        }

    # ------------------------------------------------------------------ shipped controller
    def shipped_action(self, physics: SimulationPhysics, controller: Any, state: StepState) -> np.ndarray:
        """Torque mode: the shipped ``T_ref``; rods mode: the shipped signed counts ``(N1, N2)``."""
        cmd = controller.update(state)
        if self.mode == "torque":
            return np.asarray(cmd.torque_ref_body, dtype=float)
        return np.array([cmd.N1, cmd.N2], dtype=float)


def _is_truss(kind: str):
    def matches(cfg: Any) -> bool:
        return getattr(cfg, "concept", None) == "truss_magnetorquer" and getattr(cfg, "scenario", None) == kind

    return matches


def _factory(cfg: Any, *, random: Any = None, **options: Any):
    return make_environment(cfg, TrussAttitudeTask, random=random, **options)


for _name, _config, _kind in (
    ("truss/detumble", "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml", "detumble"),  # noqa: E501
    ("truss/slew_I", "magsail_mj/concepts/truss_magnetorquer/configs/slew_i.toml", "slew"),
    ("truss/slew_II", "magsail_mj/concepts/truss_magnetorquer/configs/slew_ii.toml", "slew"),
    ("truss/slew_III", "magsail_mj/concepts/truss_magnetorquer/configs/slew_iii.toml", "slew"),  # noqa: E501
    ("truss/slew_IV", "magsail_mj/concepts/truss_magnetorquer/configs/slew_iv.toml", "slew"),
):
    register(_name, config=_config, matches=_is_truss(_kind))(_factory)
