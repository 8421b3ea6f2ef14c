"""Closed cycles of beams and trees held at several places (``magsail_mj.structure.beams``,
``magsail_mj.structure.mjcf``): a free ring of beams (the ``hoop`` generator) against the thin
ring's closed forms, a frame of two cells against the assembled modes, beams clamped or pinned at
both ends against Euler–Bernoulli.

Three readings of a MuJoCo model's small vibrations, all about ``qpos0``:

* *constrained*: the stiffness ``K = −∂qfrc_smooth/∂q`` (central differences on the tangent space,
  ``mj_integratePos``) and the mass matrix ``M`` (``mj_fullM``) restricted to the null space ``Z``
  of the equality constraints' Jacobian (``efc_J``): the eigenvalues of ``(ZᵀKZ, ZᵀMZ)`` are the
  modes of the model with its welds exact;
* *MuJoCo's linearisation*: ``mjd_transitionFD`` of one semi-implicit Euler step, whose block
  ``∂v⁺/∂q = −h M⁻¹K_eff`` includes the constraint solver with the welds' ``solref``/``solimp``
  (the constraint modes sit at ``1/τ = 1/(2h)``, far above the structure's);
* *simulated*: the free ring released from a small static deformation, its ringing read off the
  FFT of the node displacements.

The chain of rigid half-members that the builder makes of a beam is exact for straight members
(to the midpoint rule), but a polygon of ``N`` straight chords standing for a circle stiffens its
in-plane bending by ``O((π/N)²)`` (each chord's transverse displacement is tied to its end
rotations' mean, which a curved member does not obey), as does the frame-element assembly by a
smaller constant. The ring's tolerances against the closed forms are therefore
``DISCRETISATION · (π/N)²`` (measured errors in each test's docstring, with their ``N = 48``
values, a quarter of them: second order).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from scipy import linalg

from magsail_mj.concepts.structure.source import model_counts
from magsail_mj.lattice.mjcf import lattice_arena_bytes
from magsail_mj.structure.beams import body_layout, node_rotary_inertia
from magsail_mj.structure.generators import hoop
from magsail_mj.structure.mjcf import (
    CLOSURE_SOLIMP,
    CLOSURE_TIMECONST_STEPS,
    StructureModelIndex,
    build_structure_spec,
    closing_body_name,
)
from magsail_mj.structure.model import Members, RigidPart, Structure
from magsail_mj.structure.modes import structure_modes

R_M, MU_KG_M, GJ_NM2, EA_N = 1.0, 0.1, 0.8, 1.0e4
EI_NM2 = (1.0, 2.0)  # section axis 1 along +z: plane 1 is out of the ring's plane, plane 2 in it
N_SEG = 24
#: the ring's relative tolerance against the closed forms is DISCRETISATION · (π/N)² (module docstring)
DISCRETISATION = 3.0


def _ring(n: int = N_SEG, *, clamp_node: int | None = None) -> Structure:
    ring = hoop(radius_m=R_M, n_segments=n, EA_N=EA_N, EI_Nm2=EI_NM2, GJ_Nm2=GJ_NM2, linear_density_kg_m=MU_KG_M)
    if clamp_node is None:
        return ring
    fixed = np.zeros((n, 6), dtype=bool)
    fixed[clamp_node] = True
    return Structure(**{**ring.__dict__, "fixed_dofs": fixed})


def _closed_form_rad_s(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The thin free ring's in-plane and out-of-plane bending frequencies of ``n`` waves [rad/s]:
    ``ω² = EI/(m R⁴) · n²(n²−1)²/(n²+1)`` in the plane (Hoppe 1871) and
    ``ω² = EI/(m R⁴) · n²(n²−1)²/(n² + EI/GJ)`` out of it (Love 1927; Timoshenko's form
    ``n² + 1 + ν`` is that of a circular section, ``EI/GJ = 1 + ν``), inextensional, without the
    sections' rotary inertia. The frame-element modal analysis of the 24-chord ring falls within
    1.2 % of these; with ``n² + 1 + EI/GJ`` in the out-of-plane denominator it would be 5–10 % off."""
    n = np.asarray(n, dtype=float)
    shape = n * (n**2 - 1)
    in_plane = np.sqrt(EI_NM2[1] / (MU_KG_M * R_M**4)) * shape / np.sqrt(n**2 + 1)
    out_of_plane = np.sqrt(EI_NM2[0] / (MU_KG_M * R_M**4)) * shape / np.sqrt(n**2 + EI_NM2[0] / GJ_NM2)
    return in_plane, out_of_plane


