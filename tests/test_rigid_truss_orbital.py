"""The rigid counterpart of the orbital truss runs: invariants of its integrator and torques."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from magsail_mj.concepts.truss_magnetorquer.rigid_orbital import quat_to_matrix_wxyz, rigid_rhs, simulate_rigid
from magsail_mj.environment.gravity import MU_EARTH


class _HeldPolarity:
    """Controller stand-in: always the same polarity; records the rotations it was shown."""

    def __init__(self, polarity):
        self.polarity = polarity
        self.stats = np.zeros(4, dtype=np.int64)

    def update(self, state):
        self.stats[0] += 1
        return SimpleNamespace(polarity=self.polarity, clipped1=False, clipped2=False, torque_ref_body=np.zeros(3))


class _UniformDipoleLoad:
    """Rod-load stand-in: one fixed body dipole, rotated with the body (pos rows 1.. are particles)."""

    def __init__(self, m_body, nodes):
        self.m_body = np.asarray(m_body, dtype=float)
        self.nodes = nodes

    def total_dipole_world(self, pos, polarity):
        R, *_ = np.linalg.lstsq(self.nodes, pos[1:], rcond=None)  # pos = nodes @ Rᵀ
        return R.T @ self.m_body if polarity is not None else np.zeros(3)


def _environment(B, r):
    sample = SimpleNamespace(B_eci=np.asarray(B, float), r_ref_eci=np.asarray(r, float))
    return SimpleNamespace(mu=MU_EARTH, sample=lambda t: sample)


def _setup():
    nodes = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 2, 0], [0, -2, 0], [0, 0, 0.5], [0, 0, -0.5]])
    J = np.diag([30.0, 20.0, 45.0])
    return nodes, J


def test_torque_free_body_keeps_momentum_and_energy():
    # No field, no gravity gradient: H_world = R J ω and ½ ωᵀJω are invariants. RK4 at 0.1 s on
    # rates of 0.05 rad/s has a local error ~(ω dt)^5; 2 000 steps keep both within 1e-9.
    nodes, J = _setup()
    w0 = np.array([0.05, -0.03, 0.02])
    run = simulate_rigid(
        controller=_HeldPolarity(None),
        rod_load=_UniformDipoleLoad([0, 0, 0], nodes),
        environment=_environment([0, 0, 0], [7e6, 0, 0]),
        nodes_body=nodes,
        masses=np.ones(len(nodes)),
        inertia=J,
        q0_wxyz=np.array([1.0, 0, 0, 0]),
        omega0_body=w0,
        duration_s=200.0,
        dt=0.1,
        gravity_gradient=False,
        record_every_s=1.0,
    )
    H = np.array([quat_to_matrix_wxyz(q) @ (J @ w) for q, w in zip(run.q, run.omega)])
    E = 0.5 * np.einsum("ti,ij,tj->t", run.omega, J, run.omega)
    assert np.max(np.linalg.norm(H - H[0], axis=1)) < 1e-9 * np.linalg.norm(H[0])
    assert np.max(np.abs(E - E[0])) < 1e-9 * E[0]
    assert np.max(np.abs(run.omega - w0)) > 1e-3  # it does tumble (the test can fail)


def test_field_only_energy_is_kinetic_plus_dipole_potential():
    # A body-fixed dipole in a uniform field: E = ½ ωᵀJω − m·(Rᵀ B) is conserved (pendulum).
    nodes, J = _setup()
    m, B = np.array([0.0, 0.0, 200.0]), np.array([0.0, 3e-5, 1e-5])
    run = simulate_rigid(
        controller=_HeldPolarity(1),
        rod_load=_UniformDipoleLoad(m, nodes),
        environment=_environment(B, [7e6, 0, 0]),
        nodes_body=nodes,
        masses=np.ones(len(nodes)),
        inertia=J,
        q0_wxyz=np.array([1.0, 0, 0, 0]),
        omega0_body=np.zeros(3),
        duration_s=300.0,
        dt=0.1,
        gravity_gradient=False,
        record_every_s=1.0,
    )
    U = -np.array([m @ (quat_to_matrix_wxyz(q).T @ B) for q in run.q])
    E = 0.5 * np.einsum("ti,ij,tj->t", run.omega, J, run.omega) + U
    assert np.ptp(U) > 1e-3  # it swings
    assert np.max(np.abs(E - E[0])) < 1e-6 * np.ptp(U)


@settings(max_examples=30, deadline=None)
@given(
    st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda v: np.linalg.norm(v) > 0.1),
    st.lists(st.floats(-1, 1), min_size=3, max_size=3),
)
def test_gravity_gradient_in_rhs_is_the_classical_torque(qv, wv):
    # T_gg = 3μ/r⁵ r_b × J r_b with r_b = Rᵀ r; zero for r along a principal axis.
    q = np.asarray(qv) / np.linalg.norm(qv)
    _, J = _setup()
    r = np.array([0.0, 7.2e6, 1.0e6])
    _, _, _, T = rigid_rhs(
        q,
        np.asarray(wv) * 0.01,
        J=J,
        J_inv=np.linalg.inv(J),
        m_body=np.zeros(3),
        B_eci=np.zeros(3),
        r_ref_eci=r,
        mu=MU_EARTH,
        gravity_gradient=True,
    )
    r_b = quat_to_matrix_wxyz(q).T @ r
    expected = 3 * MU_EARTH / np.linalg.norm(r_b) ** 5 * np.cross(r_b, J @ r_b)
    np.testing.assert_allclose(T, expected, rtol=1e-9, atol=1e-18)
    _, _, _, T_axis = rigid_rhs(
        np.array([1.0, 0, 0, 0]),
        np.zeros(3),
        J=J,
        J_inv=np.linalg.inv(J),
        m_body=np.zeros(3),
        B_eci=np.zeros(3),
        r_ref_eci=np.array([7e6, 0, 0]),
        mu=MU_EARTH,
        gravity_gradient=True,
    )
    assert np.allclose(T_axis, 0.0)


def test_quaternion_matrix_is_a_rotation():
    q = np.array([0.5, -0.5, -0.5, 0.5])
    R = quat_to_matrix_wxyz(q)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(R @ [0, 0, 1.0], [-1.0, 0, 0], atol=1e-15)  # slew III target: z1 → −x


def test_ideal_perp_b_actuation_applies_no_torque_along_b():
    # With T_ref along B the ⊥B actuator applies nothing: the body stays at rest; "ideal" turns it.
    nodes, J = _setup()
    B = np.array([0.0, 0.0, 3e-5])

    class _AlongB(_HeldPolarity):
        def update(self, state):
            cmd = super().update(state)
            cmd.torque_ref_body = np.array([0.0, 0.0, 1e-3])
            return cmd

    kw = dict(
        rod_load=_UniformDipoleLoad([0, 0, 0], nodes),
        environment=_environment(B, [7e6, 0, 0]),
        nodes_body=nodes,
        masses=np.ones(len(nodes)),
        inertia=J,
        q0_wxyz=np.array([1.0, 0, 0, 0]),
        omega0_body=np.zeros(3),
        duration_s=10.0,
        dt=0.1,
        gravity_gradient=False,
    )
    perp = simulate_rigid(controller=_AlongB(None), actuation="ideal_perp_B", **kw)
    ideal = simulate_rigid(controller=_AlongB(None), actuation="ideal", **kw)
    assert np.max(np.abs(perp.omega)) < 1e-15
    np.testing.assert_allclose(ideal.omega[-1], [0.0, 0.0, 1e-3 * 10.0 / 45.0], rtol=1e-9)
