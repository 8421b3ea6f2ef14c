"""Aerodynamic drag on flat facets: rigid bodies and lattice top-layer cells.

Force law (Eqs. 13–15, free-molecular flat plate):

    F = −½ C_d ρ |V| V A_proj,   A_proj = A |n̂·V̂| (two-sided) or A max(n̂·V̂, 0) (one-sided),

:func:`magsail_mj.environment.surfaces.drag_forces`. ρ = ``state.env.density_kg_m3`` at the
reference point (uniform over the structure: the density changes by ~0.1 % over 75 m of
altitude), V = ``state.env.v_rel_eci`` (reference-point velocity relative to the co-rotating
atmosphere) plus the body's own world velocity ``state.vel`` (metres per second against
~7.5 km/s; the ω⊕ × x term of x ~ metres is neglected). World = ECI axes.

:func:`plate_drag_forces` is the law of many flat plates with their own flow velocities, on (3, k)
component-major arrays: the lattice cells' law, shared with the structure concept's panels
(:mod:`magsail_mj.concepts.structure.loads`).
"""

from __future__ import annotations

import numpy as np

from magsail_mj.environment.surfaces import CellGeometry, FacetSet, drag_forces

from magsail_mj.loads.base import StepState
from magsail_mj.loads.facets import RigidFacetLoad

__all__ = ["RigidDragLoad", "LatticeDragLoad", "plate_drag_forces"]


def plate_drag_forces(
    area_m2: np.ndarray,
    normal: np.ndarray,
    V: np.ndarray,
    density_kg_m3: float,
    cd: float | np.ndarray,
    *,
    two_sided: bool = True,
) -> np.ndarray:
    """Drag force (3, k) [N] on k flat plates,

        F = −½ C_d ρ A |n̂·V| V   (two-sided; max(n̂·V, 0) one-sided),

    the module's law with ``|V| A_proj = A |n̂·V|``.

    Args:
      area_m2: (k,) plate areas [m²]; normal: (3, k) unit front normals; V: (3, k) each plate's
        velocity relative to the atmosphere [m/s]; density_kg_m3: ρ; cd: C_d, one for all plates or
        (k,) per plate; two_sided: both faces take the flow (a membrane).
    """
    proj = normal[0] * V[0] + normal[1] * V[1] + normal[2] * V[2]
    proj = np.abs(proj) if two_sided else np.maximum(proj, 0.0)
    return ((-0.5 * cd * density_kg_m3) * area_m2 * proj) * V


class RigidDragLoad(RigidFacetLoad):
    """Drag on the facets of one rigid body.

    Args:
      body_id: MuJoCo body index; facets: the body's :class:`FacetSet` (centres relative to the
      centre of mass, body axes); drag_coefficient: C_d; apply_force: also add the net force
      (``False`` for attitude runs).
    """

    name = "drag"

    def __init__(
        self, body_id: int, facets: FacetSet, *, drag_coefficient: float = 2.2, apply_force: bool = True
    ) -> None:
        if not drag_coefficient > 0:
            raise ValueError(f"drag_coefficient: must be > 0, got {drag_coefficient!r}")
        super().__init__(body_id, facets, apply_force=apply_force)
        self.cd = float(drag_coefficient)

    def _scale(self, env) -> float:
        return env.density_kg_m3

    def _facet_forces(self, state: StepState, normals: np.ndarray, rho: float) -> np.ndarray:
        f = self.facets
        V = state.env.v_rel_eci + state.vel[self.body_id]
        return drag_forces(normals, f.area, V, rho, self.cd, f.two_sided)


class LatticeDragLoad:
    """Drag on lattice cells with the current geometry and each cell's own velocity (mean of its
    four corner velocities); each cell's force is shared equally among its corners.

    Args:
      cells: (ncell, 4) corner node indices (counter-clockwise about the front normal);
      drag_coefficient: C_d; two_sided: membrane (default); body_offset: body index of node 0.

    Per cell: F = −½ C_d ρ A |n̂·V| V (two-sided; max(n̂·V, 0) one-sided), which is the module's
    law with |V| A_proj = A |n̂·V|.
    """

    name = "drag_lattice"

    def __init__(self, cells, *, drag_coefficient: float = 2.2, two_sided: bool = True, body_offset: int = 1) -> None:
        cells = np.asarray(cells, dtype=np.int64)
        if cells.ndim != 2 or cells.shape[1] != 4:
            raise ValueError(f"cells: must have shape (ncell, 4), got {cells.shape}")
        if not drag_coefficient > 0:
            raise ValueError(f"drag_coefficient: must be > 0, got {drag_coefficient!r}")
        self.cells = cells
        self.geometry = CellGeometry(cells + int(body_offset))
        self.cd = float(drag_coefficient)
        self.two_sided = bool(two_sided)

    def cell_forces(self, state: StepState) -> np.ndarray:
        """Force on each cell (3, ncell) [N] in world axes (:func:`plate_drag_forces`)."""
        env = state.env
        area, n = self.geometry.area_normal(state.pos)
        V = self.geometry.mean_velocity(state.vel)
        V += env.v_rel_eci[:, None]
        return plate_drag_forces(area, n, V, env.density_kg_m3, self.cd, two_sided=self.two_sided)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        if state.env.density_kg_m3 == 0.0:
            return
        self.geometry.scatter(self.cell_forces(state), xfrc)
