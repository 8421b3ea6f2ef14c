"""Structure generators: the shipped lattice reproduced exactly, member and node counts against
their formulas, rigidity (exactly the 6 rigid motions of the assembled axial stiffness), and mass,
centre of mass and inertia of the lumped model against closed forms.

Tolerances: mass properties are sums of a few hundred terms, compared to closed forms at 1e-12
relative (round-off ~1e-15 a term). A zero eigenvalue of the axial stiffness is one below 1e-10 of
the largest: the rigid motions come out at ~1e-16 of it and the smallest elastic ones of these
small instances at >= 8e-5 (measured), six orders either side of the threshold.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from magsail_mj.config import load_config
from magsail_mj.concepts.truss_magnetorquer.model import make_truss_model
from magsail_mj.lattice.geometry import STRUT_KINDS, axial_rigidity_from_EI, make_lattice, stiffness_matrix
from magsail_mj.lattice.properties import cantilever_linear, strut_stiffness
from magsail_mj.structure.generators import (
    calibrate_axial_rigidity,
    cantilever,
    circular_plate,
    four_boom_sail,
    hexagonal_plate,
    hoop,
    octet_plate,
    offset_grid_plate,
    square_plate_lattice,
    truss_mast,
)
from magsail_mj.structure.model import MEMBER_KINDS, Members, StructureError

TRUSS_CONFIGS = Path(__file__).resolve().parents[1] / "magsail_mj" / "concepts" / "truss_magnetorquer" / "configs"
MASS_RTOL = 1e-12
ZERO_EIGENVALUE_REL = 1e-10


def zero_modes(structure) -> int:
    """Zero eigenvalues of the assembled axial stiffness (dense: small instances only)."""
    members = structure.members
    K = stiffness_matrix(structure.positions_m, members.nodes, members.stiffness_N_m).toarray()
    eigenvalues = np.linalg.eigvalsh(K)
    return int(np.sum(eigenvalues < ZERO_EIGENVALUE_REL * eigenvalues[-1]))


def components(structure) -> int:
    """Connected components of the graph of members and panel edges."""
    edges = [structure.members.nodes]
    tri = structure.panels.triangles()
    edges += [tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]
    e = np.concatenate(edges)
    n = structure.n_nodes
    return connected_components(coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n)), directed=False)[0]


def assert_mass_properties(structure, mass_kg, com_m, inertia_kg_m2):
    total, com, inertia = structure.mass_properties()
    scale = math.sqrt(np.max(np.abs(inertia_kg_m2)) / mass_kg)
    assert total == pytest.approx(mass_kg, rel=MASS_RTOL)
    np.testing.assert_allclose(com, com_m, rtol=0, atol=MASS_RTOL * scale)
    np.testing.assert_allclose(inertia, inertia_kg_m2, rtol=0, atol=MASS_RTOL * np.max(np.abs(inertia_kg_m2)))


def grid_second_moment(count: int, pitch_m: float) -> float:
    """Σ (x_i − x̄)² of ``count`` points ``pitch_m`` apart: ``pitch² count (count² − 1) / 12``."""
    return pitch_m**2 * count * (count**2 - 1) / 12.0


# --- square plate: the shipped lattice -----------------------------------------------------


@pytest.mark.parametrize("diagonals", ["parity", "X"])
def test_square_plate_is_the_shipped_lattice(diagonals):
    lat = make_lattice(units=3, side_m=7.5, diagonals=diagonals)
    s = square_plate_lattice(units=3, side_m=7.5, diagonals=diagonals, EA_N=2.0e4, total_mass_kg=3.0)
    np.testing.assert_array_equal(s.positions_m, lat.nodes)
    np.testing.assert_array_equal(s.members.nodes, lat.struts)
    np.testing.assert_array_equal(s.members.rest_length_m, lat.rest_length)
    assert np.all(s.members.kind == MEMBER_KINDS.index("strut"))
    for name in STRUT_KINDS:
        np.testing.assert_array_equal(s.member_sets[name], lat.struts_of_kind(name))
    for layer, key in ((0, "bottom_layer"), (1, "top_layer")):
        expected = np.concatenate([lat.struts_of_kind(k, layer=layer) for k in ("x_edge", "y_edge", "xy_diagonal")])
        np.testing.assert_array_equal(s.member_sets[key], np.sort(expected))
    np.testing.assert_array_equal(s.node_sets["top"], lat.top_nodes)
    np.testing.assert_array_equal(s.node_sets["root"], np.flatnonzero(lat.ijk[:, 0] == 0))
    assert len(s.node_sets["rim"]) == 2 * 4 * 3


def test_square_plate_properties_are_the_shipped_truss_models():
    """Masses, spring constants and dashpot of the shipped truss builder for a central-mass case
    (EI calibrated by the cantilever, ζ = 0.1): the same numbers, bit for bit."""
    cfg = load_config(TRUSS_CONFIGS / "dist_vs_central" / "case_a_central_bangbang.toml", ["lattice.units=5"])
    shipped = make_truss_model(cfg)
    s = square_plate_lattice(
        units=cfg.lattice.units,
        side_m=cfg.lattice.side_m,
        EI_Nm2=cfg.stiffness.EI_Nm2,
        calibration=cfg.stiffness.calibration,
        total_mass_kg=cfg.mass.total_kg,
        central_fraction=cfg.mass.central_fraction,
        zeta_strut=cfg.damping.zeta_strut,
    )
    np.testing.assert_array_equal(s.node_mass_kg, shipped.masses)
    np.testing.assert_array_equal(s.members.stiffness_N_m, shipped.k)
    np.testing.assert_array_equal(s.members.damping_Ns_m, np.full(s.n_members, shipped.gamma))


def test_square_plate_mass_properties():
    """Uniform particles on the N × N × 2 grid, cube edge a: I_xx = I_yy = M a² ((N² − 1)/12 + 1/4),
    I_zz = M a² (N² − 1)/6; the central fraction f on the central cube's 8 nodes (±a/2 each way)
    adds f M a²/2 on every axis."""
    units, side, M, f = 5, 10.0, 4.0, 0.25
    a, N = side / units, units + 1
    s = square_plate_lattice(units=units, side_m=side, EA_N=1.0, areal_density_kg_m2=M / side**2, central_fraction=f)
    uniform = (1 - f) * M * a**2
    in_plane = uniform * ((N**2 - 1) / 12 + 0.25) + f * M * a**2 / 2
    normal = uniform * (N**2 - 1) / 6 + f * M * a**2 / 2
    assert_mass_properties(s, M, np.zeros(3), np.diag([in_plane, in_plane, normal]))
    assert zero_modes(square_plate_lattice(units=3, side_m=1.0, EA_N=1.0, total_mass_kg=1.0)) == 6


# --- octet truss and offset grid -----------------------------------------------------------


@pytest.mark.parametrize("units", [1, 2, 3, 4, 5])
def test_octet_plate_counts_and_rigidity(units):
    n, N, a = units, units + 1, 2.0 / units
    s = octet_plate(units=n, side_m=2.0, EA_N=1.0, total_mass_kg=1.0)
    lat = make_lattice(units=n, side_m=2.0)
    even = lat.ijk.sum(axis=1) % 2 == 0
    np.testing.assert_array_equal(s.positions_m, lat.nodes[even])
    assert s.n_nodes == N**2
    assert s.n_members == 2 * n**2 + 2 * n * N + 4 * (N - 2)
    chords = s.member_sets["rim_chords"]
    assert len(chords) == 4 * (N - 2)
    np.testing.assert_allclose(np.delete(s.members.rest_length_m, chords), a * math.sqrt(2), rtol=1e-14)
    np.testing.assert_allclose(s.members.rest_length_m[chords], 2 * a, rtol=1e-14)
    top = s.member_sets["top_chords"]
    assert len(top) == n**2 and np.all(np.isin(s.members.nodes[top], s.node_sets["top"]))
    assert components(s) == 1
    assert zero_modes(s) == 6
    # without the rim chords the twist mechanism is left (a lone tetrahedron has none)
    assert zero_modes(octet_plate(units=n, side_m=2.0, EA_N=1.0, total_mass_kg=1.0, bracing="none")) == (
        6 if n == 1 else 7
    )


@pytest.mark.parametrize("units", [4, 5])
def test_octet_plate_mass_properties(units):
    """One even node per lattice column (z = ±a/2): Σx² = N Σ_i (x_i)², and the layers hold
    ⌈N²/2⌉ bottom and ⌊N²/2⌋ top nodes, so z̄ = −(a/2)(N² mod 2)/N²."""
    N, side, M = units + 1, 3.0, 2.0
    a = side / units
    s = octet_plate(units=units, side_m=side, EA_N=1.0, total_mass_kg=M)
    m = M / N**2
    z_com = -(a / 2) * (N**2 % 2) / N**2
    sum_x2 = N * grid_second_moment(N, a)
    sum_z2 = M * (a / 2) ** 2 - M * z_com**2
    inertia = np.diag([m * sum_x2 + sum_z2, m * sum_x2 + sum_z2, 2 * m * sum_x2])
    assert_mass_properties(s, M, np.array([0, 0, z_com]), inertia)


@pytest.mark.parametrize("cells", [1, 2, 3, 4, 5])
def test_offset_grid_counts_and_rigidity(cells):
    c, a = cells, 1.5 / cells
    s = offset_grid_plate(cells=c, side_m=1.5, EA_N=1.0, total_mass_kg=1.0)
    braces = 2 if c == 1 else 4
    assert s.n_nodes == (c + 1) ** 2 + c**2
    assert s.n_members == 8 * c**2 + braces
    assert len(s.member_sets["top_chords"]) == 2 * c * (c + 1)
    assert len(s.member_sets["bottom_chords"]) == 2 * c * (c - 1)
    assert len(s.member_sets["webs"]) == 4 * c**2
    bracing = s.member_sets["bracing"]
    assert len(bracing) == braces
    np.testing.assert_allclose(np.delete(s.members.rest_length_m, bracing), a, rtol=1e-14)  # webs = chords
    np.testing.assert_allclose(s.members.rest_length_m[bracing], a * math.sqrt(2), rtol=1e-14)
    assert components(s) == 1
    assert zero_modes(s) == 6
    assert zero_modes(offset_grid_plate(cells=c, side_m=1.5, EA_N=1.0, total_mass_kg=1.0, bracing="none")) == 7


def test_offset_grid_mass_properties():
    """Top grid of (c+1)² nodes at +h/2, bottom grid of c² at −h/2, uniform mass m."""
    c, side, depth, M = 4, 2.0, 0.3, 5.0
    a = side / c
    s = offset_grid_plate(cells=c, side_m=side, depth_m=depth, EA_N=1.0, total_mass_kg=M)
    n_top, n_bottom = (c + 1) ** 2, c**2
    m = M / (n_top + n_bottom)
    z_com = m * (n_top - n_bottom) * depth / 2 / M
    sum_x2 = (c + 1) * grid_second_moment(c + 1, a) + c * grid_second_moment(c, a)
    sum_z2 = m * (n_top * (depth / 2 - z_com) ** 2 + n_bottom * (depth / 2 + z_com) ** 2)
    inertia = np.diag([m * sum_x2 + sum_z2, m * sum_x2 + sum_z2, 2 * m * sum_x2])
    assert_mass_properties(s, M, np.array([0, 0, z_com]), inertia)


# --- cantilever calibration ----------------------------------------------------------------


@pytest.mark.parametrize(
    "factory",
    [
        functools.partial(octet_plate, units=4, side_m=10.0, total_mass_kg=1.0),
        functools.partial(offset_grid_plate, cells=4, side_m=10.0, total_mass_kg=1.0),
    ],
    ids=["octet", "offset_grid"],
)
def test_calibrated_plate_has_the_cantilever_EI(factory):
    """Clamped root edge, tip load P: the calibrated plate's tip deflection is P L³ / (3 EI) to
    1e-9 (the stiffness is linear in EA; what is left is the sparse solves' round-off)."""
    EI, P = 350.0, 2.5
    s = factory(EI_Nm2=EI)
    result = cantilever(s, load_N=P)
    p = s.positions_m
    L = p[s.node_sets["tip"], 0].mean() - p[s.node_sets["root"], 0].mean()
    assert result.tip_deflection_m == pytest.approx(P * L**3 / (3 * EI), rel=1e-9)
    assert s.members.EA_N[0] == pytest.approx(calibrate_axial_rigidity(factory, EI), rel=1e-12)


def test_calibration_is_the_shipped_cantilever_rule():
    """On the square lattice the generic calibration gives the shipped cantilever-calibrated EA,
    and the cantilever deflection is the shipped solver's."""
    units, side, EI = 4, 20.0, 1000.0
    factory = functools.partial(square_plate_lattice, units=units, side_m=side, total_mass_kg=1.0)
    shipped_EA = square_plate_lattice(units=units, side_m=side, EI_Nm2=EI, total_mass_kg=1.0).members.EA_N[0]
    assert calibrate_axial_rigidity(factory, EI) == pytest.approx(shipped_EA, rel=1e-9)
    lat = make_lattice(units=units, side_m=side)
    k, c = strut_stiffness(lat, EI_Nm2=EI)
    assert shipped_EA == c * axial_rigidity_from_EI(EI, nodes_per_side=units + 1, cube_edge_m=side / units)
    expected = cantilever_linear(lat, k, load_N=3.0).tip_deflection_m
    assert cantilever(factory(EA_N=shipped_EA), load_N=3.0).tip_deflection_m == pytest.approx(expected, rel=1e-12)


def test_calibration_refusals():
    with pytest.raises(StructureError, match="proportional to the EA_N argument"):
        calibrate_axial_rigidity(
            lambda *, EA_N: square_plate_lattice(units=2, side_m=1.0, EA_N=EA_N**0.5, total_mass_kg=1.0), 1.0
        )
    with pytest.raises(StructureError, match="node 4 is in both node sets 'root' and 'tip'"):
        offset_grid_plate(cells=1, side_m=1.0, EI_Nm2=1.0, total_mass_kg=1.0)
    with pytest.raises(StructureError, match="takes struts only"):
        cantilever(hoop(radius_m=1.0, n_segments=6, EA_N=1.0, EI_Nm2=1.0, GJ_Nm2=1.0, linear_density_kg_m=1.0))
    plate = square_plate_lattice(units=1, side_m=1.0, EA_N=1.0, total_mass_kg=1.0)
    tip_verticals = [m for m in plate.member_sets["vertical"] if set(plate.members.nodes[m]) <= {1, 5}]
    keep = np.setdiff1d(np.arange(plate.n_members), tip_verticals + list(plate.member_sets["xz_diagonal"]))
    loose = dataclasses.replace(
        plate, members=Members(**{f: getattr(plate.members, f)[keep] for f in Members.__dataclass_fields__})
    )
    with pytest.raises(StructureError, match="is a mechanism"):
        cantilever(loose)
    with pytest.raises(StructureError, match="no node set 'edge'"):
        cantilever(octet_plate(units=2, side_m=1.0, EA_N=1.0, total_mass_kg=1.0), root="edge")


# --- disc and hexagon ------------------------------------------------------------------------


def kept_cells(units: int, width_m: float, inside) -> np.ndarray:
    centres = (np.arange(units) + 0.5) * width_m / units - width_m / 2
    return inside(centres[None, :], centres[:, None])


def disc(radius):
    return lambda x, y: x**2 + y**2 <= radius**2


def hexagon(radius):
    r3 = math.sqrt(3)
    return lambda x, y: (np.abs(y) <= r3 * radius / 2) & (r3 * np.abs(x) + np.abs(y) <= r3 * radius)


CLIPPED = [
    ("disc", lambda u: circular_plate(diameter_m=2.0, units_across=u, EA_N=1.0, total_mass_kg=3.0), disc(1.0)),
    (
        "hexagon",
        lambda u: hexagonal_plate(across_corners_m=2.0, units_across=u, EA_N=1.0, total_mass_kg=3.0),
        hexagon(1.0),
    ),
]


@pytest.mark.parametrize("shape, make, inside", CLIPPED, ids=[c[0] for c in CLIPPED])
@pytest.mark.parametrize("units", [3, 4, 5, 6])
def test_clipped_plate_counts_rigidity_and_mass(shape, make, inside, units):
    """From the mask of the cubes whose centre is inside (built here): node columns P = corners
    of kept cubes, x-segments E_x and y-segments E_y on kept cubes' sides; members
    3 (E_x + E_y) + P + 2 C (edges in two layers, verticals, xz/yz face diagonals, two xy
    diagonals a cube). Mass M uniform over the 2P nodes at z = ±a/2."""
    s = make(units)
    a = 2.0 / units
    cells = kept_cells(units, 2.0, inside)  # [cj, ci]
    padded = np.pad(cells, 1)
    columns = padded[:-1, :-1] | padded[:-1, 1:] | padded[1:, :-1] | padded[1:, 1:]  # [j, i]
    e_x = np.count_nonzero(padded[:-1, 1:-1] | padded[1:, 1:-1])  # segments along x at grid line j
    e_y = np.count_nonzero(padded[1:-1, :-1] | padded[1:-1, 1:])
    P, C = np.count_nonzero(columns), np.count_nonzero(cells)
    assert s.n_nodes == 2 * P
    assert s.n_members == 3 * (e_x + e_y) + P + 2 * C
    assert components(s) == 1
    assert zero_modes(s) == 6
    j, i = np.nonzero(columns)
    x, y = i * a - 1.0, j * a - 1.0
    m = 3.0 / (2 * P)
    ixx, iyy = 2 * m * np.sum(y**2) + 3.0 * a**2 / 4, 2 * m * np.sum(x**2) + 3.0 * a**2 / 4
    assert_mass_properties(s, 3.0, np.zeros(3), np.diag([ixx, iyy, 2 * m * np.sum(x**2 + y**2)]))


def test_clipped_plates_approach_the_continuum():
    """Polar moment against the continuum disc (M R²/2) and hexagon (5 M R²/12): the staircase
    edge and the corner nodes shift the radius of gyration by O(a), so the tolerance is 3 a/R
    (measured 1.4 a/R and 1.2 a/R at 40 cubes across)."""
    disc_plate = circular_plate(diameter_m=2.0, units_across=40, EA_N=1.0, total_mass_kg=1.0)
    hex_plate = hexagonal_plate(across_corners_m=2.0, units_across=40, EA_N=1.0, total_mass_kg=1.0)
    assert disc_plate.mass_properties()[2][2, 2] == pytest.approx(0.5, rel=3 * 0.05)
    assert hex_plate.mass_properties()[2][2, 2] == pytest.approx(5 / 12, rel=3 * 0.05)
    area = np.count_nonzero(kept_cells(40, 2.0, disc(1.0))) * 0.05**2
    assert circular_plate(diameter_m=2.0, units_across=40, EA_N=1.0, areal_density_kg_m2=2.0).mass_properties()[
        0
    ] == pytest.approx(2.0 * area, rel=MASS_RTOL)


# --- deployables -----------------------------------------------------------------------------


@pytest.mark.parametrize("n", [1, 2, 5])
def test_four_boom_sail(n):
    """Lumped booms (λ h at inner nodes, λ h/2 at tips and 4 × λ h/2 at the hub): each boom's
    Σ m r² = λ L³ (1 + 1/(2n²)) / 3. Lumped membrane: each of the 4n² congruent right triangles
    (legs l = L/n) puts A/3 at its corners, which exceeds the continuum's second moment by
    (A/4) Σ dᵢdᵢᵀ (dᵢ corner − centroid), so I_zz = σ s⁴ (1 + 1/n²)/6. Booms at 45° and the
    membrane's 4-fold symmetry: I_xx = I_yy = I_zz / 2. Hub: a rigid part at the origin."""
    s_m, lam, sigma, hub_kg, hub_I = 20.0, 0.05, 0.01, 3.0, np.array([0.4, 0.5, 0.6])
    sail = four_boom_sail(
        side_m=s_m,
        n_segments=n,
        boom_EA_N=1e6,
        boom_EI_Nm2=(50.0, 80.0),
        boom_GJ_Nm2=30.0,
        boom_linear_density_kg_m=lam,
        membrane_areal_density_kg_m2=sigma,
        reflectivity=(0.85, 0.05, 0.1),
        hub_mass_kg=hub_kg,
        hub_inertia_kg_m2=hub_I,
    )
    L = s_m / math.sqrt(2)
    assert (sail.n_nodes, sail.n_members, len(sail.panels)) == (2 * n**2 + 2 * n + 1, 4 * n, 4 * n**2)
    assert np.all(sail.members.kind == MEMBER_KINDS.index("beam"))
    np.testing.assert_array_equal(sail.members.EI_Nm2, np.tile([50.0, 80.0], (4 * n, 1)))
    np.testing.assert_allclose(sail.members.rest_length_m, L / n, rtol=1e-14)
    p, tri = sail.positions_m, sail.panels.triangles()
    normal_z = np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]])[:, 2]
    np.testing.assert_allclose(normal_z, (L / n) ** 2, rtol=1e-12)  # counter-clockwise about +z, congruent
    assert sail.panels.areas_m2(p).sum() == pytest.approx(s_m**2, rel=1e-13)
    np.testing.assert_allclose(np.abs(p[sail.node_sets["tip"], :2]), s_m / 2, rtol=1e-14)
    assert len(sail.node_sets["rim"]) == 4 * n and len(sail.node_sets["membrane"]) == sail.n_nodes
    assert components(sail) == 1
    booms_zz = 4 * lam * L**3 * (1 + 1 / (2 * n**2)) / 3
    membrane_zz = sigma * s_m**4 * (1 + 1 / n**2) / 6
    zz = booms_zz + membrane_zz
    mass = hub_kg + 4 * lam * L + sigma * s_m**2
    assert_mass_properties(sail, mass, np.zeros(3), np.diag([zz / 2, zz / 2, zz]) + np.diag(hub_I))


