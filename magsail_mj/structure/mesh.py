"""gmsh meshes (and any format meshio reads) as a :class:`~magsail_mj.structure.model.Structure`.

:func:`read_mesh` reads the file with meshio and maps its elements:

``line`` (2-node) elements
    members; their kind and properties (:class:`MemberProperties`) come from the gmsh physical
    group they belong to (``groups={"booms": MemberProperties(...)}``) or from ``members=``;
``triangle`` and ``quad`` elements
    panels (corners in the file's order, which gmsh keeps counter-clockwise about the surface's
    normal); properties (:class:`PanelProperties`) from their physical group or ``panels=``;
``vertex`` elements
    named node sets, one per point physical group.

Every physical group also names a set: a curve group is a member set and the node set of its
members' nodes, a surface group the node set of its panels' corners. Any other element type
(``line3``, ``tetra``, ``hexa``, …) is a :class:`StructureError` naming the type and the file,
unless ``skip`` lists it. An element that appears more than once (MSH 2 writes an element once per
physical group it belongs to) is kept once, belonging to every group it was written in. Points no
kept element uses are left out. Coincident points are merged only if ``merge_tolerance_m`` is
given. Positions are the file's coordinates times ``length_unit_m`` (1: metres), structure frame.
Masses are the members' linear densities and the panels' areal densities (no point masses).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from pathlib import Path

import meshio
import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from magsail_mj.structure.generators.common import (
    FLAT_PLATE_DRAG_COEFFICIENT,
    check_positive,
    check_reflectivity,
)
from magsail_mj.structure.model import MEMBER_KINDS, Members, Panels, Structure, StructureError

__all__ = ["SUPPORTED_ELEMENTS", "MemberProperties", "PanelProperties", "read_mesh"]

#: meshio element types read, with their dimension (0: node sets, 1: members, 2: panels).
SUPPORTED_ELEMENTS = {"vertex": 0, "line": 1, "triangle": 2, "quad": 2}
_CORNERS = {"vertex": 1, "line": 2, "triangle": 4, "quad": 4}
#: Elements named in an error before the rest are counted.
_LISTED = 5


@dataclass(frozen=True, kw_only=True)
class MemberProperties:
    """Properties of the members made from a group of line elements (columns of
    :class:`~magsail_mj.structure.model.Members`): ``kind`` one of ``MEMBER_KINDS``, axial
    rigidity ``EA_N`` [N], bending rigidities ``EI_Nm2`` [N m²] (one value or section axes 1 and
    2; beams), ``GJ_Nm2`` [N m²] (beams), axial dashpot ``damping_Ns_m`` [N s/m], ``prestrain``
    ``ε0`` (rest length ``l / (1 + ε0)``), ``strain_limit``, ``linear_density_kg_m`` [kg/m] and
    the section-axis-1 ``orientation`` vector (zeros: the builder's choice)."""

    EA_N: float
    kind: str = "strut"
    EI_Nm2: float | tuple[float, float] = 0.0
    GJ_Nm2: float = 0.0
    damping_Ns_m: float = 0.0
    prestrain: float = 0.0
    strain_limit: float = math.inf
    linear_density_kg_m: float = 0.0
    orientation: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if self.kind not in MEMBER_KINDS:
            raise ValueError(f"kind: must be one of {MEMBER_KINDS}, got {self.kind!r}")
        check_positive("EA_N", self.EA_N)
        pair = np.asarray(self.EI_Nm2, dtype=float)
        if pair.shape not in ((), (2,)) or not np.all(np.isfinite(pair)) or np.any(pair < 0):
            raise ValueError(f"EI_Nm2: must be a number or a pair of numbers >= 0, got {self.EI_Nm2!r}")
        for name in ("GJ_Nm2", "damping_Ns_m", "linear_density_kg_m"):
            check_positive(name, getattr(self, name), allow_zero=True)
        if not (math.isfinite(self.prestrain) and self.prestrain > -1):
            raise ValueError(f"prestrain: must be finite and > -1, got {self.prestrain!r}")
        if not self.strain_limit > 0:
            raise ValueError(f"strain_limit: must be > 0, got {self.strain_limit!r}")
        vector = np.asarray(self.orientation, dtype=float)
        if vector.shape != (3,) or not np.all(np.isfinite(vector)):
            raise ValueError(f"orientation: must be 3 finite numbers, got {self.orientation!r}")

    def row(self) -> dict[str, np.ndarray]:
        """The properties as one member row of :meth:`Members.build`'s columns."""
        return {
            "kind": np.array(MEMBER_KINDS.index(self.kind)),
            "EA_N": np.array(float(self.EA_N)),
            "EI_Nm2": np.broadcast_to(np.asarray(self.EI_Nm2, dtype=float), (2,)),
            "GJ_Nm2": np.array(float(self.GJ_Nm2)),
            "damping_Ns_m": np.array(float(self.damping_Ns_m)),
            "prestrain": np.array(float(self.prestrain)),
            "strain_limit": np.array(float(self.strain_limit)),
            "linear_density_kg_m": np.array(float(self.linear_density_kg_m)),
            "orientation": np.asarray(self.orientation, dtype=float),
        }


@dataclass(frozen=True, kw_only=True)
class PanelProperties:
    """Properties of the panels made from a group of triangle and quad elements: areal density
    ``areal_density_kg_m2`` [kg/m²], ``reflectivity`` (specular, diffuse, absorbed fractions,
    summing to 1) and free-molecular ``drag_coefficient``."""

    areal_density_kg_m2: float
    reflectivity: tuple[float, float, float]
    drag_coefficient: float = FLAT_PLATE_DRAG_COEFFICIENT

    def __post_init__(self) -> None:
        check_positive("areal_density_kg_m2", self.areal_density_kg_m2, allow_zero=True)
        check_reflectivity("reflectivity", self.reflectivity)
        check_positive("drag_coefficient", self.drag_coefficient, allow_zero=True)


@dataclass
class _Elements:
    """Elements of one dimension: (e, corners) node indices (−1 pads a triangle to 4) and their
    (e, g) membership of the ``names`` physical groups."""

    nodes: np.ndarray
    member_of: np.ndarray
    names: list[str]


def _read(path: Path) -> meshio.Mesh:
    """The mesh at ``path``: a ``.msh`` file by meshio's gmsh reader, anything else by
    ``meshio.read`` (which ends the process with ``SystemExit`` on a file it cannot read)."""
    if not path.is_file():
        raise StructureError(f"path: {str(path)!r} is not a file")
    try:
        if path.suffix.lower() == ".msh":
            return meshio.gmsh.read(str(path))
        return meshio.read(path)
    except (Exception, SystemExit) as error:  # ReadError, KeyError, ValueError… on a bad file
        detail = f": {type(error).__name__}: {error}" if str(error) else f" ({type(error).__name__})"
        raise StructureError(f"path: {str(path)!r} is not a mesh meshio can read{detail}") from None


def _check_types(mesh: meshio.Mesh, path: Path, skip: Collection[str]) -> None:
    if isinstance(skip, str) or not all(isinstance(kind, str) for kind in skip):
        raise ValueError(f"skip: must be a collection of element type names such as ('tetra',), got {skip!r}")
    counts: dict[str, int] = {}
    for block in mesh.cells:
        if block.type not in SUPPORTED_ELEMENTS and block.type not in skip:
            counts[block.type] = counts.get(block.type, 0) + len(block.data)
    if counts:
        found = ", ".join(f"{count} {kind!r}" for kind, count in counts.items())
        raise StructureError(
            f"{str(path)!r}: element type {', '.join(map(repr, counts))} is not supported ({found} elements; "
            f"supported: {', '.join(SUPPORTED_ELEMENTS)}); pass skip=({next(iter(counts))!r},) to leave them out"
        )


def _group_names(mesh: meshio.Mesh, dim: int) -> list[str]:
    return [name for name, (_, d) in mesh.field_data.items() if int(d) == dim]


def _membership(mesh: meshio.Mesh, b: int, names: list[str]) -> np.ndarray:
    """(e, g) physical-group membership of block ``b``: from meshio's named cell sets (MSH 4,
    every group of an element) or else the ``gmsh:physical`` tags (MSH 2, one per element row)."""
    size = len(mesh.cells[b].data)
    member_of = np.zeros((size, len(names)), dtype=bool)
    cell_sets = mesh.cell_sets or {}
    tags = mesh.cell_data.get("gmsh:physical")
    for g, name in enumerate(names):
        if name in cell_sets:
            rows = cell_sets[name][b]
            member_of[np.asarray([] if rows is None else rows, dtype=np.int64), g] = True
        elif tags is not None:
            member_of[:, g] = np.asarray(tags[b]) == int(mesh.field_data[name][0])
    return member_of


def _elements(mesh: meshio.Mesh, dim: int, remap: np.ndarray) -> _Elements:
    """All elements of dimension ``dim`` (nodes through ``remap``), duplicates kept once with the
    union of their groups."""
    names = _group_names(mesh, dim)
    width = max(c for kind, c in _CORNERS.items() if SUPPORTED_ELEMENTS[kind] == dim)
    nodes, member_of = [np.zeros((0, width), dtype=np.int64)], [np.zeros((0, len(names)), dtype=bool)]
    for b, block in enumerate(mesh.cells):
        if SUPPORTED_ELEMENTS.get(block.type) != dim:
            continue
        data = remap[np.asarray(block.data, dtype=np.int64)]
        nodes.append(np.pad(data, ((0, 0), (0, width - data.shape[1])), constant_values=-1))
        member_of.append(_membership(mesh, b, names))
    nodes_all, member_all = np.concatenate(nodes), np.concatenate(member_of)
    _, first, inverse = np.unique(np.sort(nodes_all, axis=1), axis=0, return_index=True, return_inverse=True)
    merged = np.zeros((first.size, len(names)), dtype=bool)
    np.logical_or.at(merged, inverse.ravel(), member_all)
    order = np.argsort(first)
    return _Elements(nodes=nodes_all[first[order]], member_of=merged[order], names=names)


def _merge_map(points: np.ndarray, tolerance_m: float | None) -> np.ndarray:
    """Index of each point's representative: the first of the points within ``tolerance_m`` of it
    (transitively), or itself when no tolerance is given."""
    n = len(points)
    if tolerance_m is None:
        return np.arange(n)
    pairs = cKDTree(points).query_pairs(check_positive("merge_tolerance_m", tolerance_m), output_type="ndarray")
    graph = sparse.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    first = np.full(label.max() + 1, n)
    np.minimum.at(first, label, np.arange(n))
    return first[label]


def _assign(
    elements: _Elements, groups: Mapping[str, object], default: object, kind: type, what: str, path: Path
) -> tuple[np.ndarray, list]:
    """Each element's properties, as (e,) indices into the returned list ``[default] + mapped``:
    those of the first mapped group it is in, or ``default``. An element in two groups mapped to
    different properties, or in none and without a default, is an error."""
    mapped = [g for g, name in enumerate(elements.names) if name in groups]
    choices = [default] + [groups[elements.names[g]] for g in mapped]
    same = np.array([[x == y for y in choices] for x in choices])
    hits = elements.member_of[:, mapped]
    pick = np.where(hits.any(axis=1), 1 + np.argmax(hits, axis=1), 0) if mapped else np.zeros(len(hits), dtype=np.int64)
    for column, g in enumerate(mapped):
        clash = np.flatnonzero(hits[:, column] & ~same[pick, column + 1])
        if clash.size:
            first = elements.names[mapped[pick[clash[0]] - 1]]
            raise StructureError(
                f"groups: {clash.size} {what} of {str(path)!r} are in physical groups {first!r} and "
                f"{elements.names[g]!r}, which map to different {kind.__name__}"
            )
    missing = np.flatnonzero(pick == 0) if default is None else np.zeros(0, dtype=np.int64)
    if missing.size:
        belong = sorted({elements.names[g] for g in np.flatnonzero(elements.member_of[missing].any(axis=0))})
        raise StructureError(
            f"{str(path)!r}: {missing.size} {what} (e.g. {what}[{int(missing[0])}], physical groups "
            f"{belong or 'none'}) have no {kind.__name__}: map one of their groups in groups= or give "
            f"{'members' if kind is MemberProperties else 'panels'}="
        )
    return pick, choices


def _check_groups(mesh: meshio.Mesh, groups: Mapping[str, object], path: Path) -> None:
    expected = {1: MemberProperties, 2: PanelProperties}
    for name, value in groups.items():
        if name not in mesh.field_data:
            raise StructureError(
                f"groups[{name!r}]: {str(path)!r} has no physical group {name!r} (has {sorted(mesh.field_data)})"
            )
        dim = int(mesh.field_data[name][1])
        want = expected.get(dim)
        if want is None or not isinstance(value, want):
            need = want.__name__ if want else "nothing (a point group is a node set)"
            raise StructureError(
                f"groups[{name!r}]: physical group {name!r} has dimension {dim}: it takes {need}, "
                f"got {type(value).__name__}"
            )


def _members(lines: _Elements, pick: np.ndarray, choices: list, positions_m: np.ndarray, path: Path) -> Members:
    """The member table of the line elements, properties ``choices[pick]``."""
    if not len(pick):
        return Members.build(np.zeros((0, 2), dtype=np.int64), positions_m=positions_m, EA_N=1.0)
    used, local = np.unique(pick, return_inverse=True)
    rows = [choices[u].row() for u in used]
    columns = {key: np.stack([row[key] for row in rows])[local.ravel()] for key in rows[0]}
    members = Members.build(lines.nodes, positions_m=positions_m, **columns)
    short = np.flatnonzero(~(members.rest_length_m > 0))
    if short.size:
        raise StructureError(
            f"{str(path)!r}: {short.size} line elements join coincident points (members "
            f"{short[:_LISTED].tolist()}); merge the points with merge_tolerance_m="
        )
    return members


def _panels(surfaces: _Elements, pick: np.ndarray, choices: list) -> Panels:
    """The panel table of the surface elements, properties ``choices[pick]``."""
    if not len(pick):
        return Panels.empty()
    used, local = np.unique(pick, return_inverse=True)
    local = local.ravel()
    props = [choices[u] for u in used]
    return Panels(
        nodes=surfaces.nodes,
        areal_density_kg_m2=np.array([p.areal_density_kg_m2 for p in props], dtype=float)[local],
        reflectivity=np.array([p.reflectivity for p in props], dtype=float)[local],
        drag_coefficient=np.array([p.drag_coefficient for p in props], dtype=float)[local],
    )


def _sets(elements: _Elements) -> dict[str, np.ndarray]:
    """Element index set of each physical group."""
    return {name: np.flatnonzero(elements.member_of[:, g]) for g, name in enumerate(elements.names)}


def _element_nodes(nodes: np.ndarray) -> np.ndarray:
    return np.unique(nodes[nodes >= 0])


def _check_degenerate(lines: _Elements, surfaces: _Elements, path: Path) -> None:
    """Elements with a repeated node (points merged into one) are an error."""
    corners = np.sort(surfaces.nodes, axis=1)
    for what, bad in (
        ("line", np.flatnonzero(lines.nodes[:, 0] == lines.nodes[:, 1])),
        ("surface", np.flatnonzero(np.any((corners[:, 1:] == corners[:, :-1]) & (corners[:, 1:] >= 0), axis=1))),
    ):
        if bad.size:
            raise StructureError(
                f"merge_tolerance_m: {bad.size} {what} elements of {str(path)!r} have two nodes merged into one "
                f"({what} elements {bad[:_LISTED].tolist()}, read order); use a smaller tolerance"
            )


def read_mesh(
    path: str | Path,
    *,
    groups: Mapping[str, MemberProperties | PanelProperties] | None = None,
    members: MemberProperties | None = None,
    panels: PanelProperties | None = None,
    skip: Collection[str] = (),
    merge_tolerance_m: float | None = None,
    length_unit_m: float = 1.0,
    name: str | None = None,
) -> Structure:
    """The structure of the mesh file ``path`` (see the module docstring for the mapping).

    Args:
      groups: physical group name → :class:`MemberProperties` (a curve group) or
        :class:`PanelProperties` (a surface group).
      members: properties of line elements in no mapped group (``None``: such elements are an
        error).
      panels: properties of triangles and quads in no mapped group (``None``: an error).
      skip: element types left out (e.g. ``("tetra",)``); any other unsupported type is an error.
      merge_tolerance_m: merge points closer than this (after scaling) into the first of them;
        ``None`` (default): keep every point.
      length_unit_m: the file's length unit [m] (0.001 for a mesh drawn in millimetres).
      name: the structure's name (default: the file's stem).
    """
    path = Path(path)
    groups = dict(groups or {})
    unit = check_positive("length_unit_m", length_unit_m)
    mesh = _read(path)
    _check_types(mesh, path, skip)
    _check_groups(mesh, groups, path)
    points = np.zeros((len(mesh.points), 3))
    points[:, : mesh.points.shape[1]] = mesh.points[:, :3]
    points *= unit
    remap = _merge_map(points, merge_tolerance_m)
    vertices, lines, surfaces = (_elements(mesh, dim, remap) for dim in (0, 1, 2))
    _check_degenerate(lines, surfaces, path)
    used = np.zeros(len(points), dtype=bool)
    for elements in (vertices, lines, surfaces):
        used[_element_nodes(elements.nodes)] = True
    if not used.any():
        raise StructureError(f"{str(path)!r}: no vertex, line, triangle or quad elements to make a structure of")
    renumber = np.where(used, np.cumsum(used) - 1, -1)
    for elements in (vertices, lines, surfaces):
        elements.nodes = np.where(elements.nodes >= 0, renumber[np.maximum(elements.nodes, 0)], -1)
    positions = points[used]
    line_pick, line_choices = _assign(lines, groups, members, MemberProperties, "line elements", path)
    surface_pick, surface_choices = _assign(surfaces, groups, panels, PanelProperties, "surface elements", path)
    member_sets = _sets(lines)
    node_sets = {key: _element_nodes(vertices.nodes[index]) for key, index in _sets(vertices).items()}
    node_sets.update({key: _element_nodes(lines.nodes[index]) for key, index in member_sets.items()})
    node_sets.update({key: _element_nodes(surfaces.nodes[index]) for key, index in _sets(surfaces).items()})
    return Structure(
        name=path.stem if name is None else name,
        positions_m=positions,
        node_mass_kg=np.zeros(len(positions)),
        members=_members(lines, line_pick, line_choices, positions, path),
        panels=_panels(surfaces, surface_pick, surface_choices),
        node_sets=node_sets,
        member_sets=member_sets,
    )
