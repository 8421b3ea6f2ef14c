"""The one door for external forces: loads add into ``MjData.xfrc_applied``.

Every external force model is a *load*: an object built once (index arrays, masses, geometry)
that, each step, reads the current state and **adds** its forces and torques into the wrench
array ``xfrc`` (``(nbody, 6)``: world-frame force ``[:, :3]`` and torque ``[:, 3:]`` about each
body's centre of mass, exactly the layout of ``MjData.xfrc_applied``). The runner zeroes
``xfrc_applied`` once per step, lets every load add, then calls ``mj_step``.

Loads are vectorised over nodes and struts: no Python loop over struts in ``add``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from magsail_mj.checkpoint import restorable

__all__ = ["StepState", "Load"]


@restorable
@dataclass
class StepState:
    """What a load sees at one step.

    Attributes:
      t: simulation time [s] since the scenario epoch.
      pos: (nbody, 3) world positions of every body's frame origin (``MjData.xpos``) [m].
        For a lattice, node ``i`` is body ``i + 1`` (body 0 is the world).
      vel: (nbody, 3) world linear velocities of the body origins [m/s].
      xquat: (nbody, 4) world orientations, scalar-first ``[w, x, y, z]``.
      omega: (nbody, 3) world angular velocities [rad/s].
      env: environment sample at time ``t`` (field, reference orbit …) or ``None`` in free space.
      ctrl: the controller's current (zero-order-held) command object, or ``None``.
    """

    t: float
    pos: np.ndarray
    vel: np.ndarray
    xquat: np.ndarray
    omega: np.ndarray
    env: object | None = None
    ctrl: object | None = None


@runtime_checkable
class Load(Protocol):
    """A force model. ``add`` accumulates into ``xfrc`` (``(nbody, 6)``, world frame)."""

    name: str

    def add(self, state: StepState, xfrc: np.ndarray) -> None: ...
