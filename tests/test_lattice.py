"""Lattice geometry, stiffness, calibration, damping and masses (Robb et al. 2022a,
Sec. 2.1–2.2 and Eq. 8, with our strut layout, damping and cantilever calibration).

Pure NumPy/SciPy: no MuJoCo here (the MuJoCo physics tests are in test_physics_lattice.py).
Tolerances: exact integer counts; geometric quantities to 1e-12 relative (a few roundings of
``i·a − d/2``); hand-computed reference values to half a unit in their last printed digit (that
is all the precision they carry).
"""

from __future__ import annotations

import itertools
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from magsail_mj.config import load_config
from magsail_mj.estimation.attitude import particle_inertia
from magsail_mj.lattice.geometry import (
    STRUT_KINDS,
    axial_rigidity_from_EI,
    make_lattice,
    node_index,
    stiffness_matrix,
)
from magsail_mj.lattice.properties import (
    calibration_factor,
    cantilever_linear,
    central_cube_nodes,
    node_masses,
    strut_damping,
    strut_stiffness,
)
from magsail_mj.concepts.truss_magnetorquer.model import make_truss_model

REPO_MODELS = Path(__file__).resolve().parents[1] / "magsail_mj" / "concepts" / "truss_magnetorquer" / "configs"


def close_to_printed(value: float, printed: str) -> bool:
    """``value`` rounds to the printed reference decimal (within half a unit of its last digit)."""
    half_unit = 0.5 * 10.0 ** Decimal(printed).as_tuple().exponent
    return abs(value - float(printed)) <= half_unit * (1 + 1e-9)


# ------------------------------------------------------------------------------ counts, lengths


def test_counts_parity_units_19():
    """800 nodes (one face diagonal per square face); 760 + 760 + 400 + (361 + 361) + (380 + 380) = 3402 struts."""
    lat = make_lattice(units=19, side_m=100.0)
    assert lat.n_nodes == 800 and lat.nodes_per_side == 20
    assert lat.n_struts == 3402
    counts = {name: int(np.sum(lat.kind == i)) for i, name in enumerate(STRUT_KINDS)}
    assert counts == {
        "x_edge": 760,
        "y_edge": 760,
        "vertical": 400,
        "xy_diagonal": 722,
        "xz_diagonal": 380,
        "yz_diagonal": 380,
    }
    for layer in (0, 1):  # 361 top and 361 bottom face diagonals, 380 actuator struts per family
        assert lat.struts_of_kind("xy_diagonal", layer=layer).size == 361
        assert lat.struts_of_kind("y_edge", layer=layer).size == 380
        assert lat.struts_of_kind("x_edge", layer=layer).size == 380


def test_counts_x_units_19():
    """The X variant: both diagonals on every face, 4884 struts for N = 20."""
    lat = make_lattice(units=19, side_m=100.0, diagonals="X")
    assert lat.n_nodes == 800 and lat.n_struts == 4884
    assert int(np.sum(lat.kind >= STRUT_KINDS.index("xy_diagonal"))) == 2 * (722 + 760)


@pytest.mark.parametrize("diagonals", ["parity", "X"])
@pytest.mark.parametrize("units,side", [(19, 100.0), (19, 75.0), (4, 3.0), (1, 1.0)])
def test_strut_lengths_are_a_or_a_sqrt2(units, side, diagonals):
    """Every strut is a cube edge (a) or a face diagonal (a√2); rest length = undeformed length."""
    lat = make_lattice(units=units, side_m=side, diagonals=diagonals)
    a = side / units
    length = np.linalg.norm(lat.nodes[lat.struts[:, 1]] - lat.nodes[lat.struts[:, 0]], axis=1)
    is_edge = lat.kind <= STRUT_KINDS.index("vertical")
    np.testing.assert_allclose(length[is_edge], a, rtol=1e-12)
    np.testing.assert_allclose(length[~is_edge], a * np.sqrt(2.0), rtol=1e-12)
    np.testing.assert_allclose(lat.rest_length, length, rtol=0, atol=0)


