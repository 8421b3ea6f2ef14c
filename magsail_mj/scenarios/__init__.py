"""Scenario wiring: config → model, loads, controller, probes → summary, series and plots.

Each concept module registers its config schema (:func:`magsail_mj.config.register_concept`)
and a builder in :data:`BUILDERS` that turns a validated config into a :class:`Scenario`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Protocol

import mujoco
import numpy as np

from magsail_mj.sim import RunResult, Simulation

__all__ = ["Scenario", "BUILDERS", "register_builder", "build_scenario"]


class Scenario(Protocol):
    """What :func:`magsail_mj.run.run_scenario` needs from a concept.

    ``spec``: the MjSpec (its XML is the model of record). ``simulation()`` builds the runner.
    ``postprocess(result)`` returns ``(summary, series)``: flat summary keys with SI units in
    their names, and extra time series to store in ``timeseries.npz``. ``plots(run_dir, result,
    series)`` writes PNG files and returns their paths. ``render_info()`` goes to the manifest's
    ``render`` entry.
    """

    spec: mujoco.MjSpec

    def simulation(self) -> Simulation: ...

    def postprocess(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]: ...

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]: ...

    def render_info(self) -> dict[str, Any]: ...

    def manifest_extra(self) -> dict[str, Any]: ...


BUILDERS: dict[str, Callable[[Any], Scenario]] = {}


def register_builder(concept: str) -> Callable[[Callable[[Any], Scenario]], Callable[[Any], Scenario]]:
    """Decorator registering the scenario builder of ``concept``."""

    def wrap(fn: Callable[[Any], Scenario]) -> Callable[[Any], Scenario]:
        BUILDERS[concept] = fn
        return fn

    return wrap


def build_scenario(cfg: Any) -> Scenario:
    """Build the scenario object of a validated config."""
    from magsail_mj.config import concept_models

    concept_models()  # imports the concept modules, which register their builders
    try:
        builder = BUILDERS[cfg.concept]
    except KeyError:
        raise ValueError(f"concept: no scenario builder for {cfg.concept!r}") from None
    return builder(cfg)
