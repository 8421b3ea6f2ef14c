"""Body-frame torques on one rigid body: the held actuator torque and the classical gravity gradient.

``xfrc_applied`` torques are world-frame and act at the body's centre of mass, so a body-frame
torque ``T_b`` enters as ``τ_w = R(q) T_b`` (R body → world from ``state.xquat``), rewritten every
step (MuJoCo never clears ``xfrc_applied``; the runner zeroes it and the loads add).
"""

from __future__ import annotations

import numpy as np

from magsail_mj.quaternion import quat_to_matrix
from magsail_mj.environment.gravity import gravity_gradient_torque

from magsail_mj.loads.base import StepState

__all__ = ["HeldBodyTorqueLoad", "OrbitGravityGradientLoad"]


class HeldBodyTorqueLoad:
    """Adds ``R(q) · state.ctrl.torque_body`` (the controller's zero-order-held body torque [N m])."""

    name = "actuator_torque"

    def __init__(self, body_id: int) -> None:
        self.body_id = int(body_id)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        if state.ctrl is None:
            return
        R = quat_to_matrix(state.xquat[self.body_id])
        xfrc[self.body_id, 3:] += R @ state.ctrl.torque_body


class OrbitGravityGradientLoad:
    """Classical gravity-gradient torque ``T = 3μ/r³ r̂ × (I_w r̂)`` of a rigid body on a kinematic orbit.

    Args:
      body_id: the body.
      inertia_kgm2: (3,) principal moments in body axes [kg m²].
      position: callable ``t → r`` (3,) geocentric position in world axes [m].
      mu: gravitational parameter [m³/s²].

    In body axes this is ``3 n² r̂_b × (I r̂_b)``; here it is evaluated
    with ``I_w = R I Rᵀ`` in world axes (same value, tested).
    """

    name = "gravity_gradient"

    def __init__(self, body_id: int, *, inertia_kgm2, position, mu: float) -> None:
        self.body_id = int(body_id)
        self.inertia = np.diag(np.asarray(inertia_kgm2, dtype=float))
        self.position = position
        self.mu = float(mu)

    def torque_world(self, state: StepState) -> np.ndarray:
        R = quat_to_matrix(state.xquat[self.body_id])
        return gravity_gradient_torque(self.position(state.t), R @ self.inertia @ R.T, mu=self.mu)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        xfrc[self.body_id, 3:] += self.torque_world(state)
