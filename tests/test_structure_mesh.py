"""gmsh meshes as structures (tests/data/meshes, written by make_meshes.py there).

Mass checks: a lumped triangle or quad keeps its area's mass and its centroid exactly, so mass and
centre of mass equal the continuum's to round-off (1e-12 relative). Second moments are compared to
closed forms of the lumped model: a triangle lumped at its corners exceeds the continuum's
∫ r rᵀ dA by (A/4) Σ dᵢdᵢᵀ (dᵢ corner − centroid); a regular grid of quads lumped at corners is the
trapezoidal rule, exceeding ∫ x² by L h² / 6 a direction.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from magsail_mj.structure.mesh import MemberProperties, PanelProperties, read_mesh
from magsail_mj.structure.model import MEMBER_KINDS, StructureError

MESHES = Path(__file__).parent / "data" / "meshes"
RTOL = 1e-12
BOOM = MemberProperties(kind="beam", EA_N=2.0e5, EI_Nm2=(12.0, 15.0), GJ_Nm2=8.0, linear_density_kg_m=0.05)
FILM = PanelProperties(areal_density_kg_m2=0.02, reflectivity=(0.88, 0.02, 0.1), drag_coefficient=2.0)
SAIL_GROUPS = {"booms": BOOM, "membrane": FILM}


def read_sail(name: str = "sail.msh", **options):
    return read_mesh(MESHES / name, groups=SAIL_GROUPS, **options)


@pytest.mark.parametrize("name", ["sail.msh", "sail_msh2.msh"])
def test_sail_mesh_members_panels_and_sets(name):
    """1 m square membrane on four booms hub → corner (MSH 4.1 and 2.2)."""
    s = read_sail(name)
    p = s.positions_m
    assert s.name == Path(name).stem
    assert s.n_members == len(s.member_sets["booms"]) and s.n_members % 4 == 0
    assert np.all(s.members.kind == MEMBER_KINDS.index("beam"))
    np.testing.assert_array_equal(s.members.EI_Nm2, np.tile([12.0, 15.0], (s.n_members, 1)))
    np.testing.assert_array_equal(s.members.GJ_Nm2, 8.0)
    ends = p[s.members.nodes]
    np.testing.assert_allclose(np.abs(ends[..., 0]), np.abs(ends[..., 1]), atol=1e-15)  # on the diagonals
    assert s.members.rest_length_m.sum() == pytest.approx(4 * math.sqrt(0.5), rel=RTOL)
    # boom_0 is both in 'booms' and 'boom_0': its elements kept once, in both sets
    assert set(s.member_sets["boom_0"]) < set(s.member_sets["booms"])
    np.testing.assert_allclose(p[s.node_sets["boom_0"], 0], p[s.node_sets["boom_0"], 1], atol=1e-15)
    np.testing.assert_array_equal(p[s.node_sets["hub"]], np.zeros((1, 3)))
    np.testing.assert_allclose(np.abs(p[s.node_sets["tips"]]), np.tile([0.5, 0.5, 0.0], (4, 1)), atol=1e-15)
    assert len(s.node_sets["membrane"]) == s.n_nodes
    tri = s.panels.triangles()
    normal_z = np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]])[:, 2]
    assert np.all(normal_z > 0)  # counter-clockwise about +z, as the quadrants' curve loops
    np.testing.assert_array_equal(s.panels.reflectivity, np.tile([0.88, 0.02, 0.1], (len(s.panels), 1)))
    np.testing.assert_array_equal(s.panels.drag_coefficient, 2.0)
    assert s.panels.areas_m2(p).sum() == pytest.approx(1.0, rel=RTOL)


def test_msh2_and_msh4_give_the_same_structure():
    """MSH 2 writes boom_0's elements twice (once per group); MSH 4 once, in two groups."""
    a, b = read_sail("sail.msh"), read_sail("sail_msh2.msh")
    np.testing.assert_array_equal(a.positions_m, b.positions_m)
    np.testing.assert_array_equal(a.members.nodes, b.members.nodes)
    np.testing.assert_array_equal(a.panels.nodes, b.panels.nodes)
    for x, y in ((a.node_sets, b.node_sets), (a.member_sets, b.member_sets)):
        assert x.keys() == y.keys()
        for key in x:
            np.testing.assert_array_equal(x[key], y[key])


