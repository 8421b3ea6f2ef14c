"""Struts as 1-D flex edges (``magsail_mj.structure.mjcf``, "Flex struts"): MuJoCo's edge spring
against the analytic two-body oscillation, the flex build against the tendon build (trajectories
equal to rounding under Euler and RK4, over random small trusses), which struts qualify, the model
index's edges, MuJoCo's energy, the ``"auto"`` policy and refused options."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from magsail_mj.structure import mjcf
from magsail_mj.structure.generators import square_plate_lattice
from magsail_mj.structure.mjcf import StructureModelIndex, build_structure_spec, flex_struts
from magsail_mj.structure.model import MEMBER_KINDS, Members, Structure


def _two_nodes(*, EA_N: float, damping_Ns_m: float = 0.0) -> Structure:
    positions = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    members = Members.build([[0, 1]], positions_m=positions, EA_N=EA_N, damping_Ns_m=damping_Ns_m)
    return Structure("pair", positions, np.array([1.0, 3.0]), members)


def _truss(seed: int, n_nodes: int) -> Structure:
    """Random nodes in a unit cube joined by the struts of a chain plus random chords, with a few
    distinct (EA, c) pairs (several flexes)."""
    rng = np.random.default_rng(seed)
    positions = rng.uniform(-1.0, 1.0, (n_nodes, 3))
    chain = np.column_stack([np.arange(n_nodes - 1), np.arange(1, n_nodes)])
    chords = rng.integers(0, n_nodes, (2 * n_nodes, 2))
    chords = chords[chords[:, 0] != chords[:, 1]]
    ends = np.unique(np.sort(np.vstack([chain, chords]), axis=1), axis=0)
    choice = rng.integers(0, 3, len(ends))
    members = Members.build(
        ends,
        positions_m=positions,
        EA_N=np.array([1.0e3, 2.0e3, 1.0e3])[choice],
        damping_Ns_m=np.array([0.5, 0.5, 0.0])[choice],
    )
    return Structure("truss", positions, rng.uniform(0.5, 2.0, n_nodes), members)


def _run(structure: Structure, *, elements: str, integrator: str, steps: int, **options) -> np.ndarray:
    model = build_structure_spec(
        structure, timestep_s=1e-3, integrator=integrator, strut_elements=elements, **options
    ).compile()
    data = mujoco.MjData(model)
    data.qvel[:] = 0.3 * np.random.default_rng(7).standard_normal(model.nv)
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return np.concatenate([data.qpos, data.qvel])


def test_edge_spring_oscillates_as_the_two_body_analytic() -> None:
    """Two free nodes (1 kg, 3 kg) on a flex strut ``k = EA/l0``, stretched by ``A``: the
    extension is ``A cos ωt`` with ``ω² = k (1/m₁ + 1/m₂)`` (reduced mass); RK4 at ``ω h = 0.01``
    over two periods stays within 1e-8 ``A`` (its phase error ``(ωh)⁴ ωt / 120`` is ~1e-11 A),
    and the passive force at the start is ``−k A`` on the far node exactly to rounding."""
    EA = 400.0
    structure = _two_nodes(EA_N=EA)
    k = EA / 2.0
    omega = np.sqrt(k * (1.0 / 1.0 + 1.0 / 3.0))
    h = 0.01 / omega
    model = build_structure_spec(structure, timestep_s=h, integrator="RK4", strut_elements="flex").compile()
    assert model.ntendon == 0 and model.nflexedge == 1
    data = mujoco.MjData(model)
    amplitude = 1e-3
    data.qpos[3] = amplitude  # node 1's x slide
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.qfrc_passive[[0, 3]], [k * amplitude, -k * amplitude], rtol=1e-12)
    steps = int(round(2 * 2 * np.pi / omega / h))
    extension = np.empty(steps)
    for s in range(steps):
        mujoco.mj_step(model, data)
        extension[s] = data.qpos[3] - data.qpos[0]
    t = h * np.arange(1, steps + 1)
    assert np.abs(extension - amplitude * np.cos(omega * t)).max() < 1e-8 * amplitude


def test_edge_damping_acts_on_the_length_rate_only() -> None:
    """The dashpot is ``−c L̇`` along the edge: a transverse velocity (no length change) gets no
    force, an axial one ``−c v`` (exact to rounding)."""
    c = 3.0
    model = build_structure_spec(
        _two_nodes(EA_N=100.0, damping_Ns_m=c), timestep_s=1e-3, integrator="Euler", strut_elements="flex"
    ).compile()
    data = mujoco.MjData(model)
    data.qvel[:] = [0.0, 0.0, 0.0, 0.5, 0.7, -0.2]
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.qfrc_passive, [c * 0.5, 0, 0, -c * 0.5, 0, 0], rtol=1e-12, atol=1e-15)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31 - 1), n_nodes=st.integers(3, 12), integrator=st.sampled_from(["Euler", "RK4"]))
def test_flex_build_equals_the_tendon_build(seed: int, n_nodes: int, integrator: str) -> None:
    """Random small trusses (a chain and random chords, three (EA, c) groups, two of them damped):
    200 steps of the flex build and of the tendon build give the same ``qpos``, ``qvel`` to
    1e-12 of the largest (the same law ``−k (L − L0) − c L̇`` through the same edge Jacobian;
    they differ by rounding only: ``L0`` is MuJoCo's reference length, not the member table's,
    and the forces are summed in another order; a different law, e.g. the damping on one end's
    velocity alone or ``k`` off by 1e-9, fails by orders more)."""
    structure = _truss(seed, n_nodes)
    flex = _run(structure, elements="flex", integrator=integrator, steps=200)
    tendon = _run(structure, elements="tendons", integrator=integrator, steps=200)
    assert np.abs(flex - tendon).max() <= 1e-12 * np.abs(tendon).max()


def test_implicitfast_flex_damping_is_explicit() -> None:
    """Under ``implicitfast`` an undamped truss moves the same (to 1e-12); a damped one differs (MuJoCo
    integrates tendon damping implicitly, flex edge damping explicitly), by less than the step's
    damping term ``(c h / m)`` relative to the motion."""
    structure = _truss(3, 8)
    undamped = dataclasses.replace(
        structure, members=dataclasses.replace(structure.members, damping_Ns_m=np.zeros(len(structure.members)))
    )
    runs = [_run(undamped, elements=e, integrator="implicitfast", steps=100) for e in ("flex", "tendons")]
    assert np.abs(runs[0] - runs[1]).max() <= 1e-12 * np.abs(runs[1]).max()
    runs = [_run(structure, elements=e, integrator="implicitfast", steps=100) for e in ("flex", "tendons")]
    assert np.abs(runs[0] - runs[1]).max() > 1e-9 * np.abs(runs[1]).max()
    assert np.abs(runs[0] - runs[1]).max() < 0.05 * np.abs(runs[1]).max()


def test_which_struts_qualify_and_the_index() -> None:
    """Cables, prestrained struts, a second strut between the same two nodes and struts touching
    a beam node stay tendons; the rest are flex edges, which :class:`StructureModelIndex` finds
    by their end nodes: ``flexedge_length`` equals the member lengths after a random
    displacement (1e-14 relative)."""
    positions = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.2], [2, 0, 0], [2, 1, 0]], dtype=float)
    kinds = ["strut", "strut", "cable", "strut", "strut", "strut", "beam", "strut", "strut"]
    ends = [[0, 1], [1, 2], [2, 3], [0, 3], [1, 3], [1, 3], [4, 5], [1, 4], [3, 5]]
    members = Members.build(
        ends,
        positions_m=positions,
        kind=np.array([MEMBER_KINDS.index(k) for k in kinds]),
        EA_N=1.0e3,
        EI_Nm2=np.array([0, 0, 0, 0, 0, 0, 10.0, 0, 0]),
        GJ_Nm2=np.array([0, 0, 0, 0, 0, 0, 10.0, 0, 0]),
        prestrain=np.array([0, 0, 1e-3, 1e-3, 0, 0, 0, 0, 0]),
    )
    structure = Structure("mixed", positions, np.ones(6), members)
    expected = np.array([True, True, False, False, False, False, False, False, False])
    np.testing.assert_array_equal(flex_struts(structure), expected)
    model = build_structure_spec(structure, timestep_s=1e-3, integrator="RK4", strut_elements="flex").compile()
    index = StructureModelIndex.from_model(model, structure)
    np.testing.assert_array_equal(index.member_flex_edge >= 0, expected)
    np.testing.assert_array_equal(index.member_tendon >= 0, ~expected & (members.kind != MEMBER_KINDS.index("beam")))
    assert model.nflexedge == 2 and model.ntendon == 6
    assert np.all(model.flex_contype == 0) and np.all(model.flex_conaffinity == 0)
    assert np.all(model.flex_selfcollide == mujoco.mjtFlexSelf.mjFLEXSELF_NONE)
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0 + 0.05 * np.random.default_rng(2).standard_normal(model.nq)
    mujoco.mj_forward(model, data)
    lengths = index.member_lengths_m(data, structure)
    flexed = np.flatnonzero(expected)
    np.testing.assert_allclose(data.flexedge_length[index.member_flex_edge[flexed]], lengths[flexed], rtol=1e-14)


def test_mujoco_energy_holds_the_edge_springs() -> None:
    """MuJoCo's potential energy of a flex-built truss is ``Σ ½ k (L − l0)²`` of its struts
    computed from the node positions (1e-12 relative)."""
    structure = _truss(5, 9)
    spec = build_structure_spec(structure, timestep_s=1e-3, integrator="RK4", strut_elements="flex")
    spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    model = spec.compile()
    index = StructureModelIndex.from_model(model, structure)
    assert np.all(index.member_flex_edge >= 0)
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0 + 0.02 * np.random.default_rng(4).standard_normal(model.nq)
    mujoco.mj_forward(model, data)
    stretch = index.member_lengths_m(data, structure) - structure.members.rest_length_m
    expected = 0.5 * float(structure.members.stiffness_N_m @ stretch**2)
    np.testing.assert_allclose(data.energy[0], expected, rtol=1e-12)


def test_auto_uses_flex_for_large_models_under_explicit_integrators(monkeypatch) -> None:
    """``"auto"``: a small plate keeps its tendons (``ntendon · nv`` far below the threshold);
    with the threshold lowered under it, ``Euler`` and ``RK4`` build flexes and
    ``implicitfast`` keeps tendons."""
    plate = square_plate_lattice(units=3, side_m=10.0, EA_N=1.0e5, total_mass_kg=10.0, zeta_strut=0.01)
    model = build_structure_spec(plate, timestep_s=1e-3, integrator="RK4").compile()
    assert model.nflex == 0 and model.ntendon == plate.n_members
    assert model.ntendon * model.nv < mjcf.FLEX_AUTO_TENDON_DOFS
    monkeypatch.setattr(mjcf, "FLEX_AUTO_TENDON_DOFS", float(model.ntendon * model.nv - 1))
    for integrator, flexes in (("Euler", True), ("RK4", True), ("implicitfast", False)):
        built = build_structure_spec(plate, timestep_s=1e-3, integrator=integrator).compile()
        assert (built.nflexedge == plate.n_members and built.ntendon == 0) == flexes, integrator
        assert (built.nflex == 0) == (not flexes), integrator


def test_bad_strut_elements_is_refused() -> None:
    with pytest.raises(ValueError, match="strut_elements: must be one of .* got 'rods'"):
        build_structure_spec(_two_nodes(EA_N=1.0), timestep_s=1e-3, integrator="RK4", strut_elements="rods")
