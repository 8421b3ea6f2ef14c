"""Typed commands and body-torque actuators: one quaternion PD law on the truss, the cubesat and the reflector.

The same :class:`QuaternionPD` type (it sees only the StepState, through an attitude sensor) runs
on a shipped config of each spacecraft with that spacecraft's body-torque actuator, attached with
:func:`magsail_mj.commands.attach`; the recorded requested and delivered torques are checked against
what each actuator can do: the truss delivers the request (force pairs, within the lattice's
deformation), the cubesat the request clipped to the wheels' ±τ_max, the reflector only the part
⊥ B (``m × B``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import magsail_mj
from magsail_mj.commands import (
    BodyTorque,
    JointTargets,
    LoopCurrents,
    MagneticDipole,
    RodPolarities,
    WheelTorques,
    WheelVoltages,
    attach,
)
from magsail_mj.control.quaternion_feedback import QuaternionPD
from magsail_mj.loads.body_torque_actuators import (
    CoilBodyTorqueActuator,
    LatticeAttitude,
    StrutBodyTorqueActuator,
    WheelBodyTorqueActuator,
    attitude_sensor,
    body_torque_actuator,
    coil_torque,
)
from magsail_mj.loads.actuators_cubesat import MagnetorquerLoad, WheelDriver
from magsail_mj.loads.base import StepState
from magsail_mj.loads.magnetorquer_rods import MagnetorquerRodLoad
from magsail_mj.quaternion import quat_mul, quat_to_matrix

TRUSS = (
    "magsail_mj/concepts/truss_magnetorquer/configs/slew_i.toml",
    ["lattice.units=3", "sim.duration_s=30", "sim.record_every=1", "initial.q0_wxyz=[0.5, 0.5, 0.5, 0.5]"],
)
CUBESAT = ("magsail_mj/concepts/cnusail/configs/nadir_post.toml", ["sim.duration_s=30", "sim.record_every=1"])
REFLECTOR = ("magsail_mj/concepts/reflector/configs/tracking_10g.toml", ["sim.duration_s=150", "sim.record_every=1"])


def _start_state(sim, ctrl: object, *, env: object = None) -> StepState:
    """The step state of ``sim``'s kinematics at t = 0 (``sim.kin`` updated) with command ``ctrl``."""
    return StepState(
        t=0.0, pos=sim.kin.pos, vel=sim.kin.vel, xquat=sim.kin.xquat, omega=sim.kin.omega, env=env, ctrl=ctrl
    )


def _rot_x(deg: float) -> np.ndarray:
    h = math.radians(deg) / 2
    return np.array([math.cos(h), math.sin(h), 0.0, 0.0])


def _run(config, *, pd_for) -> tuple[object, QuaternionPD, object, dict[str, np.ndarray]]:
    """Load ``config``, attach ``pd_for(sim)`` with the spacecraft's body-torque actuator, run it."""
    sim = magsail_mj.load(*config)
    pd = pd_for(sim)
    act = body_torque_actuator(sim)
    run = attach(sim, pd, act)
    result = run.run()
    assert result.status == "completed", result.message
    return run, pd, act, result.records


def _truss_pd(sim) -> QuaternionPD:
    c = sim.cfg.control
    return QuaternionPD(
        sensor=attitude_sensor(sim),
        q_ref_wxyz=sim.cfg.maneuver.q_ref_wxyz,
        Pq_Nm=c.Pq_Nm,
        Pw_Nms=c.Pw_Nms,
        period_s=0.2,
    )


def _cubesat_pd(omega_n: float):
    def make(sim) -> QuaternionPD:
        return QuaternionPD.from_bandwidth(
            sensor=attitude_sensor(sim),
            q_ref_wxyz=(1.0, 0.0, 0.0, 0.0),
            inertia_kgm2=np.diag(sim.scenario.inertia),
            omega_n_rad_s=omega_n,
            zeta=0.7,
            period_s=1.0,
        )

    return make


def _reflector_pd(sim) -> QuaternionPD:
    q0 = sim.scenario.initial_state()[0]
    return QuaternionPD.from_bandwidth(
        sensor=attitude_sensor(sim),
        q_ref_wxyz=quat_mul(q0, _rot_x(30.0)),
        inertia_kgm2=sim.scenario.inertia,
        omega_n_rad_s=1e-3,
        zeta=0.7,
        period_s=0.5,
    )


