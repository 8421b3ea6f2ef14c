"""The truss plates against Kirchhoff plate theory (:mod:`magsail_mj.structure.plate_theory`).

The references: the free square Kirchhoff plate by scikit-fem's Argyris element (against Leissa's
table), the free disc's Bessel frequency equation (against a fine Morley solve), the lattices'
homogenised rigidities (against the energy of the assembled strut stiffness under the Kirchhoff
field). The lattices: their first free modes converge to those of the Kirchhoff plate of their
homogenised rigidities as the cubes shrink, at first order in the cube edge ``a / d`` (the uniform
node masses put a whole node's mass on the half and quarter cells of the edges and corners, the
edge chords have their full ``EA`` for half a cell, and the webs' shear flexibility, over a depth
``h = a``, makes a boundary layer at the free edges) plus ``(a / d)²`` (transverse shear, discrete
curvature): at 19 cubes the lattice is 9–15 % soft, and the extrapolation in ``1/n`` and ``1/n²``
from 19, 29 and 39 cubes leaves ``O(n⁻³)``, measured 0.16–0.64 % (0.07–0.28 % from 29, 39, 49).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import pytest

from magsail_mj.concepts.truss_magnetorquer.twist import first_twist_mode, low_modes, plate_twist_lambda
from magsail_mj.lattice.geometry import stiffness_matrix
from magsail_mj.structure.generators import (
    cantilever,
    circular_plate,
    octet_plate,
    offset_grid_plate,
    square_plate_lattice,
)
from magsail_mj.structure.model import Structure
from magsail_mj.structure.modes import structure_modes
from magsail_mj.structure.plate_theory import (
    PlateRigidity,
    cantilever_rigidity_factor,
    cubic_lattice_rigidity,
    disc_mesh,
    free_disc_lambda2,
    free_plate_modes,
    frequency_parameter,
    octet_rigidity,
    offset_grid_rigidity,
    square_mesh,
    square_symmetry_class,
    two_layer_rigidity,
)
from tests.conftest import load_file_module

#: Leissa (Vibration of Plates, NASA SP-160, 1969), completely free square plate, ν = 0.3: λ² of
#: the first five modes, given to five digits (a half unit of the last is 4e-5 of the first).
LEISSA_SQUARE_NU03 = np.array([13.468, 19.596, 24.270, 34.801, 34.801])
#: The free square plate's first five symmetry classes: twist, saddle, the symmetric mode, a pair.
SQUARE_CLASSES = ["B2", "B1", "A1", "E", "E"]
#: Cube counts of the convergence study.
UNITS = (9, 15, 19, 29, 39)


@lru_cache(maxsize=None)
def kirchhoff_square(rigidity: PlateRigidity, *, divisions: int = 4) -> tuple[np.ndarray, list[str]]:
    """λ² (per D11, side 1, ρ_A = 1) and classes of the free square plate's first five modes
    (Argyris, ``divisions² · 2`` triangles: 4 is within 3·10⁻⁵ of 8)."""
    modes = free_plate_modes(square_mesh(side_m=1.0, divisions=divisions), rigidity, areal_density_kg_m2=1.0, count=5)
    lam2 = frequency_parameter(modes.omega_rad_s, length_m=1.0, D_Nm=rigidity.D11_Nm, areal_density_kg_m2=1.0)
    return lam2, square_symmetry_class(modes.points_m, modes.deflection)


def lattice_classes(structure: Structure, count: int) -> tuple[np.ndarray, list[str]]:
    """ω [rad/s] and symmetry classes of the first ``count`` elastic modes (w over all nodes)."""
    modes = structure_modes(structure, k=6 + count)
    assert modes.n_zero == 6
    w = modes.node_translations()[6:, :, 2]
    return modes.omega_rad_s[6:], square_symmetry_class(structure.positions_m, w)


def unit_D11_EA(diagonals: str, cube_edge_m: float) -> float:
    """The strut EA [N] that gives the cubic lattice of cube edge ``cube_edge_m`` D11 = 1 N m."""
    return 1.0 / cubic_lattice_rigidity(EA_N=1.0, cube_edge_m=cube_edge_m, diagonals=diagonals).D11_Nm


@lru_cache(maxsize=None)
def square_lattice_lambda2(diagonals: str, units: int) -> tuple[np.ndarray, tuple[str, ...]]:
    """λ² (per the homogenised D11, ρ_A = M/d²) and classes of the unit square lattice's first 5 modes."""
    s = square_plate_lattice(
        units=units, side_m=1.0, EA_N=unit_D11_EA(diagonals, 1.0 / units), total_mass_kg=1.0, diagonals=diagonals
    )
    omega, classes = lattice_classes(s, 5)
    return omega, tuple(classes)


