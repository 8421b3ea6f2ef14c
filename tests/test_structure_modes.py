"""Modes of any structure (:mod:`magsail_mj.structure.assembly`, :mod:`magsail_mj.structure.modes`)
and the ``magsail modes`` verb, against Euler–Bernoulli theory, closed-form rigid-body systems and
the lattice's own dense solver."""

from __future__ import annotations

import dataclasses
import json

import meshio
import numpy as np
import pytest
from scipy import optimize
from scipy.sparse.linalg import spsolve

from magsail_mj.cli import main
from magsail_mj.lattice.geometry import make_lattice
from magsail_mj.lattice.modes import lattice_modes
from magsail_mj.structure.assembly import assemble, dof_layout, mass_matrix, stiffness_matrix
from magsail_mj.structure.fileformat import write_structure
from magsail_mj.structure.generators.plates import lattice_structure
from magsail_mj.structure.model import Members, RigidPart, Structure, StructureError
from magsail_mj.structure.modes import mode_shares, principal_frame, structure_modes

L_M, N_EL, RHO_A = 10.0, 20, 0.5  # boom length [m], elements, linear density [kg/m]
EI = (2.0e3, 3.0e3)  # plane 1 (local x–y), plane 2 (local x–z) [N m²]
EA_N, GJ_NM2 = 1.0e6, 1.0e3


def boom(
    *, clamped: bool, axis=(1.0, 0.0, 0.0), orientation=None, n: int = N_EL, linear_density: float = RHO_A
) -> Structure:
    """A straight boom of ``n`` beam elements from the origin along ``axis``, root clamped or free."""
    direction = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    p = np.linspace(0.0, L_M, n + 1)[:, None] * direction
    members = Members.build(
        np.stack([np.arange(n), np.arange(1, n + 1)], axis=1),
        positions_m=p,
        kind="beam",
        EA_N=EA_N,
        EI_Nm2=np.tile(EI, (n, 1)),
        GJ_Nm2=GJ_NM2,
        linear_density_kg_m=linear_density,
        orientation=orientation,
    )
    fixed = np.zeros((n + 1, 6), dtype=bool)
    fixed[0] = clamped
    return Structure(name="boom", positions_m=p, node_mass_kg=np.zeros(n + 1), members=members, fixed_dofs=fixed)


def beta_roots(equation, guesses) -> np.ndarray:
    return np.array([optimize.brentq(equation, g - 0.5, g + 0.5, xtol=1e-14) for g in guesses])


# β_n L: roots of cos β cosh β = −1 (clamped–free) and = +1 (free–free), ≈ 1.8751, 4.6941, 7.8548 and 4.7300
CANTILEVER_BETA = beta_roots(lambda b: np.cos(b) * np.cosh(b) + 1.0, (1.875, 4.694, 7.855))
FREE_BETA = beta_roots(lambda b: np.cos(b) * np.cosh(b) - 1.0, (4.730, 7.853))


def bending_Hz(beta_L: np.ndarray, EI_Nm2: float) -> np.ndarray:
    """Euler–Bernoulli ``f = (βL)² / (2π L²) √(EI/ρA)``."""
    return beta_L**2 / (2.0 * np.pi * L_M**2) * np.sqrt(EI_Nm2 / RHO_A)


# --------------------------------------------------------------------------- beams


def test_cantilever_tip_deflection_is_exact_at_the_nodes():
    """Static end load: P L³/(3EI) in each bending plane and P L/EA along the boom. The Hermite
    cubics hold the exact (cubic) deflection of an end-loaded cantilever, so the nodes are exact
    to round-off (tolerance 1e-9 relative)."""
    s = boom(clamped=True)
    a = assemble(s)
    tip = a.layout.translation_dofs([N_EL])[0]
    expected = (L_M / EA_N, L_M**3 / (3 * EI[0]), L_M**3 / (3 * EI[1]))  # x: axial, y: plane 1, z: plane 2
    for component, want in enumerate(expected):
        f = np.zeros(a.layout.n_dof)
        f[tip[component]] = 1.0  # 1 N at the tip
        u = a.T @ spsolve(a.K_r.tocsc(), a.T.T @ f)
        assert u[tip[component]] == pytest.approx(want, rel=1e-9)