@pytest.mark.parametrize("n", [3, 4, 12])
def test_hoop(n):
    """n equal chords 2 R sin(π/n): M = 2 n λ R sin(π/n); every node at radius R: I_zz = M R²,
    I_xx = I_yy = M R²/2 (Σ cos² = n/2 for n ≥ 3)."""
    R, lam = 7.0, 0.2
    ring = hoop(radius_m=R, n_segments=n, EA_N=1e5, EI_Nm2=10.0, GJ_Nm2=5.0, linear_density_kg_m=lam)
    M = 2 * n * lam * R * math.sin(math.pi / n)
    assert (ring.n_nodes, ring.n_members) == (n, n)
    np.testing.assert_allclose(np.linalg.norm(ring.positions_m, axis=1), R, rtol=1e-14)
    assert components(ring) == 1
    assert_mass_properties(ring, M, np.zeros(3), np.diag([M * R**2 / 2, M * R**2 / 2, M * R**2]))


@pytest.mark.parametrize("n_longerons", [3, 4])
@pytest.mark.parametrize("n_bays", [1, 2, 5])
def test_truss_mast(n_longerons, n_bays):
    """Station masses M_s = n_l λ (h e_s + w) + n_l λ d a_s / 2 (+ λ w √2 for 4 longerons), e_s = ½
    at the end stations else 1, a_s = 1 at the ends else 2, d = √(w² + h²). All nodes at radius
    ρ from the axis with each station's mass balanced: I_zz = M ρ², I_xx = I_yy = M ρ²/2 +
    Σ M_s (z_s − L/2)²; a square station's diagonal (λ w √2 on vertices 0, 2 or 1, 3 alternately)
    leaves I_xy = −λ w √2 ρ²/2 when the number of stations is odd."""
    L, w, lam, nl, b = 6.0, 0.4, 0.03, n_longerons, n_bays
    mast = truss_mast(length_m=L, n_bays=b, width_m=w, n_longerons=nl, EA_N=1e6, linear_density_kg_m=lam)
    h, rho = L / b, w / (2 * math.sin(math.pi / nl))
    d = math.hypot(w, h)
    assert mast.n_nodes == nl * (b + 1)
    assert mast.n_members == nl * b + nl * (b + 1) + nl * b + (b + 1 if nl == 4 else 0)
    assert zero_modes(mast) == 6
    ends = np.isin(np.arange(b + 1), [0, b])
    station = nl * lam * (h * np.where(ends, 0.5, 1.0) + w) + nl * lam * d * np.where(ends, 1, 2) / 2
    station += lam * w * math.sqrt(2) if nl == 4 else 0.0
    M = station.sum()
    z = np.arange(b + 1) * h
    ixx = M * rho**2 / 2 + np.sum(station * (z - L / 2) ** 2)
    inertia = np.diag([ixx, ixx, M * rho**2])
    if nl == 4 and b % 2 == 0:
        inertia[0, 1] = inertia[1, 0] = -lam * w * math.sqrt(2) * rho**2 / 2
    assert_mass_properties(mast, M, np.array([0, 0, L / 2]), inertia)