def test_reference_coordinates_and_index():
    """Node layout: p_ijk = (i a − d/2, j a − d/2, (k − ½) a), flat index k N² + j N + i."""
    lat = make_lattice(units=19, side_m=75.0)
    a, N = 75.0 / 19, 20
    for i, j, k in [(0, 0, 0), (19, 0, 1), (3, 17, 1), (19, 19, 0)]:
        n = int(node_index(i, j, k, N))
        assert tuple(lat.ijk[n]) == (i, j, k)
        np.testing.assert_allclose(lat.nodes[n], [i * a - 37.5, j * a - 37.5, (k - 0.5) * a], rtol=1e-14, atol=1e-12)
    np.testing.assert_allclose(lat.nodes.mean(axis=0), 0.0, atol=1e-12)


# ------------------------------------------------------------------------------ diagonals per face


def _faces(units: int) -> list[tuple[int, int, int, int]]:
    """Every square face of every cube as (c00, c10, c01, c11) node indices, each face once.

    Enumerated from the cubes' corners (independently of the lattice builder): a face is four
    corners sharing one coordinate within a cube; faces shared by two cubes are de-duplicated.
    """
    N = units + 1
    faces = {}
    for i, j in itertools.product(range(units), range(units)):
        corners = [(i + di, j + dj, dk) for dk in (0, 1) for dj in (0, 1) for di in (0, 1)]
        for axis in range(3):
            for side in (0, 1):
                quad = [c for c in corners if c[axis] - (i, j, 0)[axis] == side]
                key = frozenset(quad)
                if key not in faces:
                    faces[key] = quad
    out = []
    for quad in faces.values():
        # order the corners so that c00-c11 and c10-c01 are the two diagonals
        c00 = quad[0]
        far = max(quad, key=lambda c: sum(abs(np.subtract(c, c00))))
        rest = [c for c in quad if c not in (c00, far)]
        out.append(tuple(int(node_index(*c, N)) for c in (c00, rest[0], rest[1], far)))
    return out


@pytest.mark.parametrize("units", [1, 2, 5, 19])
def test_parity_rule_one_diagonal_per_face(units):
    """Our octahedral–tetrahedral truss: every square face gets exactly one diagonal, joining its
    two even-(i+j+k) corners."""
    lat = make_lattice(units=units, side_m=float(units))
    pairs = {frozenset(p) for p in lat.struts.tolist()}
    assert len(pairs) == lat.n_struts, "a strut is duplicated"
    faces = _faces(units)
    n = units
    assert len(faces) == 2 * n * n + 2 * n * (n + 1)  # top/bottom faces + vertical faces
    parity = lat.ijk.sum(axis=1) % 2
    diag_pairs = {frozenset(p) for p in lat.struts[lat.kind >= STRUT_KINDS.index("xy_diagonal")].tolist()}
    used = set()
    for c00, c10, c01, c11 in faces:
        present = [d for d in (frozenset((c00, c11)), frozenset((c10, c01))) if d in diag_pairs]
        assert len(present) == 1
        (p, q) = tuple(present[0])
        assert parity[p] == 0 and parity[q] == 0
        used.add(present[0])
    assert used == diag_pairs, "a diagonal lies on no face"


@pytest.mark.parametrize("units", [1, 3, 19])
def test_x_pattern_two_diagonals_per_face(units):
    lat = make_lattice(units=units, side_m=float(units), diagonals="X")
    diag_pairs = {frozenset(p) for p in lat.struts[lat.kind >= STRUT_KINDS.index("xy_diagonal")].tolist()}
    faces = _faces(units)
    assert len(diag_pairs) == 2 * len(faces)
    for c00, c10, c01, c11 in faces:
        assert frozenset((c00, c11)) in diag_pairs and frozenset((c10, c01)) in diag_pairs


# ------------------------------------------------------------------------------ rigidity


def _rigid_modes(x: np.ndarray) -> np.ndarray:
    """(3n, 6) translations and infinitesimal rotations of the point set ``x``."""
    n = x.shape[0]
    T = np.zeros((3 * n, 6))
    for c in range(3):
        T[c::3, c] = 1.0
    for c, axis in enumerate(np.eye(3)):
        T[:, 3 + c] = np.cross(axis, x - x.mean(axis=0)).ravel()
    return T


