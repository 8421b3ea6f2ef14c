"""Layout of the reproduction pages: the counts, the differing claims first with their explanations,
one compact claim table (claim, paper, ours, verdict) and the details below it, checked on the HTML
that MyST makes of a rendered page; and the site checker's claim-table check at a 1 280 px viewport
in headless Chromium (skipped where Chromium is absent)."""

from __future__ import annotations

import re
import shutil
from html.parser import HTMLParser
from pathlib import Path

import pytest
from docutils import nodes
from docutils.core import publish_parts
from docutils.parsers.rst import roles
from myst_parser.parsers.docutils_ import Parser

from magsail_mj.report.registry import Paper
from magsail_mj.report.render import CLAIM_TABLE_CLASS, render_page
from tests.conftest import load_file_module

CONFIG = "magsail_mj/concepts/msac/configs/lumped_limit.toml"
CHROMIUM = shutil.which("/usr/bin/chromium") or shutil.which("chromium")
needs_chromium = pytest.mark.skipif(CHROMIUM is None, reason="no chromium on this machine (apt-get install chromium)")


def _ref_role(name, rawtext, text, lineno, inliner, options=None, content=None):
    """Sphinx's ``{ref}`` as plain docutils sees it: a link to ``#label`` with the given title."""
    match = re.fullmatch(r"(.*?)\s*<([^<>]+)>", text, re.DOTALL)
    title, target = (match.group(1), match.group(2)) if match else (text, text)
    title = title.replace("\\<", "<").replace("\\>", ">")
    return [nodes.reference(rawtext, title, refuri="#" + target)], []


@pytest.fixture
def to_html(monkeypatch):
    """MyST Markdown → HTML body with docutils (no Sphinx build): the page's structure as a browser gets it."""
    monkeypatch.setitem(roles._roles, "ref", _ref_role)

    def convert(text: str) -> str:
        settings = {"report_level": 5, "myst_enable_extensions": ["colon_fence"]}
        return publish_parts(text, parser=Parser(), writer="html5", settings_overrides=settings)["body"]

    return convert