def _tolerance(n_segments: int) -> float:
    return DISCRETISATION * (math.pi / n_segments) ** 2


def _model(structure: Structure, *, timestep_s: float = 1e-4, arena_bytes: int = 0, **options) -> mujoco.MjModel:
    """The Euler model of ``structure``; at least ``arena_bytes`` of arena (``mjd_transitionFD``
    takes ``O(nv²)`` of it, more than a step)."""
    spec = build_structure_spec(structure, timestep_s=timestep_s, integrator="Euler", **options)
    spec.memory = max(spec.memory, arena_bytes)
    return spec.compile()


def _tangent_stiffness(model: mujoco.MjModel, qpos: np.ndarray | None = None) -> np.ndarray:
    """``K = −∂qfrc_smooth/∂q`` at ``qpos`` (default ``qpos0``), ``qvel = 0``, by central
    differences of step 1e-7 on the tangent space."""
    data = mujoco.MjData(model)
    q0 = model.qpos0.copy() if qpos is None else qpos
    K = np.zeros((model.nv, model.nv))
    for i in range(model.nv):
        columns = []
        for sign in (1.0, -1.0):
            data.qpos[:] = q0
            step = np.zeros(model.nv)
            step[i] = sign * 1e-7
            mujoco.mj_integratePos(model, data.qpos, step, 1)
            mujoco.mj_forward(model, data)
            columns.append(data.qfrc_smooth.copy())
        K[:, i] = -(columns[0] - columns[1]) / 2e-7
    return K


