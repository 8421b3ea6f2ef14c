"""Verdicts of the claims: our summary value against the paper's, within the claim's tolerance.

* ``agrees``: the run completed and its value lies within the tolerance of the paper's value or
  range (see :class:`magsail_mj.report.registry.Claim` for the four comparison rules);
* ``differs``: the run completed and its value lies outside (or the key is ``null``: the event
  never happened); the claim must carry an explanation, else :class:`MissingExplanation`;
* ``failed``: the run's status is not ``completed`` (e.g. ``diverged``, ``structure_failed``):
  its value is never compared;
* ``not run``: the bundle holds no run for the claim;
* ``qualitative``: the paper states no number; our value is shown next to its statement.

A *relational* claim (``relation``/``than``) turns a statement without numbers into a check: our
value must be less (greater) than ``factor`` times our value of another claim; it agrees or
differs like a numeric claim, and is ``failed`` or ``not run`` when either run is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from magsail_mj.report.registry import Claim

__all__ = [
    "AGREES",
    "DIFFERS",
    "FAILED",
    "NOT_RUN",
    "QUALITATIVE",
    "VERDICTS",
    "MissingExplanation",
    "MissingKey",
    "Verdict",
    "claim_value",
    "judge",
    "within",
]

AGREES = "agrees"
DIFFERS = "differs"
FAILED = "failed"
NOT_RUN = "not run"
QUALITATIVE = "qualitative"
VERDICTS = (AGREES, DIFFERS, FAILED, NOT_RUN, QUALITATIVE)
COMPLETED = "completed"


class MissingExplanation(ValueError):
    """A claim differs from the paper and its registry entry gives no explanation."""


class MissingKey(KeyError):
    """The claim's summary key is not in the summary of its run."""


@dataclass(frozen=True)
class Verdict:
    """The outcome of one claim: ``verdict`` (one of :data:`VERDICTS`), ``value`` (ours, scaled to
    the claim's unit; ``None`` when not compared or null) and ``status`` (the run's status)."""

    verdict: str
    value: float | str | None
    status: str | None
    than_value: float | None = None


def claim_value(claim: Claim, summary: dict[str, Any]) -> float | str | None:
    """The claim's summary value times ``claim.scale`` (``None`` for a null key; a bool as 0/1; a
    string, e.g. a classification, only for a qualitative claim).

    Raises :class:`MissingKey` naming the key when the summary lacks it (or the index is out of range).
    """
    if claim.key not in summary:
        raise MissingKey(f"claim {claim.id!r}: summary key {claim.key!r} is not in the summary of run {claim.run!r}")
    raw = summary[claim.key]
    if claim.index is not None:
        if not isinstance(raw, list) or not -len(raw) <= claim.index < len(raw):
            raise MissingKey(
                f"claim {claim.id!r}: {claim.key}[{claim.index}] is not in the summary of run {claim.run!r}"
            )
        raw = raw[claim.index]
    if raw is None:
        return None
    if isinstance(raw, bool):
        return float(raw)
    if isinstance(raw, str) and not claim.numeric:
        return raw
    if not isinstance(raw, int | float):
        raise MissingKey(f"claim {claim.id!r}: summary key {claim.key!r} is not a number (got {raw!r})")
    return float(raw) * claim.scale


def within(claim: Claim, value: float) -> bool:
    """Whether ``value`` (in the claim's unit) is within the tolerance of the paper's number or range.

    With a value p and tolerance t: ``abs`` |v − p| ≤ t; ``rel`` |v − p| ≤ t|p|; ``max`` v ≤ p + t;
    ``min`` v ≥ p − t. A range [lo, hi] widens to [lo − t, hi + t] (``rel``: t·|lo|, t·|hi|);
    ``max``/``min`` use hi/lo. A non-finite value is never within.
    """
    if not math.isfinite(value):
        return False
    tol = float(claim.tolerance or 0.0)
    lo, hi = claim.paper_range if claim.paper_range is not None else (claim.paper_value, claim.paper_value)
    assert lo is not None and hi is not None
    tol_lo, tol_hi = (tol * abs(lo), tol * abs(hi)) if claim.compare == "rel" else (tol, tol)
    if claim.compare == "max":
        return value <= hi + tol_hi
    if claim.compare == "min":
        return value >= lo - tol_lo
    return lo - tol_lo <= value <= hi + tol_hi


def _status(run: dict[str, Any]) -> str:
    return str(run.get("identity", {}).get("status") or run.get("summary", {}).get("status") or "unknown")


def judge(
    claim: Claim, run: dict[str, Any] | None, *, than: tuple[Claim, dict[str, Any] | None] | None = None
) -> Verdict:
    """The verdict of ``claim`` given its bundled run (``{"summary": ..., "identity": ...}``, or None);
    a relational claim also needs ``than``: the claim it names and that claim's run.

    Raises :class:`MissingExplanation` for a claim that differs without an explanation,
    :class:`MissingKey` when a completed run's summary lacks the claim's key, and ``ValueError``
    for a relational claim judged without ``than``.
    """
    if run is None:
        return Verdict(NOT_RUN, None, None)
    status = _status(run)
    if status != COMPLETED:
        return Verdict(FAILED, None, status)
    value = claim_value(claim, run["summary"])
    if claim.relational:
        return _judge_relation(claim, value, status, than)
    if not claim.numeric:
        return Verdict(QUALITATIVE, value, status)
    if isinstance(value, float) and within(claim, value):
        return Verdict(AGREES, value, status)
    _require_explanation(
        claim,
        f"from the paper ({value} against "
        f"{claim.paper_value if claim.paper_range is None else list(claim.paper_range)} {claim.unit})",
    )
    return Verdict(DIFFERS, value, status)


def _judge_relation(
    claim: Claim, value: float | str | None, status: str, than: tuple[Claim, dict[str, Any] | None] | None
) -> Verdict:
    """``value`` against ``factor`` × the other claim's value (see the module docs)."""
    if than is None or than[0].id != claim.than:
        raise ValueError(f"claim {claim.id!r}: a relational claim is judged with its claim {claim.than!r}")
    other, other_run = than
    if other_run is None:
        return Verdict(NOT_RUN, value, status)
    if _status(other_run) != COMPLETED:
        return Verdict(FAILED, value, f"{_status(other_run)} (run {other.run!r} of claim {other.id!r})")
    other_value = claim_value(other, other_run["summary"])
    numbers = isinstance(value, float) and isinstance(other_value, float)
    if numbers and math.isfinite(value) and math.isfinite(other_value):
        bound = claim.factor * other_value
        if (value < bound) if claim.relation == "less" else (value > bound):
            return Verdict(AGREES, value, status, other_value)
    _require_explanation(
        claim, f"from the paper's relation ({value} is not {claim.relation} than {claim.factor:g} × {other_value})"
    )
    return Verdict(DIFFERS, value, status, other_value if isinstance(other_value, float) else None)


def _require_explanation(claim: Claim, what: str) -> None:
    if not claim.explanation.strip():
        raise MissingExplanation(
            f"claim {claim.id!r} (run {claim.run!r}) differs {what} and its registry entry has no explanation"
        )
