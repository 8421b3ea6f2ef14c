r"""Detumble laws of one's own: a law written against the typed commands, named by a config.

A *detumble law* is a pure function of one magnetometer sample::

    def my_law(inputs: DetumbleInputs, params: Mapping[str, float]) -> MagneticDipole: ...

``inputs`` holds what the flight computer knows at the sample (:class:`DetumbleInputs`: the time,
the measured field and its rate estimate, the gyro rate, the inertia and the dipole limits, all in
body axes); ``params`` are the config's ``control.bdot_law_params`` (names → numbers, e.g. gains).
The law returns a :class:`~magsail_mj.commands.MagneticDipole`; the controller clips it per axis to
the magnetorquer limits and holds it over the cycle with the blanking window, exactly as it does
the shipped laws' dipoles. Because the law keeps no state between samples, checkpoints and resume
stay bit-identical, and a world of a batch calls it exactly as its single run does.

Once registered under a name, the law runs wherever a shipped law runs, unchanged: a single run
(``control.bdot_law = "<name>"``), a batch of worlds (:mod:`magsail_mj.batch`, the law called per
world at the samples), a sweep or a Monte Carlo (``[grid] "control.bdot_law" = [..., "<name>"]``),
the detumble benchmark and the CNUSAIL dm_control environment (its magnetorquer law).

Two ways to register (the config only ever *names* a law; it never names a module or an attribute):

* in the process: :func:`register_detumble_law` (scripts, notebooks, a batch in the process);
* for every process, the command line and sweep workers included: an entry point of an installed
  package in the group :data:`ENTRY_POINT_GROUP`, e.g. in that package's ``pyproject.toml``::

      [project.entry-points."magsail_mj.detumble_laws"]
      my_law = "my_package.laws:my_law"

  A name that is neither shipped nor registered is refused when the config is read, naming
  ``control.bdot_law`` and the names known.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Callable, Mapping

import numpy as np

from magsail_mj.commands import MagneticDipole

__all__ = [
    "BUILTIN_DETUMBLE_LAWS",
    "ENTRY_POINT_GROUP",
    "DetumbleInputs",
    "DetumbleLaw",
    "register_detumble_law",
    "unregister_detumble_law",
    "detumble_law",
    "detumble_law_names",
    "check_params",
    "plugin_dipole",
]

BUILTIN_DETUMBLE_LAWS = ("proportional", "bang_bang", "b_cross", "non_monotonic")
"""The shipped laws (:mod:`magsail_mj.control.detumble_laws`); no plug-in may take these names."""

ENTRY_POINT_GROUP = "magsail_mj.detumble_laws"
"""The entry-point group in which installed packages declare detumble laws."""

_NAME = re.compile(r"[a-z][a-z0-9_]{0,63}")
_PARAM = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,63}")


@dataclass(frozen=True)
class DetumbleInputs:
    """What a detumble law sees at one magnetorquer sample (body axes, SI units; read-only copies).

    Attributes:
      t_s: the sample time [s] from the start of the run.
      field_body_T: (3,) the magnetometer reading B [T] (with its noise when the config sets one).
      field_rate_body_T_s: (3,) the B-dot estimate Ḃ [T/s] of ``control.bdot_form`` (finite
        difference or filtered; zero at the first sample).
      rate_body_rad_s: (3,) the gyro reading ω [rad/s] (with its noise when set).
      inertia_kgm2: (3, 3) the inertia J [kg m²] the flight software assumes.
      dipole_max_Am2: (3,) the per-axis dipole limits [A m²] (the controller clips to them).
    """

    t_s: float
    field_body_T: np.ndarray
    field_rate_body_T_s: np.ndarray
    rate_body_rad_s: np.ndarray
    inertia_kgm2: np.ndarray
    dipole_max_Am2: np.ndarray


DetumbleLaw = Callable[[DetumbleInputs, Mapping[str, float]], MagneticDipole]
"""A detumble law: ``law(inputs, params) -> MagneticDipole`` (module docstring)."""

_REGISTERED: dict[str, DetumbleLaw] = {}


def _check_name(name: object) -> str:
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise ValueError(f"name: a law name is 1–64 of a–z, 0–9 and _, starting with a letter, got {name!r}")
    if name in BUILTIN_DETUMBLE_LAWS:
        raise ValueError(f"name: {name!r} is a shipped law; choose another name")
    return name


def register_detumble_law(name: str, law: DetumbleLaw, *, replace: bool = False) -> None:
    """Make ``law`` available as ``control.bdot_law = name`` in this process.

    Raises:
      ValueError: ``name`` is malformed or a shipped law's, ``law`` is not callable, or ``name`` is
        taken and ``replace`` is false.
    """
    _check_name(name)
    if not callable(law):
        raise ValueError(f"law: must be callable as law(inputs, params) -> MagneticDipole, got {law!r}")
    if name in _REGISTERED and not replace and _REGISTERED[name] is not law:
        raise ValueError(f"name: {name!r} is registered already (replace=True to replace it)")
    _REGISTERED[name] = law


def unregister_detumble_law(name: str) -> None:
    """Forget the law registered in this process under ``name`` (nothing if there is none)."""
    _REGISTERED.pop(name, None)


def _installed() -> dict[str, object]:
    """The entry points of :data:`ENTRY_POINT_GROUP` by name (well-formed names only)."""
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP) if _NAME.fullmatch(ep.name)}


def detumble_law_names() -> tuple[str, ...]:
    """Every law a config may name: the shipped ones, then the registered and installed plug-ins."""
    extra = sorted((set(_REGISTERED) | set(_installed())) - set(BUILTIN_DETUMBLE_LAWS))
    return BUILTIN_DETUMBLE_LAWS + tuple(extra)


def detumble_law(name: str) -> DetumbleLaw:
    """The plug-in law ``name``: registered in this process, else an installed entry point (loaded
    and registered on first use).

    Raises:
      ValueError: naming ``control.bdot_law`` when ``name`` is shipped (not a plug-in) or unknown,
        or when its entry point does not load to a callable.
    """
    if name in _REGISTERED:
        return _REGISTERED[name]
    if name in BUILTIN_DETUMBLE_LAWS:
        raise ValueError(f"control.bdot_law: {name!r} is a shipped law, not a plug-in")
    ep = _installed().get(name)
    if ep is None:
        raise ValueError(f"control.bdot_law: unknown law {name!r}; known: {', '.join(detumble_law_names())}")
    law = ep.load()  # type: ignore[attr-defined]
    if not callable(law):
        raise ValueError(f"control.bdot_law: the entry point {name!r} does not give a callable law")
    _REGISTERED[name] = law
    return law


def check_params(params: Mapping[str, object], *, key: str | None = None) -> dict[str, float]:
    """``params`` as names → finite floats (a name: a letter, then letters, digits and _, as a
    config key with its unit suffix, e.g. ``gain_Nms``), or ``ValueError`` (its message starting
    with ``key`` when given)."""
    where = f"{key}: " if key else ""
    out: dict[str, float] = {}
    for name, value in params.items():
        if not isinstance(name, str) or not _PARAM.fullmatch(name):
            raise ValueError(f"{where}a parameter name is a letter, then 0–63 letters, digits or _, got {name!r}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ValueError(f"{where}parameter {name!r} must be a finite number, got {value!r}")
        out[name] = float(value)
    return out


def plugin_dipole(
    name: str,
    params: Mapping[str, float],
    *,
    t_s: float,
    field_body_T: np.ndarray,
    field_rate_body_T_s: np.ndarray,
    rate_body_rad_s: np.ndarray,
    inertia_kgm2: np.ndarray,
    dipole_max_Am2: np.ndarray,
) -> np.ndarray:
    """The unsaturated dipole (3,) [A m²] of plug-in law ``name`` at one sample (the controller
    clips it per axis).

    Raises:
      ValueError: the law does not return a :class:`~magsail_mj.commands.MagneticDipole` (naming the
        law; a non-finite dipole is refused by the command itself).
    """
    inputs = DetumbleInputs(
        t_s=float(t_s),
        field_body_T=_frozen(field_body_T, (3,)),
        field_rate_body_T_s=_frozen(field_rate_body_T_s, (3,)),
        rate_body_rad_s=_frozen(rate_body_rad_s, (3,)),
        inertia_kgm2=_frozen(inertia_kgm2, (3, 3)),
        dipole_max_Am2=_frozen(dipole_max_Am2, (3,)),
    )
    command = detumble_law(name)(inputs, dict(params))
    if not isinstance(command, MagneticDipole):
        raise ValueError(
            f"control.bdot_law: law {name!r} returned {type(command).__name__}; a detumble law returns a MagneticDipole"
        )
    return np.array(command.dipole_body_Am2, dtype=float)


def _frozen(value: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    a = np.array(value, dtype=float, copy=True).reshape(shape)
    a.setflags(write=False)
    return a
