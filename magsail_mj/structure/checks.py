"""Validation of a :class:`~magsail_mj.structure.model.Structure`: every problem, each naming the
element, the field and the value.

:func:`check_structure` raises :class:`~magsail_mj.structure.model.StructureError` listing all
findings (at most :data:`MAX_LISTED` elements a rule, then a count of the rest), for example
``members[12].nodes: node 999 does not exist (800 nodes)``. Every rule works on whole columns
(NumPy masks, a k-d tree for coincident nodes, a sparse graph for connectivity).

Lengths are judged relative to the structure's **extent** ``L`` (the diagonal of the bounding box
of its nodes): two nodes closer than ``DUPLICATE_REL · L`` coincide and a member shorter than that
has zero length. A panel has zero area when its area is at most ``DEGENERATE_REL`` times the square
of its longest edge (its corners are collinear) or that edge is itself of zero length. A rigid
part's inertia tensor must be symmetric within ``SYMMETRY_REL`` of its largest entry, positive
definite and its principal moments must obey the triangle inequality ``I₁ ≤ I₂ + I₃`` (within
``SYMMETRY_REL`` of the trace); a massless part (``mass_kg = 0``) may have a zero tensor (a weld).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from magsail_mj.structure.model import MEMBER_KINDS, Structure, StructureError

__all__ = ["DEGENERATE_REL", "DUPLICATE_REL", "MAX_LISTED", "REFLECTIVITY_TOL", "check_structure", "structure_problems"]

#: Relative distance (to the extent) below which nodes coincide and members have zero length.
DUPLICATE_REL = 1e-9
#: Panel area relative to its longest edge squared below which the panel is degenerate.
DEGENERATE_REL = 1e-9
#: Tolerance of a reflectivity row's sum of fractions to 1.
REFLECTIVITY_TOL = 1e-9
#: Relative tolerance of the inertia tensor's symmetry and triangle inequality.
SYMMETRY_REL = 1e-9
#: Elements listed a rule before the rest are counted.
MAX_LISTED = 10


def check_structure(structure: Structure) -> None:
    """Raise :class:`StructureError` listing every problem of ``structure``; return if none."""
    problems = structure_problems(structure)
    if problems:
        raise StructureError(problems)


def structure_problems(structure: Structure) -> list[str]:
    """Every problem of ``structure`` as a line naming element, field and value (empty: valid)."""
    problems = _shape_problems(structure)
    if problems:
        return problems
    extent = _extent_m(structure.positions_m)
    index_problems = (
        _member_index_problems(structure) + _panel_index_problems(structure) + _part_index_problems(structure)
    )
    problems = _node_problems(structure, extent) + index_problems
    problems += _member_problems(structure, extent, indices_ok=not index_problems)
    problems += _panel_problems(structure, indices_ok=not index_problems)
    problems += _rigid_part_problems(structure)
    problems += _set_problems(structure)
    if not index_problems:
        problems += _mass_problems(structure) + _connectivity_problems(structure)
    return problems


def _fmt(value: object) -> str:
    """A value as it is reported: Python's repr of floats, lists of them for arrays."""
    if isinstance(value, np.ndarray):
        return "[" + ", ".join(_fmt(v) for v in value.tolist()) + "]"
    if isinstance(value, list):
        return "[" + ", ".join(_fmt(v) for v in value) + "]"
    if isinstance(value, float | np.floating):
        return repr(float(value))
    return str(value)


def _listed(mask: np.ndarray, describe: Callable[[int], str], what: str) -> list[str]:
    """``describe(i)`` for the first :data:`MAX_LISTED` indices where ``mask`` holds, then a count."""
    indices = np.flatnonzero(mask)
    lines = [describe(int(i)) for i in indices[:MAX_LISTED]]
    if indices.size > MAX_LISTED:
        lines.append(f"{what}: {indices.size - MAX_LISTED} more with the same problem (not listed)")
    return lines


def _extent_m(positions_m: np.ndarray) -> float:
    """Diagonal of the bounding box of the finite node positions [m] (0 for fewer than 2)."""
    finite = positions_m[np.isfinite(positions_m).all(axis=1)]
    if finite.shape[0] < 2:
        return 0.0
    return float(np.linalg.norm(np.ptp(finite, axis=0)))


