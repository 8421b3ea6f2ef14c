"""CNUSAIL-1 MuJoCo model: mass properties, MJCF round trip, and the bus + wheel dynamics against
an independent SciPy integration of Euler's equation (Yoo et al. 2016, Eqs. 1 and 10, corrected)."""

from __future__ import annotations

import magsail_mj  # noqa: F401  (before mujoco: GL backend choice)
import mujoco
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from magsail_mj.quaternion import quat_mul
from magsail_mj.concepts.cnusail.mjcf import CubesatModelParams, build_cubesat_spec, cubesat_indices

TABLE2 = {"stowed": (0.0506, 0.0506, 0.010), "deployed": (0.3104, 0.3121, 0.5757)}


def _model(configuration="deployed", **kw) -> mujoco.MjModel:
    p = CubesatModelParams(configuration=configuration, inertia_kgm2=TABLE2[configuration], **kw)
    return build_cubesat_spec(p).compile()


@pytest.mark.parametrize("configuration", ["stowed", "deployed"])
def test_composite_inertia_equals_table2(configuration):
    """Locked-wheel inertia of the bus subtree (mass matrix rotational block) = Table 2 to 1e-12."""
    m = _model(configuration)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    idx = cubesat_indices(m)
    np.testing.assert_allclose(M[3:6, 3:6], np.diag(TABLE2[configuration]), atol=1e-12)
    assert m.body_subtreemass[idx.bus] == pytest.approx(4.0, abs=1e-12)
    # the hub carries Table 2 minus J_s + 2 J_t = 9e-6 kg m² on every axis
    np.testing.assert_allclose(m.body_inertia[idx.bus], np.array(TABLE2[configuration]) - 9e-6, atol=1e-15)


@pytest.mark.parametrize("configuration", ["stowed", "deployed"])
def test_mjcf_round_trip_keeps_masses(configuration):
    spec = build_cubesat_spec(CubesatModelParams(configuration=configuration, inertia_kgm2=TABLE2[configuration]))
    a = spec.compile()
    b = mujoco.MjModel.from_xml_string(spec.to_xml())
    np.testing.assert_array_equal(a.body_mass, b.body_mass)
    np.testing.assert_allclose(a.body_inertia, b.body_inertia, rtol=0, atol=1e-15)
    assert (a.nq, a.nv, a.nu) == (b.nq, b.nv, b.nu)


def test_rejects_inertia_below_rotors():
    with pytest.raises(ValueError, match="inertia_kgm2"):
        CubesatModelParams(inertia_kgm2=(5e-6, 0.3, 0.3))


# ------------------------------------------------------------------ dynamics vs SciPy

J = np.array(TABLE2["deployed"])
JS = 4.5e-6
KB = 1e-8


def _reference_rhs(torque):
    """Bus + wheels (Yoo et al. 2016, Eq. 1 with the wheel reaction −ḣ_w on the bus, Eq. 10 with the rotor
    spin acceleration): H = J ω + J_s ω_M (body), J ω̇ + J_s ω̇_M = −ω × H,
    J_s(ω̇ + ω̇_M)_j = T_j − K_B ω_M,j, q̇ = ½ q ⊗ (0, ω)."""

    def rhs(_t, y):
        q, w, wM = y[:4], y[4:7], y[7:10]
        H = J * w + JS * wM
        net = torque - KB * wM  # rotor net torque about its axis
        # (J − J_s) ω̇ = −ω × H − net
        wdot = (-np.cross(w, H) - net) / (J - JS)
        wMdot = net / JS - wdot
        qdot = 0.5 * quat_mul(q, np.concatenate([[0.0], w]))
        return np.concatenate([qdot, wdot, wMdot])

    return rhs


def _angmom_world(m, d) -> np.ndarray:
    mujoco.mj_forward(m, d)
    mujoco.mj_subtreeVel(m, d)
    return d.subtree_angmom[cubesat_indices(m).bus].copy()


def test_angular_momentum_conserved_and_bus_matches_scipy():
    """Random wheel torques (zero-order hold, 10 s), no external torque, 1000 s, RK4 at 0.1 s:

    * total angular momentum (bus + rotors, ECI, MuJoCo's ``subtree_angmom``) conserved to
      1e-12 N m s (measured 9e-15 on |H| = 3.4e-3 N m s);
    * bus attitude, rate and wheel speeds equal the SciPy DOP853 integration (rtol 1e-12) of the
      hand-written Euler equation with wheel momentum to 1e-9 rad, 1e-12 rad/s and 1e-9 rad/s while
      the wheels spin up to ~110 rad/s (measured 1e-11 rad, 2e-14 rad/s, 2e-12 rad/s: RK4's O(h⁴)
      truncation at 0.1 s on rates of 0.01 rad/s, plus rounding).
    """
    m = _model("deployed", markers=False, wheel_damping_Nms=KB)
    d = mujoco.MjData(m)
    idx = cubesat_indices(m)
    rng = np.random.default_rng(7)
    q0 = rng.normal(size=4)
    q0 /= np.linalg.norm(q0)
    w0 = rng.normal(scale=0.01, size=3)
    d.qpos[idx.q_quat] = q0
    d.qvel[idx.v_ang] = w0
    H0 = _angmom_world(m, d)
    assert np.linalg.norm(H0) > 1e-3
    torques = rng.uniform(-2e-5, 2e-5, size=(100, 3))
    n_sub = int(round(10.0 / m.opt.timestep))
    y = np.concatenate([q0, w0, np.zeros(3)])
    drift = 0.0
    for k in range(100):
        d.ctrl[idx.wheel_act] = torques[k]
        for _ in range(n_sub):
            mujoco.mj_step(m, d)
        sol = solve_ivp(_reference_rhs(torques[k]), (0.0, 10.0), y, method="DOP853", rtol=1e-12, atol=1e-14)
        y = sol.y[:, -1]
        y[:4] /= np.linalg.norm(y[:4])
        drift = max(drift, float(np.linalg.norm(_angmom_world(m, d) - H0)))
    assert drift < 1e-12
    q_mj = d.qpos[idx.q_quat] / np.linalg.norm(d.qpos[idx.q_quat])
    dq = quat_mul(np.array([y[0], -y[1], -y[2], -y[3]]), q_mj)
    angle = 2 * np.arctan2(np.linalg.norm(dq[1:]), abs(dq[0]))
    assert angle < 1e-9
    np.testing.assert_allclose(d.qvel[idx.v_ang], y[4:7], rtol=0, atol=1e-12)
    np.testing.assert_allclose(d.qvel[idx.wheel_qvel], y[7:10], rtol=0, atol=1e-9)
    assert np.max(np.abs(y[7:10])) > 10.0  # the wheels did spin up


def test_markers_do_not_touch_the_bus():
    """The display marker bodies (ball joints at the origin) leave the bus motion unchanged."""
    out = []
    for markers in (False, True):
        m = _model("deployed", markers=markers)
        d = mujoco.MjData(m)
        idx = cubesat_indices(m)
        d.qvel[idx.v_ang] = [0.01, -0.02, 0.03]
        d.ctrl[idx.wheel_act] = [1e-4, -1e-4, 5e-5]
        for _ in range(500):
            mujoco.mj_step(m, d)
        out.append(np.concatenate([d.qpos[idx.q_quat], d.qvel[idx.v_ang], d.qvel[idx.wheel_qvel]]))
    np.testing.assert_allclose(out[0], out[1], rtol=0, atol=1e-13)