class _Tables(HTMLParser):
    """The tables of an HTML text: class and rows of cell texts (headers included)."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.tables: list[dict] = []
        self._cell: list[str] | None = None

    def handle_starttag(self, tag, attrs):
        if tag == "table":
            self.tables.append({"class": dict(attrs).get("class", ""), "rows": [], "links": []})
        elif tag == "tr" and self.tables:
            self.tables[-1]["rows"].append([])
        elif tag in ("td", "th") and self.tables:
            self._cell = []
        elif tag == "a" and self._cell is not None:
            self.tables[-1]["links"].append(dict(attrs).get("href"))

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None:
            self.tables[-1]["rows"][-1].append(" ".join("".join(self._cell).split()))
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)


def _paper() -> Paper:
    """Four claims on three runs: one agrees, one differs (headline), one not run, one failed run."""
    base = dict(paper_ref="Fig. 2", key="x_m", unit="m", tolerance=0.1, tolerance_why="read off the figure")
    claims = [
        dict(id="close", title="the agreeing length", run="ok", paper_value=1.0, paper_says="about 1 m"),
        dict(
            id="far",
            title="the differing length",
            run="ok",
            paper_value=5.0,
            paper_says="about 5 m",
            headline=True,
            explanation="our lattice is stiffer",
        ),
        dict(id="missing", title="the length not run", run="absent", paper_value=1.0, paper_says="1 m"),
        dict(
            id="broke",
            title="the length of the failed run",
            run="broken",
            paper_value=1.0,
            paper_says="1 m",
            explanation="the lattice collapsed",
        ),
    ]
    runs = [{"id": r, "config": CONFIG} for r in ("ok", "absent", "broken")]
    return Paper(
        paper="demo",
        title="Demo",
        citation="A 2020",
        bib_label="a2020",
        sweep="s.toml",
        run=runs,
        claim=[base | {"quantity": f"{c['title']}, measured"} | c for c in claims],
    )


def _bundle(tmp_path: Path) -> dict:
    ok = {"summary": {"x_m": 1.05}, "identity": {"status": "completed"}, "files": [], "path": tmp_path}
    broken = {"summary": {"x_m": 9.0}, "identity": {"status": "diverged"}, "files": [], "path": tmp_path}
    return {"ok": ok, "broken": broken}


def test_page_counts_differences_first_then_one_compact_table_then_details(tmp_path, to_html):
    text, verdicts = render_page(_paper(), _bundle(tmp_path), tmp_path)
    assert [v.verdict for v in verdicts] == ["agrees", "differs", "not run", "failed"]
    assert "**4 claims: 1 differs · 1 failed · 1 not run · 1 agrees.**" in text
    assert "Headline claims (the paper's abstract makes them): 1: 1 differs" in text
    html = to_html(text)
    # where ours differs: before the table, each differing or failed claim with its explanation
    differ = html.index('id="where-ours-differs"')
    table_at = html.index("<table")
    assert differ < table_at
    listed = html[differ:table_at]
    assert "our lattice is stiffer" in listed and "the lattice collapsed" in listed
    assert "the agreeing length" not in listed and "the length not run" not in listed
    parser = _Tables()
    parser.feed(html)
    claim_tables = [t for t in parser.tables if CLAIM_TABLE_CLASS in t["class"].split()]
    assert len(claim_tables) == 1
    rows = claim_tables[0]["rows"]
    assert rows[0] == ["claim", "paper", "ours", "verdict"]
    assert all(len(row) == 4 for row in rows)
    # differing claims first, the headline claim marked; verdicts as computed
    assert [row[3] for row in rows[1:]] == ["differs", "failed", "not run", "agrees"]
    assert rows[1][0] == "the differing length (headline)" and rows[1][1:3] == ["5 m", "1.05 m"]
    assert rows[3][2] == "not run" and rows[2][2] == "run diverged"
    # every claim links to its details, which follow the table in the same order
    labels = claim_tables[0]["links"]
    assert labels == [f"#repro-demo-{c}" for c in ("far", "broke", "missing", "close")]
    sections = [m.start() for m in (re.search(f'<section id="{lab[1:]}"', html) for lab in labels)]
    assert all(table_at < s for s in sections) and sections == sorted(sections)
    details = html[sections[0] :]
    assert "read off the figure" in details and "our lattice is stiffer" in details  # tolerance reason, explanation


def test_page_without_differences_has_no_such_section(tmp_path, to_html):
    paper = _paper()
    paper = paper.model_copy(update={"claim": paper.claim[:1]})
    text, _ = render_page(paper, _bundle(tmp_path), tmp_path)
    assert "Where ours differs" not in text and "Headline claims" not in text
    assert "**1 claims: 0 differs · 0 failed · 0 not run · 1 agrees.**" in text


# --------------------------------------------------------------------------- the site checker


check_docs_site = load_file_module("scripts", "check_docs_site", register=True)


def _site(tmp_path: Path, cell: str) -> Path:
    """One page with a claim table whose first cell is ``cell``, in a 740 px column as in the docs theme."""
    row = f"<tr><td>{cell}</td><td>5 m</td><td>1.05 m</td><td>agrees</td></tr>"
    table = f'<div style="overflow-x:auto"><table class="{CLAIM_TABLE_CLASS}">{row}</table></div>'
    tmp_path.mkdir(parents=True)
    page = f'<!doctype html><html><head><title>Claims</title></head><body><main style="width:740px">{table}</main>'
    (tmp_path / "index.html").write_text(page + "<p>" + "text " * 10 + "</p></body></html>")
    return tmp_path


def test_claim_table_problems_name_the_page_and_the_widths():
    fits = {"table": 700, "holderClient": 740, "holderScroll": 740, "right": 1100, "viewport": 1265, "rows": 3}
    assert check_docs_site.claim_table_problems("a.html", [fits]) == []
    wide = fits | {"table": 1600, "holderScroll": 1606}
    (problem,) = check_docs_site.claim_table_problems("a.html", [fits, wide])
    assert problem.startswith("a.html: claim table 2 (3 rows) is 1600 px wide in a column of 740 px")
    past = fits | {"right": 1300.4}
    (problem,) = check_docs_site.claim_table_problems("b.html", [past])
    assert "ends at 1300 px, past the 1265 px" in problem


@needs_chromium
def test_browser_check_finds_a_claim_table_wider_than_its_column(tmp_path):
    narrow = check_docs_site.check_in_browser(_site(tmp_path / "narrow", "a claim in words"), binary=CHROMIUM)
    assert narrow.claim_tables == 1 and narrow.problems == []
    wide = check_docs_site.check_in_browser(_site(tmp_path / "wide", "x" * 300), binary=CHROMIUM)
    assert wide.claim_tables == 1
    assert [p for p in wide.problems if "claim table 1" in p and "scrolls horizontally at a 1280 px" in p]
