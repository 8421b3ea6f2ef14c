r"""Drives of the MSAC shape joints along a prescribed cycle (spec ``msac.md`` §5.3–5.4).

Both wings get the same joint values; the shape vector is ``q_s = (φ, s, φ, s)`` in the joint
order ``w1_bend, w1_ext, w2_bend, w2_ext`` of :mod:`magsail_mj.concepts.msac.mjcf`.

Computed torque (per step, Python)
----------------------------------
Split the generalised coordinates into bus (free joint, 6 dofs) and shape (4 dofs). With the
dense mass matrix ``M`` (``mj_fullM``) and the bias ``c = qfrc_bias − qfrc_passive`` at the
step-start state, and the desired shape acceleration

.. math::
    a_s = \bar{\ddot q}_{des} + K_p (q_{des} − q_s) + K_d (\dot q_{des} − \dot q_s),
    \qquad K_p = ω_c^2,\; K_d = 2ω_c,\; ω_c = \texttt{omega\_c\_dt}/δt,

the bus acceleration that keeps the bus force-free and the shape torque are

.. math::
    a_b = −M_{bb}^{-1}(M_{bs} a_s + c_b), \qquad τ_s = M_{sb} a_b + M_{ss} a_s + c_s .

``τ_s`` goes to the ``_ff`` motors (control ``τ_s/g``, ``g`` their gear) and is held over the
step (zero-order hold). The
feed-forward term is the *step average* of the desired acceleration,
``(q̇_des(t_k + δt) − q̇_des(t_k))/δt``, so that a held torque reproduces the desired velocity
increment of the step (using ``q̈_des(t_k)`` would lag the path by half a step).

Replay (no Python per step)
---------------------------
The shape torques are periodic once the loop has settled, because nothing in the dynamics
depends on the bus yaw (spec §5.3, option 1). :func:`replay_table` runs the computed-torque
loop for a few cycles from the initial state and keeps the torques of the last cycle
(one value per step). The replay control of step ``k`` is then
``[τ_s(k mod N)/g, (u(t_{k+1}) − u(t_k))/δt]``: the feed-forward torque and the rate of the
servo set-point

.. math::
    u(t) = q_{des}(t) + (k_d/k_p)\,\dot q_{des}(t),

which the ``_servo`` actuators integrate into their activation (``act = u``, linear inside each
step, see :mod:`magsail_mj.concepts.msac.mjcf`). The servo force ``k_p(q_des − q) + k_d(q̇_des − q̇)``
removes the slow drift of pure open-loop replay. With ``N = Δt/δt`` an integer, the control
sequence of one cycle repeats exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from magsail_mj.concepts.msac.cycle import CyclePath, cycle_state
from magsail_mj.concepts.msac.mjcf import shape_indices

__all__ = [
    "steps_per_cycle",
    "desired_shape",
    "ComputedTorque",
    "ReplayTable",
    "replay_table",
    "set_initial_state",
    "servo_setpoints",
    "servo_rates",
]


def steps_per_cycle(path: CyclePath, timestep_s: float) -> int:
    """``N = Δt/δt``, which must be an integer (relative tolerance 1e-9) [steps].

    Raises ValueError naming both quantities otherwise: a non-integer ratio would make the
    replayed control drift in phase against the path.
    """
    ratio = path.period_s / timestep_s
    n = int(round(ratio))
    if n < 4 or abs(ratio - n) > 1e-9 * ratio:
        raise ValueError(f"timestep_s: the cycle period {path.period_s:g} s must be an integer multiple "
                         f">= 4 of timestep_s = {timestep_s:g} s, got a ratio of {ratio:.9g}")
    return n


def desired_shape(path: CyclePath, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Desired ``(q, q̇, q̈)`` of the four shape joints at times ``t``, each ``t.shape + (4,)``."""
    st = cycle_state(path, t)
    q = np.stack([st.phi, st.s, st.phi, st.s], axis=-1)
    qd = np.stack([st.phi_dot, st.s_dot, st.phi_dot, st.s_dot], axis=-1)
    qdd = np.stack([st.phi_ddot, st.s_ddot, st.phi_ddot, st.s_ddot], axis=-1)
    return q, qd, qdd


def set_initial_state(model: mujoco.MjModel, data: mujoco.MjData, path: CyclePath) -> None:
    """Reset ``data`` and put the shape joints on the Phase I values at rest (spec §5.4).

    ``φ = φa``, ``s = se`` (the first waypoint of the path), all velocities zero, bus at the
    origin with identity attitude, ``time = 0``, servo set-points (``act``) at ``u(0)``; then
    ``mj_forward``.
    """
    ix = shape_indices(model)
    mujoco.mj_resetData(model, data)
    phi0, s0 = path.initial
    data.qpos[ix["qpos"]] = [phi0, s0, phi0, s0]
    data.qvel[:] = 0.0
    data.act[ix["servo_act"]] = servo_setpoints(model, path, np.array(0.0))
    mujoco.mj_forward(model, data)