@settings(max_examples=30, deadline=None)
@given(
    units=st.integers(1, 5),
    diagonals=st.sampled_from(["parity", "X"]),
    side=st.floats(0.5, 200.0),
    EI=st.floats(1.0, 1e4),
)
def test_free_free_stiffness_has_exactly_six_zero_modes(units, diagonals, side, EI):
    """The lattice is rigid: the free-free K (dense) has exactly 6 zero eigenvalues.

    Zero means below 1e-10 λ_max (measured: the 6 rigid modes come out at ≤ 1e-15 λ_max, the
    rounding of the dense eigensolver); the 7th eigenvalue must be clearly positive, above
    1e-4 λ_max (measured: ≥ 2.8e-3 λ_max, the 5 × 5 parity lattice being the softest), and the
    6 rigid-body modes must lie in the null space.
    """
    lat = make_lattice(units=units, side_m=side, diagonals=diagonals)
    k, _ = strut_stiffness(lat, EI_Nm2=EI, calibration="formula")
    K = stiffness_matrix(lat.nodes, lat.struts, k).toarray()
    np.testing.assert_allclose(K, K.T, rtol=0, atol=1e-14 * np.abs(K).max())
    lam = np.linalg.eigvalsh(K)
    lam_max = lam[-1]
    assert np.sum(np.abs(lam) < 1e-10 * lam_max) == 6
    assert lam[6] > 1e-4 * lam_max
    T = _rigid_modes(lat.nodes)
    assert np.abs(K @ T).max() < 1e-12 * lam_max * np.abs(T).max()


def test_dropping_a_face_diagonal_makes_a_mechanism():
    """The zero-mode count can fail. One parity cube has 12 edges + 6 diagonals = 18 = 3·8 − 6
    struts (statically determinate); without one face diagonal it has a 7th zero mode."""
    lat = make_lattice(units=1, side_m=2.0)
    assert lat.n_struts == 18
    k, _ = strut_stiffness(lat, EI_Nm2=1.0)
    drop = lat.struts_of_kind("xy_diagonal", layer=0)[0]
    keep = np.setdiff1d(np.arange(lat.n_struts), [drop])
    lam = np.linalg.eigvalsh(stiffness_matrix(lat.nodes, lat.struts[keep], k[keep]).toarray())
    assert np.sum(np.abs(lam) < 1e-10 * lam[-1]) == 7


# ------------------------------------------------------------------------------ spring constants


# Hand-computed table (Eq. 8): case, d, EI, EA, k edge, k face diagonal (formula stiffness, printed digits).
K_TABLE = [
    ("A", 100.0, 1e3, "3.610", "0.6859", "0.4850"),
    ("B", 100.0, 1e2, "0.3610", "0.06859", "0.04850"),
    ("C", 100.0, 1e1, "0.03610", "0.006859", "0.004850"),
    ("orbital", 75.0, 1e3, "6.418", "1.6258", "1.1496"),
]


@pytest.mark.parametrize("case,d,EI,EA,k_edge,k_diag", K_TABLE)
def test_spring_constants_of_spec_table(case, d, EI, EA, k_edge, k_diag):
    """Robb et al. 2022a, Eq. 8: EA = 2 EI / (N a²), k_s = EA / l0_s, formula mode (before calibration)."""
    lat = make_lattice(units=19, side_m=d)
    k, c = strut_stiffness(lat, EI_Nm2=EI, calibration="formula")
    assert c == 1.0
    ea = axial_rigidity_from_EI(EI, nodes_per_side=20, cube_edge_m=d / 19)
    assert close_to_printed(ea, EA)
    edge = lat.kind <= STRUT_KINDS.index("vertical")
    assert close_to_printed(k[edge][0], k_edge) and close_to_printed(k[~edge][0], k_diag)
    np.testing.assert_allclose(k * lat.rest_length, ea, rtol=1e-12)  # same EA for every strut


