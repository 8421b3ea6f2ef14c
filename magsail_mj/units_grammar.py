"""The unit-suffix grammar of names (config keys, summary keys, record names, variables).

A name that carries a unit ends in a *unit suffix*: a numerator group followed by zero or more
denominator groups, each group introduced by ``_``, so ``_`` reads "per" after the first group.
Inside a group the unit symbols are concatenated, each with its power as trailing digits:

* ``omega_rad_s`` = rad/s, ``accel_m_s2`` = m/s², ``density_kg_m3`` = kg/m³, ``flux_W_m2`` = W/m²;
* ``torque_Nm`` = N·m, ``h_Nms`` = N·m·s, ``EI_Nm2`` = N·m², ``inertia_kgm2`` = kg·m²,
  ``dipole_Am2`` = A·m²;
* ``stiffness_N_m`` = N/m, ``areal_density_kg_m2`` = kg/m², ``K_M_Nm_A`` = N·m/A,
  ``damping_Ns_m`` = N·s/m, ``gain_Am2s_T`` = A·m²·s/T, ``kappa_Am2_kg`` = A·m²/kg;
* a reciprocal unit has no numerator symbols and is spelled ``per_<group>``: ``alpha_per_K`` = 1/K,
  ``rate_per_s`` = 1/s.

Symbols are written as in SI (case matters: ``N``, ``Pa``, ``Hz``), with ASCII ``u`` for µ and
``ohm`` for Ω. Base symbols (:data:`BASE_SYMBOLS`) may be multiplied inside a group; a prefixed or
named symbol (:data:`WHOLE_SYMBOLS`: ``km``, ``ms``, ``mT``, ``nT``, ``uT``, ``days`` …) stands alone
in its group, so ``Nms`` is always N·m·s and never N·ms. A dimensionless quantity has no suffix.

The spellings this grammar replaced are listed in :data:`RENAMED_SUFFIXES` (old suffix → new
suffix); :data:`KEPT_NAMES` are the names whose old-looking suffix already meant what the grammar
says (a stiffness in N/m, a pressure in N/m², an areal density in kg/m²). Config keys renamed by it
keep their old spelling as a deprecated alias until :data:`ALIAS_REMOVAL_VERSION`
(:func:`old_spellings`, used by :class:`magsail_mj.config.StrictModel`).
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass

__all__ = [
    "ALIAS_REMOVAL_VERSION",
    "BASE_SYMBOLS",
    "KEPT_NAMES",
    "RENAMED_SUFFIXES",
    "WHOLE_SYMBOLS",
    "Unit",
    "deprecated_aliases",
    "new_name",
    "old_spellings",
    "parse_group",
    "split_unit",
    "unit_label",
]

ALIAS_REMOVAL_VERSION = "0.3.0"
"""The magsail_mj version from which the deprecated config spellings are no longer accepted."""

BASE_SYMBOLS: dict[str, str] = {
    "kg": "kg",
    "m": "m",
    "s": "s",
    "A": "A",
    "K": "K",
    "N": "N",
    "J": "J",
    "W": "W",
    "V": "V",
    "C": "C",
    "T": "T",
    "H": "H",
    "Pa": "Pa",
    "Hz": "Hz",
    "ohm": "Ω",
    "rad": "rad",
    "deg": "deg",
}
"""Unit symbols that may be multiplied inside a group (``Nms``, ``kgm2``, ``Am2s``), and their
printed form."""

WHOLE_SYMBOLS: dict[str, str] = {
    "g": "g",
    "h": "h",
    "km": "km",
    "mm": "mm",
    "um": "µm",
    "ms": "ms",
    "us": "µs",
    "ns": "ns",
    "mA": "mA",
    "mT": "mT",
    "nT": "nT",
    "uT": "µT",
    "kN": "kN",
    "mN": "mN",
    "kW": "kW",
    "MPa": "MPa",
    "GPa": "GPa",
    "days": "days",
    "yr": "yr",
    "AU": "AU",
    "rpm": "rpm",
    "sfu": "sfu",
}
"""Prefixed or named symbols: each stands alone in its group (with an optional power)."""

RENAMED_SUFFIXES: tuple[tuple[str, str], ...] = (
    ("_N_m_s_per_s", "_Nms_s"),
    ("_N_m_per_A_T", "_Nm_AT"),
    ("_A_m2_s_T", "_Am2s_T"),
    ("_Am2_per_kg", "_Am2_kg"),
    ("_Nms_per_T2", "_Nms_T2"),
    ("_V_s_rad", "_Vs_rad"),
    ("_m_per_s", "_m_s"),
    ("_N_m_s", "_Nms"),
    ("_N_m_A", "_Nm_A"),
    ("_N_s_m", "_Ns_m"),
    ("_ohm_m", "_ohmm"),
    ("_kg_m2", "_kgm2"),
    ("_N_m2", "_Nm2"),
    ("_A_m2", "_Am2"),
    ("_N_m", "_Nm"),
)
"""Old suffix → suffix in the grammar, longest old suffix first (the first that ends a name wins)."""

KEPT_NAMES: frozenset[str] = frozenset(
    {
        "slide_stiffness_N_m",  # a spring stiffness: N/m
        "srp_pressure_N_m2",  # radiation pressure: N/m²
        "pressure_N_m2",
        "areal_density_kg_m2",  # mass per area: kg/m²
        "sigmas_kg_m2",  # areal densities: kg/m²
        "B_vs_N_m",  # a CSV column: the Case B side [m] against the count N
    }
)
"""Names that end in an old-looking suffix whose grammar reading is the intended unit."""

_POWER = re.compile(r"^(?P<sym>.*?)(?P<pow>[1-9][0-9]*)?$")
_BASE_BY_LENGTH = sorted(BASE_SYMBOLS, key=len, reverse=True)
_SUPERSCRIPT = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")


@dataclass(frozen=True)
class Unit:
    """A parsed unit suffix: ``numerator`` and ``denominator`` as ``(symbol, power)`` tuples, one
    tuple per group (``kg_m3`` → numerator ``(("kg", 1),)``, denominators ``(("m", 3),)``)."""

    numerator: tuple[tuple[str, int], ...]
    denominators: tuple[tuple[tuple[str, int], ...], ...]

    def label(self, *, product: str = "·") -> str:
        """The printed unit: the factors of a product joined by ``product``, powers as
        superscripts, one ``/`` per denominator group, a group of several factors in parentheses
        (``N·m/A``, ``kg/m³``, ``1/K``, ``A·m²·s/T``, ``1/(N·m·s)``; with ``product=" "``:
        ``N m s``)."""
        top = _group_label(self.numerator, product) if self.numerator else "1"
        return top + "".join(
            "/" + (f"({_group_label(g, product)})" if len(g) > 1 else _group_label(g, product))
            for g in self.denominators
        )


def _group_label(group: tuple[tuple[str, int], ...], product: str) -> str:
    names = {**BASE_SYMBOLS, **WHOLE_SYMBOLS}
    return product.join(names[s] + (str(p).translate(_SUPERSCRIPT) if p != 1 else "") for s, p in group)


def _split_power(text: str) -> tuple[str, int]:
    m = _POWER.match(text)
    return m.group("sym"), int(m.group("pow") or 1)


def parse_group(text: str) -> tuple[tuple[str, int], ...] | None:
    """The ``(symbol, power)`` factors of one group (``Nms`` → N, m, s; ``kgm2`` → kg, m²; ``uT``
    → µT), or None when ``text`` is not a group of the grammar."""
    sym, power = _split_power(text)
    if sym in WHOLE_SYMBOLS:
        return ((sym, power),)
    out: list[tuple[str, int]] = []
    rest = text
    while rest:
        sym = next((s for s in _BASE_BY_LENGTH if rest.startswith(s)), None)
        if sym is None:
            return None
        rest = rest[len(sym) :]
        digits = re.match(r"[1-9][0-9]*", rest)
        power = int(digits.group()) if digits else 1
        rest = rest[digits.end() :] if digits else rest
        out.append((sym, power))
    return tuple(out) or None


def _parse_suffix(parts: list[str]) -> Unit | None:
    """The unit of the ``_``-separated suffix ``parts``, or None when they are not a suffix."""
    if not parts:
        return None
    if parts[0] == "per":
        if len(parts) < 2:
            return None
        numerator: tuple[tuple[str, int], ...] = ()
    else:
        first = parse_group(parts[0])
        if first is None:
            return None
        numerator = first
    denominators = []
    for part in parts[1:]:
        group = parse_group(part)
        if group is None:
            return None
        denominators.append(group)
    return Unit(numerator, tuple(denominators))


def split_unit(name: str) -> tuple[str, Unit | None]:
    """``(quantity, unit)`` of ``name``: the longest ``_``-separated tail that is a unit suffix
    and leaves a non-empty quantity (``omega_body_rad_s`` → ``("omega_body", rad/s)``); a name
    without a suffix gives ``(name, None)``."""
    parts = name.split("_")
    for k in range(1, len(parts)):
        stem = "_".join(parts[:k])
        unit = _parse_suffix(parts[k:]) if stem.strip("_") else None
        if unit is not None:
            return stem, unit
    return name, None


def unit_label(name: str, *, product: str = "·") -> str:
    """The printed unit of ``name`` from its suffix (``EI_Nm2`` → ``N·m²``; see
    :meth:`Unit.label` for ``product``), ``""`` without one."""
    _, unit = split_unit(name)
    return unit.label(product=product) if unit is not None else ""


def new_name(old: str) -> str | None:
    """The grammar's spelling of ``old`` when its suffix is one of :data:`RENAMED_SUFFIXES`
    (``torque_max_N_m`` → ``torque_max_Nm``), else None (also for :data:`KEPT_NAMES`)."""
    if old in KEPT_NAMES:
        return None
    for before, after in RENAMED_SUFFIXES:
        if old.endswith(before) and len(old) > len(before):
            return old[: -len(before)] + after
    return None


def old_spellings(name: str) -> tuple[str, ...]:
    """The old spellings that :func:`new_name` maps onto ``name`` (``kappa_Am2_kg`` →
    ``("kappa_Am2_per_kg",)``); empty for a name no rename produced."""
    found = []
    for before, after in RENAMED_SUFFIXES:
        if name.endswith(after) and len(name) > len(after):
            old = name[: -len(after)] + before
            if new_name(old) == name:
                found.append(old)
    return tuple(dict.fromkeys(found))


@functools.cache
def deprecated_aliases(fields: tuple[str, ...]) -> dict[str, str]:
    """Old spelling → current key, for the keys ``fields`` of one config table (an old spelling
    that is itself a key of the table is left out). Cached: do not modify the returned dict."""
    current = set(fields)
    return {old: f for f in fields for old in old_spellings(f) if old not in current}
