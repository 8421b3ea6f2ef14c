"""The registry of paper claims: one TOML file per paper in ``magsail_mj/report/claims/``.

A paper file names the paper (``paper``, ``title``, ``citation``, ``bib_label``), the sweep that
produces its runs (``sweep``, a path relative to the repository root), the runs (``[[run]]``: ``id``,
``config`` relative to the repository root, optional ``set`` overrides, optional pinned
``config_hash``, the ``figures`` to keep and an optional ``clip``) and the claims (``[[claim]]``).

Every claim has a short ``title`` (the claim in a few words, for the table), says where the paper
states it (``paper_ref``: figure, table, equation or section), what it states (``paper_says``: its
words, with its numbers and units), whether the paper's abstract makes it (``headline``), and what we
compute (``quantity``: one summary ``key`` of one ``run``, times ``scale``, optionally element
``index`` of a list; with ``ratio_key`` the ratio of that value to the value of ``ratio_key`` in
``ratio_run``, by default the same run). Each claim is checked against exactly one of

* ``paper_value`` or ``paper_range`` ``[low, high]``: a number the paper states (``paper_says`` must
  hold it), compared by ``compare`` within ``tolerance``, fixed before comparing and justified in
  ``tolerance_why``: ``"abs"`` |ours − paper| ≤ tolerance (in the claim's unit), ``"rel"``
  |ours − paper| ≤ tolerance·|paper|, ``"max"`` ours ≤ paper + tolerance (the paper's value is an
  upper bound), ``"min"`` ours ≥ paper − tolerance;
* ``bound`` (a *qualitative* claim: the paper states no number): a bound our value must keep so
  that the paper's statement holds, e.g. "reaches its target" as a final error of at most 5°
  (``compare = "max"``), or a value it must match within ``tolerance`` (``"abs"``, ``"rel"``);
  ``criterion_why`` says where in the paper's figure or text the bound comes from;
* ``expect``: a value the run must report (a classification such as ``"collapsed"``, or a flag), also
  qualitative, with ``criterion_why``;
* ``expect_not``: a classification the run must not report (e.g. "does not collapse": any class but
  ``"collapsed"``), qualitative, with ``criterion_why``.

A run that stopped as ``structure_failed`` is only compared when ``compare_failed`` is set: when the
paper's claim is about the structure giving way, the values up to the failure are the outcome.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

__all__ = [
    "CLAIMS_DIR",
    "TITLE_MAX_CHARS",
    "REPO_ROOT",
    "Claim",
    "Paper",
    "RegistryError",
    "RunSpec",
    "load_paper",
    "load_registry",
]

CLAIMS_DIR = Path(__file__).resolve().parent / "claims"
REPO_ROOT = Path(__file__).resolve().parents[2]

Compare = Literal["abs", "rel", "max", "min"]
#: the longest claim title (the claim column of the compact table)
TITLE_MAX_CHARS = 90


class RegistryError(ValueError):
    """A claims file is malformed (the message names the file and the key)."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class RunSpec(_Strict):
    """One run a paper's claims need: the bundle folder ``results/<paper>/<id>/``."""

    id: str = Field(pattern=r"^[a-z0-9_]+(/[a-z0-9_]+)?$")
    config: str
    set: tuple[str, ...] = ()
    config_hash: str | None = None
    figures: tuple[str, ...] = ()
    clip: str | None = None
    note: str = ""


