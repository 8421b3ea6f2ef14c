"""The magnetic pendulum with compiled loads: a rigid body carrying a body-fixed dipole m in a uniform
field B (torque (R m) × B), the plugin ``magsail.dipole_in_field`` (magsail_mj/compiled/dipole_in_field.c)
evaluated by MuJoCo at every RK4 stage. Its torque equals the Python test load's; the attitude
converges at fourth order against an independent SciPy integration; a planar swing has the
elliptic-integral period; the energy ½ωᵀJω − (R m)·B is conserved."""

from __future__ import annotations

from types import SimpleNamespace

import mujoco
import numpy as np
import pytest

from magsail_mj.compiled.dipole import add_dipole_in_field, dipole_state, potential_energy_J
from magsail_mj.concepts.current_loops.rigid_reference import pendulum_period, rigid_dipole_attitude
from tests.test_load_timing import DIPOLE_BODY_A_M2, FIELD_WORLD_T, INERTIA_KG_M2, DipoleInField

NAME = "magsail_dipole_bus"
Q0 = np.array([np.cos(0.6), np.sin(0.6) / np.sqrt(2), np.sin(0.6) / np.sqrt(2), 0.0])  # tests/test_load_timing.py
W0_BODY = np.array([0.3, -0.2, 0.5])


def _model(dt: float, *, joint: str = "free", field_world_T=FIELD_WORLD_T) -> mujoco.MjModel:
    """The bare body of tests/test_load_timing.py (principal inertia 1, 1.5, 2 kg m²) on a free
    joint or a hinge about x, with the dipole plugin; RK4 at ``dt``."""
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, 0]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    spec.option.timestep = dt
    body = spec.worldbody.add_body(name="bus", mass=1.0, inertia=list(INERTIA_KG_M2))
    if joint == "free":
        body.add_freejoint()
    else:
        body.add_joint(type=mujoco.mjtJoint.mjJNT_HINGE, axis=[1, 0, 0])
    add_dipole_in_field(spec, body="bus", dipole_body_Am2=DIPOLE_BODY_A_M2, field_world_T=field_world_T)
    return spec.compile()


def _start(model: mujoco.MjModel) -> mujoco.MjData:
    data = mujoco.MjData(model)
    data.qpos[3:7], data.qvel[3:6] = Q0, W0_BODY
    return data


def _matrix(q: np.ndarray) -> np.ndarray:
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, q / np.linalg.norm(q))
    return R.reshape(3, 3)


def _angle(Ra: np.ndarray, Rb: np.ndarray) -> float:
    """Rotation angle [rad] of Raᵀ Rb."""
    D = Ra.T @ Rb
    s = 0.5 * np.linalg.norm([D[2, 1] - D[1, 2], D[0, 2] - D[2, 0], D[1, 0] - D[0, 1]])
    return float(np.arctan2(s, 0.5 * (np.trace(D) - 1)))


def test_plugin_torque_equals_the_python_load():
    """At 100 random attitudes and rates the plugin's generalized force equals that of the Python
    test load's world torque mapped as MuJoCo maps xfrc_applied (mj_applyFT), and with 100 random
    dipoles and fields written into the plugin state it equals m × Rᵀ B (body axes), both to
    2e-15 of |m||B| (measured 5.8e-16; R from xmat in C against R from xquat in NumPy: a few
    rounding units of a 3×3 product and a cross product, whose size is |m||B| however small the
    torque is where m lies near B)."""
    model = _model(0.05)
    data = _start(model)
    dipole, field = dipole_state(model, data, name=NAME)
    rng = np.random.default_rng(3)
    worst = 0.0
    for k in range(200):
        q = rng.normal(size=4)
        data.qpos[3:7], data.qvel[3:6] = q / np.linalg.norm(q), rng.uniform(-1, 1, 3)
        if k >= 100:
            dipole[:], field[:] = rng.normal(size=3), rng.normal(size=3) * 1e-5
        mujoco.mj_forward(model, data)
        if k < 100:
            xfrc = np.zeros((model.nbody, 6))
            DipoleInField().add(SimpleNamespace(xquat=data.xquat), xfrc)
            want = np.zeros(model.nv)
            mujoco.mj_applyFT(model, data, xfrc[1, :3], xfrc[1, 3:], data.xipos[1], 1, want)
        else:
            R = _matrix(data.qpos[3:7])
            want = np.concatenate([np.zeros(3), np.cross(dipole, R.T @ field)])
        scale = float(np.linalg.norm(dipole) * np.linalg.norm(field))
        worst = max(worst, float(np.abs(data.qfrc_passive - want).max()) / scale)
    assert worst < 2e-15, worst


def _final_attitude(dt: float, duration_s: float = 6.0) -> np.ndarray:
    model = _model(dt)
    data = _start(model)
    mujoco.mj_step(model, data, int(round(duration_s / dt)))
    return _matrix(data.qpos[3:7])


def _reference(rtol: float) -> np.ndarray:
    R, _ = rigid_dipole_attitude(
        np.array([0.0, 6.0]),
        inertia=np.diag(INERTIA_KG_M2),
        dipole_body=DIPOLE_BODY_A_M2,
        field_world=FIELD_WORLD_T,
        R0=_matrix(Q0),
        omega0_body=W0_BODY,
        rtol=rtol,
        atol=rtol * 1e-2,
    )
    return R[-1]


