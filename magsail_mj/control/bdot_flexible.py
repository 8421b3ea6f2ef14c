r"""B-dot detumbling of the flexible truss with the rod array.

Control law, body components (best-fit body frame):

.. math:: \mathbf T_{\text{Bdot}} = k_{\text{Bdot}}\,(\boldsymbol\omega\times\mathbf B_b)\times\mathbf B_b,
          \qquad k_{\text{Bdot}} = 10^{12}\ \text{N m s T}^{-2}\ \text{(default)},

with ``ω`` the backward-difference body rate of the best-fit rotation and ``B_b = Rᵀ B``
the field at the centre of mass. It equals ``m × B_b`` with the dipole
``m = k_Bdot ω × B_b`` — the familiar ``m = −k Ḃ_body`` for a field fixed in inertial space,
``Ḃ_body = −ω × B_b`` — and dissipates rotational energy:

.. math:: \boldsymbol\omega\cdot\mathbf T = -k\,\lvert\boldsymbol\omega\times\mathbf B_b\rvert^2 \le 0 .

``T_Bdot`` is the reference torque ``T_ref`` of the allocation; with the default gain it
exceeds the array's authority by orders of magnitude, so the allocation saturates most of the
time and the array acts as a bang-bang B-dot (the fraction of saturated samples is recorded).
"""

from __future__ import annotations

from typing import Any, Unpack

import numpy as np

from magsail_mj.control.rod_attitude import RodAttitudeController, RodControllerOptions
from magsail_mj.vec3 import cross3

__all__ = ["bdot_torque", "BdotRodController"]


def bdot_torque(omega_body: np.ndarray, B_body: np.ndarray, *, k_Nms_T2: float) -> np.ndarray:
    r"""``T = k (ω × B) × B`` [N m], body components.

    Args:
      omega_body: (3,) or (K, 3) body rate [rad/s].
      B_body: (3,) or (K, 3) field [T], same frame.
      k_Nms_T2: gain ``k_Bdot`` [N m s/T²], ``>= 0``.
    """
    if not (np.isfinite(k_Nms_T2) and k_Nms_T2 >= 0):
        raise ValueError(f"k_Nms_T2: must be a number >= 0 N m s/T², got {k_Nms_T2!r}")
    w = np.asarray(omega_body, dtype=float)
    B = np.asarray(B_body, dtype=float)
    if w.shape == (3,) and B.shape == (3,):  # the per-sample path
        return k_Nms_T2 * cross3(cross3(w, B), B)
    return k_Nms_T2 * np.cross(np.cross(w, B), B)


class BdotRodController(RodAttitudeController):
    """B-dot on the flexible structure feeding the rod allocation.

    Args:
      k_Nms_T2: ``k_Bdot`` [N m s/T²] (default 1e12).
      reference_nodes, masses, node_bodies, distributor, period_s, omega0_body, rate_method: see
        :class:`~magsail_mj.control.rod_attitude.RodAttitudeController` (``omega0_body`` is the
        known initial rate, used at the first sample).
    """

    law = "bdot"

    def __init__(
        self,
        *,
        k_Nms_T2: float = 1e12,
        **base: Unpack[RodControllerOptions],
    ) -> None:
        super().__init__(**base)
        if not (np.isfinite(k_Nms_T2) and k_Nms_T2 >= 0):
            raise ValueError(f"k_Nms_T2: must be a number >= 0 N m s/T², got {k_Nms_T2!r}")
        self.k = float(k_Nms_T2)

    def reference_torque(
        self, *, t: float, R: np.ndarray, omega_body: np.ndarray, B_body: np.ndarray, com_world: np.ndarray, env: Any
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """``T_ref = k (ω × B_b) × B_b`` (body components, N m)."""
        return bdot_torque(omega_body, B_body, k_Nms_T2=self.k), {}