def _constraint_jacobian(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """The dense ``(nefc, nv)`` constraint Jacobian of ``data`` (MuJoCo keeps it sparse from 60 dofs)."""
    if not mujoco.mj_isSparse(model):
        return data.efc_J.reshape(data.nefc, model.nv).copy()
    dense = np.zeros((data.nefc, model.nv))
    mujoco.mju_sparse2dense(dense, data.efc_J, data.efc_J_rownnz, data.efc_J_rowadr, data.efc_J_colind)
    return dense


def _constrained_rad_s(model: mujoco.MjModel) -> np.ndarray:
    """Ascending angular frequencies of the model with exact welds (module docstring)."""
    K = _tangent_stiffness(model)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    Z = linalg.null_space(_constraint_jacobian(model, data)) if data.nefc else np.eye(model.nv)
    omega2 = linalg.eigh(Z.T @ (0.5 * (K + K.T)) @ Z, Z.T @ M @ Z, eigvals_only=True)
    return np.sqrt(np.maximum(omega2, 0.0))


def _linearised_rad_s(model: mujoco.MjModel) -> np.ndarray:
    """Ascending angular frequencies of MuJoCo's linearised step (module docstring)."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    A = np.zeros((2 * model.nv, 2 * model.nv))
    mujoco.mjd_transitionFD(model, data, 1e-6, True, A, None, None, None)
    omega2 = np.linalg.eigvals(-A[model.nv :, : model.nv] / model.opt.timestep).real
    return np.sqrt(np.sort(np.maximum(omega2, 0.0)))


def _static(model: mujoco.MjModel, index: StructureModelIndex, forces_N: np.ndarray) -> mujoco.MjData:
    """Equilibrium under node forces ``forces_N`` (n, 3), world frame, on the beam-node bodies:
    Newton on MuJoCo's generalised force balance ``qfrc_smooth + qfrc_constraint = 0`` at
    ``qvel = 0`` (the welds as MuJoCo's solver holds them), Jacobian by central differences."""
    data = mujoco.MjData(model)
    data.xfrc_applied[index.node_body, :3] = forces_N

    def residual(q: np.ndarray) -> np.ndarray:
        data.qpos[:] = q
        mujoco.mj_forward(model, data)
        return data.qfrc_smooth + data.qfrc_constraint

    q = model.qpos0.copy()
    for _ in range(3):
        jacobian = np.zeros((model.nv, model.nv))
        for i in range(model.nv):
            columns = []
            for sign in (1.0, -1.0):
                step = np.zeros(model.nv)
                step[i] = sign * 1e-7
                moved = q.copy()
                mujoco.mj_integratePos(model, moved, step, 1)
                columns.append(residual(moved).copy())
            jacobian[:, i] = (columns[0] - columns[1]) / 2e-7
        mujoco.mj_integratePos(model, q, np.linalg.solve(jacobian, -residual(q)), 1)
    assert np.abs(residual(q)).max() < 1e-6 * np.abs(forces_N).max()
    return data


def _model_mass_properties(model: mujoco.MjModel) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """Total mass, centre of mass and inertia about it (world frame) of the bodies at ``qpos0``,
    and the part of that inertia that is the bodies' own (about their centres)."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    mass = model.body_mass[1:]
    total = float(mass.sum())
    center = mass @ data.xipos[1:] / total
    R = data.ximat[1:].reshape(-1, 3, 3)
    own = np.einsum("bij,bj,bkj->ik", R, model.body_inertia[1:], R)
    d = data.xipos[1:] - center
    arm = np.einsum("bk,bk->b", d, d)[:, None, None] * np.eye(3) - d[:, :, None] * d[:, None, :]
    points = np.einsum("b,bij->ij", mass, arm)
    return total, center, own + points, own


# --------------------------------------------------------------------------- the model of a ring


def test_free_ring_builds_one_weld_and_counts_its_model() -> None:
    """A free ring of 24 beams: a spanning tree (23 beams from the root node 0) and one cut beam,
    whose closing body (4 dofs) is welded to its end node's body: ``nv = 6 + 4 · 24``,
    ``nbody = 1 + 24 + 1``, one weld with ``solref = (2 h, 1)`` and ``solimp`` of ``d = 0.9999``;
    ``model_counts`` says the same without building; the beam's joints are indexed like any
    other's; 200 steps keep the weld to 1e-9 m and raise no MuJoCo warning."""
    ring = _ring()
    spec = build_structure_spec(ring, timestep_s=2e-4, integrator="Euler")
    model = spec.compile()
    assert (model.nv, model.nbody, model.ntendon) == (6 + 4 * N_SEG, N_SEG + 2, 0)
    assert model_counts(ring) == (model.nv, model.nbody, model.ntendon)
    assert model.neq == 1 and model.eq_type[0] == mujoco.mjtEq.mjEQ_WELD
    index = StructureModelIndex.from_model(model, ring)
    assert np.all(index.beam_dofadr >= 0)
    layout = body_layout(ring)
    (cut,) = layout.cut_member
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, closing_body_name(cut))
    other = set(ring.members.nodes[cut].tolist()) - {layout.cut_node[0]}
    assert model.body_dofnum[body] == 4 and model.body_parentid[body] == index.node_body[other.pop()]
    assert model.eq_obj1id[0] == body and model.eq_obj2id[0] == index.node_body[layout.cut_node[0]]
    np.testing.assert_array_equal(model.eq_solref[0], [CLOSURE_TIMECONST_STEPS * 2e-4, 1.0])
    np.testing.assert_array_equal(model.eq_solimp[0], CLOSURE_SOLIMP)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.xpos[body], ring.positions_m[layout.cut_node[0]], rtol=0, atol=1e-15)
    data.qvel[:] = 1e-3 * np.random.default_rng(1).standard_normal(model.nv)
    mujoco.mj_step(model, data, 200)
    mujoco.mj_forward(model, data)
    assert np.abs(data.efc_pos).max() < 1e-9
    assert sum(w.number for w in data.warning) == 0
    assert data.maxuse_arena < model.narena


def test_hoop_mass_properties_against_the_thin_ring() -> None:
    """The model's mass, centre and inertia are the structure's lumped point masses plus each
    node's beam rotary inertia (HRZ) and sphere ``2/5 m r²``, to 1e-12 (the closing body shares
    its node's mass and inertia without changing them), and those of a thin ring of radius R:
    ``M = 2πRμ``, centre 0, ``diag(M R²/2, M R²/2, M R²)``, within the chords' missing length
    ``(π/N)²/6`` (−0.29 % at 24 chords) plus the nodes' rotary inertia (+0.18 % of ``M R²``): 0.5 %."""
    ring = _ring()
    radius_m = 0.01
    model = _model(ring, node_radius_m=radius_m)
    total, center, inertia, own = _model_mass_properties(model)
    lumped_total, lumped_center, lumped_inertia = ring.mass_properties()
    masses = ring.lumped_masses()
    chord_m = 2 * R_M * math.sin(math.pi / N_SEG)
    assert total == pytest.approx(lumped_total, rel=1e-12)
    assert lumped_total == pytest.approx(N_SEG * chord_m * MU_KG_M, rel=1e-12)
    np.testing.assert_allclose(center, lumped_center, rtol=0, atol=1e-12)
    scale = lumped_inertia.max()
    np.testing.assert_allclose(inertia - own, lumped_inertia, rtol=0, atol=1e-12 * scale)
    expected_own = node_rotary_inertia(ring).sum(axis=0) + 0.4 * masses.sum() * radius_m**2 * np.eye(3)
    np.testing.assert_allclose(own, expected_own, rtol=0, atol=1e-12 * scale)
    thin = 2 * math.pi * R_M * MU_KG_M
    assert abs(total / thin - 1.0) <= 0.005
    np.testing.assert_allclose(center, 0.0, atol=1e-12)
    np.testing.assert_allclose(inertia, np.diag([0.5, 0.5, 1.0]) * thin * R_M**2, rtol=0, atol=0.005 * thin * R_M**2)


