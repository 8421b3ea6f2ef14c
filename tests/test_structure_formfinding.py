"""Form-finding of cable nets by the force density method (:mod:`magsail_mj.structure.formfinding`)
and the form-found 100 m four-boom sail (:func:`~magsail_mj.structure.generators.four_boom_sail`,
"Cable net"): the method's equilibrium invariant, its closed forms (a straight chain, the
parabola of an edge cable under a uniform transverse pull), random force densities, and the
shipped sail's modes with every cable in tension."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from magsail_mj.cli import main
from magsail_mj.structure.formfinding import cable_resultants_N, force_density_shape, rest_lengths_m
from magsail_mj.structure.generators import four_boom_sail
from magsail_mj.structure.generators.deployables import rim_sag_m
from magsail_mj.structure.model import Structure

SAIL_CONFIG = "magsail_mj/concepts/structure/configs/sail_detumble.toml"
SAIL_KW = dict(
    side_m=100.0,
    n_segments=4,
    boom_EA_N=3.0e4,
    boom_EI_Nm2=8.0e3,
    boom_GJ_Nm2=8.0e2,
    boom_linear_density_kg_m=0.1,
    membrane_areal_density_kg_m2=0.005,
    reflectivity=(0.88, 0.03, 0.09),
    net_EA_N=1.0e3,
    net_prestrain=1.0e-4,
)
#: equilibrium of a form-found net: the resultant at a free node over its largest cable force
#: (the solve's rounding, ~1e-15, and the rest lengths' round trip T → l0 → T, ~1e-16 / ε0)
EQUILIBRIUM_RTOL = 1e-9


def member_resultants(structure: Structure, members: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) resultant of the axial forces ``N = EA (L / l0 − 1)`` of ``members`` on every node at
    the structure's positions, and (n,) the largest ``|N|`` at each node."""
    m = structure.members
    p = structure.positions_m
    ends = m.nodes[members]
    d = p[ends[:, 1]] - p[ends[:, 0]]
    length = np.linalg.norm(d, axis=1)
    force = m.EA_N[members] * (length / m.rest_length_m[members] - 1.0)
    pull = force[:, None] * d / length[:, None]
    total = np.zeros_like(p)
    np.add.at(total, ends[:, 0], pull)
    np.add.at(total, ends[:, 1], -pull)
    largest = np.zeros(len(p))
    np.maximum.at(largest, ends[:, 0], np.abs(force))
    np.maximum.at(largest, ends[:, 1], np.abs(force))
    return total, largest


@pytest.mark.parametrize("n, ratio", [(2, 0.05), (4, 0.1), (7, 0.03)])
def test_form_found_sail_net_is_in_equilibrium(n: int, ratio: float) -> None:
    """At the form-found shape every free net node is in equilibrium under the cables' tensions
    read back from the structure's members (``EA (L / l0 − 1)``): the resultant is at most
    :data:`EQUILIBRIUM_RTOL` of the node's largest cable force; every cable is in tension, the
    rim sags by ``ratio · side`` (Brent's tolerance 1e-12), every panel keeps its +z normal, and
    the membrane's mass is its areal density times the found area."""
    sail = four_boom_sail(**SAIL_KW | {"n_segments": n}, edge_sag_ratio=ratio)
    cables = sail.members.of_kind("cable")
    assert len(cables) == 2 * n * (3 * n - 1) and len(sail.member_sets["rim_cables"]) == 4 * n
    total, largest = member_resultants(sail, cables)
    free = np.setdiff1d(np.arange(sail.n_nodes), np.arange(1 + 4 * n))
    assert np.all(np.linalg.norm(total[free], axis=1) <= EQUILIBRIUM_RTOL * largest[free])
    p = sail.positions_m
    length = np.linalg.norm(p[sail.members.nodes[cables, 1]] - p[sail.members.nodes[cables, 0]], axis=1)
    assert np.all(length > sail.members.rest_length_m[cables])
    sag = rim_sag_m(p, _rim_by_quadrant(sail, n), p[sail.node_sets["tip"]])
    np.testing.assert_allclose(sag, ratio * SAIL_KW["side_m"], rtol=1e-10)
    tri = sail.panels.triangles()
    assert np.all(np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]])[:, 2] > 0)
    area = sail.panels.areas_m2(p).sum()
    assert area < SAIL_KW["side_m"] ** 2
    booms = 4 * SAIL_KW["boom_linear_density_kg_m"] * SAIL_KW["side_m"] / math.sqrt(2.0)
    assert sail.lumped_masses().sum() == pytest.approx(
        booms + SAIL_KW["membrane_areal_density_kg_m2"] * area, rel=1e-12
    )


