"""Argument checks shared by the parameter dataclasses: each error names the attribute and its value."""

from __future__ import annotations

from typing import Any, Iterable

__all__ = ["require_non_negative", "require_positive"]


def require_positive(obj: Any, names: Iterable[str]) -> None:
    """Raise ``ValueError("<name>: must be > 0, got <value>")`` for the first attribute of ``obj``
    in ``names`` that is not ``> 0`` (NaN included)."""
    for name in names:
        value = getattr(obj, name)
        if not value > 0:
            raise ValueError(f"{name}: must be > 0, got {value!r}")


def require_non_negative(obj: Any, names: Iterable[str]) -> None:
    """Raise ``ValueError("<name>: must be >= 0, got <value>")`` for the first attribute of ``obj``
    in ``names`` that is not ``>= 0`` (NaN included)."""
    for name in names:
        value = getattr(obj, name)
        if not value >= 0:
            raise ValueError(f"{name}: must be >= 0, got {value!r}")
