"""scripts/truss_slew_control_search.py: its reduced rigid model against the rigid twin's equations
(concepts/truss_magnetorquer/rigid_orbital.py), batch by batch (no runs)."""

from __future__ import annotations

import sys

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from magsail_mj.concepts.truss_magnetorquer.rigid_orbital import rigid_rhs
from magsail_mj.environment.gravity import MU_EARTH
from magsail_mj.quaternion import quat_to_matrix
from tests.conftest import REPO

sys.path.insert(0, str(REPO / "scripts"))
import truss_slew_control_search as cs  # noqa: E402

vec = st.lists(st.floats(-1, 1), min_size=3, max_size=3)
quat = st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda v: np.linalg.norm(v) > 0.1)


@settings(max_examples=40, deadline=None)
@given(q=quat, v=vec)
def test_batched_body_axes_helper_equals_the_package_rotation(q, v):
    q = np.asarray(q) / np.linalg.norm(q)
    assert np.allclose(cs._to_body(q[None], np.asarray(v))[0], quat_to_matrix(q).T @ np.asarray(v), atol=1e-14)


@settings(max_examples=40, deadline=None)
@given(q=quat, w=vec, m=vec, B=vec, r=vec.filter(lambda v: np.linalg.norm(v) > 0.1))
def test_reduced_model_rhs_equals_the_rigid_twin(q, w, m, B, r):
    # Same body, dipole torque m × B, gravity gradient and gyroscopic term: q̇ and ω̇ agree with
    # rigid_rhs to rounding (relative 1e-10 of the largest term).
    J = np.array([[1.0e5, 20.0, -5.0], [20.0, 1.1e5, 3.0], [-5.0, 3.0, 2.0e5]])
    q = np.asarray(q) / np.linalg.norm(q)
    w, m_b = 1e-3 * np.asarray(w), 1e4 * np.asarray(m)
    B, r = 4e-5 * np.asarray(B), 7.2e6 * np.asarray(r) / np.linalg.norm(r)
    case = {"B": np.array([B, B]), "r": np.array([r, r]), "J": J, "mu": MU_EARTH}
    q_dot, w_dot = cs._rhs(case, q[None], w[None], m_b[None], 0.25)
    ref_q, ref_w, _, _ = rigid_rhs(
        q, w, J=J, J_inv=np.linalg.inv(J), m_body=m_b, B_eci=B, r_ref_eci=r, mu=MU_EARTH, gravity_gradient=True
    )
    assert np.allclose(q_dot[0], ref_q, rtol=0, atol=1e-12 * (1 + np.abs(ref_q).max()))
    assert np.allclose(w_dot[0], ref_w, rtol=0, atol=1e-10 * np.abs(ref_w).max() + 1e-300)
