"""Scenario wiring: config → model, loads, controller, probes → summary, series and plots.

Each concept registers its config schema (:func:`magsail_mj.config.register_concept`) and its
task classes (:func:`magsail_mj.concepts.register_task`) or one builder (:func:`register_builder`,
kept here as the registry's :func:`magsail_mj.concepts.register_builder`; :data:`BUILDERS` is the
registry's dict). :func:`build_scenario` turns a validated config into a :class:`Scenario`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol

import mujoco
import numpy as np

from magsail_mj.concepts import BUILDERS, KIND_KEYS, TASKS, build_task, discover, register_builder
from magsail_mj.config import ConfigError
from magsail_mj.sim import RunResult, Simulation

__all__ = ["Scenario", "BUILDERS", "register_builder", "build_scenario", "has_compiled_loads"]


class Scenario(Protocol):
    """What :func:`magsail_mj.run.run_scenario` needs from a concept.

    ``spec``: the MjSpec (its XML is the model of record). ``simulation()`` builds the runner.
    ``postprocess(result)`` returns ``(summary, series)``: flat summary keys with SI units in
    their names, and derived time series (stored in the group ``series`` of the run's
    ``timeseries.zarr``). ``plots(run_dir, result, series)`` writes PNG files and returns their
    paths (a run may be asked for none: ``plots=False``). Optional: ``data_files(run_dir, result,
    series)`` writes the run's other derived files (JSON tables such as CNUSAIL's controller events)
    and returns their paths; it runs whether or not plots are drawn. ``render_info()`` goes to the
    manifest's ``render`` entry.
    """

    spec: mujoco.MjSpec

    def simulation(self) -> Simulation: ...

    def postprocess(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]: ...

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]: ...

    def render_info(self) -> dict[str, Any]: ...

    def manifest_extra(self) -> dict[str, Any]: ...


def build_scenario(cfg: Any) -> Scenario:
    """Build the scenario object of a validated config (:func:`magsail_mj.concepts.build_task`).

    Raises:
      ConfigError: ``sim.loads = "compiled"`` for a scenario whose task runs its loads in Python
        only (a task class declares ``compiled_loads = True`` when it has compiled loads).
    """
    if getattr(getattr(cfg, "sim", None), "loads", "python") == "compiled" and not has_compiled_loads(cfg):
        key = KIND_KEYS.get(cfg.concept, "scenario")
        raise ConfigError(
            [
                "sim.loads: compiled loads exist for the CNUSAIL attitude runs and the reflector's pitch "
                f"tracking only; {cfg.concept} "
                f"({key} {getattr(cfg, key, None)!r}) computes its loads in Python: use sim.loads = 'python', "
                "got 'compiled'"
            ]
        )
    return build_task(cfg)


def has_compiled_loads(cfg: Any) -> bool:
    """Whether the scenario of a validated config can run its loads compiled (``sim.loads =
    "compiled"``): its task class declares ``compiled_loads = True``."""
    discover()
    kind = getattr(cfg, KIND_KEYS.get(cfg.concept, "scenario"), None)
    return bool(getattr(TASKS.get((cfg.concept, kind)), "compiled_loads", False))
