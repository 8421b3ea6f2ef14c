r"""Quaternion PD with current-loop allocation (Eqs. 18–20 corrected).

Each control sample, from the particle positions and velocities (or a rigid body's state):

1. attitude ``R`` = mass-weighted best-fit rotation of the nodes against the undeformed lattice,
   ``q`` its quaternion with sign continuity; body rate (``rate_estimator``):

   * ``"velocity_fit"`` (default): the least-squares rigid-velocity fit ``ω = J_c⁻¹ H_c`` of the
     particle velocities about the centre of mass, rotated into body axes (our choice;
     the rigid surrogate uses its body rate);
   * ``"finite_difference"``: the backward difference of the estimated attitude,
     ``ω_k = vee(log(R_{k−1}ᵀ R_k)) / (t_k − t_{k−1})`` (body axes), from positions only. Exact
     for a constant body rate; for a varying rate it is the mean rate over the last sample
     period, so it lags: ``|ω_k − ω(t_k)| ≤ ½ Δt max|ω̇|`` for a rotation about a fixed axis.
     The first sample, with no earlier attitude, returns the known initial rate, zero (the
     plate starts at rest);
2. error ``q_e = q_d* ⊗ q`` (negated when its scalar part is negative), vector part ``q_ev``;
3. ``T_ref = −k_p q_ev − k_ω ω`` in body axes (Eq. 18);
4. dipole command ``m_d = B_b × T_ref / |B_b|²`` (Eq. 19 with ``|B|²``);
5. currents ``I_L = (m_d,L / m_max) I_max,L`` per axis, then

   * ``allocation = "paper_clip"``: each clipped to ``±I_max,L`` (Eq. 20 as intended;
     does not keep the torque direction);
   * ``allocation = "direction_preserving"``: all three scaled by one factor so that the largest
     ``|I_L| / I_max,L`` is 1 (alternative option).

The command object carries ``currents_A`` (read by :class:`~magsail_mj.concepts.current_loops.lorentz.LorentzLoad`)
and the diagnostics the scenario records.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from magsail_mj.estimation.attitude import BestFitRotation, body_rate_step
from magsail_mj.quaternion import quat_from_matrix
from magsail_mj.quaternion import quat_conj, quat_mul
from magsail_mj.checkpoint import restorable

__all__ = ["LoopCommand", "LoopAttitudeController", "allocate_currents", "rigid_velocity_fit", "RATE_ESTIMATORS"]

RATE_ESTIMATORS = ("velocity_fit", "finite_difference")


def rigid_velocity_fit(x: np.ndarray, v: np.ndarray, m: np.ndarray) -> np.ndarray:
    r"""World angular velocity of the least-squares rigid velocity field.

    ``ω = J_c⁻¹ H_c`` with ``H_c = Σ m_i (x_i − c) × (v_i − v_c)`` and
    ``J_c = Σ m_i (|r_i|² I − r_i r_iᵀ)`` about the centre of mass ``c`` (world axes).
    It minimises ``Σ m_i |v_i − v_c − ω × r_i|²``.
    """
    M = m.sum()
    r = x - (m @ x) / M
    u = v - (m @ v) / M
    H = np.cross(r, u).T @ m
    S = (r * m[:, None]).T @ r
    J = np.trace(S) * np.eye(3) - S
    return np.linalg.solve(J, H)


def allocate_currents(
    m_cmd: np.ndarray, *, m_max: float, I_max: np.ndarray, mode: Literal["paper_clip", "direction_preserving"]
) -> tuple[np.ndarray, np.ndarray]:
    """Currents of the x, y, z circuits for a body dipole command (Eq. 20 as intended).

    Returns ``(currents_A, saturated)`` where ``saturated[L]`` flags a clipped (or scaled) axis.
    """
    I = m_cmd / m_max * I_max
    ratio = np.abs(I) / I_max
    if mode == "paper_clip":
        sat = ratio > 1.0
        return np.clip(I, -I_max, I_max), sat
    if mode == "direction_preserving":
        peak = ratio.max()
        if peak > 1.0:
            return I / peak, ratio >= peak
        return I, np.zeros(3, dtype=bool)
    raise ValueError(f"mode: must be 'paper_clip' or 'direction_preserving', got {mode!r}")


@restorable
@dataclass
class LoopCommand:
    """What one control sample decided (held until the next sample)."""

    currents_A: np.ndarray
    saturated: np.ndarray
    q: np.ndarray
    q_err: np.ndarray
    omega_body: np.ndarray
    torque_ref_body: np.ndarray
    dipole_cmd_body: np.ndarray
    B_body: np.ndarray
    R: np.ndarray


class LoopAttitudeController:
    """Quaternion PD on the best-fit attitude with per-axis loop-current allocation.

    Args:
      period_s: sample period (the shipped configs run it every integration step).
      p_ref: (n, 3) undeformed node positions (body frame; the lattice nodes).
      masses: (n,) particle masses [kg].
      node_bodies: (n,) body indices of the nodes in the state arrays.
      q_target: target attitude, body → inertial, scalar first.
      kp_Nm, kw_Nms: gains of Eq. 18.
      m_max_Am2: common dipole at full current (allocation scale).
      I_max_A: (3,) full currents of the x, y, z circuits.
      allocation: ``"paper_clip"`` or ``"direction_preserving"``.
      field_world: fixed world field [T], or ``None`` to read ``state.env.B_eci``.
      rate_estimator: ``"velocity_fit"`` (default) or ``"finite_difference"`` (module docstring).
    """

    def __init__(
        self,
        *,
        period_s: float,
        p_ref: np.ndarray,
        masses: np.ndarray,
        node_bodies: np.ndarray,
        q_target: np.ndarray,
        kp_Nm: float,
        kw_Nms: float,
        m_max_Am2: float,
        I_max_A: np.ndarray,
        allocation: Literal["paper_clip", "direction_preserving"] = "paper_clip",
        field_world: np.ndarray | None = None,
        rate_estimator: Literal["velocity_fit", "finite_difference"] = "velocity_fit",
    ):
        if not period_s > 0:
            raise ValueError(f"period_s: must be > 0, got {period_s!r}")
        self.period_s = float(period_s)
        self.fit = BestFitRotation(p_ref)
        self.masses = np.asarray(masses, dtype=float)
        self.node_bodies = np.asarray(node_bodies, dtype=int)
        q = np.asarray(q_target, dtype=float)
        self.q_target = q / np.linalg.norm(q)
        self.kp, self.kw = float(kp_Nm), float(kw_Nms)
        self.m_max = float(m_max_Am2)
        self.I_max = np.asarray(I_max_A, dtype=float)
        if self.I_max.shape != (3,) or np.any(self.I_max <= 0):
            raise ValueError(f"I_max_A: must be three positive currents, got {I_max_A!r}")
        self.allocation = allocation
        allocate_currents(np.zeros(3), m_max=1.0, I_max=np.ones(3), mode=allocation)  # validates
        self.field_world = None if field_world is None else np.asarray(field_world, dtype=float)
        self._q_prev = np.array([1.0, 0.0, 0.0, 0.0])
        if rate_estimator not in RATE_ESTIMATORS:
            raise ValueError(f"rate_estimator: must be one of {RATE_ESTIMATORS}, got {rate_estimator!r}")
        self.rate_estimator = rate_estimator
        self._R_prev = np.eye(3)
        self._t_prev = 0.0
        self._have_prev = False
        self._omega_fd = np.zeros(3)

    def attitude(self, x: np.ndarray, v: np.ndarray, *, t: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(R, q, ω_body)`` of the node set at time ``t`` [s] (sign-continuous quaternion; ``t``
        is used by the finite-difference rate only)."""
        R, _ = self.fit(x)
        q = quat_from_matrix(R)
        if q @ self._q_prev < 0:
            q = -q
        self._q_prev = q
        if self.rate_estimator == "velocity_fit":
            return R, q, R.T @ rigid_velocity_fit(x, v, self.masses)
        return R, q, self.body_rate(R, t=t, measured_body=np.zeros(3))

    def body_rate(self, R: np.ndarray, *, t: float, measured_body: np.ndarray) -> np.ndarray:
        """Body rate [rad/s] of the estimator: ``measured_body`` (the velocity fit, or a rigid
        body's rate) for ``"velocity_fit"``; the backward difference of ``R`` (body → world) against
        the previous sample for ``"finite_difference"`` (zero at the first sample; a repeated time
        returns the previous estimate)."""
        if self.rate_estimator == "velocity_fit":
            return np.asarray(measured_body, dtype=float)
        if self._have_prev and t > self._t_prev:
            self._omega_fd = body_rate_step(self._R_prev, R, t - self._t_prev)
        if not self._have_prev or t > self._t_prev:
            self._R_prev, self._t_prev, self._have_prev = np.array(R, dtype=float), float(t), True
        return self._omega_fd.copy()

    def command(self, R: np.ndarray, q: np.ndarray, omega_body: np.ndarray, B_world: np.ndarray) -> LoopCommand:
        """Eqs. 18–20 for a given attitude, body rate and world field."""
        q_err = quat_mul(quat_conj(self.q_target), q)
        if q_err[0] < 0:
            q_err = -q_err
        T_ref = -self.kp * q_err[1:] - self.kw * omega_body
        B_b = R.T @ B_world
        b2 = B_b @ B_b
        m_cmd = np.cross(B_b, T_ref) / b2 if b2 > 0 else np.zeros(3)
        currents, sat = allocate_currents(m_cmd, m_max=self.m_max, I_max=self.I_max, mode=self.allocation)
        return LoopCommand(
            currents_A=currents,
            saturated=sat,
            q=q,
            q_err=q_err,
            omega_body=omega_body,
            torque_ref_body=T_ref,
            dipole_cmd_body=m_cmd,
            B_body=B_b,
            R=R,
        )

    def field(self, state) -> np.ndarray:
        return self.field_world if self.field_world is not None else np.asarray(state.env.B_eci)

    def update(self, state) -> LoopCommand:
        x = state.pos[self.node_bodies]
        v = state.vel[self.node_bodies]
        R, q, w = self.attitude(x, v, t=state.t)
        return self.command(R, q, w, self.field(state))
