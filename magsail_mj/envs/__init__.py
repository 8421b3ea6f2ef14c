"""dm_control environments of the shipped attitude scenarios (see :mod:`magsail_mj.envs.core`).

    from magsail_mj import envs
    env = envs.load("truss/detumble", ["lattice.units=3", "sim.duration_s=20"], random=0)
    time_step = env.reset()
    while not time_step.last():
        time_step = env.step(policy(time_step))

:func:`load` returns a ``dm_control.rl.control.Environment``; :func:`list` names the tasks;
:func:`shipped_policy` runs a scenario's own controller through its environment.
"""

from __future__ import annotations

from magsail_mj.concepts.cnusail import env as cnusail  # noqa: F401  (registers the tasks)
from magsail_mj.concepts.current_loops import env as current_loops  # noqa: F401  (registers the tasks)
from magsail_mj.concepts.msac import env as msac  # noqa: F401  (registers the tasks)
from magsail_mj.concepts.reflector import env as reflector  # noqa: F401  (registers the tasks)
from magsail_mj.concepts.truss_magnetorquer import env as truss  # noqa: F401  (registers the tasks)
from magsail_mj.envs.core import (
    ActionController, AttitudeTask, RewardWeights, SimulationPhysics, list_tasks, load, register, run_episode,
    shipped_policy, summary_mismatches,
)

__all__ = ["load", "list", "shipped_policy", "run_episode", "summary_mismatches", "register", "ActionController",
           "AttitudeTask", "RewardWeights", "SimulationPhysics"]

list = list_tasks  # noqa: A001  (the issue's name: ``magsail_mj.envs.list()``)
