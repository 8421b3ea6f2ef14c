"""Double-layer truss plates: the shipped two-layer cubic lattice, Robb et al. 2022a's
octahedral–tetrahedral (octet) truss and the square-on-square offset grid, and the pieces the
plates share (pure NumPy); the disc and hexagon are in
:mod:`~magsail_mj.structure.generators.clipped`.

Frames and units: structure frame, SI. A plate lies in the x–y plane with its centre on the z
axis; ``top`` is its +z layer. Node sets: ``top``, ``bottom``, ``root`` (the −x edge, both layers:
the clamped edge of the cantilever), ``tip`` (the +x edge), ``rim`` (the plate's perimeter).
Masses: the plate's total mass, or its areal density times its area, spread uniformly over the
nodes (the shipped truss's distributed case). Every member is a strut of the same ``EA``; its
dashpot is ``damping_Ns_m``, or ``c = 2 ζ √(k m_p / 2)`` from ``zeta_strut`` (``k`` of the
shortest strut, :func:`~magsail_mj.structure.generators.common.strut_dashpot_Ns_m`). ``EA_N`` is
either given or calibrated to a plate bending stiffness ``EI_Nm2`` by the cantilever rule of
:mod:`~magsail_mj.structure.generators.calibration`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Literal

import numpy as np

from magsail_mj.lattice.geometry import STRUT_KINDS, Lattice, axial_rigidity_from_EI, make_lattice, node_index
from magsail_mj.lattice.properties import central_cube_nodes, node_masses, strut_stiffness
from magsail_mj.structure.generators.calibration import calibrate_axial_rigidity
from magsail_mj.structure.generators.common import (
    axial_rigidity_argument,
    check_count,
    check_positive,
    plate_mass_kg,
    strut_dashpot_Ns_m,
)
from magsail_mj.structure.model import Members, Structure

__all__ = ["square_plate_lattice", "octet_plate", "offset_grid_plate", "lattice_structure"]

_XY_DIAGONAL = STRUT_KINDS.index("xy_diagonal")


def check_lattice_args(units: int, side_m: float, diagonals: str) -> tuple[int, float]:
    """Checked ``units`` and ``side_m`` of a cubic lattice, and its ``diagonals`` rule."""
    n = check_count("units", units, minimum=1)
    side = check_positive("side_m", side_m)
    if diagonals not in ("parity", "X"):
        raise ValueError(f"diagonals: must be 'parity' or 'X', got {diagonals!r}")
    return n, side


def rim_columns(cells: np.ndarray) -> np.ndarray:
    """(N, N) [j, i] mask of the node columns on the perimeter of the kept cells ``cells`` (n, n)
    [cj, ci]: columns not surrounded by four kept cells."""
    padded = np.pad(cells, 1, constant_values=False)
    inside = padded[:-1, :-1] & padded[:-1, 1:] & padded[1:, :-1] & padded[1:, 1:]
    return ~inside


def lattice_sets(
    ijk: np.ndarray, struts: np.ndarray, kind: np.ndarray, cells: np.ndarray, top_chord_kinds: tuple[str, ...]
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Node and member sets of (a subset of) a two-layer lattice: ``ijk`` (n, 3) integer node
    coordinates, ``struts`` (m, 2) renumbered ends, ``kind`` (m,) STRUT_KINDS codes (−1: a member
    of none), ``cells`` (units, units) [cj, ci] mask of the cubes present."""
    i, j, k = ijk.T
    rim = rim_columns(cells)[j, i]
    node_sets = {
        "top": np.flatnonzero(k == 1),
        "bottom": np.flatnonzero(k == 0),
        "root": np.flatnonzero(i == i.min()),
        "tip": np.flatnonzero(i == i.max()),
        "rim": np.flatnonzero(rim),
    }
    layer_a, layer_b = k[struts[:, 0]], k[struts[:, 1]]
    member_sets = {name: np.flatnonzero(kind == c) for c, name in enumerate(STRUT_KINDS) if np.any(kind == c)}
    member_sets["top_layer"] = np.flatnonzero((layer_a == 1) & (layer_b == 1))
    member_sets["bottom_layer"] = np.flatnonzero((layer_a == 0) & (layer_b == 0))
    member_sets["web"] = np.flatnonzero(layer_a != layer_b)
    chord = np.isin(kind, [STRUT_KINDS.index(name) for name in top_chord_kinds])
    member_sets["top_chords"] = np.flatnonzero(chord & (layer_a == 1) & (layer_b == 1))
    return node_sets, member_sets