def richardson(units: tuple[int, ...], values: np.ndarray) -> np.ndarray:
    """``f∞`` of ``f(n) = f∞ + c1/n + c2/n²`` through three sizes (rows of ``values``)."""
    A = np.array([[1.0, 1.0 / n, 1.0 / n**2] for n in units])
    return np.linalg.solve(A, np.asarray(values))[0]


def test_free_square_kirchhoff_plate_against_leissa():
    """Argyris, 8 × 8 × 2 triangles, ν = 0.3: the first five λ² within 10⁻⁴ of Leissa's five-digit
    values (4 × 4 × 2 already within 3·10⁻⁵ of these), twist first; the twist also equals the
    truss concept's Rayleigh–Ritz over odd monomials (an independent method) to 10⁻⁵."""
    lam2, classes = kirchhoff_square(PlateRigidity.isotropic(2.5, 0.3), divisions=8)
    np.testing.assert_allclose(lam2, LEISSA_SQUARE_NU03, rtol=1e-4)
    assert classes == SQUARE_CLASSES
    assert lam2[0] == pytest.approx(plate_twist_lambda(0.3, n_terms=6), rel=1e-5)
    coarse = free_plate_modes(
        square_mesh(side_m=1.0, divisions=4), PlateRigidity.isotropic(1.0, 0.3), areal_density_kg_m2=1.0, count=5
    )
    np.testing.assert_allclose(coarse.omega_rad_s, lam2, rtol=3e-5)


def test_free_disc_bessel_roots_against_fine_morley_solve():
    """The first ten elastic λ² of the isotropic free disc (ν = 0.3; n = 2, 0, 3, 1, 4 nodal
    diameters, n = 5 last; the n ≥ 1 ones twice) from the Bessel determinant against the Morley element on
    scikit-fem's disc (5 refinements, 8 321 unknowns, 128-sided polygon: its O(h²) error, both the
    element's and the polygon's, measured 0.27 % at most): within 0.5 %, and 4 refinements
    further off for every mode (the error falls with the mesh)."""
    roots = {n: free_disc_lambda2(nu=0.3, nodal_diameters=n, count=2) for n in range(7)}
    table = sorted((float(v), n) for n, values in roots.items() for v in values for _ in range(1 if n == 0 else 2))
    bessel = np.array([v for v, _ in table[:10]])
    assert [n for _, n in table[:6]] == [2, 2, 0, 3, 3, 1]
    rigidity = PlateRigidity.isotropic(1.0, 0.3)
    fine, coarse = (
        free_plate_modes(
            disc_mesh(radius_m=1.0, refinements=r), rigidity, areal_density_kg_m2=1.0, count=10, element="morley"
        )
        for r in (5, 4)
    )
    np.testing.assert_allclose(fine.omega_rad_s, bessel, rtol=5e-3)
    assert np.all(np.abs(coarse.omega_rad_s / bessel - 1) > np.abs(fine.omega_rad_s / bessel - 1))