class Claim(_Strict):
    """One comparison of our summary value with what the paper states (module docstring)."""

    id: str = Field(pattern=r"^[a-z0-9_]+$")
    title: str = Field(min_length=1, max_length=TITLE_MAX_CHARS)
    paper_ref: str = Field(min_length=1)
    paper_says: str = Field(min_length=1)
    #: the paper's abstract makes this claim (the page marks it and counts the headline claims apart)
    headline: bool = False
    quantity: str = Field(min_length=1)
    run: str
    key: str
    index: int | None = None
    scale: float = 1.0
    unit: str = ""
    ratio_key: str | None = None
    ratio_run: str | None = None
    paper_value: float | None = None
    paper_range: tuple[float, float] | None = None
    bound: float | None = None
    expect: str | bool | None = None
    expect_not: str | None = None
    compare: Compare = "abs"
    tolerance: float = Field(default=0.0, ge=0.0)
    tolerance_why: str = ""
    criterion_why: str = ""
    compare_failed: bool = False
    figure: str | None = None
    explanation: str = ""

    @model_validator(mode="after")
    def _one_target(self) -> Claim:
        """Exactly one of paper_value, paper_range, bound, expect, expect_not, each with its reason."""
        targets = ("paper_value", "paper_range", "bound", "expect", "expect_not")
        given = [n for n in targets if getattr(self, n) is not None]
        if len(given) != 1:
            raise ValueError(f"give exactly one of {', '.join(targets)} (got {given or 'none'})")
        if self.paper_range is not None and self.paper_range[0] > self.paper_range[1]:
            raise ValueError(f"paper_range {list(self.paper_range)} is not [low, high]")
        if self.numeric:
            if not self.tolerance_why.strip():
                raise ValueError("a number of the paper needs tolerance_why (the reason for the tolerance)")
            if not any(ch.isdigit() for ch in self.paper_says):
                raise ValueError(f"paper_says states no number for paper_value/paper_range: {self.paper_says!r}")
        elif not self.criterion_why.strip():
            raise ValueError("a qualitative claim (bound or expect) needs criterion_why (where the bound comes from)")
        if self.matches_value and (self.ratio_key is not None or self.tolerance):
            raise ValueError("expect and expect_not compare a value as it is: no ratio_key, no tolerance")
        if self.ratio_run is not None and self.ratio_key is None:
            raise ValueError("ratio_run names the run of ratio_key: give ratio_key")
        return self

    @property
    def is_ratio(self) -> bool:
        """Whether ours is the ratio of ``key`` to ``ratio_key`` (of ``ratio_run``)."""
        return self.ratio_key is not None

    @property
    def denominator_run(self) -> str:
        """The run of ``ratio_key``: ``ratio_run``, by default the claim's own run."""
        return self.ratio_run or self.run

    @property
    def matches_value(self) -> bool:
        """Whether ours is compared as a value (``expect`` or ``expect_not``), not as a number."""
        return self.expect is not None or self.expect_not is not None

    @property
    def numeric(self) -> bool:
        """Whether the paper states the number compared with (``paper_value`` or ``paper_range``)."""
        return self.paper_value is not None or self.paper_range is not None

    @property
    def qualitative(self) -> bool:
        """Whether the paper states no number: ours keeps a ``bound``, an ``expect`` or an ``expect_not``."""
        return not self.numeric


class Paper(_Strict):
    """One paper: its runs and its claims."""

    paper: str = Field(pattern=r"^[a-z0-9_]+$")
    title: str
    citation: str
    bib_label: str
    sweep: str
    summary: str = ""
    notes: str = ""
    run: tuple[RunSpec, ...]
    claim: tuple[Claim, ...]

    @field_validator("claim")
    @classmethod
    def _unique_claims(cls, claims: tuple[Claim, ...]) -> tuple[Claim, ...]:
        ids = [c.id for c in claims]
        dup = sorted({i for i in ids if ids.count(i) > 1})
        if dup:
            raise ValueError(f"duplicate claim ids {dup}")
        return claims

    @model_validator(mode="after")
    def _claims_name_runs(self) -> Paper:
        runs = [r.id for r in self.run]
        dup = sorted({i for i in runs if runs.count(i) > 1})
        if dup:
            raise ValueError(f"duplicate run ids {dup}")
        for c in self.claim:
            for field, run in (("run", c.run), ("ratio_run", c.denominator_run)):
                if run not in runs:
                    raise ValueError(f"claim {c.id!r}: {field} {run!r} is not one of the [[run]] ids {runs}")
        return self

    def claim_by_id(self, claim_id: str) -> Claim:
        """The claim ``claim_id`` (KeyError naming it when absent)."""
        for c in self.claim:
            if c.id == claim_id:
                return c
        raise KeyError(f"paper {self.paper!r} has no claim {claim_id!r}")

    def run_spec(self, run_id: str) -> RunSpec:
        """The ``[[run]]`` entry ``run_id`` (KeyError naming it when absent)."""
        for r in self.run:
            if r.id == run_id:
                return r
        raise KeyError(f"paper {self.paper!r} has no run {run_id!r}")


def load_paper(path: str | Path) -> Paper:
    """Read and validate one claims file; :class:`RegistryError` names the file and the problem."""
    path = Path(path)
    try:
        tree = tomllib.loads(path.read_text(encoding="utf-8"))
        return Paper.model_validate(tree)
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise RegistryError(f"{path}: {err}") from err
    except ValidationError as err:
        lines = [f"{'.'.join(str(p) for p in e['loc'])}: {e['msg']}" for e in err.errors()]
        raise RegistryError(f"{path}: " + "; ".join(lines)) from err


def load_registry(claims_dir: str | Path = CLAIMS_DIR) -> dict[str, Paper]:
    """Every ``*.toml`` of ``claims_dir`` as ``{paper id: Paper}``, sorted by file name."""
    papers: dict[str, Paper] = {}
    for path in sorted(Path(claims_dir).glob("*.toml")):
        paper = load_paper(path)
        if paper.paper in papers:
            raise RegistryError(f"{path}: paper id {paper.paper!r} is used twice")
        papers[paper.paper] = paper
    if not papers:
        raise RegistryError(f"{claims_dir}: no claims files (*.toml)")
    return papers