@pytest.mark.parametrize(("mass", "rel"), [("consistent", 1e-4), ("lumped", 1e-2)])
def test_cantilever_bending_frequencies(mass, rel):
    """First three bending frequencies of both planes against β_n L. Consistent Hermite elements
    converge as h⁴ (measured 5e-6 with 20 elements): 1e-4. HRZ-lumped mass converges as h²
    (measured −0.13 %, −0.5 %, −0.9 %): 1 %."""
    r = structure_modes(boom(clamped=True), k=8, mass=mass)
    assert r.n_zero == 0
    expected = np.sort(np.concatenate([bending_Hz(CANTILEVER_BETA, EI[0]), bending_Hz(CANTILEVER_BETA, EI[1])]))
    np.testing.assert_allclose(r.frequencies_Hz[:6], expected, rtol=rel)


def test_free_beam_has_six_rigid_modes_and_the_free_free_frequency():
    """A free–free beam: six zero modes (three translations, three rotations, torsion included),
    then bending at β L = 4.7300 in plane 1 and plane 2 (consistent: 1e-4), by both solvers."""
    for solver in ("dense", "sparse"):
        r = structure_modes(boom(clamped=False), k=10, mass="consistent", solver=solver)
        assert r.n_zero == 6 and np.all(r.frequencies_Hz[:6] == 0.0)
        expected = [bending_Hz(FREE_BETA[0], EI[0]), bending_Hz(FREE_BETA[0], EI[1])]
        np.testing.assert_allclose(r.frequencies_Hz[6:8], expected, rtol=1e-4)
        assert r.frequencies_Hz[8] > r.frequencies_Hz[7]


def test_massless_cantilever_with_a_tip_mass():
    """Massless beams, a point mass m at the tip: the mass matrix is singular (no rotary inertia,
    no mass at the inner nodes), which the dense solver meets with its shift-inverted pair. The
    static condensation onto the tip is exact (Hermite elements), so the lowest frequencies are
    ω² = 3 EI / (m L³) in each plane, to 1e-9. Only the tip's three coordinates carry mass: three
    finite modes, of which the sparse solver finds one (its Krylov space needs two more)."""
    tip_mass = np.zeros(N_EL + 1)
    tip_mass[-1] = 2.0
    s = dataclasses.replace(boom(clamped=True, linear_density=0.0), node_mass_kg=tip_mass)
    expected = [3 * EI[0] / (2.0 * L_M**3), 3 * EI[1] / (2.0 * L_M**3), EA_N / (2.0 * L_M)]
    r = structure_modes(s, k=3, solver="dense")
    np.testing.assert_allclose(r.omega_rad_s**2, expected, rtol=1e-9)
    r = structure_modes(s, k=1, solver="sparse")
    np.testing.assert_allclose(r.omega_rad_s**2, expected[:1], rtol=1e-9)
    with pytest.raises(ValueError, match="^k: 3 coordinates carry mass"):
        structure_modes(s, k=2, solver="sparse")
    with pytest.raises(ValueError, match="^k: only 3 finite-frequency modes exist"):
        structure_modes(s, k=4, solver="dense")


def test_beam_orientation_sets_the_plane_of_EI1():
    """A boom along an oblique axis with ``orientation`` v: its softest (EI1) mode moves along the
    part of v perpendicular to the boom (section axis 1), and the frequencies do not depend on the
    boom's direction (frame rotation; 1e-7: the dense solver's absolute error ε λ_max is 1e-8 of
    the lowest λ here)."""
    axis = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
    v = np.array([0.0, 0.0, 1.0])
    r = structure_modes(boom(clamped=True, axis=axis, orientation=v), k=4, mass="consistent")
    straight = structure_modes(boom(clamped=True), k=4, mass="consistent")
    np.testing.assert_allclose(r.frequencies_Hz, straight.frequencies_Hz, rtol=1e-7)
    y = v - (v @ axis) * axis
    y /= np.linalg.norm(y)
    tip = r.node_translations()[0, N_EL]
    assert abs(tip @ y) / np.linalg.norm(tip) == pytest.approx(1.0, abs=1e-9)


