"""The body tree of a structure's MuJoCo model: which nodes become bodies, how beams chain them
and where each tree is held (pure NumPy/SciPy; :mod:`magsail_mj.structure.mjcf` writes it).

Vertices
    Every node is a vertex (index ``i``) and every rigid part is one (index ``n + p``); a node a
    part holds belongs to the part's vertex (``node_vertex``) and its own vertex is unused
    (``HELD``). A node touched by no beam and held by no part is a ``PARTICLE`` (a world body on
    slide joints); a node touched by a beam is a ``BEAM_NODE``; a part is a ``PART``.

Beam forest
    Beams are the edges of a graph on the vertices. Each connected component is rooted at a
    constrained vertex (a node or part with ``fixed_dofs``), else at its first rigid part, else at
    its lowest-numbered node, and spanned by the breadth-first tree from that root: the root hangs
    from the world, every other vertex is the child of the vertex on the root side of its tree beam
    (``parent``, ``parent_member``).

Cycles (``cut_member``, ``cut_parent``, ``cut_node``)
    A beam that is not a tree edge closes a cycle (a ring, a frame cell, two beams between the same
    vertices, a beam with both ends on one part): ``E − V + C`` of them for ``E`` beams joining
    ``V`` vertices in ``C`` components, one per independent cycle. Such a beam ``j`` is *cut* at
    its end node ``b`` (``cut_node``): a closing body at ``b`` hangs from the vertex of its other
    end (``cut_parent``) by the beam's own joints, and an equality constraint welds it to the body
    holding ``b``, so that the member is the same spring as a tree beam and the closed structure is
    the continuous one. The closing body takes an equal share of node ``b``'s lumped mass and
    rotational inertia (:mod:`magsail_mj.structure.mjcf`), so ``b`` is the end with the larger
    lumped mass (the second end on a tie); a cut beam whose two end nodes have no mass is refused.

Held places (``held_vertex``, ``held_weld``)
    A tree may hold several constrained vertices. The root is one whose constraint is neither all
    six components nor exactly the three translations, if there is one (it becomes the root's
    joints), else the lowest-numbered constrained vertex; every other constrained vertex of the
    tree is attached to the world by an equality constraint at its constraining node: a weld when
    all six components are fixed, a ball-and-socket (``connect``) when the three translations are.
    A tree with two constrained vertices of another kind is refused.

Root constraint (``anchor_node``, ``root_fixed``)
    The constraining node of a root or a held vertex: the vertex's own node, or the one node of a
    part with ``fixed_dofs`` (a part with a fully fixed node is welded whatever its other nodes
    say; two partially fixed nodes of one part are refused). ``root_fixed`` is a root's node's
    ``fixed_dofs`` row (all ``True`` for a welded part).

Node rotational inertia
    A beam node's body carries the rotational inertia of the lumped mass model of
    :func:`magsail_mj.structure.assembly.mass_matrix` (``mass="lumped"``: at each beam end
    ``diag(ρI_p l/2, ρA l³/78, ρA l³/78)`` in member axes, the HRZ lumping), so that MuJoCo's
    model and the modal analysis share one mass model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from magsail_mj.structure.assembly import dof_layout, mass_matrix
from magsail_mj.structure.model import MEMBER_KINDS, Structure, StructureError

__all__ = [
    "BEAM_NODE",
    "HELD",
    "PARTICLE",
    "PART",
    "BodyLayout",
    "body_layout",
    "node_rotary_inertia",
]

PARTICLE, BEAM_NODE, PART, HELD = 0, 1, 2, -1
#: Elements listed per finding before the rest are counted.
MAX_LISTED = 10
_BEAM = MEMBER_KINDS.index("beam")


@dataclass(frozen=True)
class BodyLayout:
    """Bodies of a structure's model (module docstring); ``V = n_nodes + n_parts`` vertices.

    Attributes:
      node_vertex: (n,) the vertex of each node (``i``, or ``n + p`` when part ``p`` holds it).
      kind: (V,) ``PARTICLE``, ``BEAM_NODE``, ``PART`` or ``HELD``.
      parent: (V,) parent vertex (−1: the world).
      parent_member: (V,) the beam joining a vertex to its parent (−1 for roots).
      parent_end: (m,) for the beams, the end (0 or 1) on the parent's side (−1 for other members).
      anchor_node: (V,) the constraining node of a root or a held vertex (−1: none, a free root).
      root_fixed: (V, 6) the constrained components (x, y, z, rx, ry, rz) of a root.
      order: the vertices to write, each after its parent (by depth from the world, then by vertex
        number; ``HELD`` vertices left out).
      cut_member: (k,) the beams that close cycles, ascending (module docstring).
      cut_parent: (k,) the vertex each cut beam's closing body hangs from.
      cut_node: (k,) the end node where each closing body sits, welded to that node's body.
      held_vertex: (h,) constrained vertices other than roots, attached to the world, ascending.
      held_weld: (h,) whether each is welded (all six components fixed) or connected (the three
        translations fixed).
    """

    node_vertex: np.ndarray
    kind: np.ndarray
    parent: np.ndarray
    parent_member: np.ndarray
    parent_end: np.ndarray
    anchor_node: np.ndarray
    root_fixed: np.ndarray
    order: np.ndarray
    cut_member: np.ndarray
    cut_parent: np.ndarray
    cut_node: np.ndarray
    held_vertex: np.ndarray
    held_weld: np.ndarray

    def closing_share(self, n_nodes: int) -> np.ndarray:
        """(n,) the fraction of each node's lumped mass and rotational inertia that each of its
        bodies carries: ``1 / (1 + k_i)`` for a node where ``k_i`` closing bodies sit, else 1."""
        return 1.0 / (1.0 + np.bincount(self.cut_node, minlength=n_nodes))


def _listed(indices: np.ndarray, describe, what: str) -> list[str]:
    """Lines for the first :data:`MAX_LISTED` ``indices``, then a count of the rest."""
    lines = [describe(int(i)) for i in indices[:MAX_LISTED]]
    if indices.size > MAX_LISTED:
        lines.append(f"... and {indices.size - MAX_LISTED} more {what}")
    return lines


def _node_vertices(structure: Structure) -> np.ndarray:
    """(n,) vertex of each node; a node held by two parts is refused."""
    n = structure.n_nodes
    held = [np.asarray(part.nodes, dtype=np.int64).ravel() for part in structure.rigid_parts]
    nodes = np.concatenate(held) if held else np.zeros(0, dtype=np.int64)
    owner = np.repeat(np.arange(len(held)), [h.size for h in held]).astype(np.int64)
    outside = (nodes < 0) | (nodes >= n)
    if np.any(outside):
        raise StructureError(
            _listed(
                np.flatnonzero(outside),
                lambda k: f"rigid_parts[{owner[k]}].nodes: node {nodes[k]} does not exist ({n} nodes)",
                "nodes",
            )
        )
    unique, counts = np.unique(nodes, return_counts=True)
    twice = unique[counts > 1]
    if twice.size:
        raise StructureError(
            _listed(
                twice,
                lambda i: (
                    f"rigid_parts.nodes: node {i} is held by parts "
                    f"{[structure.rigid_parts[o].name for o in np.unique(owner[nodes == i])]}"
                ),
                "nodes",
            )
        )
    vertex = np.arange(n, dtype=np.int64)
    vertex[nodes] = n + owner
    return vertex


def _part_anchors(structure: Structure, node_vertex: np.ndarray, V: int) -> tuple[np.ndarray, list[str]]:
    """(V,) constraining node of each vertex (−1 none; a part's fully fixed node wins) and the
    findings (a part with two partially fixed nodes)."""
    n = structure.n_nodes
    fixed = np.asarray(structure.fixed_dofs, dtype=bool)
    constrained = np.flatnonzero(fixed.any(axis=1))
    full = fixed[constrained].all(axis=1)
    anchor = np.full(V, -1, dtype=np.int64)
    # per vertex, its fully fixed node if any, else its (only) partly fixed one: the last of each group
    by = np.lexsort((full, node_vertex[constrained]))
    group = node_vertex[constrained][by]
    last = np.ones(group.size, dtype=bool)
    last[:-1] = group[1:] != group[:-1]
    anchor[group[last]] = constrained[by][last]
    count = np.bincount(node_vertex[constrained], minlength=V)
    welded = np.zeros(V, dtype=bool)
    welded[node_vertex[constrained[full]]] = True
    bad = np.flatnonzero((count > 1) & ~welded & (np.arange(V) >= n))

    def describe(v: int) -> str:
        nodes = constrained[node_vertex[constrained] == v]
        return (
            f"rigid_parts[{v - n}] ({structure.rigid_parts[v - n].name!r}): nodes {nodes.tolist()} all have partly "
            "fixed dofs; a part can be held at one node (or welded by a fully fixed node)"
        )

    return anchor, _listed(bad, describe, "parts")


def _equality_held(fixed_rows: np.ndarray) -> np.ndarray:
    """Whether each ``fixed_dofs`` row (k, 6) is one an equality constraint holds: all six
    components (a weld) or exactly the three translations (a ball-and-socket ``connect``)."""
    return fixed_rows.all(axis=1) | (fixed_rows[:, :3].all(axis=1) & ~fixed_rows[:, 3:].any(axis=1))


def _roots(
    components: np.ndarray, kind: np.ndarray, anchor: np.ndarray, fixed: np.ndarray
) -> tuple[np.ndarray, list[str]]:
    """(c,) the root vertex of each component (module docstring) and the findings (two
    constrained vertices in one tree that no equality constraint holds)."""
    V = kind.size
    constrained = anchor >= 0
    other = constrained & ~_equality_held(fixed[np.maximum(anchor, 0)])
    priority = np.where(other, 0, np.where(constrained, 1, np.where(kind == PART, 2, 3)))
    order = np.lexsort((np.arange(V), priority, components))
    _, first = np.unique(components[order], return_index=True)
    roots = order[first]
    bad = np.flatnonzero(np.bincount(components[other], minlength=roots.size) > 1)

    def describe(c: int) -> str:
        nodes = anchor[(components == c) & other]
        return (
            f"fixed_dofs: nodes {nodes.tolist()} are in one tree of beams and rigid parts and have fixed dofs other "
            "than all six or the three translations; a beam tree can be held so at one node only (make a member "
            "between them a strut)"
        )

    return roots, _listed(bad, describe, "trees")


def _tree(
    structure: Structure, beams: np.ndarray, ends: np.ndarray, roots: np.ndarray, V: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """Breadth-first forest from a super-root joined to ``roots``: parent, parent member, the
    parent-side end of each beam, depth, and the beams that close cycles (indices into ``beams``)."""
    S = V
    rows = np.concatenate([ends[:, 0], np.full(roots.size, S)])
    cols = np.concatenate([ends[:, 1], roots])
    graph = sparse.coo_matrix((np.ones(rows.size), (rows, cols)), shape=(V + 1, V + 1)).tocsr()
    _, pred = csgraph.breadth_first_order(graph, S, directed=False, return_predecessors=True)
    depth = csgraph.shortest_path(graph, directed=False, unweighted=True, indices=S)
    u, v = ends[:, 0], ends[:, 1]
    into_v, into_u = pred[v] == u, pred[u] == v
    candidates = np.flatnonzero((into_v | into_u) & (u != v))
    child = np.where(into_v, v, u)[candidates]
    _, first = np.unique(child, return_index=True)
    tree_edges = candidates[first]
    parent = np.where(pred[:V] == S, -1, pred[:V]).astype(np.int64)
    parent_member = np.full(V, -1, dtype=np.int64)
    parent_member[child[first]] = beams[tree_edges]
    parent_end = np.full(structure.n_members, -1, dtype=np.int64)
    parent_end[beams[tree_edges]] = np.where(into_v[tree_edges], 0, 1)
    closing = np.setdiff1d(np.arange(beams.size), tree_edges)
    return parent, parent_member, parent_end, depth[:V], closing


def _cuts(
    structure: Structure, cut: np.ndarray, node_vertex: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """The cut beams' closing bodies (module docstring): the members, the vertex each hangs from,
    the node each sits at, and the findings (a cut beam whose end nodes have no mass)."""
    masses = structure.lumped_masses()
    ends = structure.members.nodes[cut].reshape(-1, 2)
    at = (masses[ends[:, 1]] >= masses[ends[:, 0]]).astype(np.int64)
    rows = np.arange(cut.size)
    node = ends[rows, at]
    parent = node_vertex[ends[rows, 1 - at]]

    def describe(k: int) -> str:
        return (
            f"members[{cut[k]}] (beam, nodes {ends[k, 0]}-{ends[k, 1]}): it closes a cycle of beams, and the body "
            "that closes it takes a share of an end node's lumped mass, but both end nodes have none (give them mass "
            "or make the member a strut)"
        )

    massless = np.flatnonzero(~(masses[node] > 0))
    return cut, parent, node, _listed(massless, describe, "beams")


def body_layout(structure: Structure) -> BodyLayout:
    """The body tree of ``structure`` (module docstring).

    Raises:
      StructureError: listing every finding (a node held by two parts, a cycle of massless beams
        between massless nodes, two places in one tree held other than by a weld or a connect),
        each naming the element.
    """
    n = structure.n_nodes
    V = n + len(structure.rigid_parts)
    node_vertex = _node_vertices(structure)
    members = structure.members
    beams = np.flatnonzero(members.kind == _BEAM)
    ends = node_vertex[members.nodes[beams]].reshape(-1, 2)
    kind = np.full(V, PARTICLE, dtype=np.int8)
    kind[ends.ravel()] = BEAM_NODE
    kind[n:] = PART
    kind[:n][node_vertex != np.arange(n)] = HELD
    anchor, problems = _part_anchors(structure, node_vertex, V)
    links = ends[ends[:, 0] != ends[:, 1]]
    adjacency = sparse.coo_matrix((np.ones(len(links)), (links[:, 0], links[:, 1])), shape=(V, V))
    _, components = csgraph.connected_components(adjacency, directed=False)
    fixed = np.asarray(structure.fixed_dofs, dtype=bool)
    roots, found = _roots(components, kind, anchor, fixed)
    problems += found
    parent, parent_member, parent_end, depth, closing = _tree(structure, beams, ends, roots, V)
    cut_member, cut_parent, cut_node, found = _cuts(structure, beams[closing], node_vertex)
    problems += found
    if problems:
        raise StructureError(problems)
    is_root = parent < 0
    held_vertex = np.flatnonzero(~is_root & (anchor >= 0))
    root_fixed = np.zeros((V, 6), dtype=bool)
    rooted = np.flatnonzero(is_root & (anchor >= 0))
    root_fixed[rooted] = fixed[anchor[rooted]]  # a welded part's anchor is its fully fixed node
    order = np.lexsort((np.arange(V), depth))
    return BodyLayout(
        node_vertex=node_vertex,
        kind=kind,
        parent=parent,
        parent_member=parent_member,
        parent_end=parent_end,
        anchor_node=anchor,
        root_fixed=root_fixed,
        order=order[kind[order] != HELD],
        cut_member=cut_member,
        cut_parent=cut_parent,
        cut_node=cut_node,
        held_vertex=held_vertex,
        held_weld=fixed[anchor[held_vertex]].all(axis=1).reshape(-1),
    )


def node_rotary_inertia(structure: Structure) -> np.ndarray:
    """(n, 3, 3) rotational inertia of each node from the beams ending there, structure axes
    [kg m²]: the rotation blocks of :func:`~magsail_mj.structure.assembly.mass_matrix` (lumped,
    HRZ); zero at nodes touched by no beam."""
    n = structure.n_nodes
    out = np.zeros((n, 3, 3))
    if not np.any(structure.members.kind == _BEAM):
        return out
    layout = dof_layout(structure)
    M = mass_matrix(structure, layout, mass="lumped").tocoo()
    node_r, node_c = layout.dof_node[M.row], layout.dof_node[M.col]
    comp_r, comp_c = layout.dof_component[M.row], layout.dof_component[M.col]
    keep = (node_r == node_c) & (comp_r >= 3) & (comp_c >= 3)
    np.add.at(out, (node_r[keep], comp_r[keep] - 3, comp_c[keep] - 3), M.data[keep])
    return out
