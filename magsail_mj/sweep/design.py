"""Run designs of a sweep file: ``[grid]`` (Cartesian product) and ``[monte_carlo]`` (random draws).

Both tables vary keys of one base config (the sweep file's top-level ``config``)::

    config = "sweep/a_n12_ei1e3.toml"

    [grid]                                  # key path -> list of values; every combination runs
    "lattice.units" = [3, 4]
    "sim.timestep_s" = [0.01, 0.005]        # ids: "units=3,timestep_s=0.01", ...
    "stiffness.EI_Nm2,sim.record_every" = [[1e3, 20], [1e4, 40]]   # linked: varied together

    [monte_carlo]
    samples = 200
    seed = 7
    "sim.duration_s" = { dist = "uniform", low = 50, high = 60 }
    "orbit.epoch" = { dist = "epoch", start = "2016-01-01T00:00:00Z", end = "2017-01-01T00:00:00Z" }
    "initial.omega_rad_s" = { dist = "direction", magnitude = { dist = "log-uniform", low = 1e-3, high = 1e-1 } }

Distributions (a table with ``dist``): ``uniform`` (low, high), ``normal`` (mean, std),
``log-uniform`` (low > 0, high), ``choice`` (values), ``direction`` (a 3-vector: a direction
uniform on the unit sphere times ``magnitude``, a number or a scalar distribution) and ``epoch``
(start, end: a UTC instant uniform in the range, whole seconds, written ``YYYY-MM-DDTHH:MM:SSZ``).

Draws are reproducible and stable: the value of key ``k`` in sample ``i`` comes from its own
generator seeded with ``(seed, i, hash(k))``, so it depends neither on ``samples`` nor on the
other keys (adding samples or keys keeps the earlier draws, hence their config hashes and results).
With both tables, every grid point gets every sample (ids ``<grid id>/s<i>``).

Size. A design is counted before it is expanded (:func:`design_size`: the product of the grid's
value counts, times ``samples``) and refused at once (:func:`check_design_size`, a
:class:`~magsail_mj.config.ConfigError` naming the keys and the count) above :data:`MAX_RUNS`
runs, and above the memory limit (:func:`magsail_mj.resources.check_memory`) at
:data:`DESIGN_RUN_BYTES` a run: a sweep validates every run's config before anything starts and
keeps a record per run, so a 10⁶-point grid once validated for minutes and
``samples = 100000000`` ran out of memory after 112 s.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import itertools
import json
import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from magsail_mj.config import ConfigError
from magsail_mj.resources import check_memory

__all__ = [
    "DESIGN_RUN_BYTES",
    "MAX_RUNS",
    "DesignPoint",
    "check_design_size",
    "design_size",
    "grid_points",
    "monte_carlo_points",
    "design_points",
    "toml_literal",
]

#: the most runs a ``[grid]`` / ``[monte_carlo]`` design may have (grid points × samples); larger
#: designs are refused before they are expanded (``design_points(..., max_runs=...)`` and
#: ``load_sweep(..., max_runs=...)`` take another limit)
MAX_RUNS = 100_000
#: memory a designed run holds while a sweep is loaded and runs [bytes]: its design point and
#: overrides, its validated config's hash, its ``SweepRun``, its record and summary row (32.8 kB
#: traced per run while loading a 2 000-point grid of a CNUSAIL config; doubled for the records and
#: summaries that follow)
DESIGN_RUN_BYTES = 64 * 1024

DISTRIBUTIONS = ("uniform", "normal", "log-uniform", "choice", "direction", "epoch")
_DIST_KEYS = {
    "uniform": {"low", "high"},
    "normal": {"mean", "std"},
    "log-uniform": {"low", "high"},
    "choice": {"values"},
    "direction": {"magnitude"},
    "epoch": {"start", "end"},
}
_ID_UNSAFE = re.compile(r"[^A-Za-z0-9._+-]")


@dataclass(frozen=True)
class DesignPoint:
    """One generated run: its id, its varied values (key path -> value) and their overrides."""

    id: str
    params: dict[str, Any]

    @property
    def overrides(self) -> tuple[str, ...]:
        """``key=value`` overrides setting the point's values (TOML literals)."""
        return tuple(f"{key}={toml_literal(value)}" for key, value in self.params.items())


