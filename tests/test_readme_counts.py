"""The README's and the docs' one-line account of the reproduction states the counts the rendered
reports compute (docs/reproduction/index.md, rendered from the results bundle), not an adjective:
a re-rendered report with other verdicts makes this fail until the sentence is updated."""

from __future__ import annotations

import re

from tests.conftest import REPO


def _report_counts() -> dict[str, int]:
    """Totals of the index page's table: claims, differs, failed, not run, agrees, headline."""
    totals = dict.fromkeys(("claims", "differs", "failed", "not_run", "agrees", "headline_agrees", "headline"), 0)
    for line in (REPO / "docs/reproduction/index.md").read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 7 or not cells[1].isdigit():
            continue
        for key, cell in zip(("claims", "differs", "failed", "not_run", "agrees"), cells[1:6]):
            totals[key] += int(cell)
        agrees, of = re.fullmatch(r"(\d+) of (\d+)", cells[6]).groups()
        totals["headline_agrees"] += int(agrees)
        totals["headline"] += int(of)
    return totals


def test_the_readme_and_the_docs_state_the_computed_counts() -> None:
    counts = _report_counts()
    assert counts["claims"] > 0 and counts["claims"] == sum(
        counts[k] for k in ("differs", "failed", "not_run", "agrees")
    )
    readme = " ".join((REPO / "README.md").read_text(encoding="utf-8").split())
    docs = " ".join((REPO / "docs/index.md").read_text(encoding="utf-8").split())
    stated = f"of {counts['claims']} claims, {counts['agrees']} agree and {counts['differs']} differ"
    assert stated in readme, stated
    assert stated in docs, stated
    assert f"of the {counts['headline']} claims the papers' abstracts make, {counts['headline_agrees']} agree" in readme
    assert counts["failed"] == counts["not_run"] == 0  # else the sentence must name them too
