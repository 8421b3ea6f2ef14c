"""Current-loop environment (magsail_mj.concepts.current_loops.env): dm_env contract, the shipped slew
controller as a policy in both action modes (same summary as the run, 1e-9 relative), flexible
and rigid variants. 3 × 3-cube lattice, 2–10 s."""

from __future__ import annotations

import numpy as np
import pytest
from absl.testing import absltest
from dm_env import test_utils

from magsail_mj import envs
from magsail_mj.envs.core import REPO_ROOT
from tests.envs_shared import RandomActions, assert_shipped_policy_gives_the_run_summary

SHORT = ["lattice.units=3", "sim.duration_s=2"]
RIGID = REPO_ROOT / "magsail_mj/concepts/current_loops/configs/slew_rigid.toml"


class _Sequence(RandomActions):
    action_count = 90  # two 40-step episodes and part of a third


class LoopsSlewCurrentsEnvTest(_Sequence, test_utils.EnvironmentTestMixin, absltest.TestCase):
    def make_object_under_test(self):
        return envs.load("current_loops/slew", SHORT, random=0)


class LoopsRigidSlewTorqueEnvTest(_Sequence, test_utils.EnvironmentTestMixin, absltest.TestCase):
    def make_object_under_test(self):
        return envs.load(RIGID, ["sim.duration_s=2"], random=0, action="torque")


@pytest.mark.parametrize(
    ("config", "overrides", "action"),
    [
        ("magsail_mj/concepts/current_loops/configs/slew.toml", ["lattice.units=3", "sim.duration_s=10"], "currents"),
        ("magsail_mj/concepts/current_loops/configs/slew.toml", ["lattice.units=3", "sim.duration_s=10"], "torque"),
        ("magsail_mj/concepts/current_loops/configs/slew_rigid.toml", ["sim.duration_s=10"], "currents"),
    ],
)
def test_shipped_controller_through_the_environment_gives_the_run_summary(
    config: str, overrides: list[str], action: str
) -> None:
    ref, _ = assert_shipped_policy_gives_the_run_summary(REPO_ROOT / config, overrides, action=action)
    assert len(ref) > 10


def test_currents_action_is_in_config_circuit_order() -> None:
    """A current on the first configured circuit (C_x: normal along body x) alone gives a dipole
    along body x: m = m_max I / I_max on that axis only, torque m × B_b."""
    env = envs.load("current_loops/slew", SHORT, random=0)
    env.reset()
    i_max = env.action_spec().maximum
    env.step(np.array([0.5 * i_max[0], 0.0, 0.0]))
    cmd = env.physics.controller.command
    law = env.task.converter.law
    np.testing.assert_array_equal(cmd.currents_A, [0.5 * i_max[0], 0.0, 0.0])
    np.testing.assert_allclose(cmd.dipole_cmd_body, [0.5 * law.m_max, 0.0, 0.0], rtol=1e-15)
    np.testing.assert_allclose(cmd.torque_ref_body, np.cross(cmd.dipole_cmd_body, cmd.B_body), rtol=1e-15)


def test_structural_observations_only_where_there_is_a_structure() -> None:
    flexible = envs.load("current_loops/slew", SHORT, random=0).reset().observation
    rigid = envs.load(RIGID, ["sim.duration_s=2"], random=0).reset().observation
    assert {"surface_sd_m", "strain_max"} <= set(flexible)
    assert not {"surface_sd_m", "strain_max"} & set(rigid)
    assert set(rigid) == {"attitude_wxyz", "body_rate_rad_s", "field_body_T", "target_wxyz"}
