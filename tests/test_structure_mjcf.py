"""MuJoCo model of any structure (``magsail_mj.structure.mjcf``): struts as the truss builder's
tendons, tension-only cables, beams as joint chains against Euler–Bernoulli, rigid parts, panels
drawn by a skin, the model index.

Frequencies come from MuJoCo's own linearisation: ``mjd_transitionFD`` (central differences) of
one semi-implicit Euler step of the undamped model at rest, ``v⁺ = v + h q̈(q, v)``, whose block
``∂v⁺/∂q = −h M⁻¹K`` gives ``ω²`` as the eigenvalues of ``M⁻¹K`` (no time-step error).
"""

from __future__ import annotations

import warnings

import mujoco
import numpy as np
import pytest
from scipy import linalg as scipy_linalg
from scipy.spatial.transform import Rotation

from magsail_mj.lattice.geometry import make_lattice
from magsail_mj.lattice.mjcf import TrussModelOptions, build_truss_spec
from magsail_mj.render import backend
from magsail_mj.structure.beams import body_layout
from magsail_mj.structure.generators import square_plate_lattice
from magsail_mj.structure.mjcf import StructureModelIndex, build_structure_spec
from magsail_mj.structure.model import MEMBER_KINDS, Members, Panels, RigidPart, Structure, StructureError
from magsail_mj.structure.modes import structure_modes
from tests.conftest import small_sail

BETA1_L = 1.8751040687119611  # first root of cos βL cosh βL = −1 (cantilever)
BETA2_L = 4.6940911329741745


def _compiled(structure: Structure, **options) -> tuple[mujoco.MjModel, StructureModelIndex]:
    options = {"timestep_s": 1e-4, "integrator": "Euler", **options}
    model = build_structure_spec(structure, **options).compile()
    return model, StructureModelIndex.from_model(model, structure)


def _static(model: mujoco.MjModel, body: int, wrench: np.ndarray) -> mujoco.MjData:
    """Equilibrium under ``wrench`` (force, torque at the body's centre of mass): Newton on
    MuJoCo's generalised force ``qfrc_smooth(q) = 0`` (``qvel = 0``: no bias), Jacobian by central
    differences (the model has only hinges and slides, ``nq = nv``)."""
    data = mujoco.MjData(model)
    data.xfrc_applied[body] = wrench

    def residual(q: np.ndarray) -> np.ndarray:
        data.qpos[:] = q
        mujoco.mj_forward(model, data)
        return data.qfrc_smooth.copy()

    q = model.qpos0.copy()
    step = 1e-7 * np.eye(model.nq)
    for _ in range(3):
        jacobian = np.column_stack([(residual(q + e) - residual(q - e)) / 2e-7 for e in step])
        q = q - np.linalg.solve(jacobian, residual(q))
    scale = np.abs(wrench).max()
    assert np.abs(residual(q)).max() < 1e-10 * scale
    return data