@pytest.fixture(scope="module")
def truss_run():
    return _run(TRUSS, pd_for=_truss_pd)


@pytest.fixture(scope="module")
def cubesat_run():
    return _run(CUBESAT, pd_for=_cubesat_pd(0.03))


@pytest.fixture(scope="module")
def reflector_run():
    return _run(REFLECTOR, pd_for=_reflector_pd)


def test_one_law_type_three_spacecraft(truss_run, cubesat_run, reflector_run):
    """The same controller type, three actuators, requested and delivered torque recorded as series."""
    kinds = set()
    for run, pd, act, rec in (truss_run, cubesat_run, reflector_run):
        assert type(run.controller) is QuaternionPD and run.controller is pd
        assert act in run.loads
        kinds.add(type(act))
        n = len(rec["t"])
        assert n == run.n_steps + 1
        for key in ("torque_request_body_Nm", "torque_delivered_body_Nm", "qpos"):
            assert rec[key].shape[0] == n
        assert np.all(rec["torque_request_body_Nm"][0] == 0)  # record 0: before any step
        assert np.all(np.linalg.norm(rec["torque_request_body_Nm"][1:], axis=1) > 0)
    assert kinds == {StrutBodyTorqueActuator, WheelBodyTorqueActuator, CoilBodyTorqueActuator}


def test_truss_delivers_the_request_through_force_pairs(truss_run):
    """Force pairs: delivered = request within 1 % (the lattice deforms; exact when undeformed)."""
    run, _, act, rec = truss_run
    req, dl = rec["torque_request_body_Nm"][1:], rec["torque_delivered_body_Nm"][1:]
    err = np.linalg.norm(dl - req, axis=1) / np.linalg.norm(req, axis=1)
    assert err.max() < 1e-2
    assert err[0] < 1e-9  # first step: undeformed lattice, exact
    # the original actuator (rods) is gone, the tidal gravity stays
    assert [type(x).__name__ for x in run.loads] == ["TidalGravityLoad", "StrutBodyTorqueActuator"]


def test_truss_pair_forces_have_no_net_force():
    """The delivered couple comes with zero net force on the lattice."""
    sim = magsail_mj.load(TRUSS[0], ["lattice.units=3", "sim.duration_s=1"])
    act = body_torque_actuator(sim)
    sim.kin.update(sim.data)
    kin_pos = sim.kin.pos.copy()
    state = StepState(
        t=0.0,
        pos=kin_pos,
        vel=np.zeros_like(kin_pos),
        xquat=sim.kin.xquat,
        omega=sim.kin.omega,
        ctrl=BodyTorque(torque_body_Nm=[0.3, -0.2, 0.1]),
    )
    xfrc = np.zeros((sim.model.nbody, 6))
    act.add(state, xfrc)
    assert np.abs(xfrc[:, :3].sum(axis=0)).max() < 1e-12
    np.testing.assert_allclose(act.delivered_body_Nm, [0.3, -0.2, 0.1], rtol=0, atol=1e-12)


def _wheel_oracle(u: np.ndarray, w: np.ndarray, p) -> tuple[np.ndarray, np.ndarray]:
    """Yoo et al. 2016, Eqs. 8–11, in closed form: T_M = clip(K_B ω − u, ±τ_max), or K_B ω at Ω_max when it would spin
    the wheel faster; returns (delivered −(T_M − K_B ω), speed-limited mask)."""
    KB = p.K_B_Nms
    T_M = np.clip(KB * w - u, -p.torque_max_Nm, p.torque_max_Nm)
    at_limit = (np.abs(w) >= p.speed_max_rad_s) & ((T_M - KB * w) * w > 0)
    T_M = np.where(at_limit, KB * w, T_M)
    return -(T_M - KB * w), at_limit


