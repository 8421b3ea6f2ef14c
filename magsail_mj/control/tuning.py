r"""Detumble-law tuning objective: the mean detumble time of a law over a set of initial conditions.

A vector ``x`` of law parameters in log10 space (``x_j = log10 p_j``, ``p_j`` the value of config
key ``keys[j]`` in its own unit) is scored by running every training condition as one world of a
batch (:func:`magsail_mj.load` with ``world_overrides``, :mod:`magsail_mj.batch`) with the shared
overrides (the horizon ``sim.duration_s``, the stop rule ``sim.stop_rate_deg_s`` /
``sim.stop_hold_s``, compiled loads) and ``keys[j] = p_j`` in every world. Each world's figures are
its scenario's own summary (``sim.worlds.scenario(k).postprocess``, what the world's run folder
holds as ``summary.json``; for the CNUSAIL detumble,
:func:`magsail_mj.concepts.cnusail.metrics.attitude_outputs`). The objective [s] is

    J(x) = (1/N) Σ_k T_k + w · (1/N) Σ_k E_k,

    T_k = t_0.3,k                                  if world k detumbled (the stop rule's hold met),
    T_k = t_end,k + P · ω̄_k / ω_stop               if it completed without detumbling,
    T_k = H + P · FAILED_RATE_RATIO                 if it did not complete (diverged, failed),

with ``t_0.3,k`` = ``detumble_time_below_0p3dps_s`` (the time after which ‖ω‖ stays below
0.3 °/s), ``t_end,k`` = ``t_end_s`` (the horizon H for a run the stop rule did not end), ``ω̄_k`` =
``rate_mean_last_orbit_rad_s`` (mean ‖ω‖ over the run's last orbit), ``ω_stop`` the stop rule's
rate [rad/s], ``P`` the penalty ``penalty_s`` [s] and ``E_k`` = ``mtq_dipole_effort_Am2s``
(∫‖m‖ dt [A m² s]) with the weight ``w`` = ``effort_weight_s_per_Am2s`` [s/(A m² s)] (0: time
only). A run that does not detumble within the horizon so counts more than the horizon, by P for
each multiple of ω_stop at which it still turns over its last orbit, which keeps the objective
graded where no world detumbles (a run that detumbled counts less than H − hold time). Every evaluation runs
the same worlds (common random numbers), so two parameter vectors are compared on the same
conditions.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from magsail_mj.api import load
from magsail_mj.config import load_config, read_toml
from magsail_mj.sweep.design import monte_carlo_points, toml_literal

__all__ = [
    "FAILED_RATE_RATIO",
    "FIGURE_KEYS",
    "Evaluation",
    "DetumbleObjective",
    "draw_conditions",
    "world_figures",
    "world_score_s",
]

FIGURE_KEYS = (
    "status",
    "t_end_s",
    "detumbled",
    "detumble_time_below_1p0dps_s",
    "detumble_time_below_0p3dps_s",
    "mtq_dipole_effort_Am2s",
    "rate_mean_last_orbit_rad_s",
)
"""The summary keys the objective reads (and reports) of every world."""

FAILED_RATE_RATIO = 10.0
"""ω̄/ω_stop counted for a world that did not complete (module docstring)."""


def draw_conditions(sweep_file: str | Path, *, samples: int, seed: int) -> list[list[str]]:
    """``samples`` initial conditions drawn from the ``[monte_carlo]`` table of ``sweep_file`` with
    ``seed`` in place of its own: world overrides (``key=value``), one list per condition. A draw
    depends on (seed, index, key) only (:func:`magsail_mj.sweep.design.monte_carlo_points`), so
    another seed gives conditions independent of the file's own.

    Raises:
      ValueError: the file has no ``[monte_carlo]`` table.
    """
    tree = read_toml(Path(sweep_file))
    if "monte_carlo" not in tree:
        raise ValueError(f"sweep_file: {sweep_file} has no [monte_carlo] table to draw conditions from")
    table = {**tree["monte_carlo"], "samples": samples, "seed": seed}
    return [list(p.overrides) for p in monte_carlo_points(table)]


def world_figures(
    config: str | Path, overrides: Sequence[str], conditions: Sequence[Sequence[str]]
) -> tuple[list[dict[str, Any]], float]:
    """Run ``conditions`` (world overrides, after the shared ``overrides``) as one batch of worlds
    on one thread and return each world's :data:`FIGURE_KEYS` of its scenario's summary, with the
    process time [s] of the build, run and post-processing."""
    cpu0 = time.process_time()
    sim = load(config, list(overrides), world_overrides=[list(c) for c in conditions], nthread=1)
    result = sim.run()
    figures = []
    for k, world in enumerate(result.worlds):
        if world.status == "completed":
            summary = sim.worlds.scenario(k).postprocess(world)[0]
            figures.append({key: summary[key] for key in FIGURE_KEYS})
        else:
            figures.append({"status": world.status, "t_end_s": world.t_end_s})
    return figures, time.process_time() - cpu0


def world_score_s(fig: dict[str, Any], *, horizon_s: float, stop_rate_rad_s: float, penalty_s: float) -> float:
    """``T_k`` [s] of one world's figures (module docstring)."""
    if fig["status"] != "completed":
        return horizon_s + penalty_s * FAILED_RATE_RATIO
    if fig["detumbled"]:
        return float(fig["detumble_time_below_0p3dps_s"])
    return float(fig["t_end_s"]) + penalty_s * float(fig["rate_mean_last_orbit_rad_s"]) / stop_rate_rad_s