def _frequencies_rad_s(model: mujoco.MjModel) -> np.ndarray:
    """The ``nv`` ascending undamped angular frequencies of MuJoCo's linearisation about ``qpos0``
    (module docstring); zero modes clipped at 0."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    A = np.zeros((2 * model.nv, 2 * model.nv))
    mujoco.mjd_transitionFD(model, data, 1e-6, True, A, None, None, None)
    omega2 = np.linalg.eigvals(-A[model.nv :, : model.nv] / model.opt.timestep).real
    return np.sqrt(np.sort(np.maximum(omega2, 0.0)))


# --------------------------------------------------------------------------- struts: the truss model


@pytest.mark.parametrize("diagonals", ["parity", "X"])
def test_struts_compile_to_the_truss_model(diagonals: str) -> None:
    """A structure of the lattice's nodes and struts gives the ``MjModel`` of ``build_truss_spec``:
    every array of the model (body_pos/mass/inertia, jnt_*, dof_*, tendon_*, wrap_*, site_*,
    geom_*, names, …), the options and the XML are identical, with clamped and partly fixed
    nodes and node damping."""
    lat = make_lattice(units=3, side_m=10.0, diagonals=diagonals)
    rng = np.random.default_rng(3)
    masses = rng.uniform(0.1, 1.0, lat.n_nodes)
    members = Members.build(
        lat.struts,
        positions_m=lat.nodes,
        EA_N=rng.uniform(1.0, 5.0, lat.n_struts),
        damping_Ns_m=rng.uniform(0.0, 1.0, lat.n_struts),
    )
    clamped = (0, 5, 7)
    fixed = np.zeros((lat.n_nodes, 6), dtype=bool)
    fixed[list(clamped)] = True
    structure = Structure(name="s", positions_m=lat.nodes, node_mass_kg=masses, members=members, fixed_dofs=fixed)
    a = lat.cube_edge_m
    common = dict(timestep_s=0.01, integrator="implicit", solver_tolerance=1e-9, name="lattice")
    truss = build_truss_spec(
        lat,
        masses=masses,
        stiffness=members.stiffness_N_m,
        damping=members.damping_Ns_m,
        options=TrussModelOptions(**common, fixed_nodes=clamped, node_damping_1_s=0.3),
    )
    spec = build_structure_spec(
        structure, **common, node_damping_1_s=0.3, node_radius_m=0.04 * a, member_width_m=0.015 * a
    )
    assert spec.to_xml() == truss.to_xml()
    expected, model = truss.compile(), spec.compile()
    arrays = [k for k in dir(expected) if not k.startswith("_") and isinstance(getattr(expected, k), np.ndarray)]
    assert len(arrays) > 150 and {"body_pos", "jnt_stiffness", "tendon_lengthspring", "wrap_objid"} <= set(arrays)
    differ = [k for k in arrays if not np.array_equal(getattr(model, k), getattr(expected, k), equal_nan=True)]
    assert differ == []
    for field in ("timestep", "integrator", "tolerance", "gravity", "disableflags"):
        assert np.array_equal(getattr(model.opt, field), getattr(expected.opt, field)), field
    assert model.stat.extent == expected.stat.extent
    assert model.nv == 3 * (lat.n_nodes - len(clamped))


@pytest.mark.parametrize("diagonals", ["parity", "X"])
def test_generated_plate_compiles_to_the_shipped_truss_model(diagonals: str) -> None:
    """``square_plate_lattice`` through this builder gives the XML of ``build_truss_spec`` with the
    structure's lumped masses, spring constants and dashpots (central masses included)."""
    structure = square_plate_lattice(
        units=3, side_m=10.0, diagonals=diagonals, EA_N=3.0, total_mass_kg=4.0, central_fraction=0.3, zeta_strut=0.05
    )
    lat = make_lattice(units=3, side_m=10.0, diagonals=diagonals)
    a = lat.cube_edge_m
    truss = build_truss_spec(
        lat,
        masses=structure.lumped_masses(),
        stiffness=structure.members.stiffness_N_m,
        damping=structure.members.damping_Ns_m,
        options=TrussModelOptions(timestep_s=0.05, integrator="RK4", name="plate"),
    )
    spec = build_structure_spec(
        structure, timestep_s=0.05, integrator="RK4", name="plate", node_radius_m=0.04 * a, member_width_m=0.015 * a
    )
    assert spec.to_xml() == truss.to_xml()


# --------------------------------------------------------------------------- cables


def _pair(kind: str, *, damping: float = 0.0) -> Structure:
    """Node 0 clamped, node 1 free at 1 m along x, one member of EA = 50 N."""
    positions = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    members = Members.build([[0, 1]], positions_m=positions, kind=kind, EA_N=50.0, damping_Ns_m=damping)
    fixed = np.zeros((2, 6), dtype=bool)
    fixed[0] = True
    return Structure(name=kind, positions_m=positions, node_mass_kg=np.ones(2), members=members, fixed_dofs=fixed)


def _tension_N(model: mujoco.MjModel, length_m: float, speed_m_s: float) -> float:
    """Tension of the member of :func:`_pair` at ``length_m`` while lengthening at ``speed_m_s``:
    minus the passive force on node 1 along the member (positive: it pulls node 1 back)."""
    data = mujoco.MjData(model)
    data.qpos[0] = length_m - 1.0
    data.qvel[0] = speed_m_s
    mujoco.mj_forward(model, data)
    return -float(data.qfrc_passive[0])


