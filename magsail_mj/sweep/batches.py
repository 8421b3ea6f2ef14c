"""The runs of a sweep grouped into batches: runs of one compiled model run as the worlds of one batch.

:func:`plan_batches` takes the runs a sweep call runs and returns its tasks, each a tuple of runs:
one run (a single run in its own process, as always) or up to ``batch_size`` runs that run as the
worlds of one :class:`~magsail_mj.batch.BatchSimulation` in one process
(:func:`magsail_mj.sweep.runner.supervise_batch`), each world into its own run folder with the
form and numbers of its single run (:func:`magsail_mj.batch.folders.run_batch_folders`).

Which runs share a batch is asked of the batch loader (:mod:`magsail_mj.batch.groups`): runs of
one config file whose configs the loader takes together — one concept with a batch, the keys every
world shares, one model's sizes. A run goes alone when its concept has no batch or the batch
refuses it (for CNUSAIL: the pointing laws, sensor noise), when its folder holds a single run's
checkpoint (``checkpoint.npz``) it may resume from, and with ``batch_size = 1``.

A batch that checkpointed (its worlds' ``sim.checkpoint_every_s``) leaves one checkpoint of the
whole batch in its first run's folder (:mod:`magsail_mj.batch.checkpoint`), naming its runs'
folders. When a later call plans runs of which such a file names a whole batch (every run in it
still to run, batchable, of one config file, no more than ``batch_size``), those runs are kept
together, in the file's order, so the batch resumes from the file
(:func:`magsail_mj.sweep.runner.run_batch`); the other runs are grouped as usual.

:func:`default_batch_size` chooses the size when none is given: the runs that can share batches
spread over the cores (every core gets a batch), at most :data:`DEFAULT_MAX_WORLDS` worlds and at
most what the memory of a core holds (:func:`magsail_mj.batch.groups.batch_bytes`); 1 when that
leaves fewer than :data:`MIN_WORLDS` worlds a batch, where a batch costs more per run than single
runs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from magsail_mj.batch.build import concept_batch
from magsail_mj.batch.checkpoint import BATCH_CHECKPOINT_NAME, checkpoint_folders
from magsail_mj.batch.groups import batch_bytes, group_worlds, world_key
from magsail_mj.config import ConfigError, load_config
from magsail_mj.sweep.common import SweepRun

__all__ = [
    "MAX_BATCH_SIZE",
    "DEFAULT_MAX_WORLDS",
    "MIN_WORLDS",
    "check_batch_size",
    "default_batch_size",
    "batchable_configs",
    "plan_batches",
    "checkpointed_batches",
]

MAX_BATCH_SIZE = 1024
"""The most worlds a batch of a sweep holds (``--batch-size``): beyond 256 worlds a world-step
costs no less (docs/batch.md), and every world holds its records and environment tables."""

DEFAULT_MAX_WORLDS = 64
"""The most worlds of a batch by default: at 64 worlds a world-step costs 1.5 bare ``mj_step``
on one thread against 1.17 at 256 (docs/batch.md, 0.12 against 0.09 of a single run's step),
while a lost batch loses fewer runs."""

MIN_WORLDS = 4
"""The fewest worlds a default batch has: a step's Python costs ≈ 1.2 ms whatever the worlds
(docs/batch.md: 1 178 µs a world-step at 1 world, 88 µs at 16), so below about 4 worlds a world-
step costs more than a single run's (329 µs)."""

CHECKPOINT_NAME = "checkpoint.npz"


def check_batch_size(value: Any) -> int | None:
    """``value`` when it is None (the default) or an integer from 1 to :data:`MAX_BATCH_SIZE`;
    ValueError naming ``--batch-size`` otherwise."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= MAX_BATCH_SIZE:
        raise ValueError(f"--batch-size: must be an integer from 1 to {MAX_BATCH_SIZE}, got {value!r}")
    return value


def batchable_configs(runs: Sequence[SweepRun]) -> dict[str, Any]:
    """The validated config of every run that a batch takes, by run id: its concept runs in a
    batch and its batch does not refuse the config alone (:func:`~magsail_mj.batch.groups.world_key`);
    a config that does not load now is left out (its run fails alone, as a single run)."""
    out = {}
    has_batch: dict[str, bool] = {}  # by concept: asked once
    for run in runs:
        if run.concept not in has_batch:
            try:
                has_batch[run.concept] = concept_batch(run.concept) is not None
            except ConfigError:
                has_batch[run.concept] = False
        if not has_batch[run.concept]:
            continue
        try:
            cfg = load_config(run.config, list(run.overrides))
        except (ConfigError, OSError):
            continue
        if not world_key(cfg)[1]:
            out[run.id] = cfg
    return out


def default_batch_size(cfgs: Sequence[Any], *, cores: int, memory_per_core_bytes: float) -> int:
    """The batch size for ``cfgs`` (the configs that may share batches) on ``cores`` cores of
    ``memory_per_core_bytes`` each (module docstring):
    ``min(DEFAULT_MAX_WORLDS, ⌈n / cores⌉, 1 + (m − b₁) / (b₂ − b₁))`` with ``n`` configs, ``m``
    the memory of a core and ``bₖ`` the largest :func:`~magsail_mj.batch.groups.batch_bytes` of
    ``k`` worlds; 1 below :data:`MIN_WORLDS`."""
    if not cfgs:
        return 1
    size = min(DEFAULT_MAX_WORLDS, math.ceil(len(cfgs) / max(1, int(cores))))
    first = max(batch_bytes(cfg, 1) for cfg in cfgs)
    world = max(batch_bytes(cfg, 2) - batch_bytes(cfg, 1) for cfg in cfgs)
    if world > 0:
        size = min(size, 1 + int(max(0.0, float(memory_per_core_bytes) - first) // world))
    return size if size >= MIN_WORLDS else 1


def plan_batches(
    runs: Sequence[SweepRun],
    out: Path,
    *,
    batch_size: int | None,
    cores: int,
    memory_per_core_bytes: float,
    resume: bool = True,
) -> tuple[list[tuple[SweepRun, ...]], int]:
    """The tasks of ``runs`` (module docstring) in the runs' order, and the batch size used
    (``batch_size``, or :func:`default_batch_size` when None).

    ``resume``: a run whose folder under ``out`` holds a single run's checkpoint goes alone (it
    may resume), and the batches a batch checkpoint names are kept together (module docstring).
    """
    size = check_batch_size(batch_size)
    if size == 1:
        return [(run,) for run in runs], 1
    candidates = [r for r in runs if not (resume and (out / r.id / CHECKPOINT_NAME).is_file())]
    cfgs = batchable_configs(candidates)
    if size is None:
        size = default_batch_size(list(cfgs.values()), cores=cores, memory_per_core_bytes=memory_per_core_bytes)
    position = {run.id: n for n, run in enumerate(runs)}
    tasks: list[tuple[SweepRun, ...]] = [(run,) for run in runs if run.id not in cfgs or size == 1]
    if size > 1:
        kept = checkpointed_batches(runs, out, batchable=set(cfgs), max_worlds=size) if resume else []
        tasks.extend(kept)
        taken = {run.id for task in kept for run in task}
        by_config: dict[Path, list[SweepRun]] = {}
        for run in runs:
            if run.id in cfgs and run.id not in taken:
                by_config.setdefault(Path(run.config), []).append(run)
        for members in by_config.values():
            groups = group_worlds([cfgs[r.id] for r in members], max_worlds=size)
            tasks.extend(tuple(members[i] for i in group) for group in groups)
    return sorted(tasks, key=lambda task: position[task[0].id]), size


def checkpointed_batches(
    runs: Sequence[SweepRun], out: Path, *, batchable: set[str], max_worlds: int
) -> list[tuple[SweepRun, ...]]:
    """The batches of ``runs`` that a batch checkpoint in a run's folder under ``out`` names, in the
    file's order: every run it names is one of ``runs``, in ``batchable``, of the first one's config
    file, and in no batch found before; at most ``max_worlds`` runs (module docstring)."""
    by_id = {run.id: run for run in runs}
    used: set[str] = set()
    kept: list[tuple[SweepRun, ...]] = []
    for run in runs:
        if run.id not in batchable or run.id in used:
            continue
        found = checkpoint_folders(out / run.id / BATCH_CHECKPOINT_NAME)
        if found is None or not 1 < len(found[0]) <= max_worlds or found[0][0] != run.id:
            continue
        members = [by_id.get(name) for name in found[0]]
        if len(set(found[0])) == len(members) and all(
            m is not None and m.id in batchable and m.id not in used and Path(m.config) == Path(run.config)
            for m in members
        ):
            kept.append(tuple(members))
            used.update(found[0])
    return kept
