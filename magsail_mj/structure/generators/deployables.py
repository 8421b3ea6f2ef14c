"""Deployable structures: a four-boom square sail with its membrane, a hoop (a closed ring of
beams, the rim of a hoop-column or hoop-truss reflector) and a longeron truss mast (pure NumPy).

Frames and units: structure frame, SI. Masses come from the members' linear densities (half of
``ρA l0`` at each end) and the panels' areal density (an equal share at each corner), as
:meth:`~magsail_mj.structure.model.Structure.lumped_masses` lumps them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
from scipy.optimize import brentq

from magsail_mj.structure.formfinding import force_density_shape, rest_lengths_m
from magsail_mj.structure.generators.common import (
    FLAT_PLATE_DRAG_COEFFICIENT,
    check_count,
    check_positive,
    check_reflectivity,
)
from magsail_mj.structure.model import Members, Panels, RigidPart, Structure

__all__ = ["four_boom_sail", "hoop", "rim_sag_m", "truss_mast"]

_Z = np.array([0.0, 0.0, 1.0])


def _bending(name: str, value: float | Sequence[float]) -> np.ndarray:
    """``EI`` about section axes 1 and 2 [N m²] from a scalar (both) or a pair."""
    pair = np.broadcast_to(np.asarray(value, dtype=float), (2,)) if np.ndim(value) <= 1 else None
    if pair is None or not np.all(np.isfinite(pair)) or np.any(pair < 0):
        raise ValueError(f"{name}: must be a number or a pair of numbers >= 0, got {value!r}")
    return np.array(pair)


def _hub_part(hub_mass_kg: float, hub_inertia_kg_m2: float | Sequence | np.ndarray | None) -> tuple[RigidPart, ...]:
    mass = check_positive("hub_mass_kg", hub_mass_kg, allow_zero=True)
    if hub_inertia_kg_m2 is None:
        inertia = np.zeros((3, 3))
    else:
        given = np.asarray(hub_inertia_kg_m2, dtype=float)
        inertia = np.diag(np.broadcast_to(given, (3,))) if given.ndim <= 1 else given
        if inertia.shape != (3, 3) or not np.all(np.isfinite(inertia)):
            raise ValueError(f"hub_inertia_kg_m2: must be a number, 3 principal moments or a 3×3 tensor, got {given!r}")
    if mass == 0 and not np.any(inertia):
        return ()
    return (RigidPart(name="hub", mass_kg=mass, center_m=np.zeros(3), inertia_kg_m2=inertia, nodes=np.array([0])),)


def _quadrant(
    n: int, first_free: int, boom_a: np.ndarray, boom_b: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node grid and triangles of one quadrant of the sail: grid point ``(i, j)``,
    ``i + j ≤ n``, is ``(i A + j B) / n``; row ``j = 0`` is boom A (``boom_a``: hub, then its
    nodes 1..n), column ``i = 0`` boom B; the others are numbered from ``first_free`` (j-major).
    Returns the (n+1, n+1) [i, j] index grid (−1 outside), the (n², 3) triangles,
    counter-clockwise about +z when B lies counter-clockwise of A, and the (k, 2) ``(i, j)`` of
    the numbered nodes in their order."""
    j, i = (g.ravel() for g in np.meshgrid(np.arange(1, n), np.arange(1, n), indexing="ij"))
    inner = i + j <= n
    free = np.stack([i[inner], j[inner]], axis=1)
    grid = np.full((n + 1, n + 1), -1, dtype=np.int64)
    grid[free[:, 0], free[:, 1]] = first_free + np.arange(len(free))
    grid[:, 0] = boom_a
    grid[0, :] = boom_b
    gi, gj = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    lower, upper = gi + gj <= n - 1, gi + gj <= n - 2
    g00, g10, g01, g11 = grid[:-1, :-1], grid[1:, :-1], grid[:-1, 1:], grid[1:, 1:]
    triangles = np.concatenate(
        [np.stack([g00[lower], g10[lower], g01[lower]], 1), np.stack([g10[upper], g11[upper], g01[upper]], 1)]
    )
    return grid, triangles, free


