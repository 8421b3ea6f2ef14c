"""The repository stands alone: no tracked text file points readers to documents they do not have.

Sources, configs and docs cite the papers (author year with the paper's own equation, figure, table
or section number, written "Sec. 3.2", see ``docs/bibliography.md``) and state any modelling choice
or correction in their own words. They never point to the internal specification documents the
project was written from: no section sign (a paper's section is "Sec. n"), no ``../shared`` or
``spec/`` path, no ``*spec.md``/``design.md`` file or one of the specification file names, and no
"the spec"/"truss spec" pointer. Each hit is reported as ``path:line: [rule] text``.

Scanned: every file ``git ls-files`` lists with a text suffix (``.py``, ``.toml``, ``.md``, ``.txt``,
``.json``, ``.cfg``, ``.ini``, ``.yaml``, ``.yml``, ``.sh``, ``.rst``), except the stored regression
numbers (``tests/data``) and the committed result bundles (``results/``), which quote no prose,
and this file, which has to spell out what it forbids.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TEXT_SUFFIXES = {".py", ".toml", ".md", ".txt", ".json", ".cfg", ".ini", ".yaml", ".yml", ".sh", ".rst"}
SKIPPED_PREFIXES = ("tests/data/", "results/")
THIS_FILE = Path(__file__).resolve().relative_to(ROOT)

#: Rule name -> pattern. Written with escapes so this file does not trip its own rules.
RULES: dict[str, re.Pattern[str]] = {
    "section sign": re.compile("\u00a7"),
    "shared folder": re.compile(r"\.\./shared"),
    "spec folder": re.compile(r"(?<![\w.-])spec/"),
    "spec file": re.compile(r"\b[\w-]*spec\.md\b", re.IGNORECASE),
    "design file": re.compile(r"\bdesign\.md\b", re.IGNORECASE),
    "specification file name": re.compile(
        r"\b(?:truss-magnetorquer-array|cnusail-cubesat|conducting-structure-reflector)\.md\b", re.IGNORECASE
    ),
    "spec file pointer": re.compile(r"\bspec(?:ification)?\s+[\w-]+\.md\b", re.IGNORECASE),
    "pointer to the spec": re.compile(r"\b(?:the|this|our)\s+spec(?:ification)?\b(?!\s*=)", re.IGNORECASE),
    "concept spec pointer": re.compile(
        r"\b(?:truss|cnusail(?:-1)?|current[- ]loops|reflector|msac)\s+spec(?:ification)?\b", re.IGNORECASE
    ),
}


def tracked_text_files() -> list[Path]:
    """Tracked files with a text suffix, outside the skipped folders (paths relative to the root)."""
    out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    names = [n for n in out.decode().split("\0") if n]
    return [
        Path(n)
        for n in names
        if Path(n).suffix in TEXT_SUFFIXES
        and not n.startswith(SKIPPED_PREFIXES)
        and Path(n) != THIS_FILE
        and (ROOT / n).is_file()
    ]


def offending_lines(text: str) -> list[tuple[int, str, str]]:
    """``(line number, rule, line)`` for every line of ``text`` a rule matches (1-based lines)."""
    hits = []
    for number, line in enumerate(text.splitlines(), start=1):
        for rule, pattern in RULES.items():
            if pattern.search(line):
                hits.append((number, rule, line.strip()))
    return hits


def test_tracked_files_are_found():
    files = tracked_text_files()
    assert Path("README.md") in files and Path("magsail_mj/api.py") in files
    assert THIS_FILE not in files and not any(str(f).startswith(SKIPPED_PREFIXES) for f in files)
    assert len(files) > 100, len(files)


@pytest.mark.parametrize(
    ("line", "rule"),
    [
        ("see spec \u00a74.4 for the law", "section sign"),
        ("(current-loops.md \u00a75)", "section sign"),
        ("read ../shared/spec/msac.md", "shared folder"),
        ("the files in spec/ say", "spec folder"),
        ("as in design.md", "design file"),
        ("truss-magnetorquer-array.md", "specification file name"),
        ("(spec msac.md, the cycle)", "spec file pointer"),
        ("within 2 % as the spec asks", "pointer to the spec"),
        ("CNUSAIL spec erratum", "concept spec pointer"),
    ],
)
def test_rules_catch_pointers(line, rule):
    assert rule in {r for _, r, _ in offending_lines(line)}


@pytest.mark.parametrize(
    "line",
    [
        "Yoo et al. 2016, Eq. 24; Robb et al. 2022a, Sec. 3.2 and Fig. 9",
        "spec = mujoco.MjSpec()",
        "model = build_truss_spec(lat).spec.compile()",
        "actions drawn within the action spec's bounds",
        "docs/concepts/current-loops.md",
        "pages[docs / 'msac.md']",
    ],
)
def test_rules_leave_citations_and_code_alone(line):
    assert offending_lines(line) == []


def test_no_file_points_to_internal_documents():
    report = []
    for path in tracked_text_files():
        text = (ROOT / path).read_text(encoding="utf-8", errors="replace")
        report += [f"{path}:{n}: [{rule}] {line[:160]}" for n, rule, line in offending_lines(text)]
    assert not report, f"{len(report)} pointer(s) to internal documents:\n" + "\n".join(report)
