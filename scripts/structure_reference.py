"""Write ``docs/structure_file.md``, the structure file's reference page, from the declared slot table.

Every table and key of :data:`magsail_mj.structure.fileschema.SLOTS` is listed with its type,
unit (read from the key's suffix), default and meaning; a test checks that the committed page is
what this script writes, so the page and the reader cannot drift apart.

Usage::

    python scripts/structure_reference.py           # (re)write docs/structure_file.md
    python scripts/structure_reference.py --check   # exit 1 if the committed page differs
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from magsail_mj.structure import checks
from magsail_mj.structure.companion import MAX_COMPANION_BYTES, MAX_ELEMENTS
from magsail_mj.structure.fileschema import FORMAT, FORMS, MAX_COUNT, MAX_FILE_BYTES, SLOTS, TABLES, VERSION
from magsail_mj.units_grammar import unit_label

PAGE = Path(__file__).resolve().parents[1] / "docs" / "structure_file.md"

#: The complete example of the page: a triangle of struts hinged at one corner.
EXAMPLE = f"""\
format = "{FORMAT}"
version = {VERSION}
name = "hinged_triangle"

[nodes]
position_m = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
mass_kg = 0.5                      # the same point mass at every node

[sets]
hinge = [0]

[[member_groups]]
kind = "strut"
name = "edges"                     # a member set of these three members
nodes = [[0, 1], [1, 2], [2, 0]]
area_m2 = 1.0e-4                   # EA = E_Pa × area_m2 = 7e6 N
E_Pa = 70.0e9
density_kg_m3 = 2700.0             # 0.27 kg/m, half of each member's mass at each end
damping_Ns_m = 10.0

[[fixed]]
nodes = "hinge"                    # a node set's name, or [indices]
dofs = "123"                       # translations held: a spherical hinge
"""

COMPANION_EXAMPLE = """\
[nodes]
file = "boom_nodes.csv"            # columns x_m, y_m, z_m and optionally mass_kg

[[member_groups]]
kind = "beam"
nodes = { file = "boom.npz", array = "pairs" }
EA_N = { file = "boom.npz", array = "EA_N" }
EI_Nm2 = 350.0                     # one number for the whole group
GJ_Nm2 = 270.0

