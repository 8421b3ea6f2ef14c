"""The structure file: exact round trips, checks that name every bad element, safe companion files,
and a reference page that is what the slot table generates.

Round trips are compared bit for bit (float64 bytes, so ``-0.0`` and ``0.0`` differ). Masses and
rigidities derived from the section and material keys are compared with the analytic formulas:
products and quotients of exactly stated inputs, so within a few float64 roundings (1e-15
relative) unless the inputs are themselves rounded (the example boom's node coordinates are
written to 1e-6 m, hence 1e-5 relative on its mass).
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import math
import pathlib
import re
import tomllib
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from magsail_mj.structure import checks, fileread, filevalues
from magsail_mj.structure.fileformat import SLOTS, read_structure, structure_from_mapping, write_structure
from magsail_mj.structure.filewrite import structure_tree
from magsail_mj.structure.model import Members, Panels, RigidPart, Structure, StructureError
from magsail_mj.structure.tomlwrite import Inline, dumps
from tests.conftest import load_file_module

ROOT = Path(__file__).resolve().parents[1]
BOOM = ROOT / "tests" / "data" / "structures" / "boom" / "boom.toml"
PAGE = ROOT / "docs" / "structure_file.md"


# -- helpers ----------------------------------------------------------------------------------------
def _bits(array) -> tuple:
    array = np.ascontiguousarray(array)
    return array.dtype.str, array.shape, array.tobytes()


def assert_same(a: Structure, b: Structure) -> None:
    """Every array of ``a`` and ``b`` equal bit for bit, sets in the same order."""
    assert a.name == b.name
    for name in ("positions_m", "node_mass_kg", "fixed_dofs"):
        assert _bits(getattr(a, name)) == _bits(getattr(b, name)), name
    for table, fields in ((a.members, Members), (a.panels, Panels)):
        other = b.members if fields is Members else b.panels
        for name in fields.__dataclass_fields__:
            assert _bits(getattr(table, name)) == _bits(getattr(other, name)), f"{fields.__name__}.{name}"
    assert len(a.rigid_parts) == len(b.rigid_parts)
    for pa, pb in zip(a.rigid_parts, b.rigid_parts):
        assert pa.name == pb.name
        assert _bits(np.float64(pa.mass_kg)) == _bits(np.float64(pb.mass_kg))
        for name in ("center_m", "inertia_kg_m2", "nodes"):
            assert _bits(getattr(pa, name)) == _bits(getattr(pb, name)), f"rigid part {name}"
    for sa, sb in ((a.node_sets, b.node_sets), (a.member_sets, b.member_sets)):
        assert list(sa) == list(sb)
        assert all(_bits(sa[k]) == _bits(sb[k]) for k in sa)


def base_tree() -> dict:
    """A valid structure under ``[structure]``: a strut triangle, two beams to a fourth node, a panel,
    a rigid part on the set ``root`` and node 3 held in translation."""
    return {
        "nodes": {"position_m": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.2]], "mass_kg": 0.5},
        "sets": {"root": [0], "far": [3]},
        "member_groups": [
            {"kind": "strut", "name": "edges", "nodes": [[0, 1], [1, 2], [2, 0]], "EA_N": 1.0e6},
            {"kind": "beam", "nodes": [[1, 3], [2, 3]], "EA_N": 1.0e6, "EI_Nm2": 10.0, "GJ_Nm2": 8.0},
        ],
        "panels": [{"nodes": [[0, 1, 2]], "reflectivity": [0.8, 0.1, 0.1], "areal_density_kg_m2": 0.1}],
        "rigid_parts": [
            {
                "name": "bus",
                "mass_kg": 5.0,
                "center_m": [0.0, 0.0, -0.1],
                "inertia_kgm2": [1.0, 1.0, 1.5],
                "nodes": "root",
            }
        ],
        "fixed": [{"nodes": "far", "dofs": "123"}],
    }


def _problems(tree: dict, base_dir: Path) -> str:
    with pytest.raises(StructureError) as info:
        structure_from_mapping(tree, base_dir=base_dir)
    return str(info.value)


def _add_node(tree: dict, position: list[float], *, member: list[int] | None = None) -> None:
    tree["nodes"]["position_m"].append(position)
    if member is not None:
        tree["member_groups"][0]["nodes"].append(member)


def test_the_base_tree_is_valid_and_reads_what_it_says(tmp_path):
    s = structure_from_mapping(base_tree(), base_dir=tmp_path).structure
    assert s.n_nodes == 4 and s.n_members == 5 and len(s.panels) == 1
    assert list(s.member_sets) == ["edges"] and s.member_sets["edges"].tolist() == [0, 1, 2]
    assert s.fixed_dofs[3].tolist() == [True, True, True, False, False, False] and not s.fixed_dofs[:3].any()
    np.testing.assert_array_equal(s.panels.nodes, [[0, 1, 2, -1]])
    np.testing.assert_array_equal(s.members.rest_length_m[:3], [1.0, math.sqrt(2.0), 1.0])


# -- every bad structure class names its element ------------------------------------------------------
def _set(path: str, value):
    """A mutation setting the key at ``path`` (dots and [i]) of the tree to ``value``."""

    def mutate(tree: dict, tmp_path: Path) -> None:
        keys = [int(k) if k.isdigit() else k for k in re.findall(r"[^.\[\]]+", path)]
        target = tree
        for key in keys[:-1]:
            target = target[key]
        target[keys[-1]] = value

    return mutate


def _drop(path: str):
    def mutate(tree: dict, tmp_path: Path) -> None:
        group, index, key = path.split(".")
        del tree[group][int(index)][key]

    return mutate


def _nodes_added(*positions, members=(), masses=None):
    def mutate(tree: dict, tmp_path: Path) -> None:
        for p in positions:
            _add_node(tree, list(p))
        tree["member_groups"][0]["nodes"] += [list(m) for m in members]
        if masses is not None:
            tree["nodes"]["mass_kg"] = masses

    return mutate


def _all(*mutations):
    def mutate(tree: dict, tmp_path: Path) -> None:
        for mutation in mutations:
            mutation(tree, tmp_path)

    return mutate


def _torsion_from_nu(tree: dict, tmp_path: Path) -> None:
    group = tree["member_groups"][1]
    del group["GJ_Nm2"]
    group.update({"J_m4": 1e-9, "E_Pa": 1e9, "nu": 0.7})


def _garbage_npz(tree: dict, tmp_path: Path) -> None:
    (tmp_path / "bad.npz").write_bytes(b"not a zip archive at all")
    tree["nodes"]["position_m"] = {"file": "bad.npz", "array": "p"}


def _two_parts(second: dict):
    def mutate(tree: dict, tmp_path: Path) -> None:
        tree["rigid_parts"].append(
            {"mass_kg": 1.0, "center_m": [1.0, 1.0, 0.2], "inertia_kgm2": [1.0, 1.0, 1.0], **second}
        )

    return mutate


BAD = {
    "nan position": (
        _set("nodes.position_m[1]", [math.nan, 0.0, 0.0]),
        "structure.nodes[1].position_m: not finite ([nan, 0.0, 0.0])",
    ),
    "duplicate node": (
        _nodes_added([1.0, 0.0, 0.0], members=[[3, 4]]),
        "structure.nodes[4].position_m: [1.0, 0.0, 0.0] coincides with node 1",
    ),
    "negative mass": (
        _set("nodes.mass_kg", [0.5, -1.0, 0.5, 0.5]),
        "structure.nodes[1].mass_kg: must be finite and >= 0, got -1.0",
    ),
    "zero total mass": (
        _all(
            _set("nodes.mass_kg", 0.0),
            _set("panels[0].areal_density_kg_m2", 0.0),
            _set("rigid_parts[0].mass_kg", 0.0),
            _set("rigid_parts[0].inertia_kgm2", [0.0, 0.0, 0.0]),
        ),
        "structure: total mass is 0.0 kg",
    ),
    "dangling member end": (
        _set("member_groups[0].nodes[1]", [1, 999]),
        "structure.members[1].nodes: node 999 does not exist (4 nodes) [member_groups[0], row 1]",
    ),
    "zero-length member": (
        _nodes_added([0.0, 0.0, 1e-12], members=[[0, 4]]),
        "structure.members[3].nodes: nodes 0 and 4 are 1e-12 m apart (zero length",
    ),
    "member with both ends the same node": (
        _set("member_groups[0].nodes[2]", [2, 2]),
        "structure.members[2].nodes: both ends are node 2",
    ),
    "EA not positive": (
        _set("member_groups[1].EA_N", [1.0e6, -5.0]),
        "structure.members[4].EA_N: must be > 0, got -5.0 [member_groups[1], row 1]",
    ),
    "negative EI": (
        _set("member_groups[1].EI_Nm2", [[10.0, -1.0], [10.0, 10.0]]),
        "structure.members[3].EI_Nm2: must be >= 0, got [10.0, -1.0]",
    ),
    "negative GJ": (
        _set("member_groups[1].GJ_Nm2", [-8.0, 8.0]),
        "structure.members[3].GJ_Nm2: must be >= 0, got -8.0",
    ),
    "negative damping": (
        _set("member_groups[0].damping_Ns_m", -1.0),
        "structure.members[0].damping_Ns_m: must be >= 0, got -1.0",
    ),
    "beam without EI": (
        _drop("member_groups.1.EI_Nm2"),
        "structure.members[3]: a beam needs EI_Nm2 > 0 about both axes and GJ_Nm2 > 0, got EI_Nm2 [0.0, 0.0]",
    ),
    "beam without GJ": (_drop("member_groups.1.GJ_Nm2"), "and GJ_Nm2 0.0 [member_groups[1], row 0]"),
    "strut with bending": (
        _set("member_groups[0].EI_Nm2", 5.0),
        "structure.members[0].EI_Nm2: a strut carries no bending or torsion",
    ),
    "strain limit zero": (
        _set("member_groups[0].strain_limit", 0.0),
        "structure.members[0].strain_limit: must be > 0, got 0.0",
    ),
    "prestrain -1": (
        _set("member_groups[0].prestrain", [0.0, -1.0, 0.0]),
        "structure.member_groups[0].prestrain: must be > -1, got -1.0 (member 1 of the group)",
    ),
    "panel repeated corner": (
        _set("panels[0].nodes", [[0, 1, 1]]),
        "structure.panels[0].nodes: a corner repeats ([0, 1, 1])",
    ),
    "panel zero area": (
        _nodes_added([2.0, 0.0, 0.0], members=[[1, 4]]),
        None,  # the panel is set below to the collinear corners 0, 1, 4
    ),
    "reflectivity sum": (
        _set("panels[0].reflectivity", [0.8, 0.1, 0.2]),
        "structure.panels[0].reflectivity: fractions must be >= 0 and sum to 1 within 1e-09, got [0.8, 0.1, 0.2]",
    ),
    "reflectivity negative": (
        _set("panels[0].reflectivity", [1.1, -0.1, 0.0]),
        "structure.panels[0].reflectivity: fractions must be >= 0 and sum to 1",
    ),
    "inertia not symmetric": (
        _set("rigid_parts[0].inertia_kgm2", [1.0, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.5]),
        "structure.rigid_parts[0].inertia_kgm2: not symmetric",
    ),
    "inertia not positive definite": (
        _set("rigid_parts[0].inertia_kgm2", [1.0, 1.0, 1.5, 2.0, 0.0, 0.0]),
        "structure.rigid_parts[0].inertia_kgm2: not positive definite",
    ),
    "inertia triangle inequality": (
        _set("rigid_parts[0].inertia_kgm2", [1.0, 1.0, 3.0]),
        "structure.rigid_parts[0].inertia_kgm2: principal moments [1.0, 1.0, 3.0] violate the triangle inequality",
    ),
    "repeated rigid part name": (
        _two_parts({"name": "bus", "nodes": [3]}),
        "structure.rigid_parts[1].name: 'bus' is also",
    ),
    "node held by two rigid parts": (
        _two_parts({"name": "hub", "nodes": [3, 0]}),
        "structure.rigid_parts[1].nodes: node 0 is also held by rigid part 'bus'",
    ),
    "disconnected parts": (
        _nodes_added([5.0, 5.0, 5.0], [6.0, 5.0, 5.0], members=[[4, 5]]),
        "structure: 2 disconnected parts (the largest has 4 nodes); a node of each smaller part: nodes[4] (2 nodes)",
    ),
    "untouched massless node": (
        _nodes_added([3.0, 3.0, 3.0], masses=[0.5, 0.5, 0.5, 0.5, 0.0]),
        "structure.nodes[4]: no member, panel or rigid part touches it and it has no mass",
    ),
    "group name colliding": (
        _set("member_sets", {"edges": [0]}),
        "structure.member_groups[0].name: 'edges' is also a key of member_sets",
    ),
    "node set index out of range": (
        _set("sets.probe", [0, 7]),
        "structure.sets['probe'][1]: node 7 does not exist (4 nodes)",
    ),
    "member set index out of range": (
        _set("member_sets", {"rods": [0, 9]}),
        "structure.member_sets['rods'][1]: member 9 does not exist (5 members)",
    ),
    # schema
    "unknown key": (_set("member_groups[0].EA", 1.0), "structure.member_groups[0].EA: unknown key"),
    "wrong type": (_set("nodes.mass_kg", "heavy"), "structure.nodes.mass_kg: must be numbers, got 'heavy'"),
    "boolean for a number": (
        _set("member_groups[0].EA_N", True),
        "structure.member_groups[0].EA_N: must be numbers, got True",
    ),
    "wrong shape": (
        _set("nodes.position_m", [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]),
        "structure.nodes.position_m: rows of 3 numbers are needed, got shape (4, 2)",
    ),
    "ragged rows": (
        _set("member_groups[0].nodes", [[0, 1], [1]]),
        "structure.member_groups[0].nodes: rows of different lengths",
    ),
    "per-member length": (
        _set("member_groups[1].EA_N", [1.0, 2.0, 3.0]),
        "structure.member_groups[1].EA_N: one number or 2 numbers (one per member) are needed, got shape (3,)",
    ),
    "missing required key": (_drop("panels.0.reflectivity"), "structure.panels[0].reflectivity: required"),
    "unknown kind": (
        _set("member_groups[0].kind", "rope"),
        "structure.member_groups[0].kind: must be one of strut, cable, beam, got 'rope'",
    ),
    "fractional index": (
        _set("member_groups[0].nodes", [[0, 1.5]]),
        "structure.member_groups[0].nodes: must be integers",
    ),
    "companion file missing": (
        _set("nodes.position_m", {"file": "missing.npz", "array": "p"}),
        "structure.nodes.position_m: companion file 'missing.npz' does not exist",
    ),
    "companion file unreadable": (
        _garbage_npz,
        "structure.nodes.position_m: companion file 'bad.npz' is not a readable .npz",
    ),
    "two ways of one property": (
        _set("member_groups[0].rest_length_m", 1.0),
        None,  # prestrain added below
    ),
    "key left unused": (_set("member_groups[0].area_m2", 1.0e-4), "structure.member_groups[0].area_m2: not used"),
    "section key on a strut": (
        _set("member_groups[0].I1_m4", 1.0e-9),
        "structure.member_groups[0].I1_m4: only beams take section bending and torsion",
    ),
    "Poisson's ratio out of range": (
        _torsion_from_nu,
        "structure.member_groups[1].nu: must be in (-1, 0.5), got 0.7",
    ),
    "newer version": (_set("version", 2), "structure.version: 2 is newer than the version this magsail_mj reads (1)"),
    "wrong format": (_set("format", "other"), 'structure.format: must be "magsail-structure"'),
    "unknown node set": (
        _set("rigid_parts[0].nodes", "hub"),
        "structure.rigid_parts[0].nodes: no node set named 'hub'",
    ),
    "bad dofs": (_set("fixed[0].dofs", "127"), "structure.fixed[0].dofs: must be distinct digits 1-6"),
    "fixed node out of range": (
        _set("fixed[0].nodes", [9]),
        "structure.fixed[0].nodes: node 9 does not exist (4 nodes)",
    ),
}


@pytest.mark.parametrize("case", list(BAD))
def test_every_bad_structure_is_refused_naming_its_element(case, tmp_path):
    tree = base_tree()
    mutate, expected = BAD[case]
    mutate(tree, tmp_path)
    if case == "panel zero area":
        tree["panels"][0]["nodes"] = [[0, 1, 4]]
        expected = "structure.panels[0].nodes: zero area (0.0 m², corners [0, 1, 4, -1] are collinear)"
    if case == "two ways of one property":
        tree["member_groups"][0]["prestrain"] = 0.0
        expected = "structure.member_groups[0]: give rest_length_m or prestrain, not rest_length_m and prestrain"
    message = _problems(tree, tmp_path)
    assert expected in message, message
    assert all(line.startswith("structure") for line in message.splitlines()), message


def test_all_problems_are_reported_at_once(tmp_path):
    tree = base_tree()
    tree["nodes"]["mass_kg"] = [0.5, -2.0, 0.5, 0.5]
    tree["member_groups"][0]["nodes"][0] = [0, 17]
    tree["panels"][0]["reflectivity"] = [0.5, 0.5, 0.5]
    lines = _problems(tree, tmp_path).splitlines()
    assert any(line.startswith("structure.nodes[1].mass_kg") for line in lines)
    assert any(line.startswith("structure.members[0].nodes: node 17") for line in lines)
    assert any(line.startswith("structure.panels[0].reflectivity") for line in lines)
    tree = base_tree()
    tree["member_groups"][0]["EA"] = 1.0
    tree["panels"][0]["drag"] = 1.0
    assert len(_problems(tree, tmp_path).splitlines()) == 2


def test_many_bad_elements_are_listed_up_to_a_cap_then_counted():
    n = 30
    positions = np.stack([np.arange(n, dtype=float), np.arange(n, dtype=float) ** 2, np.zeros(n)], axis=1)
    pairs = np.stack([np.arange(n - 1), np.arange(1, n)], axis=1)
    members = Members.build(pairs, positions_m=positions, EA_N=np.where(np.arange(n - 1) < 25, -1.0, 1.0))
    s = Structure(name="chain", positions_m=positions, node_mass_kg=np.ones(n), members=members)
    lines = checks.structure_problems(s)
    listed = [line for line in lines if line.endswith("must be > 0, got -1.0")]
    assert [line.split(".")[0] for line in listed] == [f"members[{i}]" for i in range(checks.MAX_LISTED)]
    assert f"members: {25 - checks.MAX_LISTED} more with the same problem (not listed)" in lines


def test_the_count_cap_refuses_before_reading_on(monkeypatch, tmp_path):
    monkeypatch.setattr(filevalues, "MAX_COUNT", 3)
    monkeypatch.setattr(fileread, "MAX_COUNT", 3)
    message = _problems(base_tree(), tmp_path)
    assert "structure.nodes.position_m: 4 entries, more than 3" in message


def test_a_huge_array_header_is_refused_before_allocating(tmp_path):
    """An .npy header claiming 3e9 numbers (24 GB) with no data behind it: refused from the header."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False, "shape": (10**9, 3)})
    with zipfile.ZipFile(tmp_path / "huge.npz", "w") as archive:
        archive.writestr("p.npy", header.getvalue())
    tree = base_tree()
    tree["nodes"]["position_m"] = {"file": "huge.npz", "array": "p"}
    assert "structure.nodes.position_m: huge.npz['p']: 3000000000 numbers" in _problems(tree, tmp_path)