def test_cantilever_effective_masses_and_their_sum():
    """Effective masses of the first three y-bending modes over the beam's mass ρAL against the
    Euler–Bernoulli values 4 σ_n²/(β_n L)² (0.613, 0.188, 0.065; 20 consistent elements measured
    within 0.4 %: 1 %), and over all modes the fractions of each direction sum to 1 (1e-12)."""
    s = boom(clamped=True)
    r = structure_modes(s, k=assemble(s).n_dof, mass="consistent", solver="dense")
    b = CANTILEVER_BETA
    sigma = (np.sinh(b) - np.sin(b)) / (np.cosh(b) + np.cos(b))
    y_modes = r.participation.effective_mass[:, 1]
    first = y_modes[y_modes > 1e-6 * y_modes.max()][:3]
    np.testing.assert_allclose(first / (RHO_A * L_M), 4 * sigma**2 / b**2, rtol=1e-2)
    np.testing.assert_allclose(r.participation.fraction.sum(axis=0), 1.0, atol=1e-12)


def test_modes_are_mass_orthonormal_and_consistent_mass_is_the_beam_mass():
    s = boom(clamped=False)
    for mass in ("lumped", "consistent"):
        r = structure_modes(s, k=12, mass=mass)
        gram = r.shapes.T @ (r.assembly.M_r @ r.shapes)
        np.testing.assert_allclose(gram, np.eye(12), atol=1e-9)
        # total translational mass: 1ᵀ M 1 along x is ρ A L
        ones = np.zeros(r.assembly.layout.n_dof)
        ones[r.assembly.layout.translation_dofs()[:, 0]] = 1.0
        assert ones @ (r.assembly.M @ ones) == pytest.approx(RHO_A * L_M, rel=1e-12)


# --------------------------------------------------------------------------- lattice


def _lattice(units: int = 4, side_m: float = 10.0):
    lat = make_lattice(units=units, side_m=side_m)
    rng = np.random.default_rng(3)
    k = 1e5 / lat.rest_length * rng.uniform(0.5, 1.5, lat.n_struts)
    masses = np.full(lat.n_nodes, 2.0)
    structure = lattice_structure(lat, masses_kg=masses, EA_N=k * lat.rest_length, damping_Ns_m=0.0, name="lattice")
    return lat, k, masses, structure


@pytest.mark.parametrize("solver", ["dense", "sparse"])
def test_lattice_frequencies_equal_the_dense_lattice_solver(solver):
    """The shipped lattice (uniform masses, struts): the first 30 frequencies equal
    :func:`lattice_modes` (dense LAPACK on M^-½ K M^-½) to 1e-8 relative, six zero modes."""
    lat, k, masses, s = _lattice()
    ref = lattice_modes(lat.nodes, lat.struts, k, masses, use_cache=False)
    r = structure_modes(s, k=30, solver=solver)
    assert r.n_zero == 6 and r.solver == solver
    np.testing.assert_allclose(r.omega_rad_s[6:], ref.omega[6:30], rtol=1e-8)


def test_free_lattice_rigid_modes_carry_all_participation_and_twist_comes_first():
    """Free lattice: the six rigid modes carry all of the rigid-body mass and inertia (fractions
    sum to 1 over them, 0 in every elastic mode); the first elastic mode of the square plate is
    its twist (w ∝ x y: the twist share dominates)."""
    _, _, _, s = _lattice()
    r = structure_modes(s, k=12)
    frac = r.participation.fraction
    np.testing.assert_allclose(frac[:6].sum(axis=0), 1.0, atol=1e-9)
    assert np.abs(frac[6:]).max() < 1e-9
    np.testing.assert_allclose(r.participation.reference[:3], s.mass_properties()[0], rtol=1e-12)
    np.testing.assert_allclose(np.diag(s.mass_properties()[2]), r.participation.reference[3:], rtol=1e-12)
    assert r.share.symmetric and r.share.twist[6] > 0.8
    np.testing.assert_allclose(r.share.in_plane + r.share.bending + r.share.twist, 1.0, atol=1e-12)