def test_disc_roots_scale_free_and_check_arguments():
    """λ² does not depend on the grid step; the arguments are checked by name."""
    a = free_disc_lambda2(nu=0.25, nodal_diameters=3, count=3)
    b = free_disc_lambda2(nu=0.25, nodal_diameters=3, count=3, step=0.003)
    np.testing.assert_allclose(a, b, rtol=1e-12)
    with pytest.raises(ValueError, match="nodal_diameters: must be an integer >= 0, got -1"):
        free_disc_lambda2(nu=0.3, nodal_diameters=-1, count=1)
    with pytest.raises(ValueError, match="nu: must lie in"):
        free_disc_lambda2(nu=1.5, nodal_diameters=2, count=1)


def kirchhoff_field(positions_m: np.ndarray, curvature: tuple[float, float, float]) -> np.ndarray:
    """(3 n,) the Kirchhoff field ``u = −z w_x, v = −z w_y, w`` of ``w = ½ κx x² + ½ κy y² + κxy x y``."""
    x, y, z = positions_m.T
    kx, ky, kxy = curvature
    w = 0.5 * kx * x**2 + 0.5 * ky * y**2 + kxy * x * y
    return np.column_stack([-z * (kx * x + kxy * y), -z * (ky * y + kxy * x), w]).ravel()


PLATES = {
    "parity": (
        lambda n: square_plate_lattice(units=n, side_m=n * 0.7, EA_N=3.0, total_mass_kg=1.0),
        lambda n: cubic_lattice_rigidity(EA_N=3.0, cube_edge_m=0.7),
    ),
    "X": (
        lambda n: square_plate_lattice(units=n, side_m=n * 0.7, EA_N=3.0, total_mass_kg=1.0, diagonals="X"),
        lambda n: cubic_lattice_rigidity(EA_N=3.0, cube_edge_m=0.7, diagonals="X"),
    ),
    "octet": (
        lambda n: octet_plate(units=n, side_m=n * 0.7, EA_N=3.0, total_mass_kg=1.0),
        lambda n: octet_rigidity(EA_N=3.0, cube_edge_m=0.7),
    ),
    "offset": (
        lambda n: offset_grid_plate(cells=n, side_m=n * 0.7, depth_m=0.4, EA_N=3.0, total_mass_kg=1.0),
        lambda n: offset_grid_rigidity(EA_N=3.0, pitch_m=0.7, depth_m=0.4),
    ),
}


@pytest.mark.parametrize("plate", list(PLATES))
def test_homogenised_rigidities_are_the_lattice_energy_under_the_kirchhoff_field(plate):
    """``uᵀ K u`` of the assembled strut stiffness under the Kirchhoff field of a uniform
    curvature ``κ``, over the plate's area, is ``κ·D·κ`` plus boundary terms (edge and rim chords,
    a share ``1/n``; corner braces, ``1/n²``), the webs unstrained: extrapolated in ``1/n`` and
    ``1/n²`` from 8, 12 and 16 cells it equals the homogenised energy to round-off (10⁻⁹ of the
    largest), for bending (κx), bending both ways (κx = κy), the saddle (κx = −κy: nothing for the
    octet, whose rim chords alone resist it) and twist (κxy: nothing for the offset grid but its
    braces)."""
    build, rigidity = PLATES[plate]
    D = rigidity(0)
    sizes = (8, 12, 16)
    states = ((1.0, 0.0, 0.0), (1.0, 1.0, 0.0), (1.0, -1.0, 0.0), (0.0, 0.0, 1.0))
    expected = np.array([D.D11_Nm, 2 * (D.D11_Nm + D.D12_Nm), 2 * (D.D11_Nm - D.D12_Nm), 4 * D.D66_Nm])
    energies = []
    for n in sizes:
        s = build(n)
        K = stiffness_matrix(s.positions_m, s.members.nodes, s.members.stiffness_N_m)
        fields = np.array([kirchhoff_field(s.positions_m, k) for k in states]).T
        energies.append(np.einsum("ij,ij->j", fields, K @ fields) / (0.7 * n) ** 2)
    limit = richardson(sizes, np.array(energies))
    np.testing.assert_allclose(limit, expected, rtol=0, atol=1e-9 * expected.max())


