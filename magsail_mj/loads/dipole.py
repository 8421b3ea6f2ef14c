"""Residual magnetic dipole torque on a rigid body (Eq. 23).

    T = D × B,

with D the body-fixed residual dipole [A m²] rotated to world axes, D_w = R D_body (R from
``state.xquat``, body → world), and B = ``state.env.B_eci`` (world = ECI axes) [T]. The torque is
added to the torque rows of ``xfrc`` in world axes.
"""

from __future__ import annotations

import numpy as np

from magsail_mj.quaternion import quat_to_matrix

from magsail_mj.loads.base import StepState

__all__ = ["ResidualDipoleLoad"]


class ResidualDipoleLoad:
    """Torque D × B of a body-fixed dipole ``dipole_body`` [A m²] on body ``body_id``."""

    name = "residual_dipole"

    def __init__(self, body_id: int, dipole_body) -> None:
        D = np.asarray(dipole_body, dtype=float)
        if D.shape != (3,):
            raise ValueError(f"dipole_body: must have 3 components [A m²], got shape {D.shape}")
        self.body_id = int(body_id)
        self.dipole_body = D

    def torque_world(self, state: StepState) -> np.ndarray:
        D_w = quat_to_matrix(state.xquat[self.body_id], normalise=True) @ self.dipole_body
        return np.cross(D_w, state.env.B_eci)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        xfrc[self.body_id, 3:] += self.torque_world(state)