# Our damping (the paper gives none): γ for ζ_s = 0.1 with formula stiffness (printed to 2 significant figures).
GAMMA_TABLE = [
    (100.0, 1e3, 100.0, "0.041"),
    (100.0, 1e2, 100.0, "0.013"),
    (100.0, 1e1, 100.0, "0.0041"),
    (75.0, 1e3, 200.0, "0.090"),
]


@pytest.mark.parametrize("d,EI,M,gamma", GAMMA_TABLE)
def test_strut_damping_of_spec(d, EI, M, gamma):
    """Our damping: γ = 2 ζ √(k_edge m_p / 2); calibrated γ smaller by √(EI/EI_eff)."""
    lat = make_lattice(units=19, side_m=d)
    m_p = M / 800
    k_f, _ = strut_stiffness(lat, EI_Nm2=EI, calibration="formula")
    g_f = strut_damping(lat, k_f, zeta=0.1, particle_mass_kg=m_p)
    assert close_to_printed(g_f, gamma)
    k_c, c = strut_stiffness(lat, EI_Nm2=EI, calibration="cantilever")
    g_c = strut_damping(lat, k_c, zeta=0.1, particle_mass_kg=m_p)
    np.testing.assert_allclose(g_c / g_f, np.sqrt(c), rtol=1e-12)
    assert strut_damping(lat, k_c, zeta=0.0, particle_mass_kg=m_p) == 0.0


def test_scenario_damping_uses_distributed_particle_mass():
    """The central run of a case gets the same γ as the distributed run."""
    dist = make_truss_model(load_config(REPO_MODELS / "dist_vs_central/case_a_distributed_bangbang.toml"))
    cent = make_truss_model(load_config(REPO_MODELS / "dist_vs_central/case_a_central_bangbang.toml"))
    assert cent.gamma == dist.gamma
    k_f = dist.k / dist.calibration_factor
    expected = 2 * 0.1 * np.sqrt(k_f.max() * dist.calibration_factor * 0.125 / 2)
    np.testing.assert_allclose(dist.gamma, expected, rtol=1e-12)


# ------------------------------------------------------------------------------ calibration


@pytest.mark.parametrize("diagonals,printed", [("parity", "1.27"), ("X", "1.55")])
def test_formula_stiffness_ratio_at_N20(diagonals, printed):
    """Formula stiffness against the cantilever: EI_eff/EI ≈ 1.27 (parity) and ≈ 1.55 (X) at N = 20 with the formula EA.

    Tolerance: half a unit of the last printed digit (±0.005). The ratio depends only on
    N and the pattern: for d = 100 m / 75 m and EI = 10…1000 it agrees to 1e-9 (linear solves).
    """
    ratios = []
    for d, EI in [(100.0, 1e3), (100.0, 1e1), (75.0, 1e3)]:
        lat = make_lattice(units=19, side_m=d, diagonals=diagonals)
        k, _ = strut_stiffness(lat, EI_Nm2=EI, calibration="formula")
        P = 1e-3 * EI / 1e3
        res = cantilever_linear(lat, k, load_N=P)
        ratios.append(res.EI_eff_Nm2 / EI)
    assert close_to_printed(ratios[0], printed)
    np.testing.assert_allclose(ratios, ratios[0], rtol=1e-9)
    lat = make_lattice(units=19, side_m=100.0, diagonals=diagonals)
    np.testing.assert_allclose(calibration_factor(lat, "cantilever"), 1.0 / ratios[0], rtol=1e-9)
    assert calibration_factor(lat, "formula") == 1.0


# ------------------------------------------------------------------------------ masses


def test_distributed_and_orbital_masses():
    """Uniform masses: 100 kg over 800 nodes = 0.125 kg each; 200 kg = 0.25 kg each."""
    lat = make_lattice(units=19, side_m=100.0)
    m = node_masses(lat, total_kg=100.0)
    np.testing.assert_allclose(m, 0.125, rtol=1e-15)
    m75 = node_masses(make_lattice(units=19, side_m=75.0), total_kg=200.0)
    np.testing.assert_allclose(m75, 0.25, rtol=1e-15)


