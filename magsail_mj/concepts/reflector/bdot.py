r"""B-dot detumbling of the rigid reflector plate with its two coil paths.

Body frame of the plate (``z`` = normal), SI units. The printed law (paper Eq. 8) is
``T_Bdot = k ω × B``. Laws (``law``):

* ``"dipole"`` (baseline): Eq. 8 read as the commanded dipole ``m_cmd = k ω × B_b``. Only the
  x-coil and y-coil act, so the dipole lies in the body ``xy`` plane with a box limit per path:
  ``m = (clip(m_x, ±m_max), clip(m_y, ±m_max), 0)``, ``T = m × B_b``. For a field fixed in inertial
  space ``Ḃ_b = −ω × B_b``, so this is the usual ``m = −k Ḃ``; unsaturated,
  ``T = k(ω × B)×B = −k|B|² ω_⊥B`` (restricted to the xy dipoles).
* ``"printed"`` (diagnostic): ``T = sat_{T_max}(k ω × B_b)``, applied as a torque. It is ⟂ ω, so it
  does no work (|ω| changes only through ω × Iω coupling of the torque direction).
* ``"norm_cap"``: ``T = sat_{T_max}(k (ω × B_b) × B_b)`` with ``sat_c(v) = v · min(1, c/|v|)``.

Gain: ``k = m_max / (B_ref ω_k)`` [A m² s/T per rad/s], so the dipole command saturates
for ``|ω_⊥| ≳ ω_k``. Path currents ``I_path = I_max m_path / m_max`` (positive current = dipole
along the path's +axis).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from magsail_mj.control.reflector_pitch import saturate_norm
from magsail_mj.quaternion import quat_to_matrix
from magsail_mj.vec3 import cross3
from magsail_mj.checkpoint import restorable

__all__ = ["BdotCommand", "PlateBdotController"]


@restorable
@dataclass
class BdotCommand:
    """Held output of :class:`PlateBdotController` (body frame).

    Attributes:
      torque_body: (3,) applied torque T_b [N m].
      dipole_body: (3,) achieved dipole m [A m²] (zero for the torque-form laws).
      dipole_cmd_body: (3,) unsaturated command k ω × B_b [A m²].
      currents_A: (2,) x-coil and y-coil currents [A].
      saturated: (2,) per-path saturation flags (x-coil, y-coil); for the torque-form laws both
        carry the norm-cap flag.
      B_body: (3,) field in body axes [T].
    """

    torque_body: np.ndarray
    dipole_body: np.ndarray = field(default_factory=lambda: np.zeros(3))
    dipole_cmd_body: np.ndarray = field(default_factory=lambda: np.zeros(3))
    currents_A: np.ndarray = field(default_factory=lambda: np.zeros(2))
    saturated: np.ndarray = field(default_factory=lambda: np.zeros(2, dtype=bool))
    B_body: np.ndarray = field(default_factory=lambda: np.zeros(3))


class PlateBdotController:
    """B-dot on the plate, run every integration step (zero-order hold).

    Args:
      law: ``"dipole"``, ``"printed"`` or ``"norm_cap"`` (module docstring).
      m_max_Am2: per-path dipole limit ``T_max / B_ref`` [A m²].
      T_max_Nm: torque cap of the torque-form laws [N m].
      gain: k [A m² s/T] (see module docstring; :meth:`gain_from_omega_k`).
      I_max_A: path current at ``m_max`` [A].
      field_body: callable ``(t, R) → B_b`` giving the body-frame field [T] from the time and the
        body → world rotation matrix ``R``.
      body_id: the plate body; the controller reads ``state.xquat[body_id]`` and the world rate
        ``state.omega[body_id]`` (body rate ``ω_b = Rᵀ ω_w``).
      period_s: controller period (= the integration step) [s].
    """

    def __init__(
        self,
        *,
        law: Literal["dipole", "printed", "norm_cap"],
        m_max_Am2: float,
        T_max_Nm: float,
        gain: float,
        I_max_A: float,
        field_body,
        body_id: int,
        period_s: float,
    ) -> None:
        if law not in ("dipole", "printed", "norm_cap"):
            raise ValueError(f"law: must be 'dipole', 'printed' or 'norm_cap', got {law!r}")
        for name, v in (
            ("m_max_Am2", m_max_Am2),
            ("T_max_Nm", T_max_Nm),
            ("gain", gain),
            ("I_max_A", I_max_A),
            ("period_s", period_s),
        ):
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name}: must be > 0, got {v!r}")
        self.law = law
        self.m_max = float(m_max_Am2)
        self.T_max = float(T_max_Nm)
        self.gain = float(gain)
        self.I_max = float(I_max_A)
        self.field_body = field_body
        self.body_id = int(body_id)
        self.period_s = float(period_s)
        self.last = BdotCommand(torque_body=np.zeros(3))

    @staticmethod
    def gain_from_omega_k(*, m_max_Am2: float, B_ref_T: float, omega_k_rad_s: float) -> float:
        """``k = m_max / (B_ref ω_k)``."""
        if not omega_k_rad_s > 0:
            raise ValueError(f"omega_k_rad_s: must be > 0 rad/s, got {omega_k_rad_s!r}")
        return m_max_Am2 / (B_ref_T * omega_k_rad_s)

    def command(self, omega_body: np.ndarray, B_body: np.ndarray) -> BdotCommand:
        """The law's command for body rate ω_b [rad/s] and field B_b [T]."""
        wxb = cross3(omega_body, B_body)
        if self.law == "dipole":
            m_cmd = self.gain * wxb
            mm = self.m_max
            mx, my = float(m_cmd[0]), float(m_cmd[1])
            m = np.array([min(max(mx, -mm), mm), min(max(my, -mm), mm), 0.0])
            sat = np.array([abs(mx) >= mm, abs(my) >= mm])
            return BdotCommand(
                torque_body=cross3(m, B_body),
                dipole_body=m,
                dipole_cmd_body=m_cmd,
                currents_A=self.I_max * m[:2] / mm,
                saturated=sat,
                B_body=B_body,
            )
        T_raw = self.gain * (wxb if self.law == "printed" else cross3(wxb, B_body))
        T, clipped = saturate_norm(T_raw, self.T_max)
        return BdotCommand(
            torque_body=T, dipole_cmd_body=self.gain * wxb, saturated=np.array([clipped, clipped]), B_body=B_body
        )

    def update(self, state) -> BdotCommand:
        R = quat_to_matrix(state.xquat[self.body_id])
        B_b = self.field_body(state.t, R)
        self.last = self.command(R.T @ state.omega[self.body_id], B_b)
        return self.last