def rim_sag_m(positions_m: np.ndarray, rim: np.ndarray, tips: np.ndarray) -> np.ndarray:
    """(4,) largest inward distance [m] of each quadrant's rim nodes (``rim[q]``, tip to tip)
    from the straight edge between its tips ``tips[q]`` and ``tips[q + 1]``, measured along the
    edge's inward normal in the x–y plane (the hub at the origin)."""
    a, b = tips, np.roll(tips, -1, axis=0)
    outward = (a + b)[:, :2] / np.linalg.norm((a + b)[:, :2], axis=1, keepdims=True)
    inward = np.einsum("qk,qk->q", a[:, :2], outward)[:, None] - np.einsum(
        "qrk,qk->qr", positions_m[rim][:, :, :2], outward
    )
    return inward.max(axis=1)


def _cable_net(
    positions_m: np.ndarray,
    triangles: np.ndarray,
    booms: np.ndarray,
    *,
    rim: np.ndarray,
    tips: np.ndarray,
    n: int,
    side_m: float,
    EA_N: float,
    prestrain: float,
    edge_sag_ratio: float | None,
) -> tuple[Members, np.ndarray, np.ndarray]:
    """The sail's cable net (:func:`four_boom_sail`, "Cable net"): its members, the node
    positions (form-found or as given) and the indices of the rim cables among the net's."""
    edges = np.unique(
        np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1), axis=0
    )
    taken = np.sort(booms, axis=1)
    edges = edges[~(edges[:, None, :] == taken[None]).all(axis=-1).any(axis=1)]
    on_rim = np.zeros(len(positions_m), dtype=bool)
    on_rim[rim.ravel()] = True
    rim_cables = np.flatnonzero(on_rim[edges[:, 0]] & on_rim[edges[:, 1]])
    if edge_sag_ratio is None:
        cables = Members.build(edges, positions_m=positions_m, kind="cable", EA_N=EA_N, prestrain=prestrain)
        return cables, positions_m, rim_cables
    ratio = check_positive("edge_sag_ratio", edge_sag_ratio)
    if n < 2:
        raise ValueError(f"edge_sag_ratio: needs n_segments >= 2 (free rim nodes), got n_segments={n}")
    if prestrain <= 0:
        raise ValueError(f"net_prestrain: must be > 0 to set the form-found net's tension, got {prestrain!r}")
    supports = np.arange(1 + 4 * n)
    q_interior = EA_N * prestrain / (side_m / math.sqrt(2.0) / n)
    q = np.full(len(edges), q_interior)

    def shape(log_q_edge: float) -> np.ndarray:
        q[rim_cables] = math.exp(log_q_edge)
        return force_density_shape(positions_m, edges, q, supports=supports)

    def miss(log_q_edge: float) -> float:
        return float(rim_sag_m(shape(log_q_edge), rim, tips).max()) / side_m - ratio

    guess = math.log(q_interior * n / (8.0 * ratio))
    low, high = guess - math.log(10.0), guess + math.log(10.0)
    for _ in range(12):
        if miss(low) > 0 > miss(high):
            break
        low, high = low - math.log(10.0), high + math.log(10.0)
    else:
        reach = (miss(high) + ratio, miss(low) + ratio)
        raise ValueError(
            f"edge_sag_ratio: no rim force density gives a sag of {ratio!r} × side "
            f"(from {math.exp(high):.3g} down to {math.exp(low):.3g} N/m: {reach[0]:.3g} to {reach[1]:.3g} × side)"
        )
    found = shape(brentq(miss, low, high, xtol=1e-14, rtol=1e-12)) + 0.0  # no negative zeros
    side_a = found[triangles[:, 1]] - found[triangles[:, 0]]
    side_b = found[triangles[:, 2]] - found[triangles[:, 0]]
    folded = int(np.sum(np.cross(side_a, side_b)[:, 2] <= 0))  # a panel's normal turned from +z
    if folded:
        raise ValueError(f"edge_sag_ratio: the form-found net folds {folded} panels at {ratio!r}")
    length = np.linalg.norm(found[edges[:, 1]] - found[edges[:, 0]], axis=1)
    cables = Members.build(
        edges,
        positions_m=found,
        kind="cable",
        EA_N=EA_N,
        rest_length_m=rest_lengths_m(length, q * length, EA_N),
    )
    return cables, found, rim_cables