def test_cubesat_wheels_deliver_the_request_within_their_limits(cubesat_run):
    """Wheels: delivered = −(T_M − K_B ω_M) with T_M = clip(K_B ω_M − u, ±τ_max), and no torque that
    would spin a wheel at Ω_max faster; the run meets all three regimes."""
    run, _, act, rec = cubesat_run
    p = act.driver.p
    tau, KB = p.torque_max_Nm, p.K_B_Nms
    req, dl = rec["torque_request_body_Nm"][1:], rec["torque_delivered_body_Nm"][1:]
    w = rec["qvel"][:-1][:, act.wheel_qvel]  # rotor speeds at the start of each applied step
    expected, at_limit = _wheel_oracle(req, w, p)
    np.testing.assert_allclose(dl, expected, rtol=0, atol=1e-9 * tau)
    linear = ~at_limit & (np.abs(req - KB * w) < tau)
    np.testing.assert_allclose(dl[linear], req[linear], rtol=1e-9, atol=1e-9 * tau)  # delivered = request
    assert linear.any() and at_limit.any() and (~at_limit & ~linear).any()
    # MuJoCo applied the motor torques the actuator wrote
    np.testing.assert_array_equal(run.data.actuator_force[act.wheel_act], act.wheel_torque_Nm)
    np.testing.assert_allclose(rec["wheel_torque_Nm"][-1], act.wheel_torque_Nm)


def test_cubesat_unsaturated_request_delivered_exactly():
    run, _, act, rec = _run(CUBESAT, pd_for=_cubesat_pd(0.01))
    req, dl = rec["torque_request_body_Nm"][1:], rec["torque_delivered_body_Nm"][1:]
    assert np.abs(req).max() < act.driver.p.torque_max_Nm
    np.testing.assert_allclose(dl, req, rtol=1e-9, atol=1e-15)


def test_reflector_coils_deliver_only_the_part_normal_to_B(reflector_run):
    """Coils: delivered ⊥ B, = (1 − b̂b̂ᵀ) request (unsaturated here), = m × B; the part along B is lost."""
    _, _, act, rec = reflector_run
    req, dl = rec["torque_request_body_Nm"][1:], rec["torque_delivered_body_Nm"][1:]
    B, m = rec["B_body_T"][1:], rec["dipole_body_Am2"][1:]
    b = B / np.linalg.norm(B, axis=1)[:, None]
    assert not rec["saturated"][1:].any()
    along = np.einsum("ij,ij->i", dl, b)
    assert np.abs(along).max() <= 1e-12 * np.abs(dl).max()
    perp = req - np.einsum("ij,ij->i", req, b)[:, None] * b
    np.testing.assert_allclose(dl, perp, rtol=0, atol=1e-12 * np.abs(req).max())
    np.testing.assert_allclose(dl, np.cross(m, B), rtol=0, atol=1e-12 * np.abs(req).max())
    # the request has a real component along B, which the reflector cannot deliver
    lost = np.abs(np.einsum("ij,ij->i", req, b)) / np.linalg.norm(req, axis=1)
    assert lost.max() > 0.1


def test_reflector_saturates_at_the_coil_cap():
    """With large gains the delivered torque is the ⊥-projection scaled to the cap (``norm``)."""

    def strong(sim):
        return QuaternionPD.from_bandwidth(
            sensor=attitude_sensor(sim),
            q_ref_wxyz=(1.0, 0.0, 0.0, 0.0),
            inertia_kgm2=sim.scenario.inertia,
            omega_n_rad_s=0.05,
            zeta=0.7,
            period_s=0.5,
        )

    _, _, act, rec = _run((REFLECTOR[0], ["sim.duration_s=10", "sim.record_every=1"]), pd_for=strong)
    cap = act.limits["cap_Nm"]
    dl, req, B = (rec[k][1:] for k in ("torque_delivered_body_Nm", "torque_request_body_Nm", "B_body_T"))
    b = B / np.linalg.norm(B, axis=1)[:, None]
    perp = req - np.einsum("ij,ij->i", req, b)[:, None] * b
    assert rec["saturated"][1:].all()
    np.testing.assert_allclose(np.linalg.norm(dl, axis=1), cap, rtol=1e-12)
    np.testing.assert_allclose(dl, perp * (cap / np.linalg.norm(perp, axis=1))[:, None], rtol=1e-12, atol=0)