def toml_literal(value: Any) -> str:
    """``value`` written as a TOML literal that reads back as the same value.

    Raises:
      ValueError: a value TOML cannot hold (None, an unknown type).
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        x = float(value)
        return ("nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")) if not math.isfinite(x) else repr(x)
    if isinstance(value, str):  # a TOML basic string: JSON escapes are TOML escapes; TOML also escapes DEL
        return json.dumps(value, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(value, (_dt.datetime, _dt.date, _dt.time)):
        return value.isoformat()
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_literal(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {toml_literal(v)}" for k, v in value.items()) + "}"
    raise ValueError(f"cannot be written as a TOML value: {value!r}")


def _jsonable(value: Any) -> Any:
    """A drawn or listed value as JSON data (datetimes as ISO strings)."""
    if isinstance(value, (_dt.datetime, _dt.date, _dt.time)):
        return value.isoformat()
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    return value


# ---------------------------------------------------------------------------------------------
# Key paths


def _flatten(table: dict[str, Any], *, leaf: Callable[[Any], bool], prefix: str = "") -> dict[str, Any]:
    """``{"a": {"b": x}}`` -> ``{"a.b": x}``, descending into tables that are not leaves."""
    out: dict[str, Any] = {}
    for key, value in table.items():
        path = f"{prefix}{key}"
        if isinstance(value, dict) and not leaf(value):
            out.update(_flatten(value, leaf=leaf, prefix=f"{path}."))
        else:
            out[path] = value
    return out


def _short_names(keys: list[str]) -> dict[str, str]:
    """The last part of each key path, or the whole path where two keys share their last part."""
    last = [k.rsplit(".", 1)[-1] for k in keys]
    return {k: _ID_UNSAFE.sub("-", s if last.count(s) == 1 else k) for k, s in zip(keys, last)}


def _id_text(value: Any) -> str:
    """A value as id text: numbers compact, strings with unsafe characters as '-'."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.12g}"
    if isinstance(value, (list, tuple)):
        return "x".join(_id_text(v) for v in value)
    return _ID_UNSAFE.sub("-", str(_jsonable(value))) or "-"


# ---------------------------------------------------------------------------------------------
# Grid


def _grid_axes(flat: dict[str, Any]) -> list[tuple[list[str], list[tuple[Any, ...]]]]:
    """Per ``[grid]`` entry its keys (several for linked keys ``"a.b,c.d"``) and value tuples.

    Raises:
      ConfigError: naming ``grid.<key>`` for values that are not a non-empty list (of lists as
        long as the linked keys).
    """
    axes, problems = [], []
    for name, values in flat.items():
        keys = [k.strip() for k in name.split(",")]
        if not isinstance(values, list) or not values:
            problems.append(f"grid.{name}: must be a non-empty list of values, got {values!r}")
        elif len(keys) > 1 and not all(isinstance(v, list) and len(v) == len(keys) for v in values):
            problems.append(f"grid.{name}: linked keys take a list of [{', '.join(keys)}] lists, got {values!r}")
        elif not all(keys):
            problems.append(f"grid.{name}: empty key in a list of linked keys")
        else:
            axes.append((keys, [tuple(v) if len(keys) > 1 else (v,) for v in values]))
    if problems:
        raise ConfigError(problems)
    return axes


def grid_points(table: Any) -> list[DesignPoint]:
    """Every combination of the ``[grid]`` values, in file order (the last entry varies fastest).

    An entry whose key lists several key paths separated by commas (``"a.b,c.d" = [[1, 2], [3, 4]]``)
    varies them together (linked keys, e.g. a stiffness and the time step it needs).

    Raises:
      ConfigError: naming ``grid.<key>`` for a value list that is not a non-empty list, a key
        varied twice, or two points whose ids coincide.
    """
    if not isinstance(table, dict) or not table:
        raise ConfigError([f"grid: must be a table of key.path = [values], got {table!r}"])
    axes = _grid_axes(_flatten(table, leaf=lambda v: False))
    keys = [k for axis_keys, _ in axes for k in axis_keys]
    twice = sorted({k for k in keys if keys.count(k) > 1})
    if twice:
        raise ConfigError([f"grid.{k}: varied by more than one grid entry" for k in twice])
    short = _short_names(keys)
    points = []
    for combo in itertools.product(*(values for _, values in axes)):
        flat_values = [v for group in combo for v in group]
        rid = ",".join(f"{short[k]}={_id_text(v)}" for k, v in zip(keys, flat_values))
        points.append(DesignPoint(id=rid, params={k: _jsonable(v) for k, v in zip(keys, flat_values)}))
    seen: dict[str, DesignPoint] = {}
    for p in points:
        if p.id in seen:
            raise ConfigError(
                [f"grid: the points {seen[p.id].params} and {p.params} get the same id {p.id!r}; give distinct values"]
            )
        seen[p.id] = p
    return points


# ---------------------------------------------------------------------------------------------
# Monte Carlo


def _number(spec: dict[str, Any], name: str, where: str) -> float:
    value = spec.get(name)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError([f"{where}.{name}: must be a finite number, got {value!r}"])
    return float(value)


