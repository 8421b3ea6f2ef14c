"""dm_control environments of the shipped attitude scenarios (see :mod:`magsail_mj.envs.core`).

    from magsail_mj import envs
    env = envs.load("truss/detumble", ["lattice.units=3", "sim.duration_s=20"], random=0)
    time_step = env.reset()
    while not time_step.last():
        time_step = env.step(policy(time_step))

:func:`load` returns a ``dm_control.rl.control.Environment``; :func:`list` names the tasks;
:func:`shipped_policy` runs a scenario's own controller through its environment.

The tasks come from the concepts: every concept package with an ``env`` module registers its
tasks when that module is imported, and :func:`magsail_mj.concepts.concept_modules` imports them
all here, so this package names no concept. Each such module is also an attribute of this
package under its concept's name and under the domain of its task names (the part before
``/``: ``envs.truss`` is :mod:`magsail_mj.concepts.truss_magnetorquer.env`).
"""

from __future__ import annotations

from types import ModuleType

from magsail_mj.concepts import concept_modules
from magsail_mj.envs.core import (
    ActionController,
    AttitudeTask,
    RewardWeights,
    SimulationPhysics,
    list_tasks,
    load,
    register,
    run_episode,
    shipped_policy,
    summary_mismatches,
    task_entry,
)

__all__ = [
    "load",
    "list",
    "shipped_policy",
    "run_episode",
    "summary_mismatches",
    "register",
    "ActionController",
    "AttitudeTask",
    "RewardWeights",
    "SimulationPhysics",
]

list = list_tasks  # noqa: A001  (the public name: ``magsail_mj.envs.list()``)

ENV_MODULES: dict[str, ModuleType] = concept_modules("env")
"""Concept name → its ``env`` module (imported: its tasks are registered)."""


def env_module(name: str) -> ModuleType:
    """The ``env`` module of a concept (``"truss_magnetorquer"``) or of a task domain (``"truss"``,
    the part of a task name before ``/``); ``AttributeError`` naming ``name`` when there is none."""
    if name in ENV_MODULES:
        return ENV_MODULES[name]
    by_module = {m.__name__: m for m in ENV_MODULES.values()}
    for task in list_tasks():
        module = by_module.get(task_entry(task).factory.__module__)
        if task.partition("/")[0] == name and module is not None:
            return module
    raise AttributeError(
        f"module 'magsail_mj.envs' has no attribute {name!r} (no concept or task domain of "
        f"that name: tasks {', '.join(list_tasks())})"
    )


def __getattr__(name: str) -> ModuleType:
    """``envs.<concept>`` and ``envs.<task domain>``: the concept's ``env`` module (PEP 562)."""
    if name.startswith("__"):
        raise AttributeError(name)
    return env_module(name)