def lattice_subset(lat: Lattice, node_keep: np.ndarray, strut_keep: np.ndarray) -> tuple[np.ndarray, ...]:
    """Positions, ijk, renumbered struts, kinds and rest lengths of the kept nodes and struts
    (lattice order kept)."""
    renumber = np.cumsum(node_keep) - 1
    struts = renumber[lat.struts[strut_keep]]
    return lat.nodes[node_keep], lat.ijk[node_keep], struts, lat.kind[strut_keep], lat.rest_length[strut_keep]


def uniform_strut_plate(
    *,
    name: str,
    positions_m: np.ndarray,
    struts: np.ndarray,
    rest_length_m: np.ndarray,
    EA_N: float,
    total_kg: float,
    damping_Ns_m: float | None,
    zeta_strut: float | None,
    node_sets: dict[str, np.ndarray],
    member_sets: dict[str, np.ndarray],
) -> Structure:
    """A strut plate of uniform node masses ``total_kg / n`` and one ``EA`` and dashpot."""
    n = positions_m.shape[0]
    damping = strut_dashpot_Ns_m(
        damping_Ns_m=damping_Ns_m,
        zeta_strut=zeta_strut,
        EA_N=EA_N,
        shortest_m=float(rest_length_m.min()),
        particle_mass_kg=total_kg / n,
    )
    members = Members.build(
        struts, positions_m=positions_m, EA_N=EA_N, damping_Ns_m=damping, rest_length_m=rest_length_m
    )
    return Structure(
        name=name,
        positions_m=positions_m,
        node_mass_kg=np.full(n, total_kg / n),
        members=members,
        node_sets=node_sets,
        member_sets=member_sets,
    )


def lattice_structure(
    lat: Lattice,
    *,
    masses_kg: np.ndarray,
    EA_N: float | np.ndarray,
    damping_Ns_m: float | np.ndarray,
    fixed_nodes: np.ndarray | tuple[int, ...] = (),
    name: str = "square_plate_lattice",
) -> Structure:
    """The shipped lattice with given particle masses, strut axial rigidities (one or per strut:
    spring constants ``EA / l0``) and dashpots as a :class:`Structure` (the sets of
    :func:`square_plate_lattice`; ``fixed_nodes`` held in all three translations): what the
    truss concept builds its model from."""
    members = Members.build(
        lat.struts,
        positions_m=lat.nodes,
        EA_N=EA_N,
        damping_Ns_m=damping_Ns_m,
        rest_length_m=lat.rest_length,
    )
    node_sets, member_sets = lattice_sets(
        lat.ijk, lat.struts, lat.kind, np.ones((lat.units, lat.units), bool), ("x_edge", "y_edge")
    )
    node_sets["central_cube"] = central_cube_nodes(lat)
    fixed = np.zeros((lat.n_nodes, 6), dtype=bool)
    fixed[np.asarray(fixed_nodes, dtype=np.int64), :3] = True
    return Structure(
        name=name,
        positions_m=np.array(lat.nodes),
        node_mass_kg=np.asarray(masses_kg, dtype=float),
        members=members,
        node_sets=node_sets,
        member_sets=member_sets,
        fixed_dofs=fixed,
    )


def _with_axial_rigidity(build: Callable[[float], Structure], EA_N: float | None, EI_Nm2: float | None) -> Structure:
    """``build(EA)`` at ``EA_N``, or at the EA whose cantilever bending stiffness is ``EI_Nm2``."""
    axial_rigidity_argument(EA_N, EI_Nm2)
    if EI_Nm2 is not None:
        EA_N = calibrate_axial_rigidity(lambda *, EA_N: build(EA_N), EI_Nm2)
    return build(float(EA_N))


