"""Modes of prestressed structures about their static equilibrium
(:mod:`magsail_mj.structure.assembly`, "Prestress"): the taut string's closed form, the bow's
equilibrium tension, six zero modes of any free prestressed structure in any orientation (the
100 m sail's config and random cable–strut structures), and a MuJoCo bow ringing at the computed
frequency."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from magsail_mj.structure.assembly import assemble, reference_forces
from magsail_mj.structure.mjcf import build_structure_spec
from magsail_mj.structure.model import MEMBER_KINDS, Members, RigidPart, Structure
from magsail_mj.structure.modes import structure_modes
from magsail_mj.verbs.sources import read_source

SAIL_CONFIG = "magsail_mj/concepts/structure/configs/sail_detumble.toml"


def taut_string(n_masses: int, *, tension_N: float, mass_kg: float, spacing_m: float, EA_N: float) -> Structure:
    """``n_masses`` point masses on a cable of ``n_masses + 1`` segments between two clamped nodes
    along x, the cable prestrained to ``tension_N``."""
    n = n_masses + 2
    positions = np.zeros((n, 3))
    positions[:, 0] = spacing_m * np.arange(n)
    members = Members.build(
        np.stack([np.arange(n - 1), np.arange(1, n)], axis=1),
        positions_m=positions,
        kind="cable",
        EA_N=EA_N,
        prestrain=tension_N / EA_N,
    )
    fixed = np.zeros((n, 6), dtype=bool)
    fixed[[0, -1], :3] = True
    masses = np.full(n, mass_kg)
    return Structure(name="string", positions_m=positions, node_mass_kg=masses, members=members, fixed_dofs=fixed)


def test_taut_string_has_the_discrete_string_frequencies() -> None:
    """A taut string of N = 7 lumped masses m at spacing a under tension T (ends clamped): the
    transverse frequencies are ``f_n = (1/π) √(T/(m a)) sin(nπ / (2(N + 1)))`` in both transverse
    directions and the axial ones the same with ``T`` replaced by ``EA a / l0`` (the segments'
    spring constant times a). The clamped string is in equilibrium at the reference, so the
    closed forms hold to rounding: tolerance 10⁻⁹ (measured 3·10⁻¹⁴)."""
    N, T, m, a, EA = 7, 2.5, 0.3, 0.4, 1.0e3
    string = taut_string(N, tension_N=T, mass_kg=m, spacing_m=a, EA_N=EA)
    result = structure_modes(string, k=3 * N)
    n = np.arange(1, N + 1)
    sine = np.sin(n * np.pi / (2 * (N + 1)))
    l0 = a / (1.0 + T / EA)
    tension = EA * (a / l0 - 1.0)
    transverse = np.sqrt(tension / (m * a)) * sine / np.pi
    axial = np.sqrt(EA / (l0 * m)) * sine / np.pi
    expected = np.sort(np.concatenate([transverse, transverse, axial]))
    assert result.n_zero == 0
    np.testing.assert_allclose(result.frequencies_Hz, expected, rtol=1e-9)
    np.testing.assert_allclose(result.assembly.prestress.force_N, tension, rtol=1e-12)


def bow(*, n_masses: int = 5, prestrain: float = 1e-2, strut_EA_N: float = 2e3, cable_EA_N: float = 1e3) -> Structure:
    """A free bow along x: a strut between its two end nodes (at its rest length) and a prestrained
    cable of ``n_masses + 1`` segments between the same two nodes through ``n_masses`` point
    masses on the line between them."""
    n = n_masses + 2
    length_m = 4.0
    positions = np.zeros((n, 3))
    positions[:, 0] = np.linspace(0.0, length_m, n)
    chain = np.stack([np.arange(n - 1), np.arange(1, n)], axis=1)
    cable = Members.build(chain, positions_m=positions, kind="cable", EA_N=cable_EA_N, prestrain=prestrain)
    strut = Members.build([[0, n - 1]], positions_m=positions, kind="strut", EA_N=strut_EA_N)
    masses = np.full(n, 0.2)
    masses[[0, -1]] = 0.5
    return Structure(
        name="bow",
        positions_m=positions,
        node_mass_kg=masses,
        members=Members.concatenate([cable, strut]),
        fixed_dofs=np.zeros((n, 6), dtype=bool),
    )


def test_bow_equilibrium_tension_and_zero_modes() -> None:
    """The bow's prestress equilibrium: the cable of series stiffness ``k_c`` pulled to ``N0`` at the
    reference shortens the strut of stiffness ``k_s`` until ``T = N0 k_s / (k_s + k_c)`` in every
    segment and ``−T`` in the strut (linear springs on one line: exact; tolerance 10⁻⁹, measured
    10⁻¹⁵). The free bow has five zero modes (point masses on a line: the turn about the line moves
    nothing); with ``N0`` in the cable and nothing in the strut, as the reference shape has them,
    the turns about y and z would be stiffened by the cable's pull on the strut's ends."""
    structure = bow()
    members = structure.members
    cables = members.of_kind("cable")
    N0 = reference_forces(structure)[cables[0]]
    k_c = 1.0 / np.sum(1.0 / members.stiffness_N_m[cables])
    k_s = members.stiffness_N_m[members.of_kind("strut")[0]]
    tension = N0 * k_s / (k_s + k_c)
    prestress = assemble(structure).prestress
    np.testing.assert_allclose(prestress.force_N[cables], tension, rtol=1e-9)
    np.testing.assert_allclose(prestress.force_N[members.of_kind("strut")], -tension, rtol=1e-9)
    assert prestress.compressed_cables.size == 0
    result = structure_modes(structure, k=8, solver="dense")
    assert result.n_zero == 5
    assert result.frequencies_Hz[5] > 0


def test_sail_config_has_six_zero_modes() -> None:
    """The 100 m four-boom sail (booms as beams from a rigid hub, a form-found cable net, membrane
    panels): about the prestress equilibrium (the booms in compression, 0.61 to 1.17 N, every
    cable in tension) its three rigid rotations are zero modes with the translations, ``|ω²|`` at
    most 10⁻⁸ of the first elastic mode's (the rounding of the solve; measured 6·10⁻¹²; the
    straight-edged net's tangent stiffness of the reference shape put the rotations at 3.9–4.1
    mHz, ω² a quarter of the first elastic's)."""
    structure, _ = read_source(SAIL_CONFIG)
    result = structure_modes(structure, k=10)
    assert result.n_zero == 6
    first = result.eigenvalues[6]
    assert np.all(np.abs(result.eigenvalues[:6]) <= 1e-8 * first), result.eigenvalues[:6] / first
    beams = structure.members.of_kind("beam")
    force = result.assembly.prestress.force_N
    assert np.all(force[beams] < 0)  # the booms hold the net's pull in compression
    assert result.assembly.prestress.compressed_cables.size == 0
    np.testing.assert_allclose(result.participation.fraction[:6].sum(axis=0), 1.0, rtol=1e-9)


