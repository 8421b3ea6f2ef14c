"""Reflector environments (magsail_mj.concepts.reflector.env): dm_env contract, the shipped B-dot laws and
the pitch controller as policies (same summary as the run, 1e-9 relative), the coil actions.
Short runs (2–100 s)."""

from __future__ import annotations

import numpy as np
import pytest
from absl.testing import absltest
from dm_env import test_utils

from magsail_mj import envs
from magsail_mj.envs.core import REPO_ROOT
from tests.envs_shared import RandomActions, assert_shipped_policy_gives_the_run_summary


class ReflectorDetumbleEnvTest(RandomActions, test_utils.EnvironmentTestMixin, absltest.TestCase):
    def make_object_under_test(self):
        return envs.load("reflector/detumble", ["sim.duration_s=2"], random=0)


class ReflectorPitchEnvTest(RandomActions, test_utils.EnvironmentTestMixin, absltest.TestCase):
    def make_object_under_test(self):
        return envs.load("reflector/pitch_tracking", ["sim.duration_s=10"], random=0)


@pytest.mark.parametrize(
    ("config", "duration", "action"),
    [
        ("magsail_mj/concepts/reflector/configs/detumble.toml", 20, "currents"),
        ("magsail_mj/concepts/reflector/configs/detumble/norm_cap.toml", 20, "torque"),
        ("magsail_mj/concepts/reflector/configs/detumble/printed_law.toml", 20, "torque"),
        ("magsail_mj/concepts/reflector/configs/detumble/body_field.toml", 20, "currents"),
        ("magsail_mj/concepts/reflector/configs/tracking_100g.toml", 100, "torque"),
        ("magsail_mj/concepts/reflector/configs/tracking_10g.toml", 100, "torque"),
        ("magsail_mj/concepts/reflector/configs/pitch/b4_rate_error_ff_sigma10.toml", 100, "torque"),
    ],
)
def test_shipped_controller_through_the_environment_gives_the_run_summary(
    config: str, duration: int, action: str
) -> None:
    ref, _ = assert_shipped_policy_gives_the_run_summary(
        REPO_ROOT / config, [f"sim.duration_s={duration}"], action=action
    )
    assert len(ref) > 10


def test_coil_currents_give_the_dipole_torque() -> None:
    """x-coil at +I_max alone: m = (m_max, 0, 0), T = m × B_b (the plate's field in body axes)."""
    env = envs.load("reflector/detumble", ["sim.duration_s=2"], random=0)
    env.reset()
    i_max = env.action_spec().maximum[0]
    env.step(np.array([i_max, 0.0]))
    cmd = env.physics.controller.command
    m_max = env.task.converter.law.m_max
    np.testing.assert_array_equal(cmd.dipole_body, [m_max, 0.0, 0.0])
    np.testing.assert_allclose(cmd.torque_body, np.cross([m_max, 0.0, 0.0], cmd.B_body), rtol=1e-15)
    np.testing.assert_array_equal(cmd.saturated, [True, False])


def test_torque_request_is_projected_off_the_field_and_capped() -> None:
    """Requests along B deliver nothing; a large request ⟂ B is capped at T_max (norm)."""
    env = envs.load("reflector/detumble", ["sim.duration_s=2"], random=0, action="torque")
    obs = env.reset().observation
    b = obs["field_body_T"] / np.linalg.norm(obs["field_body_T"])
    env.step(5.0 * b)
    np.testing.assert_allclose(env.physics.controller.command.torque_body, 0.0, atol=1e-18)
    cap = env.task.converter.law.T_max
    perp = np.cross(b, [1.0, 0.0, 0.0])
    perp /= np.linalg.norm(perp)
    env.step(100 * cap * perp)
    torque = env.physics.controller.command.torque_body
    np.testing.assert_allclose(np.linalg.norm(torque), cap, rtol=1e-12)
    B = env.physics.controller.command.B_body
    assert abs(float(torque @ B)) < 1e-12 * cap * np.linalg.norm(B)


def test_pitch_observations_carry_the_steering_reference() -> None:
    """Started on the reference (randomize=False): attitude = q_ref(0), rate = ω_ref(0) = −ψ̇ ŷ."""
    env = envs.load("reflector/pitch_tracking", ["sim.duration_s=10"], randomize=False)
    obs = env.reset().observation
    assert abs(abs(float(obs["attitude_wxyz"] @ obs["target_wxyz"])) - 1.0) < 1e-12
    np.testing.assert_allclose(obs["body_rate_rad_s"], obs["target_rate_rad_s"], rtol=0, atol=1e-15)
    assert obs["target_rate_rad_s"][1] != 0.0