def square_plate_lattice(
    *,
    units: int,
    side_m: float,
    diagonals: Literal["parity", "X"] = "parity",
    EA_N: float | None = None,
    EI_Nm2: float | None = None,
    calibration: Literal["cantilever", "formula"] = "cantilever",
    total_mass_kg: float | None = None,
    areal_density_kg_m2: float | None = None,
    central_fraction: float = 0.0,
    damping_Ns_m: float | None = None,
    zeta_strut: float | None = None,
    name: str = "square_plate_lattice",
) -> Structure:
    """The shipped two-layer cubic lattice (:func:`magsail_mj.lattice.geometry.make_lattice`,
    Robb et al. 2022a) as a :class:`Structure`: the same nodes, struts (order and end order) and
    rest lengths; ``units`` cubes of edge ``a = side_m / units`` per side.

    Stiffness as the shipped truss: ``EA_N``, or from ``EI_Nm2`` ``EA = c · 2 EI / (N a²)``
    (Eq. 8, ``N = units + 1``) with ``c`` the cantilever calibration factor (``calibration =
    "cantilever"``) or 1 (``"formula"``). Masses as the shipped truss: ``(1 − central_fraction)``
    of the total uniformly over the nodes, the rest over the 8 nodes of the central cube. Damping:
    ``damping_Ns_m``, or the shipped ``γ = 2 ζ √(k_edge m_p / 2)`` with ``m_p = M / n``.

    Member sets: the strut kinds of :data:`~magsail_mj.lattice.geometry.STRUT_KINDS`,
    ``top_layer``, ``bottom_layer``, ``web`` (between the layers) and ``top_chords`` (the top
    layer's cube edges); node sets as the module docstring, plus ``central_cube``.
    """
    n, side = check_lattice_args(units, side_m, diagonals)
    axial_rigidity_argument(EA_N, EI_Nm2)
    lat = make_lattice(units=n, side_m=side, diagonals=diagonals)
    total = plate_mass_kg(total_mass_kg=total_mass_kg, areal_density_kg_m2=areal_density_kg_m2, area_m2=side**2)
    masses = node_masses(lat, total_kg=total, central_fraction=central_fraction)
    if EI_Nm2 is not None:
        _, factor = strut_stiffness(lat, EI_Nm2=EI_Nm2, calibration=calibration)
        EA_N = factor * axial_rigidity_from_EI(EI_Nm2, nodes_per_side=lat.nodes_per_side, cube_edge_m=lat.cube_edge_m)
    damping = strut_dashpot_Ns_m(
        damping_Ns_m=damping_Ns_m,
        zeta_strut=zeta_strut,
        EA_N=EA_N,
        shortest_m=float(lat.rest_length.min()),
        particle_mass_kg=total / lat.n_nodes,
    )
    node_sets, member_sets = lattice_sets(lat.ijk, lat.struts, lat.kind, np.ones((n, n), bool), ("x_edge", "y_edge"))
    node_sets["central_cube"] = central_cube_nodes(lat)
    members = Members.build(
        lat.struts, positions_m=lat.nodes, EA_N=EA_N, damping_Ns_m=damping, rest_length_m=lat.rest_length
    )
    return Structure(
        name=name,
        positions_m=np.array(lat.nodes),
        node_mass_kg=masses,
        members=members,
        node_sets=node_sets,
        member_sets=member_sets,
    )


def _rim_chords(n: int) -> np.ndarray:
    """(r, 2) lattice node pairs: consecutive even-parity nodes (``i + j + k`` even) along each of
    the plate's four edges, in both layers (``2a`` long, across the dropped odd node)."""
    N = n + 1
    pairs = []
    for along_i in (True, False):
        for fixed in (0, N - 1):
            for layer in (0, 1):
                start = np.arange((fixed + layer) % 2, N - 2, 2)
                ends = np.stack([start, start + 2], axis=1)
                i, j = (ends, np.full_like(ends, fixed)) if along_i else (np.full_like(ends, fixed), ends)
                pairs.append(node_index(i, j, layer, N))
    return np.concatenate(pairs).reshape(-1, 2)