def random_tensile_structure(seed: int, n_nodes: int) -> Structure:
    """``n_nodes`` random nodes joined by every pair (a rigid truss), each member a strut or a cable
    at random, with random stiffness, masses and prestrain (cables 10⁻⁴ to 10⁻³ stretched,
    struts ±10⁻³)."""
    rng = np.random.default_rng(seed)
    positions = rng.uniform(-1.0, 1.0, (n_nodes, 3))
    i, j = np.triu_indices(n_nodes, 1)
    pairs = np.stack([i, j], axis=1)
    m = pairs.shape[0]
    kinds = np.where(rng.random(m) < 0.5, MEMBER_KINDS.index("cable"), MEMBER_KINDS.index("strut"))
    prestrain = np.where(kinds == MEMBER_KINDS.index("cable"), rng.uniform(1e-4, 1e-3, m), rng.uniform(-1e-3, 1e-3, m))
    members = Members.build(
        pairs, positions_m=positions, kind=kinds, EA_N=rng.uniform(500.0, 2000.0, m), prestrain=prestrain
    )
    return Structure(
        name="random",
        positions_m=positions,
        node_mass_kg=rng.uniform(0.5, 2.0, n_nodes),
        members=members,
        fixed_dofs=np.zeros((n_nodes, 6), dtype=bool),
    )


