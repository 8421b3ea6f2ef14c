r"""The CNUSAIL flight controller's B-dot detumble mode over a world axis, with the wheel drivers.

For N worlds sampled in lockstep (one schedule: the attitude period, the magnetorquer cycle and its
blanking window are the same in every world), this is
:class:`~magsail_mj.concepts.cnusail.modes.CnusailController` in its DETUMBLE mode (Yoo et al.
2016, Sec. 5; stand-alone ``control.mode = "bdot"``, mode switching off), with each world's gains
and limits:

* magnetorquer sample (every cycle, at its start): the magnetometer reading ``B_B = Rᵀ B`` (R of
  the raw ``qpos`` quaternion), the B-dot estimate — finite difference ``Ḃ_k = (B_k − B_{k−1})/Δt``
  (Eq. 25) or the Tustin-filtered derivative (Eq. 26), per world — the dipole ``m = −K Ḃ`` clipped
  per axis to the world's limits and held; the coils carry it for the first ``T_c − t_blank`` of
  the cycle and nothing during the blanking window; the world's ``control.bdot_law`` other than
  the proportional one replaces ``−K Ḃ`` before the clip (:mod:`magsail_mj.control.detumble_laws`,
  each law evaluated on every world's row as the single run evaluates it on its one row): bang-bang
  ``−m_max sign Ḃ``, the B×ω law ``k (ω × B)/‖B‖²`` with the world's gain, or the non-monotonic
  law with the field table read ahead (``EnvironmentStack.sample`` at ``min(t + Δt, t_max)``, in
  today's body axes); a plug-in law (:mod:`magsail_mj.control.detumble_plugins`) is called per
  world at the sample with that world's inputs, as its single run calls it; a law that raises
  stops its world alone (``failed``, with the law, the time and the error: :attr:`law_errors`,
  taken by the plant's ``control_failures``);
* attitude sample (every ``1/rate_Hz``): the telemetry of the single run (the error quaternion to
  the nadir frame, its eigen-angle, the rate error); in DETUMBLE the wheels idle (command 0);
* wheel drivers every step (Eqs. 8–11): the quasi-static DC motor ``V = clip(R i_c + K_b ω_M,
  ±V_max)``, ``T_M = K_M (V − K_b ω_M)/R`` or the ideal torque source, and the speed limiter
  (``T_M = K_B ω_M`` where ``|ω_M| ≥ Ω_max`` and the net rotor torque would speed it up), written to
  ``ctrl``.

Everything is element-wise over the worlds in the single run's order of operations
(:mod:`magsail_mj.batch.worldmath`), so each world's commands equal its single run's bit for bit.
A world that has stopped (diverged) keeps its controller state: every update is masked by
``live``.
"""

from __future__ import annotations

import math
import sys
from typing import Any

import numpy as np

from magsail_mj.batch.worldmath import mat_t_vec_blas, quat_to_mat
from magsail_mj.concepts.cnusail.modes import CnusailController, Mode
from magsail_mj.control.bdot import normalised_bdot_dipole
from magsail_mj.control.detumble_laws import bang_bang_dipole, bcross_dipole, nonmonotonic_dipole
from magsail_mj.control.detumble_plugins import BUILTIN_DETUMBLE_LAWS as DETUMBLE_LAWS
from magsail_mj.control.detumble_plugins import plugin_dipole

__all__ = ["BdotWorlds", "nadir_frame", "error_quaternion", "eigen_angle", "rate_error"]

_STATE = ("prev", "B_dot", "dipole_held", "B_meas", "p_e", "theta_e", "omega_e", "T_M", "dipole_body", "wheel_cmd")
"""The per-world arrays of the controller's state (with ``has_prev``, ``last_att``, ``last_mtq``)."""


def _sum_of_squares(c: list[np.ndarray]) -> np.ndarray:
    """``sum(x * x for x in c)`` per world with Python's ``sum`` of floats: left to right before
    Python 3.12, compensated from 3.12 on (then evaluated per world by ``sum`` itself)."""
    if sys.version_info < (3, 12):
        return c[0] * c[0] + c[1] * c[1] + c[2] * c[2] + c[3] * c[3]
    rows = np.stack(c, axis=1).tolist()
    return np.array([sum(x * x for x in row) for row in rows])