def test_cable_pulls_when_stretched_and_never_pushes() -> None:
    """Tension ``k (l − l0)`` above the rest length, exactly 0 at or below it whatever the speed
    (``springlength = [0, l0]``, no dashpot); the same member as a strut pushes when compressed."""
    cable, _ = _compiled(_pair("cable"))
    strut, _ = _compiled(_pair("strut"))
    assert np.array_equal(cable.tendon_lengthspring[0], [0.0, 1.0])
    lengths = np.linspace(0.4, 1.6, 25)
    for speed in (-3.0, 0.0, 3.0):
        tension = np.array([_tension_N(cable, length, speed) for length in lengths])
        assert np.all(tension >= 0.0)
        np.testing.assert_allclose(tension, 50.0 * np.maximum(lengths - 1.0, 0.0), rtol=1e-12, atol=0.0)
    assert _tension_N(strut, 0.8, 0.0) == pytest.approx(-10.0, rel=1e-12)


def test_damped_cable_is_refused() -> None:
    with pytest.raises(StructureError, match=r"members\[0\]\.damping_Ns_m: a cable carries no dashpot"):
        build_structure_spec(_pair("cable", damping=0.2), timestep_s=0.01, integrator="RK4")


# --------------------------------------------------------------------------- beams


N_SEG, L_M, MU_KG_M, EA_N, GJ_NM2 = 20, 10.0, 1.0, 1.0e6, 800.0
EI_NM2 = (1000.0, 1500.0)  # plane 1 (deflection along local y), plane 2 (along local z)
V_DIR = np.array([0.0, 1.0, 1.0]) / np.sqrt(2.0)  # section axis 1: local y


def _boom(*, n: int = N_SEG, start: int = 0, offset=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, Members]:
    """A straight boom along x from ``offset``: ``n + 1`` nodes numbered from ``start``."""
    positions = np.column_stack([np.linspace(0.0, L_M, n + 1), np.zeros(n + 1), np.zeros(n + 1)]) + offset
    ends = start + np.column_stack([np.arange(n), np.arange(1, n + 1)])
    all_positions = np.zeros((start + n + 1, 3))
    all_positions[start:] = positions
    members = Members.build(
        ends,
        positions_m=all_positions,
        kind="beam",
        EA_N=EA_N,
        EI_Nm2=np.tile(EI_NM2, (n, 1)),
        GJ_Nm2=GJ_NM2,
        linear_density_kg_m=MU_KG_M,
        orientation=np.tile(V_DIR, (n, 1)),
    )
    return positions, members


def _cantilever() -> Structure:
    positions, members = _boom()
    fixed = np.zeros((N_SEG + 1, 6), dtype=bool)
    fixed[0] = True
    return Structure(
        name="boom", positions_m=positions, node_mass_kg=np.zeros(N_SEG + 1), members=members, fixed_dofs=fixed
    )


@pytest.fixture(scope="module")
def cantilever() -> tuple[Structure, mujoco.MjModel, StructureModelIndex]:
    structure = _cantilever()
    model, index = _compiled(structure, node_radius_m=0.01)
    return structure, model, index


def test_cantilever_layout(cantilever) -> None:
    """Welded root, then one body per node hanging from the previous one by four joints."""
    structure, model, index = cantilever
    assert model.nv == model.nq == 4 * N_SEG
    assert model.body_jntnum[index.node_body[0]] == 0
    assert np.array_equal(model.body_parentid[index.node_body[1:]], index.node_body[:-1])
    assert np.all(index.beam_qposadr == 4 * np.arange(N_SEG)[:, None] + np.arange(4))


