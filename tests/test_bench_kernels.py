"""The plain-float per-step kernels of the cubesat equal their NumPy / library definitions.

Tolerances: a float kernel sums in another order than NumPy's BLAS products (which may fuse
multiply-adds), so results agree to a few units of round-off of the largest term: 1e-15 relative
to the scale of the terms for single products, 1e-14 for chains (rotation, normalisation, atan2).
"""

from __future__ import annotations

import math

import magsail_mj  # noqa: F401  (before mujoco: GL backend choice)
import mujoco
import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from magsail_mj.concepts.cnusail.disturbances import CubesatDisturbanceLoad, cubesat_drag_facets
from magsail_mj.concepts.cnusail.eigenaxis import (
    eigen_angle,
    eigen_angle_f,
    error_quaternion,
    error_quaternion_f,
    orbital_rate,
    rate_error,
    rate_error_f,
)
from magsail_mj.concepts.cnusail.modes import Mode, command_frame, command_quaternion
from magsail_mj.loads.actuators_cubesat import MagnetorquerLoad, WheelDriver
from magsail_mj.loads.base import StepState
from magsail_mj.vec3 import cross_f, dot_f, mat_t_vec_f, mat_vec_f, norm_f

finite = st.floats(-1e6, 1e6, allow_nan=False)
vec = arrays(float, 3, elements=finite)
mat = arrays(float, (3, 3), elements=finite)
seeds = st.integers(0, 2**32 - 1)


def _unit_quat(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


@settings(max_examples=200, deadline=None)
@given(vec, vec, mat)
def test_vector_helpers_equal_numpy(a, b, R):
    scale = max(1.0, float(np.abs(a).max() * max(np.abs(b).max(), np.abs(R).max())))
    tol = dict(rtol=0, atol=4e-16 * 3 * scale)
    np.testing.assert_allclose(cross_f(a.tolist(), b.tolist()), np.cross(a, b), **tol)
    np.testing.assert_allclose(dot_f(a.tolist(), b.tolist()), a @ b, **tol)
    np.testing.assert_allclose(norm_f(a.tolist()), np.linalg.norm(a), rtol=1e-15, atol=1e-300)
    Rl = R.ravel().tolist()
    np.testing.assert_allclose(mat_vec_f(Rl, a.tolist()), R @ a, **tol)
    np.testing.assert_allclose(mat_t_vec_f(Rl, a.tolist()), R.T @ a, **tol)
    np.testing.assert_allclose(mat_t_vec_f(Rl, a.tolist()), a @ R, **tol)


@settings(max_examples=200, deadline=None)
@given(seeds, st.booleans())
def test_attitude_telemetry_floats_equal_numpy(seed, shortest):
    rng = np.random.default_rng(seed)
    p_c, p_b = _unit_quat(rng), _unit_quat(rng)
    p_e = error_quaternion_f(p_c.tolist(), p_b.tolist(), shortest=shortest)
    ref = error_quaternion(p_c, p_b, shortest=shortest)
    np.testing.assert_allclose(p_e, ref, rtol=0, atol=1e-15)
    assert math.isclose(eigen_angle_f(p_e), float(eigen_angle(ref)), rel_tol=0, abs_tol=1e-14)
    omega, w_o = rng.normal(size=3) * 0.1, float(rng.uniform(0, 2e-3))
    np.testing.assert_allclose(rate_error_f(omega.tolist(), p_e, w_o), rate_error(omega, ref, w_o), rtol=0, atol=1e-16)


@settings(max_examples=200, deadline=None)
@given(seeds, st.sampled_from([Mode.DETUMBLE, Mode.NADIR, Mode.DEORBIT]))
def test_command_frame_equals_command_quaternion_and_orbital_rate(seed, mode):
    rng = np.random.default_rng(seed)
    r = rng.normal(size=3) * 7e6
    v = np.cross(rng.normal(size=3), r)
    v *= 7.5e3 / np.linalg.norm(v)
    v += rng.normal(size=3) * 100.0  # not exactly circular
    q, w_o = command_frame(int(mode), r, v)
    np.testing.assert_allclose(q, command_quaternion(mode, r, v), rtol=0, atol=2e-15)
    assert math.isclose(w_o, orbital_rate(r, v), rel_tol=1e-14)
    assert q[0] >= 0 and math.isclose(float(q @ q), 1.0, rel_tol=1e-15)


class _Env:
    def __init__(self, rng: np.random.Generator) -> None:
        self.r_ref_eci = rng.normal(size=3) * 7e6
        self.v_rel_eci = rng.normal(size=3) * 7.5e3
        self.B_eci = rng.normal(size=3) * 3e-5
        self.sun_eci = np.zeros(3)
        self.density_kg_m3 = 1e-12
        self.srp_pressure_N_m2 = 0.0


def _state(rng: np.random.Generator, ctrl=None) -> StepState:
    xq = np.array([[1.0, 0, 0, 0], _unit_quat(rng)])
    return StepState(
        t=float(rng.uniform()),
        pos=rng.normal(size=(2, 3)),
        vel=rng.normal(size=(2, 3)),
        xquat=xq,
        omega=np.zeros((2, 3)),
        env=_Env(rng),
        ctrl=ctrl,
    )


def _numpy_disturbances(load: CubesatDisturbanceLoad, s: StepState) -> np.ndarray:
    """The stowed cubesat's body torques with NumPy arrays (the expressions the float kernel replaced)."""
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, s.xquat[1])
    R = R.reshape(3, 3)
    r_b = (s.env.r_ref_eci + s.pos[1]) @ R
    rn = np.linalg.norm(r_b)
    u = r_b / rn
    gg = 3.0 * load.mu / rn**3 * np.cross(u, load.inertia @ u)
    V = (s.env.v_rel_eci + s.vel[1]) @ R
    f = load.drag_facets
    proj = f.normal @ V
    proj = np.where(f.two_sided, np.abs(proj), np.maximum(proj, 0.0))
    lever = s.env.density_kg_m3 * (proj @ ((-0.5 * load.cd * f.area)[:, None] * f.centre))
    dip = np.cross(load.dipole, s.env.B_eci @ R)
    return np.array([gg, np.cross(lever, V), np.zeros(3), dip])


