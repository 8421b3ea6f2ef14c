r"""The CNUSAIL cubesat's step over a world axis: what Python does between two batched ``mj_step``\ s.

:class:`CubesatWorlds` is the cubesat part of a batch (:class:`magsail_mj.batch.runner.BatchSimulation`
drives it). Each step ``k`` (``t = k·δt``), for all N worlds at once, as
:class:`magsail_mj.sim.Simulation` does for one:

1. :meth:`control`: the environment at t (:class:`~magsail_mj.batch.environment.EnvironmentStack`)
   and the flight controller (:class:`~magsail_mj.concepts.cnusail.batch_control.BdotWorlds`: samples due,
   held dipole, wheel motor torques written to ``ctrl``);
2. :meth:`probes` (record steps): the single run's probes — ``qpos``, ``qvel``, ``mode``, ``p_e``,
   ``theta_e_rad``, ``omega_e_rad_s``, ``u_cmd_Nm``, ``T_M_Nm``, ``dipole_cmd_Am2``,
   ``unload_mask``, ``torque_dist_body_Nm`` (the disturbance torques at t) and
   ``torque_mtq_body_Nm`` (``m × Rᵀ B``);
3. :meth:`loads`: the disturbance and magnetorquer torques
   (:mod:`~magsail_mj.concepts.cnusail.batch_loads`) on the bus row of ``xfrc_applied`` (world axes), seen
   at the step's start (``sim.load_timing = "start"``) or at its predicted middle (``"midpoint"``:
   ``q(t + δt/2) = q ⊕ (δt/2)·v(t + δt/4)`` with ``v(t + δt/4) ≈ v + (v − v_prev)/4`` and
   ``v(t + δt/2) ≈ v + (v − v_prev)/2``, the environment at ``t + δt/2``; the single run's
   :class:`~magsail_mj.sim.LoadTiming`, with MuJoCo's ``mj_integratePos`` of the free joint written
   out in :mod:`~magsail_mj.batch.worldmath`).

The bus is a free body: its pose comes straight from ``qpos`` (quaternion divided by its norm, as
:class:`~magsail_mj.sim.BodyKinematics` does) — the wheels' and markers' poses, which no load reads,
are not formed. A stopped world (``live`` False) keeps its ``ctrl``, ``xfrc_applied`` and
controller state.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from magsail_mj.concepts.cnusail.batch_control import BdotWorlds
from magsail_mj.concepts.cnusail.batch_loads import BodyState, DisturbanceWorlds, magnetorquer_torque
from magsail_mj.batch.environment import EnvironmentStack
from magsail_mj.batch.worldmath import cross, mat_t_vec_blas, quat_integrate, quat_to_mat
from magsail_mj.concepts.cnusail.mjcf import CubesatIndices

__all__ = ["CubesatWorlds", "PROBES", "controller_probes"]

PROBES = (
    "qpos",
    "qvel",
    "mode",
    "p_e",
    "theta_e_rad",
    "omega_e_rad_s",
    "u_cmd_Nm",
    "T_M_Nm",
    "dipole_cmd_Am2",
    "unload_mask",
    "torque_dist_body_Nm",
    "torque_mtq_body_Nm",
)
"""The probes of the cubesat's attitude run (the single run's, in its order)."""


def controller_probes(ctl: Any, qpos: np.ndarray, qvel: np.ndarray) -> dict[str, np.ndarray]:
    """The probes every world reads from its state and its controller ``ctl`` (the batch
    controller of :mod:`magsail_mj.concepts.cnusail.batch_control`), (N, …) each: the state, the
    mode, the attitude error, the wheel command, the held dipole and the unloading mask."""
    return {
        "qpos": qpos.copy(),
        "qvel": qvel.copy(),
        "mode": ctl.mode,
        "p_e": ctl.p_e,
        "theta_e_rad": ctl.theta_e,
        "omega_e_rad_s": ctl.omega_e,
        "u_cmd_Nm": ctl.u,
        "dipole_cmd_Am2": ctl.dipole_held,
        "unload_mask": ctl.unload_mask,
    }


class CubesatWorlds:
    """The cubesat of N worlds (module docstring).

    Args:
      idx: the cubesat's indices (every world's model has the same layout).
      environments: the worlds' environments.
      disturbances: the worlds' disturbance torques.
      controller: the worlds' flight controller.
      timestep_s: δt [s].
      load_timing: ``"start"`` or ``"midpoint"``.
      nv: the model's velocity count (the predicted mid-step state keeps the whole ``qvel``).
    """

    probe_names = PROBES

    def __init__(
        self,
        *,
        idx: CubesatIndices,
        environments: EnvironmentStack,
        disturbances: DisturbanceWorlds,
        controller: BdotWorlds,
        timestep_s: float,
        load_timing: str,
        nv: int,
    ) -> None:
        if load_timing not in ("start", "midpoint"):
            raise ValueError(f"load_timing: must be 'start' or 'midpoint', got {load_timing!r}")
        self.idx = idx
        self.env = environments
        self.dist = disturbances
        self.ctl = controller
        if controller.environments is None:
            controller.environments = environments  # the non-monotonic law reads the field table ahead
        self.dt = float(timestep_s)
        self.midpoint = load_timing == "midpoint"
        self.n = controller.n
        self.nv = int(nv)
        self.bus = int(idx.bus)
        self.live = np.ones(self.n, dtype=bool)
        self.reset()

    def reset(self) -> None:
        """The state of the build: controller state, no previous step for the midpoint prediction."""
        self.ctl.reset()
        self.qvel_prev = np.zeros((self.n, self.nv))
        self.primed = False
        self._start: tuple[int, BodyState] | None = None

    def set_live(self, live: np.ndarray) -> None:
        """Which worlds still run (the others keep their state)."""
        self.live = live
        self.ctl.live = live

    # ------------------------------------------------------------------ the step
    def _start_state(self, step: int, qpos: np.ndarray, qvel: np.ndarray) -> BodyState:
        """The bus at the start of step ``step`` (views of the batch's state: valid until its step)."""
        if self._start is None or self._start[0] != step:
            idx = self.idx
            body = BodyState(
                qpos[:, idx.q_quat], qpos[:, idx.q_pos], qvel[:, idx.v_lin], self.env.sample(step * self.dt)
            )
            self._start = (step, body)
        return self._start[1]

    def control(self, step: int, qpos: np.ndarray, qvel: np.ndarray, ctrl: np.ndarray) -> None:
        """The controller at step ``step``: samples due, held dipole, motor torques into ``ctrl``."""
        s = self._start_state(step, qpos, qvel)
        T_M = self.ctl.step(step, qpos, qvel, s.env)
        _write(ctrl, self.ctl.wheel_act, T_M, self.live)

    def control_failures(self) -> dict[int, str]:
        """The worlds whose plug-in detumble law raised at the last :meth:`control` → message
        (taken: the next call starts empty)."""
        errors, self.ctl.law_errors = self.ctl.law_errors, {}
        return errors

    def probes(self, step: int, qpos: np.ndarray, qvel: np.ndarray) -> dict[str, np.ndarray]:
        """The probes' values at step ``step`` (after :meth:`control`), (N, …) each."""
        s = self._start_state(step, qpos, qvel)
        c = self.ctl
        R_raw = quat_to_mat(qpos[:, self.idx.q_quat])
        return {
            **controller_probes(c, qpos, qvel),
            "T_M_Nm": c.T_M,
            "torque_dist_body_Nm": self.dist.torques_body(s),
            "torque_mtq_body_Nm": cross(c.dipole_body, mat_t_vec_blas(R_raw, s.env.B_eci)),
        }

    def loads(self, step: int, qpos: np.ndarray, qvel: np.ndarray, xfrc: np.ndarray) -> None:
        """``xfrc_applied`` of step ``step``: zero, then the disturbance and magnetorquer torques on
        the bus (world axes), at the step's start or its predicted middle."""
        s = self._mid_state(step, qpos, qvel) if self.midpoint else self._start_state(step, qpos, qvel)
        T = self.dist.torques_body(s)
        tau = 0.0 + self.dist.torque_world(T, s.R)
        T_mtq, acts = magnetorquer_torque(self.ctl.dipole_body, s)
        tau = np.where(acts[:, None], tau + T_mtq, tau)
        if self.live.all():
            xfrc[...] = 0.0
            xfrc[:, self.bus, 3:6] = tau
        else:
            wrench = np.zeros(xfrc.shape)
            wrench[:, self.bus, 3:6] = tau
            np.copyto(xfrc, wrench, where=self.live[:, None, None])

    def _mid_state(self, step: int, qpos: np.ndarray, qvel: np.ndarray) -> BodyState:
        """The bus predicted at t + δt/2 (module docstring); keeps this step's ``qvel``."""
        idx, dt = self.idx, self.dt
        v = qvel
        dv = (v - self.qvel_prev) if self.primed else np.zeros_like(v)
        v_int = v + 0.25 * dv
        scale = 0.5 * dt
        pos = qpos[:, idx.q_pos] + scale * v_int[:, idx.v_lin]
        quat = quat_integrate(qpos[:, idx.q_quat], v_int[:, idx.v_ang], scale)
        vel = (v + 0.5 * dv)[:, idx.v_lin]
        if self.live.all():
            self.qvel_prev = v.copy()
        else:
            np.copyto(self.qvel_prev, v, where=self.live[:, None])
        self.primed = True
        return BodyState(quat, pos, vel, self.env.sample(step * dt + 0.5 * dt))

    # ------------------------------------------------------------------ state
    def get_state(self) -> dict[str, Any]:
        """The Python-side state as plain data: the controller's and the midpoint prediction's."""
        return {"controller": self.ctl.get_state(), "qvel_prev": self.qvel_prev.copy(), "primed": self.primed}

    def set_state(self, state: dict[str, Any]) -> None:
        """Continue from a state of :meth:`get_state`."""
        self.ctl.set_state(state["controller"])
        self.qvel_prev = np.array(state["qvel_prev"], dtype=float, copy=True)
        self.primed = bool(state["primed"])
        self._start = None


def _write(ctrl: np.ndarray, columns: np.ndarray, values: np.ndarray, live: np.ndarray) -> None:
    """``ctrl[:, columns] = values`` for the live worlds."""
    if live.all():
        ctrl[:, columns] = values
        return
    rows = np.flatnonzero(live)
    ctrl[np.ix_(rows, columns)] = values[rows]
