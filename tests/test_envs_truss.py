"""Truss environments (magsail_mj.concepts.truss_magnetorquer.env): dm_env contract, shipped controllers as policies
(same summary as the run of the config, 1e-9 relative), the signed-rod-count action, the episode
start. Small lattices (3 × 3 cubes) and short runs (2–10 s at δt = 0.1 s)."""

from __future__ import annotations

import math
from datetime import datetime, timedelta

import magsail_mj
import numpy as np
import pytest
from absl.testing import absltest
from dm_env import test_utils

from magsail_mj import envs
from magsail_mj.config import load_config
from magsail_mj.estimation.attitude import BestFitRotation, so3_exp
from magsail_mj.quaternion import quat_from_matrix, quat_to_matrix
from tests.envs_shared import RandomActions, assert_shipped_policy_gives_the_run_summary

SMALL = ["lattice.units=3", 'control.cache_dir=""']
SHORT = [*SMALL, "sim.duration_s=2"]  # 20 steps: the 50 conformance actions span two episodes and part of a third


class TrussDetumbleTorqueEnvTest(RandomActions, test_utils.EnvironmentTestMixin, absltest.TestCase):
    def make_object_under_test(self):
        return envs.load("truss/detumble", SHORT, random=0)


class TrussSlewRodsEnvTest(RandomActions, test_utils.EnvironmentTestMixin, absltest.TestCase):
    def make_object_under_test(self):
        return envs.load("truss/slew_III", SHORT, random=0, action="rods")


@pytest.mark.parametrize("name", ["truss/detumble", "truss/slew_I", "truss/slew_II", "truss/slew_III", "truss/slew_IV"])
def test_shipped_controller_through_the_environment_gives_the_run_summary(name: str) -> None:
    ref, _ = assert_shipped_policy_gives_the_run_summary(
        name, [*SMALL, "sim.duration_s=6"], reference=envs.core.task_entry(name).config
    )
    assert len(ref) > 20


def test_rod_counts_action_drives_the_same_rods() -> None:
    """The shipped signed counts (N1, N2) as the ``rods`` action select the same rods, so the motion
    is the run's exactly (the recorded reference torque is then the allocated one)."""
    overrides = [*SMALL, "sim.duration_s=5"]
    env = envs.load("truss/slew_II", overrides, randomize=False, action="rods")
    envs.run_episode(env, envs.shipped_policy(env))
    got = env.physics.result().records
    sim = magsail_mj.load(load_config(envs.core.task_entry("truss/slew_II").config, overrides))
    ref = sim.run().records
    for key in ("qpos", "N_signed", "rod_counts", "strut_activity", "torque_ac_body_Nm"):
        np.testing.assert_array_equal(got[key], ref[key], err_msg=key)
    np.testing.assert_array_equal(got["torque_ref_body_Nm"], got["torque_alloc_body_Nm"])


def test_rods_action_is_rounded_and_clipped_to_the_rod_counts() -> None:
    env = envs.load("truss/detumble", SHORT, random=0, action="rods")
    env.reset()
    n_max = env.action_spec().maximum
    assert env.action_spec().name == "N1,N2" and np.all(n_max == np.round(n_max)) and np.all(n_max > 0)
    env.step(np.array([2.5, -1e9]))
    cmd = env.physics.controller.command
    assert (cmd.N1, cmd.N2) == (3, -int(n_max[1]))
    assert np.count_nonzero(cmd.polarity) == 3 + int(n_max[1])


def test_drawn_start_is_a_rigid_motion_with_the_drawn_rates() -> None:
    """The particles start rigidly turned and spinning: the best-fit rotation of the first
    observation is the drawn attitude, and after one control period the backward-difference rate
    matches the drawn rate to O(|ω| δt) (free rigid rotation; tolerance 2 % of |ω|)."""
    env = envs.load("truss/detumble", SHORT, random=9, rate_range_rad_s=0.002)
    obs = env.reset().observation
    start = env.task.start
    assert abs(abs(float(obs["attitude_wxyz"] @ start["q0_wxyz"])) - 1.0) < 1e-12
    np.testing.assert_array_equal(obs["body_rate_rad_s"], start["omega0_body_rad_s"])
    assert obs["strain_max"][0] < 1e-12 and obs["surface_sd_m"][0] < 1e-9
    obs1 = env.step(np.zeros(3)).observation
    w = start["omega0_body_rad_s"]
    assert np.linalg.norm(obs1["body_rate_rad_s"] - w) < 0.02 * np.linalg.norm(w)
    R, _ = BestFitRotation(env.physics.scenario.tm.lattice.nodes)(env.physics.step_state().pos[env.task.node_slice])
    assert abs(abs(float(quat_from_matrix(R) @ obs1["attitude_wxyz"])) - 1.0) < 1e-12