def _instant(value: Any, where: str) -> _dt.datetime:
    """A UTC instant from a TOML datetime or an ISO-8601 string (naive means UTC)."""
    if isinstance(value, str):
        try:
            value = _dt.datetime.fromisoformat(value.replace("Z", "+00:00"))
        except ValueError:
            raise ConfigError([f"{where}: must be an ISO-8601 date-time, got {value!r}"]) from None
    if isinstance(value, _dt.date) and not isinstance(value, _dt.datetime):
        value = _dt.datetime(value.year, value.month, value.day)
    if not isinstance(value, _dt.datetime):
        raise ConfigError([f"{where}: must be a date-time, got {value!r}"])
    return value.replace(tzinfo=_dt.UTC) if value.tzinfo is None else value.astimezone(_dt.UTC)


def _check_distribution(spec: Any, where: str, *, scalar: bool = False) -> None:
    """ConfigError naming ``where`` when ``spec`` is not a valid distribution table."""
    if not isinstance(spec, dict) or spec.get("dist") not in DISTRIBUTIONS:
        got = spec.get("dist") if isinstance(spec, dict) else spec
        raise ConfigError([f"{where}.dist: must be one of {list(DISTRIBUTIONS)}, got {got!r}"])
    dist = spec["dist"]
    unknown = sorted(set(spec) - _DIST_KEYS[dist] - {"dist"})
    missing = sorted(_DIST_KEYS[dist] - set(spec))
    if unknown or missing:
        raise ConfigError(
            [
                f"{where}: dist {dist!r} takes {sorted(_DIST_KEYS[dist])}"
                + (f"; unknown {unknown}" if unknown else "")
                + (f"; missing {missing}" if missing else "")
            ]
        )
    if scalar and dist in ("direction", "epoch", "choice"):
        raise ConfigError([f"{where}.dist: must be a scalar distribution (uniform, normal, log-uniform), got {dist!r}"])
    if dist in ("uniform", "log-uniform"):
        low, high = _number(spec, "low", where), _number(spec, "high", where)
        if high < low or (dist == "log-uniform" and low <= 0):
            need = "0 < low <= high" if dist == "log-uniform" else "low <= high"
            raise ConfigError([f"{where}: needs {need}, got low={low!r}, high={high!r}"])
    elif dist == "normal":
        _number(spec, "mean", where)
        if _number(spec, "std", where) < 0:
            raise ConfigError([f"{where}.std: must be >= 0, got {spec['std']!r}"])
    elif dist == "choice":
        if not isinstance(spec["values"], list) or not spec["values"]:
            raise ConfigError([f"{where}.values: must be a non-empty list, got {spec['values']!r}"])
    elif dist == "direction":
        magnitude = spec["magnitude"]
        if isinstance(magnitude, dict):
            _check_distribution(magnitude, f"{where}.magnitude", scalar=True)
        elif isinstance(magnitude, bool) or not isinstance(magnitude, (int, float)) or not math.isfinite(magnitude):
            raise ConfigError([f"{where}.magnitude: must be a number or a scalar distribution, got {magnitude!r}"])
    else:
        start, end = _instant(spec["start"], f"{where}.start"), _instant(spec["end"], f"{where}.end")
        if end < start:
            raise ConfigError([f"{where}: end {spec['end']!r} lies before start {spec['start']!r}"])


def _draw(spec: dict[str, Any], rng: np.random.Generator) -> Any:
    """One value of a checked distribution."""
    dist = spec["dist"]
    if dist == "uniform":
        return float(rng.uniform(spec["low"], spec["high"]))
    if dist == "normal":
        return float(rng.normal(spec["mean"], spec["std"]))
    if dist == "log-uniform":
        return float(math.exp(rng.uniform(math.log(spec["low"]), math.log(spec["high"]))))
    if dist == "choice":
        return _jsonable(spec["values"][int(rng.integers(len(spec["values"])))])
    if dist == "direction":
        v = rng.normal(size=3)
        while np.linalg.norm(v) < 1e-12:  # measure zero; keeps the direction defined
            v = rng.normal(size=3)
        magnitude = spec["magnitude"]
        size = _draw(magnitude, rng) if isinstance(magnitude, dict) else float(magnitude)
        return [float(x) for x in v / np.linalg.norm(v) * size]
    start, end = _instant(spec["start"], "start"), _instant(spec["end"], "end")
    seconds = int(rng.integers(0, int((end - start).total_seconds()) + 1))
    return (start + _dt.timedelta(seconds=seconds)).strftime("%Y-%m-%dT%H:%M:%SZ")