def test_rigidity_closed_forms_and_checks():
    """The module docstring's constants: parity ν = (√2/4)/(1 + √2/4), twist ratio 1/√2; X ν = √2 − 1,
    ratio √2; octet ν = 1; offset grid D12 = D66 = 0; an unsymmetric layer is refused by name."""
    parity = cubic_lattice_rigidity(EA_N=2.0, cube_edge_m=0.5)
    assert parity.poisson_ratio == pytest.approx((math.sqrt(2) / 4) / (1 + math.sqrt(2) / 4), rel=1e-14)
    assert parity.twist_ratio == pytest.approx(1 / math.sqrt(2), rel=1e-14)
    assert parity.D11_Nm == pytest.approx(2.0 * 0.5 * (1 + math.sqrt(2) / 4) / 2, rel=1e-14)
    X = cubic_lattice_rigidity(EA_N=2.0, cube_edge_m=0.5, diagonals="X")
    assert (X.poisson_ratio, X.twist_ratio) == pytest.approx((math.sqrt(2) - 1, math.sqrt(2)), rel=1e-14)
    assert octet_rigidity(EA_N=1.0, cube_edge_m=1.0).poisson_ratio == pytest.approx(1.0, rel=1e-14)
    grid = offset_grid_rigidity(EA_N=1.0, pitch_m=1.0, depth_m=1.0)
    assert (grid.D12_Nm, grid.D66_Nm, grid.D11_Nm) == pytest.approx((0.0, 0.0, 0.5), abs=1e-15)
    iso = PlateRigidity.isotropic(3.0, 0.3)
    assert (iso.poisson_ratio, iso.twist_ratio) == pytest.approx((0.3, 1.0), rel=1e-14)
    with pytest.raises(ValueError, match="families: the layer is not square-symmetric"):
        two_layer_rigidity(EA_N=1.0, depth_m=1.0, families=[(1.0, 0.0, 1.0)])
    with pytest.raises(ValueError, match="diagonals: must be 'parity' or 'X', got 'Y'"):
        cubic_lattice_rigidity(EA_N=1.0, cube_edge_m=1.0, diagonals="Y")
    with pytest.raises(ValueError, match="D12_Nm: must satisfy"):
        PlateRigidity(D11_Nm=1.0, D12_Nm=1.5, D66_Nm=0.0)


@pytest.mark.parametrize("diagonals, units", [("parity", (9, 15, 19, 29, 39)), ("X", (9, 15, 19))])
def test_square_lattice_modes_converge_to_their_kirchhoff_plate(diagonals, units):
    """The unit square lattice with EA for D11 = 1 (homogenised), M = 1, refined, against the free
    Kirchhoff plate of its rigidities (parity: ν = 0.261, twist 0.71 of isotropic; X: 0.414,
    1.41): the same five mode classes (twist first), every one softer, the error falling at every
    refinement at first order (9 → 19 cubes: a factor 1.5–2.6; measured 1.7–2.0 parity, 1.9–2.2 X;
    19 → 39: 1.9–2.5), and the extrapolation from 19, 29, 39 cubes within 1 % (measured
    ≤ 0.64 %, module docstring). Errors at 9, 15, 19 cubes, parity: twist −24.6, −15.2, −12.0 %,
    the fifth mode −32.2, −19.3, −14.9 %."""
    reference, ref_classes = kirchhoff_square(cubic_lattice_rigidity(EA_N=1.0, cube_edge_m=1.0, diagonals=diagonals))
    assert ref_classes == SQUARE_CLASSES
    for n in units:
        assert list(square_lattice_lambda2(diagonals, n)[1]) == SQUARE_CLASSES
    omega = np.array([square_lattice_lambda2(diagonals, n)[0] for n in units])
    error = omega / reference - 1.0
    assert np.all(error < 0)
    assert np.all(np.diff(np.abs(error), axis=0) < 0)
    rate = error[units.index(9)] / error[units.index(19)]
    assert np.all((rate > 1.5) & (rate < 2.6)), rate
    if 39 in units:
        limit = richardson((19, 29, 39), omega[units.index(19) :])
        np.testing.assert_allclose(limit, reference, rtol=1e-2)


