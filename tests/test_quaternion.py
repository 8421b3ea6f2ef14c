"""The shared quaternion algebra against MuJoCo's own functions (random quaternions)."""

from __future__ import annotations

import magsail_mj  # noqa: F401  (chooses the GL backend before mujoco is imported)
import mujoco
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from magsail_mj.quaternion import error_quaternion, quat_conj, quat_mul, quat_to_matrix

quat = st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda v: np.linalg.norm(v) > 0.1).map(
    lambda v: np.asarray(v) / np.linalg.norm(v))


@settings(max_examples=60, deadline=None)
@given(quat, quat)
def test_product_matrix_and_error_match_mujoco(p, q):
    ref = np.empty(4)
    mujoco.mju_mulQuat(ref, p, q)
    np.testing.assert_allclose(quat_mul(p, q), ref, atol=1e-15)
    np.testing.assert_allclose(quat_mul(p[None], q[None])[0], ref, atol=1e-15)   # stacked path
    mat = np.empty(9)
    mujoco.mju_quat2Mat(mat, q)
    np.testing.assert_allclose(quat_to_matrix(q), mat.reshape(3, 3), atol=1e-14)
    np.testing.assert_allclose(quat_mul(q, quat_conj(q)), [1, 0, 0, 0], atol=1e-14)
    e = error_quaternion(p, q)
    assert e[0] >= 0.0
    # q = p ⊗ q_e up to sign: the error rotates the reference into the current attitude.
    back = quat_mul(p, e)
    assert min(np.abs(back - q).max(), np.abs(back + q).max()) < 1e-14
    np.testing.assert_allclose(error_quaternion(np.stack([p, p]), np.stack([q, q])), [e, e], atol=1e-15)