def test_reflector_detumble_config_uses_per_path_limits():
    """A B-dot config's box saturation becomes the per-path dipole clip."""
    sim = magsail_mj.load("magsail_mj/concepts/reflector/configs/detumble.toml", ["sim.duration_s=1"])
    act = body_torque_actuator(sim)
    assert act.limits["saturation"] == "per_path"
    np.testing.assert_array_equal(act.limits["m_max_Am2"], sim.scenario.cap.m_max_Am2)


def test_attached_simulation_state_round_trip(cubesat_run):
    """get_state/set_state of an attached simulation: the steps after a restore repeat exactly."""
    sim = magsail_mj.load(TRUSS[0], ["lattice.units=3", "sim.duration_s=6", "sim.record_every=5"])
    run = attach(sim, _truss_pd(sim), body_torque_actuator(sim))
    run.step(20)
    state = run.get_state()
    run.step(20)
    first = run.records()
    run.set_state(state)
    run.step(20)
    second = run.records()
    for key in first:
        np.testing.assert_array_equal(first[key], second[key])


def test_attach_leaves_the_original_and_marks_identity():
    sim = magsail_mj.load(*CUBESAT)
    loads, probes, controller = list(sim.loads), dict(sim.probes), sim.controller
    run = attach(sim, _cubesat_pd(0.01)(sim), body_torque_actuator(sim))
    assert list(sim.loads) == loads and sim.probes == probes and sim.controller is controller
    assert run.data is not sim.data and run.model is sim.model
    assert run.identity["numbers_hash"] != sim.identity["numbers_hash"]
    assert run.identity["numbers_hash"].startswith(str(sim.identity["numbers_hash"]))
    assert run.cfg is sim.cfg and run.scenario is sim.scenario


# ----------------------------------------------------------------------------- invariants

_component = st.floats(-1.0, 1.0, allow_nan=False).map(lambda x: round(x, 12))  # no 1e-300 underflow traps
_vec = st.tuples(_component, _component, _component).map(np.array)
_LIMITS = dict(cap_Nm=1.0, B_ref_T=30e-6, m_max_Am2=np.array([4e4, 3e4, 2e4]))


@settings(max_examples=300, deadline=None)
@given(
    T=_vec,
    B=_vec,
    scale_T=st.floats(1e-6, 10.0),
    scale_B=st.floats(1e-6, 1e-4),
    mode=st.sampled_from(["norm", "field_scaled", "per_path"]),
)
def test_coil_torque_is_never_along_B_and_is_the_projection_when_unsaturated(T, B, scale_T, scale_B, mode):
    T, B = T * scale_T, B * scale_B
    B2 = float(B @ B)
    if B2 < 1e-20 * scale_B**2:
        return
    m, delivered, saturated = coil_torque(T, B, saturation=mode, **_LIMITS)
    b = B / math.sqrt(B2)
    scale = max(float(np.linalg.norm(T)), 1e-300)
    assert abs(float(delivered @ b)) <= 1e-12 * scale  # no component along B, ever
    np.testing.assert_allclose(delivered, np.cross(m, B), rtol=0, atol=1e-12 * scale)
    perp = T - b * float(b @ T)
    if not saturated:
        np.testing.assert_allclose(delivered, perp, rtol=0, atol=1e-9 * scale)
    else:
        assert float(np.linalg.norm(delivered)) <= float(np.linalg.norm(perp)) * (1 + 1e-9)
    if mode == "per_path":
        # the delivered torque is that of a dipole within every path's limit (m may be any dipole
        # differing from it along B)
        m_clip = np.clip(np.cross(B, T) / B2, -_LIMITS["m_max_Am2"], _LIMITS["m_max_Am2"])
        np.testing.assert_allclose(delivered, np.cross(m_clip, B), rtol=0, atol=1e-9 * scale)
    else:
        cap = _LIMITS["cap_Nm"] * (1.0 if mode == "norm" else math.sqrt(B2) / _LIMITS["B_ref_T"])
        assert float(np.linalg.norm(delivered)) <= cap * (1 + 1e-12)


