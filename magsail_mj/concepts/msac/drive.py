r"""Drives of the MSAC shape joints along a prescribed cycle.

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
depends on the bus yaw (option 1). :func:`replay_table` runs the computed-torque
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

The servos leak angular momentum. Every drive force is an internal joint force, so the exact
dynamics conserve the total angular momentum whatever the forces; RK4 conserves it to round-off
when the joint forces are *held* over each step, but not when they depend on the state inside
the step. Measured (paper case, δt = 5 µs, 200 steps per cycle, no projection): the servo
replay drifts 8·10⁻⁵ N m s per cycle (0.08 N m s per second; 2·10⁻³ at δt = 10 µs, 1·10⁻⁵ at
2.5 µs, changing sign with the servo gain), a servo alone springing a wing by 0.01 rad from
rest 1.5·10⁻³ N m s (∝ amplitude², plain joint damping alike), held torques ~2·10⁻⁹ per cycle.

Held torque (no Python per step, momentum conserved by construction)
--------------------------------------------------------------------
:func:`held_torque_table`: the settled computed-torque cycle's torques, each held over its step
(the ``_ff`` motors; servos off), are the inverse dynamics of the path (the demand of the
prescribed accelerations on the step-start state, :class:`ComputedTorque` with its feedback
settled). Replayed open loop they would leave the path: the cycle map's monodromy ``A`` has an
eigenvalue of modulus ~1.3 (an e-fold in ~4 cycles). So once per cycle, at the cycle start,
the runner adds a *trim*: torques held over ``P`` pieces of the cycle on each joint,
``u = −B⁺ (x_end⁰ − x⁰ + A (x − x⁰))``, which brings the shape vector ``x = (q_s, q̇_s)`` back
to the orbit start ``x⁰`` at the end of the cycle (deadbeat to first order; ``B = ∂x_end/∂u``,
both by central differences of one-cycle rollouts). The run's first ``calibration_cycles``
cycles are the computed-torque loop itself from the rest state (the steps of the calibration), so
the held replay starts exactly on the orbit and the trims stay at round-off (~10⁻⁹ of their
unit). Every force is then a held internal joint force; measured drift ~1.2·10⁻⁹ N m s per
cycle at δt = 5 µs over 10⁴ cycles (−3·10⁻⁶ at 10 µs, 6·10⁻⁹ at 2.5 µs: round-off), the shape
on the orbit to ~10⁻¹¹.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
from mujoco import rollout as mj_rollout
import numpy as np

from magsail_mj.concepts.msac.cycle import CyclePath, cycle_state
from magsail_mj.concepts.msac.mjcf import shape_indices
from magsail_mj.checkpoint import restorable

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
        raise ValueError(
            f"timestep_s: the cycle period {path.period_s:g} s must be an integer multiple "
            f">= 4 of timestep_s = {timestep_s:g} s, got a ratio of {ratio:.9g}"
        )
    return n


def desired_shape(path: CyclePath, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Desired ``(q, q̇, q̈)`` of the four shape joints at times ``t``, each ``t.shape + (4,)``."""
    st = cycle_state(path, t)
    q = np.stack([st.phi, st.s, st.phi, st.s], axis=-1)
    qd = np.stack([st.phi_dot, st.s_dot, st.phi_dot, st.s_dot], axis=-1)
    qdd = np.stack([st.phi_ddot, st.s_ddot, st.phi_ddot, st.s_ddot], axis=-1)
    return q, qd, qdd


def set_initial_state(model: mujoco.MjModel, data: mujoco.MjData, path: CyclePath) -> None:
    """Reset ``data`` and put the shape joints on the Phase I values at rest.

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


@restorable
@dataclass
class ComputedTorque:
    """The computed-torque law of the module docs for one compiled MSAC model.

    Attributes:
      model: compiled model (its ``opt.timestep`` sets ``ω_c``).
      path: the prescribed cycle.
      omega_c_dt: ``ω_c·δt`` (default 0.2).
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
        a_s = (
            self._qdd_avg[k]
            + self.kp * (self._q[k] - data.qpos[self.q_adr])
            + self.kd * (self._qd[k] - data.qvel[self.v_adr])
        )
        M = self.M
        a_b = -np.linalg.solve(M[self._bb], M[self._bs] @ a_s + c[self.bus])
        return M[self._sb] @ a_b + M[self._ss] @ a_s + c[self.v_adr]


@restorable
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


def replay_table(
    model: mujoco.MjModel, path: CyclePath, *, omega_c_dt: float = 0.2, calibration_cycles: int = 3
) -> ReplayTable:
    """Record the settled computed-torque cycle and build the replay controls (module docs).

    Runs the computed-torque loop (servos disabled) from the Phase I rest state for
    ``calibration_cycles`` cycles on a private copy of the data; the model is not modified
    (its ``opt.disableactuator`` is restored).
    """
    N = steps_per_cycle(path, model.opt.timestep)
    ix = shape_indices(model)
    tau, _, change = _calibrate(model, path, omega_c_dt=omega_c_dt, calibration_cycles=calibration_cycles)
    last = tau[-N:]
    ctrl = np.zeros((N, model.nu))
    ctrl[:, ix["ff"]] = last / model.actuator_gear[ix["ff"], 0]
    ctrl[:, ix["servo"]] = servo_rates(model, path, N)
    return ReplayTable(ctrl=ctrl, torque=last, settle_change=change)


