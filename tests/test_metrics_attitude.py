"""Best-fit rotation, SO(3) log/exp, body rates, Euler angles, quaternions, inertia
(Robb et al. 2022a, Eqs. 7 and 21). Point sets: the two-layer N x N lattice (``tests.conftest.lattice_points``),
independent of the lattice module.

Tolerances. The Kabsch solution is the polar factor of H = P'^T Q'; its sensitivity to a
perturbation dH is about |dH| / (sigma_2 + sigma_3), and for the lattice sigma_2 + sigma_3 is of
the order of sigma_1, so rounding in the inputs (eps |q|) gives rotation errors of a few eps.
We observe <= 2e-14 and assert 1e-12 on rotation entries. The translation d = q_bar - R p_bar
inherits eps * |q| from the input coordinates (|q| <= ~1e3 m here): we assert 1e-10 m.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from magsail_mj.estimation import (
    BestFitRotation,
    best_fit_rotation,
    body_rate_step,
    body_rates,
    euler_zyx,
    hat,
    matrix_from_quat,
    particle_inertia,
    quat_from_matrix,
    rotation_angle,
    rotation_from_euler_zyx,
    so3_exp,
    so3_log,
    vee,
)
from tests.conftest import lattice_points


P20 = lattice_points(20, 75.0)

unit = st.floats(-1.0, 1.0, allow_nan=False)
quats = st.tuples(unit, unit, unit, unit)


def rot_from(qt) -> np.ndarray:
    q = np.asarray(qt, dtype=float)
    assume(np.linalg.norm(q) > 0.1)
    return Rotation.from_quat(q / np.linalg.norm(q), scalar_first=True).as_matrix()


# ------------------------------------------------------------------------------------------
# best-fit rotation
# ------------------------------------------------------------------------------------------
@settings(max_examples=60, deadline=None)
@given(qt=quats, d=st.tuples(*[st.floats(-1000.0, 1000.0)] * 3))
def test_best_fit_recovers_exact_rigid_motion(qt, d):
    R = rot_from(qt)
    d = np.asarray(d)
    q = P20 @ R.T + d
    Rf, df = best_fit_rotation(P20, q)
    assert np.abs(Rf - R).max() < 1e-12
    assert np.abs(df - d).max() < 1e-10
    assert np.linalg.det(Rf) == pytest.approx(1.0, abs=1e-13)


def test_best_fit_time_series_matches_single_calls():
    R = Rotation.random(50, random_state=3).as_matrix()
    d = np.random.default_rng(3).normal(size=(50, 3)) * 10
    q = np.einsum("tij,nj->tni", R, P20) + d[:, None, :]
    Rf, df = best_fit_rotation(P20, q)
    assert Rf.shape == (50, 3, 3) and df.shape == (50, 3)
    assert np.abs(Rf - R).max() < 1e-12
    assert np.abs(df - d).max() < 1e-10
    R7, d7 = best_fit_rotation(P20, q[7])
    assert np.abs(R7 - Rf[7]).max() < 1e-14 and np.abs(d7 - df[7]).max() < 1e-12
    fit = BestFitRotation(P20)  # reusable form for per-step use
    R7b, d7b = fit(q[7])
    assert np.array_equal(R7b, R7) and np.array_equal(d7b, d7)
    q_bad = q.copy()
    q_bad[13, 5, 1] = np.nan
    with pytest.raises(ValueError, match="q: contains NaN or Inf at time index 13"):
        fit(q_bad)


@settings(max_examples=40, deadline=None)
@given(qt=quats, seed=st.integers(0, 2**31 - 1))
def test_best_fit_noisy_points_within_noise(qt, seed):
    """Noise sigma per coordinate: the rotation error about axis e has standard deviation
    sigma / sqrt(I_e) (I_e = sum |e x p'|^2, unit masses) and the translation error
    sigma / sqrt(n) per component; assert 6-sigma bounds."""
    R = rot_from(qt)
    rng = np.random.default_rng(seed)
    sigma = 1e-3
    d = rng.normal(size=3) * 5
    q = P20 @ R.T + d + sigma * rng.normal(size=P20.shape)
    Rf, df = best_fit_rotation(P20, q)
    I_min = particle_inertia(P20, 1.0).principal.min()
    ang = rotation_angle(Rf, relative_to=R)
    assert ang < 6 * sigma / np.sqrt(I_min)
    assert np.linalg.norm(df - d) < 6 * sigma / np.sqrt(P20.shape[0])
    assert np.linalg.det(Rf) > 0


@settings(max_examples=40, deadline=None)
@given(qt=quats, seed=st.integers(0, 2**31 - 1))
def test_best_fit_never_returns_reflection(qt, seed):
    rng = np.random.default_rng(seed)
    M = rot_from(qt) @ np.diag([1.0, 1.0, -1.0])  # improper: a mirror image
    q_mirror = P20 @ M.T + rng.normal(size=3)
    q_random = rng.normal(size=P20.shape)
    for q in (q_mirror, q_random):
        Rf, _ = best_fit_rotation(P20, q)
        assert np.linalg.det(Rf) == pytest.approx(1.0, abs=1e-12)
        assert np.abs(Rf.T @ Rf - np.eye(3)).max() < 1e-12


@settings(max_examples=30, deadline=None)
@given(qt=quats)
def test_best_fit_planar_reference(qt):
    """A single layer (rank-2 H) still gives the exact rotation thanks to the det term."""
    R = rot_from(qt)
    top = P20[400:]
    Rf, _ = best_fit_rotation(top, top @ R.T)
    assert np.abs(Rf - R).max() < 1e-12


def test_best_fit_errors_name_argument():
    with pytest.raises(ValueError, match=r"q: expected shape \(n, 3\) or \(T, n, 3\), got \(4,\)"):
        best_fit_rotation(P20, np.zeros(4))
    with pytest.raises(ValueError, match="q: expected 800 points"):
        best_fit_rotation(P20, P20[:10])
    with pytest.raises(ValueError, match="p_ref: expected shape"):
        best_fit_rotation(P20[:, :2], P20)
    with pytest.raises(ValueError, match="p_ref: points are collinear"):
        line = np.outer(np.arange(5.0), [1.0, 2.0, 3.0])
        best_fit_rotation(line, line)


# ------------------------------------------------------------------------------------------
# SO(3) log / exp, rotation angle, quaternions
# ------------------------------------------------------------------------------------------
def test_so3_log_matches_scipy_and_roundtrips():
    rv = Rotation.random(2000, random_state=5).as_rotvec()
    R = Rotation.from_rotvec(rv).as_matrix()
    assert np.abs(so3_log(R) - rv).max() < 1e-13
    assert np.abs(so3_exp(rv) - R).max() < 1e-14
    assert np.abs(rotation_angle(R) - np.linalg.norm(rv, axis=-1)).max() < 1e-14


@pytest.mark.parametrize(
    "theta", [0.0, 1e-12, 1e-8, 1e-5, 1e-4, 0.3, 2.0, np.pi / 2 * 1.9, np.pi - 1e-4, np.pi - 1e-7, np.pi - 1e-10, np.pi]
)
def test_so3_log_near_zero_and_pi(theta):
    axes = np.random.default_rng(11).normal(size=(50, 3))
    axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
    rv = theta * axes
    R = Rotation.from_rotvec(rv).as_matrix()
    w = so3_log(R)
    # angle exact to rounding in the whole range
    assert np.abs(np.linalg.norm(w, axis=-1) - theta).max() < 4e-15 * max(1.0, theta)
    assert np.abs(so3_exp(w) - R).max() < 1e-14
    if theta < np.pi - 1e-9:  # at exactly pi, +axis and -axis are the same rotation
        assert np.abs(w - rv).max() < 1e-14 * max(1.0, theta / max(np.pi - theta, 1e-3))


def test_hat_vee_inverse():
    w = np.random.default_rng(0).normal(size=(10, 3))
    v = np.random.default_rng(1).normal(size=(10, 3))
    assert np.allclose(np.einsum("nij,nj->ni", hat(w), v), np.cross(w, v), atol=1e-15)
    assert np.array_equal(vee(hat(w)), w)


def test_quaternion_roundtrip_and_scipy():
    R = Rotation.random(1000, random_state=9).as_matrix()
    q = quat_from_matrix(R)
    ref = Rotation.from_matrix(R).as_quat(scalar_first=True)
    ref *= np.sign(ref[:, :1])
    assert np.all(q[:, 0] >= 0)
    assert np.abs(q - ref).max() < 1e-15 * 4
    assert np.abs(matrix_from_quat(q) - R).max() < 2e-15
    # rotations by pi (w = 0) and the identity
    Rpi = Rotation.from_rotvec(np.pi * np.eye(3)).as_matrix()
    qpi = quat_from_matrix(Rpi)
    assert np.abs(qpi[:, 0]).max() < 1e-15
    assert np.abs(matrix_from_quat(qpi) - Rpi).max() < 1e-15
    assert np.array_equal(quat_from_matrix(np.eye(3)), [1.0, 0, 0, 0])
    with pytest.raises(ValueError, match=r"q: expected shape \(\.\.\., 4\)"):
        matrix_from_quat(np.zeros(3))


# ------------------------------------------------------------------------------------------
# body rates
# ------------------------------------------------------------------------------------------
def constant_rate_sequence(omega_b, dt, T, R0):
    """R_k = R0 exp(k dt hat(omega_b)), each built directly (no accumulation)."""
    k = np.arange(T)[:, None]
    return R0 @ Rotation.from_rotvec(k * dt * omega_b).as_matrix()


def test_body_rates_log_exact_for_constant_rate():
    omega_b = np.array([0.01, -0.007, 0.03])
    R0 = Rotation.from_rotvec([0.3, -1.2, 2.0]).as_matrix()
    for dt in (0.1, 1.0, 10.0):
        R = constant_rate_sequence(omega_b, dt, 2000, R0)
        w = body_rates(R, dt, omega0=omega_b)
        # rounding: eps / dt per step from R_{k-1}^T R_k; a few eps * |omega| otherwise
        assert np.abs(w - omega_b).max() < 1e-12 / dt
    w0 = body_rates(R[:3], 10.0)
    assert np.array_equal(w0[0], np.zeros(3))


def test_body_rates_first_order_error_is_o_dt():
    omega_b = np.array([0.2, -0.1, 0.05])
    om = np.linalg.norm(omega_b)
    R0 = Rotation.from_rotvec([1.0, 0.5, -0.2]).as_matrix()
    errs = []
    for dt in (0.4, 0.2, 0.1, 0.05):
        R = constant_rate_sequence(omega_b, dt, 50, R0)
        w = body_rates(R, dt, method="first_order")[1:]
        err = np.abs(w - omega_b).max()
        # closed form for a constant rate: w = omega sin(|omega| dt)/(|omega| dt)
        x = om * dt
        assert np.abs(w - omega_b * np.sin(x) / x).max() < 1e-13 / dt
        assert err <= np.abs(omega_b).max() * x * x / 6 * (1 + 1e-6)
        assert err < 0.05 * dt * om  # at least O(dt) (here in fact O(dt^2))
        errs.append(err)
    assert all(e1 > e2 for e1, e2 in zip(errs, errs[1:]))


def test_body_rates_nonuniform_dt_and_step_form():
    omega_b = np.array([0.0, 0.02, 0.0])
    t = np.cumsum(np.r_[0.0, np.random.default_rng(2).uniform(0.05, 0.2, 99)])
    R = Rotation.from_rotvec(t[:, None] * omega_b).as_matrix()
    w = body_rates(R, np.diff(t))
    assert np.abs(w[1:] - omega_b).max() < 1e-13
    assert np.abs(body_rate_step(R[4], R[5], t[5] - t[4]) - w[5]).max() == 0.0
    with pytest.raises(ValueError, match="dt: must be > 0"):
        body_rates(R, 0.0)
    with pytest.raises(ValueError, match="method: expected"):
        body_rates(R, 0.1, method="euler")
    with pytest.raises(ValueError, match=r"omega0: expected shape \(3,\)"):
        body_rates(R, 0.1, omega0=[1.0, 2.0])


def test_body_rates_from_best_fit_of_spinning_lattice():
    """End to end: positions of a rigidly spinning lattice -> best fit -> rates."""
    # detumble initial rate (Robb et al. 2022a: the text's value; Table 2 prints 0.07)
    omega_b = np.array([0.01, 0.007, 0.0])
    dt = 0.1
    R = constant_rate_sequence(omega_b, dt, 300, np.eye(3))
    q = np.einsum("tij,nj->tni", R, P20) + np.array([1.0, 2.0, 3.0])
    Rf, _ = best_fit_rotation(P20, q)
    w = body_rates(Rf, dt, omega0=omega_b)
    assert np.abs(w - omega_b).max() < 1e-12


# ------------------------------------------------------------------------------------------
# Euler angles
# ------------------------------------------------------------------------------------------
@settings(max_examples=100, deadline=None)
@given(
    psi=st.floats(-np.pi + 1e-9, np.pi - 1e-9),
    theta=st.floats(-np.pi / 2 + 1e-3, np.pi / 2 - 1e-3),
    phi=st.floats(-np.pi + 1e-9, np.pi - 1e-9),
)
def test_euler_zyx_roundtrip(psi, theta, phi):
    R = rotation_from_euler_zyx(psi, theta, phi)
    ref = Rotation.from_euler("ZYX", [psi, theta, phi]).as_matrix()  # intrinsic Z-Y'-X''
    assert np.abs(R - ref).max() < 1e-15 * 8
    p2, t2, f2 = euler_zyx(R)
    tol = 1e-14 / np.cos(theta)  # psi, phi lose accuracy ~ eps / cos(theta) near gimbal lock
    assert abs(t2 - theta) < 1e-14
    assert abs(np.angle(np.exp(1j * (p2 - psi)))) < tol
    assert abs(np.angle(np.exp(1j * (f2 - phi)))) < tol


def test_euler_zyx_matrix_roundtrip_and_unwrap():
    R = Rotation.random(500, random_state=4).as_matrix()
    e = euler_zyx(R)
    assert np.abs(rotation_from_euler_zyx(*e) - R).max() < 1e-13
    # a steady yaw spin passes through +-pi: unwrapped psi is the straight line
    psi_true = np.linspace(0.0, 6 * np.pi, 400)
    Rs = rotation_from_euler_zyx(psi_true, 0.2, -0.1)
    psi, theta, phi = euler_zyx(Rs, unwrap=True)
    assert np.abs(psi - psi_true).max() < 1e-12
    assert np.abs(theta - 0.2).max() < 1e-14 and np.abs(phi + 0.1).max() < 1e-14
    psi_w, _, _ = euler_zyx(Rs)
    assert psi_w.max() <= np.pi and psi_w.min() >= -np.pi
    with pytest.raises(ValueError, match="R: unwrap needs a time series"):
        euler_zyx(np.eye(3), unwrap=True)


def test_rotation_angle_relative():
    R0 = Rotation.from_rotvec([0.1, 0.2, 0.3]).as_matrix()
    dR = Rotation.from_rotvec([0.0, 0.0, 0.25]).as_matrix()
    assert rotation_angle(R0 @ dR, relative_to=R0) == pytest.approx(0.25, abs=1e-15)


# ------------------------------------------------------------------------------------------
# inertia (Eq. 21; the printed Sec. 4.3 values are 55–72x smaller than Eq. 21 gives)
# ------------------------------------------------------------------------------------------
def test_particle_inertia_75m_truss():
    inert = particle_inertia(P20, 0.25)
    I1, I2, I3 = inert.moments
    assert I1 == pytest.approx(1.0440e5, rel=1e-4)
    assert I2 == pytest.approx(I1, rel=1e-14)
    assert I3 == pytest.approx(2.0724e5, rel=1e-4)
    # closed form: sum over one axis of x_i^2 = a^2 N (N^2 - 1)/12, z = +-a/2
    N, a, m = 20, 75.0 / 19, 0.25
    sx2 = a * a * N * (N * N - 1) / 12
    assert I3 == pytest.approx(m * 2 * N * 2 * sx2, rel=1e-14)
    assert I1 == pytest.approx(m * (2 * N * sx2 + 2 * N * N * a * a / 4), rel=1e-14)
    assert np.abs(inert.tensor - np.diag(inert.moments)).max() < 1e-9
    assert np.abs(inert.com).max() < 1e-13 and inert.mass == pytest.approx(200.0)
    # rotated set: tensor rotates as R J R^T, principal moments unchanged
    R = Rotation.from_rotvec([0.4, -0.3, 1.0]).as_matrix()
    rot = particle_inertia(P20 @ R.T + 5.0, np.full(800, 0.25))
    assert np.abs(rot.tensor - R @ inert.tensor @ R.T).max() < 1e-9
    assert np.allclose(rot.principal, np.sort(inert.moments), rtol=1e-13)
    with pytest.raises(ValueError, match=r"m: expected a scalar or shape \(800,\)"):
        particle_inertia(P20, np.ones(3))