# --------------------------------------------------------------------------- the free ring's modes


@pytest.fixture(scope="module")
def free_ring() -> tuple[Structure, mujoco.MjModel, np.ndarray]:
    ring = _ring()
    model = _model(ring)
    return ring, model, _constrained_rad_s(model)


def test_free_ring_modes_against_the_closed_forms(free_ring) -> None:
    """The lowest four elastic mode pairs of the free ring (out-of-plane n = 2, in-plane n = 2,
    out-of-plane n = 3, in-plane n = 3; each a degenerate pair) against the closed forms within
    ``3 (π/N)²`` (5.1 % at N = 24, 1.3 % at N = 48): the modal analysis (frame elements, lumped
    and consistent mass; measured −1.2 % … +1.0 %) and the MuJoCo model with exact welds
    (measured −0.1 %, +2.2 %, +0.6 %, +3.4 %; at N = 48 −0.05 %, +0.5 %, +0.1 %, +0.8 %). Six
    zero modes below 1e-5 of the first elastic one."""
    ring, _, omega = free_ring
    in_plane, out_of_plane = _closed_form_rad_s(np.array([2, 3]))
    closed = np.array([out_of_plane[0], in_plane[0], out_of_plane[1], in_plane[1]])
    assert np.all(omega[:6] < 1e-5 * omega[6])
    for mass in ("lumped", "consistent"):
        modes = structure_modes(ring, k=14, mass=mass)
        assert modes.n_zero == 6
        pairs = modes.omega_rad_s[6:14].reshape(4, 2)
        np.testing.assert_allclose(pairs[:, 1], pairs[:, 0], rtol=1e-9)
        np.testing.assert_allclose(pairs[:, 0], closed, rtol=_tolerance(N_SEG))
    pairs = omega[6:14].reshape(4, 2)
    np.testing.assert_allclose(pairs[:, 1], pairs[:, 0], rtol=1e-7)
    np.testing.assert_allclose(pairs[:, 0], closed, rtol=_tolerance(N_SEG))
    fine = _constrained_rad_s(_model(_ring(48)))[6:14:2]
    np.testing.assert_allclose(fine, closed, rtol=_tolerance(48))


def test_weld_impedance_keeps_the_linearised_modes(free_ring) -> None:
    """MuJoCo's own linearisation (the welds as its solver holds them, ``solref = (2h, 1)``,
    ``d = 0.9999``) gives the exact-weld frequencies of the four lowest mode pairs within 1e-5
    (measured 3e-7 … 9e-7); MuJoCo's default ``solref = (0.02, 1)``, ``solimp = (0.9, 0.95, …)``
    would lower the first by 38 % (the weld is then softer than the ring)."""
    ring, model, omega = free_ring
    linearised = _linearised_rad_s(model)
    np.testing.assert_allclose(linearised[6:14], omega[6:14], rtol=1e-5)
    spec = build_structure_spec(ring, timestep_s=model.opt.timestep, integrator="Euler")
    for equality in spec.equalities:
        equality.solref = [0.02, 1.0]
        equality.solimp = [0.9, 0.95, 0.001, 0.5, 2.0]
    default = _linearised_rad_s(spec.compile())
    assert default[6] < 0.7 * omega[6]


# --------------------------------------------------------------------------- the pinched ring


def _pinch_forces_N(n: int, force_N: float) -> tuple[np.ndarray, int, int]:
    """Two opposite forces ``force_N`` pressing nodes ``n/4`` and ``3n/4`` (on the y axis) inward."""
    a, b = n // 4, 3 * n // 4
    forces = np.zeros((n, 3))
    forces[a, 1], forces[b, 1] = -force_N, force_N
    return forces, a, b