def test_disc_lattice_modes_converge_to_their_kirchhoff_disc():
    """The cubic lattice clipped to a disc (12, 24, 48 cubes across, D11 = 1, ρ_A = 1 over the
    kept cubes) against the Kirchhoff disc of its rigidities (Morley, 5 refinements) of the
    kept area's radius: the first three modes are of the disc's classes (the twist ``B2``, then the
    saddle ``B1``: the lattice's lower twisting rigidity splits the isotropic pair), and the error
    halves (first order) at each doubling: a factor in 0.35–0.6 (the staircase rim adds an
    irregular part; measured errors −24.0, −11.3, −5.3 % twist, −23.0, −10.1, −4.2 % third mode)."""
    rigidity = cubic_lattice_rigidity(EA_N=1.0, cube_edge_m=1.0)
    disc = free_plate_modes(
        disc_mesh(radius_m=1.0, refinements=5), rigidity, areal_density_kg_m2=1.0, count=3, element="morley"
    )
    disc_classes = square_symmetry_class(disc.points_m, disc.deflection)
    assert disc_classes == ["B2", "B1", "A1"]
    reference = disc.omega_rad_s * rigidity.D11_Nm**-0.5
    errors = []
    for n in (12, 24, 48):
        a = 2.0 / n
        s = circular_plate(diameter_m=2.0, units_across=n, EA_N=unit_D11_EA("parity", a), areal_density_kg_m2=1.0)
        radius = math.sqrt(s.node_mass_kg.sum() / math.pi)
        omega, classes = lattice_classes(s, 3)
        assert classes == disc_classes
        errors.append(omega * radius**2 / reference - 1.0)
    halving = np.abs(np.array(errors[1:]) / np.array(errors[:-1]))
    assert np.all((halving > 0.35) & (halving < 0.6)), halving


def test_cantilever_calibration_maps_EI_to_D11():
    """The Kirchhoff cantilever's ``c = EI / (D11 d)``: 1 for ν = 0 (beam bending, 10⁻⁹), between
    ``1 − ν²`` and 1 for ν = 0.3; the parity lattice's linear cantilever (the calibration's) at 19,
    29, 39 cubes, over ``c D11 d`` of its homogenised plate, extrapolated in ``1/n``, ``1/n²``: 1
    within 0.3 % (measured 0.08 %; 0.11 % for X; from 19, 39, 59 cubes 0.05 %), so a lattice
    calibrated to EI is, as its cubes shrink, the plate of ``D11 = EI / (c d)``: c = 0.974 parity,
    0.939 X (``D11 = 1.026 EI/d``, ``1.064 EI/d``), not ``EI / d``."""
    assert cantilever_rigidity_factor(PlateRigidity.isotropic(1.0, 0.0), divisions=2) == pytest.approx(1.0, rel=1e-9)
    iso = cantilever_rigidity_factor(PlateRigidity.isotropic(1.0, 0.3), divisions=4)
    assert 1 - 0.3**2 < iso < 1.0
    X = cantilever_rigidity_factor(cubic_lattice_rigidity(EA_N=1.0, cube_edge_m=1.0, diagonals="X"))
    c = cantilever_rigidity_factor(cubic_lattice_rigidity(EA_N=1.0, cube_edge_m=1.0))
    assert (c, X) == pytest.approx((0.9742, 0.9394), abs=2e-4)  # 12 divisions: within 1.1e-4 of 24
    sizes = (19, 29, 39)
    ratios = []
    for n in sizes:
        s = square_plate_lattice(units=n, side_m=1.0, EA_N=1.0, total_mass_kg=1.0)
        ratios.append(cantilever(s).EI_eff_Nm2 / (c * cubic_lattice_rigidity(EA_N=1.0, cube_edge_m=1.0 / n).D11_Nm))
    assert richardson(sizes, np.array(ratios)) == pytest.approx(1.0, abs=3e-3)