def test_central_case_masses_and_centre_of_mass():
    """Central case (our mass placement): ⅔ M/800 = 0.08333 kg per node plus M/3 over the 8
    central-cube nodes (+4.1667)."""
    lat = make_lattice(units=19, side_m=100.0)
    m = node_masses(lat, total_kg=100.0, central_fraction=1.0 / 3.0)
    centre = central_cube_nodes(lat)
    assert sorted(map(tuple, lat.ijk[centre].tolist())) == sorted(
        (i, j, k) for i in (9, 10) for j in (9, 10) for k in (0, 1)
    )
    others = np.setdiff1d(np.arange(800), centre)
    assert close_to_printed(m[others][0], "0.08333")
    np.testing.assert_allclose(m[others], m[others][0], rtol=1e-15)
    assert close_to_printed(m[centre][0] - m[others][0], "4.1667")
    np.testing.assert_allclose(m.sum(), 100.0, rtol=1e-14)
    com = (m[:, None] * lat.nodes).sum(axis=0) / m.sum()
    np.testing.assert_allclose(com, 0.0, atol=1e-12 * 100.0)


def test_shipped_central_config_masses():
    """The shipped Case A central config builds the central-case masses (sum 100 kg, COM at the centre)."""
    tm = make_truss_model(load_config(REPO_MODELS / "dist_vs_central/case_a_central_bangbang.toml"))
    np.testing.assert_allclose(tm.masses.sum(), 100.0, rtol=1e-14)
    assert np.sum(tm.masses > 1.0) == 8
    com = (tm.masses[:, None] * tm.lattice.nodes).sum(axis=0) / tm.masses.sum()
    np.testing.assert_allclose(com, 0.0, atol=1e-12 * 100.0)
    assert tm.particle_mass_kg == 0.125


def test_orbital_inertia_eq21():
    """Robb et al. 2022a, Eq. 21: 75 m, 200 kg, 800 particles: I1 = I2 ≈ 1.0440e5, I3 ≈ 2.0724e5 kg m²."""
    lat = make_lattice(units=19, side_m=75.0)
    I = particle_inertia(lat.nodes, node_masses(lat, total_kg=200.0)).moments
    assert close_to_printed(I[0] / 1e5, "1.0440") and close_to_printed(I[1] / 1e5, "1.0440")
    assert close_to_printed(I[2] / 1e5, "2.0724")


def test_invalid_inputs_are_rejected():
    with pytest.raises(ValueError, match="units"):
        make_lattice(units=0, side_m=1.0)
    with pytest.raises(ValueError, match="diagonals"):
        make_lattice(units=2, side_m=1.0, diagonals="Y")
    lat = make_lattice(units=2, side_m=1.0)
    with pytest.raises(ValueError, match="central_fraction"):
        node_masses(lat, total_kg=1.0, central_fraction=1.0)
    with pytest.raises(ValueError, match="calibration"):
        calibration_factor(lat, "magic")


@settings(max_examples=50, deadline=None)
@given(st.integers(1, 4), st.integers(0, 2**32 - 1), st.floats(1e-4, 0.9))
def test_strain_check_finds_the_largest_strain(units, seed, scale):
    """The run's divergence check equals max |l/l0 − 1| over the struts written out plainly."""
    from magsail_mj.lattice.geometry import strain_check

    lat = make_lattice(units=units, side_m=3.0 * units)
    rng = np.random.default_rng(seed)
    x = lat.nodes + rng.normal(scale=scale * lat.cube_edge_m / 4, size=lat.nodes.shape)
    pos = np.vstack([np.full(3, 7.0), x])  # body 0 is the world
    eps = np.array([abs(np.linalg.norm(x[j] - x[i]) / l0 - 1.0) for (i, j), l0 in zip(lat.struts, lat.rest_length)])
    value, strut = strain_check(lat)(pos)
    assert value == pytest.approx(eps.max(), rel=1e-12, abs=1e-15)
    assert eps[strut] == pytest.approx(eps.max(), rel=1e-12, abs=1e-15)