def test_pinched_ring_against_the_closed_form() -> None:
    """A ring of 48 beams pinched by two opposite forces P (node 0 clamped: the loads are
    self-equilibrated, so the clamp carries nothing): the loaded diameter shortens by
    ``δ = P R³/EI (π/4 − 2/π)`` (Roark, thin ring under diametral loads), within ``3 (π/N)²``
    (1.3 %; measured −1.0 %, −4.3 % at 24 beams, −0.17 % at 96; the frame-element assembly
    −0.25 %); the diameter at right angles lengthens by ``P R³/EI (2/π − 1/2)`` within the same.
    MuJoCo's equilibrium (the weld as its solver holds it) equals the exact-weld linear solution
    ``[K Jᵀ; J 0]`` within 2e-5 (measured 7.2e-6 at this load, 4.2e-5 at ten times it: 3.4e-6
    of the weld's compliance, the rest geometric nonlinearity, which grows with the load)."""
    n, P = 48, 1e-4
    ring = _ring(n, clamp_node=0)
    model = _model(ring)
    index = StructureModelIndex.from_model(model, ring)
    forces, a, b = _pinch_forces_N(n, P)
    data = _static(model, index, forces)
    position = index.node_positions(data)
    shortening = 2 * R_M - float(np.linalg.norm(position[a] - position[b]))
    widening = float(np.linalg.norm(position[0] - position[n // 2])) - 2 * R_M
    scale = P * R_M**3 / EI_NM2[1]
    assert shortening / (scale * (math.pi / 4 - 2 / math.pi)) - 1 == pytest.approx(0.0, abs=_tolerance(n))
    assert widening / (scale * (2 / math.pi - 0.5)) - 1 == pytest.approx(0.0, abs=_tolerance(n))
    # the exact weld: K dq + Jᵀ λ = f, J dq = 0 about qpos0
    rest = mujoco.MjData(model)
    rest.xfrc_applied[index.node_body, :3] = forces
    mujoco.mj_forward(model, rest)
    f = rest.qfrc_smooth.copy()
    J = _constraint_jacobian(model, rest)
    K = _tangent_stiffness(model)
    system = np.block([[K, J.T], [J, np.zeros((J.shape[0], J.shape[0]))]])
    dq = np.linalg.solve(system, np.concatenate([f, np.zeros(J.shape[0])]))[: model.nv]
    mujoco.mj_integratePos(model, rest.qpos, dq, 1)
    mujoco.mj_kinematics(model, rest)
    exact = 2 * R_M - float(np.linalg.norm(index.node_positions(rest)[a] - index.node_positions(rest)[b]))
    assert shortening / exact - 1 == pytest.approx(0.0, abs=2e-5)


# --------------------------------------------------------------------------- the ringing free ring


def _peak_rad_s(signal: np.ndarray, dt_s: float, near_rad_s: float) -> float:
    """The frequency [rad/s] of the largest peak of the summed power spectra of ``signal`` (t, k)
    within ±25 % of ``near_rad_s``: Hann window, zero-padded 64 times, parabola through the
    largest bin of the log spectrum and its neighbours."""
    t = signal.shape[0]
    window = np.hanning(t)[:, None]
    size = 64 * t
    power = (np.abs(np.fft.rfft((signal - signal.mean(axis=0)) * window, n=size, axis=0)) ** 2).sum(axis=1)
    omega = 2 * np.pi * np.fft.rfftfreq(size, dt_s)
    band = np.flatnonzero(np.abs(omega / near_rad_s - 1) <= 0.25)
    k = band[np.argmax(power[band])]
    a, b, c = np.log(power[k - 1 : k + 2])
    return float(omega[k] + 0.5 * (a - c) / (a - 2 * b + c) * (omega[1] - omega[0]))


def test_free_ring_rings_at_its_modal_frequencies(free_ring) -> None:
    """The free ring released from a small static deformation (in-plane: a pinch and three radial
    forces at 120°; out of plane: ±z forces alternating at 90° and at 60°, all self-equilibrated,
    solved with node 0 clamped, which then carries nothing) rings, 6 s of semi-implicit Euler at
    h = 0.4 ms (the highest frequency 2 400 rad/s: ω h ≈ 1), at the exact-weld modal frequencies
    of the four lowest pairs within 5e-4 (measured 4e-7 … 2.2e-5; the FFT's bins are 1.05 rad/s
    apart, the parabola through the peak refines them), hence at the closed forms within
    ``3 (π/N)²``; the weld holds to 1e-8 m
    and the total energy stays within 5e-3 of the strain energy released (measured ±2.3e-3, a
    slow oscillation without drift: semi-implicit Euler's energy error on the deformation's fast
    content; the weld neither feeds nor drains the ring)."""
    ring, _, omega = free_ring
    n, P = N_SEG, 1e-3
    clamped = _ring(n, clamp_node=0)
    h = 4e-4
    model = _model(clamped, timestep_s=h)
    index = StructureModelIndex.from_model(model, clamped)
    theta = 2 * np.pi * np.arange(n) / n
    radial = np.column_stack([np.cos(theta), np.sin(theta), np.zeros(n)])
    forces = _pinch_forces_N(n, P)[0]
    forces[[2, 10, 18]] += P * radial[[2, 10, 18]]
    forces[[3, 9, 15, 21], 2] += P * np.array([1.0, -1.0, 1.0, -1.0])
    forces[[1, 5, 9, 13, 17, 21], 2] += P * np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0])
    assert np.abs(forces.sum(axis=0)).max() < 1e-15
    assert np.abs(np.cross(ring.positions_m, forces).sum(axis=0)).max() < 1e-15
    deformed = _static(model, index, forces).qpos.copy()
    spec = build_structure_spec(ring, timestep_s=h, integrator="Euler")
    spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    free = spec.compile()
    free_index = StructureModelIndex.from_model(free, ring)
    assert free.nq == model.nq + 7
    data = mujoco.MjData(free)
    data.qpos[7:] = deformed
    mujoco.mj_forward(free, data)
    released = data.energy.sum()
    every, records = 10, 1500
    positions = np.empty((records, n, 3))
    energy = np.empty(records)
    for r in range(records):
        mujoco.mj_step(free, data, every)
        positions[r] = free_index.node_positions(data)
        energy[r] = data.energy.sum()
    assert np.abs(energy / released - 1).max() < 5e-3
    displacement = positions - positions.mean(axis=1, keepdims=True)
    in_plane = np.einsum("tij,ij->ti", displacement, radial)
    out_of_plane = displacement[:, :, 2]
    dt = every * h
    in_plane_modes, out_of_plane_modes = _closed_form_rad_s(np.array([2, 3]))
    rung = np.array(
        [
            _peak_rad_s(out_of_plane, dt, omega[6]),
            _peak_rad_s(in_plane, dt, omega[8]),
            _peak_rad_s(out_of_plane, dt, omega[10]),
            _peak_rad_s(in_plane, dt, omega[12]),
        ]
    )
    np.testing.assert_allclose(rung, omega[6:14:2], rtol=5e-4)
    closed = np.array([out_of_plane_modes[0], in_plane_modes[0], out_of_plane_modes[1], in_plane_modes[1]])
    np.testing.assert_allclose(rung, closed, rtol=_tolerance(n))
    mujoco.mj_forward(free, data)
    assert np.abs(data.efc_pos).max() < 1e-8
    assert sum(w.number for w in data.warning) == 0


# --------------------------------------------------------------------------- several cycles, several held places


def _frame(cells: int = 2, segments: int = 8) -> Structure:
    """A planar frame of ``cells`` unit square cells in a row (x–y plane), every side ``segments``
    beams (section axis 1 along +z): ``cells`` independent cycles."""
    corners = np.array([[x, y, 0.0] for y in (0.0, 1.0) for x in range(cells + 1)])
    top = cells + 1
    sides = [(x, x + 1) for x in range(cells)] + [(top + x, top + x + 1) for x in range(cells)]
    sides += [(x, top + x) for x in range(cells + 1)]
    positions, ends = [corners], []
    count = len(corners)
    for a, b in sides:
        inner = corners[a] + np.arange(1, segments)[:, None] / segments * (corners[b] - corners[a])
        chain = [a, *range(count, count + segments - 1), b]
        ends += list(zip(chain[:-1], chain[1:]))
        positions.append(inner)
        count += segments - 1
    positions_m = np.vstack(positions)
    members = Members.build(
        np.array(ends),
        positions_m=positions_m,
        kind="beam",
        EA_N=EA_N,
        EI_Nm2=np.tile(EI_NM2, (len(ends), 1)),
        GJ_Nm2=GJ_NM2,
        linear_density_kg_m=MU_KG_M,
        orientation=np.tile([0.0, 0.0, 1.0], (len(ends), 1)),
    )
    return Structure("frame", positions_m, np.zeros(len(positions_m)), members)


def test_frame_of_two_cells_matches_the_assembled_modes() -> None:
    """A free frame of two square cells (7 sides of 8 beams: 56 beams, 55 nodes, two independent
    cycles): two closing bodies and two welds, ``model_counts`` exact; the lowest twelve elastic
    frequencies of the model with exact welds match the frame-element modal analysis (lumped mass)
    within 2 % (measured +0.1 % … +1.3 %; +2.3 % at 6 beams a side, +0.6 % at 12: second order; the same frame
    without two sides, a tree, shows the same: the chain's discretisation of the members and
    corners, not the welds), and MuJoCo's linearisation matches them within 5e-5 (measured 5e-6)."""
    frame = _frame()
    model = _model(frame, arena_bytes=64 << 20)
    assert model.neq == 2 and (model.nv, model.nbody) == (6 + 4 * frame.n_members, 1 + frame.n_nodes + 2)
    assert model_counts(frame) == (model.nv, model.nbody, model.ntendon)
    omega = _constrained_rad_s(model)
    reference = structure_modes(frame, k=18, mass="lumped")
    assert reference.n_zero == 6 and np.all(omega[:6] < 1e-5 * omega[6])
    np.testing.assert_allclose(omega[6:18], reference.omega_rad_s[6:18], rtol=0.02)
    linearised = _linearised_rad_s(model)
    np.testing.assert_allclose(linearised[6:18], omega[6:18], rtol=5e-5)


BOOM_L_M, BOOM_N = 10.0, 20
BOOM_EI_NM2 = 1000.0


def _boom(fixed_rows: dict[int, list[bool]]) -> Structure:
    """A straight boom of 20 beams along x (EI = 1000 N m² in both planes, μ = 1 kg/m), with the
    given ``fixed_dofs`` rows."""
    positions = np.column_stack([np.linspace(0.0, BOOM_L_M, BOOM_N + 1), np.zeros((BOOM_N + 1, 2))])
    members = Members.build(
        np.column_stack([np.arange(BOOM_N), np.arange(1, BOOM_N + 1)]),
        positions_m=positions,
        kind="beam",
        EA_N=1e6,
        EI_Nm2=BOOM_EI_NM2,
        GJ_Nm2=800.0,
        linear_density_kg_m=1.0,
        orientation=np.tile([0.0, 0.0, 1.0], (BOOM_N, 1)),
    )
    fixed = np.zeros((BOOM_N + 1, 6), dtype=bool)
    for node, row in fixed_rows.items():
        fixed[node] = row
    return Structure("boom", positions, np.zeros(BOOM_N + 1), members, fixed_dofs=fixed)


@pytest.mark.parametrize(
    "ends, kind, deflection_coefficient, midpoint_rule, beta_L",
    [
        ("clamped", mujoco.mjtEq.mjEQ_WELD, 1 / 192, 4.0, 4.730040744862704),  # cosh βL cos βL = 1
        ("pinned", mujoco.mjtEq.mjEQ_CONNECT, 1 / 48, 1.0, math.pi),
    ],
)
def test_boom_held_at_both_ends(
    ends: str, kind: int, deflection_coefficient: float, midpoint_rule: float, beta_L: float
) -> None:
    """A boom of 20 beams held at both ends: the root by its joints, the far end by an equality
    constraint to the world (a weld when all six components are fixed, a ``connect`` when the
    three translations are; the pinned root also holds the twist about the boom, else a
    mechanism); ``model_counts`` exact. Midspan deflection under a midspan force against
    ``P L³/(192 EI)`` (clamped) and ``P L³/(48 EI)`` (pinned) within 1.5 %, and against the
    chain's own value within 1e-4: its midpoint rule integrates the moment's square short by
    ``(l²/12) ∫M'² / ∫M²``, ``4/N²`` and ``1/N²`` here (−1 %, −0.25 %; measured 1.2e-6 and
    −9.6e-6 off them). First bending frequency against ``(βL)² √(EI/(μL⁴))`` within 1 %
    (measured +0.48 % and +0.07 %)."""
    clamped = [True] * 6
    rows = {0: clamped, BOOM_N: clamped}
    if ends == "pinned":
        rows = {0: [True, True, True, True, False, False], BOOM_N: [True, True, True, False, False, False]}
    boom = _boom(rows)
    model = _model(boom)
    assert model.neq == 1 and model.eq_type[0] == kind
    assert model_counts(boom) == (model.nv, model.nbody, model.ntendon)
    index = StructureModelIndex.from_model(model, boom)
    expected = deflection_coefficient * BOOM_L_M**3 / BOOM_EI_NM2  # per newton
    P = 2e-4 / expected  # 0.2 mm: the axial tension the held ends take stiffens it by < 1e-5 (0.16 % at 5 mm)
    expected *= P
    forces = np.zeros((BOOM_N + 1, 3))
    forces[BOOM_N // 2, 1] = P
    data = _static(model, index, forces)
    deflection = index.node_positions(data)[BOOM_N // 2, 1]
    assert deflection / expected - 1 == pytest.approx(0.0, abs=0.015)
    assert deflection / (expected * (1 - midpoint_rule / BOOM_N**2)) - 1 == pytest.approx(0.0, abs=1e-4)
    omega = _constrained_rad_s(model)
    first = beta_L**2 * math.sqrt(BOOM_EI_NM2 / (1.0 * BOOM_L_M**4))
    np.testing.assert_allclose(omega[:2], first, rtol=0.01)


def _part_with_boom(*, beam_on_part: bool, n: int = 10) -> Structure:
    """A free rigid part (nodes 0 and 1, 1 m apart, optionally joined by a beam) carrying a 2 m
    boom of ``n`` beams from node 1 along x."""
    positions = np.column_stack([np.r_[0.0, 1.0 + np.linspace(0.0, 2.0, n + 1)], np.zeros((n + 2, 2))])
    ends = np.column_stack([np.arange(n + 1), np.arange(1, n + 2)])[0 if beam_on_part else 1 :]
    members = Members.build(
        ends, positions_m=positions, kind="beam", EA_N=1e4, EI_Nm2=10.0, GJ_Nm2=8.0, linear_density_kg_m=0.5
    )
    part = RigidPart("bus", 2.0, np.array([0.5, 0.0, 0.0]), np.diag([0.2, 0.3, 0.4]), np.array([0, 1]))
    return Structure("bus", positions, np.zeros(n + 2), members, rigid_parts=(part,))


def test_beam_between_two_nodes_of_a_rigid_part() -> None:
    """A beam with both ends on one rigid part closes a cycle through the part: its closing body
    hangs from the part and is welded back to it, which holds the beam rigid. The model's mass
    and centre are the structure's (1e-12); its four lowest elastic frequencies differ from the
    modal analysis's (which moves the beam with the part) by what the same structure without
    that beam shows, within 1e-3 (measured +0.12 %, +0.12 %, +1.2 %, +1.2 % with the beam, 4e-5 …
    3e-4 less without: the 10-beam boom's discretisation)."""
    structure = _part_with_boom(beam_on_part=True)
    model = _model(structure)
    assert body_layout(structure).cut_member.tolist() == [0] and model.neq == 1
    assert model_counts(structure) == (model.nv, model.nbody, model.ntendon)
    total, center, _, _ = _model_mass_properties(model)
    expected_total, expected_center, _ = structure.mass_properties()
    assert total == pytest.approx(expected_total, rel=1e-12)
    np.testing.assert_allclose(center, expected_center, rtol=0, atol=1e-12)
    deviation = _constrained_rad_s(model)[6:10] / structure_modes(structure, k=10).omega_rad_s[6:10] - 1
    without = _part_with_boom(beam_on_part=False)
    assert _model(without).neq == 0
    reference = _constrained_rad_s(_model(without))[6:10] / structure_modes(without, k=10).omega_rad_s[6:10] - 1
    np.testing.assert_allclose(deviation, reference, rtol=0, atol=1e-3)


@pytest.mark.parametrize("structure", ["ring", "frame"])
def test_arena_covers_the_constraint_solver(structure: str) -> None:
    """The arena holds what MuJoCo's Newton solver takes for the welds (a ring of 120 beams: one
    weld over a dense chain; a row of 6 cells of 4 beams a side: 6 welds), with every integrator
    but ``implicit`` (whose velocity derivatives of a long chain take ``O(nv²)`` beyond the
    lattice arena, welds or not), and no more than twice it beyond the lattice arena (measured
    1.4 and 1.2 times): no constraint dropped, no warning."""
    built = _ring(120) if structure == "ring" else _frame(cells=6, segments=4)
    for integrator in ("Euler", "RK4", "implicitfast"):
        model = build_structure_spec(built, timestep_s=1e-4, integrator=integrator).compile()
        data = mujoco.MjData(model)
        data.qvel[:] = 1e-3 * np.random.default_rng(2).standard_normal(model.nv)
        mujoco.mj_step(model, data, 3)
        assert sum(w.number for w in data.warning) == 0
        assert data.nefc == 6 * model.neq
        assert data.maxuse_arena <= model.narena
        assert model.narena - lattice_arena_bytes(model.nv) <= 2 * data.maxuse_arena