def test_share_definition_on_prescribed_fields():
    """Shares of prescribed displacement fields on a square plate: w = x y is all twist, w = x² − y²
    and w = x all bending, u along e1 all in-plane; a mixture splits by the parts' energies."""
    _, _, _, s = _lattice()
    axes = principal_frame(s.mass_properties()[2])
    np.testing.assert_allclose(np.abs(axes), np.eye(3), atol=1e-12)  # square plate: aligned with x, y, z
    x, y, _ = (s.positions_m - s.mass_properties()[1]).T
    zero = np.zeros_like(x)
    fields = np.array(
        [
            np.stack([zero, zero, x * y], axis=1),
            np.stack([zero, zero, x**2 - y**2], axis=1),
            np.stack([zero, zero, x], axis=1),
            np.stack([np.ones_like(x), zero, zero], axis=1),
            np.stack([zero, zero, x * y / np.sqrt(np.mean((x * y) ** 2)) + x / np.sqrt(np.mean(x**2))], axis=1),
        ]
    )
    sh = mode_shares(s, fields)
    np.testing.assert_allclose(sh.twist, [1, 0, 0, 0, 0.5], atol=1e-12)
    np.testing.assert_allclose(sh.bending, [0, 1, 1, 0, 0.5], atol=1e-12)
    np.testing.assert_allclose(sh.in_plane, [0, 0, 0, 1, 0], atol=1e-12)


def test_lattice_matrices_are_sparse():
    """A lattice is assembled without a dense n × n matrix (nnz a few dozen per row)."""
    lat = make_lattice(units=20, side_m=20.0)
    s = lattice_structure(lat, masses_kg=np.ones(lat.n_nodes), EA_N=1.0, damping_Ns_m=0.0, name="big")
    layout = dof_layout(s)
    K, M = stiffness_matrix(s, layout), mass_matrix(s, layout)
    assert K.format == M.format == "csr" and K.nnz < 60 * layout.n_dof and M.nnz == layout.n_dof


# --------------------------------------------------------------------------- rigid parts, constraints


def _two_parts() -> Structure:
    """Two rigid parts (a bus, a tip mass) joined by one beam along z: node 0 held by the bus at
    its centre, node 1 by the tip at its centre; the beam itself massless."""
    p = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 2.0]])
    members = Members.build([[0, 1]], positions_m=p, kind="beam", EA_N=3e4, EI_Nm2=50.0, GJ_Nm2=40.0)
    parts = (
        RigidPart("bus", 10.0, p[0], np.diag([1.0, 2.0, 3.0]), np.array([0])),
        RigidPart("tip", 4.0, p[1], np.diag([0.5, 0.7, 0.9]), np.array([1])),
    )
    return Structure(name="two", positions_m=p, node_mass_kg=np.zeros(2), members=members, rigid_parts=parts)


def test_two_rigid_parts_on_a_beam_give_the_closed_form_frequencies():
    """Six zero modes; the axial mode ω² = (EA/L)(1/m_a + 1/m_b) and the torsion mode
    ω² = (GJ/L)(1/I_a + 1/I_b) (I about z) exactly (1e-10), the bending modes between them."""
    s = _two_parts()
    r = structure_modes(s, k=12)
    assert r.assembly.n_dof == 12
    assert r.n_zero == 6
    omega2 = (2 * np.pi * r.frequencies_Hz[6:]) ** 2
    axial = 3e4 / 2.0 * (1 / 10.0 + 1 / 4.0)
    torsion = 40.0 / 2.0 * (1 / 3.0 + 1 / 0.9)
    assert np.min(np.abs(omega2 / axial - 1)) < 1e-10
    assert np.min(np.abs(omega2 / torsion - 1)) < 1e-10