def test_sail_mesh_mass_properties():
    """M = σ s² + λ · 4 L; centre at the origin; I_zz = σ s⁴/6 + Σ (σ A/4) Σ|dᵢ|² (lumped
    triangles) + 4 λ L³ (1 + 1/(2n²))/3 (each boom of n equal lumped segments)."""
    s = read_sail()
    sigma, lam, L = 0.02, 0.05, math.sqrt(0.5)
    n = s.n_members // 4
    p, tri = s.positions_m, s.panels.triangles()
    d = p[tri] - p[tri].mean(axis=1, keepdims=True)
    lumping = np.sum(sigma * s.panels.areas_m2(p) / 4 * np.sum(d[..., :2] ** 2, axis=(1, 2)))
    i_zz = sigma / 6 + lumping + 4 * lam * L**3 * (1 + 1 / (2 * n**2)) / 3
    mass, com, inertia = s.mass_properties()
    assert mass == pytest.approx(sigma + 4 * lam * L, rel=RTOL)
    np.testing.assert_allclose(com, 0.0, atol=RTOL)
    assert inertia[2, 2] == pytest.approx(i_zz, rel=RTOL)


def test_quad_plate_and_frame():
    """1 m × 0.5 m plate of 4 × 2 quads (h = 0.25 m), its edges 12 cable segments of density λ:
    plate I_yy = M (Lx²/12 + h²/6), I_xx = M (Ly²/12 + h²/6); each frame node carries λ h."""
    sigma, lam, h = 1.5, 0.01, 0.25
    s = read_mesh(
        MESHES / "quads.msh",
        groups={"frame": MemberProperties(kind="cable", EA_N=1e3, linear_density_kg_m=lam)},
        panels=PanelProperties(areal_density_kg_m2=sigma, reflectivity=(1.0, 0.0, 0.0)),
    )
    assert (s.n_nodes, s.n_members, len(s.panels)) == (15, 12, 8)
    assert np.all(s.panels.nodes[:, 3] >= 0)
    assert np.all(s.members.kind == MEMBER_KINDS.index("cable"))
    plate_m = sigma * 0.5
    frame = s.node_sets["frame"]
    assert len(frame) == 12
    r = s.positions_m[frame] - [0.5, 0.25, 0.0]
    i_xx = plate_m * (0.5**2 / 12 + h**2 / 6) + lam * h * np.sum(r[:, 1] ** 2)
    i_yy = plate_m * (1.0**2 / 12 + h**2 / 6) + lam * h * np.sum(r[:, 0] ** 2)
    mass, com, inertia = s.mass_properties()
    assert mass == pytest.approx(plate_m + lam * 3.0, rel=RTOL)
    np.testing.assert_allclose(com, [0.5, 0.25, 0.0], atol=RTOL)
    np.testing.assert_allclose(np.diag(inertia), [i_xx, i_yy, i_xx + i_yy], rtol=RTOL)


def test_unsupported_elements_name_the_type_and_file():
    path = MESHES / "tetra.msh"
    edges = MemberProperties(EA_N=1.0)
    with pytest.raises(StructureError, match=r"tetra\.msh'.*element type 'tetra' is not supported.*skip=\('tetra',\)"):
        read_mesh(path, members=edges)
    s = read_mesh(path, members=edges, skip=("tetra",))
    assert (s.n_nodes, s.n_members) == (8, 12)  # the cube's corners and edges; interior points left out
    assert s.members.rest_length_m.sum() == pytest.approx(12 * 0.1, rel=RTOL)


def test_points_merged_only_when_asked():
    cable = MemberProperties(kind="cable", EA_N=50.0)
    split = read_mesh(MESHES / "split_cable.msh", members=cable)
    assert split.n_nodes == 4 and len(np.unique(split.members.nodes)) == 4
    merged = read_mesh(MESHES / "split_cable.msh", members=cable, merge_tolerance_m=1e-6)
    assert merged.n_nodes == 3
    np.testing.assert_array_equal(merged.members.nodes, [[0, 1], [1, 2]])
    np.testing.assert_array_equal(merged.positions_m[:, 0], [0.0, 1.0, 2.0])  # the first of the merged points
    np.testing.assert_array_equal(merged.node_sets["ends"], [0, 2])
    with pytest.raises(StructureError, match="join coincident points.*merge_tolerance_m"):
        read_mesh(MESHES / "zero_link.msh", members=cable)
    with pytest.raises(StructureError, match=r"merge_tolerance_m: 1 line elements .* merged into one"):
        read_mesh(MESHES / "zero_link.msh", members=cable, merge_tolerance_m=1e-6)


