"""CNUSAIL-1 control laws (Yoo et al. 2016, Eqs. 2–3, 24–40, and the mode logic): quaternion conventions,
eigen-axis gains and slew-rate limit, PD sign and stability, B-dot dissipation, unloading, modes."""

from __future__ import annotations

import math

import magsail_mj  # noqa: F401  (before mujoco: GL backend choice)
import mujoco
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from magsail_mj.control.bdot import BdotFiltered, BdotFiniteDifference, make_bdot
from magsail_mj.concepts.cnusail.modes import (
    Mode,
    ModeLogicParams,
    ModeManager,
    command_quaternion,
    deorbit_command_matrix,
    nadir_command_matrix,
)
from magsail_mj.concepts.cnusail.eigenaxis import (
    attitude_matrix,
    eigen_angle,
    eigen_axis_gains,
    eigen_axis_torque,
    error_quaternion,
    paper_error_quaternion,
    quat_from_paper,
    quat_to_paper,
    rate_error,
)
from magsail_mj.quaternion import quat_conj, quat_mul
from magsail_mj.concepts.cnusail.pd import pd_torque
from magsail_mj.concepts.cnusail.unloading import UnloadingLogic, unloading_dipole
from magsail_mj.estimation.attitude import matrix_from_quat

DEG = math.pi / 180
J_DEP = np.diag([0.3104, 0.3121, 0.5757])
RNG = np.random.default_rng(3)


def _rand_quat():
    q = RNG.normal(size=4)
    return q / np.linalg.norm(q)


# ------------------------------------------------------------------ conventions (Eqs. 2–3)


def test_attitude_matrix_is_xmat_transpose_after_reordering():
    for _ in range(20):
        p = _rand_quat()
        xmat = np.empty(9)
        mujoco.mju_quat2Mat(xmat, p)
        np.testing.assert_allclose(attitude_matrix(quat_to_paper(p)), xmat.reshape(3, 3).T, atol=1e-14)
        np.testing.assert_allclose(quat_from_paper(quat_to_paper(p)), p)


def test_eq37_equals_hamilton_error():
    for _ in range(20):
        pc, pb = _rand_quat(), _rand_quat()
        pe = quat_mul(quat_conj(pc), pb)
        np.testing.assert_allclose(
            paper_error_quaternion(quat_to_paper(pc), quat_to_paper(pb)), quat_to_paper(pe), atol=1e-14
        )
        # A(q_e) = A(q) A(q_c)^T
        np.testing.assert_allclose(
            attitude_matrix(quat_to_paper(pe)),
            attitude_matrix(quat_to_paper(pb)) @ attitude_matrix(quat_to_paper(pc)).T,
            atol=1e-13,
        )


def test_kinematics_adot():
    """Under Eq. 2, Ȧ = −[ω×] A (finite difference of A along a short rotation)."""
    p = _rand_quat()
    w = np.array([0.02, -0.05, 0.03])
    h = 1e-6
    step = np.concatenate(
        [[math.cos(np.linalg.norm(w) * h / 2)], math.sin(np.linalg.norm(w) * h / 2) * w / np.linalg.norm(w)]
    )
    A0 = attitude_matrix(quat_to_paper(p))
    A1 = attitude_matrix(quat_to_paper(quat_mul(p, step)))
    skew = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    np.testing.assert_allclose((A1 - A0) / h, -skew @ A0, atol=1e-7)


def test_deorbit_command_error_from_nadir_attitude():
    r = np.array([6.9e6, 1.0e5, -2.0e5])
    v = np.array([-100.0, 1000.0, 7400.0])
    p_body = command_quaternion(Mode.NADIR, r, v)
    p_c = command_quaternion(Mode.DEORBIT, r, v)
    pe = error_quaternion(p_c, p_body)
    np.testing.assert_allclose(quat_to_paper(pe), [0.0, math.sqrt(0.5), 0.0, math.sqrt(0.5)], atol=1e-12)
    M = nadir_command_matrix(r, v)
    np.testing.assert_allclose(M[:, 2], r / np.linalg.norm(r))  # z_R = zenith
    assert M[:, 0] @ v < 0  # x_R ≈ −v̂
    D = deorbit_command_matrix(r, v)
    assert D[:, 2] @ v / np.linalg.norm(v) > 0.999  # sail normal along the flight


