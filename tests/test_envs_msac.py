"""MSAC panel-cycle environment: dm_env conformance, the configured cycle as a policy (= magsail
run), seeding, and commanded cycles against the exact planar model (ours, for verification)."""

from __future__ import annotations

import dataclasses
import math
import unittest

import numpy as np
import pytest
from dm_control.rl import control
from dm_env import test_utils

from magsail_mj import envs
from magsail_mj.concepts.msac.reference import exact_rotation_path
from magsail_mj.config import load_config
from magsail_mj.envs.core import REPO_ROOT, entry_for_config
from tests.envs_shared import assert_shipped_policy_gives_the_run_summary, fresh_environment

SLOW = "magsail_mj/concepts/msac/configs/slow_1hz.toml"  # 200 steps per 1 s cycle: cheap cycles


def fresh(action: str) -> control.Environment:
    return fresh_environment(SLOW, ("sim.duration_s=3",), action=action)


class JointTargetsConformance(test_utils.EnvironmentTestMixin, unittest.TestCase):
    def make_object_under_test(self):
        return fresh("joint_targets")


class PhaseTimingConformance(test_utils.EnvironmentTestMixin, unittest.TestCase):
    def make_object_under_test(self):
        return fresh("phase_timing")


@pytest.mark.parametrize(
    "config, duration, action",
    [
        (SLOW, "3", "joint_targets"),
        (SLOW, "3", "phase_timing"),
        ("magsail_mj/concepts/msac/configs/paper_1khz.toml", "0.01", "joint_targets"),
    ],
)
def test_configured_cycle_gives_magsail_run_summary(config, duration, action):
    """The environment drives the servo replay (its actions are joint targets): with the configured
    cycle it gives the summary of ``magsail run`` with that drive."""
    overrides = [f"sim.duration_s={duration}", "drive.method='replay'"]
    ref, steps = assert_shipped_policy_gives_the_run_summary(config, overrides, action=action)
    assert steps == round(float(duration) * load_config(config).cycle.frequency_Hz)
    assert len(ref) > 40


def _per_cycle_yaw(env: control.Environment, action: np.ndarray) -> np.ndarray:
    ts = env.reset()
    yaw = [ts.observation["bus_yaw_rad"][0]]
    while not ts.last():
        ts = env.step(action)
        yaw.append(ts.observation["bus_yaw_rad"][0])
    return np.diff(yaw)


def test_commanded_cycles_turn_as_the_exact_model():
    """Once settled (third cycle on), the rotation per cycle of a commanded cycle is the exact
    planar model's for that path (0.1 %); the loop run the other way turns the other way; a cycle
    without stroke (φa = φb: extension alone, reciprocal) does not turn (< 1e-3 of it)."""
    env = envs.load(SLOW, ["sim.duration_s=4"], randomize=False)
    sc = env.physics.scenario
    a = np.array([math.radians(5.0), math.radians(-8.0), 0.05, -0.02])
    path = dataclasses.replace(sc.path, phi_a_rad=a[0], phi_b_rad=a[1], s_e_m=a[2], s_c_m=a[3])
    exact = float(exact_rotation_path(sc.planar, path.waypoints).sum())
    assert abs(exact) > 1e-4
    turned = _per_cycle_yaw(env, a)
    assert turned[3] == pytest.approx(exact, rel=1e-3)
    back = _per_cycle_yaw(env, a[[1, 0, 2, 3]])
    assert back[3] == pytest.approx(-exact, rel=2e-3)
    still = _per_cycle_yaw(env, np.array([a[0], a[0], a[2], a[3]]))
    assert abs(still[3]) < 1e-3 * abs(exact)
    # the shape reached the commanded start point at the cycle start
    obs = env.reset().observation
    assert obs["shape_qpos"][0] == pytest.approx(sc.path.phi_a_rad, abs=1e-9)


def test_reward_counts_turn_in_units_of_the_configured_cycle():
    env = envs.load(SLOW, ["sim.duration_s=3"], randomize=False)
    policy = envs.shipped_policy(env)
    ts = env.reset()
    rewards = []
    while not ts.last():
        ts = env.step(policy(ts))
        rewards.append(ts.reward)
    # the configured cycle: no effort, each settled cycle turns the exact model's angle (0.1 %)
    assert rewards[-1] == pytest.approx(1.0, rel=1e-3)


def test_same_seed_same_first_observation_and_bounds():
    obs = []
    for seed in (3, 3, 4):
        env = fresh("joint_targets")
        env.task._random = np.random.RandomState(seed)
        obs.append(env.reset().observation)
    for key in obs[0]:
        np.testing.assert_array_equal(obs[0][key], obs[1][key])
    assert obs[0]["bus_yaw_rad"][0] != obs[2]["bus_yaw_rad"][0]
    spec = fresh("joint_targets").action_spec()
    assert spec.shape == (4,)
    np.testing.assert_allclose(spec.maximum[:2], np.pi / 2)
    with pytest.raises(ValueError, match="cycles_per_step"):
        envs.load(SLOW, ["sim.duration_s=3"], cycles_per_step=0)


def test_every_shipped_cnusail_and_msac_config_is_served_or_refused():
    """Every config file of the two concepts: CNUSAIL attitude configs are served by the task of
    their law/command, MSAC multibody configs by ``msac/cycle``; the lifetime analysis, the analytic
    ``lumped`` scenario and the sweeps are refused (the registry's match only, no build)."""
    served, refused = {}, 0
    for folder in ("cnusail", "msac"):
        for path in sorted((REPO_ROOT / "magsail_mj" / "concepts" / folder).rglob("*.toml")):
            try:
                cfg = load_config(path)
            except ValueError:
                continue  # a sweep-of-runs file, not a run config
            attitude = (cfg.kind == "attitude") if folder == "cnusail" else (cfg.scenario == "multibody")
            if attitude:
                name = entry_for_config(cfg, str(path)).name
                assert name.startswith(folder + "/"), path
                if folder == "cnusail":
                    want = "detumble" if cfg.control.mode == "bdot" else cfg.control.command
                    assert name == f"cnusail/{want}", path
                served[name] = served.get(name, 0) + 1
            else:
                with pytest.raises(ValueError, match="has no environment"):
                    entry_for_config(cfg, str(path))
                refused += 1
    assert served["cnusail/detumble"] >= 2 and served["cnusail/nadir"] >= 3 and served["cnusail/deorbit"] >= 2
    assert served["msac/cycle"] >= 5 and refused >= 3
