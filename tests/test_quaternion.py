"""The shared quaternion algebra against MuJoCo's own functions and scipy's ``Rotation`` (random quaternions)."""

from __future__ import annotations

import magsail_mj  # noqa: F401  (chooses the GL backend before mujoco is imported)
import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from magsail_mj.environment.frames import quat_to_mat
from magsail_mj.estimation.attitude import matrix_from_quat
from magsail_mj.concepts.cnusail.mjcf import quat_z_to as cubesat_quat_z_to
from magsail_mj.quaternion import (
    error_quaternion,
    direction_quaternions,
    quat_conj,
    quat_from_axis_angle,
    quat_from_matrix,
    quat_mul,
    quat_to_axis_angle,
    quat_to_matrix,
    quat_z_to,
)

quat = (
    st.lists(st.floats(-1, 1), min_size=4, max_size=4)
    .filter(lambda v: np.linalg.norm(v) > 0.1)
    .map(lambda v: np.asarray(v) / np.linalg.norm(v))
)


@settings(max_examples=60, deadline=None)
@given(quat, quat)
def test_product_matrix_and_error_match_mujoco(p, q):
    ref = np.empty(4)
    mujoco.mju_mulQuat(ref, p, q)
    np.testing.assert_allclose(quat_mul(p, q), ref, atol=1e-15)
    np.testing.assert_allclose(quat_mul(p[None], q[None])[0], ref, atol=1e-15)  # stacked path
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


def _scipy(q: np.ndarray) -> Rotation:
    """scipy stores quaternions scalar last."""
    return Rotation.from_quat(np.roll(q, -1, axis=-1))


raw = arrays(np.float64, 4, elements=st.floats(-3, 3)).filter(lambda v: np.linalg.norm(v) > 0.1)


@settings(max_examples=80, deadline=None)
@given(quat, quat, raw)
def test_matrix_product_and_inverse_match_scipy_rotation(p, q, r):
    """R(q) = Rotation.as_matrix, R(p ⊗ q) = R(p) R(q), q ↔ R round trip with w ≥ 0 (tol 1e-13)."""
    np.testing.assert_allclose(quat_to_matrix(q), _scipy(q).as_matrix(), atol=1e-13)
    np.testing.assert_allclose(quat_to_matrix(quat_mul(p, q)), (_scipy(p) * _scipy(q)).as_matrix(), atol=1e-13)
    np.testing.assert_allclose(quat_to_matrix(quat_conj(q)), _scipy(q).inv().as_matrix(), atol=1e-13)
    # normalise=True divides by |r| first; scipy normalises too
    np.testing.assert_allclose(quat_to_matrix(r, normalise=True), _scipy(r).as_matrix(), atol=1e-13)
    back = quat_from_matrix(_scipy(q).as_matrix())
    assert back[0] >= 0.0
    assert min(np.abs(back - q).max(), np.abs(back + q).max()) < 1e-13
    # the stacked path agrees bit for bit with the single-quaternion path
    stack = np.stack([q, p, r])
    assert np.array_equal(quat_to_matrix(stack)[1], quat_to_matrix(p))
    assert np.array_equal(quat_to_matrix(stack, normalise=True)[2], quat_to_matrix(r, normalise=True))