# -- companion files ---------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("../outside.npz", "leaves the structure file's folder ('..' is refused)"),
        ("sub/../../outside.npz", "leaves the structure file's folder"),
        ("/etc/outside.npz", "is an absolute path"),
        ("C:\\data\\outside.npz", "is an absolute path"),
        ("nodes.txt", "is neither an .npz nor a .csv file"),
        ("", "a companion file is a relative path string"),
    ],
)
def test_companion_paths_that_leave_the_folder_are_refused(tmp_path, name, expected):
    inner = tmp_path / "inner"
    inner.mkdir()
    np.savez(tmp_path / "outside.npz", p=np.zeros((4, 3)))
    tree = base_tree()
    tree["nodes"]["position_m"] = {"file": name, "array": "p"}
    message = _problems(tree, inner)
    assert "structure.nodes.position_m.file: " in message and expected in message, message


def test_a_link_leading_out_of_the_folder_is_refused(tmp_path):
    inner = tmp_path / "inner"
    inner.mkdir()
    np.savez(tmp_path / "outside.npz", p=np.zeros((4, 3)))
    (inner / "link.npz").symlink_to(tmp_path / "outside.npz")
    tree = base_tree()
    tree["nodes"]["position_m"] = {"file": "link.npz", "array": "p"}
    assert "'link.npz' leads out of the structure file's folder (through a link)" in _problems(tree, inner)