def nadir_frame(r: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, 4) nadir command quaternions and (N,) orbital rates ``|r × v|/|r|²`` [rad/s] of the
    reference states ``r`` [m], ``v`` [m/s] (N, 3): :func:`magsail_mj.concepts.cnusail.modes.command_frame`
    for the nadir frame (ẑ = r̂, ŷ = (v × r)/|v × r|, x̂ = ŷ × ẑ; Shepperd's quaternion, w ≥ 0)."""
    rx, ry, rz = r[:, 0], r[:, 1], r[:, 2]
    vx, vy, vz = v[:, 0], v[:, 1], v[:, 2]
    rn = np.sqrt(rx * rx + ry * ry + rz * rz)
    z0, z1, z2 = rx / rn, ry / rn, rz / rn
    hx, hy, hz = vy * rz - vz * ry, vz * rx - vx * rz, vx * ry - vy * rx
    hn = np.sqrt(hx * hx + hy * hy + hz * hz)
    y0, y1, y2 = hx / hn, hy / hn, hz / hn
    x0, x1, x2 = y1 * z2 - y2 * z1, y2 * z0 - y0 * z2, y0 * z1 - y1 * z0
    (r00, r10, r20), (r01, r11, r21), (r02, r12, r22) = (x0, x1, x2), (y0, y1, y2), (z0, z1, z2)
    K = np.stack(
        [
            np.stack((1 + r00 + r11 + r22, r21 - r12, r02 - r20, r10 - r01), axis=1),
            np.stack((r21 - r12, 1 + r00 - r11 - r22, r01 + r10, r02 + r20), axis=1),
            np.stack((r02 - r20, r01 + r10, 1 - r00 + r11 - r22, r12 + r21), axis=1),
            np.stack((r10 - r01, r02 + r20, r12 + r21, 1 - r00 - r11 + r22), axis=1),
        ],
        axis=1,
    )  # (N, 4, 4)
    pick = np.argmax(np.stack([K[:, i, i] for i in range(4)], axis=1), axis=1)  # first largest, as max()
    col = K[np.arange(len(K)), pick]
    n = np.sqrt(_sum_of_squares([col[:, 0], col[:, 1], col[:, 2], col[:, 3]]))
    q = col / n[:, None]
    q = np.where((q[:, 0] < 0)[:, None], -q, q)
    return q, hn / (rn * rn)


def error_quaternion(p_c: np.ndarray, p_b: np.ndarray, shortest: np.ndarray) -> np.ndarray:
    """(N, 4) ``p_e = p_c* ⊗ p_b / |p_c* ⊗ p_b|``, sign flipped where ``shortest`` and w < 0
    (:func:`magsail_mj.concepts.cnusail.eigenaxis.error_quaternion_f`)."""
    w1, x1, y1, z1 = p_c[:, 0], -p_c[:, 1], -p_c[:, 2], -p_c[:, 3]
    w2, x2, y2, z2 = p_b[:, 0], p_b[:, 1], p_b[:, 2], p_b[:, 3]
    w = w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2
    x = w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2
    y = w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2
    z = w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2
    n = np.sqrt(w * w + x * x + y * y + z * z)
    n = np.where(shortest & (w < 0), -n, n)
    return np.stack((w / n, x / n, y / n, z / n), axis=1)


def eigen_angle(p_e: np.ndarray) -> np.ndarray:
    """(N,) eigen-angles ``2 atan2(√(x² + y² + z²), |w|)`` [rad] (``math.atan2`` per world)."""
    w, x, y, z = p_e[:, 0], p_e[:, 1], p_e[:, 2], p_e[:, 3]
    s = np.sqrt(x * x + y * y + z * z).tolist()
    return np.array([2.0 * math.atan2(a, b) for a, b in zip(s, np.abs(w).tolist())])


def rate_error(omega: np.ndarray, p_e: np.ndarray, omega_o: np.ndarray) -> np.ndarray:
    """(N, 3) ``ω_e = ω + ω_o (2(xy + wz), 1 − 2(x² + z²), 2(yz − wx))`` [rad/s]
    (:func:`magsail_mj.concepts.cnusail.eigenaxis.rate_error_f`)."""
    w, x, y, z = p_e[:, 0], p_e[:, 1], p_e[:, 2], p_e[:, 3]
    return np.stack(
        (
            omega[:, 0] + omega_o * (2 * (x * y + w * z)),
            omega[:, 1] + omega_o * (1 - 2 * (x * x + z * z)),
            omega[:, 2] + omega_o * (2 * (y * z - w * x)),
        ),
        axis=1,
    )


class BdotWorlds:
    """The B-dot detumble controller of N worlds (module docstring), from each world's
    :class:`CnusailController` (its gains, limits and driver constants) and, for the non-monotonic
    law, the worlds' ``environments`` (an :class:`~magsail_mj.batch.environment.EnvironmentStack`;
    :class:`~magsail_mj.concepts.cnusail.batch_plant.CubesatWorlds` gives its own when None).

    Raises:
      ValueError: a world's controller is not a stand-alone B-dot controller, uses the sub-stepped
        armature model, or samples on another schedule than world 0, or the non-monotonic law's
        look-ahead differs from world 0's (naming the key).
    """

    def __init__(self, controllers: list[CnusailController], *, environments: Any = None) -> None:
        c0 = controllers[0]
        for k, c in enumerate(controllers):
            if c.p.law != "bdot" or c.p.modes.enabled:
                raise ValueError(f"controllers[{k}]: control.mode must be 'bdot' without mode switching")
            if c.driver.electrical != "quasi_static":
                raise ValueError(f"controllers[{k}]: actuators.wheels.electrical must be 'quasi_static'")
            if c.p.nonmonotonic_lookahead_s != c0.p.nonmonotonic_lookahead_s:
                raise ValueError(f"controllers[{k}]: control.nonmonotonic_lookahead_s differs from world 0's")
            for attr, key in (
                ("n_att", "control.rate_Hz"),
                ("_n_cycle", "actuators.mtq.cycle_s"),
                ("_n_on", "actuators.mtq.blank_s"),
            ):
                if getattr(c, attr) != getattr(c0, attr):
                    raise ValueError(f"controllers[{k}]: {key} differs from world 0's")
        n = len(controllers)
        self.n = n
        self.n_att, self.n_cycle, self.n_on = c0.n_att, c0._n_cycle, c0._n_on
        self.q_quat, self.v_ang = c0.q_quat, c0.v_ang
        self.wheel_qvel = c0.wheel_qvel
        self.wheel_act = c0.wheel_act
        self.filtered = np.array([c.bdot.form == "filtered" for c in controllers])
        self.gain = np.array([c.bdot.gain for c in controllers])[:, None]
        k_norm = [c.p.bdot_normalised_gain_Am2s for c in controllers]
        self.normalised = np.array([k is not None for k in k_norm])
        self.k_normalised = np.array([1.0 if k is None else k for k in k_norm])[:, None]
        self.bdot_dt = np.array([c.bdot.dt for c in controllers])[:, None]
        self.c_prev = np.array([getattr(c.bdot, "_c_prev", 0.0) for c in controllers])[:, None]
        self.c_in = np.array([getattr(c.bdot, "_c_in", 0.0) for c in controllers])[:, None]
        self.limit = np.array([c.p.mtq_limits_Am2 for c in controllers])
        laws = np.array([c.p.bdot_law for c in controllers])
        self.bang_bang = laws == "bang_bang"
        self.b_cross = laws == "b_cross"
        self.non_monotonic = laws == "non_monotonic"
        self.extrapolated = np.array([c.p.nonmonotonic_field_ahead == "extrapolated" for c in controllers])
        self.plugin = ~np.isin(laws, DETUMBLE_LAWS)
        self.laws = laws.tolist()
        self.law_params = [dict(c.p.bdot_law_params) for c in controllers]
        self.environments = environments  # CubesatWorlds gives its stack when None here
        self.dt = c0._dt
        self.lookahead_s = c0.p.nonmonotonic_lookahead_s
        self.k_bcross = np.array([c.p.bcross_gain_Nms for c in controllers])[:, None]
        self.k_nonmon = np.array([c.p.nonmonotonic_gain_per_Nms for c in controllers])[:, None]
        self.alpha = np.array([c.p.nonmonotonic_alpha for c in controllers])[:, None]
        self.inertia = np.array([c.p.inertia_kgm2 for c in controllers])
        self.shortest = np.array([bool(c.p.shortest_rotation) for c in controllers])
        self.ideal = np.array([c.driver.model == "ideal" for c in controllers])[:, None]
        ps = [c.driver.p for c in controllers]
        self.R_ohm = np.array([p.R_ohm for p in ps])[:, None]
        self.K_b = np.array([p.K_b_Vs_rad for p in ps])[:, None]
        self.K_M = np.array([p.K_M_Nm_A for p in ps])[:, None]
        self.K_B = np.array([p.K_B_Nms for p in ps])[:, None]
        self.V_max = np.array([p.V_max_V for p in ps])[:, None]
        self.w_max = np.array([p.speed_max_rad_s for p in ps])[:, None]
        self.live = np.ones(n, dtype=bool)
        self.mode = np.full(n, int(Mode.DETUMBLE), dtype=np.int64)
        self.u = np.zeros((n, 3))
        self.unload_mask = np.zeros((n, 3), dtype=np.int8)
        self.reset()

    def reset(self) -> None:
        """The controller state of the build (no sample yet, all held values zero)."""
        n = self.n
        self.prev = np.zeros((n, 3))
        self.has_prev = False
        self.B_dot = np.zeros((n, 3))
        self.dipole_held = np.zeros((n, 3))
        self.B_meas = np.zeros((n, 3))
        self.p_e = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
        self.theta_e = np.zeros(n)
        self.omega_e = np.zeros((n, 3))
        self.T_M = np.zeros((n, 3))
        self.dipole_body = np.zeros((n, 3))
        self.wheel_cmd = np.zeros((n, 3))
        self.last_att = -1
        self.last_mtq = -1
        self.law_errors: dict[int, str] = {}

    def _set(self, name: str, value: np.ndarray) -> None:
        """``self.<name> = value`` for the live worlds; a stopped world keeps its value."""
        if self.live.all():
            setattr(self, name, value)
            return
        old = getattr(self, name).copy()
        np.copyto(old, value, where=self.live.reshape(-1, *([1] * (old.ndim - 1))))
        setattr(self, name, old)

    def step(self, step: int, qpos: np.ndarray, qvel: np.ndarray, env: Any) -> np.ndarray:
        """One dynamics step ``step`` (t = step·δt): the samples due, then the wheel drivers; returns
        the (N, 3) motor torques T_M [N m] for ``ctrl``. ``env`` is the environment at t
        (:class:`~magsail_mj.batch.environment.EnvSamples`)."""
        self.sample(step, qpos, qvel, env)
        self._set("dipole_body", self.dipole_held if step % self.n_cycle < self.n_on else np.zeros((self.n, 3)))
        self._set("T_M", self._motor_torque(qvel[:, self.wheel_qvel]))
        return self.T_M

    def sample(self, step: int, qpos: np.ndarray, qvel: np.ndarray, env: Any) -> None:
        """The attitude and magnetorquer samples due at step ``step`` (t = step·δt), each once:
        the attitude sample when ``step // n_att`` is new, the magnetorquer sample when
        ``step // n_cycle`` is; ``env`` is the environment at t. Compiled loads call this at the
        controller's samples only (blanking and the wheel drivers run in the plugin)."""
        i_att, i_mtq = step // self.n_att, step // self.n_cycle
        if i_att > self.last_att or i_mtq > self.last_mtq:
            att, mtq = i_att > self.last_att, i_mtq > self.last_mtq
            self.last_att, self.last_mtq = max(self.last_att, i_att), max(self.last_mtq, i_mtq)
            q = qpos[:, self.q_quat]
            if att:
                self._attitude_sample(q, qvel[:, self.v_ang], env)
            if mtq:
                self._mtq_sample(step, quat_to_mat(q), env, qvel[:, self.v_ang])

    def _attitude_sample(self, q: np.ndarray, omega: np.ndarray, env: Any) -> None:
        """Telemetry against the nadir frame; in DETUMBLE the wheels idle."""
        p_c, w_o = nadir_frame(env.r_ref_eci, env.v_ref_eci)
        p_e = error_quaternion(p_c, q, self.shortest)
        self._set("p_e", p_e)
        self._set("theta_e", eigen_angle(p_e))
        self._set("omega_e", rate_error(omega, p_e, w_o))
        self._set("wheel_cmd", np.zeros((self.n, 3)))

    def _mtq_sample(self, step: int, R: np.ndarray, env: Any, omega: np.ndarray) -> None:
        """Magnetometer reading, B-dot estimate, each world's detumble law at the body rates
        ``omega`` [rad/s], clipped dipole (held for the cycle)."""
        B = mat_t_vec_blas(R, env.B_eci)
        self._set("B_meas", B)
        if self.has_prev:
            fd = (B - self.prev) / self.bdot_dt
            filt = self.c_prev * self.B_dot + self.c_in * (B - self.prev)
            B_dot = np.where(self.filtered[:, None], filt, fd)
        else:
            B_dot = np.zeros_like(B)
        self._set("B_dot", B_dot)
        self._set("prev", B.copy())
        self.has_prev = True
        m = -self.gain * self.B_dot
        if self.normalised.any():
            m_norm = normalised_bdot_dipole(self.B_dot, B, gain_Am2s=self.k_normalised)
            m = np.where(self.normalised[:, None], m_norm, m)
        if self.bang_bang.any():
            m = np.where(self.bang_bang[:, None], bang_bang_dipole(self.B_dot, self.limit), m)
        if self.b_cross.any():
            m = np.where(self.b_cross[:, None], bcross_dipole(omega, B, k_Nms=self.k_bcross), m)
        if self.non_monotonic.any():
            if self.extrapolated.all():
                B_ahead = mat_t_vec_blas(R, env.B_eci + self.lookahead_s * env.B_dot_eci)
            else:
                t_ahead = min(step * self.dt + self.lookahead_s, self.environments.t_max)
                B_ahead = mat_t_vec_blas(R, self.environments.sample(t_ahead).B_eci)
                if self.extrapolated.any():
                    B_ext = mat_t_vec_blas(R, env.B_eci + self.lookahead_s * env.B_dot_eci)
                    B_ahead = np.where(self.extrapolated[:, None], B_ext, B_ahead)
            m_nm = nonmonotonic_dipole(
                omega,
                B,
                B_ahead,
                self.inertia,
                gain_per_Nms=self.k_nonmon,
                alpha=self.alpha,
                m_max_Am2=self.limit,
            )
            m = np.where(self.non_monotonic[:, None], m_nm, m)
        for k in np.flatnonzero(self.plugin & self.live).tolist():
            try:
                m[k] = plugin_dipole(
                    self.laws[k],
                    self.law_params[k],
                    t_s=step * self.dt,
                    field_body_T=B[k],
                    field_rate_body_T_s=self.B_dot[k],
                    rate_body_rad_s=omega[k],
                    inertia_kgm2=self.inertia[k],
                    dipole_max_Am2=self.limit[k],
                )
            except Exception as err:  # noqa: BLE001 - the law is the user's code: its world fails alone
                m[k] = 0.0
                t_s, kind = step * self.dt, type(err).__name__
                self.law_errors[k] = f"control.bdot_law {self.laws[k]!r} raised {kind} at t = {t_s:.6g} s: {err}"
        self._set("dipole_held", np.clip(m, -self.limit, self.limit))

    def _motor_torque(self, w: np.ndarray) -> np.ndarray:
        """T_M (N, 3) of the held wheel commands at the relative speeds ``w`` [rad/s]."""
        cmd = self.wheel_cmd
        V = self.R_ohm * cmd + self.K_b * w
        V = np.where(V > self.V_max, self.V_max, np.where(V < -self.V_max, -self.V_max, V))
        T_dc = self.K_M * ((V - self.K_b * w) / self.R_ohm)
        T = np.where(self.ideal, cmd, T_dc)
        at_limit = (w >= self.w_max) | (w <= -self.w_max)
        stop = at_limit & ((T - self.K_B * w) * w > 0.0)
        return np.where(stop, self.K_B * w, T)

    # ------------------------------------------------------------------ state
    def get_state(self) -> dict[str, Any]:
        """The controller's state as plain data (copies)."""
        out: dict[str, Any] = {name: getattr(self, name).copy() for name in _STATE}
        out.update(has_prev=self.has_prev, last_att=self.last_att, last_mtq=self.last_mtq)
        return out

    def set_state(self, state: dict[str, Any]) -> None:
        """Continue from a state of :meth:`get_state`."""
        for name in _STATE:
            setattr(self, name, np.array(state[name], copy=True))
        self.has_prev = bool(state["has_prev"])
        self.last_att, self.last_mtq = int(state["last_att"]), int(state["last_mtq"])