@settings(max_examples=80, deadline=None)
@given(
    arrays(np.float64, 3, elements=st.floats(-2, 2)).filter(lambda v: np.linalg.norm(v) > 0.1),
    st.floats(-2 * np.pi, 2 * np.pi),
)
def test_axis_angle_matches_scipy_rotvec(axis, angle):
    """quat_from_axis_angle = Rotation.from_rotvec(θ n̂); quat_to_axis_angle returns θ ∈ [0, π] (tol 1e-12)."""
    n = axis / np.linalg.norm(axis)
    q = quat_from_axis_angle(axis, angle)
    np.testing.assert_allclose(quat_to_matrix(q), Rotation.from_rotvec(angle * n).as_matrix(), atol=1e-13)
    ax, th = quat_to_axis_angle(q)
    assert 0.0 <= th <= np.pi + 1e-15
    np.testing.assert_allclose(th * ax, Rotation.from_matrix(quat_to_matrix(q)).as_rotvec(), atol=1e-12)
    # broadcasting: one axis, several angles
    qs = quat_from_axis_angle(axis, np.array([angle, 0.0]))
    np.testing.assert_allclose(qs[0], q, atol=0)
    np.testing.assert_allclose(qs[1], [1.0, 0.0, 0.0, 0.0], atol=0)


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, 3, elements=st.floats(-2, 2)).filter(lambda v: np.linalg.norm(v) > 0.1))
def test_z_to_rotates_z_onto_the_direction(v):
    """R(quat_z_to(v)) ẑ = v̂, including v̂ = −ẑ. Tolerance 1e-12 + 4ε/(1 + c), c = ẑ·v̂: the
    quaternion is not renormalised, and rounding in 1 + c grows as v̂ nears −ẑ."""
    for d in (v, np.array([0.0, 0.0, -abs(v[2]) - 0.5])):
        q = np.array(quat_z_to(d))
        u = d / np.linalg.norm(d)
        tol = 1e-12 + 4 * np.finfo(float).eps / max(1.0 + u[2], 1e-300)
        # c < −1 + 1e-12 snaps to the half turn: d̂ then lies within √2·1e-6 rad of −ẑ
        np.testing.assert_allclose(quat_to_matrix(q)[:, 2], u, rtol=0, atol=tol if u[2] >= -1 + 1e-12 else 2e-6)


@settings(max_examples=40, deadline=None)
@given(arrays(np.float64, (5, 3), elements=st.floats(-2, 2)).filter(lambda v: np.all(np.linalg.norm(v, axis=1) > 0.1)))
def test_direction_quaternions_rotate_z_onto_each_direction(d):
    """R(q_t) ẑ = d̂_t for every row, antiparallel rows included; unit quaternions. Tolerance
    1e-12 + 4ε/(1 + c) (rounding in 1 + c near −ẑ), or 3e-8 where w = √((1 + c)/2) ≤ 1e-8 snaps the
    row to the half turn (d̂ within 2e-8 rad of −ẑ)."""
    d = np.vstack([d, [0.0, 0.0, -1.5]])
    q = direction_quaternions(d)
    u = d / np.linalg.norm(d, axis=1, keepdims=True)
    snapped = np.sqrt(np.maximum(0.5 * (1.0 + u[:, 2]), 0.0)) <= 1e-8
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)
    err = np.abs(quat_to_matrix(q)[:, :, 2] - u).max(axis=1)
    tol = 1e-12 + 4 * np.finfo(float).eps / np.maximum(1.0 + u[:, 2], 1e-300)
    assert np.all(err <= np.where(snapped, 3e-8, tol)), err


def test_aliases_and_errors_name_their_argument():
    """The aliases kept for callers equal the one implementation bit for bit; bad input names its argument."""
    q = np.array([0.3, -0.2, 0.9, 0.1])
    assert np.array_equal(quat_to_mat(q), quat_to_matrix(q, normalise=True))
    assert np.array_equal(matrix_from_quat(q), quat_to_matrix(q, normalise=True))
    assert cubesat_quat_z_to is quat_z_to
    np.testing.assert_allclose(quat_to_axis_angle(np.array([1.0, 0, 0, 0]))[1], 0.0, atol=0)
    for bad, fn in (
        (np.zeros(4), lambda x: quat_to_matrix(x, normalise=True)),
        (np.zeros(3), quat_to_matrix),
        (np.zeros(3), quat_to_axis_angle),
    ):
        with pytest.raises(ValueError, match="^q: "):
            fn(bad)
    with pytest.raises(ValueError, match="^R: "):
        quat_from_matrix(np.eye(2))
    with pytest.raises(ValueError, match="^axis: "):
        quat_from_axis_angle(np.zeros(3), 1.0)
    with pytest.raises(ValueError, match="^d: "):
        direction_quaternions(np.zeros(3))
