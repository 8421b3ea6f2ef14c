"""CNUSAIL environments: dm_env conformance, the shipped controller as a policy (= magsail run),
seeding, and the plant's wheel/magnetorquer actuation against independent computations."""

from __future__ import annotations

import math
import unittest
from datetime import datetime, timedelta

import mujoco
import numpy as np
import pytest
from dm_env import test_utils

from magsail_mj import envs
from magsail_mj.concepts.cnusail.modes import command_quaternion
from magsail_mj.concepts.cnusail.eigenaxis import orbital_rate
from magsail_mj.concepts.cnusail import env as cnusail
from magsail_mj.envs.core import RewardWeights
from tests.envs_shared import assert_shipped_policy_gives_the_run_summary, built_environment, fresh_environment

DETUMBLE_5S = ("cnusail/detumble", ("sim.duration_s=5",))


class DetumbleConformance(test_utils.EnvironmentTestMixin, unittest.TestCase):
    def make_object_under_test(self):
        return fresh_environment(*DETUMBLE_5S)


class NadirConformance(test_utils.EnvironmentTestMixin, unittest.TestCase):
    def make_object_under_test(self):
        return fresh_environment("cnusail/nadir", ("sim.duration_s=5",))


class DeorbitConformance(test_utils.EnvironmentTestMixin, unittest.TestCase):
    def make_object_under_test(self):
        return fresh_environment("cnusail/deorbit", ("sim.duration_s=5",))


@pytest.mark.parametrize(
    "config, duration_s",
    [
        ("magsail_mj/concepts/cnusail/configs/detumble_post.toml", 20),
        ("magsail_mj/concepts/cnusail/configs/nadir_post.toml", 40),  # the unloading turns on at t ≈ 33 s
        ("magsail_mj/concepts/cnusail/configs/deorbit_recalc.toml", 20),
    ],
)
def test_shipped_policy_gives_magsail_run_summary(config, duration_s):
    ref, _ = assert_shipped_policy_gives_the_run_summary(config, [f"sim.duration_s={duration_s}"])
    assert len(ref) > 40


@pytest.mark.parametrize("law", ["bang_bang", "b_cross", "non_monotonic"])
def test_shipped_policy_of_each_detumble_law_gives_the_run_summary(law):
    """The detumble laws that read the body rate at the magnetorquer sample go through the
    environment's sample as through the run's."""
    overrides = ["sim.duration_s=20", f"control.bdot_law={law!r}".replace("'", '"')]
    ref, _ = assert_shipped_policy_gives_the_run_summary(
        "magsail_mj/concepts/cnusail/configs/detumble_pre.toml", overrides
    )
    assert len(ref) > 40


def test_task_follows_config_and_lists():
    names = envs.list()
    for name in ("cnusail/detumble", "cnusail/nadir", "cnusail/deorbit"):
        assert name in names
    env = built_environment("cnusail/nadir", ("sim.duration_s=5",))
    assert env.control_timestep() == pytest.approx(1.0 / env.physics.cfg.control.rate_Hz)
    spec = env.action_spec()
    assert spec.shape == (6,)
    motor = env.physics.cfg.actuators.wheels.motor_params()
    u_max = motor.K_M_Nm_A * motor.current_max_A + 2 * motor.K_B_Nms * motor.speed_max_rad_s
    assert spec.maximum[0] == pytest.approx(u_max)
    # a request beyond the bound gives the wheel command of the clipped request (clipping is harmless)
    driver = env.physics.base.controller.driver
    rng = np.random.default_rng(0)
    for _ in range(200):
        u = rng.uniform(-5, 5, 3) * u_max
        w = rng.uniform(-1, 1, 3) * motor.speed_max_rad_s
        np.testing.assert_array_equal(driver.command(u, w), driver.command(np.clip(u, -u_max, u_max), w))
    np.testing.assert_array_equal(spec.maximum[3:], env.physics.cfg.actuators.mtq.limit_vector)
    with pytest.raises(ValueError, match="action"):
        envs.load("cnusail/detumble", ["sim.duration_s=5"], action="wheels")


def test_same_seed_same_first_observation():
    first = []
    for seed in (7, 7, 8):
        env = fresh_environment(*DETUMBLE_5S)
        env.task._random = np.random.RandomState(seed)
        first.append(env.reset().observation)
    for key in first[0]:
        np.testing.assert_array_equal(first[0][key], first[1][key])
    assert not np.array_equal(first[0]["body_rate_rad_s"], first[2]["body_rate_rad_s"])
    # a rate drawn within ±rate_range per axis
    rng = envs.load("cnusail/detumble", ["sim.duration_s=5"], random=7).task.rate_range_deg_s
    assert np.all(np.abs(np.degrees(first[0]["body_rate_rad_s"])) <= rng)