def four_boom_sail(
    *,
    side_m: float,
    n_segments: int,
    boom_EA_N: float,
    boom_EI_Nm2: float | Sequence[float],
    boom_GJ_Nm2: float,
    boom_linear_density_kg_m: float,
    membrane_areal_density_kg_m2: float,
    reflectivity: Sequence[float],
    drag_coefficient: float = FLAT_PLATE_DRAG_COEFFICIENT,
    boom_damping_Ns_m: float = 0.0,
    hub_mass_kg: float = 0.0,
    hub_inertia_kg_m2: float | Sequence | np.ndarray | None = None,
    net_EA_N: float | None = None,
    net_prestrain: float = 0.0,
    edge_sag_ratio: float | None = None,
    name: str = "four_boom_sail",
) -> Structure:
    """A square solar sail of side ``side_m`` in the x–y plane, front normal +z: four booms of
    ``n_segments`` beam members each from the hub node 0 at the origin to the square's corners
    ``(±side/2, ±side/2, 0)`` (boom ``q`` at ``45° + 90° q``, length ``L = side/√2``), and the
    membrane: each quadrant between booms ``q`` and ``q + 1`` is the triangle (hub, tip q, tip
    q+1) cut into ``n_segments²`` congruent right triangles on the grid ``(i A + j B) / n``, whose
    sides on the booms are the boom nodes (counter-clockwise about +z).

    Booms: ``EA``, ``EI`` (one value or section axes 1 and 2; axis 1 in the plane of +z),
    ``GJ``, linear density and axial dashpot. Membrane panels: areal density, ``reflectivity``
    (specular, diffuse, absorbed fractions) and drag coefficient. A hub of ``hub_mass_kg`` and
    ``hub_inertia_kg_m2`` (about the origin: a number, principal moments or a 3×3 tensor) is a
    rigid part holding node 0.

    ``2 n² + 2 n + 1`` nodes (hub, ``4 n`` boom nodes, then each quadrant's membrane nodes),
    ``4 n`` members, ``4 n²`` panels. Node sets: ``hub``, ``boom_nodes`` (boom nodes without the
    hub), ``boom_nodes_0..boom_nodes_3`` (hub to tip), ``tip`` (the four boom tips), ``rim`` (the free membrane
    edge, tips included), ``membrane`` (every panel corner); member sets
    ``booms`` and ``boom_0..boom_3``.

    Cable net (``net_EA_N`` given): a cable of axial rigidity ``net_EA_N`` along every panel edge
    that no boom member joins, ``2 n (3 n − 1)`` after the booms (member set ``membrane``; ``rim``
    cables along the free edges, ``4 n`` of them, in member set ``rim_cables``):

    - ``edge_sag_ratio=None``: the grid's straight edges, every cable prestrained by
      ``net_prestrain`` (``l0 = l / (1 + ε0)``: ``EA ε0`` of tension at the reference). A
      tension-only net with straight free edges is not in equilibrium (the interior pulls the rim
      inward; the linear prestress equilibrium then leaves the cables next to the rim in
      compression).
    - ``edge_sag_ratio=s``: the net is form-found by the force density method
      (:mod:`magsail_mj.structure.formfinding`), the hub and boom nodes its supports, in the
      x–y plane: the interior cables at the force density ``q_i = EA ε0 / a`` (``a = L / n``, a
      boom segment: the tension a leg cable of the straight grid carries at ``ε0``), the rim
      cables at the ``q_e`` (Brent's method on ``log q_e``, relative tolerance 1e-12) that puts
      the rim's largest inward sag from the straight edge between its two tips at ``s · side``.
      The free net nodes are then in equilibrium under the tensions ``T = q L`` at the found
      lengths ``L``, each cable's rest length is ``l0 = L / (1 + T / EA)`` and the panels (with
      their areas and masses) follow the found nodes; the booms, at their rest length, take the
      net's pull in compression at the prestress equilibrium. Start of the search: the rim as a
      cable of tension ``T_e = q_e S / n`` (``S = side``) under the uniform inward pull
      ``p = q_i`` per length (the straight grid's two leg cables at a rim node, ``q_i a √2``
      inward per ``a √2`` of rim) sags ``f = p S² / (8 T_e)``, so ``q_e ≈ q_i n / (8 s)``.
      Needs ``n_segments >= 2`` and ``net_prestrain > 0``; the sag is bounded by the rim's shape
      as ``q_e → 0`` (0.204 of the side at 4 segments), and a ratio beyond it is refused.
    """
    side = check_positive("side_m", side_m)
    n = check_count("n_segments", n_segments, minimum=1)
    row = check_reflectivity("reflectivity", reflectivity)
    EI = _bending("boom_EI_Nm2", boom_EI_Nm2)
    angles = np.pi / 4 + np.pi / 2 * np.arange(4)
    tips = side / math.sqrt(2.0) * np.column_stack([np.cos(angles), np.sin(angles), np.zeros(4)])
    fractions = np.arange(1, n + 1) / n
    boom_positions = (tips[:, None, :] * fractions[None, :, None]).reshape(-1, 3)
    boom_nodes = np.concatenate([np.zeros((4, 1), dtype=np.int64), 1 + np.arange(4 * n).reshape(4, n)], axis=1)
    positions, triangles, rim = [np.zeros((1, 3)), boom_positions], [], []
    first = 1 + 4 * n
    for q in range(4):
        a, b = tips[q], tips[(q + 1) % 4]
        grid, tri, free = _quadrant(n, first, boom_nodes[q], boom_nodes[(q + 1) % 4])
        positions.append((free[:, :1] * a + free[:, 1:] * b) / n)
        triangles.append(tri)
        rim.append(grid[np.arange(n + 1), n - np.arange(n + 1)])
        first += len(free)
    positions_m = np.concatenate(positions)
    triangles_all = np.concatenate(triangles)
    ends = np.stack([boom_nodes[:, :-1], boom_nodes[:, 1:]], axis=-1).reshape(-1, 2)
    members = Members.build(
        ends,
        positions_m=positions_m,
        kind="beam",
        EA_N=check_positive("boom_EA_N", boom_EA_N),
        EI_Nm2=EI[None, :],
        GJ_Nm2=check_positive("boom_GJ_Nm2", boom_GJ_Nm2, allow_zero=True),
        damping_Ns_m=check_positive("boom_damping_Ns_m", boom_damping_Ns_m, allow_zero=True),
        linear_density_kg_m=check_positive("boom_linear_density_kg_m", boom_linear_density_kg_m, allow_zero=True),
        orientation=_Z,
    )
    node_sets = {
        "hub": np.array([0]),
        "boom_nodes": np.arange(1, 1 + 4 * n),
        "tip": boom_nodes[:, -1].copy(),
        "rim": np.unique(np.concatenate(rim)),
        "membrane": np.unique(triangles_all),
    }
    member_sets = {"booms": np.arange(4 * n)}
    member_sets.update({f"boom_{q}": np.arange(q * n, (q + 1) * n) for q in range(4)})
    if net_EA_N is not None:
        cables, positions_m, rim_cables = _cable_net(
            positions_m,
            triangles_all,
            ends,
            rim=np.stack(rim),
            tips=tips,
            n=n,
            side_m=side,
            EA_N=check_positive("net_EA_N", net_EA_N),
            prestrain=check_positive("net_prestrain", net_prestrain, allow_zero=True),
            edge_sag_ratio=edge_sag_ratio,
        )
        members = Members.concatenate([members, cables])
        member_sets["membrane"] = 4 * n + np.arange(len(cables))
        member_sets["rim_cables"] = 4 * n + rim_cables
    elif edge_sag_ratio is not None:
        raise ValueError(f"edge_sag_ratio: needs a cable net (net_EA_N), got {edge_sag_ratio!r} without one")
    p = len(triangles_all)
    panels = Panels(
        nodes=np.column_stack([triangles_all, np.full(p, -1)]),
        areal_density_kg_m2=np.full(
            p, check_positive("membrane_areal_density_kg_m2", membrane_areal_density_kg_m2, allow_zero=True)
        ),
        reflectivity=np.tile(row, (p, 1)),
        drag_coefficient=np.full(p, check_positive("drag_coefficient", drag_coefficient, allow_zero=True)),
    )
    node_sets.update({f"boom_nodes_{q}": boom_nodes[q].copy() for q in range(4)})
    return Structure(
        name=name,
        positions_m=positions_m,
        node_mass_kg=np.zeros(len(positions_m)),
        members=members,
        panels=panels,
        rigid_parts=_hub_part(hub_mass_kg, hub_inertia_kg_m2),
        node_sets=node_sets,
        member_sets=member_sets,
    )


