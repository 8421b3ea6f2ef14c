r"""PD comparison law (CNUSAIL-1 paper Eq. 40).

    u = −K_PD q_e − C ω_e,     K_PD = k J,   C = c J,

with J the spacecraft inertia matrix, q_e the error-quaternion vector part and ω_e the rate error
of :mod:`magsail_mj.concepts.cnusail.eigenaxis`, and the same k = 2ω_n², c = 2ζω_n as the eigen-axis law,
so the two laws are identical for small errors (both give q̈_e ≈ −(k/2) q_e − c q̇_e). The paper
does not define its PD gain matrix; k J (rather than the diag(k_i) J of Eq. 29) is the
only choice that makes the comparison about large-angle behaviour. As printed, there is no
saturation function and no gyroscopic term. Large errors therefore ask for large torques, which
the wheel driver clips at τ_max: the rate is not limited and the rotation axis wanders.
"""

from __future__ import annotations

import numpy as np

__all__ = ["pd_torque"]


def pd_torque(q_e: np.ndarray, omega_e: np.ndarray, inertia: np.ndarray, *, k: float, c: float) -> np.ndarray:
    """u = −k J q_e − c J ω_e [N m] (body axes); ``q_e`` (3,), ``omega_e`` (3,) [rad/s],
    ``inertia`` (3, 3) [kg m²], ``k`` [1/s²], ``c`` [1/s]."""
    if not k > 0 or not c > 0:
        raise ValueError(f"k, c: must be > 0, got {k!r}, {c!r}")
    J = np.asarray(inertia, dtype=float)
    return -J @ (k * np.asarray(q_e, dtype=float) + c * np.asarray(omega_e, dtype=float))