def test_partly_fixed_rigid_part_turns_about_its_fixed_node():
    """A part (mass m, inertia I_zz about its centre at (d, 0, 0)) holds node 0 at the origin
    (translations fixed) and node 1 at (2d, 0, 0), tied by a strut along y to a fixed node: it can
    only turn about node 0, the strut resists θ_z only: ω² = k (2d)² / (I_zz + m d²), two zero modes."""
    d, m, I_zz, k, L = 0.5, 3.0, 0.2, 800.0, 1.0
    p = np.array([[0.0, 0.0, 0.0], [2 * d, 0.0, 0.0], [2 * d, L, 0.0]])
    members = Members.build([[1, 2]], positions_m=p, EA_N=k * L)
    fixed = np.zeros((3, 6), dtype=bool)
    fixed[0, :3] = fixed[2, :3] = True
    part = RigidPart("arm", m, np.array([d, 0.0, 0.0]), np.diag([0.1, 0.15, I_zz]), np.array([0, 1]))
    s = Structure(
        name="arm", positions_m=p, node_mass_kg=np.zeros(3), members=members, rigid_parts=(part,), fixed_dofs=fixed
    )
    r = structure_modes(s, k=3)
    assert r.assembly.n_dof == 3 and r.n_zero == 2
    assert (2 * np.pi * r.frequencies_Hz[2]) ** 2 == pytest.approx(k * (2 * d) ** 2 / (I_zz + m * d**2), rel=1e-12)


def test_refusals_name_the_element():
    s = boom(clamped=False, n=2)
    with pytest.raises(ValueError, match="mass: must be one of"):
        structure_modes(s, mass="diagonal")
    with pytest.raises(ValueError, match="^k: must be an integer in 1..18"):
        structure_modes(s, k=19)
    with pytest.raises(ValueError, match="sigma: must be finite and < 0"):
        structure_modes(s, k=2, sigma=1.0)
    loose = Structure(
        name="loose",
        positions_m=np.array([[0.0, 0, 0], [1, 0, 0], [5, 5, 5]]),
        node_mass_kg=np.array([1.0, 1.0, 0.0]),
        members=Members.build([[0, 1]], positions_m=np.array([[0.0, 0, 0], [1, 0, 0]]), EA_N=1.0),
    )
    with pytest.raises(StructureError, match=r"nodes\[2\]: its x coordinate has neither stiffness nor mass"):
        assemble(loose)
    parallel = boom(clamped=False, n=2, orientation=np.array([1.0, 0.0, 0.0]))
    with pytest.raises(StructureError, match=r"members\[0\]\.orientation: .* parallel to the member axis"):
        assemble(parallel)


# --------------------------------------------------------------------------- the verb


def _run(capsys, argv):
    capsys.readouterr()
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_verb_on_a_structure_file_and_a_lattice_config(tmp_path, capsys):
    """A structure file of a free lattice: JSON with ascending frequencies, 6 zero modes, equal to
    the library call; a lattice config (truss detumble, 800 nodes: the sparse solver) likewise."""
    _, _, _, s = _lattice(units=3, side_m=6.0)
    write_structure(s, tmp_path / "lattice.toml")
    code, out, err = _run(
        capsys, ["modes", str(tmp_path / "lattice.toml"), "--count", "8", "--plot", str(tmp_path / "plots")]
    )
    assert code == 0, err
    report = json.loads(out)
    f = np.array(report["frequencies_Hz"])
    assert report["rigid_body_modes"] == 6 and report["count"] == 8 and report["source"]["kind"] == "structure file"
    assert np.all(np.diff(f) >= 0) and np.all(f[:6] == 0) and f[6] > 0
    np.testing.assert_allclose(f, structure_modes(s, k=8).frequencies_Hz, rtol=1e-9)
    assert len(report["share"]["twist"]) == 8 and len(report["participation"]["fraction"][0]) == 6
    assert [p.rsplit("/", 1)[1] for p in report["plots"]] == ["mode_07.png", "mode_08.png"]
    assert all((tmp_path / "plots" / name).stat().st_size > 0 for name in ("mode_07.png", "mode_08.png"))

    config = "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml"
    code, out, err = _run(capsys, ["modes", config, "--count", "8"])
    assert code == 0, err
    report = json.loads(out)
    assert report["rigid_body_modes"] == 6 and report["solver"] == "sparse" and report["n_dof"] == 2400
    assert np.all(np.diff(report["frequencies_Hz"]) >= 0) and report["frequencies_Hz"][6] > 0