def _shape_problems(s: Structure) -> list[str]:
    """Array shapes and dtypes the other rules rely on (a structure built in code may differ)."""
    n = s.positions_m.shape[0] if s.positions_m.ndim == 2 else -1
    m, p = len(s.members), len(s.panels)
    expected = {
        "nodes.position_m": (s.positions_m, (n, 3), "f"),
        "nodes.mass_kg": (s.node_mass_kg, (n,), "f"),
        "fixed_dofs": (s.fixed_dofs, (n, 6), "b"),
        "members.nodes": (s.members.nodes, (m, 2), "iu"),
        "members.kind": (s.members.kind, (m,), "iu"),
        "members.EI_Nm2": (s.members.EI_Nm2, (m, 2), "f"),
        "members.orientation": (s.members.orientation, (m, 3), "f"),
        "panels.nodes": (s.panels.nodes, (p, 4), "iu"),
        "panels.reflectivity": (s.panels.reflectivity, (p, 3), "f"),
        "panels.areal_density_kg_m2": (s.panels.areal_density_kg_m2, (p,), "f"),
        "panels.drag_coefficient": (s.panels.drag_coefficient, (p,), "f"),
    }
    for name in ("EA_N", "GJ_Nm2", "damping_Ns_m", "rest_length_m", "strain_limit", "linear_density_kg_m"):
        expected[f"members.{name}"] = (getattr(s.members, name), (m,), "f")
    problems = [
        f"{name}: shape {array.shape} dtype {array.dtype}, expected shape {shape} of kind {kinds!r}"
        for name, (array, shape, kinds) in expected.items()
        if array.shape != shape or array.dtype.kind not in kinds
    ]
    for i, part in enumerate(s.rigid_parts):
        for name, shape in (("center_m", (3,)), ("inertia_kg_m2", (3, 3))):
            if np.shape(getattr(part, name)) != shape:
                problems.append(f"rigid_parts[{i}].{name}: shape {np.shape(getattr(part, name))}, expected {shape}")
        if np.ndim(part.nodes) != 1 or np.asarray(part.nodes).dtype.kind not in "iu":
            problems.append(
                f"rigid_parts[{i}].nodes: a 1-D integer array is needed, got {np.asarray(part.nodes).dtype}"
            )
    return problems


def _node_problems(s: Structure, extent: float) -> list[str]:
    p, mass = s.positions_m, s.node_mass_kg
    finite = np.isfinite(p).all(axis=1)
    problems = _listed(~finite, lambda i: f"nodes[{i}].position_m: not finite ({_fmt(p[i])})", "nodes")
    problems += _listed(
        ~(mass >= 0) | ~np.isfinite(mass),
        lambda i: f"nodes[{i}].mass_kg: must be finite and >= 0, got {_fmt(mass[i])}",
        "nodes",
    )
    index = np.flatnonzero(finite)
    if index.size < 2:
        return problems
    tolerance = DUPLICATE_REL * extent
    # only neighbours within the tolerance matter: bounding the search keeps it fast (the bound's
    # square must not underflow, hence at least 1e-150 m; the test below is against the tolerance)
    bound = max(2.0 * tolerance, 1e-150)
    distance, neighbour = cKDTree(p[index]).query(p[index], k=2, distance_upper_bound=bound)
    neighbour = np.minimum(neighbour, index.size - 1)  # "no neighbour" is reported as index.size
    other = np.where(neighbour[:, 0] == np.arange(index.size), neighbour[:, 1], neighbour[:, 0])
    close = distance[:, 1] <= tolerance
    # a coincident pair is reported once, from its later node
    mutual_earlier = (other > np.arange(index.size)) & (other[other] == np.arange(index.size))
    flagged = np.zeros(p.shape[0], dtype=bool)
    flagged[index[close & ~mutual_earlier]] = True
    partner = np.full(p.shape[0], -1)
    partner[index] = index[other]
    problems += _listed(
        flagged,
        lambda i: (
            f"nodes[{i}].position_m: {_fmt(p[i])} coincides with node {partner[i]} "
            f"(closer than {DUPLICATE_REL:g} x the extent {extent:.6g} m)"
        ),
        "nodes",
    )
    return problems


def _out_of_range(indices: np.ndarray, n: int) -> np.ndarray:
    return (indices < 0) | (indices >= n)


def _member_index_problems(s: Structure) -> list[str]:
    ends, n = s.members.nodes, s.n_nodes
    bad = _out_of_range(ends, n)
    first = np.where(bad[:, 0], ends[:, 0], ends[:, 1])
    return _listed(
        bad.any(axis=1), lambda i: f"members[{i}].nodes: node {first[i]} does not exist ({n} nodes)", "members"
    )


