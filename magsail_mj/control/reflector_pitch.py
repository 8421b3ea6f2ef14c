r"""Reflector pitch tracking: quaternion feedback, projection ⟂ B and saturation (Robb et al. 2020, Eqs. 14–15).

Body frame of the plate (``x`` grey line, ``y`` pitch axis, ``z`` normal); quaternions scalar
first, body → world; SI units.

Error and reference torque (normative form, Eqs. 14–15 corrected):

.. math::

   q_e = q_{ref}^{*}\otimes q_t\ (q_{e,w}\ge 0),\qquad
   \mathbf T_{ref,b} = -P_q\,\mathbf q_{e,vec} - P_\omega\,(\boldsymbol\omega_b - [\boldsymbol\omega_{ref,b}])
                        + [\mathcal I\,\boldsymbol\alpha_{ref,b}],

``rate_term = "absolute"`` (as printed, baseline) damps ω_b; ``"error"`` damps ω_b − ω_ref,b with
``ω_ref,b = R(q_e)ᵀ β̇ ŷ`` (the reference rate in current body axes); ``feedforward`` adds
``𝓘 α_ref,b`` with ``α_ref,b = R(q_e)ᵀ β̈ ŷ``. Gains per axis from a bandwidth:
``P_q = 2 I_jj ω_n²``, ``P_ω = 2 ζ ω_n I_jj``.

Actuator (normative): with the x-coil, y-coil and in-plane loop any torque ⟂ B is available,

.. math:: \mathbf T_{act} = \mathrm{sat}_{c}\big((\mathbb 1 - \hat b\hat b^{\mathsf T})\mathbf T_{ref}\big),

``saturation = "norm"`` (baseline): ``c = T_max`` (the coil capability at 30 µT);
``"field_scaled"``: ``c = T_max |B| / B_ref``; ``"per_path"``: ``m = B × T_ref / |B|²``, each
component clipped to its path's ``±m_max``, ``T = m × B``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Sequence

import numpy as np

from magsail_mj.control.reflector_steering import ReflectorOrbit, SteeringReference, SteeringState
from magsail_mj.quaternion import error_quaternion, quat_to_matrix
from magsail_mj.vec3 import cross3
from magsail_mj.checkpoint import restorable


__all__ = ["PitchCommand", "ReflectorPitchController", "pitch_gains", "project_and_saturate", "saturate_norm"]


def saturate_norm(v: np.ndarray, cap: float) -> tuple[np.ndarray, bool]:
    """``sat_c(v) = v · min(1, c/|v|)`` and whether it clipped."""
    n = math.sqrt(float(v @ v))
    if n > cap:
        return v * (cap / n), True
    return v, False


def pitch_gains(inertia: Sequence[float], *, omega_n_rad_s: float, zeta: float) -> tuple[np.ndarray, np.ndarray]:
    """``(P_q, P_ω)`` per axis: ``2 I_jj ω_n²`` [N m] and ``2 ζ ω_n I_jj`` [N m s]."""
    I = np.asarray(inertia, dtype=float)
    if not (omega_n_rad_s > 0 and zeta > 0):
        raise ValueError(f"omega_n_rad_s, zeta: must be > 0, got {omega_n_rad_s!r}, {zeta!r}")
    return 2 * I * omega_n_rad_s**2, 2 * zeta * omega_n_rad_s * I


def project_and_saturate(
    T_ref: np.ndarray,
    B: np.ndarray,
    *,
    saturation: Literal["norm", "field_scaled", "per_path"],
    cap_Nm: float,
    B_ref_T: float,
    m_max_Am2: np.ndarray,
) -> tuple[np.ndarray, bool]:
    """Achievable torque for the desired ``T_ref`` in field ``B`` (same axes) and whether it saturated."""
    B2 = float(B @ B)
    if not B2 > 0:
        return np.zeros(3), bool(np.any(T_ref != 0))
    if saturation == "per_path":
        m = cross3(B, T_ref) / B2
        mc = np.clip(m, -m_max_Am2, m_max_Am2)
        return cross3(mc, B), bool(np.any(np.abs(m) > m_max_Am2))
    b = B / math.sqrt(B2)
    T_perp = T_ref - b * float(b @ T_ref)
    cap = cap_Nm if saturation == "norm" else cap_Nm * math.sqrt(B2) / B_ref_T
    return saturate_norm(T_perp, cap)


@restorable
@dataclass
class PitchCommand:
    """Held output of :class:`ReflectorPitchController` (body frame unless named).

    ``torque_body`` T_act [N m]; ``T_ref_body`` [N m]; ``saturated``; ``q_e`` (4,); ``q_ref`` (4,);
    ``psi_ref``, ``psi_dot_ref`` [rad, rad/s]; ``psi_ddot_ref`` [rad/s²]; ``B_world`` [T].
    """

    torque_body: np.ndarray
    T_ref_body: np.ndarray
    saturated: bool
    q_e: np.ndarray
    q_ref: np.ndarray
    psi_ref: float
    psi_dot_ref: float
    psi_ddot_ref: float
    B_world: np.ndarray


class ReflectorPitchController:
    """Pitch tracking (Robb et al. 2020, Eqs. 14–15), run every integration step (zero-order hold).

    Args:
      orbit: the kinematic orbit (field, steering law).
      inertia_kgm2: principal moments (I₁, I₂, I₃) [kg m²] (gains, feed-forward).
      omega_n_rad_s, zeta: closed-loop bandwidth and damping of the gain design.
      rate_term: ``"absolute"`` (as printed) or ``"error"``.
      feedforward: add ``𝓘 α_ref``.
      saturation: ``"norm"``, ``"field_scaled"`` or ``"per_path"``.
      cap_Nm: torque cap T_max [N m].
      B_ref_T: reference field of the cap [T].
      m_max_Am2: (3,) per-path dipole limits (x-coil, y-coil, in-plane loop) [A m²].
      body_id: the plate body (reads ``state.xquat``, ``state.omega`` (world)).
      period_s: controller period [s].
    """

    def __init__(
        self,
        *,
        orbit: ReflectorOrbit,
        inertia_kgm2: Sequence[float],
        omega_n_rad_s: float,
        zeta: float,
        rate_term: Literal["absolute", "error"],
        feedforward: bool,
        saturation: Literal["norm", "field_scaled", "per_path"],
        cap_Nm: float,
        B_ref_T: float,
        m_max_Am2: Sequence[float],
        body_id: int,
        period_s: float,
    ) -> None:
        if rate_term not in ("absolute", "error"):
            raise ValueError(f"rate_term: must be 'absolute' or 'error', got {rate_term!r}")
        if saturation not in ("norm", "field_scaled", "per_path"):
            raise ValueError(f"saturation: must be 'norm', 'field_scaled' or 'per_path', got {saturation!r}")
        if not (math.isfinite(cap_Nm) and cap_Nm > 0):
            raise ValueError(f"cap_Nm: must be > 0, got {cap_Nm!r}")
        self.orbit = orbit
        self.steering = SteeringReference(orbit)
        self.inertia = np.asarray(inertia_kgm2, dtype=float)
        self.Pq, self.Pw = pitch_gains(self.inertia, omega_n_rad_s=omega_n_rad_s, zeta=zeta)
        self.rate_term = rate_term
        self.feedforward = bool(feedforward)
        self.saturation = saturation
        self.cap = float(cap_Nm)
        self.B_ref = float(B_ref_T)
        self.m_max = np.asarray(m_max_Am2, dtype=float)
        self.body_id = int(body_id)
        self.period_s = float(period_s)
        self.last: PitchCommand | None = None

    def reference_torque(self, q: np.ndarray, omega_body: np.ndarray, t: float):
        """``(T_ref_b, q_e, steering state)`` at time ``t`` for attitude ``q`` and body rate ω_b."""
        ref = self.steering.at(t)
        q_e = error_quaternion(ref.q_ref, q)
        w_err = omega_body
        if self.rate_term == "error" or self.feedforward:
            Re = quat_to_matrix(q_e)  # current body → reference body
            yb = Re[1]  # Reᵀ ŷ: the reference pitch axis in current body axes
            if self.rate_term == "error":
                w_err = omega_body - (-ref.psi_dot) * yb
        T = -self.Pq * q_e[1:] - self.Pw * w_err
        if self.feedforward:
            T = T + self.inertia * ((-ref.psi_ddot) * yb)
        return T, q_e, ref

    def update(self, state) -> PitchCommand:
        q = state.xquat[self.body_id]
        R = quat_to_matrix(q)
        w_b = R.T @ state.omega[self.body_id]
        T_ref, q_e, ref = self.reference_torque(q, w_b, state.t)
        self.last = self.saturated_command(T_ref, R=R, t=state.t, q_e=q_e, ref=ref)
        return self.last

    def saturated_command(
        self, T_ref: np.ndarray, *, R: np.ndarray, t: float, q_e: np.ndarray, ref: SteeringState
    ) -> PitchCommand:
        """The command of the reference torque ``T_ref`` [N m, body axes] at time ``t`` [s]: ``T_ref``
        projected perpendicular to ``B_b = Rᵀ B_w`` and saturated (:func:`project_and_saturate`), with
        the error quaternion ``q_e`` and the steering state ``ref`` as diagnostics (``R``: body →
        world rotation of the plate)."""
        B_w = self.orbit.field(t)
        T_act, sat = project_and_saturate(
            T_ref, R.T @ B_w, saturation=self.saturation, cap_Nm=self.cap, B_ref_T=self.B_ref, m_max_Am2=self.m_max
        )
        return PitchCommand(
            torque_body=T_act,
            T_ref_body=T_ref,
            saturated=sat,
            q_e=q_e,
            q_ref=ref.q_ref,
            psi_ref=ref.psi_c,
            psi_dot_ref=ref.psi_dot,
            psi_ddot_ref=ref.psi_ddot,
            B_world=B_w,
        )
