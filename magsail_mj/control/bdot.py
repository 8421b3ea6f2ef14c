r"""B-dot detumbling law (CNUSAIL-1 paper Eqs. 24–27).

Per axis, with the magnetometer reading B_B (body axes, tesla) sampled every Δt (2 s):

    M_i = −K Ḃ_i,        T_mag = M × B_B,

K [A m² s/T] = 3e4 before deployment, 5e4 after. Two estimates of Ḃ:

* finite difference (Eq. 25, default): Ḃ_k = (B_k − B_{k−1})/Δt;
* filtered derivative (Eq. 26): Ḃ/B = ω_c s/(s + ω_c), discretised by Tustin at Δt,
  (2 + ω_c Δt) y_k = (2 − ω_c Δt) y_{k−1} + 2 ω_c (B_k − B_{k−1}), y_0 = 0
  (ω_c not in the paper; default 0.5 rad/s).

The first sample has no derivative: the command is zero. Saturation (per-axis clipping) and the
magnetometer-blanking duty cycle are applied by the caller
(:mod:`magsail_mj.loads.actuators_cubesat`).

Why it detumbles: for a field fixed in inertial space, Ḃ_B = −ω × B_B, so with the continuous
law T = M × B = K (ω × B) × B and ω·T = −K(|ω|²|B|² − (ω·B)²) ≤ 0: the rotational energy can
only decrease (tested).
"""

from __future__ import annotations

from typing import Literal

import numpy as np

__all__ = ["BdotFiniteDifference", "BdotFiltered", "make_bdot", "normalised_bdot_dipole"]


class BdotFiniteDifference:
    """B-dot with the finite-difference derivative (paper Eq. 25).

    Args:
      gain: K [A m² s/T] (> 0).
      sample_period_s: Δt between magnetometer samples [s].
    """

    form = "finite_difference"

    def __init__(self, *, gain: float, sample_period_s: float) -> None:
        if not gain > 0:
            raise ValueError(f"gain: must be > 0 A m² s/T, got {gain!r}")
        if not sample_period_s > 0:
            raise ValueError(f"sample_period_s: must be > 0 s, got {sample_period_s!r}")
        self.gain = float(gain)
        self.dt = float(sample_period_s)
        self._prev: np.ndarray | None = None
        self.B_dot = np.zeros(3)

    def reset(self) -> None:
        """Forget the previous sample (the next call returns zero)."""
        self._prev = None
        self.B_dot = np.zeros(3)

    def update(self, B_body: np.ndarray) -> np.ndarray:
        """New magnetometer sample B_B [T] → unsaturated dipole command M = −K Ḃ [A m²]."""
        B = np.asarray(B_body, dtype=float)
        if self._prev is None:
            self.B_dot = np.zeros(3)
        else:
            self.B_dot = (B - self._prev) / self.dt
        self._prev = B.copy()
        return -self.gain * self.B_dot


class BdotFiltered(BdotFiniteDifference):
    """B-dot with the first-order filtered derivative ω_c s/(s + ω_c), Tustin at Δt (paper Eq. 26).

    Args:
      gain: K [A m² s/T]; sample_period_s: Δt [s]; omega_c_rad_s: filter corner ω_c [rad/s].
    """

    form = "filtered"

    def __init__(self, *, gain: float, sample_period_s: float, omega_c_rad_s: float = 0.5) -> None:
        super().__init__(gain=gain, sample_period_s=sample_period_s)
        if not omega_c_rad_s > 0:
            raise ValueError(f"omega_c_rad_s: must be > 0 rad/s, got {omega_c_rad_s!r}")
        self.omega_c = float(omega_c_rad_s)
        a = self.omega_c * self.dt
        self._c_prev = (2.0 - a) / (2.0 + a)
        self._c_in = 2.0 * self.omega_c / (2.0 + a)

    def update(self, B_body: np.ndarray) -> np.ndarray:
        B = np.asarray(B_body, dtype=float)
        if self._prev is None:
            self.B_dot = np.zeros(3)
        else:
            self.B_dot = self._c_prev * self.B_dot + self._c_in * (B - self._prev)
        self._prev = B.copy()
        return -self.gain * self.B_dot


def make_bdot(
    form: Literal["finite_difference", "filtered"], *, gain: float, sample_period_s: float, omega_c_rad_s: float = 0.5
) -> BdotFiniteDifference:
    """B-dot law of the given ``form`` (``"finite_difference"`` or ``"filtered"``)."""
    if form == "finite_difference":
        return BdotFiniteDifference(gain=gain, sample_period_s=sample_period_s)
    if form == "filtered":
        return BdotFiltered(gain=gain, sample_period_s=sample_period_s, omega_c_rad_s=omega_c_rad_s)
    raise ValueError(f"form: must be 'finite_difference' or 'filtered', got {form!r}")


def normalised_bdot_dipole(B_dot: np.ndarray, B: np.ndarray, *, gain_Am2s: float | np.ndarray) -> np.ndarray:
    """B-dot scaled by the field magnitude, ``M = −k Ḃ/‖B‖`` [A m²] (unsaturated; the "B-dot" of
    Willis, Fisch, Seletskiy & Manchester 2024's code, ``bdot_control``), for field rates ``B_dot``
    [T/s] and fields ``B`` [T] (body axes, ``(..., 3)``) and gain ``gain_Am2s`` = k [A m² s] (scalar
    or ``(..., 1)``); zero where B = 0. ‖B‖ by components, so one row and a stack give the same bits."""
    B_dot = np.asarray(B_dot, dtype=float)
    B = np.asarray(B, dtype=float)
    n = np.sqrt(B[..., 0] * B[..., 0] + B[..., 1] * B[..., 1] + B[..., 2] * B[..., 2])[..., None]
    some = n > 0.0
    scale = np.where(some, gain_Am2s / np.where(some, n, 1.0), 0.0)
    return -scale * B_dot