@settings(max_examples=100, deadline=None)
@given(T=_vec, scale=st.floats(1e-6, 1e-2), w=_vec, w_scale=st.sampled_from([100.0, 750.0]))
def test_wheel_actuator_delivers_clip_of_request(T, scale, w, w_scale):
    """Ideal and DC-motor wheels: delivered = the request within ±τ_max and the speed limit (no
    voltage limit reached: |ω_M| ≤ 750 rad/s per wheel, K_b ω_M + R_M i_max < V_max; the speed
    limit Ω_max = 733 rad/s is)."""

    class Data:
        qvel = np.asarray(w) * w_scale
        ctrl = np.zeros(3)

    for model in ("ideal", "dc_motor"):
        act = WheelBodyTorqueActuator(
            WheelDriver(model=model), wheel_qvel=[0, 1, 2], wheel_act=[0, 1, 2], timestep_s=0.1
        )
        data = Data()
        act.bind(data)
        state = StepState(
            t=0.0,
            pos=np.zeros((1, 3)),
            vel=np.zeros((1, 3)),
            xquat=np.zeros((1, 4)),
            omega=np.zeros((1, 3)),
            ctrl=BodyTorque(torque_body_Nm=T * scale),
        )
        act.add(state, np.zeros((1, 6)))
        expected, _ = _wheel_oracle(T * scale, data.qvel, act.driver.p)
        np.testing.assert_allclose(act.delivered_body_Nm, expected, rtol=1e-9, atol=1e-18)
        np.testing.assert_array_equal(data.ctrl, act.wheel_torque_Nm)


def test_lattice_attitude_rate_of_a_rigid_rotation():
    """The truss sensor: best-fit quaternion and backward-difference rate of a rigid spin."""
    rng = np.random.default_rng(1)
    p = rng.normal(size=(10, 3))
    sensor = LatticeAttitude(p, omega0_body=(0.0, 0.0, 0.0))
    w = 0.05
    for k, t in enumerate((0.0, 0.5, 1.0)):
        c, s = math.cos(w * t), math.sin(w * t)
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        pos = np.vstack([np.zeros(3), p @ R.T])
        q, omega = sensor(
            StepState(t=t, pos=pos, vel=np.zeros_like(pos), xquat=np.zeros((11, 4)), omega=np.zeros((11, 3)))
        )
        np.testing.assert_allclose(abs(q[0]), math.cos(w * t / 2), atol=1e-12)
        if k:
            np.testing.assert_allclose(omega, [0.0, 0.0, w], atol=1e-12)


# ----------------------------------------------------------------------------- hostile inputs


@pytest.mark.parametrize(
    "make, key",
    [
        (lambda: BodyTorque(torque_body_Nm=[1.0, 2.0]), "torque_body_Nm"),
        (lambda: BodyTorque(torque_body_Nm=[1.0, math.nan, 0.0]), "torque_body_Nm"),
        (lambda: BodyTorque(torque_body_Nm="abc"), "torque_body_Nm"),
        (lambda: MagneticDipole(dipole_body_Am2=[[1.0, 2.0, 3.0]]), "dipole_body_Am2"),
        (lambda: RodPolarities(polarity=[1, 2, 0]), "polarity"),
        (lambda: LoopCurrents(currents_A=[]), "currents_A"),
        (lambda: WheelTorques(torque_Nm=[math.inf]), "torque_Nm"),
        (lambda: WheelVoltages(voltage_V=None), "voltage_V"),
        (lambda: JointTargets(targets=[0.1, 0.2], actuator_ids=[0]), "actuator_ids"),
        (lambda: JointTargets(targets=[0.1], actuator_ids=[-1]), "actuator_ids"),
    ],
)
def test_bad_commands_name_the_field(make, key):
    with pytest.raises(ValueError, match=key):
        make()


def test_commands_hold_copies():
    src = np.array([1.0, 2.0, 3.0])
    cmd = BodyTorque(torque_body_Nm=src)
    src[0] = 9.0
    assert cmd.torque_body_Nm[0] == 1.0
    assert RodPolarities(polarity=[1, -1, 0]).polarity.dtype == np.int8
    data = type("D", (), {"ctrl": np.zeros(3)})()
    JointTargets(targets=[0.5, -0.5], actuator_ids=[2, 0]).apply_ctrl(data)
    np.testing.assert_array_equal(data.ctrl, [-0.5, 0.0, 0.5])


