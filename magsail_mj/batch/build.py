r"""``load_batch``: from a config and per-world overrides to a batch ready to reset, step and run.

A concept runs in a batch when its package has a ``batch`` module (found through
:func:`magsail_mj.concepts.concept_modules`, as the environments' ``env`` modules are), holding

* ``LOCKSTEP_KEYS`` — its keys that every world must share, with the reason;
* ``refusals(cfgs)`` — problem lines for what its batch does not run;
* ``build_worlds(cfgs)`` — every world built as its single run builds it, an object with
  ``models`` (the distinct compiled models, world 0's first), ``world_model`` (each world's index
  in it), ``compile_model(cfg)``, ``init_state(k, data)``, ``plant()`` (the
  :class:`~magsail_mj.batch.runner.Plant` over the world axis) and ``scenario(k)`` (world k's task,
  for its run folder); with ``caller_models`` true, each world runs on its own model
  ``models[world_model[k]]`` (:meth:`mujoco.batch.Batch.set_models`: models that differ in fields
  the batch cannot expand economically, such as the custom numerics of compiled loads) instead of
  world 0's with expanded fields.
* ``COMPILED_LOADS`` (optional, default false) — its batch runs ``sim.loads = "compiled"``.
* ``compile_model(cfg)`` (optional) — the compiled model of one config, whose sizes group configs
  into batches before anything is built (:mod:`magsail_mj.batch.groups`).
  Its worlds object may also have ``stop_rule()`` — the worlds' stop rules
  (:class:`~magsail_mj.batch.runner.HoldBelowWorlds`, or ``None`` when no world has one).

Steps: each world's config (:func:`~magsail_mj.batch.worlds.world_configs`); what one batch cannot
run refused by name (:func:`~magsail_mj.batch.worlds.check_batchable`); the worlds built; every
distinct compiled model checked to have world 0's sizes (else the keys that change them are named,
:func:`~magsail_mj.batch.worlds.size_changing_keys`); the :class:`mujoco.batch.Batch` of world 0's
model with MuJoCo's automatic reset off and every world's differing model fields expanded
(:func:`~magsail_mj.batch.models.expand_worlds`), or each world's own model set; each world's
initial state written as its single run writes it (into an ``MjData`` of its own model, read back
as the integration state).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import mujoco
import numpy as np
from mujoco.batch import Batch
from pydantic import BaseModel

from magsail_mj.batch.models import expand_worlds, model_sizes
from magsail_mj.batch.runner import BatchSimulation
from magsail_mj.batch.worlds import check_batchable, size_changing_keys, world_configs
from magsail_mj.checkpoint import run_identity
from magsail_mj.concepts import concept_modules
from magsail_mj.config import ConfigError, numbers_hash, numbers_tree
from magsail_mj.divergence import disable_autoreset, route_mujoco_warnings

__all__ = ["load_batch", "concept_batch"]

_STATE = mujoco.mjtState.mjSTATE_INTEGRATION


#: the most threads a batch starts (each is an OS thread with its own MjData)
MAX_THREADS = 256


def concept_batch(concept: str) -> Any:
    """The ``batch`` module of ``concept``.

    Raises:
      ConfigError: the concept has none (naming the concepts that have one)."""
    found = concept_modules("batch")
    if concept not in found:
        raise ConfigError(
            [f"concept: the batch runs {', '.join(sorted(found)) or 'no concept'} only (for now), got {concept!r}"]
        )
    return found[concept]


def _size_problems(worlds: Any, cfgs: list[BaseModel]) -> list[str]:
    """Problem lines for the worlds whose compiled model's sizes differ from world 0's."""
    base = model_sizes(worlds.models[0])
    out = []
    for j, model in enumerate(worlds.models[1:], start=1):
        sizes = model_sizes(model)
        if sizes == base:
            continue
        k = int(np.flatnonzero(worlds.world_model == j)[0])
        changed = ", ".join(f"{n} {base[n]} → {sizes[n]}" for n in sorted(sizes) if sizes[n] != base.get(n))
        for key, v0, vk in size_changing_keys(cfgs[0], cfgs[k], lambda c: model_sizes(worlds.compile_model(c))):
            out.append(
                f"world {k}: {key}: changes the sizes of the compiled model ({changed}); a batch runs one "
                f"model, so every world must have world 0's value {v0!r}, got {vk!r}"
            )
    return out


def load_batch(
    config: str | Path | BaseModel,
    overrides: Sequence[str] = (),
    *,
    worlds: int | None = None,
    world_overrides: Sequence[Sequence[str]] | None = None,
    nthread: int = 1,
) -> BatchSimulation:
    """Build a batch of worlds of ``config`` (module docstring).

    Args:
      config: a config file path, or a validated config.
      overrides: ``key=value`` strings applied to every world (as ``--set``).
      worlds: the number of worlds (default: one per list of ``world_overrides``).
      world_overrides: per world, ``key=value`` strings applied after ``overrides``.
      nthread: threads stepping the worlds (1: the caller's only; the numbers are the same bit
        for bit at any count).

    Raises:
      ValueError: malformed ``worlds``, ``world_overrides`` or ``nthread`` (named).
      ConfigError: a world's config is invalid, asks what the batch does not run, or differs from
        world 0 in a key that must be shared or that changes the model's sizes (each named).
    """
    if isinstance(nthread, bool) or not isinstance(nthread, int) or not 1 <= nthread <= MAX_THREADS:
        raise ValueError(f"nthread: must be an integer from 1 to {MAX_THREADS}, got {nthread!r}")
    cfgs = world_configs(config, overrides, worlds=worlds, world_overrides=world_overrides)
    concept = concept_batch(cfgs[0].concept)
    check_batchable(cfgs, concept)
    built = concept.build_worlds(cfgs)
    problems = _size_problems(built, cfgs)
    if problems:
        raise ConfigError(problems)
    models = built.models
    route_mujoco_warnings()
    for model in models:
        disable_autoreset(model)
    batch = Batch(models[0], len(cfgs), nthread)
    if getattr(built, "caller_models", False):
        batch.set_models([models[int(j)] for j in built.world_model])
    else:
        try:
            expand_worlds(batch, models, built.world_model)
        except ValueError as err:
            raise ConfigError([f"the worlds' models: {err}"]) from None
    nstate = mujoco.mj_stateSize(models[0], _STATE)
    if batch.nstate != nstate:  # pragma: no cover - MuJoCo's batch rows are the integration state
        raise RuntimeError(f"the batch's state rows hold {batch.nstate} numbers, mjSTATE_INTEGRATION {nstate}")
    initial = np.empty((len(cfgs), nstate))
    for k in range(len(cfgs)):
        model = models[int(built.world_model[k])]
        data = mujoco.MjData(model)
        built.init_state(k, data)
        mujoco.mj_getState(model, data, initial[k], _STATE)
    sim = BatchSimulation(
        batch=batch,
        plant=built.plant(),
        duration_s=cfgs[0].sim.duration_s,
        record_every=cfgs[0].sim.record_every,
        initial_state=initial,
        stop_rule=built.stop_rule() if hasattr(built, "stop_rule") else None,
    )
    sim.cfgs = list(cfgs)
    sim.worlds = built
    versions = run_identity(None)["versions"]  # read once: a package-metadata lookup costs ≈ 0.1 s
    sim.identities = [
        {"numbers_hash": numbers_hash(cfg), "versions": dict(versions), "numbers_config": numbers_tree(cfg)}
        for cfg in cfgs
    ]
    return sim