def test_health_observations_are_held_between_refreshes() -> None:
    env = envs.load("truss/detumble", SHORT, random=1, health_every=5)
    env.reset()
    seen = [env.step(np.zeros(3)).observation["surface_sd_m"][0] for _ in range(9)]
    # refreshed at observations 0, 5, 10 …: steps 1–4 repeat the reset's value, 5–9 the fifth's
    assert len(set(seen[:4])) == 1 and len(set(seen[4:9])) == 1 and seen[4] != seen[3]
    assert math.isfinite(seen[0])


def test_rate_from_rotations_is_the_log_map_rate() -> None:
    """R = R0 · exp(ω̂ δt) gives back ω (body axes) for small and large turns (rotation vector of
    the turn divided by δt)."""
    rng = np.random.RandomState(2)
    R0 = so3_exp(rng.normal(size=3))
    for angle in (1e-7, 1e-3, 0.5, 2.5):
        axis = rng.normal(size=3)
        w = angle * axis / np.linalg.norm(axis) / 0.1
        got = envs.truss.rate_from_rotations(R0, R0 @ so3_exp(w * 0.1), 0.1)
        np.testing.assert_allclose(got, w, rtol=1e-9, atol=1e-15)


def test_epoch_draw_rebuilds_the_orbit_at_a_seeded_epoch() -> None:
    """epoch_range_s: each episode's epoch is orbit.epoch + U(0, range), drawn first from the task's
    random state; the same seed gives the same epoch and field, the field differs from the
    config epoch's, and the episode runs on the rebuilt simulation."""
    runs = [envs.load("truss/detumble", SHORT, random=3, epoch_range_s=86400.0) for _ in range(2)]
    first = [env.reset().observation for env in runs]
    epochs = [env.task.start["epoch"] for env in runs]
    assert epochs[0] == epochs[1] == runs[0].physics.cfg.orbit.epoch
    offset = datetime.fromisoformat(epochs[0]) - datetime.fromisoformat("2020-01-01T00:00:00+00:00")
    assert timedelta(0) <= offset <= timedelta(days=1)
    np.testing.assert_array_equal(first[0]["field_body_T"], first[1]["field_body_T"])
    plain = envs.load("truss/detumble", SHORT, random=3).reset().observation
    assert not np.allclose(plain["field_body_T"], first[0]["field_body_T"])
    _, n = envs.run_episode(runs[0], lambda ts: np.zeros(3))
    assert n == 20 and runs[0].physics.status == "completed"
    assert runs[0].task.start["epoch"] != epochs[0]  # the second episode drew its own epoch
    with pytest.raises(ValueError, match="epoch_range_s: this config has no orbit"):
        envs.load("reflector/detumble", ["sim.duration_s=2"], epoch_range_s=10.0)


def test_quat_of_rotation_equals_quat_from_matrix():
    """The observation's scalar quaternion of a rotation matrix is the vectorised
    ``quat_from_matrix`` (same Shepperd construction and operation order): equal to 1e-15 (observed
    bit-equal) on random rotations, near-180° turns (the other diagonal entries of K chosen) included."""
    rng = np.random.default_rng(3)
    quats = rng.normal(size=(400, 4))
    quats[::4] = [0.0, 1.0, 0.0, 0.0] + 1e-9 * rng.normal(size=(100, 4))
    quats[1::4] = [0.0, 0.0, 0.6, -0.8] + 1e-9 * rng.normal(size=(100, 4))
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    for q in quats:
        R = quat_to_matrix(q)
        a, b = envs.truss.quat_of_rotation(R), quat_from_matrix(R)
        assert a[0] >= 0.0
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)


def test_reused_fit_repeats_only_for_equal_positions():
    """``ReusedFit`` returns the wrapped fit's result for equal positions (copies, so a caller
    mutating one does not change the next), and fits again when a position changes."""
    rng = np.random.default_rng(4)
    nodes = rng.normal(size=(8, 3))
    fit = BestFitRotation(nodes)
    reused = envs.truss.ReusedFit(fit)
    pos = nodes @ quat_to_matrix(np.array([0.9, 0.1, -0.3, 0.2]) / math.sqrt(0.95)).T + 1.0
    R1, d1 = reused(pos)
    R_ref, d_ref = fit(pos)
    np.testing.assert_array_equal(R1, R_ref)
    np.testing.assert_array_equal(d1, d_ref)
    R1[:] = 0.0
    R2, _ = reused(pos.copy())
    np.testing.assert_array_equal(R2, R_ref)
    moved = pos.copy()
    moved[0, 0] += 1e-3
    R3, _ = reused(moved)
    np.testing.assert_array_equal(R3, fit(moved)[0])
    assert not np.array_equal(R3, R_ref)
