"""What the rigid-body facet loads share (:class:`~magsail_mj.loads.drag.RigidDragLoad`,
:class:`~magsail_mj.loads.srp.RigidSRPLoad`): the wrench of per-facet forces on one body."""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from magsail_mj.quaternion import quat_to_matrix
from magsail_mj.environment.surfaces import FacetSet

from magsail_mj.loads.base import StepState

__all__ = ["RigidFacetLoad"]


class RigidFacetLoad(ABC):
    """Base of a surface load on the facets of one rigid body.

    A subclass gives ``_scale``, the per-step scale of its force law (ρ or the SRP pressure;
    0 = no load this step), and ``_facet_forces``, the (nfacet, 3) world forces from the world
    facet normals. The wrench is ΣF_i (only with ``apply_force``) and Σ (R c_i) × F_i about the
    centre of mass.

    Args:
      body_id: MuJoCo body index; facets: the body's :class:`FacetSet` (centres relative to the
      centre of mass, body axes); apply_force: also add the net force.
    """

    def __init__(self, body_id: int, facets: FacetSet, *, apply_force: bool = True) -> None:
        self.body_id = int(body_id)
        self.facets = facets
        self.apply_force = bool(apply_force)

    @abstractmethod
    def _scale(self, env) -> float:
        """Per-step scale of the force law (0 = no load this step)."""

    @abstractmethod
    def _facet_forces(self, state: StepState, normals: np.ndarray, scale: float) -> np.ndarray:
        """(nfacet, 3) world forces from the world facet normals."""

    def wrench_world(self, state: StepState) -> tuple[np.ndarray, np.ndarray]:
        """(force, torque about the centre of mass) in world axes [N, N m]."""
        scale = self._scale(state.env)
        if scale == 0.0:
            return np.zeros(3), np.zeros(3)
        R = quat_to_matrix(state.xquat[self.body_id], normalise=True)
        f = self.facets
        F = self._facet_forces(state, f.normal @ R.T, scale)
        return F.sum(axis=0), np.cross(f.centre @ R.T, F).sum(axis=0)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        F, tau = self.wrench_world(state)
        if self.apply_force:
            xfrc[self.body_id, :3] += F
        xfrc[self.body_id, 3:] += tau