@pytest.fixture(scope="module")
def readings():
    script = load_file_module("scripts", "plate_frequencies", register=True)
    return script, script.plate_readings(units=19, side_m=75.0, EI_Nm2=1e3, mass_kg=200.0)


def test_75m_twist_readings(readings):
    """The 75 m plates (19 cubes or cells, EI = 10³ N m², 200 kg) of ``scripts/plate_frequencies.py``:
    the shipped lattice twists first (B2, then the saddle and the symmetric mode, Kirchhoff's
    order) at 0.770 of the isotropic plate's twist (ν = 0.3) — the frequency the truss concept's
    own solver and twist-share rule give (10⁻⁸) — and at 0.880 of its own homogenised plate's (the
    discretisation error of the convergence study at 19 cubes, 10⁻³); the octet's lowest mode is
    its saddle (the twist about its chords, the mechanism its rim chords hold: below the plate's
    twist), its ``x y`` twist above the plate's; the offset grid's twist, held by four corner
    braces only, is below a tenth of the plate's."""
    script, rows = readings
    parity, octet, grid = rows
    assert parity.classes[:5] == SQUARE_CLASSES
    plate_twist = plate_twist_lambda(0.3, n_terms=6)
    assert parity.twist_lambda2 / plate_twist == pytest.approx(0.7705, abs=5e-4)
    s = square_plate_lattice(units=19, side_m=75.0, EI_Nm2=1e3, total_mass_kg=200.0)
    modes = low_modes(s.positions_m, s.members.nodes, s.members.stiffness_N_m, s.node_mass_kg, n_elastic=4)
    _, omega = first_twist_mode(modes, s.positions_m, s.node_mass_kg)
    assert parity.twist_Hz == pytest.approx(omega / (2 * math.pi), rel=1e-8)
    own_plate = kirchhoff_square(cubic_lattice_rigidity(EA_N=1.0, cube_edge_m=1.0))[0][0]
    discretisation = square_lattice_lambda2("parity", 19)[0][0] / own_plate
    assert parity.twist_lambda2 / parity.own_twist_lambda2 == pytest.approx(discretisation, abs=1e-3)
    assert octet.classes[0] == "B1" and octet.lambda2[0] < plate_twist < octet.twist_lambda2
    assert grid.classes[0] == "B2" and grid.twist_lambda2 < 0.1 * plate_twist
    text = script.table(rows, nu=0.3)
    assert "| square_plate_lattice |" in text and "| 0.7705 |" in text


def test_free_plate_modes_checks():
    """Bad arguments are refused by name; a plate with a mechanism (D12 = D11: the saddle
    ``x² − y²`` stores nothing) has a fourth zero mode, refused."""
    with pytest.raises(ValueError, match="count: must be an integer >= 1, got 0"):
        free_plate_modes(
            square_mesh(side_m=1.0, divisions=2), PlateRigidity.isotropic(1.0, 0.3), areal_density_kg_m2=1.0, count=0
        )
    with pytest.raises(ValueError, match="element: must be one of"):
        free_plate_modes(
            square_mesh(side_m=1.0, divisions=2),
            PlateRigidity.isotropic(1.0, 0.3),
            areal_density_kg_m2=1.0,
            count=1,
            element="hct",
        )
    mechanism = PlateRigidity(D11_Nm=1.0, D12_Nm=1.0, D66_Nm=0.25)
    with pytest.raises(ValueError, match="mesh: a free plate has 3 rigid modes, found 4"):
        free_plate_modes(square_mesh(side_m=1.0, divisions=4), mechanism, areal_density_kg_m2=1.0, count=2)