class _Trap:
    """Unpickling this object creates the file ``marker`` (it must never happen)."""

    def __init__(self, marker: Path):
        self.marker = marker

    def __reduce__(self):
        return (pathlib.Path.touch, (self.marker,))


def test_an_object_array_in_an_npz_is_refused_and_never_unpickled(tmp_path):
    marker = tmp_path / "unpickled"
    objects = np.empty(4, dtype=object)
    objects[:] = [_Trap(marker)] * 4
    np.savez(tmp_path / "trap.npz", pairs=objects)  # np.savez pickles object arrays
    tree = base_tree()
    tree["member_groups"][0]["nodes"] = {"file": "trap.npz", "array": "pairs"}
    message = _problems(tree, tmp_path)
    assert "structure.member_groups[0].nodes: trap.npz['pairs']: holds Python objects" in message
    assert not marker.exists()
    with pytest.raises(StructureError, match="holds Python objects"):
        structure_from_mapping(
            {**base_tree(), "sets": {"root": {"file": "trap.npz", "array": "pairs"}}}, base_dir=tmp_path
        )
    assert not marker.exists()


def test_csv_columns_and_indices(tmp_path):
    (tmp_path / "m.csv").write_text("a,b,EA_N\n0,1,1e6\n1,2,2e6\n2,0,3e6\n")
    tree = base_tree()
    group = tree["member_groups"][0]
    group["nodes"] = {"file": "m.csv", "columns": ["a", "b"]}
    group["EA_N"] = {"file": "m.csv", "columns": "EA_N"}
    s = structure_from_mapping(tree, base_dir=tmp_path)
    np.testing.assert_array_equal(s.structure.members.nodes[:3], [[0, 1], [1, 2], [2, 0]])
    np.testing.assert_array_equal(s.structure.members.EA_N[:3], [1e6, 2e6, 3e6])
    assert s.sha256 == {"m.csv": hashlib.sha256((tmp_path / "m.csv").read_bytes()).hexdigest()}
    group["nodes"] = {"file": "m.csv", "columns": ["a", "c"]}
    assert "no column 'c' (the header has a, b, EA_N)" in _problems(tree, tmp_path)
    (tmp_path / "f.csv").write_text("a,b\n0,1.5\n")
    group["nodes"] = {"file": "f.csv"}
    assert "structure.member_groups[0].nodes: must be integers, got 1.5" in _problems(tree, tmp_path)
    group["nodes"] = {"file": "m.csv", "array": "x"}
    assert "'m.csv' is a .csv file: name its columns with 'columns'" in _problems(tree, tmp_path)


