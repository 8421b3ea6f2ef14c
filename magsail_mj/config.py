"""Typed, validated scenario configs loaded from TOML.

A scenario is a TOML file with a top-level ``concept`` key (``truss_magnetorquer``,
``current_loops``, ``reflector``, ``cnusail``, ``msac``) and a ``scenario`` key naming the
experiment. Each concept registers a pydantic model (``register_concept``) that describes its
tables. Loading:

1. read the TOML file (``tomllib``);
2. apply ``--set key.path=value`` overrides (the value is parsed as a TOML literal, so
   ``sim.duration_s=60`` gives a float and ``actuators.placement=central`` a string);
3. validate the whole tree against the concept's model. Unknown keys are errors.

Any failure raises :class:`ConfigError`, whose message names every offending key path, the
value given and what is allowed, e.g. ``lattice.units: must be an integer >= 1, got 0``.
Nothing is built or written before validation passes.
"""

from __future__ import annotations

import copy
import hashlib
import importlib
import json
import math
import tomllib
from pathlib import Path
from typing import Any, Callable, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

__all__ = [
    "ConfigError",
    "StrictModel",
    "SimConfig",
    "LatticeRenderConfig",
    "normalised",
    "check_finite_fields",
    "register_concept",
    "concept_models",
    "load_config",
    "parse_config",
    "apply_overrides",
    "config_hash",
]

Integrator = Literal["RK4", "Euler", "implicitfast", "implicit", "discrete"]


class ConfigError(ValueError):
    """A config failed validation. ``str(err)`` lists ``key.path: message, got value`` lines."""

    def __init__(self, problems: list[str], *, source: str | None = None):
        self.problems = list(problems)
        head = f"invalid config {source}" if source else "invalid config"
        super().__init__(head + ":\n  " + "\n  ".join(self.problems))


class StrictModel(BaseModel):
    """Base of every config table: unknown keys are errors, assignments are validated."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True, frozen=False)


class SimConfig(StrictModel):
    """The ``[sim]`` table every scenario has.

    ``timestep_s`` is MuJoCo's ``opt.timestep``; ``record_every`` keeps every k-th step;
    ``checkpoint_every_s`` writes a resumable checkpoint each so many simulated seconds
    (0 = never); ``max_strain`` is the divergence bound on any strut's |Δl|/l0.
    ``integrator = "discrete"`` is MuJoCo's position-implicit step (strut springs and dashpots
    in the metric M + hD + h²K, stable beyond 2/ω_max but with backward-Euler damping of the
    structural modes); ``solver_tolerance`` is MuJoCo's ``opt.tolerance`` (unset: MuJoCo's
    1e-8), which also ends that integrator's iterative effective-metric solve.
    """

    duration_s: float = Field(gt=0)
    timestep_s: float = Field(gt=0, le=10.0)
    integrator: Integrator = "RK4"
    solver_tolerance: float | None = Field(default=None, gt=0, lt=1)
    record_every: int = Field(default=10, ge=1)
    seed: int = Field(default=0, ge=0)
    checkpoint_every_s: float = Field(default=0.0, ge=0)
    max_strain: float = Field(default=0.5, gt=0)
    progress: bool = True

    @model_validator(mode="after")
    def _step_fits(self) -> "SimConfig":
        if self.timestep_s > self.duration_s:
            raise ValueError(
                f"timestep_s ({self.timestep_s}) must not exceed duration_s ({self.duration_s})"
            )
        return self


class LatticeRenderConfig(StrictModel):
    """``[render]`` of the lattice concepts (truss, current loops): video options; the defaults are
    the truss's, a concept overrides its own in a subclass."""

    exaggeration: float = Field(default=1.0, gt=0)
    azimuth_deg: float = 180.0
    elevation_deg: float = -30.0
    distance_factor: float = Field(default=1.6, gt=0)
    fps: int = Field(default=30, ge=1, le=120)
    max_frames: int = Field(default=450, ge=2)


def normalised(v: tuple[float, ...], what: str) -> tuple[float, ...]:
    """``v / |v|`` for a field validator; a zero ``v`` is a ``must be a non-zero {what}`` error."""
    n = math.sqrt(sum(c * c for c in v))
    if not n > 0:
        raise ValueError(f"must be a non-zero {what}")
    return tuple(c / n for c in v)


def check_finite_fields(obj: Any, *, positive: tuple[str, ...] = (), non_negative: tuple[str, ...] = ()) -> None:
    """Raise ``ValueError`` naming the first attribute of ``obj`` in ``positive`` that is not a
    finite number > 0, then the first in ``non_negative`` that is not a finite number >= 0."""
    for name in positive:
        v = getattr(obj, name)
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name}: must be a finite number > 0, got {v!r}")
    for name in non_negative:
        v = getattr(obj, name)
        if not (math.isfinite(v) and v >= 0):
            raise ValueError(f"{name}: must be a finite number >= 0, got {v!r}")