def test_stage_loads_converge_at_fourth_order():
    """The tumbling pendulum of tests/test_load_timing.py (6 s, about one swing), attitude error at
    δt = 0.05, 0.025, 0.0125 s against SciPy's DOP853 at rtol 1e-13: halving δt divides the error
    by 16 (observed orders within 0.25 of 4; measured 4.00 and 4.00, errors 1.0e-7, 6.5e-9,
    4.1e-10 rad, where the Python path's held loads give 2.7e-2 rad at start and 1.4e-4 rad at the
    midpoint at δt = 0.05 s). The reference's own error is negligible: it moves by less than 1e-3 of
    the smallest error when its tolerance is tightened tenfold (measured 1.4e-13 rad), and RK4 at
    δt/64 lands 2e-14 rad from it."""
    reference = _reference(1e-13)
    errors = [_angle(_final_attitude(dt), reference) for dt in (0.05, 0.025, 0.0125)]
    assert _angle(_reference(1e-12), reference) < 1e-3 * errors[-1], errors
    orders = [np.log2(errors[0] / errors[1]), np.log2(errors[1] / errors[2])]
    assert all(abs(o - 4.0) < 0.25 for o in orders), (errors, orders)


def _downward_zero_crossings_s(theta: np.ndarray, rate: np.ndarray, dt: float) -> list[float]:
    """Times [s] where θ passes from > 0 to ≤ 0, from the cubic Hermite interpolant of θ and θ̇ over
    the step (interpolation error O(δt⁴), as RK4's)."""
    out = []
    for k in np.flatnonzero((theta[:-1] > 0) & (theta[1:] <= 0)):
        p0, p1, m0, m1 = theta[k], theta[k + 1], rate[k] * dt, rate[k + 1] * dt
        cubic = [2 * p0 + m0 - 2 * p1 + m1, -3 * p0 - 2 * m0 + 3 * p1 - m1, m0, p0]
        roots = [r.real for r in np.roots(cubic) if abs(r.imag) < 1e-9 and -1e-9 <= r.real <= 1 + 1e-9]
        out.append((k + roots[0]) * dt)
    return out


def test_swing_period_is_the_elliptic_integral():
    """On a hinge about the body's x axis (J = 1 kg m², m = 1 A m² along body z, B = 1 T along world
    z), released at rest at θ₀ = 2.5 rad: the time between successive downward passes through
    θ = 0 at δt = 0.05 s equals 4 K(sin²(θ₀/2)) √(J/(mB)) = 10.32 s to 1e-7 (measured 4.1e-9; RK4's
    and the interpolation's error scale as δt⁴, 4.9e-10 at δt = 0.02 s). The hinge maps the torque
    as MuJoCo maps xfrc_applied, so the plugin is not tied to a free joint."""
    theta0, dt = 2.5, 0.05
    model = _model(dt, joint="hinge", field_world_T=[0.0, 0.0, 1.0])
    data = mujoco.MjData(model)
    data.qpos[0] = theta0
    period = pendulum_period(inertia_axis=1.0, dipole=1.0, field=1.0, theta0_rad=theta0)
    n = int(2.2 * period / dt)
    theta, rate = np.empty(n + 1), np.empty(n + 1)
    for k in range(n + 1):
        theta[k], rate[k] = data.qpos[0], data.qvel[0]
        mujoco.mj_step(model, data)
    crossings = _downward_zero_crossings_s(theta, rate, dt)
    assert len(crossings) == 2, crossings
    assert abs((crossings[1] - crossings[0]) / period - 1) < 1e-7, (crossings, period)


def test_energy_is_conserved_over_a_hundred_swings():
    """The tumbling pendulum for 600 s (about 100 swings of the ≈ 1 rad/s natural rate) at the coarse
    δt = 0.05 s, sampled every 100 steps: E = ½ωᵀJω − (R m)·B [J] stays within 1e-5 J of its start
    (mB = 1 J; measured 7.2e-7 J, and 2.3e-5 J at δt = 0.1 s). The Python path's loads held over
    the step drift by 7.6 J (start) and 2.7e-3 J (midpoint) in the same run
    (scripts/pendulum_load_timing.py)."""
    model = _model(0.05)
    data = _start(model)
    inertia = np.asarray(INERTIA_KG_M2)

    def energy_J() -> float:
        mujoco.mj_kinematics(model, data)
        return 0.5 * float(np.sum(inertia * data.qvel[3:6] ** 2)) + potential_energy_J(model, data, name=NAME)

    e0 = energy_J()
    drift = []
    for _ in range(120):
        mujoco.mj_step(model, data, 100)
        drift.append(energy_J() - e0)
    assert np.abs(drift).max() < 1e-5, (e0, np.abs(drift).max())


def test_a_missing_body_or_a_bad_vector_is_refused_by_name():
    spec = mujoco.MjSpec()
    spec.worldbody.add_body(name="bus", mass=1.0, inertia=[1, 1, 1])
    with pytest.raises(ValueError, match="body: no body 'rotor'"):
        add_dipole_in_field(spec, body="rotor", dipole_body_Am2=[0, 0, 1], field_world_T=[1, 0, 0])
    with pytest.raises(ValueError, match="field_world_T: must be three finite numbers"):
        add_dipole_in_field(spec, body="bus", dipole_body_Am2=[0, 0, 1], field_world_T=[1, 0])
