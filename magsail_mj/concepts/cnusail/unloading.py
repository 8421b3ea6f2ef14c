r"""Magnetic momentum unloading of the reaction wheels (CNUSAIL-1 paper Eq. 39).

    m = −(k_rw/|B_B|²) B_B × Δh,      T_mag = m × B_B = −k_rw (Δh − (Δh·B̂) B̂),

Δh = h_w − h_w,des with h_w,des = 0 and h_w = I_w ω_M (wheel momentum relative to the bus, body
axes). Only the part of Δh perpendicular to B can be removed. The attitude loop sees T_mag as a
disturbance and moves the wheels to absorb it, which drains h_w.

Activation (the paper only says the logic runs when the wheel momentum exceeds a limit): **per
axis** — component j of Δh is kept while |ω_M,j| > ω_on (3000 rpm, on the
speed: the paper's 1.35 mN m s does not match 3000 rpm) and
set to zero otherwise; no unloading when all three are below. Optional hysteresis: once on, an
axis stays on until |ω_M,j| < ω_off (``off_rpm``; default ω_off = ω_on, i.e. no hysteresis).
The dipole is limited by uniform scaling (:func:`magsail_mj.loads.actuators_cubesat.saturate_uniform`)
and runs on the 2 s magnetorquer cycle with blanking; k_rw is not in the paper (default
0.005 1/s).
"""

from __future__ import annotations

import numpy as np

from magsail_mj.loads.actuators_cubesat import RPM

__all__ = ["unloading_dipole", "UnloadingLogic"]


def unloading_dipole(delta_h: np.ndarray, B_body: np.ndarray, *, k_rw: float) -> np.ndarray:
    """m = −(k_rw/|B|²) B × Δh [A m²] (unsaturated); zero when B = 0."""
    B = np.asarray(B_body, dtype=float)
    b2 = float(B @ B)
    if b2 == 0.0:
        return np.zeros(3)
    return -(k_rw / b2) * np.cross(B, np.asarray(delta_h, dtype=float))


class UnloadingLogic:
    """Per-axis activation of the unloading (module docstring).

    Args:
      on_rpm: |ω_M| above which an axis is unloaded [rpm] (3000).
      off_rpm: |ω_M| below which an active axis stops (``None``: = ``on_rpm``, no hysteresis).
    """

    def __init__(self, *, on_rpm: float = 3000.0, off_rpm: float | None = None) -> None:
        if not on_rpm > 0:
            raise ValueError(f"on_rpm: must be > 0, got {on_rpm!r}")
        off = on_rpm if off_rpm is None else off_rpm
        if not 0 <= off <= on_rpm:
            raise ValueError(f"off_rpm: must be in [0, on_rpm = {on_rpm}], got {off_rpm!r}")
        self.on = on_rpm * RPM
        self.off = off * RPM
        self.active = np.zeros(3, dtype=bool)

    def update(self, omega_M: np.ndarray) -> np.ndarray:
        """Active mask (3,) bool for the relative wheel speeds ``omega_M`` [rad/s]."""
        w = np.abs(np.asarray(omega_M, dtype=float))
        self.active = np.where(self.active, w >= self.off, w > self.on) if self.off < self.on else w > self.on
        return self.active.copy()