_REGISTRY: dict[str, type[BaseModel]] = {}
_CONCEPT_MODULES = {
    "truss_magnetorquer": "magsail_mj.scenarios.truss",
    "current_loops": "magsail_mj.scenarios.current_loops",
    "reflector": "magsail_mj.scenarios.reflector",
    "cnusail": "magsail_mj.scenarios.cnusail",
    "msac": "magsail_mj.scenarios.msac",
}


def register_concept(name: str) -> Callable[[type[BaseModel]], type[BaseModel]]:
    """Class decorator: make ``cls`` the schema of configs whose ``concept`` is ``name``."""

    def wrap(cls: type[BaseModel]) -> type[BaseModel]:
        _REGISTRY[name] = cls
        return cls

    return wrap


def concept_models() -> dict[str, type[BaseModel]]:
    """All registered concept schemas (imports the concept modules that exist)."""
    for name, module in _CONCEPT_MODULES.items():
        if name not in _REGISTRY:
            try:
                importlib.import_module(module)
            except ModuleNotFoundError as err:
                if err.name != module:
                    raise
    return dict(_REGISTRY)


def _format_error(err: dict[str, Any]) -> str:
    loc = ".".join(str(part) for part in err.get("loc", ()) if not str(part).startswith("function-"))
    kind = err.get("type", "")
    value = err.get("input")
    ctx = err.get("ctx") or {}
    if kind == "extra_forbidden":
        return f"{loc}: unknown key (not part of this table), got {value!r}"
    if kind == "missing":
        return f"{loc}: required key is missing"
    if kind == "literal_error":
        return f"{loc}: must be one of {ctx.get('expected')}, got {value!r}"
    if kind in ("greater_than_equal", "greater_than", "less_than", "less_than_equal"):
        sign = {"greater_than_equal": ">=", "greater_than": ">",
                "less_than": "<", "less_than_equal": "<="}[kind]
        bound = next(iter(ctx.values())) if ctx else "?"
        noun = "an integer" if isinstance(bound, int) and not isinstance(bound, bool) else "a number"
        return f"{loc}: must be {noun} {sign} {bound}, got {value!r}"
    msg = err.get("msg", "invalid value")
    msg = msg.removeprefix("Value error, ")
    where = f"{loc}: " if loc else ""
    return f"{where}{msg}, got {value!r}" if "input" in err and not isinstance(value, dict) else f"{where}{msg}"


def _parse_literal(text: str) -> Any:
    """Parse ``text`` as a TOML value; bare words that are not TOML become strings."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def apply_overrides(tree: dict[str, Any], overrides: list[str] | tuple[str, ...]) -> dict[str, Any]:
    """Return a copy of ``tree`` with ``key.path=value`` overrides applied.

    Raises ConfigError naming the override when it is not of the form ``a.b=value``.
    """
    out = copy.deepcopy(tree)
    problems = []
    for item in overrides:
        if "=" not in item:
            problems.append(f"--set {item!r}: must look like key.path=value")
            continue
        key, text = item.split("=", 1)
        parts = [p for p in key.strip().split(".") if p]
        if not parts:
            problems.append(f"--set {item!r}: empty key path")
            continue
        node = out
        for part in parts[:-1]:
            child = node.setdefault(part, {})
            if not isinstance(child, dict):
                problems.append(f"--set {item!r}: {part} is a value, not a table")
                break
            node = child
        else:
            node[parts[-1]] = _parse_literal(text.strip())
    if problems:
        raise ConfigError(problems)
    return out


def parse_config(tree: dict[str, Any], *, source: str | None = None) -> BaseModel:
    """Validate a raw config tree against its concept's schema."""
    models = concept_models()
    concept = tree.get("concept")
    if concept not in models:
        raise ConfigError(
            [f"concept: must be one of {sorted(models)}, got {concept!r}"], source=source
        )
    try:
        return models[concept].model_validate(tree)
    except ValidationError as err:
        raise ConfigError([_format_error(e) for e in err.errors()], source=source) from None


def load_config(path: str | Path, overrides: list[str] | tuple[str, ...] = ()) -> BaseModel:
    """Load, override and validate the scenario config at ``path``."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError([f"config file {str(path)!r} does not exist"])
    try:
        tree = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as err:
        raise ConfigError([f"not valid TOML: {err}"], source=str(path)) from None
    tree = apply_overrides(tree, overrides)
    return parse_config(tree, source=str(path))


def config_hash(cfg: BaseModel) -> str:
    """SHA-256 of the validated config (canonical JSON): the run's identity in manifests."""
    text = json.dumps(cfg.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()