# --- argument checks -------------------------------------------------------------------------


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: square_plate_lattice(units=0, side_m=1.0, EA_N=1.0, total_mass_kg=1.0), "units: must be an integer"),
        (lambda: square_plate_lattice(units=2, side_m=1.0, total_mass_kg=1.0), "EA_N, EI_Nm2: give exactly one"),
        (lambda: octet_plate(units=2, side_m=-1.0, EA_N=1.0, total_mass_kg=1.0), "side_m: must be finite and > 0"),
        (lambda: octet_plate(units=2, side_m=1.0, EA_N=1.0), "total_mass_kg, areal_density_kg_m2: give exactly one"),
        (lambda: octet_plate(units=2, side_m=1.0, EA_N=1.0, total_mass_kg=1.0, bracing="X"), "bracing: must be"),
        (
            lambda: offset_grid_plate(cells=2, side_m=1.0, EA_N=1.0, total_mass_kg=1.0, damping_Ns_m=1, zeta_strut=0.1),
            "damping_Ns_m, zeta_strut: give at most one",
        ),
        (lambda: circular_plate(diameter_m=float("nan"), units_across=3, EA_N=1.0, total_mass_kg=1.0), "diameter_m"),
        (lambda: hoop(radius_m=1.0, n_segments=2, EA_N=1, EI_Nm2=1, GJ_Nm2=1, linear_density_kg_m=1), "n_segments"),
        (
            lambda: truss_mast(length_m=1.0, n_bays=2, width_m=0.1, n_longerons=5, EA_N=1, linear_density_kg_m=1),
            "n_longerons",
        ),
        (
            lambda: four_boom_sail(
                side_m=1.0,
                n_segments=2,
                boom_EA_N=1.0,
                boom_EI_Nm2=1.0,
                boom_GJ_Nm2=1.0,
                boom_linear_density_kg_m=0.1,
                membrane_areal_density_kg_m2=0.01,
                reflectivity=(0.9, 0.0, 0.0),
            ),
            r"reflectivity: must be three fractions",
        ),
    ],
)
def test_argument_errors_name_the_argument(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_damping_from_zeta_is_the_shipped_rule():
    """c = 2 ζ √(k m_p / 2), k = EA / l of the shortest strut, m_p the particle mass."""
    s = offset_grid_plate(cells=3, side_m=3.0, EA_N=500.0, total_mass_kg=2.0, zeta_strut=0.05)
    k = 500.0 / s.members.rest_length_m.min()
    expected = 2 * 0.05 * math.sqrt(k * (2.0 / s.n_nodes) / 2)
    np.testing.assert_allclose(s.members.damping_Ns_m, expected, rtol=1e-14)
