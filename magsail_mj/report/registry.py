"""The registry of paper claims: one TOML file per paper in ``magsail_mj/report/claims/``.

A paper file names the paper (``paper``, ``title``, ``citation``, ``bib_label``), the sweep that
produces its runs (``sweep``, a path relative to the repository root), the runs (``[[run]]``: ``id``,
``config`` relative to the repository root, optional ``set`` overrides, optional pinned
``config_hash``, the ``figures`` to keep and an optional ``clip``) and the claims (``[[claim]]``).

A claim compares one summary key of one run with the paper: ``paper_value`` (a number),
``paper_range`` (``[low, high]``) or only ``paper_statement`` (a qualitative claim). ``compare``
says how a number is compared: ``"abs"`` (|ours − paper| ≤ tolerance, in the claim's unit),
``"rel"`` (|ours − paper| ≤ tolerance·|paper|), ``"max"`` (ours ≤ paper + tolerance: the paper's
value is an upper bound or requirement) or ``"min"`` (ours ≥ paper − tolerance). The summary
value is multiplied by ``scale`` (e.g. 57.29577951308232 for rad → deg) before it is compared or
shown; ``index`` picks one element of a list-valued key.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

__all__ = [
    "CLAIMS_DIR",
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
    """One comparison of our summary key with the paper's figure, table or text."""

    id: str = Field(pattern=r"^[a-z0-9_]+$")
    paper_ref: str
    quantity: str
    #: the paper's abstract makes this claim (the page marks it and counts the headline claims apart)
    headline: bool = False
    run: str
    key: str
    index: int | None = None
    scale: float = 1.0
    unit: str = ""
    paper_value: float | None = None
    paper_range: tuple[float, float] | None = None
    paper_statement: str = ""
    compare: Compare = "abs"
    tolerance: float | None = Field(default=None, ge=0.0)
    tolerance_why: str = ""
    figure: str | None = None
    explanation: str = ""
    #: a relation the paper states without numbers: our value is ``"less"`` or ``"greater"`` than
    #: ``factor`` times our value of the claim ``than`` (same paper), e.g. the distributed torque's
    #: σ_SD less than the central torque's
    relation: Literal["less", "greater"] | None = None
    than: str | None = None
    factor: float = Field(default=1.0, gt=0.0)

    @model_validator(mode="after")
    def _numbers_or_statement(self) -> Claim:
        """A number needs a tolerance and its justification; a claim without one needs a statement."""
        if self.paper_value is not None and self.paper_range is not None:
            raise ValueError("give paper_value or paper_range, not both")
        numeric = self.paper_value is not None or self.paper_range is not None
        if (self.relation is None) != (self.than is None):
            raise ValueError("relation and than go together")
        if self.relation is not None and numeric:
            raise ValueError("a relational claim compares with another claim, not with paper_value/paper_range")
        if numeric and (self.tolerance is None or not self.tolerance_why.strip()):
            raise ValueError("a numeric claim needs tolerance and tolerance_why")
        if not numeric and not self.paper_statement.strip():
            raise ValueError("a claim without paper_value/paper_range needs paper_statement")
        if self.paper_range is not None and self.paper_range[0] > self.paper_range[1]:
            raise ValueError(f"paper_range {list(self.paper_range)} is not [low, high]")
        return self

    @property
    def relational(self) -> bool:
        """Whether the claim checks a relation to another claim's value (``relation``/``than``)."""
        return self.relation is not None

    @property
    def numeric(self) -> bool:
        """Whether the paper gives a number or range to compare with."""
        return self.paper_value is not None or self.paper_range is not None


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
        ids = {c.id: c for c in self.claim}
        for c in self.claim:
            if c.run not in runs:
                raise ValueError(f"claim {c.id!r}: run {c.run!r} is not one of the [[run]] ids {runs}")
            if c.than is not None and (c.than not in ids or c.than == c.id):
                raise ValueError(f"claim {c.id!r}: than {c.than!r} is not another claim of the paper")
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
