"""Typed, validated scenario configs loaded from TOML.

A scenario is a TOML file with a top-level ``concept`` key (``truss_magnetorquer``,
``current_loops``, ``reflector``, ``cnusail``, ``msac``) and a ``scenario`` key naming the
experiment. Each concept registers a pydantic model (``register_concept``) that describes its
tables. Loading:

1. read the TOML file (``tomllib``; a folder, an unreadable, binary or non-UTF-8 file is a
   :class:`ConfigError`);
2. apply ``--set key.path=value`` overrides (the value is parsed as a TOML literal, so
   ``sim.duration_s=60`` gives a float and ``actuators.placement=central`` a string);
3. validate the whole tree against the concept's model. Unknown keys are errors.

Validation is strict (every :class:`StrictModel`): numbers must be finite (no ``nan``/``inf``
unless a key documents otherwise), a boolean is never a number, a string is never a number or a
boolean, a float is never an integer (a TOML integer for a float key is fine), and TOML arrays
fill the fixed-length vectors (``tuple``) of the schemas. Bounds are what the physics and MuJoCo
need (masses and inertias above :data:`MJ_MINVAL`, time steps at least :data:`MIN_TIMESTEP_S`,
derived quantities finite); how much memory a config needs is checked elsewhere (the CLI).

Any failure raises :class:`ConfigError`, whose message names every offending key path, the
value given and what is allowed, e.g. ``lattice.units: must be an integer >= 1, got 0``; all
problems of a file and its overrides are reported at once. Nothing is built or written before
validation passes.
"""

from __future__ import annotations

import copy
import hashlib
import json
import logging
import math
import re
import tomllib
import types
import typing
import warnings
from contextvars import ContextVar
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from magsail_mj.concepts import config_schemas, register_config
from magsail_mj.units_grammar import ALIAS_REMOVAL_VERSION, deprecated_aliases, new_name

__all__ = [
    "CONFIG_DIR",
    "MAX_STEPS",
    "MIN_TIMESTEP_S",
    "MJ_MINVAL",
    "PRESENTATION_KEYS",
    "ConfigError",
    "ConfigProblem",
    "LatticeRenderConfig",
    "SimConfig",
    "StrictModel",
    "apply_overrides",
    "check_finite_fields",
    "check_lattice_numbers",
    "concept_models",
    "config_hash",
    "derived_quantity",
    "finite_product",
    "likeliest_key",
    "load_config",
    "normalised",
    "numbers_hash",
    "numbers_tree",
    "parse_config",
    "read_toml",
    "register_concept",
    "validation_problems",
    "warn_deprecated_key",
]

Integrator = Literal["RK4", "Euler", "implicitfast", "implicit", "discrete"]

MJ_MINVAL = 1e-15
"""MuJoCo's ``mjMINVAL``: a body mass or principal inertia at or below it is treated as zero
(the model fails to compile or to step), so every mass and inertia a config implies must exceed it."""

MIN_TIMESTEP_S = 1e-9
"""Smallest accepted ``sim.timestep_s`` [s]."""

MAX_STEPS = float(2**63)
"""Upper bound of every count a config implies (time steps, cells, samples): a 64-bit integer."""

CONFIG_DIR: ContextVar[Path | None] = ContextVar("magsail_config_dir", default=None)
"""The folder of the config file :func:`load_config` is validating (``None``: a tree validated
without a file): a key that names a file (a structure file) is read relative to it, else relative to
the working directory."""

PRESENTATION_KEYS = ("sim.progress", "sim.duration_s", "sim.checkpoint_every_s", "render")
"""Keys that do not change the numbers of a run up to a given time (left out of :func:`numbers_hash`)."""


class ConfigError(ValueError):
    """A config failed validation. ``str(err)`` lists ``key.path: message, got value`` lines."""

    def __init__(self, problems: list[str], *, source: str | None = None):
        self.problems = list(problems)
        head = f"invalid config {source}" if source else "invalid config"
        super().__init__(head + ":\n  " + "\n  ".join(self.problems))