[sets]
root = { file = "boom_sets.csv", columns = "root" }
"""


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def _table_heading(table: str) -> str:
    if table == "":
        return "Top level"
    if table == "file":
        return "Companion reference `{ file = ... }`"
    if table in ("sets", "member_sets"):
        return f"`[{table}]`"
    if table in ("nodes", "modal_damping"):
        return f"`[{table}]`"
    return f"`[[{table}]]`"


def _key_table(table: str) -> list[str]:
    rows = ["| key | type | unit | default | meaning |", "|---|---|---|---|---|"]
    for s in (s for s in SLOTS if s.table == table):
        default = s.default_doc if s.default_doc is not None else f"`{s.default}`"
        unit = unit_label(s.key) or "—"
        rows.append(f"| `{s.key}` | {_cell(FORMS[s.form])} | {unit} | {_cell(default)} | {_cell(s.meaning)} |")
    return rows


def _tables_section() -> list[str]:
    lines = ["## Tables and keys", ""]
    lines += [
        "Units are SI and read from each key's suffix (see the naming conventions page). A key not "
        "listed here is refused. n is the number of nodes, m the number of members of the group, p the "
        "number of panels of the group; indices are 0-based.",
        "",
    ]
    for table, meaning in TABLES.items():
        lines += [f"### {_table_heading(table)}", "", _cell(meaning), ""]
        if table in ("sets", "member_sets"):
            lines += [
                f"Each key is a set's name; its value is an array of indices or a companion reference. "
                f"At most {MAX_COUNT:,} entries a set.",
                "",
            ]
            continue
        lines += [*_key_table(table), ""]
    return lines


def _derived_section() -> list[str]:
    return [
        "## Derived member properties",
        "",
        "- axial rigidity `EA = E_Pa · area_m2` unless `EA_N` is given;",
        "- bending `EI = E_Pa · [I1_m4, I2_m4]` unless `EI_Nm2` is given, torsion `GJ = G_Pa · J_m4` "
        "unless `GJ_Nm2` is given, with `G = E_Pa / (2 (1 + nu))` when `nu` stands for `G_Pa` "
        "(section keys are for beams only);",
        "- linear density `ρA = density_kg_m3 · area_m2` unless `linear_density_kg_m` is given;",
        "- rest length `l0 = |x_b − x_a| / (1 + prestrain)` unless `rest_length_m` is given.",
        "",
        "Two ways of giving one property (`EA_N` with `area_m2` and `E_Pa` both used for it, "
        "`rest_length_m` with `prestrain`, `G_Pa` with `nu`, ...) are refused, and so is a key that "
        "the keys given leave unused (`area_m2` with `EA_N` and no `density_kg_m3`). Members are "
        "numbered across the groups in file order: the checks name `members[i]` and add the group and row.",
        "",
    ]


def _companion_section() -> list[str]:
    return [
        "## Companion files",
        "",
        "Any value that is an array may be kept in a file beside the structure file and named by a "
        "companion reference (the table above). For example:",
        "",
        "```toml",
        COMPANION_EXAMPLE.rstrip(),
        "```",
        "",
        "- `.npz`: named arrays (NumPy's `np.savez`); `array` names one. Arrays are read with "
        "`allow_pickle=False`: an array of Python objects is refused from its header, before any of it "
        "is read, and so is a non-numeric one.",
        "- `.csv`: a first line of unique column names, then rows of as many comma-separated numbers; "
        "`columns` picks some, in order (one name as a string: a 1-D array). Indices read from a `.csv` "
        "must be whole numbers.",
        "- The path is relative to the structure file's folder (for `[structure]` in a task config: the "
        "config's folder) and must stay inside it: an absolute path, a `..` step or a link leading out "
        "is refused.",
        f"- Sizes are checked before anything is allocated: at most {MAX_ELEMENTS:,} numbers an array "
        f"(from the `.npy` header or the line count), {MAX_COMPANION_BYTES // 1024**3} GiB a file, "
        f"{MAX_COUNT:,} nodes, members or panels, {MAX_FILE_BYTES // 1024**2} MiB for the structure file itself.",
        "- Each file is read once; the SHA-256 of the bytes read is returned with the structure "
        "(`StructureSource.sha256`, by the path as the reference spells it, with the structure file's "
        "own digest) so that a run manifest can record exactly what was read.",
        '- `write_structure(structure, path, arrays="npz")` writes every whole column into `<stem>.npz` '
        'beside the file; `arrays="inline"` (the default) writes them into the TOML. Either reads back '
        "to the same arrays, bit for bit.",
        "",
    ]


def _checks_section() -> list[str]:
    return [
        "## Checks",
        "",
        "Reading a structure checks it (`magsail_mj.structure.checks.check_structure`) and reports every "
        "problem at once, each naming the element, the key and the value, for example "
        "`boom.toml: members[12].nodes: node 999 does not exist (800 nodes) [member_groups[1], row 4]`. "
        f"At most {checks.MAX_LISTED} elements are listed a rule, then the rest are counted. The extent "
        "L is the diagonal of the nodes' bounding box.",
        "",
        "| element | refused |",
        "|---|---|",
        f"| nodes | a position not finite; two nodes closer than {checks.DUPLICATE_REL:g} L; a negative or "
        "non-finite mass; a node that no member, panel or rigid part touches and that has no mass |",
        f"| members | an end node that does not exist; both ends the same node; a length under "
        f"{checks.DUPLICATE_REL:g} L; `EA_N` or `rest_length_m` not > 0; `EI_Nm2`, `GJ_Nm2`, `damping_Ns_m` "
        "or the linear density negative; `strain_limit` not > 0; `prestrain` not > −1; a beam without "
        "`EI_Nm2` > 0 about both axes and `GJ_Nm2` > 0; a strut or cable with bending or torsion; a beam's "
        "`orientation` parallel to it |",
        f"| panels | a corner that does not exist or repeats; zero area (at most {checks.DEGENERATE_REL:g} "
        f"times the longest edge squared); reflectivity fractions negative or not summing to 1 within "
        f"{checks.REFLECTIVITY_TOL:g}; a negative areal density; `drag_coefficient` not > 0 |",
        "| rigid parts | a repeated name; a negative mass; an inertia tensor not symmetric, not positive "
        "definite or whose principal moments break the triangle inequality (a massless part may have a zero "
        "tensor); no node, a node that does not exist or that another part holds |",
        "| sets | an index out of range; a name that is both a node set and a member set, or a group's "
        "`name` that is also a key of `member_sets` |",
        "| structure | a total mass not > 0; more than one connected part (members, panel edges and rigid "
        "parts join nodes): the count and a node of each smaller part are named |",
        "",
        "Schema problems are reported the same way, by key path: an unknown key, a value of the wrong "
        "type or shape, a missing required key, a companion file missing, unreadable or outside the folder.",
        "",
    ]


def reference_page() -> str:
    """The Markdown (MyST) text of ``docs/structure_file.md``."""
    lines = [
        "# Structure file",
        "",
        "<!-- Generated by scripts/structure_reference.py from magsail_mj/structure/fileschema.py: "
        "edit those, then run the script. -->",
        "",
        "A structure file describes any spacecraft structure — nodes, struts, cables, beams, panels, rigid "
        "parts, named sets and constraints — as TOML, with large arrays optionally in companion `.npz` or "
        "`.csv` files. It reads into `magsail_mj.structure.model.Structure` and is written from it, the round "
        "trip exact. The same tables may stand under `[structure]` in a task config.",
        "",
        "```python",
        "from magsail_mj.structure.fileformat import read_structure, structure_from_mapping, write_structure",
        "",
        'source = read_structure("boom.toml")  # checked; StructureError lists every problem',
        "structure, digests = source.structure, source.sha256",
        'write_structure(structure, "copy.toml", arrays="npz")',
        "```",
        "",
        f'A structure file starts with `format = "{FORMAT}"` and `version = {VERSION}`; a file of a newer '
        "version is refused by name. Frames and units: positions in the structure frame (the body frame of "
        "the undeformed structure), SI units throughout.",
        "",
        "## Example",
        "",
        "A triangle of aluminium struts with a point mass at each corner, held at one corner by a spherical hinge:",
        "",
        "```toml",
        EXAMPLE.rstrip(),
        "```",
        "",
    ]
    lines += _tables_section() + _derived_section() + _companion_section() + _checks_section()
    return "\n".join(lines).rstrip() + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if the committed page differs")
    args = parser.parse_args(argv)
    text = reference_page()
    if args.check:
        same = PAGE.is_file() and PAGE.read_text(encoding="utf-8") == text
        print(f"{PAGE}: {'up to date' if same else 'differs from the slot table: run scripts/structure_reference.py'}")
        return 0 if same else 1
    PAGE.write_text(text, encoding="utf-8")
    print(f"wrote {PAGE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