def test_s3_initial_eigen_angle():
    """The paper's initial error quaternion of the stowed nadir slew has unit norm to 3e-5 and
    eigen-angle 146.5° within 0.1°."""
    q = np.array([0.2876, 0.6460, 0.2876, -0.6460])
    assert abs(np.linalg.norm(q) - 1) < 3e-5
    assert abs(math.degrees(eigen_angle(q / np.linalg.norm(q))) - 146.5) < 0.1


def test_rate_error_zero_for_body_locked_to_command():
    """A body at the command attitude turning with R (ω = [0, −ω_o, 0]) has ω_e = 0."""
    w_o = 1.09e-3
    pe = np.array([1.0, 0, 0, 0])
    np.testing.assert_allclose(rate_error(np.array([0, -w_o, 0]), pe, w_o), 0, atol=1e-18)
    pe = _rand_quat()
    w = -rate_error(np.zeros(3), pe, w_o)  # ω = A(q_e)[0, −ω_o, 0]
    np.testing.assert_allclose(w, attitude_matrix(quat_to_paper(pe)) @ [0, -w_o, 0], atol=1e-18)


# ------------------------------------------------------------------ gains (Eqs. 28–38, our reading)


def test_eigen_axis_gains_and_clamp():
    q0 = np.array([0.6460, 0.2876, -0.6460])
    g = eigen_axis_gains(q0, omega_n_rad_s=0.02, zeta=0.9, rate_max_rad_s=0.3 * DEG)
    assert g.k == pytest.approx(2 * 0.02**2) and g.c == pytest.approx(2 * 0.9 * 0.02)
    np.testing.assert_allclose(g.k_i * g.p_i, g.k)  # K P = k J
    np.testing.assert_allclose(np.linalg.norm(g.k_i) / g.c, 0.3 * DEG)  # |k|/c = θ̇_max
    # deorbit case: components below 0.1 are clamped for the gains only
    g2 = eigen_axis_gains(np.array([0.0, 0.7071, 0.0]), omega_n_rad_s=0.02, zeta=0.9, rate_max_rad_s=0.3 * DEG)
    np.testing.assert_allclose(g2.q_ref, [0.1, 0.7071, 0.1])
    assert g2.theta_true_rad == pytest.approx(math.pi / 2, abs=1e-4)
    assert g2.theta_clamped_rad > g2.theta_true_rad
    with pytest.raises(ValueError, match="q_e0"):
        eigen_axis_gains(np.array([0.0, 0.5, 0.0]), omega_n_rad_s=0.02, zeta=0.9, rate_max_rad_s=0.01, clamp_min=0)
    with pytest.raises(ValueError, match="omega_n_rad_s"):
        eigen_axis_gains(q0, omega_n_rad_s=0.0, zeta=0.9, rate_max_rad_s=0.01)


