"""Disc and hexagon plates: the two-layer cubic lattice clipped to the shape by whole cubes
(pure NumPy). Frames, units, sets, masses and damping as
:mod:`~magsail_mj.structure.generators.plates`, and two member sets more, ``rim_top`` and
``rim_bottom`` (:func:`rim_loops`): the chords along the staircase perimeter of each layer, in
order round it, each a closed loop (for current loops along the rim)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Literal

import numpy as np

from magsail_mj.lattice.geometry import make_lattice
from magsail_mj.structure.generators.common import check_count, check_positive, plate_mass_kg
from magsail_mj.structure.generators.plates import (
    check_lattice_args,
    lattice_sets,
    lattice_subset,
    uniform_strut_plate,
)
from magsail_mj.structure.model import Structure, StructureError

__all__ = ["circular_plate", "hexagonal_plate", "rim_loops"]


def rim_loops(ijk: np.ndarray, struts: np.ndarray, cells: np.ndarray) -> dict[str, np.ndarray]:
    """``{"rim_top": …, "rim_bottom": …}``: in each layer (``k = 1``, ``k = 0``) the chords along
    the perimeter of the kept cubes (an edge along x or y with a kept cube on one side only), listed
    in order counter-clockwise about +z, starting at the lowest row's first chord, whose stored
    node order runs +x (so a loop taking its sense from its first member's node order runs
    counter-clockwise: a positive current makes a dipole along +z).

    Args:
      ijk: (n, 3) integer node coordinates; struts: (m, 2) end nodes; cells: (units, units)
        [cj, ci] mask of the kept cubes.

    Raises:
      StructureError: the perimeter of a layer is not one simple loop (kept cubes touching at a
        corner only, or several pieces).
    """
    units = cells.shape[0]
    i, j, k = (np.asarray(c, dtype=np.int64) for c in ijk.T)
    a, b = np.asarray(struts, dtype=np.int64).T
    di, dj = i[b] - i[a], j[b] - j[a]
    flat = k[a] == k[b]
    along_x = flat & (dj == 0) & (np.abs(di) == 1)
    along_y = flat & (di == 0) & (np.abs(dj) == 1)

    def kept(ci: np.ndarray, cj: np.ndarray) -> np.ndarray:
        valid = (ci >= 0) & (ci < units) & (cj >= 0) & (cj < units)
        return valid & cells[np.clip(cj, 0, units - 1), np.clip(ci, 0, units - 1)]

    i0, j0 = np.minimum(i[a], i[b]), np.minimum(j[a], j[b])
    above, below = kept(i0, j[a]), kept(i0, j[a] - 1)  # an x chord's cubes
    right, left = kept(i[a], j0), kept(i[a] - 1, j0)  # a y chord's cubes
    rim = (along_x & (above != below)) | (along_y & (left != right))
    # counter-clockwise about +z: +x below the cubes, −x above them, +y right of them, −y left
    forward = np.where(along_x, np.where(above, 1, -1) == di, np.where(left, 1, -1) == dj)
    src, dst = np.where(forward, a, b), np.where(forward, b, a)
    out = {}
    for name, layer in (("rim_top", 1), ("rim_bottom", 0)):
        members = np.flatnonzero(rim & (k[a] == layer))
        leaving: dict[int, int] = {}
        for m in members.tolist():
            if leaving.setdefault(int(src[m]), m) != m:
                raise StructureError(f"{name}: the perimeter passes node {int(src[m])} twice (cubes meet at a corner)")
        starts = members[along_x[members] & forward[members]]
        m = int(starts[np.lexsort((i0[starts], j[a][starts]))[0]])
        order = [m]
        while (m := leaving[int(dst[m])]) != order[0]:
            order.append(m)
            if len(order) > members.size:
                raise StructureError(f"{name}: the perimeter does not close")  # pragma: no cover
        if len(order) != members.size:
            raise StructureError(f"{name}: the perimeter is {members.size - len(order) + 1} or more separate loops")
        out[name] = np.array(order, dtype=np.int64)
    return out


def _clipped_plate(
    *,
    units: int,
    width_m: float,
    inside: Callable[[np.ndarray, np.ndarray], np.ndarray],
    diagonals: str,
    EA_N: float,
    total_mass_kg: float | None,
    areal_density_kg_m2: float | None,
    damping_Ns_m: float | None,
    zeta_strut: float | None,
    name: str,
) -> Structure:
    """The cubic lattice of ``units`` cubes across ``width_m`` keeping the whole cubes whose centre
    ``(x, y)`` is ``inside``, their nodes and the struts of their edges and faces."""
    n, width = check_lattice_args(units, width_m, diagonals)
    check_positive("EA_N", EA_N)
    lat = make_lattice(units=n, side_m=width, diagonals=diagonals)
    a = lat.cube_edge_m
    centres = (np.arange(n) + 0.5) * a - width / 2
    cells = inside(centres[None, :], centres[:, None])  # [cj, ci]
    mid = 0.5 * (lat.ijk[lat.struts[:, 0], :2] + lat.ijk[lat.struts[:, 1], :2])
    keep = np.zeros(lat.n_struts, dtype=bool)
    for ci in (np.ceil(mid[:, 0]) - 1, np.floor(mid[:, 0])):
        for cj in (np.ceil(mid[:, 1]) - 1, np.floor(mid[:, 1])):
            valid = (ci >= 0) & (ci < n) & (cj >= 0) & (cj < n)
            keep |= valid & cells[np.clip(cj, 0, n - 1).astype(int), np.clip(ci, 0, n - 1).astype(int)]
    used = np.zeros(lat.n_nodes, dtype=bool)
    used[lat.struts[keep].ravel()] = True
    positions, ijk, struts, kind, rest = lattice_subset(lat, used, keep)
    area = float(cells.sum()) * a**2
    total = plate_mass_kg(total_mass_kg=total_mass_kg, areal_density_kg_m2=areal_density_kg_m2, area_m2=area)
    node_sets, member_sets = lattice_sets(ijk, struts, kind, cells, ("x_edge", "y_edge"))
    member_sets.update(rim_loops(ijk, struts, cells))
    return uniform_strut_plate(
        name=name,
        positions_m=positions,
        struts=struts,
        rest_length_m=rest,
        EA_N=float(EA_N),
        total_kg=total,
        damping_Ns_m=damping_Ns_m,
        zeta_strut=zeta_strut,
        node_sets=node_sets,
        member_sets=member_sets,
    )


def circular_plate(
    *,
    diameter_m: float,
    units_across: int,
    EA_N: float,
    diagonals: Literal["parity", "X"] = "parity",
    total_mass_kg: float | None = None,
    areal_density_kg_m2: float | None = None,
    damping_Ns_m: float | None = None,
    zeta_strut: float | None = None,
    name: str = "circular_plate",
) -> Structure:
    """A disc of diameter ``diameter_m``: the two-layer cubic lattice of ``units_across`` cubes
    of edge ``a = diameter_m / units_across`` across, keeping the whole cubes whose centre lies in
    the disc (``x² + y² ≤ (diameter_m / 2)²``) with their edges and face diagonals. Every cube is
    rigid and the kept cubes join face to face, so the plate has exactly the 6 rigid motions.

    Node and member sets as :func:`~magsail_mj.structure.generators.plates.square_plate_lattice`
    (``rim``: the staircase perimeter of the kept cubes; no ``central_cube``), and ``rim_top``,
    ``rim_bottom``: the perimeter's chords in order round each layer (:func:`rim_loops`).
    ``areal_density_kg_m2`` is per the kept cubes' area ``n_cubes a²``.
    """
    units = check_count("units_across", units_across, minimum=1)
    radius = check_positive("diameter_m", diameter_m) / 2

    def inside(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return x**2 + y**2 <= radius**2 * (1.0 + 1e-12)

    return _clipped_plate(
        units=units,
        width_m=diameter_m,
        inside=inside,
        diagonals=diagonals,
        EA_N=EA_N,
        total_mass_kg=total_mass_kg,
        areal_density_kg_m2=areal_density_kg_m2,
        damping_Ns_m=damping_Ns_m,
        zeta_strut=zeta_strut,
        name=name,
    )


def hexagonal_plate(
    *,
    across_corners_m: float,
    units_across: int,
    EA_N: float,
    diagonals: Literal["parity", "X"] = "parity",
    total_mass_kg: float | None = None,
    areal_density_kg_m2: float | None = None,
    damping_Ns_m: float | None = None,
    zeta_strut: float | None = None,
    name: str = "hexagonal_plate",
) -> Structure:
    """A regular hexagon of corner-to-corner width ``across_corners_m`` (corners on the ±x axis,
    circumradius ``R``): the two-layer cubic lattice of ``units_across`` cubes of edge
    ``a = across_corners_m / units_across`` across, keeping the whole cubes whose centre lies in
    the hexagon (``|y| ≤ √3 R / 2`` and ``√3 |x| + |y| ≤ √3 R``). Rigid as
    :func:`circular_plate`; sets and areal density likewise (its rim loops are refused by
    :func:`rim_loops` where kept cubes meet at a corner only)."""
    units = check_count("units_across", units_across, minimum=1)
    radius = check_positive("across_corners_m", across_corners_m) / 2
    root3 = math.sqrt(3.0)

    def inside(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        slack = 1.0 + 1e-12
        return (np.abs(y) <= root3 * radius / 2 * slack) & (root3 * np.abs(x) + np.abs(y) <= root3 * radius * slack)

    return _clipped_plate(
        units=units,
        width_m=across_corners_m,
        inside=inside,
        diagonals=diagonals,
        EA_N=EA_N,
        total_mass_kg=total_mass_kg,
        areal_density_kg_m2=areal_density_kg_m2,
        damping_Ns_m=damping_Ns_m,
        zeta_strut=zeta_strut,
        name=name,
    )
