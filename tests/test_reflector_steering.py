"""Reflector Scenario B kinematics and control laws (Robb et al. 2020): field Eq. 11, steering law
Eqs. 12–13 and ψ̈ against finite differences, unwrapping, q_ref, controller sign, projection ⟂ B."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import simpson

from magsail_mj.control.reflector_pitch import ReflectorPitchController, pitch_gains, project_and_saturate
from magsail_mj.quaternion import error_quaternion, quat_to_matrix
from magsail_mj.control.reflector_steering import (
    ReflectorOrbit,
    SteeringReference,
    pitch_angle_from_quaternion,
    pitch_reference_quaternion,
)

ORBIT = ReflectorOrbit.from_altitude(altitude_m=800e3)
T_F = 10 * ORBIT.period_s


def test_orbit_constants_and_phases():
    assert ORBIT.r_m == 7171e3
    assert ORBIT.period_s == pytest.approx(2 * math.pi * math.sqrt(7171e3**3 / 3.986004418e14))
    assert ORBIT.t_mid_s == pytest.approx(T_F / 2)
    # overhead at t_m: reflector and ground point both on +x
    r, R = ORBIT.position(ORBIT.t_mid_s), ORBIT.ground_point(ORBIT.t_mid_s)
    assert np.allclose(r / np.linalg.norm(r), [1, 0, 0]) and np.allclose(R / np.linalg.norm(R), [1, 0, 0])
    assert ORBIT.theta(0.0) == pytest.approx(-ORBIT.n_rad_s * ORBIT.t_mid_s)
    assert math.cos(ORBIT.theta(0.0)) == pytest.approx(1.0)  # θ₀ ≡ 0 mod 2π


def test_dipole_field_eq11():
    k = 3.12e-5 * (6371e3 / 7171e3) ** 3
    t = ORBIT.t_mid_s + np.array([0.0, 0.25, 0.5, 0.75]) * ORBIT.period_s  # θ = 0, π/2, π, 3π/2
    B = ORBIT.field(t)
    assert np.allclose(B[:, 1], 0.0)
    assert np.allclose(np.linalg.norm(B, axis=1), [k, 2 * k, k, 2 * k], rtol=1e-12)
    assert np.allclose(B[0], [0, 0, -k], atol=1e-18)  # equator: B = B_θ ê_θ, ê_θ = ẑ
    assert np.allclose(B[1], [0, 0, -2 * k], atol=1e-18)  # north pole: B_r ê_r = −2k ẑ


def _times(n=400, seed=0):
    return np.sort(np.random.default_rng(seed).uniform(10.0, T_F - 10.0, n))


def test_psi_dot_eq13_matches_finite_difference_of_unwrapped_psi():
    h = 0.01
    for t in _times():
        s = ORBIT.psi_series(np.array([t - h, t, t + h]))
        fd = (s["psi_c"][2] - s["psi_c"][0]) / (2 * h)
        assert fd == pytest.approx(s["psi_dot"][1], rel=1e-6)


def test_psi_ddot_matches_finite_difference_of_eq13():
    h = 0.01
    t = _times(seed=1)
    _, _, pdd, _ = ORBIT.rates(t)
    _, pd_p, _, _ = ORBIT.rates(t + h)
    _, pd_m, _, _ = ORBIT.rates(t - h)
    fd = (pd_p - pd_m) / (2 * h)
    away = np.abs(pdd) > 1e-3 * np.max(np.abs(pdd))  # away from the zero crossings
    assert away.sum() > 300
    assert np.allclose(fd[away], pdd[away], rtol=1e-6, atol=0)


def test_integral_of_psi_dot_equals_change_of_unwrapped_psi():
    t = np.linspace(0.0, T_F, 600_001)
    s = ORBIT.psi_series(t)
    integral = simpson(s["psi_dot"], x=t)
    assert integral == pytest.approx(s["psi_c"][-1] - s["psi_c"][0], rel=1e-9)
    assert np.max(np.abs(np.diff(s["psi_c"]))) < 0.01  # continuous: no π or 2π jumps


def test_unwrapped_psi_equals_eq12_modulo_pi_and_online_reference_matches():
    t = np.linspace(0.0, T_F, 20_001)
    s = ORBIT.psi_series(t)
    th, ph = ORBIT.theta(t), ORBIT.phi(t)
    a = ORBIT.r_m * np.cos(th) - ORBIT.R_e_m * np.cos(ph)
    b = ORBIT.r_m * np.sin(th)
    ok = np.abs(b) > 1.0
    eq12 = np.pi / 2 - np.arctan(a[ok] / b[ok])
    d = np.mod(s["psi_c"][ok] - eq12, np.pi)
    assert np.allclose(np.minimum(d, np.pi - d), 0.0, atol=1e-9)
    online = SteeringReference(ORBIT)
    psi_online = np.array([online.at(x).psi_c for x in t])
    assert np.allclose(psi_online, s["psi_c"], atol=1e-12)


def test_q_ref_puts_the_grey_line_perpendicular_to_r_rad():
    """Reference attitude: R(q_ref) x̂ · (a, 0, b) = 0; body z along (a, 0, b); ω_ref = −ψ̇ ŷ."""
    ref = SteeringReference(ORBIT)
    for t in np.linspace(0.0, T_F, 257):
        st = ref.at(t)
        R = quat_to_matrix(st.q_ref)
        r_rad = ORBIT.position(t) - ORBIT.ground_point(t)
        inplane = np.array([r_rad[0], 0.0, r_rad[2]])
        assert R[:, 0] @ inplane == pytest.approx(0.0, abs=1e-6 * np.linalg.norm(inplane))
        assert R[:, 2] @ inplane / np.linalg.norm(inplane) == pytest.approx(1.0, abs=1e-12)
        assert st.beta_ref == pytest.approx(math.pi / 2 - st.psi_c)
    # pitch angle read back from q_ref (unwrapped) equals β_ref
    t = np.linspace(0.0, T_F, 5001)
    s = ORBIT.psi_series(t)
    assert np.allclose(pitch_angle_from_quaternion(pitch_reference_quaternion(s["beta_ref"])), s["beta_ref"])


def _controller(**kw):
    opts = dict(
        orbit=ORBIT,
        inertia_kgm2=(8.3e5, 8.3e5, 1.67e6),
        omega_n_rad_s=0.1,
        zeta=0.7,
        rate_term="absolute",
        feedforward=False,
        saturation="norm",
        cap_Nm=1e9,
        B_ref_T=30e-6,
        m_max_Am2=(37500.0, 37500.0, 38440.0),
        body_id=1,
        period_s=0.5,
    )
    opts.update(kw)
    return ReflectorPitchController(**opts)


def test_controller_sign_restoring_about_plus_y():
    """Eqs. 14–15: a small positive rotation away from the reference about +y gives a negative y torque."""
    ctl = _controller()
    st = SteeringReference(ORBIT).at(1234.0)
    d = 0.01
    q = np.array([math.cos(st.beta_ref / 2 + d / 2), 0.0, math.sin(st.beta_ref / 2 + d / 2), 0.0])
    T, q_e, _ = ctl.reference_torque(q, np.zeros(3), 1234.0)
    assert T[1] < 0 and abs(T[0]) < 1e-9 * abs(T[1]) and abs(T[2]) < 1e-9 * abs(T[1])
    Pq, _ = pitch_gains((8.3e5, 8.3e5, 1.67e6), omega_n_rad_s=0.1, zeta=0.7)
    assert T[1] == pytest.approx(-Pq[1] * math.sin(d / 2), rel=1e-9)
    assert q_e[2] == pytest.approx(math.sin(d / 2))


def test_rate_error_variant_and_feedforward_vanish_on_the_reference():
    ctl = _controller(rate_term="error", feedforward=False)
    st = SteeringReference(ORBIT).at(ORBIT.t_mid_s)
    T, _, _ = ctl.reference_torque(st.q_ref, np.array([0.0, -st.psi_dot, 0.0]), ORBIT.t_mid_s)
    assert np.allclose(T, 0.0, atol=1e-9)
    ctl = _controller(rate_term="error", feedforward=True)
    T, _, ref = ctl.reference_torque(st.q_ref, np.array([0.0, -st.psi_dot, 0.0]), ORBIT.t_mid_s)
    assert T[1] == pytest.approx(8.3e5 * -ref.psi_ddot, rel=1e-9)


def test_error_quaternion_shortest_path():
    q_ref = np.array([1.0, 0, 0, 0])
    q = -np.array([math.cos(0.1), 0, math.sin(0.1), 0])
    qe = error_quaternion(q_ref, q)
    assert qe[0] > 0 and qe[2] == pytest.approx(math.sin(0.1))


def test_projection_perpendicular_to_B_and_saturation_modes():
    rng = np.random.default_rng(3)
    m_max = np.array([37500.0, 37500.0, 38440.0])
    for _ in range(50):
        T = rng.normal(size=3) * 3.0
        B = rng.normal(size=3) * 3e-5
        for mode in ("norm", "field_scaled", "per_path"):
            Ta, sat = project_and_saturate(T, B, saturation=mode, cap_Nm=1.125, B_ref_T=30e-6, m_max_Am2=m_max)
            assert abs(Ta @ B) <= 1e-12 * np.linalg.norm(Ta) * np.linalg.norm(B) + 1e-30
            if mode == "norm":
                assert np.linalg.norm(Ta) <= 1.125 * (1 + 1e-12)
            if mode == "field_scaled":
                assert np.linalg.norm(Ta) <= 1.125 * np.linalg.norm(B) / 30e-6 * (1 + 1e-12)
    # a pure pitch torque is never reduced by the projection when B lies in the xz plane
    Ta, sat = project_and_saturate(
        np.array([0.0, 0.7, 0.0]),
        np.array([2e-5, 0.0, -1e-5]),
        saturation="norm",
        cap_Nm=1.125,
        B_ref_T=30e-6,
        m_max_Am2=m_max,
    )
    assert np.allclose(Ta, [0, 0.7, 0]) and not sat
    # per-path: the unclipped dipole reproduces the projected torque exactly
    B = np.array([1e-5, 2e-5, -2e-5])
    T = np.array([0.1, -0.2, 0.05])
    Ta, sat = project_and_saturate(T, B, saturation="per_path", cap_Nm=1.0, B_ref_T=30e-6, m_max_Am2=m_max)
    b = B / np.linalg.norm(B)
    assert not sat and np.allclose(Ta, T - b * (b @ T))