def test_cantilever_static_bending_torsion_and_stretch(cantilever) -> None:
    """Tip loads on the 20-beam cantilever: deflection in each bending plane vs ``P L³/(3 EI)``
    (Euler–Bernoulli) within 1 %, and equal to the chain's midpoint-rule value
    ``P L³/(3 EI) (1 − 1/(4N²))`` (−0.0625 %) to 1e-6; twist ``T L / GJ`` and stretch ``F L / EA``
    exact to 1e-6 (springs in series; loads small enough that geometric nonlinearity is < 1e-8)."""
    structure, model, index = cantilever
    frame_y = V_DIR
    frame_z = np.cross([1.0, 0.0, 0.0], V_DIR)
    tip = index.node_body[N_SEG]
    P = 1e-3
    for direction, EI in ((frame_y, EI_NM2[0]), (frame_z, EI_NM2[1])):
        data = _static(model, tip, np.concatenate([P * direction, np.zeros(3)]))
        deflection = float(index.node_positions(data)[N_SEG] @ direction)
        euler_bernoulli = P * L_M**3 / (3.0 * EI)
        assert abs(deflection / euler_bernoulli - 1.0) <= 0.01
        assert deflection / euler_bernoulli == pytest.approx(1.0 - 1.0 / (4.0 * N_SEG**2), abs=1e-6)
    T = 1e-3
    data = _static(model, tip, np.array([0.0, 0.0, 0.0, T, 0.0, 0.0]))
    twist = Rotation.from_matrix(data.site_xmat[index.node_site[N_SEG]].reshape(3, 3)).as_rotvec()[0]
    assert twist == pytest.approx(T * L_M / GJ_NM2, rel=1e-6)
    F = 1.0
    data = _static(model, tip, np.array([F, 0.0, 0.0, 0.0, 0.0, 0.0]))
    assert index.node_positions(data)[N_SEG, 0] - L_M == pytest.approx(F * L_M / EA_N, rel=1e-6)


def test_cantilever_bending_frequencies(cantilever) -> None:
    """First and second bending frequencies of each plane from MuJoCo's linearisation vs
    Euler–Bernoulli ``(β_k L)² √(EI / (ρA L⁴))`` within 1 % (measured −0.081 % and −0.16 % at 20
    beams, both planes; the nodes carry the lumped HRZ rotary inertia)."""
    _, model, _ = cantilever
    omega = _frequencies_rad_s(model)
    for beta_L, first in ((BETA1_L, 0), (BETA2_L, 2)):
        expected = sorted(beta_L**2 * np.sqrt(EI / (MU_KG_M * L_M**4)) for EI in EI_NM2)
        np.testing.assert_allclose(omega[[first, first + 1]], expected, rtol=0.01)
    assert omega[0] / (BETA1_L**2 * np.sqrt(EI_NM2[0] / (MU_KG_M * L_M**4))) - 1.0 == pytest.approx(-8.1e-4, abs=1e-4)


