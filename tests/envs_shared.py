"""Helpers of the environment tests (tests/test_envs_*.py): the random action sequence of the
dm_env conformance tests, and the check that a scenario's shipped controller run through its
environment gives the summary of ``magsail run`` (1e-9 relative, wall-clock keys left out), and
environments built once and handed out afresh."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any, Iterator

import numpy as np
from dm_control.rl import control

import magsail_mj
from magsail_mj import envs
from magsail_mj.config import load_config


class RandomActions:
    """``make_action_sequence`` of ``dm_env.test_utils.EnvironmentTestMixin``: ``action_count``
    actions drawn uniformly within the action spec's bounds (seed 0)."""

    action_count = 50
    environment: control.Environment

    def make_action_sequence(self) -> Iterator[np.ndarray]:
        spec = self.environment.action_spec()
        rng = np.random.RandomState(0)
        for _ in range(self.action_count):
            yield rng.uniform(spec.minimum, spec.maximum)


def run_summary(config: str | Path, overrides: list[str]) -> dict[str, Any]:
    """The summary ``magsail run`` writes for ``config``: its simulation run, then the scenario's
    post-processing."""
    sim = magsail_mj.load(load_config(config, overrides))
    return sim.scenario.postprocess(sim.run())[0]


def shipped_policy_episode(config: str | Path, overrides: list[str], **options: Any) -> tuple[control.Environment, int]:
    """The environment of ``config`` (a task name or a path; start from the config, no draw) after
    one episode driven by the shipped controller (:func:`magsail_mj.envs.shipped_policy`), and the
    number of steps; the episode must end by its time limit (discount 1, not a failure)."""
    env = envs.load(config, overrides, randomize=False, **options)
    policy = envs.shipped_policy(env)
    time_step, steps = env.reset(), 0
    while not time_step.last():
        time_step = env.step(policy(time_step))
        steps += 1
    assert time_step.discount == 1.0, env.physics.status
    return env, steps


def assert_shipped_policy_gives_the_run_summary(
    config: str | Path, overrides: list[str], *, reference: str | Path | None = None, **options: Any
) -> tuple[dict[str, Any], int]:
    """Assert that the shipped controller through the environment of ``config`` reproduces the
    summary of the run of ``reference`` (a config path; default ``config``) to 1e-9 relative
    (:func:`magsail_mj.envs.summary_mismatches`); returns that summary and the episode's steps."""
    env, steps = shipped_policy_episode(config, overrides, **options)
    ref = run_summary(reference if reference is not None else config, overrides)
    assert envs.summary_mismatches(ref, env.physics.summary(), rel=1e-9) == []
    return ref, steps


@functools.lru_cache(maxsize=None)
def built_environment(config: str, overrides: tuple[str, ...] = (), **options: Any) -> control.Environment:
    """The environment of ``config`` seeded with 0, built once per arguments (a build takes seconds)."""
    return envs.load(config, list(overrides), random=0, **options)


def fresh_environment(config: str, overrides: tuple[str, ...] = (), **options: Any) -> control.Environment:
    """A new Environment around the physics and task of :func:`built_environment` (time limit the
    config's ``sim.duration_s``)."""
    env = built_environment(config, tuple(overrides), **options)
    return control.Environment(
        env.physics, env.task, time_limit=env.physics.cfg.sim.duration_s, control_timestep=env.control_timestep()
    )