def _calibrate(
    model: mujoco.MjModel, path: CyclePath, *, omega_c_dt: float, calibration_cycles: int
) -> tuple[np.ndarray, mujoco.MjData, float]:
    """Run the computed-torque loop (servos disabled) from the Phase I rest state for
    ``calibration_cycles`` cycles on a private data; return the torques of every step
    (cycles·N, 4), the data at the end (a cycle start) and the settle change of the last cycle
    (see :class:`ReplayTable`). The model is not modified (``opt.disableactuator`` restored)."""
    if int(calibration_cycles) != calibration_cycles or calibration_cycles < 2:
        raise ValueError(f"calibration_cycles: must be an integer >= 2, got {calibration_cycles!r}")
    N = steps_per_cycle(path, model.opt.timestep)
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
    last, prev = tau[-N:], tau[-2 * N : -N]
    scale = np.maximum(np.abs(last).max(axis=0), 1e-300)
    return tau, data, float(np.max(np.abs(last - prev).max(axis=0) / scale))


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


def shape_vector(model: mujoco.MjModel, state: np.ndarray, *, ix: dict[str, np.ndarray] | None = None) -> np.ndarray:
    """``x = (q_s, q̇_s)`` (8,) of a full physics state (``mjSTATE_FULLPHYSICS``: time, qpos,
    qvel, …): the four shape joint positions [rad, m] and velocities [rad/s, m/s]. ``ix``: the
    model's :func:`shape_indices` (looked up when not given)."""
    ix = shape_indices(model) if ix is None else ix
    nq = model.nq
    return np.concatenate([state[1 + ix["qpos"]], state[1 + nq + ix["dof"]]])