def test_clamped_gain_angle_is_that_of_the_normalised_quaternion():
    """Deorbit error [0, √½, 0, √½] (scalar-last): the clamp raises the vector to (0.1, √½, 0.1), and
    its logged eigen-angle is that of [q_ref, q_e4] normalised, 2 atan2(√0.52, √½) = 91.124° (Yoo et
    al. 2016 state about 1.15° over the true 90°), not 2 asin √0.52 = 92.292° of the un-normalised
    vector. The two analytic values differ by 1.17°; 1e-9 rad is rounding."""
    h = math.sqrt(0.5)
    g = eigen_axis_gains(np.array([0.0, h, 0.0]), omega_n_rad_s=0.02, zeta=0.9, rate_max_rad_s=0.3 * DEG)
    normalised = np.array([0.1, h, 0.1, h]) / math.sqrt(0.52 + 0.5)
    expected = 2.0 * math.acos(normalised[3])  # the angle of the normalised clamped quaternion
    assert expected == pytest.approx(2.0 * math.atan2(math.sqrt(0.52), h), abs=1e-12)
    assert g.theta_clamped_rad == pytest.approx(expected, abs=1e-9)
    assert math.degrees(g.theta_clamped_rad) == pytest.approx(91.124, abs=1e-3)
    assert math.degrees(g.theta_clamped_rad - g.theta_true_rad) == pytest.approx(1.124, abs=1e-3)
    assert math.degrees(g.theta_clamped_rad) < math.degrees(2 * math.asin(math.sqrt(0.52))) - 1.0
    # unclamped: both angles are the true one, 2 acos|q4|
    q = np.array([0.6460, 0.2876, -0.6460])
    g = eigen_axis_gains(q, omega_n_rad_s=0.02, zeta=0.9, rate_max_rad_s=0.3 * DEG)
    assert g.theta_clamped_rad == g.theta_true_rad
    assert g.theta_true_rad == pytest.approx(2 * math.acos(math.sqrt(1 - q @ q)), abs=1e-12)
    with pytest.raises(ValueError, match="q_e0: .*norm ≤ 1"):
        eigen_axis_gains(np.array([0.9, 0.9, 0.0]), omega_n_rad_s=0.02, zeta=0.9, rate_max_rad_s=0.01)


def test_pd_equals_eigen_axis_for_small_errors_and_opposes_the_error():
    q0 = np.array([0.6460, 0.2876, -0.6460])
    g = eigen_axis_gains(q0, omega_n_rad_s=0.02, zeta=0.9, rate_max_rad_s=0.3 * DEG)
    qe = np.array([1e-3, -2e-3, 5e-4])
    we = np.array([1e-5, 2e-5, -1e-5])
    u_ea = eigen_axis_torque(qe, we, np.zeros(3), J_DEP, g, gyro_comp="none")
    u_pd = pd_torque(qe, we, J_DEP, k=g.k, c=g.c)
    np.testing.assert_allclose(u_ea, u_pd, rtol=1e-12)
    # sign: a positive error about x with no rate gives a negative torque about x
    u = pd_torque(np.array([0.01, 0, 0]), np.zeros(3), J_DEP, k=g.k, c=g.c)
    assert u[0] < 0 and abs(u[1]) < 1e-18 and abs(u[2]) < 1e-18
    # small-angle closed loop q̈ = −(k/2) q − c q̇ is stable with the designed ω_n, ζ
    A = np.array([[0, 1], [-g.k / 2, -g.c]])
    ev = np.linalg.eigvals(A)
    assert np.all(ev.real < 0)
    assert abs(ev[0]) == pytest.approx(0.02, rel=1e-12)
    assert -ev[0].real / abs(ev[0]) == pytest.approx(0.9, rel=1e-12)


def _slew(law: str, q_e0: np.ndarray, t_end: float = 1500.0):
    """Rigid body (deployed J, no wheels, no disturbances), command fixed in inertial space,
    continuous control torque applied directly (unlimited actuator)."""
    g = eigen_axis_gains(q_e0[1:], omega_n_rad_s=0.02, zeta=0.9, rate_max_rad_s=0.3 * DEG)
    Jd = np.diag(J_DEP)

    def rhs(_t, y):
        q, w = y[:4] / np.linalg.norm(y[:4]), y[4:]
        pe = q if q[0] >= 0 else -q
        if law == "eigen_axis":
            u = eigen_axis_torque(pe[1:], w, w, J_DEP, g, gyro_comp="Iw")
        else:
            u = pd_torque(pe[1:], w, J_DEP, k=g.k, c=g.c)
        wdot = (u - np.cross(w, Jd * w)) / Jd
        return np.concatenate([0.5 * quat_mul(q, np.concatenate([[0.0], w])), wdot])

    t = np.arange(0.0, t_end, 1.0)
    sol = solve_ivp(rhs, (0, t_end), np.concatenate([q_e0, np.zeros(3)]), t_eval=t, rtol=1e-9, atol=1e-12)
    q = sol.y[:4].T
    return t, q, sol.y[4:].T, g