def _key_seed(key: str) -> int:
    return int.from_bytes(hashlib.sha256(key.encode()).digest()[:8], "little")


def monte_carlo_points(table: Any) -> list[DesignPoint]:
    """The ``samples`` draws of ``[monte_carlo]`` (ids ``s000`` ... with the width of the count).

    Raises:
      ConfigError: naming ``monte_carlo.samples``, ``.seed`` or ``monte_carlo.<key>`` and what is allowed.
    """
    if not isinstance(table, dict):
        raise ConfigError([f"monte_carlo: must be a table (samples, seed, key.path = {{dist = ...}}), got {table!r}"])
    samples, seed = table.get("samples"), table.get("seed", 0)
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise ConfigError([f"monte_carlo.samples: must be an integer >= 1, got {samples!r}"])
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError([f"monte_carlo.seed: must be an integer >= 0, got {seed!r}"])
    specs = _flatten({k: v for k, v in table.items() if k not in ("samples", "seed")}, leaf=lambda v: "dist" in v)
    if not specs:
        raise ConfigError(["monte_carlo: names no key to draw (key.path = { dist = ... })"])
    for key, spec in specs.items():
        _check_distribution(spec, f"monte_carlo.{key}")
    width = len(str(samples - 1))
    return [
        DesignPoint(
            id=f"s{i:0{width}d}",
            params={k: _draw(s, np.random.default_rng([seed, i, _key_seed(k)])) for k, s in specs.items()},
        )
        for i in range(samples)
    ]


def design_size(tree: dict[str, Any]) -> tuple[int, str]:
    """``(runs, how)`` of a sweep file's design, counted without expanding it: the product of the
    value counts of the ``[grid]`` entries times ``monte_carlo.samples``; ``how`` says which keys
    gave the count (e.g. ``"grid.a (1000) × grid.b (1000)"``). Entries that are not a non-empty
    list, and a ``samples`` that is not an integer >= 1, count 1 (their own checks report them)."""
    counts: list[tuple[str, int]] = []
    grid = tree.get("grid")
    if isinstance(grid, dict):
        for name, values in _flatten(grid, leaf=lambda v: False).items():
            if isinstance(values, list) and values:
                counts.append((f"grid.{name}", len(values)))
    mc = tree.get("monte_carlo")
    if isinstance(mc, dict):
        samples = mc.get("samples")
        if isinstance(samples, int) and not isinstance(samples, bool) and samples >= 1:
            counts.append(("monte_carlo.samples", samples))
    return math.prod(n for _, n in counts), " × ".join(f"{k} ({n})" for k, n in counts)


def check_design_size(tree: dict[str, Any], *, max_runs: int = MAX_RUNS) -> int:
    """The number of runs of a sweep file's design (:func:`design_size`), refused before it is
    expanded when it is above ``max_runs`` or its bookkeeping (:data:`DESIGN_RUN_BYTES` a run)
    above the memory limit.

    Raises:
      ConfigError: more than ``max_runs`` runs (naming the keys, their counts and the total).
      MemoryLimitError: the runs' bookkeeping is above the memory limit in force.
    """
    if isinstance(max_runs, bool) or not isinstance(max_runs, int) or max_runs < 1:
        raise ValueError(f"max_runs: must be an integer >= 1, got {max_runs!r}")
    runs, how = design_size(tree)
    if runs > max_runs:
        raise ConfigError(
            [
                f"{how}: the design has {runs} runs, above the limit of {max_runs} runs a sweep file may "
                "design (magsail_mj.sweep.design.MAX_RUNS); use fewer values or samples, or split the sweep"
            ]
        )
    check_memory(runs * DESIGN_RUN_BYTES, what=f"sweep design {how} = {runs} runs")
    return runs


def design_points(tree: dict[str, Any], *, max_runs: int = MAX_RUNS) -> list[DesignPoint]:
    """The runs of a sweep file's ``[grid]`` and ``[monte_carlo]`` tables (none without them),
    after :func:`check_design_size` (refused before anything is expanded when there are more than
    ``max_runs``, or more than the memory limit holds)."""
    check_design_size(tree, max_runs=max_runs)
    grid = grid_points(tree["grid"]) if "grid" in tree else None
    mc = monte_carlo_points(tree["monte_carlo"]) if "monte_carlo" in tree else None
    if grid is None or mc is None:
        return grid or mc or []
    both = sorted(set(grid[0].params) & set(mc[0].params))
    if both:
        raise ConfigError([f"monte_carlo.{k}: also varied by grid.{k}; vary a key in one table only" for k in both])
    return [DesignPoint(id=f"{g.id}/{m.id}", params={**g.params, **m.params}) for g in grid for m in mc]