def _panel_index_problems(s: Structure) -> list[str]:
    corners, n = s.panels.nodes, s.n_nodes
    bad = _out_of_range(corners, n)
    bad[:, 3] &= corners[:, 3] != -1
    column = np.argmax(bad, axis=1)
    return _listed(
        bad.any(axis=1),
        lambda i: (
            f"panels[{i}].nodes: corner {column[i]} is node {corners[i, column[i]]}, which does not exist ({n} nodes)"
        ),
        "panels",
    )


def _part_index_problems(s: Structure) -> list[str]:
    problems = []
    for k, part in enumerate(s.rigid_parts):
        bad = _out_of_range(part.nodes, s.n_nodes)
        if bad.any():
            problems.append(
                f"rigid_parts[{k}].nodes: node {part.nodes[bad][0]} does not exist ({s.n_nodes} nodes)"
                + (f" and {int(bad.sum()) - 1} more" if bad.sum() > 1 else "")
            )
    return problems


def _positive(values: np.ndarray, label: str, *, strict: bool = True, allow_inf: bool = False) -> list[str]:
    """Elements of ``values`` (m,) or (m, k) that are not (strictly) positive and finite."""
    values2 = values.reshape(values.shape[0], int(np.prod(values.shape[1:])))
    ok = (values2 > 0) if strict else (values2 >= 0)
    ok &= np.isfinite(values2) | (allow_inf & (values2 == np.inf))
    table, field = label.split(".")
    sign = ">" if strict else ">="
    return _listed(~ok.all(axis=1), lambda i: f"{table}[{i}].{field}: must be {sign} 0, got {_fmt(values[i])}", table)


def _member_problems(s: Structure, extent: float, *, indices_ok: bool) -> list[str]:
    mm, p = s.members, s.positions_m
    kinds = ", ".join(f"{c} ({k})" for c, k in enumerate(MEMBER_KINDS))
    problems = _listed(
        (mm.kind < 0) | (mm.kind >= len(MEMBER_KINDS)),
        lambda i: f"members[{i}].kind: code {mm.kind[i]} is not one of {kinds}",
        "members",
    )
    same = mm.nodes[:, 0] == mm.nodes[:, 1]
    problems += _listed(same, lambda i: f"members[{i}].nodes: both ends are node {mm.nodes[i, 0]}", "members")
    if indices_ok:
        length = np.linalg.norm(p[mm.nodes[:, 1]] - p[mm.nodes[:, 0]], axis=1)
        short = ~same & (length <= DUPLICATE_REL * extent)
        problems += _listed(
            short,
            lambda i: (
                f"members[{i}].nodes: nodes {mm.nodes[i, 0]} and {mm.nodes[i, 1]} are {_fmt(length[i])} m apart "
                f"(zero length: at most {DUPLICATE_REL:g} x the extent {extent:.6g} m)"
            ),
            "members",
        )
        problems += _orientation_problems(s, p[mm.nodes[:, 1]] - p[mm.nodes[:, 0]])
    problems += _positive(mm.rest_length_m, "members.rest_length_m")
    problems += _positive(mm.EA_N, "members.EA_N")
    for name in ("EI_Nm2", "GJ_Nm2", "damping_Ns_m", "linear_density_kg_m"):
        problems += _positive(getattr(mm, name), f"members.{name}", strict=False)
    problems += _positive(mm.strain_limit, "members.strain_limit", allow_inf=True)
    beam = mm.kind == MEMBER_KINDS.index("beam")
    bending = np.concatenate([mm.EI_Nm2, mm.GJ_Nm2[:, None]], axis=1)
    problems += _listed(
        beam & ~(bending > 0).all(axis=1),
        lambda i: (
            f"members[{i}]: a beam needs EI_Nm2 > 0 about both axes and GJ_Nm2 > 0, got EI_Nm2 "
            f"{_fmt(mm.EI_Nm2[i])} and GJ_Nm2 {_fmt(mm.GJ_Nm2[i])}"
        ),
        "members",
    )
    problems += _listed(
        ~beam & (bending != 0).any(axis=1) & (mm.kind >= 0) & (mm.kind < len(MEMBER_KINDS)),
        lambda i: (
            f"members[{i}].EI_Nm2: a {MEMBER_KINDS[mm.kind[i]]} carries no bending or torsion, got EI_Nm2 "
            f"{_fmt(mm.EI_Nm2[i])} and GJ_Nm2 {_fmt(mm.GJ_Nm2[i])} (make it a beam)"
        ),
        "members",
    )
    return problems