def test_length_unit_scales_positions_and_masses():
    s = read_sail(length_unit_m=1e-3)
    np.testing.assert_allclose(s.positions_m, read_sail().positions_m * 1e-3, rtol=1e-15)
    assert s.mass_properties()[0] == pytest.approx(0.02e-6 + 4 * 0.05 * math.sqrt(0.5) * 1e-3, rel=RTOL)


def test_default_properties_for_unmapped_groups():
    s = read_mesh(MESHES / "sail.msh", groups={"membrane": FILM}, members=MemberProperties(EA_N=7.0))
    assert np.all(s.members.EA_N == 7.0) and np.all(s.members.kind == MEMBER_KINDS.index("strut"))


@pytest.mark.parametrize(
    "options, message",
    [
        ({"groups": {"booms": BOOM}}, r"surface elements .*\['membrane'\]\) have no PanelProperties.*panels="),
        ({"groups": {"membrane": FILM}}, r"line elements .*'booms'.* have no MemberProperties.*members="),
        ({"groups": {**SAIL_GROUPS, "boom": BOOM}}, r"groups\['boom'\]: .* has no physical group 'boom'"),
        (
            {"groups": {"booms": FILM, "membrane": FILM}},
            r"groups\['booms'\]: .* dimension 1: it takes MemberProperties",
        ),
        ({"groups": {**SAIL_GROUPS, "hub": BOOM}}, r"groups\['hub'\]: .* dimension 0"),
        (
            {"groups": {**SAIL_GROUPS, "boom_0": MemberProperties(EA_N=1.0)}},
            r"groups: 2 line elements .* in physical groups 'booms' and 'boom_0'.* different MemberProperties",
        ),
        ({"groups": SAIL_GROUPS, "skip": "tetra"}, r"skip: must be a collection"),
        ({"groups": SAIL_GROUPS, "length_unit_m": 0.0}, r"length_unit_m: must be finite and > 0"),
    ],
)
def test_mapping_errors(options, message):
    with pytest.raises(ValueError, match=message):
        read_mesh(MESHES / "sail.msh", **options)


def test_same_properties_in_two_groups_are_accepted():
    s = read_mesh(MESHES / "sail.msh", groups={**SAIL_GROUPS, "boom_0": BOOM})
    assert s.n_members == read_sail().n_members


def test_unreadable_files(tmp_path):
    with pytest.raises(StructureError, match="is not a file"):
        read_mesh(tmp_path / "absent.msh")
    junk = tmp_path / "junk.msh"
    junk.write_text("$MeshFormat\nnot a mesh\n")
    with pytest.raises(StructureError, match=r"junk\.msh' is not a mesh meshio can read"):
        read_mesh(junk)
    other = tmp_path / "junk.vtk"  # meshio.read ends the process on a file it cannot read
    other.write_text("not a mesh\n")
    with pytest.raises(StructureError, match=r"junk\.vtk' is not a mesh meshio can read"):
        read_mesh(other)


@pytest.mark.parametrize(
    "fields, message",
    [
        ({"EA_N": 1.0, "kind": "rope"}, "kind: must be one of"),
        ({"EA_N": -1.0}, "EA_N: must be finite and > 0"),
        ({"EA_N": 1.0, "EI_Nm2": (1.0, 2.0, 3.0)}, "EI_Nm2: must be a number or a pair"),
        ({"EA_N": 1.0, "prestrain": -1.0}, "prestrain: must be finite and > -1"),
        ({"EA_N": 1.0, "orientation": (0.0, 1.0)}, "orientation: must be 3 finite numbers"),
    ],
)
def test_member_properties_are_checked(fields, message):
    with pytest.raises(ValueError, match=message):
        MemberProperties(**fields)


def test_panel_properties_are_checked():
    with pytest.raises(ValueError, match="reflectivity: must be three fractions"):
        PanelProperties(areal_density_kg_m2=0.01, reflectivity=(0.5, 0.2, 0.2))
    with pytest.raises(ValueError, match="areal_density_kg_m2: must be finite and >= 0"):
        PanelProperties(areal_density_kg_m2=-0.01, reflectivity=(1.0, 0.0, 0.0))
