"""Solar radiation pressure on flat facets: rigid bodies and lattice top-layer cells.

Force law: :func:`magsail_mj.environment.surfaces.srp_forces` (McInnes' non-ideal flat-plate
model, Yoo et al. 2016, Eqs. 16–22 with its misprints corrected). The pressure comes from the environment
sample, ``state.env.srp_pressure_N_m2`` = P_1AU (1 AU/d)², which is zero in the Earth's shadow;
the Sun direction is ``state.env.sun_eci`` (world = ECI axes). Self-shadowing is not modelled.

* :class:`RigidSRPLoad`: facets fixed in one body; facet normals and centres rotate with
  ``state.xquat``; adds ΣF_i (optional) and Σ (R c_i) × F_i about the centre of mass
  (CNUSAIL Eq. 22 generalised to several facets).
* :class:`LatticeSRPLoad`: quadrilateral cells given by corner node indices; each cell's area
  and normal come from the **current** node positions (vector area ½ d₁ × d₂ of the diagonals),
  and its force is shared equally among its four corner nodes (so it acts at the corner
  centroid). Body index = node index + ``body_offset`` (1 for a lattice whose body 0 is the world).

:func:`plate_srp_forces` is the force law of many flat plates with their coefficients folded into
constants, on (3, k) component-major arrays: the lattice cells' law, shared with the structure
concept's panels (:mod:`magsail_mj.concepts.structure.loads`).
"""

from __future__ import annotations

import numpy as np

from magsail_mj.environment.surfaces import (
    CellGeometry,
    Optics,
    srp_forces,
    uniform_srp_constants,
)

from magsail_mj.loads.base import StepState
from magsail_mj.loads.facets import RigidFacetLoad

__all__ = ["RigidSRPLoad", "LatticeSRPLoad", "plate_srp_forces"]


def plate_srp_forces(
    area_m2: np.ndarray,
    normal: np.ndarray,
    sun: np.ndarray,
    pressure_N_m2: float,
    *,
    rs: float | np.ndarray,
    k_front: float | np.ndarray,
    k_back: float | np.ndarray,
    one_minus_rs: float | np.ndarray,
    two_sided: bool = True,
) -> np.ndarray:
    """SRP force (3, k) [N] on k flat plates, the law of
    :func:`~magsail_mj.environment.surfaces.srp_forces` with the coefficients folded into constants
    (:func:`~magsail_mj.environment.surfaces.uniform_srp_constants`):

        F = −P A cos α [(1 − r s) ŝ + (2 r s cos α + K_l) n̂_l],

    ``cos α = |ŝ·n̂|``, ``n̂_l = ±n̂`` the lit face's normal and ``K_l`` = ``k_front`` or ``k_back``
    by the lit face.

    Args:
      area_m2: (k,) plate areas [m²]; normal: (3, k) unit front normals; sun: (3,) unit vector to
        the Sun (same axes); pressure_N_m2: P [N/m²] (0 in shadow).
      rs, k_front, k_back, one_minus_rs: the constants, one for all plates or (k,) per plate.
      two_sided: the back face takes light too (a membrane); else a plate lit from behind feels
        nothing.
    """
    s = sun
    c = s[0] * normal[0] + s[1] * normal[1] + s[2] * normal[2]
    front = c >= 0.0
    cos_a = np.abs(c)
    two_rs_cos = (2.0 * rs) * cos_a
    k_n = np.where(front, two_rs_cos + k_front, -(two_rs_cos + k_back))
    scale = (-pressure_N_m2) * area_m2 * cos_a
    if not two_sided:
        scale = np.where(front, scale, 0.0)
    F = (scale * k_n) * normal
    if np.ndim(one_minus_rs) == 0:
        F += np.multiply.outer(s * one_minus_rs, scale)
    else:
        F += (s[:, None] * one_minus_rs) * scale
    return F


class RigidSRPLoad(RigidFacetLoad):
    """SRP on the facets of one rigid body.

    Args:
      body_id: MuJoCo body index; facets: the body's :class:`FacetSet` (centres relative to the
      centre of mass, body axes); apply_force: also add the net force (``False`` for attitude runs
      whose translation belongs to the reference orbit).
    """

    name = "srp"

    def _scale(self, env) -> float:
        return env.srp_pressure_N_m2

    def _facet_forces(self, state: StepState, normals: np.ndarray, P: float) -> np.ndarray:
        f = self.facets
        return srp_forces(normals, f.area, state.env.sun_eci, P, f.coeffs, f.two_sided)


class LatticeSRPLoad:
    """SRP on lattice cells with the current geometry.

    Args:
      cells: (ncell, 4) node indices of each cell's corners, counter-clockwise about the front
        normal (see :func:`magsail_mj.environment.surfaces.lattice_top_cells`).
      optics: surface coefficients (one for all cells); two_sided: membrane (default) or not.
      body_offset: body index of node 0 (1 when body 0 is the world).

    Per step (vectorised, (3, ncell) layout): cell areas and normals from the current node
    positions, the force law of :func:`~magsail_mj.environment.surfaces.srp_forces` with the
    coefficients folded into constants (:func:`~magsail_mj.environment.surfaces.uniform_srp_constants`),
    and one sparse product to share the forces among the corners.
    """

    name = "srp_lattice"

    def __init__(self, cells, *, optics: Optics | None = None, two_sided: bool = True, body_offset: int = 1) -> None:
        cells = np.asarray(cells, dtype=np.int64)
        if cells.ndim != 2 or cells.shape[1] != 4:
            raise ValueError(f"cells: must have shape (ncell, 4), got {cells.shape}")
        self.cells = cells
        self.body_offset = int(body_offset)
        self.geometry = CellGeometry(cells + self.body_offset)
        self.optics = optics or Optics()
        self.two_sided = bool(two_sided)
        self._rs, self._k_front, self._k_back, self._one_minus_rs = uniform_srp_constants(self.optics)

    def cell_forces(self, state: StepState) -> np.ndarray:
        """Force on each cell (3, ncell) [N] in world axes (:func:`plate_srp_forces`)."""
        env = state.env
        area, n = self.geometry.area_normal(state.pos)
        return plate_srp_forces(
            area,
            n,
            env.sun_eci,
            env.srp_pressure_N_m2,
            rs=self._rs,
            k_front=self._k_front,
            k_back=self._k_back,
            one_minus_rs=self._one_minus_rs,
            two_sided=self.two_sided,
        )

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        if state.env.srp_pressure_N_m2 == 0.0:
            return
        self.geometry.scatter(self.cell_forces(state), xfrc)