def _orientation_problems(s: Structure, axis_m: np.ndarray) -> list[str]:
    v = s.members.orientation
    problems = _listed(
        ~np.isfinite(v).all(axis=1), lambda i: f"members[{i}].orientation: not finite ({_fmt(v[i])})", "members"
    )
    beam = s.members.kind == MEMBER_KINDS.index("beam")
    given = np.flatnonzero(beam & np.isfinite(v).all(axis=1) & (v != 0).any(axis=1))
    cross = np.linalg.norm(np.cross(v[given], axis_m[given]), axis=1)
    scale = np.linalg.norm(v[given], axis=1) * np.linalg.norm(axis_m[given], axis=1)
    parallel = np.zeros(len(s.members), dtype=bool)
    parallel[given] = cross <= DEGENERATE_REL * scale
    problems += _listed(
        parallel,
        lambda i: (
            f"members[{i}].orientation: {_fmt(v[i])} is parallel to the member (it must span the section's axis 1)"
        ),
        "members",
    )
    return problems


def _panel_problems(s: Structure, *, indices_ok: bool) -> list[str]:
    pn = s.panels
    c = pn.nodes
    pairs = [(0, 1), (0, 2), (1, 2), (0, 3), (1, 3), (2, 3)]
    repeated = np.zeros(len(pn), dtype=bool)
    for a, b in pairs:
        repeated |= (c[:, a] == c[:, b]) & (c[:, b] >= 0)
    problems = _listed(repeated, lambda i: f"panels[{i}].nodes: a corner repeats ({_fmt(c[i][c[i] >= 0])})", "panels")
    if indices_ok and len(pn):
        area = pn.areas_m2(s.positions_m)
        ring = np.where(c[:, 3:] >= 0, c, c[:, [0, 1, 2, 0]])
        edges = s.positions_m[np.roll(ring, -1, axis=1)] - s.positions_m[ring]
        longest = np.linalg.norm(edges, axis=2).max(axis=1)
        flat = ~repeated & (
            (area <= DEGENERATE_REL * longest**2) | (longest <= DUPLICATE_REL * _extent_m(s.positions_m))
        )
        problems += _listed(
            flat,
            lambda i: f"panels[{i}].nodes: zero area ({_fmt(area[i])} m², corners {_fmt(c[i])} are collinear)",
            "panels",
        )
    rho = pn.reflectivity
    bad_rho = (
        ~np.isfinite(rho).all(axis=1) | (rho < 0).any(axis=1) | ~(np.abs(rho.sum(axis=1) - 1.0) <= REFLECTIVITY_TOL)
    )
    problems += _listed(
        bad_rho,
        lambda i: (
            f"panels[{i}].reflectivity: fractions must be >= 0 and sum to 1 within {REFLECTIVITY_TOL:g}, got "
            f"{_fmt(rho[i])} (sum {_fmt(rho[i].sum())})"
        ),
        "panels",
    )
    problems += _positive(pn.areal_density_kg_m2, "panels.areal_density_kg_m2", strict=False)
    problems += _positive(pn.drag_coefficient, "panels.drag_coefficient")
    return problems


def _inertia_problem(mass_kg: float, inertia: np.ndarray) -> str | None:
    """Why ``inertia`` (3, 3) is not a body's inertia tensor about its centre of mass (None: it is)."""
    if not np.isfinite(inertia).all():
        return "not finite"
    scale = float(np.abs(inertia).max())
    if scale == 0.0 and mass_kg == 0.0:
        return None
    if np.abs(inertia - inertia.T).max() > SYMMETRY_REL * scale:
        return "not symmetric"
    moments = np.linalg.eigvalsh(0.5 * (inertia + inertia.T))
    if moments[0] <= 0:
        return f"not positive definite (principal moments {_fmt(moments)})"
    if moments[2] > moments[0] + moments[1] + SYMMETRY_REL * moments.sum():
        return f"principal moments {_fmt(moments)} violate the triangle inequality I3 <= I1 + I2"
    return None


def _rigid_part_problems(s: Structure) -> list[str]:
    problems = []
    names: dict[str, int] = {}
    for k, part in enumerate(s.rigid_parts):
        where = f"rigid_parts[{k}]"
        if not isinstance(part.name, str) or not part.name:
            problems.append(f"{where}.name: a non-empty name is needed, got {part.name!r}")
        elif part.name in names:
            problems.append(f"{where}.name: {part.name!r} is also the name of rigid_parts[{names[part.name]}]")
        names.setdefault(part.name, k)
        if not (np.isfinite(part.mass_kg) and part.mass_kg >= 0):
            problems.append(f"{where}.mass_kg: must be finite and >= 0, got {_fmt(part.mass_kg)}")
        if not np.isfinite(part.center_m).all():
            problems.append(f"{where}.center_m: not finite ({_fmt(part.center_m)})")
        why = _inertia_problem(float(part.mass_kg), np.asarray(part.inertia_kg_m2, dtype=float))
        if why:
            problems.append(f"{where}.inertia_kgm2: {why}, got {_fmt(np.asarray(part.inertia_kg_m2).ravel())}")
        if part.nodes.size == 0:
            problems.append(f"{where}.nodes: holds no node (a free body: weld it to at least one node)")
    return problems + _shared_part_nodes(s)