def test_the_example_boom_reads_with_its_digests_and_analytic_mass():
    source = read_structure(BOOM)
    s = source.structure
    folder = BOOM.parent
    assert source.sha256 == {
        name: hashlib.sha256((folder / name).read_bytes()).hexdigest()
        for name in ("boom.toml", "boom_nodes.csv", "boom.npz", "boom_battens.csv")
    }
    assert (s.n_nodes, s.n_members, len(s.panels), len(s.rigid_parts)) == (12, 30, 1, 1)
    assert list(s.member_sets) == ["longerons", "diagonals"]
    np.testing.assert_array_equal(s.member_sets["diagonals"], np.arange(21, 30))
    # beams: EI = E I, GJ = E / (2 (1 + nu)) J
    np.testing.assert_allclose(s.members.EI_Nm2[:9], 120e9 * 3.5e-10, rtol=1e-15)
    np.testing.assert_allclose(s.members.GJ_Nm2[:9], 120e9 / 2.6 * 7e-10, rtol=1e-15)
    np.testing.assert_allclose(s.members.rest_length_m[21:], np.hypot(0.5, 0.2 * math.sqrt(3)) / 1.001, rtol=1e-5)
    side = 0.2 * math.sqrt(3.0)  # triangle of circumradius 0.2 m
    expected = 12 * 0.05 + 9 * 0.5 * 1600.0 * 3e-5 + 12 * side * 0.02 + 0.2 * side * 0.5 + 12.0
    assert s.mass_properties()[0] == pytest.approx(expected, rel=1e-5)