def with_shape(model: mujoco.MjModel, data: mujoco.MjData, state: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """``state`` with its shape vector moved by ``dx`` (8,) and the bus velocity re-solved so that
    the free joint's generalised momentum ``p_b = (M v)_b`` (total linear and angular momentum)
    keeps its value: ``v_b ← M_bb⁻¹ (p_b − M_bs v_s)`` at the moved configuration. Uses ``data``
    as scratch."""
    fp = mujoco.mjtState.mjSTATE_FULLPHYSICS
    ix = shape_indices(model)
    nq, nv = model.nq, model.nv
    b = ix["bus_dof"]
    M = np.zeros((nv, nv))
    mujoco.mj_setState(model, data, state, fp)
    mujoco.mj_fwdPosition(model, data)
    mujoco.mj_fullM(model, data, M)
    p_b = (M @ state[1 + nq : 1 + nq + nv])[b]
    out = state.copy()
    out[1 + ix["qpos"]] += dx[:4]
    out[1 + nq + ix["dof"]] += dx[4:]
    mujoco.mj_setState(model, data, out, fp)
    mujoco.mj_fwdPosition(model, data)
    mujoco.mj_fullM(model, data, M)
    v = out[1 + nq : 1 + nq + nv]
    s = ix["dof"]
    out[1 + nq + b] = np.linalg.solve(M[np.ix_(b, b)], p_b - M[np.ix_(b, s)] @ v[s])
    return out


@restorable
@dataclass
class HeldTorqueTable:
    r"""One cycle of held joint torques and the once-per-cycle trim of the ``held_torque`` drive.

    Attributes:
      ctrl: (N, nu) nominal controls: the ``_ff`` torques / gear of one settled computed-torque
        cycle; the servo columns are zero (the servos are switched off).
      torque: (N, 4) the nominal held torques ``τ_s`` [N m, N, N m, N].
      settle_change: as :attr:`ReplayTable.settle_change`.
      x_start: (8,) shape vector ``(q_s, q̇_s)`` of the periodic orbit at a cycle start.
      offset: (8,) ``x_end − x_start`` of one nominal cycle rolled out from the orbit start (the
        orbit's residual non-periodicity).
      monodromy: (8, 8) ``A = ∂x_end/∂x_start`` of one nominal cycle (central differences).
      trim_gain: (4P, 8) ``B⁺``, the pseudo-inverse of ``B = ∂x_end/∂u``.
      trim_scale: (4,) torque of a unit trim coefficient on each joint [N m or N].
      piece: (N,) the trim piece (0 … P−1) of each step of the cycle.
      u: (4P,) trim coefficients of the current cycle (coefficient ``j·P + p``: joint ``j``, piece ``p``).
    """

    ctrl: np.ndarray
    torque: np.ndarray
    settle_change: float
    x_start: np.ndarray
    offset: np.ndarray
    monodromy: np.ndarray
    trim_gain: np.ndarray
    trim_scale: np.ndarray
    piece: np.ndarray
    u: np.ndarray

    def trim(self, x: np.ndarray) -> np.ndarray:
        """Set and return the trim coefficients of a cycle that starts at shape vector ``x``:
        ``u = −B⁺ (offset + A (x − x_start))``, so that the cycle ends on the orbit start to first
        order."""
        self.u = -self.trim_gain @ (self.offset + self.monodromy @ (x - self.x_start))
        return self.u

    def trim_torque(self) -> np.ndarray:
        """(N, 4) the held trim torques of the current cycle: ``Δτ_j(k) = scale_j u[j·P + piece(k)]``."""
        P = self.trim_gain.shape[0] // 4
        return self.u.reshape(4, P)[:, self.piece].T * self.trim_scale


def held_torque_table(
    model: mujoco.MjModel,
    path: CyclePath,
    *,
    omega_c_dt: float = 0.2,
    calibration_cycles: int = 3,
    trim_pieces: int = 4,
    trim_eps: float = 1e-6,
) -> HeldTorqueTable:
    r"""Build the ``held_torque`` drive of a model and cycle (module docs).

    1. The computed-torque loop runs ``calibration_cycles`` cycles from the Phase I rest state
       (:func:`_calibrate`); its last cycle of torques, held over each step, is the nominal
       table, and its end state the orbit start ``x_start``.
    2. One cycle of the nominal table is rolled out (servos off) from ``x_start`` and from
       states with each shape coordinate moved by ``±ε`` (``ε = trim_eps`` rad or m, velocities
       ``±ε·2π f``; bus velocity re-solved for unchanged momentum, :func:`with_shape`), and with
       each trim piece's torque ``±`` its unit: central differences give ``A`` and ``B``.

    The trim basis: the cycle's steps fall into ``trim_pieces`` equal pieces; coefficient
    ``j·P + p`` holds a torque ``scale_j`` on joint ``j`` during piece ``p``, with
    ``scale_j = M_jj ε / (Δt/P)²`` (``M_jj`` the joint's diagonal mass-matrix entry), a torque
    that moves the joint by about ``ε`` over a piece.
    """
    if int(trim_pieces) != trim_pieces or trim_pieces < 2:
        raise ValueError(f"trim_pieces: must be an integer >= 2, got {trim_pieces!r}")
    if not trim_eps > 0:
        raise ValueError(f"trim_eps: must be > 0, got {trim_eps!r}")
    fp = mujoco.mjtState.mjSTATE_FULLPHYSICS
    dt = model.opt.timestep
    N = steps_per_cycle(path, dt)
    ix = shape_indices(model)
    tau, data, change = _calibrate(model, path, omega_c_dt=omega_c_dt, calibration_cycles=calibration_cycles)
    gear = model.actuator_gear[ix["ff"], 0]
    ctrl = np.zeros((N, model.nu))
    ctrl[:, ix["ff"]] = tau[-N:] / gear
    start = np.empty(mujoco.mj_stateSize(model, fp))
    mujoco.mj_getState(model, data, start, fp)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    P = int(trim_pieces)
    piece = np.minimum((np.arange(N) * P) // N, P - 1)
    scale = np.diag(M)[ix["dof"]] * trim_eps / (path.period_s / P) ** 2
    eps = np.concatenate([np.full(4, trim_eps), np.full(4, trim_eps * 2 * np.pi / path.period_s)])
    states = [start]
    for i in range(8):
        for sign in (1.0, -1.0):
            dx = np.zeros(8)
            dx[i] = sign * eps[i]
            states.append(with_shape(model, data, start, dx))
    ctrls = [ctrl] * len(states)
    for j in range(4):
        for p in range(P):
            for sign in (1.0, -1.0):
                c = ctrl.copy()
                c[piece == p, ix["ff"][j]] += sign * scale[j] / gear[j]
                ctrls.append(c)
                states.append(start)
    x_end = _roll_cycle(model, np.array(states), np.array(ctrls))
    A = np.stack([(x_end[1 + 2 * i] - x_end[2 + 2 * i]) / (2 * eps[i]) for i in range(8)], axis=1)
    o = 17
    B = np.stack([(x_end[o + 2 * c] - x_end[o + 2 * c + 1]) / 2.0 for c in range(4 * P)], axis=1)
    x0 = shape_vector(model, start)
    return HeldTorqueTable(
        ctrl=ctrl,
        torque=tau[-N:].copy(),
        settle_change=change,
        x_start=x0,
        offset=x_end[0] - x0,
        monodromy=A,
        trim_gain=np.linalg.pinv(B),
        trim_scale=scale,
        piece=piece,
        u=np.zeros(4 * P),
    )


def _roll_cycle(model: mujoco.MjModel, states: np.ndarray, ctrls: np.ndarray) -> np.ndarray:
    """Shape vectors (B, 8) at the end of rolling out ``states`` (B, nstate) under ``ctrls``
    (B, N, nu) with the servos off (the model's ``opt.disableactuator`` is restored)."""
    saved = model.opt.disableactuator
    model.opt.disableactuator = saved | (1 << 1)
    try:
        st, _ = mj_rollout.rollout(model, mujoco.MjData(model), states, ctrls)
    finally:
        model.opt.disableactuator = saved
    return np.stack([shape_vector(model, s) for s in st[:, -1]])