def hoop(
    *,
    radius_m: float,
    n_segments: int,
    EA_N: float,
    EI_Nm2: float | Sequence[float],
    GJ_Nm2: float,
    linear_density_kg_m: float,
    damping_Ns_m: float = 0.0,
    name: str = "hoop",
) -> Structure:
    """A closed ring of ``n_segments`` straight beam members in the x–y plane: node ``k`` at
    ``R (cos 2πk/n, sin 2πk/n, 0)``, member ``k`` from node ``k`` to ``k + 1`` (mod n), each a
    chord ``2 R sin(π/n)`` long; section axis 1 in the plane of +z (``EI`` one value or the pair:
    ``EI1`` bends the ring out of its plane, ``EI2`` in it). Node set ``rim`` (all), member set
    ``hoop`` (all).

    Mass ``M = 2 n R μ sin(π/n)``, short of the thin ring's ``2πRμ`` by ``(π/n)²/6``; every node
    at radius R, so the inertia is the thin ring's ``diag(M R²/2, M R²/2, M R²)`` of that mass.
    The model builder closes the ring with one weld (:mod:`magsail_mj.structure.mjcf`, "Cycles");
    a polygon of ``n`` chords is stiffer in its plane than the circle by ``O((π/n)²)``: its first
    in-plane frequencies are +2.2 % and +3.4 % off the thin ring's at 24 chords, a quarter of
    that at 48."""
    radius = check_positive("radius_m", radius_m)
    n = check_count("n_segments", n_segments, minimum=3)
    theta = 2.0 * np.pi * np.arange(n) / n
    positions = radius * np.column_stack([np.cos(theta), np.sin(theta), np.zeros(n)])
    ends = np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)
    members = Members.build(
        ends,
        positions_m=positions,
        kind="beam",
        EA_N=check_positive("EA_N", EA_N),
        EI_Nm2=_bending("EI_Nm2", EI_Nm2)[None, :],
        GJ_Nm2=check_positive("GJ_Nm2", GJ_Nm2, allow_zero=True),
        damping_Ns_m=check_positive("damping_Ns_m", damping_Ns_m, allow_zero=True),
        linear_density_kg_m=check_positive("linear_density_kg_m", linear_density_kg_m, allow_zero=True),
        orientation=_Z,
    )
    return Structure(
        name=name,
        positions_m=positions,
        node_mass_kg=np.zeros(n),
        members=members,
        node_sets={"rim": np.arange(n)},
        member_sets={"hoop": np.arange(n)},
    )