def test_eigen_axis_slew_respects_rate_limit_and_axis():
    """Stowed nadir-slew error: cruise rate within 2 % of θ̇_max, rotation axis within 1° of the
    initial eigen-axis while θ_e > 5°, error → 0."""
    q0 = np.array([0.2876, 0.6460, 0.2876, -0.6460])
    q0 /= np.linalg.norm(q0)
    t, q, w, g = _slew("eigen_axis", q0, t_end=1200.0)
    wn = np.linalg.norm(w, axis=1)
    assert wn.max() <= 1.02 * 0.3 * DEG
    theta = eigen_angle(q)
    saturated = np.all(np.abs(g.p_i * q[:, 1:]) >= 1.0, axis=1)  # every sat(P q_e) component at ±1
    cruise = saturated & (t > 5 / g.c)  # after the 5/c spin-up transient
    assert cruise.sum() > 200
    assert np.all(np.abs(wn[cruise] / (0.3 * DEG) - 1) < 0.02)
    e0 = q0[1:] / np.linalg.norm(q0[1:])
    moving = (theta > 5 * DEG) & (wn > 0.1 * 0.3 * DEG)
    dev = np.degrees(np.arccos(np.clip((-w[moving] / wn[moving, None]) @ e0, -1, 1)))
    assert dev.max() < 1.0
    assert math.degrees(theta[-1]) < 0.05


def test_pd_large_slew_exceeds_rate_limit():
    """S5 error (108°): the PD law (no saturation, unlimited actuator) turns more than twice as
    fast as θ̇_max — the point of the comparison; it still converges."""
    q0 = np.array([0.5878, 0.5457, 0.2429, -0.5457])
    q0 /= np.linalg.norm(q0)
    t, q, w, _ = _slew("pd", q0, t_end=1200.0)
    assert np.linalg.norm(w, axis=1).max() > 2 * 0.3 * DEG
    assert math.degrees(eigen_angle(q[-1])) < 0.5


# ------------------------------------------------------------------ B-dot (Eqs. 24–27)


def test_bdot_finite_difference_and_first_sample():
    b = BdotFiniteDifference(gain=5e4, sample_period_s=2.0)
    np.testing.assert_array_equal(b.update(np.array([1e-5, 0, 0])), 0.0)
    np.testing.assert_allclose(b.update(np.array([1.2e-5, 0, 0])), [-5e4 * 0.2e-5 / 2.0, 0, 0])
    with pytest.raises(ValueError, match="gain"):
        make_bdot("finite_difference", gain=0.0, sample_period_s=2.0)


def test_bdot_filtered_tracks_a_ramp():
    """Tustin filter of ω_c s/(s + ω_c) on a ramp B = a t converges to the slope a."""
    b = BdotFiltered(gain=1.0, sample_period_s=2.0, omega_c_rad_s=0.5)
    for k in range(60):
        b.update(np.array([3e-8 * 2.0 * k, 0, 0]))
    assert b.B_dot[0] == pytest.approx(3e-8, rel=1e-9)


@pytest.mark.parametrize("form", ["finite_difference", "filtered"])
def test_bdot_is_dissipative_in_a_fixed_field(form):
    """Rigid stowed body in a constant inertial field, B-dot sampled every 2 s with the 0.2 s
    blanking, per-axis saturation: the rotational energy never increases from one cycle to the
    next (tolerance 1e-12 relative for the integration) and falls overall (by > 5 % in 300 s)."""
    J = np.array([0.0506, 0.0506, 0.010])
    B_in = np.array([2e-5, -1e-5, 3e-5])
    law = make_bdot(form, gain=3e4, sample_period_s=2.0)
    q = np.array([1.0, 0, 0, 0])
    w = np.array([6.0, -7.0, 3.0]) * DEG
    energies = []
    for _ in range(150):
        R = matrix_from_quat(q)
        Bb = R.T @ B_in
        m = np.clip(law.update(Bb), -0.2, 0.2) * np.array([1, 1, 0.5])

        def rhs(_t, y, m=m):
            qq, ww = y[:4] / np.linalg.norm(y[:4]), y[4:]
            T = np.cross(m, matrix_from_quat(qq).T @ B_in)
            return np.concatenate([0.5 * quat_mul(qq, np.concatenate([[0.0], ww])), (T - np.cross(ww, J * ww)) / J])

        energies.append(0.5 * float(w @ (J * w)))
        y = solve_ivp(rhs, (0, 1.8), np.concatenate([q, w]), rtol=1e-10, atol=1e-14).y[:, -1]
        q, w = y[:4] / np.linalg.norm(y[:4]), y[4:]
        # coils off for the last 0.2 s: torque-free
        y = solve_ivp(
            lambda _t, y: np.concatenate(
                [0.5 * quat_mul(y[:4], np.concatenate([[0.0], y[4:]])), -np.cross(y[4:], J * y[4:]) / J]
            ),
            (0, 0.2),
            np.concatenate([q, w]),
            rtol=1e-11,
            atol=1e-14,
        ).y[:, -1]
        q, w = y[:4] / np.linalg.norm(y[:4]), y[4:]
    e = np.array(energies)
    assert np.all(np.diff(e) <= 1e-12 * e[0])
    assert e[-1] < 0.95 * e[0]


