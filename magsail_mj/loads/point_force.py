"""Constant world-frame forces on chosen bodies (e.g. the cantilever's tip load)."""

from __future__ import annotations

import numpy as np

from magsail_mj.loads.base import StepState

__all__ = ["NodeForceLoad"]


class NodeForceLoad:
    """Adds a fixed force ``force[k]`` [N] (world frame) to body ``bodies[k]`` every step."""

    name = "node_force"

    def __init__(self, bodies: np.ndarray, force: np.ndarray):
        self.bodies = np.asarray(bodies, dtype=int)
        self.force = np.asarray(force, dtype=float).reshape(self.bodies.size, 3)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        xfrc[self.bodies, :3] += self.force