def circumradius_m(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    """Radius [m] of the circle through three points (3,): ``|ab| |bc| |ca| / (2 |ab × ac|)``."""
    sides = np.linalg.norm(a - b) * np.linalg.norm(b - c) * np.linalg.norm(c - a)
    return float(sides / (2.0 * np.linalg.norm(np.cross(b - a, c - a))))


def _rim_by_quadrant(sail: Structure, n: int) -> np.ndarray:
    """(4, n + 1) rim nodes of each quadrant from tip ``q + 1`` to tip ``q`` (the generator's
    order): the rim nodes nearest the edge between the two tips."""
    p = sail.positions_m
    tips = sail.node_sets["tip"]
    rows = []
    for q in range(4):
        a, b = tips[q], tips[(q + 1) % 4]
        middle = (p[a] + p[b])[:2]
        out = middle / np.linalg.norm(middle)
        rim = sail.node_sets["rim"]
        rim = rim[(rim != a) & (rim != b)]
        rim = rim[np.argsort(-(p[rim, :2] @ out))][: n - 1]
        chord = (p[a] - p[b])[:2]
        rim = rim[np.argsort(p[rim, :2] @ chord)]
        rows.append(np.concatenate([[b], rim, [a]]))
    return np.stack(rows)


def test_straight_edged_net_keeps_the_grid() -> None:
    """Without ``edge_sag_ratio`` the net keeps the straight grid, every cable prestrained by
    ``ε0`` (``l0 = l / (1 + ε0)``); its rim nodes are then pulled inward, off equilibrium, by
    ``q_i a √2`` each (the two leg cables at ``EA ε0``): the case form-finding removes."""
    n, eps = 4, SAIL_KW["net_prestrain"]
    sail = four_boom_sail(**SAIL_KW)
    cables = sail.members.of_kind("cable")
    p = sail.positions_m
    length = np.linalg.norm(p[sail.members.nodes[cables, 1]] - p[sail.members.nodes[cables, 0]], axis=1)
    np.testing.assert_allclose(sail.members.rest_length_m[cables], length / (1 + eps), rtol=1e-14)
    total, _ = member_resultants(sail, cables)
    rim = _rim_by_quadrant(sail, n)[:, 1:-1].ravel()
    np.testing.assert_allclose(np.linalg.norm(total[rim], axis=1), math.sqrt(2.0) * 1e3 * eps, rtol=1e-9)


def test_uniform_chain_is_a_straight_line_with_uniform_spacing() -> None:
    """A chain of 9 cables between two supports, equal force density on every segment, from a
    scrambled start: every free node's equation is ``x_{k−1} − 2 x_k + x_{k+1} = 0``, so the
    nodes lie evenly spaced on the straight line between the supports (exact; tolerance 1e-12 of
    the span for rounding)."""
    rng = np.random.default_rng(3)
    n = 10
    a, b = np.array([1.0, -2.0, 0.5]), np.array([7.0, 3.0, -1.5])
    start = rng.normal(size=(n, 3)) * 5.0
    start[0], start[-1] = a, b
    chain = np.stack([np.arange(n - 1), np.arange(1, n)], axis=1)
    shape = force_density_shape(start, chain, 0.37, supports=np.array([0, n - 1]))
    expected = a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
    np.testing.assert_allclose(shape, expected, atol=1e-12 * np.linalg.norm(b - a))


def test_edge_cable_under_a_uniform_pull_sags_as_a_parabola() -> None:
    """An edge cable of ``N = 20`` segments over a span ``S = 100 m`` (force density ``q_e`` on
    each) whose ``N − 1`` free nodes are each held by a tie, of force density ``q_t = p h / D``,
    to an anchor ``D = 10⁶ m`` below its start on the chord (``h = S / N``): each tie pulls its
    node by ``p h (1 + y / D)``, the uniform transverse pull ``p`` per length to ``y / D ≤ 10⁻⁵``.
    The horizontal force in every segment is ``H = q_e h`` (2.5 N) and the nodes of a funicular polygon
    under equal loads at equal spacing lie on the parabola ``y = p x (S − x) / (2 H)``, sag ``f
    = p S² / (8 H)`` (10 m), with ``H / R = p`` at the apex (``R = H / p`` its radius of curvature): the
    edge tension over the rim's radius is the interior pull per length. Tolerances: 2·10⁻⁵
    relative (the ties' ``y / D``); the circle through the three middle nodes has the radius of
    the parabola's curvature to ``O((h / R)²)`` = 1.6·10⁻³ here (``R = H / p`` = 125 m), tolerance
    5·10⁻³."""
    N, S, D, p_N_m, q_e = 20, 100.0, 1.0e6, 0.02, 0.5
    h = S / N
    x = h * np.arange(N + 1)
    start = np.column_stack([x, np.zeros(N + 1), np.zeros(N + 1)])
    anchors = np.column_stack([x[1:-1], np.full(N - 1, -D), np.zeros(N - 1)])
    positions = np.concatenate([start, anchors])
    chain = np.stack([np.arange(N), np.arange(1, N + 1)], axis=1)
    ties = np.stack([np.arange(1, N), N + 1 + np.arange(N - 1)], axis=1)
    q = np.concatenate([np.full(N, q_e), np.full(N - 1, p_N_m * h / D)])
    supports = np.concatenate([[0, N], N + 1 + np.arange(N - 1)])
    shape = force_density_shape(positions, np.concatenate([chain, ties]), q, supports=supports)
    H = q_e * h
    parabola = -p_N_m * x * (S - x) / (2.0 * H)  # the pull is towards −y: the cable sags to −y
    np.testing.assert_allclose(shape[: N + 1, 1], parabola, rtol=2e-5, atol=1e-12)
    np.testing.assert_allclose(shape[: N + 1, 0], x, atol=1e-9 * S)  # the ties keep their x
    sag = -shape[N // 2, 1]
    assert sag == pytest.approx(p_N_m * S**2 / (8.0 * H), rel=2e-5)
    a, b, c = shape[N // 2 - 1], shape[N // 2], shape[N // 2 + 1]
    radius = (
        np.linalg.norm(a - b)
        * np.linalg.norm(b - c)
        * np.linalg.norm(c - a)
        / (2.0 * np.linalg.norm(np.cross(b - a, c - a)))
    )
    tension = q_e * np.linalg.norm(c - b)  # T = q L in the segment next to the apex
    assert tension / radius == pytest.approx(p_N_m, rel=5e-3)


def test_sail_rim_tension_over_radius_is_the_interior_pull() -> None:
    """The form-found sail of 16 segments a boom: at the middle of each rim the edge tension over
    the rim's radius (the circle through the middle node and its two rim neighbours) equals the
    interior cables' inward pull at that node per length of rim (their resultant over the mean of
    the two rim segments), to 1 % (the two rim segments differ in tension and length by
    ``O(h / R)``)."""
    n, ratio = 16, 0.1
    sail = four_boom_sail(**SAIL_KW | {"n_segments": n}, edge_sag_ratio=ratio)
    p = sail.positions_m
    m = sail.members
    rim_cables = sail.member_sets["rim_cables"]
    interior = np.setdiff1d(m.of_kind("cable"), rim_cables)
    inward, _ = member_resultants(sail, interior)
    rows = _rim_by_quadrant(sail, n)
    for row in rows:
        a, b, c = p[row[n // 2 - 1]], p[row[n // 2]], p[row[n // 2 + 1]]
        radius = (
            np.linalg.norm(a - b)
            * np.linalg.norm(b - c)
            * np.linalg.norm(c - a)
            / (2.0 * np.linalg.norm(np.cross(b - a, c - a)))
        )
        ends = m.nodes[rim_cables]
        next_to = rim_cables[np.any(ends == row[n // 2], axis=1)]
        length = np.linalg.norm(p[m.nodes[next_to, 1]] - p[m.nodes[next_to, 0]], axis=1)
        tension = m.EA_N[next_to] * (length / m.rest_length_m[next_to] - 1.0)
        pull = np.linalg.norm(inward[row[n // 2]]) / length.mean()
        assert tension.mean() / radius == pytest.approx(pull, rel=1e-2)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31 - 1), n_free=st.integers(1, 12), n_support=st.integers(2, 6))
def test_random_force_densities_give_equilibrium(seed: int, n_free: int, n_support: int) -> None:
    """Random nets on random nodes in a 20 m cube: every free node joined to two different supports
    (so that no free node can collapse onto another and carry no force), then random extra cables
    among all nodes, at random force densities in [10⁻², 10²] N/m: every free node's resultant
    ``Σ q (x_j − x_i)`` is zero to 10⁻⁹ of its largest cable force ``q L`` (the solve's rounding,
    ~10⁻¹⁶ of ``q_max |x|``, over ``q_min`` times a length of metres: ~10⁻¹¹), and the supports
    have not moved."""
    rng = np.random.default_rng(seed)
    n = n_free + n_support
    positions = rng.uniform(-10.0, 10.0, (n, 3))
    free = np.arange(n_support, n)
    pair = np.stack([rng.permutation(n_support)[:2] for _ in free])
    anchors = np.concatenate([np.stack([pair[:, 0], free], 1), np.stack([pair[:, 1], free], 1)])
    extra = rng.integers(0, n, (int(rng.integers(0, 2 * n)), 2))
    cables = np.concatenate([anchors, extra[extra[:, 0] != extra[:, 1]]])
    q = 10.0 ** rng.uniform(-2.0, 2.0, len(cables))
    supports = np.arange(n_support)
    shape = force_density_shape(positions, cables, q, supports=supports)
    np.testing.assert_array_equal(shape[supports], positions[supports])
    total = cable_resultants_N(shape, cables, q)
    force = q * np.linalg.norm(shape[cables[:, 1]] - shape[cables[:, 0]], axis=1)
    largest = np.zeros(n)
    np.maximum.at(largest, cables[:, 0], force)
    np.maximum.at(largest, cables[:, 1], force)
    assert np.all(np.linalg.norm(total[free], axis=1) <= EQUILIBRIUM_RTOL * largest[free])


def test_rest_lengths_carry_the_tension() -> None:
    """``l0 = L / (1 + T / EA)`` gives back ``T = EA (L / l0 − 1)`` (rounding: 10⁻¹⁰ relative at
    ``T / EA`` down to 10⁻⁴)."""
    L, T, EA = np.array([1.0, 17.7, 25.0]), np.array([0.1, 0.37, 3.0]), 1.0e3
    l0 = rest_lengths_m(L, T, EA)
    np.testing.assert_allclose(EA * (L / l0 - 1.0), T, rtol=1e-10)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: force_density_shape(np.zeros((3, 3)), [[0, 1]], -1.0, supports=[0]), "force_density_N_m"),
        (lambda: force_density_shape(np.zeros((3, 3)), [[0, 3]], 1.0, supports=[0]), "cables"),
        (lambda: force_density_shape(np.zeros((3, 3)), [[0, 1]], 1.0, supports=[]), "supports"),
        (
            lambda: force_density_shape(np.eye(3), [[1, 2]], 1.0, supports=[0]),
            r"supports: free nodes \[1, 2\] are joined to no support",
        ),
        (lambda: four_boom_sail(**SAIL_KW | {"n_segments": 1}, edge_sag_ratio=0.1), "edge_sag_ratio: needs n_segments"),
        (lambda: four_boom_sail(**SAIL_KW | {"net_prestrain": 0.0}, edge_sag_ratio=0.1), "net_prestrain: must be > 0"),
        (lambda: four_boom_sail(**SAIL_KW, edge_sag_ratio=-0.1), "edge_sag_ratio: must be finite and > 0"),
        (lambda: four_boom_sail(**SAIL_KW, edge_sag_ratio=0.3), "edge_sag_ratio: no rim force density gives"),
        (
            lambda: four_boom_sail(**{k: v for k, v in SAIL_KW.items() if k != "net_EA_N"}, edge_sag_ratio=0.1),
            "edge_sag_ratio: needs a cable net",
        ),
    ],
)
def test_bad_arguments_name_themselves(call, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        call()


def test_shipped_sail_modes_have_every_cable_in_tension(capsys) -> None:
    """``magsail modes`` of the shipped sail (form-found, rim sag 10 m): the ``prestress`` block
    lists no compressed cable (every cable force > 0 at the linear prestress equilibrium, where
    the straight-edged net left 16 of its 88 cables down to −0.03 N), the booms hold the net in
    compression, and the free sail has its six zero modes."""
    assert main(["modes", SAIL_CONFIG, "--count", "10"]) == 0
    out = json.loads(capsys.readouterr().out)
    prestress = out["prestress"]
    assert prestress["compressed_cables"] == []
    assert prestress["force_N"]["cable"][0] > 0
    assert prestress["force_N"]["beam"][1] < 0
    assert out["rigid_body_modes"] == 6
    assert all(f == 0.0 for f in out["frequencies_Hz"][:6]) and out["frequencies_Hz"][6] > 0
