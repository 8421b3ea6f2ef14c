"""Write a tree of tables, arrays and numbers as TOML that :mod:`tomllib` reads back exactly.

The subset needed by the structure file: a table's plain values (strings, booleans, integers,
floats, NumPy arrays and lists of them, inline tables) come first, then its sub-tables
(``[a.b]``) and arrays of tables (``[[a]]``). Floats are written as Python's shortest
round-trip ``repr`` (``inf`` and ``nan`` as TOML spells them), so every float64 reads back to the
same bits (apart from a NaN's sign and payload). Arrays of more than one dimension are written one
row per line.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping

import numpy as np

__all__ = ["Inline", "dumps"]

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")
_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


class Inline(dict):
    """A mapping written as an inline table ``{ k = v }`` rather than as a ``[section]``."""


def _string(text: str) -> str:
    out = []
    for char in text:
        if char in _ESCAPES:
            out.append(_ESCAPES[char])
        elif ord(char) < 0x20 or ord(char) == 0x7F:
            out.append(f"\\u{ord(char):04x}")
        else:
            out.append(char)
    return '"' + "".join(out) + '"'


def _key(name: str) -> str:
    return name if _BARE_KEY.match(name) else _string(name)


def _float(value: float) -> str:
    if math.isnan(value):
        return "nan"
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    text = repr(float(value))
    return text if any(c in text for c in ".en") else text + ".0"


def _scalar(value: object) -> str:
    if isinstance(value, bool | np.bool_):
        return "true" if value else "false"
    if isinstance(value, int | np.integer):
        return str(int(value))
    if isinstance(value, float | np.floating):
        return _float(float(value))
    if isinstance(value, str):
        return _string(value)
    raise TypeError(f"value: cannot be written as TOML, got {type(value).__name__}")


def _value(value: object, indent: str = "") -> str:
    """``value`` as one TOML value (arrays of rows over several lines)."""
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{_key(k)} = {_value(v)}" for k, v in value.items()) + " }"
    if isinstance(value, np.ndarray):
        if value.ndim == 0:
            return _scalar(value[()])
        value = list(value)
    if isinstance(value, list | tuple):
        if value and isinstance(value[0], np.ndarray | list | tuple):
            inner = indent + "  "
            rows = ",\n".join(inner + _value(row, inner) for row in value)
            return "[\n" + rows + ",\n" + indent + "]"
        return "[" + ", ".join(_value(item) for item in value) + "]"
    return _scalar(value)


def _is_table(value: object) -> bool:
    return isinstance(value, Mapping) and not isinstance(value, Inline)


def _is_table_array(value: object) -> bool:
    return isinstance(value, list) and bool(value) and all(_is_table(item) for item in value)


def _table(tree: Mapping, path: list[str], lines: list[str]) -> None:
    for name, value in tree.items():
        if not _is_table(value) and not _is_table_array(value):
            lines.append(f"{_key(name)} = {_value(value)}")
    for name, value in tree.items():
        here = [*path, _key(name)]
        if _is_table(value):
            lines += ["", f"[{'.'.join(here)}]"]
            _table(value, here, lines)
        elif _is_table_array(value):
            for item in value:
                lines += ["", f"[[{'.'.join(here)}]]"]
                _table(item, here, lines)


def dumps(tree: Mapping) -> str:
    """The TOML text of ``tree`` (a mapping; nested plain mappings become tables, lists of them
    arrays of tables, :class:`Inline` mappings inline tables)."""
    lines: list[str] = []
    _table(tree, [], lines)
    return "\n".join(lines).lstrip("\n") + "\n"