def _shared_part_nodes(s: Structure) -> list[str]:
    """A node welded to two rigid parts: named once, at the later part, with the earlier part."""
    if len(s.rigid_parts) < 2:
        return []
    nodes = [np.unique(part.nodes) for part in s.rigid_parts]
    owner = np.repeat(np.arange(len(nodes)), [n.size for n in nodes])
    nodes = np.concatenate(nodes)
    order = np.lexsort((owner, nodes))
    nodes, owner = nodes[order], owner[order]
    again = np.flatnonzero(nodes[1:] == nodes[:-1]) + 1
    problems = []
    for part in np.unique(owner[again]):
        first = again[owner[again] == part][0]
        problems.append(
            f"rigid_parts[{part}].nodes: node {nodes[first]} is also held by rigid part "
            f"{s.rigid_parts[owner[first - 1]].name!r}"
        )
    return problems


def _set_problems(s: Structure) -> list[str]:
    problems: list[str] = []  # node and member sets are separate tables: a name may be in both
    for table, sets, count, what in (
        ("sets", s.node_sets, s.n_nodes, "node"),
        ("member_sets", s.member_sets, s.n_members, "member"),
    ):
        for name, indices in sets.items():
            indices = np.asarray(indices)
            if indices.ndim != 1 or (indices.size and indices.dtype.kind not in "iu"):
                problems.append(
                    f"{table}[{name!r}]: a 1-D array of {what} indices is needed, got {indices.dtype} {indices.shape}"
                )
                continue
            bad = np.flatnonzero(_out_of_range(indices, count))
            problems += [
                f"{table}[{name!r}][{j}]: {what} {indices[j]} does not exist ({count} {what}s)"
                for j in bad[:MAX_LISTED]
            ]
            if bad.size > MAX_LISTED:
                problems.append(f"{table}[{name!r}]: {bad.size - MAX_LISTED} more indices out of range (not listed)")
    return problems


def _mass_problems(s: Structure) -> list[str]:
    total = float(s.lumped_masses().sum()) + sum(float(part.mass_kg) for part in s.rigid_parts)
    if not (np.isfinite(total) and total > 0):
        return [f"structure: total mass is {_fmt(total)} kg (nodes, members, panels and rigid parts carry no mass)"]
    return []


def _graph_edges(s: Structure) -> np.ndarray:
    """(e, 2) node pairs that members, panel edges and rigid parts (a star from their first node) join."""
    c = s.panels.nodes
    ring = np.where(c[:, 3:] >= 0, c, c[:, [0, 1, 2, 0]])
    panel_edges = np.stack([ring, np.roll(ring, -1, axis=1)], axis=2).reshape(-1, 2)
    part_edges = [
        np.stack([np.full(part.nodes.size, part.nodes[0]), part.nodes], axis=1)
        for part in s.rigid_parts
        if part.nodes.size
    ]
    return np.concatenate([s.members.nodes, panel_edges, *part_edges]).astype(np.int64)


def _connectivity_problems(s: Structure) -> list[str]:
    n = s.n_nodes
    edges = _graph_edges(s)
    touched = np.zeros(n, dtype=bool)
    touched[edges.ravel()] = True
    unused = ~touched & (s.node_mass_kg == 0)
    problems = _listed(
        unused, lambda i: f"nodes[{i}]: no member, panel or rigid part touches it and it has no mass", "nodes"
    )
    graph = coo_matrix((np.ones(edges.shape[0]), (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    kept = labels[~unused]
    parts, sizes = np.unique(kept, return_counts=True)
    if parts.size > 1:
        _, first = np.unique(labels, return_index=True)  # labels run 0 .. components - 1
        order = np.argsort(-sizes, kind="stable")
        smaller = ", ".join(f"nodes[{first[parts[j]]}] ({sizes[j]} nodes)" for j in order[1 : MAX_LISTED + 1])
        problems.append(
            f"structure: {parts.size} disconnected parts (the largest has {sizes[order[0]]} nodes); a node of each "
            f"smaller part: {smaller}" + (" ..." if parts.size - 1 > MAX_LISTED else "")
        )
    return problems