@pytest.mark.parametrize("arrays", ["inline", "npz"])
def test_the_boom_round_trips_exactly(tmp_path, arrays):
    original = read_structure(BOOM).structure
    written = write_structure(original, tmp_path / "copy.toml", arrays=arrays)
    assert [p.name for p in written] == (["copy.toml", "copy.npz"] if arrays == "npz" else ["copy.toml"])
    back = read_structure(tmp_path / "copy.toml")
    assert_same(original, back.structure)
    assert sorted(back.sha256) == sorted(p.name for p in written)


def test_derived_member_properties(tmp_path):
    tree = base_tree()
    tree["member_groups"][1] = {
        "kind": "beam",
        "nodes": [[1, 3], [2, 3]],
        "area_m2": 2.0e-4,
        "E_Pa": 200.0e9,
        "I1_m4": 3.0e-9,
        "I2_m4": 5.0e-9,
        "J_m4": 8.0e-9,
        "nu": 0.25,
        "density_kg_m3": 7850.0,
        "prestrain": 0.01,
    }
    m = structure_from_mapping(tree, base_dir=tmp_path).structure.members
    np.testing.assert_array_equal(m.EA_N[3:], 200.0e9 * 2.0e-4)
    np.testing.assert_array_equal(m.EI_Nm2[3:], [[200.0e9 * 3.0e-9, 200.0e9 * 5.0e-9]] * 2)
    np.testing.assert_allclose(m.GJ_Nm2[3:], 80.0e9 * 8.0e-9, rtol=1e-15)  # G = E / 2.5
    np.testing.assert_allclose(m.linear_density_kg_m[3:], 7850.0 * 2.0e-4, rtol=1e-15)
    np.testing.assert_allclose(m.rest_length_m[3:], math.sqrt(1.04) / 1.01, rtol=1e-15)


