"""The shipped claim files (``magsail_mj/report/claims/*.toml``): every claim says where the paper
states it and what it states, with the paper's number (and units) where it gives one, or else a
criterion a run can fail; every claim can both agree and differ; each paper marks its headline
claims; and the numbers the papers state are the ones recorded (not rounded into words)."""

from __future__ import annotations

import math
import re

import pytest

from magsail_mj.report.registry import Claim, Paper, load_registry
from magsail_mj.report.verdict import AGREES, DIFFERS, judge

PAPERS = load_registry()
CLAIMS = [(paper, claim) for paper in PAPERS.values() for claim in paper.claim]
IDS = [f"{paper.paper}/{claim.id}" for paper, claim in CLAIMS]


def _number_forms(value: float) -> set[str]:
    """How a number may be written in prose: 0.085, 7800 or 7 800 (a space or thin space for thousands)."""
    plain = f"{value:g}" if abs(value) < 1e5 else f"{value:.0f}"
    forms = {plain}
    if abs(value) >= 1000 and value == int(value):
        grouped = f"{int(value):,}"
        forms |= {grouped.replace(",", " "), grouped.replace(",", "\u2009")}
    if value > 0 and math.log10(value).is_integer():
        forms.add("10" + str(int(math.log10(value))).translate(str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")))
    return forms


@pytest.mark.parametrize(("paper", "claim"), CLAIMS, ids=IDS)
def test_claim_quotes_the_paper_with_its_number_or_states_a_criterion(paper: Paper, claim: Claim):
    assert claim.paper_ref.strip() and claim.paper_says.strip() and claim.title.strip() and claim.quantity.strip()
    if claim.numeric:
        assert claim.tolerance_why.strip()
        numbers = [claim.paper_value] if claim.paper_range is None else list(claim.paper_range)
        for number in numbers:
            if number == 0.0 and claim.key.endswith("_rel_diff"):  # ours against the paper's equation
                assert re.search(r"Eq\. ?\(?\d", claim.paper_says), claim.paper_says
                continue
            assert any(form in claim.paper_says for form in _number_forms(number)), (number, claim.paper_says)
        if claim.unit and not claim.is_ratio:  # a ratio's number has no unit
            assert claim.unit in claim.paper_says, (claim.unit, claim.paper_says)
    else:
        assert claim.criterion_why.strip()
        assert claim.bound is not None or claim.matches_value


def _summaries(claim: Claim, value: float | str | bool) -> dict:
    """Bundled runs in which the claim's value (or ratio) is ``value``."""
    if isinstance(value, float):
        raw = value / claim.scale
        if claim.is_ratio:
            other = {claim.ratio_key: 1.0 / claim.scale}
            runs = {claim.denominator_run: {"summary": dict(other), "identity": {"status": "completed"}}}
            runs.setdefault(claim.run, {"summary": {}, "identity": {"status": "completed"}})
            runs[claim.run]["summary"][claim.key] = raw
            return runs
        summary = {claim.key: raw if claim.index is None else [raw] * (claim.index + 1)}
    else:
        summary = {claim.key: value}
    return {claim.run: {"summary": summary, "identity": {"status": "completed"}}}


def _passing_and_failing(claim: Claim) -> tuple[float | str | bool, float | str | bool]:
    if isinstance(claim.expect, bool):
        return claim.expect, not claim.expect
    if isinstance(claim.expect, str):
        return claim.expect, claim.expect + "_not"
    if claim.expect_not is not None:
        return claim.expect_not + "_not", claim.expect_not
    lo, hi = claim.paper_range if claim.paper_range is not None else (claim.paper_value, claim.paper_value)
    if lo is None:
        lo = hi = claim.bound
    assert lo is not None and hi is not None
    span = max(abs(lo), abs(hi), 1.0)
    inside = 0.5 * (lo + hi)
    if claim.compare == "max":
        return hi - 0.1 * span, hi + 10.0 * span
    if claim.compare == "min":
        return lo + 0.1 * span, lo - 10.0 * span
    return inside, hi + 10.0 * span + 10.0 * claim.tolerance * span


@pytest.mark.parametrize(("paper", "claim"), CLAIMS, ids=IDS)
def test_every_claim_can_agree_and_can_differ(paper: Paper, claim: Claim):
    """A value that keeps the paper's number or the criterion agrees; one far outside differs."""
    passing, failing = _passing_and_failing(claim)
    explained = claim.model_copy(update={"explanation": claim.explanation or "explained"})
    assert judge(explained, _summaries(claim, passing)).verdict == AGREES
    assert judge(explained, _summaries(claim, failing)).verdict == DIFFERS


def test_every_paper_marks_its_headline_claims():
    for paper in PAPERS.values():
        assert any(c.headline for c in paper.claim), paper.paper
        titles = [c.title for c in paper.claim]
        assert len(titles) == len(set(titles)), paper.paper


def _claim(paper: str, claim_id: str) -> Claim:
    return PAPERS[paper].claim_by_id(claim_id)


def test_the_papers_numbers_are_recorded_as_numbers():
    """Numbers the papers state, kept as numbers with their units instead of 'late', 'within the run'
    or 'more than 2×' (Robb et al. 2022a, Sec. 2 and 4.2–4.3; Robb et al. 2022b, structural sweep and
    slew)."""
    truss, loops = "truss", "current_loops"
    assert _claim(truss, "detumble_time").paper_value == 1.0 and _claim(truss, "detumble_time").unit == "h"
    assert _claim(truss, "detumble_surface_sd").paper_value == 0.5 and _claim(truss, "detumble_surface_sd").unit == "m"
    assert _claim(truss, "detumble_edge_angle").paper_value == 4.0
    assert _claim(truss, "case_a_versine_central_long_sd_max").paper_value == 0.085
    assert _claim(truss, "case_a_versine_central_long_sd_time").paper_value == 7800.0
    for slew in ("i", "ii", "iii"):
        assert _claim(truss, f"slew_{slew}_time").paper_value == 1.5  # h
    assert _claim(truss, "slew_iv_tumbles").expect is True  # IV does not reach its attitude and tumbles
    assert _claim(truss, "slew_iv_not_reached").compare == "min"
    assert not [c.id for c in PAPERS[truss].claim if "iv" in c.id and "reaches" in c.paper_says]
    assert _claim(loops, "s4_n19_b_ei1e4_peak").paper_value == 2000.0
    assert _claim(loops, "s4_n19_b_ei1e4_single_peak").bound == 1.0
    assert _claim(loops, "s5_strain_peak").paper_value == 9339.0
    assert _claim(loops, "s4_n19_d_over_c_energy").paper_range == (100.0, 1000.0)
    assert _claim("cnusail", "s6_gain_clamp").paper_value == pytest.approx(91.15)


def test_comparisons_without_a_factor_need_more_than_the_reading_of_a_plot():
    """'More' or 'less' without a number is checked as a ratio at least 25 % above (20 % below) one:
    D against C, B's fall with N and slew II's effort against slew I's cannot pass as agreeing by a
    few percent."""
    for paper, claim in CLAIMS:
        if claim.is_ratio and claim.bound is not None and claim.compare in ("min", "max"):
            if claim.compare == "min" and claim.bound >= 1.0:
                assert claim.bound >= 1.25, (paper.paper, claim.id)
            if claim.compare == "max" and 0.1 < claim.bound <= 1.0:
                assert claim.bound <= 0.8, (paper.paper, claim.id)
    assert _claim("truss", "slew_ii_effort").bound == 0.8
    assert _claim("current_loops", "s4_trend_b_n27_over_n19").bound == 0.8