def test_verb_on_a_nastran_deck(tmp_path, capsys):
    """A Nastran cantilever of 20 CBARs (v along y: plane 1 is x–y, I1 < I2): the first two
    frequencies are the Euler–Bernoulli ones of E I1 and E I2 (the verb's HRZ-lumped mass: 1 %), the
    E I1 mode moving along y and the E I2 mode along z (effective mass fractions)."""
    n, E, rho, A, I1, I2 = 20, 7e10, 2700.0, 1e-4, 2e-8, 5e-8
    cards = ["BEGIN BULK"] + [f"GRID,{i + 1},,{L_M * i / n:.6f},0.,0." for i in range(n + 1)]
    cards += [f"CBAR,{i + 1},1,{i + 1},{i + 2},0.,1.,0." for i in range(n)]
    cards += ["PBAR,1,1,1.-4,2.-8,5.-8,1.-8", "MAT1,1,7.+10,2.7+10,,2700.", "SPC1,1,123456,1", "ENDDATA"]
    deck = tmp_path / "boom.bdf"
    deck.write_text("\n".join(cards) + "\n")
    code, out, err = _run(capsys, ["modes", str(deck), "--count", "4"])
    assert code == 0, err
    report = json.loads(out)
    assert report["rigid_body_modes"] == 0 and report["source"]["kind"] == "Nastran deck"
    beta2 = CANTILEVER_BETA[0] ** 2 / (2 * np.pi * L_M**2)
    expected = [beta2 * np.sqrt(E * I1 / (rho * A)), beta2 * np.sqrt(E * I2 / (rho * A))]
    np.testing.assert_allclose(report["frequencies_Hz"][:2], expected, rtol=1e-2)
    fraction = np.array(report["participation"]["fraction"])
    assert fraction[0, 1] > 0.6 and fraction[1, 2] > 0.6 and fraction[0, 2] < 1e-12 and fraction[1, 1] < 1e-12


def test_verb_takes_set_overrides_of_a_config(tmp_path, capsys):
    """``--set KEY=VALUE`` (repeatable) overrides a config SOURCE as ``magsail run`` does: the truss
    detumble at 3 cubes a side has the modes of that lattice (96 coordinates instead of 2 400), and
    twice its EI (every strut's EA doubled, the masses kept) puts its elastic frequencies √2 higher
    (to rounding: 1e-9). A bad or unknown value is the config's error (exit 2, naming the key and
    the --set); a structure file, a Nastran deck or a mesh refuses --set by name."""
    config = "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml"
    code, out, err = _run(capsys, ["modes", config, "--count", "9", "--set", "lattice.units=3"])
    assert code == 0, err
    small = json.loads(out)
    assert small["n_dof"] == 96 and small["rigid_body_modes"] == 6 and small["source"]["kind"] == "config"
    argv = ["modes", config, "--count", "9", "--set", "lattice.units=3", "--set", "stiffness.EI_Nm2=2e3"]
    code, out, err = _run(capsys, argv)
    assert code == 0, err
    stiff = json.loads(out)
    expected = np.sqrt(2.0) * np.array(small["frequencies_Hz"][6:])
    np.testing.assert_allclose(stiff["frequencies_Hz"][6:], expected, rtol=1e-9)
    code, out, err = _run(capsys, ["modes", config, "--set", "lattice.units=0"])
    assert code == 2 and out == "" and "lattice.units" in err, err
    code, out, err = _run(capsys, ["modes", config, "--set", "nope=3"])
    assert code == 2 and out == "" and "--set 'nope=3'" in err, err
    _, _, _, s = _lattice(units=2, side_m=2.0)
    write_structure(s, tmp_path / "lattice.toml")
    deck = tmp_path / "rod.bdf"
    cards = ["BEGIN BULK", "GRID,1,,0.,0.,0.", "GRID,2,,1.,0.,0.", "CROD,1,1,1,2", "PROD,1,1,1.-4"]
    deck.write_text("\n".join([*cards, "MAT1,1,7.+10,,.3,2700.", "ENDDATA"]) + "\n")
    meshio.write(tmp_path / "bare.msh", meshio.Mesh(np.eye(3), [("line", np.array([[0, 1], [1, 2]]))]), "gmsh22")
    sources = ((tmp_path / "lattice.toml", "structure file"), (deck, "Nastran deck"), (tmp_path / "bare.msh", "mesh"))
    for source, kind in sources:
        code, out, err = _run(capsys, ["modes", str(source), "--set", "lattice.units=3"])
        assert code == 2 and out == "" and err.startswith("error: --set: 'lattice.units=3'") and kind in err, err