@dataclass
class Evaluation:
    """One scored parameter vector: values by key, objective [s], mean time term [s], mean effort
    [A m² s] (completed worlds), detumbled worlds, process time [s]."""

    values: dict[str, float]
    score_s: float
    time_term_s: float
    effort_mean_Am2s: float
    detumbled: int
    worlds: int
    cpu_s: float


@dataclass
class DetumbleObjective:
    """``J(x)`` of the module docstring over fixed training conditions.

    Args:
      config: the base config (e.g. ``detumble_pre.toml``).
      overrides: shared by every world: the horizon ``sim.duration_s``, the stop rule
        (``sim.stop_rate_deg_s`` is required: ω_stop), ``sim.loads``, the law ``control.bdot_law``.
      conditions: one list of world overrides per training condition (:func:`draw_conditions`).
      keys: the tuned config keys, one per component of ``x`` (values ``10**x_j`` in the key's unit).
      penalty_s: P [s]; effort_weight_s_per_Am2s: w [s/(A m² s)].

    Calling it with ``x`` runs the batch, appends an :class:`Evaluation` to ``evaluations`` and
    returns ``J(x)`` [s].
    """

    config: str | Path
    overrides: Sequence[str]
    conditions: Sequence[Sequence[str]]
    keys: Sequence[str]
    penalty_s: float
    effort_weight_s_per_Am2s: float = 0.0
    evaluations: list[Evaluation] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not self.conditions:
            raise ValueError("conditions: need at least one training condition")
        if not self.keys:
            raise ValueError("keys: need at least one tuned config key")
        if not (math.isfinite(self.penalty_s) and self.penalty_s >= 0):
            raise ValueError(f"penalty_s: must be a finite number >= 0, got {self.penalty_s!r}")
        cfg = load_config(Path(self.config), [*self.overrides, *self.conditions[0]])
        if cfg.sim.stop_rate_deg_s is None:
            raise ValueError("overrides: set sim.stop_rate_deg_s (the objective's ω_stop)")
        self.horizon_s = float(cfg.sim.duration_s)
        self.stop_rate_rad_s = math.radians(cfg.sim.stop_rate_deg_s)

    def values(self, x: Sequence[float]) -> dict[str, float]:
        """The config values ``10**x_j`` by key, rounded to 12 significant digits (so that
        ``x_j = log10 3000`` gives 3000 exactly)."""
        if len(x) != len(self.keys):
            raise ValueError(f"x: {len(x)} components for {len(self.keys)} keys {list(self.keys)}")
        return {key: float(f"{10.0 ** float(xj):.12g}") for key, xj in zip(self.keys, x)}

    def figures(self, x: Sequence[float]) -> tuple[list[dict[str, Any]], float]:
        """Every training world's figures at ``x`` and the process time [s] (:func:`world_figures`)."""
        law = [f"{key}={toml_literal(value)}" for key, value in self.values(x).items()]
        return world_figures(self.config, [*self.overrides, *law], self.conditions)

    def score(self, figures: Sequence[dict[str, Any]]) -> tuple[float, float, float]:
        """``(J, mean T_k, mean E_k)`` [s, s, A m² s] of the worlds' figures."""
        times = [
            world_score_s(f, horizon_s=self.horizon_s, stop_rate_rad_s=self.stop_rate_rad_s, penalty_s=self.penalty_s)
            for f in figures
        ]
        efforts = [f["mtq_dipole_effort_Am2s"] for f in figures if f["status"] == "completed"]
        time_term = float(np.mean(times))
        effort = float(np.mean(efforts)) if efforts else math.inf
        weighted = self.effort_weight_s_per_Am2s * effort if self.effort_weight_s_per_Am2s else 0.0
        return time_term + weighted, time_term, effort

    def __call__(self, x: Sequence[float]) -> float:
        figures, cpu_s = self.figures(x)
        score, time_term, effort = self.score(figures)
        self.evaluations.append(
            Evaluation(
                values=self.values(x),
                score_s=score,
                time_term_s=time_term,
                effort_mean_Am2s=effort,
                detumbled=sum(bool(f.get("detumbled")) for f in figures),
                worlds=len(figures),
                cpu_s=cpu_s,
            )
        )
        return score
