"""Verdicts of the claims, computed from the bundled runs: our value against the paper's.

* ``agrees``: our value lies within the tolerance of the paper's number or range, keeps the bound
  of a qualitative claim, or equals its expected value;
* ``differs``: it does not (or the key is ``null``: the event never happened); the claim must carry
  an explanation, else :class:`MissingExplanation`;
* ``failed``: the run's status is not ``completed`` (e.g. ``diverged``, ``structure_failed``), so
  its values are not compared, unless the claim sets ``compare_failed`` and the run stopped as
  ``structure_failed`` (then the values up to the failure are compared);
* ``not run``: the bundle holds no run for the claim (or for the run of its ``ratio_key``).

No verdict is ever assumed: a claim whose run value is missing is *not run*, never *agrees*.
See :class:`magsail_mj.report.registry.Claim` for the comparison rules.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from collections.abc import Mapping
from typing import Any

from magsail_mj.report.registry import Claim

__all__ = [
    "AGREES",
    "DIFFERS",
    "FAILED",
    "NOT_RUN",
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
#: the order of the counts and of the claims on a page: where ours differs first
VERDICTS = (DIFFERS, FAILED, NOT_RUN, AGREES)
COMPLETED = "completed"
STRUCTURE_FAILED = "structure_failed"


class MissingExplanation(ValueError):
    """A claim differs from the paper and its registry entry gives no explanation."""


class MissingKey(KeyError):
    """The claim's summary key is not in the summary of its run."""


@dataclass(frozen=True)
class Verdict:
    """The outcome of one claim: ``verdict`` (one of :data:`VERDICTS`), ``value`` (ours, scaled to
    the claim's unit, or the ratio for a ``ratio_key`` claim; ``None`` when not compared or null),
    ``status`` (the run's status) and, for a ratio, ``numerator``/``denominator`` (the two values)."""

    verdict: str
    value: float | str | None
    status: str | None
    numerator: float | None = None
    denominator: float | None = None


def claim_value(claim: Claim, summary: dict[str, Any], *, denominator: bool = False) -> float | str | None:
    """The claim's summary value (``denominator``: that of ``ratio_key``) times ``claim.scale``
    (``None`` for a null key; a bool as 0/1; a string, e.g. a classification, only for an
    ``expect`` claim).

    Raises :class:`MissingKey` naming the key and the run when the summary lacks it (or the index is
    out of range).
    """
    key, index = (claim.ratio_key, None) if denominator else (claim.key, claim.index)
    run = claim.denominator_run if denominator else claim.run
    if key not in summary:
        raise MissingKey(f"claim {claim.id!r}: summary key {key!r} is not in the summary of run {run!r}")
    raw = summary[key]
    if index is not None:
        if not isinstance(raw, list) or not -len(raw) <= index < len(raw):
            raise MissingKey(f"claim {claim.id!r}: {key}[{index}] is not in the summary of run {run!r}")
        raw = raw[index]
    if raw is None:
        return None
    if isinstance(raw, bool):
        return float(raw)
    if isinstance(raw, str) and (isinstance(claim.expect, str) or claim.expect_not is not None):
        return raw
    if not isinstance(raw, int | float):
        raise MissingKey(f"claim {claim.id!r}: summary key {key!r} of run {run!r} is not a number (got {raw!r})")
    return float(raw) * claim.scale


def within(claim: Claim, value: float) -> bool:
    """Whether ``value`` (in the claim's unit) keeps the claim's number, range or bound.

    With a value (or bound) p and tolerance t: ``abs`` |v − p| ≤ t; ``rel`` |v − p| ≤ t|p|;
    ``max`` v ≤ p + t; ``min`` v ≥ p − t. A range [lo, hi] widens to [lo − t, hi + t] (``rel``:
    t·|lo|, t·|hi|); ``max``/``min`` use hi/lo. A non-finite value is never within.
    """
    if not math.isfinite(value):
        return False
    if claim.paper_range is not None:
        lo, hi = claim.paper_range
    else:
        target = claim.paper_value if claim.paper_value is not None else claim.bound
        if target is None:
            raise ValueError(f"claim {claim.id!r}: an expect claim has no number to be within")
        lo = hi = target
    tol = claim.tolerance
    tol_lo, tol_hi = (tol * abs(lo), tol * abs(hi)) if claim.compare == "rel" else (tol, tol)
    if claim.compare == "max":
        return value <= hi + tol_hi
    if claim.compare == "min":
        return value >= lo - tol_lo
    return lo - tol_lo <= value <= hi + tol_hi


def _status(run: dict[str, Any]) -> str:
    return str(run.get("identity", {}).get("status") or run.get("summary", {}).get("status") or "unknown")


def _compared(claim: Claim, run: dict[str, Any]) -> bool:
    """Whether the run's values count: it completed, or it failed structurally and the claim says so."""
    status = _status(run)
    return status == COMPLETED or (status == STRUCTURE_FAILED and claim.compare_failed)


def judge(claim: Claim, runs: Mapping[str, dict[str, Any]]) -> Verdict:
    """The verdict of ``claim`` from the bundled runs of its paper (``{run id: {"summary": ...,
    "identity": ...}}``; a run absent from it is not run).

    Raises :class:`MissingExplanation` for a claim that differs without an explanation and
    :class:`MissingKey` when a compared run's summary lacks the claim's key.
    """
    run = runs.get(claim.run)
    other = runs.get(claim.denominator_run) if claim.is_ratio else run
    if run is None or other is None:
        return Verdict(NOT_RUN, None, None if run is None else _status(run))
    status = _status(run)
    for item in (run, other):
        if not _compared(claim, item):
            return Verdict(FAILED, None, _status(item))
    value = claim_value(claim, run["summary"])
    numerator = denominator = None
    if claim.is_ratio:
        numerator, denominator = value, claim_value(claim, other["summary"], denominator=True)
        value = _ratio(numerator, denominator)
    if _agrees(claim, value):
        return Verdict(AGREES, value, status, numerator, denominator)
    if not claim.explanation.strip():
        raise MissingExplanation(
            f"claim {claim.id!r} (run {claim.run!r}) differs from the paper ({value!r} against "
            f"{_target_text(claim)}) and its registry entry has no explanation"
        )
    return Verdict(DIFFERS, value, status, numerator, denominator)


def _ratio(numerator: float | str | None, denominator: float | str | None) -> float | None:
    """numerator / denominator, ``None`` when either is not a number (null: the event never happened)."""
    if not isinstance(numerator, float) or not isinstance(denominator, float):
        return None
    if denominator == 0.0:
        return math.copysign(math.inf, numerator) if numerator else math.nan
    return numerator / denominator


def _agrees(claim: Claim, value: float | str | None) -> bool:
    if claim.expect_not is not None:
        return value is not None and value != claim.expect_not
    if claim.expect is not None:
        expected = float(claim.expect) if isinstance(claim.expect, bool) else claim.expect
        return value == expected
    return isinstance(value, float) and within(claim, value)


def _target_text(claim: Claim) -> str:
    if claim.paper_range is not None:
        return f"{list(claim.paper_range)} {claim.unit}".strip()
    if claim.expect is not None:
        return repr(claim.expect)
    if claim.expect_not is not None:
        return f"not {claim.expect_not!r}"
    target = claim.paper_value if claim.paper_value is not None else claim.bound
    return f"{claim.compare} {target} {claim.unit}".strip()