def test_bdot_continuous_torque_dissipates():
    """ω·T ≤ 0 for T = (−K Ḃ) × B with Ḃ = −ω × B (fixed inertial field)."""
    for _ in range(100):
        w, B = RNG.normal(size=3), RNG.normal(size=3)
        T = np.cross(-5e4 * (-np.cross(w, B)), B)
        assert w @ T <= 1e-12


# ------------------------------------------------------------------ unloading (Eq. 39)


def test_unloading_torque_is_minus_k_dh_perp():
    for _ in range(20):
        dh, B = RNG.normal(size=3) * 1e-3, RNG.normal(size=3) * 3e-5
        m = unloading_dipole(dh, B, k_rw=0.005)
        Bh = B / np.linalg.norm(B)
        np.testing.assert_allclose(np.cross(m, B), -0.005 * (dh - (dh @ Bh) * Bh), rtol=1e-10, atol=1e-20)


def test_unloading_activation_per_axis_with_hysteresis():
    rpm = 2 * math.pi / 60
    u = UnloadingLogic(on_rpm=3000.0)
    np.testing.assert_array_equal(u.update(np.array([3100, -2900, -3500]) * rpm), [True, False, True])
    uh = UnloadingLogic(on_rpm=3000.0, off_rpm=2000.0)
    np.testing.assert_array_equal(uh.update(np.array([3100, 100, 0]) * rpm), [True, False, False])
    np.testing.assert_array_equal(uh.update(np.array([2500, 2500, 0]) * rpm), [True, False, False])
    np.testing.assert_array_equal(uh.update(np.array([1900, 2500, 0]) * rpm), [False, False, False])
    with pytest.raises(ValueError, match="off_rpm"):
        UnloadingLogic(on_rpm=3000.0, off_rpm=4000.0)


# ------------------------------------------------------------------ modes


def test_mode_manager_chain():
    p = ModeLogicParams(enabled=True, dwell_s=60.0, deorbit_at_s=1000.0)
    mm = ModeManager(p, initial=Mode.NADIR)
    assert mm.update(0.0, 2.0 * DEG) == (Mode.DETUMBLE, True)
    assert mm.update(10.0, 0.2 * DEG) == (Mode.DETUMBLE, False)
    assert mm.update(50.0, 0.4 * DEG)[0] == Mode.DETUMBLE  # dwell restarts
    assert mm.update(60.0, 0.2 * DEG)[0] == Mode.DETUMBLE
    assert mm.update(119.0, 0.2 * DEG)[0] == Mode.DETUMBLE
    assert mm.update(120.0, 0.2 * DEG) == (Mode.NADIR, True)
    assert mm.update(999.0, 0.5 * DEG) == (Mode.NADIR, False)
    assert mm.update(1000.0, 0.5 * DEG) == (Mode.DEORBIT, True)
    assert mm.update(1001.0, 1.5 * DEG) == (Mode.DETUMBLE, True)
    off = ModeManager(ModeLogicParams(enabled=False), initial=Mode.NADIR)
    assert off.update(0.0, 5.0 * DEG) == (Mode.NADIR, False)
