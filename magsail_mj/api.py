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
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import BaseModel

from magsail_mj.checkpoint import run_identity
from magsail_mj.config import apply_overrides, load_config, numbers_hash, numbers_tree, parse_config
from magsail_mj.scenario import build_scenario

__all__ = ["load"]


def load(config: str | Path | BaseModel, overrides: list[str] | tuple[str, ...] = ()) -> Any:
    """Build the simulation of ``config``.

    Args:
      config: a config file path, or a validated config (:func:`magsail_mj.config.load_config`).
      overrides: ``"key.path=value"`` strings, exactly as ``--set`` on the command line.

    Raises:
      ConfigError: the config (with the overrides) is not valid; nothing is built.
    """
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
