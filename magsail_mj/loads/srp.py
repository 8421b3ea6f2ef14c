"""Solar radiation pressure on flat facets: rigid bodies and lattice top-layer cells.

Force law: :func:`magsail_mj.environment.surfaces.srp_forces` (McInnes' non-ideal flat-plate
model, CNUSAIL spec §6.3 with errata E-6, E-10, E-11). The pressure comes from the environment
sample, ``state.env.srp_pressure_N_m2`` = P_1AU (1 AU/d)², which is zero in the Earth's shadow;
the Sun direction is ``state.env.sun_eci`` (world = ECI axes). Self-shadowing is not modelled.

* :class:`RigidSRPLoad`: facets fixed in one body; facet normals and centres rotate with
  ``state.xquat``; adds ΣF_i (optional) and Σ (R c_i) × F_i about the centre of mass
  (CNUSAIL Eq. 22 generalised to several facets).
* :class:`LatticeSRPLoad`: quadrilateral cells given by corner node indices; each cell's area
  and normal come from the **current** node positions (vector area ½ d₁ × d₂ of the diagonals),
  and its force is shared equally among its four corner nodes (so it acts at the corner
  centroid). Body index = node index + ``body_offset`` (1 for a lattice whose body 0 is the world).
"""

from __future__ import annotations

import numpy as np

from magsail_mj.environment.frames import quat_to_mat
from magsail_mj.environment.surfaces import (
    FacetSet,
    Optics,
    cell_node_matrix,
    optics_arrays,
    quad_area_vectors,
    srp_forces,
)

from .base import StepState

__all__ = ["RigidSRPLoad", "LatticeSRPLoad"]


class RigidSRPLoad:
    """SRP on the facets of one rigid body.

    Args:
      body_id: MuJoCo body index; facets: the body's :class:`FacetSet` (centres relative to the
      centre of mass, body axes); apply_force: also add the net force (``False`` for attitude runs
      whose translation belongs to the reference orbit, CNUSAIL spec §4.3).
    """

    name = "srp"

    def __init__(self, body_id: int, facets: FacetSet, *, apply_force: bool = True) -> None:
        self.body_id = int(body_id)
        self.facets = facets
        self.apply_force = bool(apply_force)

    def wrench_world(self, state: StepState) -> tuple[np.ndarray, np.ndarray]:
        """(force, torque about the centre of mass) in world axes [N, N m]."""
        env = state.env
        P = env.srp_pressure_N_m2
        if P == 0.0:
            return np.zeros(3), np.zeros(3)
        R = quat_to_mat(state.xquat[self.body_id])
        f = self.facets
        F = srp_forces(f.normal @ R.T, f.area, env.sun_eci, P, f.coeffs, f.two_sided)
        tau = np.cross(f.centre @ R.T, F).sum(axis=0)
        return F.sum(axis=0), tau

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        F, tau = self.wrench_world(state)
        if self.apply_force:
            xfrc[self.body_id, :3] += F
        xfrc[self.body_id, 3:] += tau


class LatticeSRPLoad:
    """SRP on lattice cells with the current geometry.

    Args:
      cells: (ncell, 4) node indices of each cell's corners, counter-clockwise about the front
        normal (see :func:`magsail_mj.environment.surfaces.lattice_top_cells`).
      optics: surface coefficients (one for all cells); two_sided: membrane (default) or not.
      body_offset: body index of node 0 (1 when body 0 is the world).
    """

    name = "srp_lattice"

    def __init__(self, cells, *, optics: Optics | None = None, two_sided: bool = True,
                 body_offset: int = 1) -> None:
        cells = np.asarray(cells, dtype=np.int64)
        if cells.ndim != 2 or cells.shape[1] != 4:
            raise ValueError(f"cells: must have shape (ncell, 4), got {cells.shape}")
        self.cells = cells
        self.body_cells = cells + int(body_offset)
        self.body_offset = int(body_offset)
        self.optics = optics or Optics()
        self.coeffs = optics_arrays([self.optics])
        self.two_sided = bool(two_sided)
        self._S = None

    def _scatter(self, nrows: int):
        if self._S is None or self._S.shape[0] != nrows:
            self._S = cell_node_matrix(self.body_cells, nrows)
        return self._S

    def cell_forces(self, state: StepState) -> np.ndarray:
        """Force on each cell (ncell, 3) [N] in world axes."""
        env = state.env
        A = quad_area_vectors(state.pos, self.body_cells)
        area = np.sqrt(np.einsum("ij,ij->i", A, A))
        normal = A / area[:, None]
        return srp_forces(normal, area, env.sun_eci, env.srp_pressure_N_m2, self.coeffs, self.two_sided)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        if state.env.srp_pressure_N_m2 == 0.0:
            return
        xfrc[:, :3] += self._scatter(xfrc.shape[0]) @ self.cell_forces(state)
