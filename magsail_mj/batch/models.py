r"""The compiled model of a batch and its per-world values.

A batch runs world 0's compiled model (:class:`mujoco.batch.Batch` copies it). Every other world's
compiled model must have the same sizes (:func:`model_sizes`: every count of
:class:`mujoco.MjModel`, so that one ``MjData`` layout serves all); :func:`expand_worlds` then
compares it with world 0's field by field and writes every field that differs — masses,
inertias, geometry, and the constants the compiler derived from them (``body_subtreemass``,
``dof_invweight0``, ``actuator_acc0`` …) — into the batch's per-world copy
(:meth:`mujoco.batch.Batch.expand`). A world's model in the batch is then its own compiled model in
every field, so it steps exactly as its single run.
"""

from __future__ import annotations

import mujoco
import numpy as np
from mujoco.batch import MODEL_FIELDS, Batch

__all__ = ["model_sizes", "differing_fields", "expand_worlds"]


def model_sizes(model: mujoco.MjModel) -> dict[str, int]:
    """Every size count of ``model`` (its integer attributes ``n…``: ``nq``, ``nbody``, ``ngeom`` …)."""
    return {
        name: int(getattr(model, name))
        for name in dir(model)
        if name.startswith("n") and isinstance(getattr(model, name), int) and not isinstance(getattr(model, name), bool)
    }


def _value(model: mujoco.MjModel, name: str) -> np.ndarray:
    if name.startswith("opt."):
        return np.asarray(getattr(model.opt, name[4:]))
    return np.asarray(getattr(model, name))


def differing_fields(base: mujoco.MjModel, other: mujoco.MjModel) -> tuple[list[str], list[str]]:
    """``(expandable, fixed)``: the array fields (and ``opt.*`` options) of ``other`` whose bytes
    differ from ``base``'s, split into those a batch can hold per world (:data:`MODEL_FIELDS`) and
    those it cannot."""
    names = {n for n in dir(base) if not n.startswith("_") and isinstance(getattr(base, n, None), np.ndarray)}
    names |= {n for n in MODEL_FIELDS if n.startswith("opt.")}
    expandable, fixed = [], []
    for name in sorted(names):
        a, b = _value(base, name), _value(other, name)
        if a.shape != b.shape or a.dtype != b.dtype or a.tobytes() != b.tobytes():
            (expandable if name in MODEL_FIELDS else fixed).append(name)
    return expandable, fixed


def expand_worlds(batch: Batch, models: list[mujoco.MjModel], world_model: np.ndarray) -> list[str]:
    """Give each world of ``batch`` (built on ``models[0]``) the fields of its own model
    ``models[world_model[k]]`` that differ from ``models[0]``; return the expanded field names.

    Raises:
      ValueError: a model differs from ``models[0]`` in a field a batch cannot hold per world
        (naming the fields).
    """
    base = models[0]
    done: set[str] = set()
    for j, model in enumerate(models[1:], start=1):
        rows = np.flatnonzero(np.asarray(world_model) == j)
        if not rows.size:
            continue
        expandable, fixed = differing_fields(base, model)
        if fixed:
            raise ValueError(f"models[{j}]: differs from world 0's model in fields a batch shares: {', '.join(fixed)}")
        for name in expandable:
            values = batch.expand(name)
            values[rows] = _value(model, name)
            done.add(name)
    return sorted(done)
