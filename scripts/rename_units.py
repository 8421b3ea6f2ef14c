"""Rename unit suffixes across the tree to the one grammar of :mod:`magsail_mj.units_grammar`.

Every identifier (a maximal run of ``[A-Za-z0-9_]``) in the ``*.py``, ``*.toml``, ``*.md`` and
``*.json`` files of the repository whose suffix is an old spelling of
:data:`~magsail_mj.units_grammar.RENAMED_SUFFIXES` is rewritten (``torque_max_N_m`` →
``torque_max_Nm``, ``inertia_kg_m2`` → ``inertia_kgm2``, ``kappa_Am2_per_kg`` →
``kappa_Am2_kg``), except the names of :data:`~magsail_mj.units_grammar.KEPT_NAMES` whose old
suffix already reads right (``areal_density_kg_m2`` is kg/m², ``slide_stiffness_N_m`` N/m).
Only whole identifiers are touched, never text inside another word. A bare suffix that follows an
f-string field or a pattern (``f"T_B{ax}_N_m"``, ``max[_{a,b}]_N_m``) is renamed too, and so is
a string holding just a unit (``"N_m"`` → ``"Nm"``); a bare suffix standing alone (a quoted
``"_N_m"``) is left for a person to judge and listed.

In JSON files only object keys are renamed (values stay byte for byte). Folders skipped:
``.venv``, ``runs``, ``docs/_build``, ``docs/gallery`` and anything git ignores; so are the files
that spell the old suffixes on purpose (:data:`OWN_FILES`). Each changed file
is read, rewritten and written back whole.

Usage::

    python scripts/rename_units.py            # list what would change (dry run)
    python scripts/rename_units.py --apply    # rewrite the files, print the changed paths
"""

from __future__ import annotations

import argparse
import collections
import re
import subprocess
import sys
from pathlib import Path

from magsail_mj.units_grammar import RENAMED_SUFFIXES, new_name

REPO = Path(__file__).resolve().parents[1]
EXTENSIONS = (".py", ".toml", ".md", ".json")
SKIPPED = (".venv/", "runs/", "docs/_build/", "docs/gallery/")
#: files that spell old suffixes on purpose (the grammar, its tests, its page, this script)
OWN_FILES = (
    "magsail_mj/units_grammar.py",
    "scripts/rename_units.py",
    "docs/conventions.md",
    "tests/test_unit_names.py",
)
_TOKEN = re.compile(r"[A-Za-z0-9_]+")
_JSON_KEY = re.compile(r'"((?:[^"\\]|\\.)*)"(\s*:)')
_OLD_SUFFIXES = dict(RENAMED_SUFFIXES)


def candidate_files(repo: Path = REPO) -> list[Path]:
    """Tracked and untracked (not ignored) files with one of :data:`EXTENSIONS`, outside
    :data:`SKIPPED`."""
    out = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard"],
        cwd=repo,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    names = sorted(set(out.split("\n")) - {""})
    return [
        repo / n
        for n in names
        if n.endswith(EXTENSIONS) and not n.startswith(SKIPPED) and n not in OWN_FILES and (repo / n).is_file()
    ]


def renamed_token(token: str, before: str, after: str = "") -> str | None:
    """The new spelling of ``token`` (an identifier; ``before`` and ``after`` are the characters
    around it), or None when it stays."""
    new = new_name(token)
    if new is not None:
        return new
    if before in "'\"" and before and after == before and f"_{token}" in _OLD_SUFFIXES:  # a unit as a string: "N_m"
        return _OLD_SUFFIXES[f"_{token}"][1:]
    if token in _OLD_SUFFIXES and before in "}]" and before:  # f"{x}_N_m", `{a,b}]_N_m`: a generated name
        return _OLD_SUFFIXES[token]
    return None


def rename_text(text: str, counts: collections.Counter, bare: list[str]) -> str:
    """``text`` with every old identifier renamed; ``counts`` gets ``old → new`` tallies and
    ``bare`` the standalone old suffixes left as they are."""

    def swap(m: re.Match) -> str:
        token = m.group()
        before = text[m.start() - 1] if m.start() else ""
        new = renamed_token(token, before, text[m.end() : m.end() + 1])
        if new is None:
            if token in _OLD_SUFFIXES:
                bare.append(token)
            return token
        counts[(token, new)] += 1
        return new

    return _TOKEN.sub(swap, text)


def rename_json_keys(text: str, counts: collections.Counter, bare: list[str]) -> str:
    """``text`` (JSON) with the old identifiers in object keys renamed; values untouched."""

    def swap(m: re.Match) -> str:
        return '"' + rename_text(m.group(1), counts, bare) + '"' + m.group(2)

    return _JSON_KEY.sub(swap, text)


def rename_file(path: Path, counts: collections.Counter, bare: list[str], *, apply: bool) -> bool:
    """Rename the identifiers of one file (written back only with ``apply``); True if it changed."""
    text = path.read_text(encoding="utf-8")
    new = (rename_json_keys if path.suffix == ".json" else rename_text)(text, counts, bare)
    if new == text:
        return False
    if apply:
        path.write_text(new, encoding="utf-8")
    return True


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--apply", action="store_true", help="rewrite the files (default: dry run)")
    parser.add_argument("--quiet", action="store_true", help="print only the changed paths")
    args = parser.parse_args(argv)
    counts: collections.Counter = collections.Counter()
    changed = []
    for path in candidate_files():
        bare: list[str] = []
        if rename_file(path, counts, bare, apply=args.apply):
            changed.append(path.relative_to(REPO).as_posix())
        if bare and not args.quiet:
            print(f"# left as is in {path.relative_to(REPO)}: {sorted(set(bare))}", file=sys.stderr)
    if not args.quiet:
        for (old, new), n in sorted(counts.items()):
            print(f"{n:5d}  {old} -> {new}", file=sys.stderr)
        print(f"# {sum(counts.values())} identifiers in {len(changed)} files", file=sys.stderr)
    print("\n".join(changed))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