def _peaks(t_s: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Times and values of the positive local maxima of ``y(t)`` (parabola through each sample
    maximum and its neighbours; uniform ``t``)."""
    i = 1 + np.flatnonzero((y[1:-1] > y[:-2]) & (y[1:-1] >= y[2:]) & (y[1:-1] > 0))
    a, b, c = y[i - 1], y[i], y[i + 1]
    shift = 0.5 * (a - c) / (a - 2.0 * b + c)
    return t_s[i] + shift * (t_s[1] - t_s[0]), b - 0.25 * (a - c) * shift


def test_damped_cantilever_decays_at_the_stiffness_proportional_ratio() -> None:
    """A 10-beam cantilever with the member damping ``c`` (``β = c l0 / EA`` = 0.036 s): every
    joint's damping is ``β`` times its stiffness (the axial slide ``c``, the twist and bending hinges
    ``β GJ/l0``, ``β EI/l0``), so MuJoCo's damping matrix is ``β K`` and each mode decays with
    ``ζ = β ω / 2``. Released from MuJoCo's own first bending mode (10⁻⁴ of it: linear), the
    modal coordinate ``φᵀ M (q − q0)`` rings with the decay rate ``σ`` and damped frequency ``ω_d``
    of its peaks; the measured ``ζ = σ / √(σ² + ω_d²)`` (0.02) equals ``β ω_n / 2`` within 10⁻³
    (Euler's implicit damping shifts it by at most ``ζ ω h`` = 2·10⁻⁵; measured 1·10⁻⁷), and
    ``ω_n`` is the first frequency of the modal analysis within 1 % (the hinge chain's
    discretisation; measured −0.27 %), so the modal analysis' ``β ω / 2`` predicts the decay.
    Without the hinges' damping the bending mode would not decay at all (the axial slide does not
    move in it)."""
    n, EA, beta = 10, 1.0e4, 0.036
    positions = np.column_stack([np.linspace(0.0, L_M, n + 1), np.zeros(n + 1), np.zeros(n + 1)])
    l0 = L_M / n
    members = Members.build(
        np.column_stack([np.arange(n), np.arange(1, n + 1)]),
        positions_m=positions,
        kind="beam",
        EA_N=EA,
        EI_Nm2=np.tile(EI_NM2, (n, 1)),
        GJ_Nm2=GJ_NM2,
        linear_density_kg_m=MU_KG_M,
        damping_Ns_m=beta * EA / l0,
        orientation=np.tile(V_DIR, (n, 1)),
    )
    fixed = np.zeros((n + 1, 6), dtype=bool)
    fixed[0] = True
    structure = Structure(
        name="damped", positions_m=positions, node_mass_kg=np.zeros(n + 1), members=members, fixed_dofs=fixed
    )
    h_s = 1e-3
    model, _ = _compiled(structure, node_radius_m=0.01, timestep_s=h_s)
    stiffness = model.jnt_stiffness[model.dof_jntid]
    np.testing.assert_allclose(model.dof_damping, beta * stiffness, rtol=1e-12)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    mass = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, mass)
    omega2, shapes = scipy_linalg.eigh(np.diag(stiffness), mass)
    phi = shapes[:, 0]
    data.qpos[:] = model.qpos0 + 1e-4 * phi / np.abs(phi).max()
    weights = mass @ phi
    steps = int(10 * 2.0 * np.pi / np.sqrt(omega2[0]) / h_s)
    y = np.empty(steps + 1)
    y[0] = weights @ (data.qpos - model.qpos0)
    for i in range(steps):
        mujoco.mj_step(model, data)
        y[i + 1] = weights @ (data.qpos - model.qpos0)
    t_peak, y_peak = _peaks(h_s * np.arange(steps + 1), y)
    sigma = -np.polyfit(t_peak, np.log(y_peak), 1)[0]
    omega_d = 2.0 * np.pi / np.mean(np.diff(t_peak))
    omega_n = np.hypot(sigma, omega_d)
    assert sigma / omega_n == pytest.approx(0.5 * beta * omega_n, rel=1e-3)
    first_Hz = structure_modes(structure, k=1).frequencies_Hz[0]
    assert omega_n / (2.0 * np.pi * first_Hz) == pytest.approx(1.0, abs=0.01)


def _hub_with_booms(n: int) -> Structure:
    """A free rigid hub (nodes 0–3 at ±0.5 m on x and y) with an ``n``-beam boom of length L along
    +x from node 0 and one along −x from node 1."""
    hub = np.array([[0.5, 0.0, 0.0], [-0.5, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, -0.5, 0.0]])
    steps = np.arange(1, n + 1)[:, None] * (L_M / n) * np.array([1.0, 0.0, 0.0])
    positions = np.vstack([hub, hub[0] + steps, hub[1] - steps])
    right = np.arange(4, 4 + n)
    left = np.arange(4 + n, 4 + 2 * n)
    ends = np.vstack(
        [
            np.column_stack([np.append(0, right[:-1]), right]),
            np.column_stack([np.append(1, left[:-1]), left]),
        ]
    )
    members = Members.build(
        ends,
        positions_m=positions,
        kind="beam",
        EA_N=EA_N,
        EI_Nm2=np.tile(EI_NM2, (2 * n, 1)),
        GJ_Nm2=GJ_NM2,
        linear_density_kg_m=MU_KG_M,
        orientation=np.tile(V_DIR, (2 * n, 1)),
    )
    part = RigidPart("hub", 20.0, np.zeros(3), np.diag([4.0, 5.0, 6.0]), np.arange(4))
    return Structure("hub", positions, np.zeros(len(positions)), members, rigid_parts=(part,))


def test_free_hub_with_booms_matches_the_modal_analysis() -> None:
    """A free rigid hub (free joint) carrying two 20-beam booms: six zero modes, and the lowest
    eight elastic frequencies of MuJoCo's linearisation match ``structure_modes`` (Hermite frame
    elements with consistent mass, within 0.04 % of their 80-beam values) within 1 %; measured
    −0.11 % to −0.22 % (the chain's discretisation error)."""
    n = 20
    structure = _hub_with_booms(n)
    model, index = _compiled(structure, node_radius_m=0.01)
    assert model.nv == 6 + 4 * 2 * n and model.nq == model.nv + 1
    assert model.body_parentid[index.part_body[0]] == 0
    assert np.all(index.node_body[:4] == index.part_body[0])
    omega = _frequencies_rad_s(model)
    assert np.all(omega[:6] < 1e-6 * omega[6])
    reference = structure_modes(structure, k=14, mass="consistent")
    assert reference.n_zero == 6
    np.testing.assert_allclose(omega[6:14], reference.omega_rad_s[6:14], rtol=0.01)


def test_pinned_and_partly_fixed_roots() -> None:
    """A root with fixed translations turns on a ball joint about its node; with one rotation
    fixed too, on two hinges about the world axes; its other nodes hang by beam joints."""
    structure = _cantilever()
    for rotations, joints in ((0, ["ball"]), (1, ["hinge", "hinge"])):
        fixed = np.zeros((N_SEG + 1, 6), dtype=bool)
        fixed[0, :3] = True
        fixed[0, 3:][:rotations] = True
        pinned = Structure(**{**structure.__dict__, "fixed_dofs": fixed})
        model, index = _compiled(pinned)
        root = index.node_body[0]
        types = model.jnt_type[model.body_jntadr[root] : model.body_jntadr[root] + model.body_jntnum[root]]
        assert [mujoco.mjtJoint(t).name[6:].lower() for t in types] == joints
        assert model.nv == 3 - rotations + 4 * N_SEG


def test_free_sail_conserves_energy_and_momentum() -> None:
    """The generated four-boom sail (free rigid hub, four 4-beam booms with EI1 ≠ EI2, membrane
    panels lumped into the nodes), undamped, from random velocities: 1 000 RK4 steps of 0.2 ms
    (``ω_max h ≈ 0.5``) keep the total energy (kinetic + joint springs) to 1e-7 relative
    (measured 6e-10, RK4's truncation error), and the linear and angular momentum about the
    origin to 1e-10 of their values (measured 3e-12 and 1e-13, round-off over 1 000 steps): the
    springs derive from a potential and every internal force has its reaction."""
    structure = small_sail(n_segments=4)
    spec = build_structure_spec(structure, timestep_s=2e-4, integrator="RK4")
    spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    model = spec.compile()
    assert model.nskin == 1
    data = mujoco.MjData(model)
    data.qvel[:] = 0.05 * np.random.default_rng(0).standard_normal(model.nv)

    def invariants() -> tuple[float, np.ndarray, np.ndarray]:
        mujoco.mj_forward(model, data)
        mujoco.mj_subtreeVel(model, data)
        return data.energy.sum(), data.subtree_linvel[0].copy(), data.subtree_angmom[0].copy()

    energy, velocity, momentum = invariants()
    mujoco.mj_step(model, data, 1000)
    energy_1, velocity_1, momentum_1 = invariants()
    assert abs(energy_1 / energy - 1.0) < 1e-7
    assert np.abs(velocity_1 - velocity).max() < 1e-10 * np.abs(velocity).max()
    assert np.abs(momentum_1 - momentum).max() < 1e-10 * np.abs(momentum).max()


@pytest.mark.parametrize(
    "case, message",
    [
        ("massless_ring", r"members\[\d\] \(beam, nodes \d-\d\): it closes a cycle of beams.*both end nodes have none"),
        ("two_fixed", r"fixed_dofs: nodes \[0, 2\] are in one tree .* other than all six or the three translations"),
        ("damping", r"node_damping_1_s: applies to particles only"),
    ],
)
def test_unmodellable_beam_networks_are_refused(case: str, message: str) -> None:
    """What the builder cannot model: a cycle of massless beams between massless nodes (the body
    that closes it takes a share of an end node's mass), a tree held at two nodes by constraints
    that are neither all six components nor the three translations, node damping in a chain.
    (Closed cycles and trees held at several places otherwise build: ``test_structure_hoop.py``.)"""
    positions = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    members = Members.build([[0, 1], [1, 2]], positions_m=positions, kind="beam", EA_N=1.0, EI_Nm2=1.0)
    fixed = np.zeros((3, 6), dtype=bool)
    masses = np.ones(3)
    damping = 0.0
    if case == "massless_ring":
        members = Members.build([[0, 1], [1, 2], [2, 0]], positions_m=positions, kind="beam", EA_N=1.0, EI_Nm2=1.0)
        masses = np.zeros(3)
    if case == "two_fixed":
        fixed[[0, 2], 2] = True
    if case == "damping":
        damping = 0.1
    structure = Structure("s", positions, masses, members, fixed_dofs=fixed)
    with pytest.raises(StructureError, match=message):
        build_structure_spec(structure, timestep_s=0.01, integrator="RK4", node_damping_1_s=damping)


# --------------------------------------------------------------------------- rigid parts, panels, index


def _hub_and_particles(panels: bool = False) -> Structure:
    """A rigid square hub (4 nodes) and 4 particles strutted to it, optionally 4 panels."""
    hub = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    positions = np.vstack([hub, 3.0 * hub + [0.0, 0.0, 0.2]])
    ends = np.array([[0, 4], [1, 5], [2, 6], [3, 7], [4, 5], [5, 6], [6, 7], [7, 4]])
    members = Members.build(ends, positions_m=positions, EA_N=100.0, damping_Ns_m=0.1, linear_density_kg_m=0.05)
    part = RigidPart("bus", 5.0, np.array([0.0, 0.0, -0.1]), np.diag([1.0, 1.0, 1.5]), np.arange(4))
    table = Panels.empty()
    if panels:
        quads = np.array([[0, 4, 5, 1], [1, 5, 6, 2], [2, 6, 7, 3], [3, 7, 4, 0]])
        table = Panels(quads, np.full(4, 0.02), np.tile([0.9, 0.05, 0.05], (4, 1)), np.full(4, 2.2))
    return Structure("hub", positions, np.full(8, 0.3), members, panels=table, rigid_parts=(part,))


def test_rigid_part_body_mass_properties() -> None:
    """The part is one free body holding its nodes (no node bodies); its mass, centre and inertia
    equal ``Structure.mass_properties`` of the part with its nodes' lumped masses, and the whole
    model's mass and centre those of the structure (1e-12)."""
    structure = _hub_and_particles()
    model, index = _compiled(structure)
    part = index.part_body[0]
    assert model.nv == 6 + 3 * 4
    assert model.jnt_type[model.body_jntadr[part]] == mujoco.mjtJoint.mjJNT_FREE
    assert all(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"n{i}") == -1 for i in range(4))
    assert np.all(index.node_body[:4] == part)
    nothing = Members.build(np.zeros((0, 2)), positions_m=structure.positions_m, EA_N=1.0)
    held = Structure(
        "bus", structure.positions_m[:4], structure.lumped_masses()[:4], nothing, rigid_parts=structure.rigid_parts
    )
    mass, com, inertia = held.mass_properties()
    assert model.body_mass[part] == pytest.approx(mass, rel=1e-12)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.xipos[part], com, rtol=0, atol=1e-12)
    R = data.ximat[part].reshape(3, 3)
    np.testing.assert_allclose(R @ np.diag(model.body_inertia[part]) @ R.T, inertia, rtol=0, atol=1e-12)
    total, center, _ = structure.mass_properties()
    np.testing.assert_allclose(data.subtree_com[0], center, rtol=0, atol=1e-12)
    assert model.body_subtreemass[0] == pytest.approx(total, rel=1e-12)