def test_wheel_currents_give_the_motor_torque():
    """``current_dipole``: T_M = K_M (V − K_b ω_M)/R with V = clip(R i_c + K_b ω_M, ±V_max) every step."""
    env = envs.load(
        "cnusail/detumble", ["sim.duration_s=3", "sim.record_every=1"], randomize=False, action="current_dipole"
    )
    motor = env.physics.cfg.actuators.wheels.motor_params()
    i_c = np.array([0.5, -0.3, 0.1]) * motor.current_max_A
    ts = env.reset()
    while not ts.last():
        ts = env.step(np.concatenate([i_c, np.zeros(3)]))
    rec = env.physics.sim.records()
    w = rec["qvel"][:, env.physics.scenario.idx.wheel_qvel]
    V = np.clip(motor.R_ohm * i_c + motor.K_b_Vs_rad * w, -motor.V_max_V, motor.V_max_V)
    want = motor.K_M_Nm_A * (V - motor.K_b_Vs_rad * w) / motor.R_ohm
    np.testing.assert_allclose(rec["T_M_Nm"], want, rtol=1e-12, atol=1e-18)
    assert np.all(np.abs(w[-1]) > 0)  # the wheels spun up


def test_dipole_latched_per_cycle_and_blanked():
    """The dipole of the action at a cycle boundary acts for cycle_s − blank_s, then 0; an action
    between boundaries waits for the next one. Torque = m × Aᵀ B_eci (body axes)."""
    env = envs.load("cnusail/detumble", ["sim.duration_s=4", "sim.record_every=1"], randomize=False)
    cfg = env.physics.cfg
    m = [np.array([0.1, -0.05, 0.02]), np.array([-0.2, 0.2, -0.1]), np.array([0.03, 0.04, -0.05]), np.zeros(3)]
    env.reset()
    for a in m:
        env.step(a)
    rec = env.physics.sim.records()
    t = rec["t"]
    on = (t % cfg.actuators.mtq.cycle_s) < cfg.actuators.mtq.cycle_s - cfg.actuators.mtq.blank_s - 1e-9
    latched = np.where((t < 2.0 - 1e-9)[:, None], m[0], m[2])
    np.testing.assert_array_equal(rec["dipole_cmd_Am2"][:-1], latched[:-1])
    q = rec["qpos"][:, env.physics.scenario.idx.q_quat]
    B_eci = np.array([env.physics.sim.environment.sample(float(x)).B_eci for x in t])
    R = np.empty((len(t), 9))
    for k in range(len(t)):
        mujoco.mju_quat2Mat(R[k], q[k])
    B_body = np.einsum("kji,kj->ki", R.reshape(-1, 3, 3), B_eci)
    want = np.where(on[:, None], np.cross(latched, B_body), 0.0)
    np.testing.assert_allclose(rec["torque_mtq_body_Nm"][:-1], want[:-1], rtol=1e-12, atol=1e-20)
    assert np.count_nonzero(~on[:-1]) == 4  # 1.8, 1.9, 3.8, 3.9 s


def test_detumble_reward_formula():
    weights = RewardWeights(w_theta=1.0, w_omega=0.5, w_u=0.2)
    env = envs.load("cnusail/detumble", ["sim.duration_s=3"], randomize=False, reward_weights=weights)
    cfg = env.physics.cfg
    a = np.array([0.1, -0.1, 0.05])
    env.reset()
    ts = env.step(a)
    w_s = math.radians(cfg.analysis.detumble_threshold_deg_s)
    effort = float(np.mean((a / cfg.actuators.mtq.limit_vector) ** 2))
    rate = float(np.linalg.norm(ts.observation["body_rate_rad_s"]))
    assert ts.reward == pytest.approx(-(0.5 * (rate / w_s) ** 2 + 0.2 * effort), rel=1e-12)


def test_epoch_draw_is_seeded_and_within_range():
    """``epoch_range_s``: the episode's epoch is drawn in [orbit.epoch, orbit.epoch + range] from the
    task's seed; the simulation is rebuilt for it (the reference orbit at t = 0 moves with it)."""
    starts, first = [], []
    for seed in (5, 5):
        env = envs.load("cnusail/detumble", ["sim.duration_s=3"], random=seed, epoch_range_s=86400.0)
        first.append(env.reset().observation)
        starts.append(env.task.start["epoch"])
        ts = env.step(np.zeros(3))
        assert ts.mid() and env.physics.sim.cfg.orbit.epoch == starts[-1]
    assert starts[0] == starts[1]
    for key in first[0]:
        np.testing.assert_array_equal(first[0][key], first[1][key])
    epoch0 = datetime.fromisoformat(built_environment(*DETUMBLE_5S).physics.cfg.orbit.epoch.replace("Z", "+00:00"))
    drawn = datetime.fromisoformat(starts[0])
    assert epoch0 < drawn <= epoch0 + timedelta(days=1)
    plain = envs.load("cnusail/detumble", ["sim.duration_s=3"], random=5).reset().observation
    assert not np.allclose(plain["orbit_position_eci_m"], first[0]["orbit_position_eci_m"])
    with pytest.raises(ValueError, match="epoch_range_s"):
        envs.load("cnusail/detumble", ["sim.duration_s=3"], epoch_range_s=-1.0)


def test_command_frame_matches_the_flight_software():
    """The plant's scalar command frame equals the controller's command quaternion and orbital rate
    (to round-off, 1e-14) for random orbits, all three modes."""
    rng = np.random.default_rng(1)
    for _ in range(300):
        r, v = rng.normal(size=3) * 7.0e6, rng.normal(size=3) * 7.5e3
        for mode in (0, 1, 2):
            q, w_o = cnusail.command_frame(mode, r, v)
            np.testing.assert_allclose(q, command_quaternion(mode, r, v), rtol=0, atol=1e-14)
            assert w_o == pytest.approx(orbital_rate(r, v), rel=1e-14)
