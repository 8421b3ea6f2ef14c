"""``magsail_mj.load``: from a config to a simulation ready to reset, step, run and checkpoint.

    import magsail_mj
    sim = magsail_mj.load("magsail_mj/concepts/cnusail/configs/detumble_pre.toml", ["sim.duration_s=60"])
    sim.step(100)                # 100 physics steps (controller, loads and records as in run)
    state = sim.get_state()      # plain arrays and scalars
    result = sim.run()           # on to sim.duration_s
    summary, series = sim.scenario.postprocess(result)

The object returned is the scenario's runner with ``scenario`` (model builder, post-processing,
plots) and ``cfg`` (the validated config) attached, and ``identity`` set so that its checkpoints
refuse another config. Scenarios stepped in Python return a :class:`magsail_mj.sim.Simulation`
(``reset``, ``step``, ``run``, ``get_state``, ``set_state``, ``time``, ``model``, ``data``,
``records()``); the natively rolled-out MSAC cycle, the scenario-level searches (reflector cap
search, MSAC sweeps) and the lifetime analysis return runners with ``run()``.

To run a controller of your own, build a new simulation with it and its actuators through
:func:`magsail_mj.commands.attach` (``examples/custom_controller.py``); assigning
``sim.controller`` is not enough, because ``reset`` and ``set_state`` restore the controller the
simulation was built with.

Many worlds at once: with ``worlds`` and/or ``world_overrides`` (one list of ``key=value`` strings
per world, applied after ``overrides``), ``load`` returns a
:class:`magsail_mj.batch.BatchSimulation` — N runs of one compiled model stepped together, each
world equal to the single run of its own config (``reset``, ``step``, ``run``, ``get_state``,
``set_state`` over the batch; see :mod:`magsail_mj.batch` and ``docs/batch.md``)::

    sim = magsail_mj.load(config, ["sim.duration_s=600"], world_overrides=[["control.bdot_gain_Am2s_T=2e4"], []])
    result = sim.run()  # result.worlds[k]: world k's RunResult
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

from pydantic import BaseModel

from magsail_mj.batch import load_batch
from magsail_mj.checkpoint import run_identity
from magsail_mj.config import apply_overrides, load_config, numbers_hash, numbers_tree, parse_config
from magsail_mj.scenario import build_scenario

__all__ = ["load"]


def load(
    config: str | Path | BaseModel,
    overrides: list[str] | tuple[str, ...] = (),
    *,
    worlds: int | None = None,
    world_overrides: Sequence[Sequence[str]] | None = None,
    nthread: int = 1,
) -> Any:
    """Build the simulation of ``config`` (or, with ``worlds``/``world_overrides``, a batch of them).

    Args:
      config: a config file path, or a validated config (:func:`magsail_mj.config.load_config`).
      overrides: ``"key.path=value"`` strings, exactly as ``--set`` on the command line.
      worlds: build a batch of this many worlds (:func:`magsail_mj.batch.load_batch`).
      world_overrides: build a batch, world k with ``overrides`` and then ``world_overrides[k]``.
      nthread: threads stepping a batch's worlds (ignored for a single run).

    Raises:
      ConfigError: the config (with the overrides) is not valid, or a batch's worlds cannot run
        together (the key named); nothing is built.
    """
    if worlds is not None or world_overrides is not None:
        return load_batch(config, overrides, worlds=worlds, world_overrides=world_overrides, nthread=nthread)
    if isinstance(config, BaseModel):
        cfg = parse_config(apply_overrides(config.model_dump(mode="json"), list(overrides))) if overrides else config
    else:
        cfg = load_config(config, list(overrides))
    scenario = build_scenario(cfg)
    sim = scenario.simulation()
    sim.scenario, sim.cfg = scenario, cfg
    if hasattr(sim, "timing"):  # the field too: a simulation derived from this one (dataclasses.replace,
        # e.g. an environment's) builds its own timing from it
        sim.load_timing = sim.timing.mode = cfg.sim.load_timing
    if hasattr(sim, "identity"):
        sim.identity = run_identity(numbers_hash(cfg), numbers_tree(cfg))
    return sim