def rotated(structure: Structure, rotation: np.ndarray) -> Structure:
    """``structure`` with its positions turned by ``rotation`` about the origin (rest lengths kept)."""
    return Structure(**{**structure.__dict__, "positions_m": structure.positions_m @ rotation.T})


@settings(max_examples=25, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 2**32 - 1),
    n_nodes=st.integers(4, 7),
    rotation=st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4).filter(lambda q: np.linalg.norm(q) > 0.1),
)
def test_free_prestressed_structure_has_six_zero_modes_in_any_orientation(seed, n_nodes, rotation) -> None:
    """A free cable–strut truss with random prestrain, as given and turned by a random rotation:
    six zero modes (``|ω²|`` at most 10⁻⁹ of the stiffest mode's: the rounding of the
    equilibrium solve and of the eigenproblem; measured 3·10⁻¹⁵; without the equilibrium the
    rotations would have ω² ~ 10⁻⁴ of it, the prestrain) and the same elastic frequencies in
    both orientations (relative 10⁻⁹: rounding)."""
    structure = random_tensile_structure(seed, n_nodes)
    turned = rotated(structure, Rotation.from_quat(rotation).as_matrix())
    n_dof = 3 * n_nodes
    results = [structure_modes(s, k=n_dof, solver="dense") for s in (structure, turned)]
    for result in results:
        top = result.eigenvalues[-1]
        assert result.n_zero == 6
        assert np.all(np.abs(result.eigenvalues[:6]) <= 1e-9 * top), result.eigenvalues[:6] / top
    np.testing.assert_allclose(results[1].frequencies_Hz[6:], results[0].frequencies_Hz[6:], rtol=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_rigid_part_on_a_prestressed_truss_keeps_six_zero_modes(seed: int) -> None:
    """A rigid part holding three nodes of a random prestressed truss, its centre off them, turned
    at random: six zero modes (``|ω²|`` at most 10⁻⁹ of the stiffest mode's; measured 4·10⁻¹⁶ at
    most). The part's finite-rotation term ``Σ sym(g rᵀ) − (g · r) I`` is needed: without it the
    three rotations have ``|ω²|`` of 10⁻⁶ to 7·10⁻⁵ of the stiffest mode's, some negative."""
    rng = np.random.default_rng(100 + seed)
    truss = random_tensile_structure(seed, 7)
    part = RigidPart(
        name="bus",
        mass_kg=2.0,
        center_m=rng.uniform(-0.5, 0.5, 3),
        inertia_kg_m2=np.diag(rng.uniform(0.2, 0.5, 3)),
        nodes=np.array([0, 1, 2]),
    )
    rotation = Rotation.random(random_state=seed).as_matrix()
    turned = Structure(
        **{
            **truss.__dict__,
            "positions_m": truss.positions_m @ rotation.T,
            "rigid_parts": (dataclasses.replace(part, center_m=rotation @ part.center_m),),
        }
    )
    result = structure_modes(turned, k=12, solver="dense")
    assert result.n_zero == 6
    assert np.all(np.abs(result.eigenvalues[:6]) <= 1e-9 * result.eigenvalues[-1])


def zero_crossing_frequency_Hz(t_s: np.ndarray, q: np.ndarray) -> float:
    """Frequency from the first and last of the linearly interpolated zero crossings of ``q(t)``."""
    change = np.flatnonzero(np.sign(q[:-1]) * np.sign(q[1:]) < 0)
    crossings = t_s[change] - q[change] * (t_s[change + 1] - t_s[change]) / (q[change + 1] - q[change])
    return (crossings.size - 1) / (2.0 * (crossings[-1] - crossings[0]))


@pytest.mark.parametrize("mode", [5, 7])
def test_mujoco_bow_rings_at_the_prestressed_frequency(mode: int) -> None:
    """The free bow (prestrain 10⁻⁴) as a MuJoCo model (particles on slide joints, the cable as
    tension-only tendons, the strut a spring tendon), started at the prestress equilibrium (on one
    line the springs are linear in the node coordinates, so the linear equilibrium is MuJoCo's own)
    plus 10⁻⁶ of a segment along a transverse mode, simulated with RK4 at 2 000 steps per period
    (the fastest axial mode is 560 times faster than the first string mode; RK4 is stable to
    ω h = 2.8) for 30 periods. The modal coordinate ``φᵀ M (x − x_eq)`` rings at the computed
    frequency, but for one difference the linear model has by construction: it takes the
    geometric stiffness ``N/l`` at the reference lengths, MuJoCo at the equilibrium's ``l_eq``,
    here shorter by the same fraction (3.3·10⁻⁵) in every member, so a transverse mode (all
    geometric stiffness) rings at ``f √(l / l_eq)``, 1.7·10⁻⁵ above ``f``. Tolerance 2·10⁻⁶ about
    that: RK4's frequency error (ω h)⁴/120 ~ 10⁻¹², the interpolated zero crossings ~10⁻⁹
    (measured 1.0·10⁻⁹ and 1.5·10⁻⁹ from ``f √(l / l_eq)``, 1.67·10⁻⁵ from ``f``). The reference
    tension instead of the equilibrium's would put the string's modes √(N0/T) = 1.22 times
    higher."""
    structure = bow(prestrain=1e-4)
    result = structure_modes(structure, k=mode + 1, solver="dense")
    f_Hz = float(result.frequencies_Hz[mode])
    phi = result.dof_shapes()[:, mode].reshape(-1, 3)
    assert np.abs(phi[:, 0]).max() <= 1e-9 * np.abs(phi).max()  # a transverse (string) mode
    u_eq = result.assembly.prestress.displacement.reshape(-1, 3)
    ends = structure.members.nodes
    length = np.abs(np.diff(structure.positions_m[ends, 0], axis=1))[:, 0]
    length_eq = np.abs(np.diff((structure.positions_m + u_eq)[ends, 0], axis=1))[:, 0]
    shortening = length / length_eq
    assert np.ptp(shortening) <= 1e-9 and shortening[0] - 1.0 > 1e-5  # one fraction for every member
    per_period = 2000
    h_s = 1.0 / (per_period * f_Hz)
    model = build_structure_spec(structure, timestep_s=h_s, integrator="RK4").compile()
    data = mujoco.MjData(model)
    adr = np.array(
        [[model.joint(f"n{i}_{a}").qposadr[0] for a in "xyz"] for i in range(structure.n_nodes)], dtype=np.int64
    )
    data.qpos[adr] = u_eq + 1e-6 * length[0] * phi / np.abs(phi).max()
    weights = structure.lumped_masses()[:, None] * phi
    steps = 30 * per_period
    q = np.empty(steps + 1)
    q[0] = np.sum(weights * (data.qpos[adr] - u_eq))
    for i in range(steps):
        mujoco.mj_step(model, data)
        q[i + 1] = np.sum(weights * (data.qpos[adr] - u_eq))
    measured = zero_crossing_frequency_Hz(h_s * np.arange(steps + 1), q)
    expected = f_Hz * np.sqrt(shortening[0])
    assert measured == pytest.approx(expected, rel=2e-6), (measured / expected - 1, measured / f_Hz - 1)
