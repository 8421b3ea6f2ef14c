"""Concept registry and discovery: a concept is a package under ``magsail_mj.concepts``.

A concept package registers, when imported,

- its config schema, ``@register_config("<concept>")`` on the pydantic model of its TOML files
  (``kind_key`` names the config field that selects the scenario kind, ``"scenario"`` by default);
- its tasks, ``@register_task("<concept>", "<kind>")`` on one class per scenario kind, keyed by
  ``(concept, kind)``; a class is built from a validated config by ``cls.from_config(cfg)`` when
  it has that class method, else by ``cls(cfg)``;
- or, instead of task classes, one builder ``@register_builder("<concept>")`` (``cfg → task``);
- optionally, ``@register_structure("<concept>")`` on ``cfg → Structure``: the structure a config
  models (what ``magsail modes`` analyses), registered from the ``tasks`` module.

Discovery has two sides, and this registry is the one place that names the modules it imports
(:data:`SCHEMA_MODULE`, :data:`TASK_MODULE`, resolved with ``importlib``):

- the schema side, :func:`discover_schemas` (behind :func:`config_schemas`, so behind
  :func:`magsail_mj.config.load_config` and ``magsail validate``), imports every subpackage of
  ``magsail_mj.concepts`` (``pkgutil``) and its ``config`` module;
- the task side, :func:`discover` (behind :func:`task_kinds` and :func:`build_task`, so behind
  building a scenario), imports, in addition, each package's ``tasks`` module.

A concept package's ``__init__`` and its ``config`` module therefore never import its ``tasks``
module (nor the plots, the model or the runner it brings): validating a config loads the schemas
only, never Matplotlib. A new concept is added by adding a package: no existing module names it.
This module imports no concept and no other part of magsail_mj (the framework imports it, never
the reverse).
"""

from __future__ import annotations

import importlib
import importlib.util
import pkgutil
from collections.abc import Callable
from types import ModuleType
from typing import Any, TypeVar

__all__ = [
    "CONFIG_SCHEMAS",
    "KIND_KEYS",
    "TASKS",
    "BUILDERS",
    "register_config",
    "register_task",
    "register_builder",
    "register_structure",
    "STRUCTURES",
    "structure_of",
    "SCHEMA_MODULE",
    "TASK_MODULE",
    "discover",
    "discover_schemas",
    "concept_modules",
    "config_schemas",
    "task_kinds",
    "build_task",
]

T = TypeVar("T")

CONFIG_SCHEMAS: dict[str, type] = {}
"""Concept name → pydantic model of its config files."""

KIND_KEYS: dict[str, str] = {}
"""Concept name → config field holding the scenario kind (``"scenario"`` unless registered)."""

TASKS: dict[tuple[str, str], type] = {}
"""``(concept, scenario kind)`` → task class."""

BUILDERS: dict[str, Callable[[Any], Any]] = {}

STRUCTURES: dict[str, Callable[[Any], Any]] = {}
"""Concept name → ``cfg → Structure`` of its configs (concepts whose model is a structure)."""
"""Concept name → builder ``cfg → task`` (concepts that dispatch on their kind themselves)."""


def register_config(concept: str, *, kind_key: str = "scenario") -> Callable[[type[T]], type[T]]:
    """Class decorator: make ``cls`` the config schema of ``concept``; ``kind_key`` names its kind field."""
    _check_name("concept", concept)
    _check_name("kind_key", kind_key)

    def wrap(cls: type[T]) -> type[T]:
        CONFIG_SCHEMAS[concept] = cls
        KIND_KEYS[concept] = kind_key
        return cls

    return wrap


def register_task(concept: str, kind: str) -> Callable[[type[T]], type[T]]:
    """Class decorator: make ``cls`` the task of scenario kind ``kind`` of ``concept``."""
    _check_name("concept", concept)
    _check_name("kind", kind)

    def wrap(cls: type[T]) -> type[T]:
        TASKS[(concept, kind)] = cls
        return cls

    return wrap


def register_builder(concept: str) -> Callable[[Callable[[Any], T]], Callable[[Any], T]]:
    """Decorator: make ``fn(cfg) → task`` the builder of every scenario kind of ``concept``."""
    _check_name("concept", concept)

    def wrap(fn: Callable[[Any], T]) -> Callable[[Any], T]:
        BUILDERS[concept] = fn
        return fn

    return wrap