def test_verb_refusals_name_the_argument(tmp_path, capsys):
    code, _, err = _run(capsys, ["modes", "magsail_mj/concepts/cnusail/configs/detumble_pre.toml"])
    assert code == 2 and err.startswith("error: SOURCE: concept: 'cnusail' has no structure (concepts with one: "), err
    (tmp_path / "x.stl").write_text("solid")
    code, _, err = _run(capsys, ["modes", str(tmp_path / "x.stl")])
    assert code == 2 and err.startswith("error: SOURCE:") and ".stl" in err, err
    code, _, err = _run(capsys, ["modes", str(tmp_path / "missing.toml")])
    assert code == 2 and err.startswith("error: SOURCE: no such file"), err
    meshio.write(tmp_path / "bare.msh", meshio.Mesh(np.eye(3), [("line", np.array([[0, 1], [1, 2]]))]), "gmsh22")
    code, out, err = _run(capsys, ["modes", str(tmp_path / "bare.msh")])
    assert code == 2 and err.startswith("error: SOURCE:") and "write_structure" in err and out == "", err
    tip_mass = np.zeros(N_EL + 1)
    tip_mass[-1] = 2.0
    massless = dataclasses.replace(boom(clamped=True, linear_density=0.0), node_mass_kg=tip_mass)
    write_structure(massless, tmp_path / "b.toml")
    code, _, err = _run(capsys, ["modes", str(tmp_path / "b.toml"), "--count", "5"])
    assert code == 2 and err.startswith("error: --count: only 3 finite-frequency modes exist"), err
    code, _, err = _run(capsys, ["modes", str(tmp_path / "x.stl"), "--count", "0"])
    assert code == 2 and err.startswith("error: --count"), err
    config = "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml"
    code, _, err = _run(capsys, ["modes", config, "--plot", "/"])
    assert code == 2 and err.startswith("error: --plot"), err


def test_a_string_under_tension_has_the_transverse_stiffness_of_its_tension() -> None:
    """A mass between two prestrained cables (ends held): transverse ω² = 2N/(l m) with the
    tension N = EA (l/l0 − 1) (geometric stiffness), axial ω² = 2 EA/(l0 m); compressed cables
    are slack and hold nothing (three zero modes)."""
    import dataclasses

    from magsail_mj.structure.model import Members, Structure

    l_m, EA, m, eps = 2.0, 1.0e4, 0.5, 1e-3
    positions = np.array([[0.0, 0.0, 0.0], [l_m, 0.0, 0.0], [2 * l_m, 0.0, 0.0]])
    fixed = np.zeros((3, 6), bool)
    fixed[[0, 2], :3] = True
    members = Members.build([[0, 1], [1, 2]], positions_m=positions, kind="cable", EA_N=EA, prestrain=eps)
    string = Structure(
        name="string", positions_m=positions, node_mass_kg=np.array([1.0, m, 1.0]), members=members, fixed_dofs=fixed
    )
    omega2 = (2 * np.pi * structure_modes(string, k=3).frequencies_Hz) ** 2
    l0 = l_m / (1 + eps)
    tension = EA * (l_m / l0 - 1.0)
    np.testing.assert_allclose(omega2, [2 * tension / (l_m * m)] * 2 + [2 * EA / (l0 * m)], rtol=1e-9)
    slack = dataclasses.replace(
        string, members=Members.build([[0, 1], [1, 2]], positions_m=positions, kind="cable", EA_N=EA, prestrain=-eps)
    )
    assert structure_modes(slack, k=3).n_zero == 3