def test_six_inertia_numbers_are_the_tensor_entries(tmp_path):
    tree = base_tree()
    tree["rigid_parts"][0]["inertia_kgm2"] = [1.0, 2.0, 2.5, 0.1, 0.2, 0.3]
    part = structure_from_mapping(tree, base_dir=tmp_path).structure.rigid_parts[0]
    np.testing.assert_array_equal(part.inertia_kg_m2, [[1.0, 0.1, 0.2], [0.1, 2.0, 0.3], [0.2, 0.3, 2.5]])


def test_a_file_needs_its_header_and_names_itself(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text("[nodes]\nposition_m = [[0.0, 0.0, 0.0]]\nmass_kg = 1.0\n")
    with pytest.raises(StructureError) as info:
        read_structure(path)
    assert f"{path}: format: required in a structure file" in str(info.value)
    assert f"{path}: version: required in a structure file" in str(info.value)
    path.write_text(
        'format = "magsail-structure"\nversion = 1\n[nodes]\nposition_m = [[0.0, 0.0, 0.0]]\nmass_kg = 1.0\n'
    )
    s = read_structure(path).structure
    assert s.name == "s" and s.n_nodes == 1 and s.n_members == 0
    path.write_text("nodes = [")
    with pytest.raises(StructureError, match="not valid TOML"):
        read_structure(path)
    with pytest.raises(StructureError, match="does not exist"):
        read_structure(tmp_path / "none.toml")


def test_write_refuses_an_invalid_structure_and_an_unknown_mode(tmp_path):
    s = structure_from_mapping(base_tree(), base_dir=tmp_path).structure
    bad = Structure(name="x", positions_m=s.positions_m, node_mass_kg=-s.node_mass_kg, members=s.members)
    with pytest.raises(StructureError, match=r"nodes\[0\].mass_kg"):
        write_structure(bad, tmp_path / "bad.toml")
    assert not (tmp_path / "bad.toml").exists()
    with pytest.raises(ValueError, match="arrays: must be one of"):
        write_structure(s, tmp_path / "s.toml", arrays="zip")


def test_toml_writer_round_trips_awkward_floats_and_strings():
    floats = np.array([math.inf, -math.inf, -0.0, 0.0, 5e-324, 1.7976931348623157e308, 0.1, 1e16, -2.5e-7])
    names = ["plain", "with space", 'quote"', "back\\slash", "new\nline", "\x00\x1f\x7f", "ünï ✓", ""]
    tree = {
        "a": floats,
        "s": names,
        "rows": np.arange(6, dtype=np.int64).reshape(3, 2),
        "t": {name: 1 for name in names},
        "ref": Inline(file="x.npz", array="a b"),
        "groups": [{"flag": True, "v": np.float64(1.5)}, {"flag": False}],
    }
    back = tomllib.loads(dumps(tree))
    assert _bits(np.array(back["a"])) == _bits(floats)
    assert back["s"] == names and list(back["t"]) == names
    assert back["rows"] == [[0, 1], [2, 3], [4, 5]] and back["ref"] == {"file": "x.npz", "array": "a b"}
    assert back["groups"] == [{"flag": True, "v": 1.5}, {"flag": False}]


# -- property tests ----------------------------------------------------------------------------------
_names = st.text(alphabet=st.characters(exclude_categories=("Cs",)), min_size=0, max_size=6)
_positive = st.floats(min_value=1e-300, max_value=1e300)
_nonnegative = st.floats(min_value=0.0, max_value=1e6) | st.just(-0.0)


@st.composite
def structures(draw) -> Structure:
    """Valid structures: nodes along a parabola (so consecutive nodes are never collinear), a chain
    of members joining them all plus random extra members, random kinds and properties of odd bits,
    triangle and quad panels, rigid parts with random rotated inertia, sets and constraints."""
    n = draw(st.integers(3, 9))
    small = st.floats(-0.01, 0.01)
    jitter = np.array(draw(st.lists(st.tuples(small, small, st.floats(-10, 10)), min_size=n, max_size=n)))
    i = np.arange(n, dtype=float)
    positions = np.stack([i, i**2, np.zeros(n)], axis=1) + jitter
    pair = st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)).filter(lambda p: p[0] != p[1])
    pairs = np.array([(k, k + 1) for k in range(n - 1)] + draw(st.lists(pair, max_size=5)), dtype=np.int64)
    m = pairs.shape[0]
    kind = np.array(draw(st.lists(st.integers(0, 2), min_size=m, max_size=m)), dtype=np.int8)
    beam = kind == 2

    def column(strategy, size=m) -> np.ndarray:
        return np.array(draw(st.lists(strategy, min_size=size, max_size=size)), dtype=float)

    length = filevalues.member_lengths_m(positions, pairs)
    members = Members(
        nodes=pairs,
        kind=kind,
        EA_N=column(_positive),
        EI_Nm2=np.where(beam[:, None], column(_positive, 2 * m).reshape(m, 2), 0.0),
        GJ_Nm2=np.where(beam, column(_positive), 0.0),
        damping_Ns_m=column(_nonnegative),
        rest_length_m=length if draw(st.booleans()) else column(_positive),
        strain_limit=column(_positive | st.just(math.inf)),
        linear_density_kg_m=column(_nonnegative),
        orientation=np.where(beam[:, None], np.array([[0.0, 0.0, 1.0]]) * column(st.floats(0.5, 2.0))[:, None], 0.0),
    )
    starts = draw(st.lists(st.integers(0, n - 3), max_size=3))
    corners = [[s, s + 1, s + 2, s + 3 if s + 3 < n and draw(st.booleans()) else -1] for s in starts]
    fractions = []
    for _ in corners:
        a = draw(st.floats(0.0, 1.0))
        b = draw(st.floats(0.0, 1.0 - a))
        fractions.append([a, b, (1.0 - a) - b])
    p = len(corners)
    panels = Panels(
        nodes=np.array(corners, dtype=np.int64).reshape(p, 4),
        areal_density_kg_m2=column(_nonnegative, p),
        reflectivity=np.array(fractions, dtype=float).reshape(p, 3),
        drag_coefficient=column(st.floats(0.1, 10.0), p),
    )
    parts = tuple(_rigid_part(draw, k) for k in range(draw(st.integers(0, 2))))
    masses = column(_nonnegative, n)
    masses[0] = draw(st.floats(1e-3, 1e6))
    node_sets = draw(st.dictionaries(_names.map("n".__add__), st.lists(st.integers(0, n - 1), max_size=4), max_size=2))
    member_sets = draw(
        st.dictionaries(_names.map("m".__add__), st.lists(st.integers(0, m - 1), max_size=4), max_size=2)
    )
    return Structure(
        name=draw(_names),
        positions_m=positions,
        node_mass_kg=masses,
        members=members,
        panels=panels,
        rigid_parts=parts,
        node_sets={k: np.array(v, dtype=np.int64) for k, v in node_sets.items()},
        member_sets={k: np.array(v, dtype=np.int64) for k, v in member_sets.items()},
        fixed_dofs=np.array(draw(st.lists(st.lists(st.booleans(), min_size=6, max_size=6), min_size=n, max_size=n))),
    )