class ConfigProblem(ValueError):
    """A validator's complaint about ``key`` (a dotted path relative to the table it validates).

    Raised inside a pydantic validator, it is reported as ``<table path>.<key>: <message>``, so a
    table's model validator names the full key path of the offending key. ``others`` are further
    keys of the same table involved in the problem; they are named too (``also: table.k``).
    """

    def __init__(self, key: str, message: str, *, others: tuple[str, ...] = ()):
        self.key = key
        self.message = message
        self.others = tuple(others)
        super().__init__(f"{key}: {message}")


def _is_tuple_annotation(annotation: Any) -> bool:
    """True when ``annotation`` is a ``tuple[...]`` or an optional/union containing one."""
    origin = typing.get_origin(annotation)
    if origin is tuple:
        return True
    if origin in (typing.Union, types.UnionType):
        return any(_is_tuple_annotation(a) for a in typing.get_args(annotation))
    return False


_log = logging.getLogger(__name__)


def _current_spellings(model: type[BaseModel], data: dict[str, Any]) -> dict[str, Any]:
    """``data`` (one config table) with each key in a deprecated unit spelling renamed to the
    model's current key (:func:`magsail_mj.units_grammar.deprecated_aliases`), each rename
    announced by a ``DeprecationWarning`` (and the log); an old and a new spelling of the same key
    given together are a :class:`ConfigProblem` naming both."""
    aliases = deprecated_aliases(tuple(model.model_fields))
    given = [old for old in data if old in aliases]
    if not given:
        return data
    out = dict(data)
    for old in given:
        new = aliases[old]
        if new in out:
            raise ConfigProblem(
                new, f"given twice: as {new!r} and as its deprecated spelling {old!r}; keep only {new!r}", others=(old,)
            )
        out[new] = out.pop(old)
        warn_deprecated_key(old, new)
    return out


def warn_deprecated_key(old: str, new: str) -> None:
    """Announce that config key ``old`` was read as ``new``: a ``DeprecationWarning`` and a log
    warning naming both and the version in which the old spelling goes."""
    message = (
        f"config key {old!r} is deprecated: its unit suffix is now spelled {new!r} (one unit-suffix "
        f"grammar, see the conventions page); the old spelling is accepted until magsail_mj "
        f"{ALIAS_REMOVAL_VERSION}"
    )
    warnings.warn(message, DeprecationWarning, stacklevel=3)
    _log.warning(message)