def _render_center(model: mujoco.MjModel, camera: mujoco.MjvCamera) -> np.ndarray:
    """RGB at the centre of a 64 × 64 image of ``model`` at ``qpos0``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        renderer = backend.make_renderer(model, width=64, height=64)
    try:
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        renderer.update_scene(data, camera)
        return renderer.render()[32, 32].astype(int)
    finally:
        renderer.close()


def test_panels_are_drawn_without_changing_the_dynamics() -> None:
    """The skin adds no dof, mass or force (same nq, nv, mass matrix and accelerations in a moving
    state; massless panels, so that the node masses agree); it holds both faces of each triangle;
    and it is drawn: the panel's colour at the centre of a view down onto panel 0."""
    with_panels = _hub_and_particles(panels=True)
    massless = Panels(with_panels.panels.nodes, np.zeros(4), with_panels.panels.reflectivity, np.full(4, 2.2))
    models = [
        build_structure_spec(s, timestep_s=0.01, integrator="RK4").compile()
        for s in (_hub_and_particles(), Structure(**{**with_panels.__dict__, "panels": massless}))
    ]
    bare, model = models
    assert (model.nq, model.nv, model.nskin, bare.nskin) == (bare.nq, bare.nv, 1, 0)
    assert model.skin_vertnum[0] == 2 * 8 and model.skin_facenum[0] == 2 * 8
    states = []
    for m in models:
        rng = np.random.default_rng(0)
        data = mujoco.MjData(m)
        data.qpos[:] = m.qpos0 + 0.05 * rng.standard_normal(m.nq)
        data.qvel[:] = rng.standard_normal(m.nv)
        mujoco.mj_forward(m, data)
        full = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, data, full)
        states.append((full, data.qacc.copy()))
    assert np.array_equal(states[0][0], states[1][0]) and np.array_equal(states[0][1], states[1][1])
    camera = mujoco.MjvCamera()
    camera.lookat[:] = [1.3, 1.3, 0.1]  # the middle of panel 0 (nodes 0, 4, 5, 1)
    camera.distance, camera.elevation, camera.azimuth = 1.0, -90.0, 0.0
    try:
        panel, background = (_render_center(m, camera) for m in (model, bare))
    except backend.GLBackendError as exc:
        pytest.skip(f"no OpenGL backend can create a MuJoCo renderer: {exc}")
    assert panel[0] > panel[2] + 40 and not np.array_equal(panel, background)