def octet_plate(
    *,
    units: int,
    side_m: float,
    bracing: Literal["rim", "none"] = "rim",
    EA_N: float | None = None,
    EI_Nm2: float | None = None,
    total_mass_kg: float | None = None,
    areal_density_kg_m2: float | None = None,
    damping_Ns_m: float | None = None,
    zeta_strut: float | None = None,
    name: str = "octet_plate",
) -> Structure:
    """Robb et al. 2022a's octahedral–tetrahedral truss alone: of the two-layer cubic lattice
    of ``units`` cubes of edge ``a = side_m / units`` per side, only the even-parity nodes
    (``i + j + k`` even, one node per lattice column) and the parity rule's face diagonals, all of
    which join even nodes (``a √2`` long): every cube holds a regular tetrahedron, and between
    them lie half octahedra. The odd nodes are dropped: held only by cube edges, which this truss
    does not have, they would be free.

    The top layer's face diagonals are its chords (member set ``top_chords``, the rods' places: a
    square grid turned 45°). A free octet plate has one mechanism besides the rigid motions —
    twist, the top and bottom chord grids shearing in plane in opposite senses (the chord grids
    are squares without in-plane diagonals); ``bracing="rim"`` removes it with rim chords
    (member set ``rim_chords``, ``4 (N − 2)`` struts ``2a`` long joining consecutive even nodes
    along each plate edge in both layers); ``"none"`` leaves it.

    Nodes in the lattice's order (:func:`~magsail_mj.lattice.geometry.make_lattice`) with the
    odd ones taken out, members the lattice's face diagonals in its order then the rim chords;
    member count ``2 n² + 2 n N`` (+ ``4 (N − 2)``), ``N = n + 1``. Mass: uniform over the ``N²``
    nodes; ``areal_density_kg_m2`` is per ``side_m²``.
    """
    n, side = check_lattice_args(units, side_m, "parity")
    if bracing not in ("rim", "none"):
        raise ValueError(f"bracing: must be 'rim' or 'none', got {bracing!r}")
    total = plate_mass_kg(total_mass_kg=total_mass_kg, areal_density_kg_m2=areal_density_kg_m2, area_m2=side**2)
    lat = make_lattice(units=n, side_m=side, diagonals="parity")
    even = lat.ijk.sum(axis=1) % 2 == 0
    positions, ijk, struts, kind, rest = lattice_subset(lat, even, lat.kind >= _XY_DIAGONAL)
    if bracing == "rim":
        chords = _rim_chords(n)
        struts = np.concatenate([struts, (np.cumsum(even) - 1)[chords]])
        kind = np.concatenate([kind, np.full(len(chords), -1, dtype=kind.dtype)])
        rest = np.concatenate([rest, np.full(len(chords), 2.0 * lat.cube_edge_m)])
    node_sets, member_sets = lattice_sets(ijk, struts, kind, np.ones((n, n), bool), ("xy_diagonal",))
    member_sets["rim_chords"] = np.flatnonzero(kind == -1)

    plate = {"name": name, "positions_m": positions, "struts": struts, "rest_length_m": rest, "total_kg": total}
    dashpots = {"damping_Ns_m": damping_Ns_m, "zeta_strut": zeta_strut}
    sets = {"node_sets": node_sets, "member_sets": member_sets}
    return _with_axial_rigidity(lambda EA: uniform_strut_plate(EA_N=EA, **plate, **dashpots, **sets), EA_N, EI_Nm2)


def _grid(count: int, pitch_m: float, offset_m: float, z_m: float) -> np.ndarray:
    """(count², 3) positions of a square grid, j-major (index ``j · count + i``)."""
    j, i = np.meshgrid(np.arange(count), np.arange(count), indexing="ij")
    return np.column_stack([i.ravel() * pitch_m + offset_m, j.ravel() * pitch_m + offset_m, np.full(count**2, z_m)])


def _grid_chords(count: int, first: int) -> np.ndarray:
    """(2 count (count − 1), 2) chords of a j-major square grid of ``count²`` nodes numbered from
    ``first``: the x chords, then the y chords."""
    j, i = np.meshgrid(np.arange(count), np.arange(count - 1), indexing="ij")
    along_x = np.stack([j * count + i, j * count + i + 1], axis=-1).reshape(-1, 2)
    j, i = np.meshgrid(np.arange(count - 1), np.arange(count), indexing="ij")
    along_y = np.stack([j * count + i, (j + 1) * count + i], axis=-1).reshape(-1, 2)
    return np.concatenate([along_x, along_y]) + first


