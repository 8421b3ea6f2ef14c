r"""The worlds of a batch: each world's config, and what may and may not differ between them.

World k's config is exactly the config a single run of it would use: the config file (or validated
config) with the shared ``overrides`` and then the world's own ``world_overrides[k]`` (``key=value``
strings as ``--set``), validated by the concept's schema (:func:`world_configs`). Each world's
problems are reported together, every line prefixed ``world k:``.

:func:`check_batchable` then refuses, naming the world, the key path and the values, what one batch
cannot run:

* what the concept's batch does not run (its ``refusals(cfgs)``; for CNUSAIL: the pointing laws,
  sensor noise, the sub-stepped armature model), and compiled loads (``sim.loads = "compiled"``)
  for a concept whose batch module does not declare ``COMPILED_LOADS = True``;
* a key that differs between worlds but must be shared (:data:`LOCKSTEP_KEYS` and the concept's
  own ``LOCKSTEP_KEYS``: the batch steps every world with one time step and integrator to one end
  time, records them on one schedule, and the concept's controller schedule, facet layout and
  environment grid are shared).

A key that changes the compiled model's sizes (e.g. ``spacecraft.configuration`` adds the sail's
bodies, ``render.markers`` the marker bodies) is refused when the models are compared
(:func:`size_changing_keys` names it): a batch runs one model, whose per-world values may differ
but whose sizes may not.

Everything else may differ per world, and the concept's batch reads it per world (for CNUSAIL:
initial state, epoch and orbit, environment models, gains, masses and inertias through the
compiled model's fields, :mod:`magsail_mj.batch.models`, geometry that keeps the sizes, dipole and
wheel limits, disturbance parameters).
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any, Callable, Sequence

from pydantic import BaseModel

from magsail_mj.config import ConfigError, apply_overrides, load_config, parse_config

__all__ = [
    "world_configs",
    "check_batchable",
    "differing_keys",
    "size_changing_keys",
    "atmosphere_mix_problems",
    "LOCKSTEP_KEYS",
    "IGNORED_KEYS",
]

LOCKSTEP_KEYS: dict[str, str] = {
    "concept": "a batch runs one concept",
    "kind": "a batch runs one scenario kind",
    "scenario": "a batch runs one compiled model, named after the scenario",
    "sim.timestep_s": "the batch steps every world with one time step",
    "sim.duration_s": "the batch steps every world to one end time",
    "sim.record_every": "the batch records every world on one schedule",
    "sim.load_timing": "the batch evaluates every world's loads at one instant of the step",
    "sim.integrator": "the batch integrates every world with one integrator",
    "sim.loads": "the batch steps every world's loads one way (NumPy between steps, or compiled into the step)",
}
"""Keys that must be the same in every world of a batch, with the reason."""

IGNORED_KEYS = ("description", "sim.progress", "sim.checkpoint_every_s")
"""Keys that may differ freely (they change no number of a batch run; the batch checkpoints at the
smallest positive ``sim.checkpoint_every_s`` of its worlds, :func:`magsail_mj.batch.folders.checkpoint_interval_s`)."""


def _config(config: str | Path | BaseModel, overrides: list[str]) -> BaseModel:
    """The validated config with ``overrides``, exactly as :func:`magsail_mj.load` makes it."""
    if isinstance(config, BaseModel):
        return parse_config(apply_overrides(config.model_dump(mode="json"), overrides)) if overrides else config
    return load_config(config, overrides)


def world_configs(
    config: str | Path | BaseModel,
    overrides: Sequence[str] = (),
    *,
    worlds: int | None = None,
    world_overrides: Sequence[Sequence[str]] | None = None,
) -> list[BaseModel]:
    """Each world's validated config (module docstring).

    Args:
      config: a config file path, or a validated config.
      overrides: ``key=value`` strings applied to every world.
      worlds: the number of worlds (default: one per entry of ``world_overrides``).
      world_overrides: per world, a list of ``key=value`` strings applied after ``overrides``.

    Raises:
      ValueError: ``worlds`` or ``world_overrides`` malformed (named).
      ConfigError: a world's config is invalid (every world's problems, prefixed ``world k:``).
    """
    if world_overrides is not None:
        if isinstance(world_overrides, (str, bytes)) or not all(
            isinstance(w, (list, tuple)) and all(isinstance(s, str) for s in w) for w in world_overrides
        ):
            raise ValueError("world_overrides: must be a list of lists of 'key=value' strings, one list per world")
        world_overrides = [list(w) for w in world_overrides]
    if worlds is not None:
        if isinstance(worlds, bool) or not isinstance(worlds, int) or worlds < 1:
            raise ValueError(f"worlds: must be an integer >= 1, got {worlds!r}")
        if world_overrides is not None and len(world_overrides) != worlds:
            raise ValueError(f"world_overrides: {len(world_overrides)} lists for worlds = {worlds}")
    if world_overrides is None:
        if worlds is None:
            raise ValueError("worlds: give the number of worlds or world_overrides (one list per world)")
        world_overrides = [[] for _ in range(worlds)]
    if not world_overrides:
        raise ValueError("world_overrides: needs at least one world")
    shared = list(overrides)
    cfgs: list[BaseModel] = []
    problems: list[str] = []
    for k, extra in enumerate(world_overrides):
        try:
            cfgs.append(_config(config, [*shared, *extra]))
        except ConfigError as err:
            problems += [f"world {k}: {line}" for line in err.problems]
    if problems:
        raise ConfigError(problems)
    return cfgs


def _flat(tree: Any, prefix: str = "") -> dict[str, Any]:
    """``{"a.b.c": value}`` of a nested dict (lists are values)."""
    if not isinstance(tree, dict):
        return {prefix: tree}
    out: dict[str, Any] = {}
    for key, value in tree.items():
        out.update(_flat(value, f"{prefix}.{key}" if prefix else str(key)))
    return out


def differing_keys(a: BaseModel | dict[str, Any], b: BaseModel) -> dict[str, tuple[Any, Any]]:
    """``{key path: (value in a, value in b)}`` of the keys where the validated configs ``a`` and
    ``b`` differ (all but :data:`IGNORED_KEYS`); ``a`` may be given as its flat key → value dict."""
    fa = a if isinstance(a, dict) else _flat(a.model_dump(mode="json"))
    fb = _flat(b.model_dump(mode="json"))
    keys = sorted((set(fa) | set(fb)) - set(IGNORED_KEYS))
    return {k: (fa.get(k), fb.get(k)) for k in keys if fa.get(k) != fb.get(k)}


def check_batchable(cfgs: Sequence[BaseModel], concept: Any) -> None:
    """Refuse what one batch cannot run (module docstring) — every problem of every world at once.

    Args:
      cfgs: each world's validated config.
      concept: the concept's batch module (its ``LOCKSTEP_KEYS`` and ``refusals(cfgs)``).

    Raises:
      ConfigError: naming the world, the key path and the values.
    """
    problems = list(concept.refusals(cfgs))
    for k, cfg in enumerate(cfgs):
        if getattr(getattr(cfg, "sim", None), "loads", "python") == "compiled" and not getattr(
            concept, "COMPILED_LOADS", False
        ):
            problems.append(
                f"world {k}: sim.loads: the batch of concept {cfg.concept!r} computes its worlds' loads "
                "vectorised in NumPy; its compiled loads run in a single run only, got 'compiled'"
            )
    lockstep = {**LOCKSTEP_KEYS, **concept.LOCKSTEP_KEYS}
    base = _flat(cfgs[0].model_dump(mode="json"))
    for k, cfg in enumerate(cfgs[1:], start=1):
        for key, (v0, vk) in differing_keys(base, cfg).items():
            if key in lockstep:
                problems.append(
                    f"world {k}: {key}: must be the same in every world of a batch ({lockstep[key]}); "
                    f"world 0 has {v0!r}, got {vk!r}"
                )
    if problems:
        raise ConfigError(problems)


def atmosphere_mix_problems(first: Any, cfg: Any, *, where: str) -> list[str]:
    """The refusal (as a one-item list, else empty) of a world whose ``atmosphere.model`` mixes
    ``"msis"`` with another model against world 0's ``first``: the two give environment tables with
    different channels, which a batch's one environment stack cannot hold."""
    base, model = first.atmosphere.model, cfg.atmosphere.model
    if (base == "msis") == (model == "msis"):
        return []
    return [
        f"{where}atmosphere.model: 'msis' and the other models cannot be mixed in one batch (their "
        f"environment tables have different channels); world 0 has {base!r}, got {model!r}"
    ]


def _with_key(cfg: BaseModel, key: str, value: Any) -> BaseModel:
    """``cfg`` with one key path set to ``value`` (validated)."""
    tree = copy.deepcopy(cfg.model_dump(mode="json"))
    node = tree
    *parents, last = key.split(".")
    for part in parents:
        node = node.setdefault(part, {})
    node[last] = value
    return parse_config(tree)


def size_changing_keys(
    base: BaseModel, other: BaseModel, sizes: Callable[[BaseModel], dict[str, int]]
) -> list[tuple[str, Any, Any]]:
    """The keys of ``other`` that change the compiled model's sizes from ``base``'s: each differing
    key is set alone in ``base`` and the model compiled (``sizes(cfg)``: the model's size counts);
    those that change a size (or cannot be set alone) are returned as ``(key, base value, other
    value)``. When no key does alone, all differing keys are returned (they do it together)."""
    ref = sizes(base)
    diff = differing_keys(base, other)
    found = []
    for key, (v0, vk) in diff.items():
        try:
            changed = sizes(_with_key(base, key, vk)) != ref
        except (ConfigError, ValueError):
            changed = True
        if changed:
            found.append((key, v0, vk))
    return found or [(key, v0, vk) for key, (v0, vk) in diff.items()]