def _rigid_part(draw, k: int) -> RigidPart:
    """Part ``k`` on node ``k``: principal moments obeying the triangle inequality, rotated."""
    a, b = draw(st.floats(0.1, 10.0)), draw(st.floats(0.1, 10.0))
    c = abs(a - b) + draw(st.floats(0.1, 0.9)) * (a + b - abs(a - b))
    q = np.array(draw(st.tuples(*[st.floats(-1.0, 1.0)] * 4)))
    q = q / np.linalg.norm(q) if np.linalg.norm(q) > 0.1 else np.array([1.0, 0.0, 0.0, 0.0])
    w, x, y, z = q
    rotation = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    inertia = np.diag([a, b, c]) if draw(st.booleans()) else rotation @ np.diag([a, b, c]) @ rotation.T
    return RigidPart(
        name=f"part{k}",
        mass_kg=draw(st.floats(0.0, 1e3)),
        center_m=np.array(draw(st.tuples(*[st.floats(-5.0, 5.0)] * 3))),
        inertia_kg_m2=inertia,
        nodes=np.array([k], dtype=np.int64),
    )


_PROPERTY = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@_PROPERTY
@given(structure=structures(), arrays=st.sampled_from(["inline", "npz"]))
def test_random_valid_structures_pass_the_checks_and_round_trip_exactly(tmp_path, structure, arrays):
    assert checks.structure_problems(structure) == []
    write_structure(structure, tmp_path / "s.toml", arrays=arrays)
    assert_same(structure, read_structure(tmp_path / "s.toml").structure)