def test_hostile_attach_and_factories():
    sim = magsail_mj.load(*CUBESAT)
    pd = _cubesat_pd(0.01)(sim)
    with pytest.raises(TypeError, match="controller"):
        attach(sim, object(), body_torque_actuator(sim))
    with pytest.raises(TypeError, match="actuators"):
        attach(sim, pd, [object()])
    with pytest.raises(TypeError, match="sim"):
        attach(object(), pd, body_torque_actuator(sim))
    with pytest.raises(ValueError, match="sim"):
        body_torque_actuator(object())
    with pytest.raises(ValueError, match="q_ref_wxyz"):
        QuaternionPD(
            sensor=attitude_sensor(sim), q_ref_wxyz=(0, 0, 0, 0), Pq_Nm=(1, 1, 1), Pw_Nms=(1, 1, 1), period_s=1.0
        )
    with pytest.raises(ValueError, match="Pw_Nms"):
        QuaternionPD(
            sensor=attitude_sensor(sim), q_ref_wxyz=(1, 0, 0, 0), Pq_Nm=(1, 1, 1), Pw_Nms=(1, -1, 1), period_s=1.0
        )
    with pytest.raises(ValueError, match="period_s"):
        QuaternionPD(
            sensor=attitude_sensor(sim), q_ref_wxyz=(1, 0, 0, 0), Pq_Nm=(1, 1, 1), Pw_Nms=(1, 1, 1), period_s=0.0
        )
    with pytest.raises(ValueError, match="saturation"):
        CoilBodyTorqueActuator(
            1,
            field_body=lambda t, R: np.ones(3),
            saturation="box",
            cap_Nm=1.0,
            B_ref_T=1e-5,
            m_max_Am2=(1.0, 1.0, 1.0),
        )
    unbound = body_torque_actuator(sim)
    state = _start_state(sim, BodyTorque(torque_body_Nm=[0.0, 0.0, 1e-5]))
    with pytest.raises(RuntimeError, match="attach"):
        unbound.add(state, np.zeros((sim.model.nbody, 6)))


def test_non_torque_command_is_a_zero_request():
    """An actuator given another command type (or none) requests nothing."""
    sim = magsail_mj.load(*REFLECTOR)
    act = body_torque_actuator(sim)
    sim.kin.update(sim.data)
    xfrc = np.zeros((sim.model.nbody, 6))
    for ctrl in (None, MagneticDipole(dipole_body_Am2=[1.0, 0.0, 0.0])):
        state = _start_state(sim, ctrl)
        act.add(state, xfrc)
        assert not xfrc.any() and not act.delivered_body_Nm.any()


def test_magnetic_dipole_command_drives_the_cubesat_magnetorquers():
    """A MagneticDipole command runs on the cubesat's magnetorquer load: torque = R (m × B_body)."""
    sim = magsail_mj.load(*CUBESAT)
    sim.kin.update(sim.data)
    bus = sim.scenario.idx.bus
    env = sim.environment.sample(0.0)
    m = np.array([0.1, -0.05, 0.02])
    state = _start_state(sim, MagneticDipole(dipole_body_Am2=m), env=env)
    R = quat_to_matrix(sim.kin.xquat[bus])
    expected = R @ np.cross(m, R.T @ np.asarray(env.B_eci))
    np.testing.assert_allclose(
        MagnetorquerLoad(bus).torque_world(state), expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max()
    )
    assert np.abs(expected).max() > 0


def test_rod_polarities_command_drives_the_truss_rods():
    """A RodPolarities command drives the truss rod load exactly as the rod controllers' command does."""
    sim = magsail_mj.load(TRUSS[0], ["lattice.units=3", "sim.duration_s=1"])
    rod = next(x for x in sim.loads if isinstance(x, MagnetorquerRodLoad))
    sim.kin.update(sim.data)
    pol = np.resize(np.array([1, -1, 0], dtype=np.int8), rod.n_rods)
    out = []
    for ctrl in (RodPolarities(polarity=pol), {"polarity": pol.copy()}):
        state = _start_state(sim, ctrl, env=sim.environment.sample(0.0))
        xfrc = np.zeros((sim.model.nbody, 6))
        rod.add(state, xfrc)
        out.append(xfrc)
    assert np.abs(out[0]).max() > 0
    np.testing.assert_array_equal(out[0], out[1])
