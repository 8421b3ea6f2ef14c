r"""Which configs may run as the worlds of one batch, asked of the batch loader before anything runs.

A sweep holds many configs and runs those of one compiled model as the worlds of batches
(:mod:`magsail_mj.sweep.batches`). It asks here, never naming a concept:

* :func:`world_key` — a config alone: the problems that keep it out of every batch (its concept
  has no ``batch`` module, :func:`~magsail_mj.batch.build.concept_batch`; the concept's batch
  refuses it, its ``refusals([cfg])``: for CNUSAIL the pointing laws, sensor noise, the sub-stepped
  armature), or else its key: the concept, the values of every key the worlds of a batch share
  (:data:`~magsail_mj.batch.worlds.LOCKSTEP_KEYS` and the concept's ``LOCKSTEP_KEYS``) and the
  sizes of its compiled model (the concept's ``compile_model(cfg)``,
  :func:`~magsail_mj.batch.models.model_sizes`). Configs of equal keys share those keys and one
  model's sizes.
* :func:`group_worlds` — configs of equal keys, in batches of at most ``max_worlds`` worlds (the
  fewest batches, as equal in size as they can be, in the configs' order). A refusal between
  worlds that is not a shared key (CNUSAIL: the MSIS atmosphere beside another model) is found by
  the loader's own :func:`~magsail_mj.batch.worlds.check_batchable` of the config with the
  candidate batch's world 0: the config goes to the first batch whose world 0 accepts it. Every
  batch is checked whole once more; one refused whole runs as single worlds.
* :func:`batch_bytes` — the memory estimate of a batch of ``worlds`` worlds of a config.

A config that the loader later refuses anyway (a concept without ``compile_model`` whose worlds
differ in size) is refused by :func:`~magsail_mj.batch.load_batch` by name, as always.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence

from pydantic import BaseModel

from magsail_mj.batch.build import concept_batch
from magsail_mj.batch.models import model_sizes
from magsail_mj.batch.worlds import LOCKSTEP_KEYS, _flat, check_batchable
from magsail_mj.config import ConfigError
from magsail_mj.resources import ENVIRONMENT_ROW_BYTES, environment_bytes, estimate_run_bytes

__all__ = ["world_key", "group_worlds", "batch_bytes", "WORLD_BYTES", "ENVIRONMENT_TABLE_ROW_BYTES"]

#: memory of a world of a batch beyond the first, besides its environment tables [bytes]: its
#: recorder's buffered records, its model's per-world fields, its controller and loads. Measured
#: peak RSS of CNUSAIL detumble batches written to run folders (distinct epochs, 600 s): 314 MB
#: for 1 world, 365 MB for 8, 400 MB for 32 — 7.4 MB a world beyond the first at 8 worlds, 2.7 MB
#: at 32 (the first world's post-processing is most of the peak); 4 MiB with the tables below
#: keeps every measured batch below :func:`batch_bytes`
WORLD_BYTES = 4.0 * 2**20
#: bytes per row of a world's environment tables kept through the run (≈ 0.7 MB for three orbits
#: at the 10 s grid, 1 735 rows: 400 B a row, docs/batch.md), rounded up; the precompute's
#: temporaries (:data:`magsail_mj.resources.ENVIRONMENT_ROW_BYTES`) are one world's at a time
ENVIRONMENT_TABLE_ROW_BYTES = 1024.0


def world_key(cfg: BaseModel) -> tuple[str, list[str]]:
    """``(key, problems)`` of a validated config (module docstring): ``problems`` name what keeps
    it out of every batch (then ``key`` is empty); configs of equal ``key`` share every key a batch
    shares and the sizes of one compiled model."""
    try:
        concept = concept_batch(cfg.concept)
    except ConfigError as err:
        return "", list(err.problems)
    problems = list(concept.refusals([cfg]))
    if problems:
        return "", problems
    flat = _flat(cfg.model_dump(mode="json"))
    shared = {key: flat.get(key) for key in sorted({*LOCKSTEP_KEYS, *concept.LOCKSTEP_KEYS})}
    compile_model = getattr(concept, "compile_model", None)
    sizes = model_sizes(compile_model(cfg)) if compile_model is not None else {}
    return json.dumps([cfg.concept, shared, sizes], sort_keys=True, default=str), []


def _accepts(first: BaseModel, cfg: BaseModel) -> bool:
    """True when the batch loader takes ``cfg`` as a world beside ``first`` (its world 0)."""
    try:
        check_batchable([first, cfg], concept_batch(first.concept))
    except ConfigError:
        return False
    return True


def _chunks(members: list[int], max_worlds: int) -> list[list[int]]:
    """``members`` in the fewest consecutive chunks of at most ``max_worlds``, sizes differing by one at most."""
    n = math.ceil(len(members) / max_worlds)
    size, extra = divmod(len(members), n)
    out, start = [], 0
    for j in range(n):
        stop = start + size + (1 if j < extra else 0)
        out.append(members[start:stop])
        start = stop
    return out


def group_worlds(cfgs: Sequence[BaseModel], *, max_worlds: int) -> list[list[int]]:
    """The configs' indices in batches (module docstring): each list is one batch's worlds, in the
    configs' order; a config no batch takes, and ``max_worlds = 1``, give lists of one.

    Raises:
      ValueError: ``max_worlds`` is not an integer >= 1.
    """
    if isinstance(max_worlds, bool) or not isinstance(max_worlds, int) or max_worlds < 1:
        raise ValueError(f"max_worlds: must be an integer >= 1, got {max_worlds!r}")
    if max_worlds == 1:
        return [[i] for i in range(len(cfgs))]
    sets: dict[str, list[list[int]]] = {}  # per key: the sets of worlds one batch may hold
    order: list[tuple[str, int] | int] = []
    for i, cfg in enumerate(cfgs):
        key, problems = world_key(cfg)
        if problems:
            order.append(i)
            continue
        candidates = sets.setdefault(key, [])
        for members in candidates:
            if _accepts(cfgs[members[0]], cfg):
                members.append(i)
                break
        else:
            candidates.append([i])
            order.append((key, len(candidates) - 1))
    groups: list[list[int]] = []
    for entry in order:
        if isinstance(entry, int):
            groups.append([entry])
            continue
        for chunk in _chunks(sets[entry[0]][entry[1]], max_worlds):
            try:
                check_batchable([cfgs[i] for i in chunk], concept_batch(cfgs[chunk[0]].concept))
            except ConfigError:
                groups.extend([i] for i in chunk)
            else:
                groups.append(chunk)
    return sorted(groups, key=lambda g: g[0])


def batch_bytes(cfg: BaseModel, worlds: int) -> float:
    """Memory a batch of ``worlds`` worlds of ``cfg`` (or of configs like it) needs [bytes]: one
    world as its single run (:func:`~magsail_mj.resources.estimate_run_bytes`: model, records,
    post-processing — the worlds' folders are written one after another) plus, for every further
    world, its environment tables (``(duration + 2h) / h`` rows of
    :data:`ENVIRONMENT_TABLE_ROW_BYTES`, ``h = field.sample_step_s``, each world its own) and
    :data:`WORLD_BYTES`."""
    if isinstance(worlds, bool) or not isinstance(worlds, int) or worlds < 1:
        raise ValueError(f"worlds: must be an integer >= 1, got {worlds!r}")
    rows = environment_bytes(cfg) / ENVIRONMENT_ROW_BYTES
    return estimate_run_bytes(cfg) + (worlds - 1) * (rows * ENVIRONMENT_TABLE_ROW_BYTES + WORLD_BYTES)