@_PROPERTY
@given(structure=structures(), corruption=st.sampled_from(["member node", "NaN", "negative mass"]), data=st.data())
def test_random_corruptions_are_reported_naming_the_element(tmp_path, structure, corruption, data):
    tree, _ = structure_tree(structure, arrays="inline", npz_name="unused.npz")
    n = structure.n_nodes
    if corruption == "member node":
        i = data.draw(st.integers(0, structure.n_members - 1), label="member")
        end = data.draw(st.integers(0, 1), label="end")
        node = data.draw(st.integers(n, 2**40) | st.integers(-(2**40), -1), label="node")
        kinds = structure.members.kind
        g = int(np.count_nonzero(np.diff(kinds[: i + 1])))  # groups are runs of one kind
        row = i - int(np.flatnonzero(np.concatenate([[True], np.diff(kinds[: i + 1]) != 0]))[-1])
        pairs = np.array(tree["member_groups"][g]["nodes"])
        pairs[row, end] = node
        tree["member_groups"][g]["nodes"] = pairs
        expected = (
            f"structure.members[{i}].nodes: node {node} does not exist ({n} nodes) [member_groups[{g}], row {row}]"
        )
    elif corruption == "NaN":
        j = data.draw(st.integers(0, n - 1), label="node")
        positions = np.array(structure.positions_m)
        positions[j, data.draw(st.integers(0, 2), label="axis")] = math.nan
        tree["nodes"]["position_m"] = positions
        expected = f"structure.nodes[{j}].position_m: not finite"
    else:
        j = data.draw(st.integers(0, n - 1), label="node")
        masses = np.array(structure.node_mass_kg)
        masses[j] = -data.draw(st.floats(5e-324, 1e300), label="mass")
        tree["nodes"]["mass_kg"] = masses
        expected = f"structure.nodes[{j}].mass_kg: must be finite and >= 0, got {float(masses[j])!r}"
    with pytest.raises(StructureError) as info:
        structure_from_mapping(tree, base_dir=tmp_path)
    assert expected in str(info.value), str(info.value)


# -- the reference page --------------------------------------------------------------------------------
def test_the_reference_page_is_what_the_slot_table_generates():
    page = load_file_module("scripts", "structure_reference").reference_page()
    assert PAGE.read_text(encoding="utf-8") == page, "run: python scripts/structure_reference.py"
    for slot in SLOTS:
        assert f"| `{slot.key}` |" in page
    index = (ROOT / "docs" / "index.md").read_text()
    assert re.search(r":caption: Reference\n\n(?:[\w/-]+\n)*structure_file\n", index)


def test_the_pages_example_is_a_valid_structure_of_the_stated_mass(tmp_path):
    blocks = re.findall(r"```toml\n(.*?)```", PAGE.read_text(encoding="utf-8"), flags=re.DOTALL)
    s = structure_from_mapping(tomllib.loads(blocks[0]), base_dir=tmp_path, key_prefix="").structure
    assert s.name == "hinged_triangle" and list(s.member_sets["edges"]) == [0, 1, 2]
    np.testing.assert_allclose(s.members.EA_N, 7.0e6, rtol=1e-15)
    # three 0.5 kg nodes and 0.27 kg/m over the perimeter 2 + sqrt(2) m
    assert s.mass_properties()[0] == pytest.approx(1.5 + 2700.0 * 1.0e-4 * (2.0 + math.sqrt(2.0)), rel=1e-14)
    assert s.fixed_dofs[0].tolist() == [True] * 3 + [False] * 3


def test_a_name_may_name_a_node_set_and_a_member_set():
    """Node sets and member sets are separate tables (a mesh's physical group gives both its
    elements and its nodes one name): the same name in both is not a problem."""
    from magsail_mj.structure.checks import structure_problems
    from magsail_mj.structure.generators import four_boom_sail

    sail = four_boom_sail(
        side_m=10.0,
        n_segments=3,
        boom_EA_N=1e6,
        boom_EI_Nm2=1e3,
        boom_GJ_Nm2=1e3,
        boom_linear_density_kg_m=0.1,
        membrane_areal_density_kg_m2=0.01,
        reflectivity=(0.9, 0.05, 0.05),
    )
    assert structure_problems(sail) == []
    both = dataclasses.replace(sail, node_sets={**sail.node_sets, "booms": sail.node_sets["boom_nodes"]})
    assert structure_problems(both) == []


def test_stiffness_model_and_modal_damping_round_trip_and_are_checked(tmp_path):
    """The structure-level stiffness model and Caughey damping read, write back and refuse bad
    values naming the key."""
    tree = base_tree()
    tree["stiffness_model"] = "corotational"
    tree["modal_damping"] = {"schedule": "capped_rayleigh", "xi_low": 0.02, "n_low": 3, "frame": "inertial"}
    s = structure_from_mapping(tree, base_dir=tmp_path).structure
    assert s.stiffness_model == "corotational"
    assert s.modal_damping.schedule == "capped_rayleigh" and s.modal_damping.n_low == 3
    assert s.modal_damping.form == "dense" and s.modal_damping.rtol == 0.02  # defaults
    write_structure(s, tmp_path / "s.toml")
    back = read_structure(tmp_path / "s.toml").structure
    assert back.stiffness_model == s.stiffness_model and back.modal_damping == s.modal_damping
    for key, value, message in (
        ("stiffness_model", "linear", "structure.stiffness_model: must be one of members, corotational"),
        ("modal_damping", {"n_low": 0}, "structure.modal_damping.n_low: must be an integer >= 1"),
        ("modal_damping", {"frame": "world"}, "structure.modal_damping.frame: must be one of body, inertial"),
        ("modal_damping", {"xi_low": -1.0}, "structure.modal_damping.xi_low: must be finite and >= 0"),
        ("modal_damping", {"zeta": 0.1}, "structure.modal_damping.zeta: unknown key"),
    ):
        bad = {**tree, key: value}
        with pytest.raises(StructureError, match=re.escape(message)):
            structure_from_mapping(bad, base_dir=tmp_path)