@settings(max_examples=100, deadline=None)
@given(seeds)
def test_disturbance_kernel_equals_numpy_expressions(seed):
    rng = np.random.default_rng(seed)
    drag = cubesat_drag_facets(
        configuration="stowed",
        surfaces="sail+bus",
        sail_area_m2=4.0,
        r_cp_m=(0.01, 0.01, 0.1),
        bus_size_m=(0.1, 0.1, 0.3),
        bus_centroid_m=(0.005, 0.005, -0.02),
    )
    load = CubesatDisturbanceLoad(
        1, inertia_kgm2=[0.0506, 0.0506, 0.010], drag_facets=drag, srp_facets=None, residual_dipole_Am2=[2.887e-4] * 3
    )
    s = _state(rng)
    ref = _numpy_disturbances(load, s)
    T = load.torques_body(s)
    scale = np.abs(ref).max(axis=1, keepdims=True)
    for row in range(4):
        np.testing.assert_allclose(T[row], ref[row], rtol=0, atol=1e-14 * max(scale[row, 0], 1e-300))
    x = np.zeros((2, 6))
    load.add(s, x)
    R = load.rotation(s)
    np.testing.assert_allclose(x[1, 3:], R @ ref.sum(axis=0), rtol=0, atol=1e-14 * np.abs(ref).max())
    assert not x[:, :3].any() and not x[0].any()


@settings(max_examples=100, deadline=None)
@given(seeds, st.booleans())
@example(47648, False)  # a component far below max|ref|: an atol of 1e-15 max|ref| failed it
def test_magnetorquer_kernel_equals_numpy(seed, as_list):
    """T = (R m) × B in floats equals NumPy's within the rounding bound of the operation.

    Both evaluate a = R m (each a_j a sum of three products, |δa_j| ≤ γ₃ Σ_k |R_jk||m_k| ≤ γ₃ |m|,
    the rows of R being unit vectors; R is the same array in both) and then
    T_x = a_y B_z − a_z B_y (|δT_x| ≤ |δa_y||B_z| + |δa_z||B_y| + γ₂ (|a_y B_z| + |a_z B_y|)
    ≤ 5u √2 |m||B| to first order, u = eps/2 the unit round-off, γ_n ≈ n u). The two results thus
    differ by at most 10√2 u |m||B| ≈ 7.1 eps |m||B| per component: the tolerance is
    8 eps |m||B|, the rounding of the largest terms contributing to a component, not of the
    component itself (which cancellation can make far smaller than max|ref|)."""
    rng = np.random.default_rng(seed)

    class Cmd:
        dipole_body = rng.normal(size=3) * 0.1

    if as_list:
        Cmd.dipole_body = Cmd.dipole_body.tolist()
    s = _state(rng, ctrl=Cmd())
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, s.xquat[1])
    ref = np.cross(R.reshape(3, 3) @ np.asarray(Cmd.dipole_body), s.env.B_eci)
    x = np.zeros((2, 6))
    MagnetorquerLoad(1).add(s, x)
    bound = 8 * np.finfo(float).eps * np.linalg.norm(Cmd.dipole_body) * np.linalg.norm(s.env.B_eci)
    np.testing.assert_allclose(x[1, 3:], ref, rtol=0, atol=bound)


@settings(max_examples=100, deadline=None)
@given(seeds)
def test_quasi_static_wheel_kernel_equals_vector_form(seed):
    """Steps 3–4 of the wheel driver in floats = V clip, i = (V − K_b ω)/R, T = K_M i, speed limiter,
    evaluated with NumPy arrays (``electrical='quasi_static'``, speeds around the limit)."""
    rng = np.random.default_rng(seed)
    drv = WheelDriver()
    p = drv.p
    cmd = rng.uniform(-2, 2, size=3) * p.current_max_A
    w = rng.choice([-1.0, 1.0], size=3) * rng.uniform(0.9, 1.1, size=3) * p.speed_max_rad_s
    T = drv.motor_torque(cmd, w, 0.1)
    V = np.clip(p.R_ohm * cmd + p.K_b_Vs_rad * w, -p.V_max_V, p.V_max_V)
    i = (V - p.K_b_Vs_rad * w) / p.R_ohm
    ref = drv.limit_speed(p.K_M_Nm_A * i, w)
    np.testing.assert_array_equal(T, ref)  # same operations elementwise: identical
    np.testing.assert_array_equal(drv.current_A, i)
    np.testing.assert_array_equal(drv.motor_torque(cmd, w.tolist(), 0.1), ref)