def register_structure(concept: str) -> Callable[[Callable[[Any], T]], Callable[[Any], T]]:
    """Decorator: make ``fn(cfg) → Structure`` the structure of the configs of ``concept``."""
    _check_name("concept", concept)

    def wrap(fn: Callable[[Any], T]) -> Callable[[Any], T]:
        STRUCTURES[concept] = fn
        return fn

    return wrap


def _check_name(arg: str, value: object) -> None:
    if not isinstance(value, str) or not value.isidentifier():
        raise ValueError(f"{arg}: must be an identifier string, got {value!r}")


def _import_children(package: str, *, packages_only: bool) -> None:
    """Import the direct children of ``package`` (a missing package is skipped)."""
    try:
        pkg = importlib.import_module(package)
    except ModuleNotFoundError as err:
        if err.name != package:
            raise
        return
    for info in pkgutil.iter_modules(getattr(pkg, "__path__", ()), prefix=package + "."):
        if info.name.rpartition(".")[2].startswith("_") or (packages_only and not info.ispkg):
            continue
        importlib.import_module(info.name)


SCHEMA_MODULE = "config"
"""The module of a concept package that registers its config schema (``<concept>.config``)."""

TASK_MODULE = "tasks"
"""The module of a concept package that registers its tasks or builder (``<concept>.tasks``)."""

_schemas_discovered = False
_discovered = False


def discover_schemas() -> None:
    """Import every concept package and its :data:`SCHEMA_MODULE` once per process (the schema side).

    Imports no ``tasks`` module: what this registers is what validating a config needs.
    """
    global _schemas_discovered
    if _schemas_discovered:
        return
    _import_children(__name__, packages_only=True)
    concept_modules(SCHEMA_MODULE)
    _schemas_discovered = True


def discover() -> None:
    """Import every concept package, its schema and its :data:`TASK_MODULE` once per process.

    The task side: each concept's tasks (with their models, runners and plots) register here.
    """
    global _discovered
    if _discovered:
        return
    discover_schemas()
    concept_modules(TASK_MODULE)
    _discovered = True


def concept_modules(leaf: str) -> dict[str, ModuleType]:
    """The module ``<concept>.<leaf>`` of every concept package that has one, by concept name.

    For a framework part that collects one optional module per concept (``env`` for the
    control-suite environments) without naming the concepts.
    """
    _check_name("leaf", leaf)
    found = {}
    pkg = importlib.import_module(__name__)
    for info in pkgutil.iter_modules(pkg.__path__, prefix=__name__ + "."):
        concept = info.name.rpartition(".")[2]
        if not info.ispkg or concept.startswith("_"):
            continue
        name = f"{info.name}.{leaf}"
        if importlib.util.find_spec(name) is not None:
            found[concept] = importlib.import_module(name)
    return found


def config_schemas() -> dict[str, type]:
    """All concept config schemas after :func:`discover_schemas` (no task module), by concept name."""
    discover_schemas()
    return dict(CONFIG_SCHEMAS)


def task_kinds(concept: str) -> list[str]:
    """Scenario kinds registered with a task class for ``concept`` (after :func:`discover`)."""
    discover()
    return sorted(kind for (c, kind) in TASKS if c == concept)


def build_task(cfg: Any) -> Any:
    """The task of a validated config: ``TASKS[(cfg.concept, kind)]``, else ``BUILDERS[cfg.concept]``.

    ``kind`` is the config field named by the concept's ``kind_key``. A ``ValueError`` names
    ``concept`` or the kind field when nothing is registered for them.
    """
    discover()
    concept = cfg.concept
    key = KIND_KEYS.get(concept, "scenario")
    kind = getattr(cfg, key, None)
    cls = TASKS.get((concept, kind))
    if cls is not None:
        make = getattr(cls, "from_config", None)
        return make(cfg) if callable(make) else cls(cfg)
    if concept in BUILDERS:
        return BUILDERS[concept](cfg)
    if any(c == concept for (c, _) in TASKS):
        raise ValueError(f"{key}: no {concept} task {kind!r}; known {task_kinds(concept)}")
    raise ValueError(f"concept: no scenario builder for {concept!r}")


def structure_of(cfg: Any) -> Any:
    """The structure a validated config models (``STRUCTURES[cfg.concept](cfg)``); a
    ``ValueError`` names the concept when it registers none."""
    discover()
    fn = STRUCTURES.get(cfg.concept)
    if fn is None:
        raise ValueError(
            f"concept: {cfg.concept!r} has no structure (concepts with one: {sorted(STRUCTURES) or 'none'})"
        )
    return fn(cfg)
