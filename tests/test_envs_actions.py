"""Every registered environment takes any finite action without an exception and refuses a
non-finite one by name (magsail_mj.envs.core.AttitudeTask.prepare_action, the one place actions
pass).

dm_control's convention for a ``BoundedArray`` action spec: a task that clips its actions clips
each component into the bounds; a task whose actuator saturates a request itself (a torque through
an allocation) hands the request on, scaled down (direction kept) to at most
``REQUEST_HEADROOM`` times the bounds. Huge finite actions (1e200, 1e308) overflowed the reward's
effort term and the rod allocation before.

Small, short builds (truss and current loops at 3 × 3 cubes, 2 s; msac 0.05 s; the structure
concept's sail, 2 s), each built once;
a few hypothesis examples per task, one environment step each.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from magsail_mj import envs
from magsail_mj.envs.core import REQUEST_HEADROOM
from tests.envs_shared import fresh_environment

SMALL = {
    "truss": ("lattice.units=3", "sim.duration_s=2", 'control.cache_dir=""'),
    "current_loops": ("lattice.units=3", "sim.duration_s=2"),
    "reflector": ("sim.duration_s=2",),
    "cnusail": ("sim.duration_s=5",),  # as tests/test_envs_cnusail.py: the same cached builds
    "msac": ("sim.duration_s=0.05",),
    "structure": ("sim.duration_s=2", "sim.progress=false"),  # the 100 m sail, control every 0.5 s
}
# every registered task, and the torque-request variants of the tasks whose default action is clipped
CASES = [(name, ()) for name in envs.list()] + [
    ("current_loops/slew", (("action", "torque"),)),
    ("reflector/detumble", (("action", "torque"),)),
]

huge = st.floats(allow_nan=False, allow_infinity=False) | st.sampled_from([1e200, -1e200, 1e308, -1.7e308, 1e-300])


def _env(name: str, options: tuple[tuple[str, str], ...]):
    return fresh_environment(name, SMALL[name.split("/")[0]], **dict(options))


def test_every_registered_task_is_covered() -> None:
    assert {name for name, _ in CASES} == set(envs.list())
    assert set(SMALL) == {name.split("/")[0] for name in envs.list()}


@pytest.mark.parametrize(("name", "options"), CASES, ids=[n + "".join(f"-{v}" for _, v in o) for n, o in CASES])
def test_any_finite_action_is_bounded_and_steps(name: str, options: tuple[tuple[str, str], ...]) -> None:
    env = _env(name, options)
    task = env.task
    n = env.action_spec().shape[0]
    bound = np.maximum(np.abs(task.action_low), np.abs(task.action_high))

    @settings(max_examples=2, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
    @given(arrays(float, n, elements=huge))
    @example(np.full(n, 1e200))
    def check(action: np.ndarray) -> None:
        env.reset()
        time_step = env.step(action)
        held = task._last_action  # what before_step handed on (prepare_action)
        assert np.all(np.isfinite(held))
        if task.clip_actions:
            assert np.all(held >= task.action_low) and np.all(held <= task.action_high)
        else:
            assert np.all(np.abs(held) <= REQUEST_HEADROOM * bound * (1 + 1e-12))
            big = np.abs(action) > REQUEST_HEADROOM * bound
            if big.any():  # scaled down, direction kept
                np.testing.assert_allclose(held / np.abs(held).max(), action / np.abs(action).max(), rtol=1e-12)
            else:
                np.testing.assert_array_equal(held, action)
        assert math.isfinite(time_step.reward) or env.physics.status == "diverged"

    check()


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_actions_are_refused_by_name(bad: float) -> None:
    for name, options in (("truss/detumble", ()), ("reflector/detumble", ())):
        env = _env(name, options)
        env.reset()
        action = np.zeros(env.action_spec().shape)
        action[0] = bad
        with pytest.raises(ValueError, match="action: every component must be finite"):
            env.step(action)