class StrictModel(BaseModel):
    """Base of every config table: unknown keys are errors, assignments are validated, types are
    strict (no bool/str → number, no str → bool, no float → int) and numbers finite
    (``allow_inf_nan=False``). A TOML array given for a ``tuple[...]`` key (a fixed-length vector)
    is accepted as that tuple; its items are still checked strictly. A key in a unit spelling the
    unit-suffix grammar replaced (``kp_Nm`` for ``kp_Nm``) is read as the current key with a
    ``DeprecationWarning`` until :data:`~magsail_mj.units_grammar.ALIAS_REMOVAL_VERSION`."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True, frozen=False, strict=True, allow_inf_nan=False)

    @model_validator(mode="before")
    @classmethod
    def _arrays_as_tuples(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        data = _current_spellings(cls, data)
        names = [
            n
            for n, f in cls.model_fields.items()
            if isinstance(data.get(n), list) and _is_tuple_annotation(f.annotation)
        ]
        if not names:
            return data
        return {**data, **{n: tuple(data[n]) for n in names}}


class SimConfig(StrictModel):
    """The ``[sim]`` table every scenario has.

    ``timestep_s`` is MuJoCo's ``opt.timestep`` (at least 1e-9 s, at most 10 s);
    ``duration_s`` the simulated time (at least one time step); ``record_every`` keeps every k-th
    step; ``checkpoint_every_s`` writes a resumable checkpoint each so many simulated seconds
    (0 = never, else at least one time step); ``max_strain`` is the divergence bound on any
    strut's |Δl|/l0. ``integrator = "discrete"`` is MuJoCo's position-implicit step (strut
    springs and dashpots in the metric M + hD + h²K, stable beyond 2/ω_max but with
    backward-Euler damping of the structural modes); ``solver_tolerance`` is MuJoCo's
    ``opt.tolerance`` (unset: MuJoCo's 1e-8), which also ends that integrator's iterative
    effective-metric solve. ``load_timing`` says when the loads see the state: ``"start"``
    (held at the step's start value: first order in the time step) or ``"midpoint"`` (predicted at
    mid-step: second order; see :mod:`magsail_mj.sim`), or ``"stage"`` (at the state and time of
    every stage of the integrator: RK4's fourth order; compiled loads only). ``loads`` says where
    the loads are computed: ``"python"`` (the default: NumPy/Python loads adding into
    ``xfrc_applied`` before each step) or ``"compiled"`` (a MuJoCo plugin built from C on first use,
    computing them inside the step, :mod:`magsail_mj.compiled`; the scenarios that have one: the
    CNUSAIL attitude runs and the reflector's pitch tracking). ``progress`` only shows a progress bar.
    """

    duration_s: float = Field(gt=0)
    timestep_s: float = Field(ge=MIN_TIMESTEP_S, le=10.0)
    integrator: Integrator = "RK4"
    solver_tolerance: float | None = Field(default=None, gt=0, lt=1)
    record_every: int = Field(default=10, ge=1)
    seed: int = Field(default=0, ge=0, lt=2**63)
    checkpoint_every_s: float = Field(default=0.0, ge=0)
    max_strain: float = Field(default=0.5, gt=0)
    load_timing: Literal["start", "midpoint", "stage"] = "start"
    loads: Literal["python", "compiled"] = "python"
    progress: bool = True

    @model_validator(mode="after")
    def _step_fits(self) -> SimConfig:
        if self.timestep_s > self.duration_s:
            raise ConfigProblem(
                "duration_s",
                f"must be at least one time step, timestep_s = {self.timestep_s} s, got {self.duration_s!r}",
                others=("timestep_s",),
            )
        if self.duration_s / self.timestep_s >= MAX_STEPS:
            raise ConfigProblem(
                "duration_s",
                f"needs duration_s / timestep_s = {self.duration_s / self.timestep_s:.3g} "
                f"steps, more than a 64-bit step counter holds ({MAX_STEPS:.3g}), "
                f"got {self.duration_s!r}",
                others=("timestep_s",),
            )
        if self.load_timing == "stage" and self.loads != "compiled":
            raise ConfigProblem(
                "load_timing",
                "'stage' evaluates the loads at every stage of the integrator, which only loads computed "
                f"inside MuJoCo's step can do: it needs loads = 'compiled', loads = {self.loads!r}, got 'stage'",
                others=("loads",),
            )
        if 0 < self.checkpoint_every_s < self.timestep_s:
            raise ConfigProblem(
                "checkpoint_every_s",
                "must be 0 (never) or at least one time step, "
                f"timestep_s = {self.timestep_s} s, got {self.checkpoint_every_s!r}",
                others=("timestep_s",),
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
    """``v / |v|`` for a field validator; a zero ``v`` is a ``must be a non-zero {what}`` error.

    The norm is computed without overflow (``math.hypot``), so huge finite components are fine."""
    n = math.hypot(*v)
    if not (n > 0 and math.isfinite(n)):
        raise ValueError(f"must be a non-zero {what}")
    return tuple(c / n for c in v)


def finite_product(key: str, *factors: float, what: str, minimum: float = 0.0, others: tuple[str, ...] = ()) -> float:
    """The product of ``factors`` (a quantity derived from several keys, e.g. a node mass), or a
    :class:`ConfigProblem` on ``key`` (and ``others``) when it overflows float64 or is not above
    ``minimum`` (e.g. :data:`MJ_MINVAL` for what MuJoCo receives as a mass or inertia)."""
    value = 1.0
    for f in factors:
        value *= f
    if not math.isfinite(value):
        raise ConfigProblem(key, f"makes the {what} overflow float64", others=others)
    if not value > minimum:
        raise ConfigProblem(key, f"makes the {what} {value:.6g}, which must be > {minimum:g}", others=others)
    return value


def _extremeness(value: Any) -> float:
    """How far a number is from 1 in decades (0 for zero and non-numbers; a vector: its most
    extreme item)."""
    if isinstance(value, (tuple, list)):
        return max(map(_extremeness, value), default=0.0)
    try:
        v = abs(float(value))
    except (TypeError, ValueError):
        return 0.0
    return abs(math.log10(v)) if 0 < v < math.inf else 0.0


def likeliest_key(keys: dict[str, Any]) -> str:
    """Of ``keys`` (key path → value), the one whose value is farthest from 1 in decades: the
    likeliest culprit of a derived quantity out of range, on which a problem is reported."""
    return max(keys, key=lambda k: _extremeness(keys[k]))


def derived_quantity(what: str, *factors: float, keys: dict[str, Any], minimum: float = 0.0) -> float:
    """The product of ``factors``: a quantity the build derives from the config keys ``keys`` (key
    path → value), e.g. a controller gain; a :class:`ConfigProblem` when it overflows float64 or is
    not above ``minimum``. The problem is reported on the key whose value is farthest from 1 (in
    decades: the likeliest culprit) and names every key with its value, e.g.
    ``coil.I_max_A: the B-dot gain k overflows float64 (coil.I_max_A = 1e+300, ...)``."""
    value = 1.0
    for f in factors:
        value *= f
    if math.isfinite(value) and value > minimum:
        return value
    primary = likeliest_key(keys)
    named = ", ".join(f"{k} = {v!r}" for k, v in keys.items())
    problem = "overflows float64" if not math.isfinite(value) else f"is {value:.6g}, which must be > {minimum:g}"
    raise ConfigProblem(primary, f"the {what} {problem} ({named})")


def check_lattice_numbers(
    *,
    units: int,
    side_m: float,
    total_kg: float,
    EI_Nm2: float,
    zeta: float,
    keys: dict[str, str],
    node_mass_fraction: float = 1.0,
) -> None:
    """The numbers MuJoCo receives from a spring–mass lattice config, checked before building.

    ``units`` cubes per side of ``side_m`` [m], two layers of (units + 1)² particles sharing
    ``node_mass_fraction`` × ``total_kg``, strut EA = 2 EI / ((units + 1) w²) with w = side/units,
    dashpot 2 ζ √(k m / 2), visual node spheres of radius 0.04 w carrying the particle mass (so the
    particle inertia 0.4 m (0.04 w)² must exceed :data:`MJ_MINVAL` too). ``keys`` maps ``side``,
    ``mass``, ``EI``, ``zeta`` to the config keys named in a :class:`ConfigProblem`.
    """
    n = units + 1
    w = finite_product(keys["side"], side_m, 1.0 / units, what="cube edge w = side / units")
    m = finite_product(
        keys["mass"],
        total_kg,
        node_mass_fraction / (2 * n * n),
        minimum=MJ_MINVAL,
        what="particle mass (MuJoCo needs > mjMINVAL)",
        others=(keys["side"],),
    )
    finite_product(
        keys["mass"],
        0.4 * m,
        0.04 * w,
        0.04 * w,
        minimum=MJ_MINVAL,
        what="particle inertia 0.4 m (0.04 w)² (MuJoCo needs > mjMINVAL)",
        others=(keys["side"],),
    )
    k = finite_product(
        keys["EI"], 2.0 * EI_Nm2 / n, 1.0 / w, 1.0 / w, 1.0 / w, what="strut stiffness EA / w", others=(keys["side"],)
    )
    finite_product(
        keys["zeta"],
        2.0 * zeta,
        math.sqrt(k) * math.sqrt(m / 2.0),
        minimum=-1.0,
        what="strut damping 2 ζ √(k m / 2)",
        others=(keys["EI"], keys["mass"]),
    )


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


register_concept = register_config
"""Class decorator ``@register_concept(name)``: the concept registry's
:func:`magsail_mj.concepts.register_config` (kept under this name for the concept modules)."""


def concept_models() -> dict[str, type[BaseModel]]:
    """All registered concept schemas, by concept name (discovers the concept packages first)."""
    return config_schemas()


# ------------------------------------------------------------------------ error formatting

_TYPE_MESSAGES = {
    "float_type": "must be a number (not a string or a boolean)",
    "int_type": "must be an integer (not a float, a string or a boolean)",
    "int_from_float": "must be an integer (not a float)",
    "bool_type": "must be true or false (a boolean, not a string or a number)",
    "string_type": "must be a string",
    "finite_number": "must be a finite number",
    "tuple_type": "must be an array",
    "list_type": "must be an array",
    "model_type": "must be a table",
    "model_attributes_type": "must be a table",
    "dict_type": "must be a table",
}
_KEYED = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z0-9_]+|\[\d+\])*): (.*)$", re.DOTALL)
_UNION_TAG = re.compile(r"[\[\]()<>, ]|^(float|int|str|bool|none|list|tuple|dict)$")


def _loc_path(loc: tuple) -> str:
    """``('sim', 'duration_s')`` → ``sim.duration_s``; list indices as ``[i]``; union tags and
    validator names dropped."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        elif not _UNION_TAG.search(str(part)) and not str(part).startswith("function-"):
            out += f".{part}" if out else str(part)
    return out


def _join(loc: str, key: str) -> str:
    return f"{loc}.{key}" if loc else key


def _got(value: Any) -> str:
    return "" if isinstance(value, dict) else f", got {value!r}"


def _bound_message(kind: str, ctx: dict) -> str:
    sign = {"greater_than_equal": ">=", "greater_than": ">", "less_than": "<", "less_than_equal": "<="}[kind]
    bound = next(iter(ctx.values())) if ctx else "?"
    noun = "an integer" if isinstance(bound, int) and not isinstance(bound, bool) else "a number"
    return f"must be {noun} {sign} {bound}"


def _value_error_lines(loc: str, err: dict[str, Any]) -> list[str]:
    """Lines of a validator's ``ValueError``: a :class:`ConfigProblem` names its key under ``loc``;
    a message ``key: text`` (or several joined by ``; ``) is read the same way."""
    exc = (err.get("ctx") or {}).get("error")
    if isinstance(exc, ConfigProblem):
        also = ", ".join(_join(loc, k) for k in exc.others)
        return [f"{_join(loc, exc.key)}: {exc.message}" + (f" (see also {also})" if also else "")]
    msg = str(err.get("msg", "invalid value")).removeprefix("Value error, ")
    parts = msg.split("; ")
    if len(parts) > 1 and all(_KEYED.match(p) for p in parts):
        return [f"{_join(loc, m.group(1))}: {m.group(2)}" for m in map(_KEYED.match, parts)]
    m = _KEYED.match(msg)
    if m:
        return [f"{_join(loc, m.group(1))}: {m.group(2)}"]
    where = f"{loc}: " if loc else ""
    return [f"{where}{msg}" + _got(err.get("input")) if "input" in err else f"{where}{msg}"]


def _format_error(err: dict[str, Any]) -> list[str]:
    """The ``key.path: what is wrong, got value`` line(s) of one pydantic error."""
    loc = _loc_path(tuple(err.get("loc", ())))
    kind = err.get("type", "")
    value = err.get("input")
    ctx = err.get("ctx") or {}
    if kind == "extra_forbidden":
        return [f"{loc}: unknown key (not part of this table){_got(value)}"]
    if kind == "missing":
        raw = tuple(err.get("loc", ()))
        if raw and isinstance(raw[-1], int):
            return [f"{_loc_path(raw[:-1])}: too few items (item [{raw[-1]}] is missing)"]
        return [f"{loc}: required key is missing"]
    if kind == "literal_error":
        return [f"{loc}: must be one of {ctx.get('expected')}{_got(value)}"]
    if kind in ("greater_than_equal", "greater_than", "less_than", "less_than_equal"):
        return [f"{loc}: {_bound_message(kind, ctx)}{_got(value)}"]
    if kind in _TYPE_MESSAGES:
        return [f"{loc}: {_TYPE_MESSAGES[kind]}{_got(value)}"]
    if kind in ("too_short", "too_long"):
        return [f"{loc}: {err.get('msg', 'wrong length')}{_got(value)}"]
    if kind == "value_error":
        return _value_error_lines(loc, err)
    msg = str(err.get("msg", "invalid value")).removeprefix("Value error, ")
    where = f"{loc}: " if loc else ""
    return [f"{where}{msg}{_got(value)}" if "input" in err else f"{where}{msg}"]


def _is_union_error(err: dict[str, Any]) -> bool:
    return any(isinstance(p, str) and _UNION_TAG.search(p) for p in err.get("loc", ()))


def validation_problems(err: ValidationError, *, prefix: str = "") -> list[str]:
    """The ``key.path: what is wrong, got value`` lines of a pydantic ``ValidationError`` raised by
    a :class:`StrictModel`, each key path prefixed with ``prefix`` (e.g. ``"scaling."`` for a table
    validated on its own), formatted as :func:`load_config` reports them."""
    return [f"{prefix}{line}" for line in _problems(err)]


def _problems(err: ValidationError) -> list[str]:
    """Every line of a ValidationError; the failed alternatives of a union key (such as
    ``float | list[float]``) are merged into one ``key: must be ... — or: ...`` line."""
    out: list[str] = []
    unions: dict[str, list[str]] = {}
    for e in err.errors():
        for line in _format_error(e):
            key, _, rest = line.partition(": ")
            if _is_union_error(e):
                if key not in unions:
                    unions[key] = []
                    out.append(key)
                if rest not in unions[key]:
                    unions[key].append(rest)
            elif line not in out:
                out.append(line)
    return [f"{line}: " + " — or: ".join(unions[line]) if line in unions else line for line in out]


# ------------------------------------------------------------------------ loading


def _parse_literal(text: str) -> Any:
    """Parse ``text`` as a TOML value; bare words that are not TOML become strings."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except (tomllib.TOMLDecodeError, RecursionError, ValueError):  # not TOML, nested too deeply, > 4 300 digits
        return text


def _override_problems(
    tree: dict[str, Any], overrides: list[str] | tuple[str, ...]
) -> tuple[dict[str, Any], list[str]]:
    """``tree`` with the well-formed overrides applied, and a line per malformed one."""
    out = copy.deepcopy(tree)
    problems = []
    from_files: dict[int, set[str]] = {}  # per table: the keys the file gave
    spellings: dict[int, dict[str, str]] = {}  # per table: key written → spelling the override used
    for item in overrides:
        if not isinstance(item, str) or "=" not in item:
            problems.append(f"--set {item!r}: must look like key.path=value")
            continue
        key, text = item.split("=", 1)
        parts = [p.strip() for p in key.strip().split(".")]
        if not key.strip() or not all(parts):
            problems.append(f"--set {item!r}: empty key path or empty part in {key.strip()!r}")
            continue
        node = out
        for i, part in enumerate(parts[:-1]):
            child = node.setdefault(part, {})
            if not isinstance(child, dict):
                problems.append(
                    f"--set {item!r}: {'.'.join(parts[: i + 1])} is a value, not a table, "
                    f"so it has no key {parts[i + 1]!r}"
                )
                break
            node = child
        else:
            from_file = from_files.setdefault(id(node), set(node))
            last = _override_key(node, parts[-1], from_file, where=".".join(parts[:-1]))
            spelled = spellings.setdefault(id(node), {}).setdefault(last, parts[-1])
            if spelled != parts[-1]:
                where = ".".join(parts[:-1] + [""])
                problems.append(
                    f"--set {item!r}: {where}{parts[-1]} and {where}{spelled} are the same key (one is its "
                    f"deprecated unit spelling); give it once, as {where}{last}"
                )
                continue
            node[last] = _parse_literal(text.strip())
    return out, problems


def _override_key(node: dict[str, Any], key: str, from_file: set[str], *, where: str) -> str:
    """The key an override of ``key`` writes into the table ``node`` (at path ``where``) whose
    keys ``from_file`` came from the config file: an old unit spelling
    (:func:`magsail_mj.units_grammar.new_name`) whose current spelling the file gives becomes the
    current one, and an old spelling in the file of the current key given here is dropped (the
    override replaces it); each with :func:`warn_deprecated_key`. Both spellings given by the file
    or both by overrides are left for validation to refuse."""
    prefix = f"{where}." if where else ""
    new = new_name(key)
    if new is not None and new in from_file:
        warn_deprecated_key(prefix + key, prefix + new)
        return new
    for old in [k for k in from_file if new_name(k) == key]:
        node.pop(old, None)
        from_file.discard(old)
        warn_deprecated_key(prefix + old, prefix + key)
    return key


def apply_overrides(tree: dict[str, Any], overrides: list[str] | tuple[str, ...]) -> dict[str, Any]:
    """Return a copy of ``tree`` with ``key.path=value`` overrides applied.

    Raises ConfigError naming every override that is not of the form ``a.b=value`` or that goes
    through a value (``sim.duration_s.x=1``). :func:`load_config` instead reports these together
    with the validation problems of the rest.
    """
    out, problems = _override_problems(tree, overrides)
    if problems:
        raise ConfigError(problems)
    return out


def _validate(tree: dict[str, Any]) -> tuple[BaseModel | None, list[str]]:
    """Validate ``tree``; the model, or the problem lines. Any exception a validator raises
    (e.g. an OverflowError) becomes a problem line naming what was validated."""
    models = concept_models()
    concept = tree.get("concept")
    if not isinstance(concept, str) or concept not in models:
        return None, [f"concept: must be one of {sorted(models)}, got {concept!r}"]
    try:
        return models[concept].model_validate(tree), []
    except ValidationError as err:
        return None, _problems(err)
    except (ArithmeticError, TypeError, ValueError, IndexError, KeyError, AttributeError) as err:
        where = _locate_crash(models[concept], tree)
        value = _dig(tree, where)
        shown = f" = {value!r}" if where else ""
        line = (
            f"{where or concept + ' config'}: its validator failed ({type(err).__name__}: {err}) on "
            f"{where or 'the config'}{shown}; check these numbers for extreme magnitudes"
        )
        return None, [line]


def _table_model(annotation: Any) -> type[BaseModel] | None:
    """The config table class in a field annotation (``X`` or ``X | None``), if any."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in typing.get_args(annotation):
        found = _table_model(arg)
        if found is not None:
            return found
    return None


def _locate_crash(model: type[BaseModel], data: dict[str, Any], prefix: str = "") -> str:
    """The dotted path of the deepest table of ``data`` whose own validation raises something
    other than a ValidationError ("" when only the whole config does)."""
    for key, value in data.items():
        sub = _table_model(model.model_fields[key].annotation) if key in model.model_fields else None
        if sub is None or not isinstance(value, dict):
            continue
        try:
            sub.model_validate(value)
        except ValidationError:
            continue
        except Exception:  # noqa: BLE001 - locating the validator that crashed
            return _locate_crash(sub, value, f"{prefix}{key}.") or f"{prefix}{key}"
    return prefix.rstrip(".")


def _dig(tree: dict[str, Any], path: str) -> Any:
    node: Any = tree
    for part in path.split(".") if path else ():
        node = node.get(part) if isinstance(node, dict) else None
    return node


def parse_config(tree: dict[str, Any], *, source: str | None = None) -> BaseModel:
    """Validate a raw config tree against its concept's schema (ConfigError on any problem)."""
    if not isinstance(tree, dict):
        raise ConfigError([f"the config must be a table, got {type(tree).__name__}"], source=source)
    cfg, problems = _validate(tree)
    if problems:
        raise ConfigError(problems, source=source)
    return cfg


def read_toml(path: str | Path) -> dict[str, Any]:
    """The TOML tree of the file at ``path``; :class:`ConfigError` (never another exception) for a
    missing path, a folder, an unreadable, binary, non-UTF-8 or invalid TOML file."""
    return _read_tree(Path(path))


def _read_tree(path: Path) -> dict[str, Any]:
    """The TOML tree of ``path``; ConfigError for a missing path, a folder, an unreadable,
    non-UTF-8 or invalid file."""
    if path.is_dir():
        raise ConfigError([f"config {str(path)!r} is a folder, not a config file"])
    if not path.exists():
        raise ConfigError([f"config file {str(path)!r} does not exist"])
    try:
        raw = path.read_bytes()
    except OSError as err:
        raise ConfigError([f"config file {str(path)!r} cannot be read: {err.strerror or err}"]) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        line = (
            f"config file {str(path)!r} is not UTF-8 text (a binary file?): byte {err.start} "
            f"is {raw[err.start : err.start + 1]!r}"
        )
        raise ConfigError([line]) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ConfigError([f"not valid TOML: {err}"], source=str(path)) from None
    except RecursionError:
        raise ConfigError(["not a config: arrays or tables nested too deeply to read"], source=str(path)) from None
    except ValueError as err:  # e.g. an integer of more than 4 300 digits
        where = next(
            (
                f"line {n}: {line.split('=', 1)[0].strip()!r}: "
                for n, line in enumerate(text.splitlines(), 1)
                if re.search(r"\d{4300}", line)
            ),
            "",
        )
        raise ConfigError([f"not a config: {where}a value cannot be read ({err})"], source=str(path)) from None


def _mark_override_keys(problems: list[str], overrides: list[str] | tuple[str, ...]) -> list[str]:
    """Say which unknown keys came from ``--set``."""
    keys = {item.split("=", 1)[0].strip(): item for item in overrides if isinstance(item, str) and "=" in item}
    out = []
    for line in problems:
        key, _, rest = line.partition(": ")
        given = [item for k, item in keys.items() if k == key or k.startswith(key + ".")]
        if given and rest.startswith("unknown key"):
            line = f"{key}: unknown key given by --set {given[0]!r} (not part of this table)"
        out.append(line)
    return out


def load_config(path: str | Path, overrides: list[str] | tuple[str, ...] = ()) -> BaseModel:
    """Load, override and validate the scenario config at ``path``.

    Malformed overrides and the validation problems of the rest are reported together in one
    :class:`ConfigError`.
    """
    path = Path(path)
    tree = _read_tree(path)
    tree, problems = _override_problems(tree, overrides)
    token = CONFIG_DIR.set(path.parent.absolute())
    try:
        cfg, more = _validate(tree)
    finally:
        CONFIG_DIR.reset(token)
    problems += _mark_override_keys(more, overrides)
    if problems:
        raise ConfigError(problems, source=str(path))
    return cfg


def _canonical_hash(tree: Any) -> str:
    text = json.dumps(tree, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def config_hash(cfg: BaseModel) -> str:
    """SHA-256 of the validated config (canonical JSON): the run's identity in manifests."""
    return _canonical_hash(cfg.model_dump(mode="json"))


def numbers_hash(cfg: BaseModel) -> str:
    """SHA-256 of the validated config's canonical JSON without the presentation keys
    :data:`PRESENTATION_KEYS` (``sim.progress``, ``sim.duration_s``, ``sim.checkpoint_every_s``
    and the whole ``render`` table).

    Two configs with the same ``numbers_hash`` compute the same numbers up to the shorter
    duration, so a checkpoint written under one may be resumed under the other (extending
    ``sim.duration_s`` on resume stays allowed); any other change (a gain, a mass, the time step,
    the seed) changes it.
    """
    return _canonical_hash(numbers_tree(cfg))


def numbers_tree(cfg: BaseModel) -> dict[str, Any]:
    """The validated config as a JSON tree without the presentation keys (what
    :func:`numbers_hash` hashes)."""
    tree = cfg.model_dump(mode="json")
    for key in PRESENTATION_KEYS:
        *parents, last = key.split(".")
        node = tree
        for part in parents:
            node = node.get(part, {}) if isinstance(node, dict) else {}
        if isinstance(node, dict):
            node.pop(last, None)
    return tree