def test_index_positions_and_member_lengths() -> None:
    """Node positions from ``qpos`` (vectorised for particles, kinematics otherwise) equal MuJoCo's
    site positions; tendons and beam joints are indexed by member."""
    rng = np.random.default_rng(1)
    lat = make_lattice(units=2, side_m=4.0)
    members = Members.build(
        lat.struts, positions_m=lat.nodes, kind=np.where(np.arange(lat.n_struts) % 3, 0, 1), EA_N=10.0
    )
    fixed = np.zeros((lat.n_nodes, 6), dtype=bool)
    fixed[0, :2] = True
    particles = Structure("p", lat.nodes, np.ones(lat.n_nodes), members, fixed_dofs=fixed)
    cases = [(particles, True), (_cantilever(), False), (_hub_and_particles(), False)]
    for structure, fast in cases:
        model, index = _compiled(structure)
        assert index.particles_only is fast
        qpos = model.qpos0 + 0.01 * rng.standard_normal((2, 3, model.nq))
        positions = index.node_positions_from_qpos(model, qpos)
        data = mujoco.MjData(model)
        data.qpos[:] = qpos[1, 2]
        mujoco.mj_kinematics(model, data)
        np.testing.assert_allclose(positions[1, 2], index.node_positions(data), rtol=0, atol=1e-14)
        mujoco.mj_forward(model, data)
        tendons = index.member_tendon >= 0
        lengths = index.member_lengths_m(data, structure)
        np.testing.assert_allclose(data.ten_length[index.member_tendon[tendons]], lengths[tendons], rtol=1e-14)
        kinds = structure.members.kind
        assert np.array_equal(tendons, kinds != MEMBER_KINDS.index("beam"))
    assert body_layout(particles).order.tolist() == list(range(lat.n_nodes))


def test_balanced_inertias_pass_the_triangle_inequality_after_rounding() -> None:
    """A body inertia corrected to the triangle inequality lands a few ulps inside it, not on it
    (on it, rounding made MuJoCo refuse the 40-segment sail: "A + B >= C"); a valid one is kept."""
    from magsail_mj.structure.mjcf import _balanced

    rng = np.random.default_rng(3)
    rods = (
        rng.uniform(0.1, 10.0, (2000, 1, 1)) * np.diag([0.0, 1.0, 1.0])[None]
        + rng.uniform(1e-9, 1e-6, (2000, 1, 1)) * np.diag([0.0, 0.0, 3.0])[None]
    )
    moments = np.linalg.eigvalsh(_balanced(rods))
    assert np.all(moments[:, 0] + moments[:, 1] > moments[:, 2])
    valid = np.diag([1.0, 2.0, 2.5])[None]
    assert np.array_equal(_balanced(valid), valid)