def _mast_members(n_longerons: int, n_bays: int) -> dict[str, np.ndarray]:
    """End nodes of the mast's member groups; node ``s · n_l + v`` is vertex ``v`` of station ``s``."""
    nl, b = n_longerons, n_bays
    s, v = np.meshgrid(np.arange(b), np.arange(nl), indexing="ij")
    nxt = (v + 1) % nl
    odd = (s % 2).astype(bool)
    station, vertex = np.meshgrid(np.arange(b + 1), np.arange(nl), indexing="ij")
    groups = {
        "longerons": np.stack([s * nl + v, (s + 1) * nl + v], -1).reshape(-1, 2),
        "battens": np.stack([station * nl + vertex, station * nl + (vertex + 1) % nl], -1).reshape(-1, 2),
        "diagonals": np.stack([s * nl + np.where(odd, nxt, v), (s + 1) * nl + np.where(odd, v, nxt)], -1).reshape(
            -1, 2
        ),
    }
    if nl == 4:
        stations = np.arange(b + 1)
        start = stations % 2
        groups["station_diagonals"] = np.stack([stations * 4 + start, stations * 4 + start + 2], -1)
    return groups


def truss_mast(
    *,
    length_m: float,
    n_bays: int,
    width_m: float,
    n_longerons: Literal[3, 4] = 3,
    EA_N: float,
    linear_density_kg_m: float,
    damping_Ns_m: float = 0.0,
    name: str = "truss_mast",
) -> Structure:
    """A longeron truss mast along +z from ``z = 0`` to ``length_m``: ``n_bays + 1`` stations
    ``h = length_m / n_bays`` apart, each a regular polygon of ``n_longerons`` vertices of side
    ``width_m`` (circumradius ``ρ = width / (2 sin(π/n_l))``, vertex ``v`` at angle
    ``π/2 + 2πv/n_l`` for 3 longerons, ``π/4 + πv/2`` for 4). Struts: longerons (vertex to vertex
    between stations), battens (the polygon's sides at every station), one diagonal per side face
    per bay (``(s, v) → (s+1, v+1)`` in even bays, ``(s, v+1) → (s+1, v)`` in odd ones) and, for 4
    longerons, one diagonal across every station's square (alternating between the two), which
    makes each bay a rigid box. Node ``s · n_l + v``; node sets ``root`` (station 0), ``tip``
    (the last); member sets ``longerons``, ``battens``, ``diagonals`` (and
    ``station_diagonals``)."""
    length = check_positive("length_m", length_m)
    b = check_count("n_bays", n_bays, minimum=1)
    width = check_positive("width_m", width_m)
    if n_longerons not in (3, 4):
        raise ValueError(f"n_longerons: must be 3 or 4, got {n_longerons!r}")
    rho = width / (2.0 * math.sin(math.pi / n_longerons))
    phase = math.pi / 2 if n_longerons == 3 else math.pi / 4
    angle = phase + 2.0 * math.pi * np.arange(n_longerons) / n_longerons
    polygon = rho * np.column_stack([np.cos(angle), np.sin(angle)])
    z = np.repeat(np.arange(b + 1) * (length / b), n_longerons)
    positions = np.column_stack([np.tile(polygon, (b + 1, 1)), z])
    groups = _mast_members(n_longerons, b)
    bounds = np.cumsum([0] + [len(g) for g in groups.values()])
    members = Members.build(
        np.concatenate(list(groups.values())),
        positions_m=positions,
        EA_N=check_positive("EA_N", EA_N),
        damping_Ns_m=check_positive("damping_Ns_m", damping_Ns_m, allow_zero=True),
        linear_density_kg_m=check_positive("linear_density_kg_m", linear_density_kg_m, allow_zero=True),
    )
    return Structure(
        name=name,
        positions_m=positions,
        node_mass_kg=np.zeros(len(positions)),
        members=members,
        node_sets={"root": np.arange(n_longerons), "tip": b * n_longerons + np.arange(n_longerons)},
        member_sets={key: np.arange(bounds[g], bounds[g + 1]) for g, key in enumerate(groups)},
    )