def offset_grid_plate(
    *,
    cells: int,
    side_m: float,
    depth_m: float | None = None,
    bracing: Literal["corners", "none"] = "corners",
    EA_N: float | None = None,
    EI_Nm2: float | None = None,
    total_mass_kg: float | None = None,
    areal_density_kg_m2: float | None = None,
    damping_Ns_m: float | None = None,
    zeta_strut: float | None = None,
    name: str = "offset_grid_plate",
) -> Structure:
    """The square-on-square offset double-layer grid: a top square chord grid of ``cells`` ×
    ``cells`` cells of pitch ``a = side_m / cells`` at ``z = +depth_m / 2``, a bottom chord grid
    offset by ``a / 2`` in x and y at ``z = −depth_m / 2`` (one node under the centre of each top
    cell), and four web struts from each bottom node to the corners of its top cell. The default
    ``depth_m = a / √2`` makes webs as long as chords (regular half octahedra and tetrahedra: the
    octet truss turned 45°).

    Nodes: the ``(cells + 1)²`` top ones (j-major), then the ``cells²`` bottom ones. Members: top
    chords (x then y), bottom chords, webs (per bottom node, to its top cell's corners
    ``(i, j), (i+1, j), (i, j+1), (i+1, j+1)``), bracing; ``8 cells²`` before bracing. Member
    sets ``top_chords``, ``bottom_chords``, ``webs``, ``bracing``.

    A free offset grid has one mechanism besides the rigid motions, twist (the two square chord
    grids shear in plane in opposite senses); ``bracing="corners"`` removes it with one top-layer
    diagonal across each corner cell, from the plate corner inwards (2 for one cell); ``"none"``
    leaves it. ``root``/``tip`` are both layers' −x/+x edges (distinct for ``cells >= 2``).
    Mass: uniform over the nodes; ``areal_density_kg_m2`` is per ``side_m²``.
    """
    c = check_count("cells", cells, minimum=1)
    side = check_positive("side_m", side_m)
    a = side / c
    depth = a / math.sqrt(2.0) if depth_m is None else check_positive("depth_m", depth_m)
    if bracing not in ("corners", "none"):
        raise ValueError(f"bracing: must be 'corners' or 'none', got {bracing!r}")
    total = plate_mass_kg(total_mass_kg=total_mass_kg, areal_density_kg_m2=areal_density_kg_m2, area_m2=side**2)
    p, n_top = c + 1, (c + 1) ** 2
    positions = np.concatenate([_grid(p, a, -side / 2, depth / 2), _grid(c, a, a / 2 - side / 2, -depth / 2)])
    top_chords, bottom_chords = _grid_chords(p, 0), _grid_chords(c, n_top)
    j, i = (g.ravel() for g in np.meshgrid(np.arange(c), np.arange(c), indexing="ij"))
    corners = np.stack([j * p + i, j * p + i + 1, (j + 1) * p + i, (j + 1) * p + i + 1], axis=1)
    webs = np.stack([np.repeat(n_top + j * c + i, 4), corners.ravel()], axis=1)
    braces = np.array([[0, p + 1], [c, p + c - 1], [c * p, (c - 1) * p + 1], [c * p + c, (c - 1) * p + c - 1]])
    braces = braces[np.sort(np.unique(np.sort(braces, axis=1), axis=0, return_index=True)[1])]
    groups = {"top_chords": top_chords, "bottom_chords": bottom_chords, "webs": webs}
    if bracing == "corners":
        groups["bracing"] = braces
    struts = np.concatenate(list(groups.values()))
    bounds = np.cumsum([0] + [len(g) for g in groups.values()])
    member_sets = {key: np.arange(bounds[g], bounds[g + 1]) for g, key in enumerate(groups)}
    member_sets.setdefault("bracing", np.zeros(0, dtype=np.int64))
    top_i = np.tile(np.arange(p), p)
    bottom_i, bottom_j = np.tile(np.arange(c), c), np.repeat(np.arange(c), c)
    top_j = np.repeat(np.arange(p), p)
    on_top_rim = (top_i == 0) | (top_i == c) | (top_j == 0) | (top_j == c)
    on_bottom_rim = (bottom_i == 0) | (bottom_i == c - 1) | (bottom_j == 0) | (bottom_j == c - 1)
    node_sets = {
        "top": np.arange(n_top),
        "bottom": np.arange(n_top, n_top + c * c),
        "root": np.concatenate([np.flatnonzero(top_i == 0), n_top + np.flatnonzero(bottom_i == 0)]),
        "tip": np.concatenate([np.flatnonzero(top_i == c), n_top + np.flatnonzero(bottom_i == c - 1)]),
        "rim": np.concatenate([np.flatnonzero(on_top_rim), n_top + np.flatnonzero(on_bottom_rim)]),
    }
    rest = np.linalg.norm(positions[struts[:, 1]] - positions[struts[:, 0]], axis=1)

    plate = {"name": name, "positions_m": positions, "struts": struts, "rest_length_m": rest, "total_kg": total}
    dashpots = {"damping_Ns_m": damping_Ns_m, "zeta_strut": zeta_strut}
    sets = {"node_sets": node_sets, "member_sets": member_sets}
    return _with_axial_rigidity(lambda EA: uniform_strut_plate(EA_N=EA, **plate, **dashpots, **sets), EA_N, EI_Nm2)