@dataclass
class ComputedTorque:
    """The computed-torque law of the module docs for one compiled MSAC model.

    Attributes:
      model: compiled model (its ``opt.timestep`` sets ``ω_c``).
      path: the prescribed cycle.
      omega_c_dt: ``ω_c·δt`` (spec default 0.2).
    """

    model: mujoco.MjModel
    path: CyclePath
    omega_c_dt: float = 0.2

    def __post_init__(self) -> None:
        if not self.omega_c_dt > 0:
            raise ValueError(f"omega_c_dt: must be > 0, got {self.omega_c_dt!r}")
        m = self.model
        ix = shape_indices(m)
        self.q_adr, self.v_adr = ix["qpos"], ix["dof"]
        self.ff = ix["ff"]
        self.gear = m.actuator_gear[self.ff, 0].copy()
        self.bus = np.setdiff1d(np.arange(m.nv), self.v_adr)
        self.M = np.zeros((m.nv, m.nv))
        dt = m.opt.timestep
        w = self.omega_c_dt / dt
        self.kp, self.kd = w * w, 2.0 * w
        self.dt = dt
        # the desired path at the step times of one cycle (t_k = k δt is periodic in k mod N)
        self.N = steps_per_cycle(self.path, dt)
        q, qd, _ = desired_shape(self.path, np.arange(self.N + 1) * dt)
        self._q, self._qd = q[:-1], qd[:-1]
        self._qdd_avg = np.diff(qd, axis=0) / dt
        s, b = self.v_adr, self.bus
        self._bb, self._bs, self._sb, self._ss = np.ix_(b, b), np.ix_(b, s), np.ix_(s, b), np.ix_(s, s)

    def torque(self, data: mujoco.MjData, step: int) -> np.ndarray:
        """Shape torques ``τ_s`` (4,) [N m, N, N m, N] for the state in ``data`` at step ``step``
        (time ``step·δt``).

        Runs ``mj_fwdPosition`` and ``mj_fwdVelocity`` on ``data`` (mass matrix and bias).
        """
        m = self.model
        mujoco.mj_fwdPosition(m, data)
        mujoco.mj_fwdVelocity(m, data)
        mujoco.mj_fullM(m, data, self.M)
        c = data.qfrc_bias - data.qfrc_passive
        k = int(step) % self.N
        a_s = (self._qdd_avg[k] + self.kp * (self._q[k] - data.qpos[self.q_adr])
               + self.kd * (self._qd[k] - data.qvel[self.v_adr]))
        M = self.M
        a_b = -np.linalg.solve(M[self._bb], M[self._bs] @ a_s + c[self.bus])
        return M[self._sb] @ a_b + M[self._ss] @ a_s + c[self.v_adr]


@dataclass
class ReplayTable:
    """One cycle of replay controls.

    Attributes:
      ctrl: (N, nu) controls of the steps of one cycle (``_ff`` torques / gear and ``_servo``
        set-point rates, in actuator order).
      torque: (N, 4) the recorded settled computed torques ``τ_s``.
      settle_change: max over joints of ``max|τ_last − τ_previous| / max|τ_last|`` between the
        last two computed-torque cycles (how periodic the recorded torque is).
    """

    ctrl: np.ndarray
    torque: np.ndarray
    settle_change: float


def replay_table(model: mujoco.MjModel, path: CyclePath, *, omega_c_dt: float = 0.2,
                 calibration_cycles: int = 3) -> ReplayTable:
    """Record the settled computed-torque cycle and build the replay controls (module docs).

    Runs the computed-torque loop (servos disabled) from the Phase I rest state for
    ``calibration_cycles`` cycles on a private copy of the data; the model is not modified
    (its ``opt.disableactuator`` is restored).
    """
    if int(calibration_cycles) != calibration_cycles or calibration_cycles < 2:
        raise ValueError(f"calibration_cycles: must be an integer >= 2, got {calibration_cycles!r}")
    dt = model.opt.timestep
    N = steps_per_cycle(path, dt)
    ix = shape_indices(model)
    data = mujoco.MjData(model)
    set_initial_state(model, data, path)
    ct = ComputedTorque(model, path, omega_c_dt=omega_c_dt)
    tau = np.zeros((calibration_cycles * N, 4))
    saved = model.opt.disableactuator
    model.opt.disableactuator = saved | (1 << 1)
    try:
        for k in range(calibration_cycles * N):
            tau[k] = ct.torque(data, k)
            data.ctrl[ix["ff"]] = tau[k] / ct.gear
            mujoco.mj_step(model, data)
    finally:
        model.opt.disableactuator = saved
    last, prev = tau[-N:], tau[-2 * N:-N]
    scale = np.maximum(np.abs(last).max(axis=0), 1e-300)
    change = float(np.max(np.abs(last - prev).max(axis=0) / scale))
    ctrl = np.zeros((N, model.nu))
    ctrl[:, ix["ff"]] = last / ct.gear
    ctrl[:, ix["servo"]] = servo_rates(model, path, N)
    return ReplayTable(ctrl=ctrl, torque=last, settle_change=change)


def servo_setpoints(model: mujoco.MjModel, path: CyclePath, t: np.ndarray) -> np.ndarray:
    """Servo set-points ``u = q_des + (k_d/k_p) q̇_des`` at times ``t``, shape ``t.shape + (4,)``."""
    ix = shape_indices(model)
    kp = model.actuator_gainprm[ix["servo"], 0]
    kd = -model.actuator_biasprm[ix["servo"], 2]
    q, qd, _ = desired_shape(path, t)
    return q + (kd / kp) * qd


def servo_rates(model: mujoco.MjModel, path: CyclePath, n_steps: int) -> np.ndarray:
    """Servo controls of the steps of one cycle: ``(u(t_{k+1}) − u(t_k))/δt``, shape (N, 4)."""
    dt = model.opt.timestep
    u = servo_setpoints(model, path, np.arange(n_steps + 1) * dt)
    return np.diff(u, axis=0) / dt
