"""Nastran bulk-data reader: field formats, coordinate systems, cards, errors and warnings.

Reference values are worked out by hand from the decks (tests/data/nastran/); products such as
``E A`` are the same floating-point operation in the reader and here, so they compare exactly
(``rtol=1e-15`` only allows for the order of operations); positions through the trigonometry of
cylindrical and spherical systems compare to ``atol=1e-12`` m (a few ulps of the unit-size
coordinates after a handful of rotations).
"""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from magsail_mj.structure.checks import structure_problems
from magsail_mj.structure.model import MEMBER_KINDS, StructureError
from magsail_mj.structure.nastran import (
    NastranWarning,
    nastran_deck_from_text,
    nastran_real,
    parse_bulk,
    read_nastran,
    read_nastran_deck,
)

DATA = Path(__file__).parent / "data" / "nastran"
TRUSS_DECKS = ["truss_small.bdf", "truss_large.bdf", "truss_free.bdf", "truss_mixed.bdf"]
BEAM, STRUT = MEMBER_KINDS.index("beam"), MEMBER_KINDS.index("strut")
RTOL = 1e-15
ATOL_M = 1e-12


def read_quietly(path: Path, **options):
    """The deck read with its NastranWarnings recorded: (deck, warning messages)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        deck = read_nastran_deck(path, **options)
    return deck, [str(w.message) for w in caught if issubclass(w.category, NastranWarning)]


def deck_text(text: str, **options):
    """A deck from text with its NastranWarnings recorded: (deck, warning messages)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        deck = nastran_deck_from_text(text, **options)
    return deck, [str(w.message) for w in caught if issubclass(w.category, NastranWarning)]


def line_of(text: str, fragment: str) -> int:
    """1-based line number of the first line of ``text`` containing ``fragment``."""
    return next(i for i, line in enumerate(text.splitlines(), start=1) if fragment in line)


MATERIALS = "MAT1,1,7.E10,,.33,2700.\nPROD,10,1,1.E-4,2.E-9\nPBAR,20,1,2.E-4,3.E-9,4.E-9,5.E-9\n"


# ---------------------------------------------------------------------------------------------
# The reference truss in every field format


@pytest.mark.parametrize("name", TRUSS_DECKS)
def test_truss_decks_give_the_hand_worked_structure(name):
    deck, messages = read_quietly(DATA / name)
    s = deck.structure
    E, nu, rho = 7.0e10, 0.33, 2700.0
    G = E / (2.0 * (1.0 + nu))
    np.testing.assert_array_equal(deck.grid_ids, [1, 2, 3, 4, 5])
    np.testing.assert_array_equal(s.positions_m, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]])
    np.testing.assert_array_equal(deck.element_ids, [1, 2, 3, 4, 11, 12, 13, 14])
    assert deck.element_types.tolist() == ["CROD"] * 3 + ["CONROD", "CBAR", "CBAR", "CBAR", "CBEAM"]
    m = s.members
    np.testing.assert_array_equal(m.nodes, [[0, 1], [1, 2], [2, 3], [3, 0], [0, 4], [1, 4], [2, 4], [3, 4]])
    np.testing.assert_array_equal(m.kind, [STRUT] * 4 + [BEAM] * 4)
    np.testing.assert_allclose(m.EA_N, [E * 1e-4] * 4 + [E * 2e-4] * 4, rtol=RTOL)
    np.testing.assert_allclose(m.EI_Nm2, [[0, 0]] * 4 + [[E * 3e-9, E * 4e-9]] * 4, rtol=RTOL)
    np.testing.assert_allclose(m.GJ_Nm2, [0.0] * 4 + [G * 5e-9] * 4, rtol=RTOL)  # struts: no torsion
    np.testing.assert_allclose(deck.rod_GJ_Nm2, [G * 2e-9] * 4 + [0.0] * 4, rtol=RTOL)  # for information
    np.testing.assert_allclose(m.linear_density_kg_m, [rho * 1e-4] * 4 + [rho * 2e-4 + 0.1] * 4, rtol=RTOL)
    np.testing.assert_allclose(m.rest_length_m, [1.0] * 4 + [math.sqrt(1.5)] * 4, rtol=RTOL)
    # CBAR 11 and CBEAM 14: v = (0, 0, 1); CBAR 12: G0 = GRID 3, v = x3 - x2; CBAR 13: (1, 0, 0)
    np.testing.assert_array_equal(m.orientation, [[0, 0, 0]] * 4 + [[0, 0, 1], [0, 1, 0], [1, 0, 0], [0, 0, 1]])
    np.testing.assert_array_equal(s.node_mass_kg, [0, 0, 0, 0, 2.5])
    (part,) = s.rigid_parts  # CONM2 101: offset (0, 0, 0.1) and inertia at GRID 1
    assert part.name == "conm2_1" and part.mass_kg == 1.0
    np.testing.assert_array_equal(part.nodes, [0])
    np.testing.assert_allclose(part.center_m, [0, 0, 0.1], rtol=RTOL)
    np.testing.assert_allclose(part.inertia_kg_m2, np.diag([0.01, 0.02, 0.03]), rtol=RTOL)
    # case control selects SPC set 1 (GRIDs 1, 2 all; GRID 3 translations); set 2 is only a node set
    expected_fixed = np.zeros((5, 6), dtype=bool)
    expected_fixed[[0, 1]] = True
    expected_fixed[2, :3] = True
    np.testing.assert_array_equal(s.fixed_dofs, expected_fixed)
    assert sorted(s.node_sets) == ["spc1", "spc2"]
    np.testing.assert_array_equal(s.node_sets["spc1"], [0, 1, 2])
    np.testing.assert_array_equal(s.node_sets["spc2"], [3])
    np.testing.assert_array_equal(s.member_sets["pid20"], [4, 5, 6])
    assert len(messages) == 1 and "EIGRL (1)" in messages[0] and "FORCE (1)" in messages[0]
    assert "PARAM (1)" in messages[0]


@pytest.mark.parametrize("name", [*TRUSS_DECKS, "cantilever_cbar.bdf"])
def test_decks_pass_the_structure_checks(name):
    assert structure_problems(read_quietly(DATA / name)[0].structure) == []


def test_truss_decks_are_identical_structures():
    decks = [read_quietly(DATA / name)[0].structure for name in TRUSS_DECKS]
    for other in decks[1:]:
        for attribute in ("positions_m", "node_mass_kg", "fixed_dofs"):
            np.testing.assert_array_equal(getattr(other, attribute), getattr(decks[0], attribute))
        for column in other.members.__dataclass_fields__:
            np.testing.assert_array_equal(getattr(other.members, column), getattr(decks[0].members, column))
        total, com, inertia = other.mass_properties()
        reference = decks[0].mass_properties()
        assert total == reference[0]
        np.testing.assert_array_equal(com, reference[1])
        np.testing.assert_array_equal(inertia, reference[2])


def test_read_nastran_returns_the_structure_and_names_it_after_the_file():
    with pytest.warns(NastranWarning):
        structure = read_nastran(DATA / "truss_small.bdf")
    assert structure.name == "truss_small" and structure.n_members == 8


def test_parse_bulk_fields_and_lines():
    text = (DATA / "truss_small.bdf").read_text()
    cards = parse_bulk(text)
    assert [c.name for c in cards[:6]] == ["GRID"] * 5 + ["MAT1"]
    pbar = next(c for c in cards if c.name == "PBAR")
    assert pbar.line == line_of(text, "PBAR")
    assert pbar.fields[:7] == ["20", "1", "2.-4", "3.-9", "4.-9", "5.-9", ".1"]
    assert pbar.field(18) == "0." and pbar.line_of(18) == line_of(text, "+PB2   ")
    assert pbar.label(18) == "I12 (continuation 2, field 4)"
    large = parse_bulk((DATA / "truss_large.bdf").read_text())
    conm2 = [c for c in large if c.name == "CONM2"][1]
    assert conm2.fields[:7] == ["101", "1", "0", "1.0", "0.0", "0.0", "0.1"]
    assert conm2.fields[8:14] == ["1.0E-2", "0.0", "2.0E-2", "0.0", "0.0", "3.0E-2"]
    assert cards[-1].name == "FORCE"  # ENDDATA ends the bulk data
    # a small-field continuation after one large-field line starts the next group of 8 fields
    (mixed,) = parse_bulk("BEGIN BULK\nCBAR*   " + "".join(f"{x:>16}" for x in "1234") + "\n+       " + "      0." * 3)
    assert mixed.fields == ["1", "2", "3", "4", "", "", "", "", "0.", "0.", "0.", "", "", "", "", ""]


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("1.5", 1.5),
        ("1.5E3", 1500.0),
        ("1.5e+3", 1500.0),
        ("1.5+3", 1500.0),
        ("1.5D3", 1500.0),
        ("-2.-4", -2e-4),
        (".5", 0.5),
        ("7.", 7.0),
        ("+.25E-2", 0.0025),
        (" 3.1 ", 3.1),
    ],
)
def test_nastran_real_formats(text, value):
    assert nastran_real(text) == value


@pytest.mark.parametrize("text", ["1", "1E3", "1.5.3", "nan", "inf", "1_0.", "", "E3", "1.5E", "--1."])
def test_nastran_real_refuses(text):
    with pytest.raises(ValueError, match="not a Nastran real"):
        nastran_real(text)


# ---------------------------------------------------------------------------------------------
# Coordinate systems


def test_coordinate_systems_and_chains():
    deck, _ = read_quietly(DATA / "coordinate_systems.bdf")
    r6 = 3.0 * math.sqrt(6.0) / 4.0
    expected = [
        [-1.0, 3.0, 6.0],  # CORD2R 1: origin (1, 2, 3), x = basic y, y = -basic x; local (1, 2, 3)
        [math.sqrt(3.0), 1.0, 5.0],  # CORD2C 2 (basic axes): r = 2, θ = 30°, z = 5
        [0.0, 2.0, 1.0],  # CORD2S 3, origin (0, 0, 1): r = 2, θ = 90°, φ = 90°
        [r6, r6, 2.5],  # r = 3, θ = 60°, φ = 45°: 3 (sin60 cos45, sin60 sin45, cos60) + (0, 0, 1)
        [-1.0, 2.0, 1.0],  # CORD2R 4 on CORD2C 2: origin (0, 1, 0), x = basic y, y = -basic x
        [1.0, 1.0, 1.0],  # basic
        [-2.0, 1.0, 3.0],  # CORD2C 5 on CORD2R 4: r = 2, θ = 90° is along 4's y = -basic x, z = 3
    ]
    np.testing.assert_allclose(deck.structure.positions_m, expected, rtol=0, atol=ATOL_M)


CYCLE = (
    "BEGIN BULK\nCORD2R,6,7,0.,0.,0.,0.,0.,1.\n,1.,0.,0.\nCORD2R,7,6,0.,0.,0.,0.,0.,1.\n,1.,0.,0.\nGRID,1,6,0.,0.,0.\n"
)


def test_coordinate_system_cycle_is_refused():
    with pytest.raises(StructureError, match=r"RID cycle CORD2R 6 → CORD2R 7 → 6"):
        nastran_deck_from_text(CYCLE)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("CORD2R,1,9,0.,0.,0.,0.,0.,1.\n,1.,0.,0.", r"line 2: CORD2R 1: RID \(field 3\) = 9: coordinate system"),
        ("CORD2R,1,,0.,0.,0.,0.,0.,0.\n,1.,0.,0.", r"line 2: CORD2R 1: .*B .* coincides with A"),
        ("CORD2R,1,,0.,0.,0.,0.,0.,1.\n,0.,0.,5.", r"line 3: CORD2R 1: C .* lies on the z axis"),
        ("GRID,1,4,0.,0.,0.", r"line 2: GRID 1: CP \(field 3\) = 4: coordinate system not defined"),
    ],
)
def test_coordinate_system_errors(text, message):
    with pytest.raises(StructureError, match=message):
        nastran_deck_from_text("BEGIN BULK\n" + text + "\nGRID,2,,0.,0.,0.\n")


# ---------------------------------------------------------------------------------------------
# The CBAR cantilever, materials, masses, constraints


def test_cbar_cantilever_properties():
    deck, messages = read_quietly(DATA / "cantilever_cbar.bdf")
    s = deck.structure
    E, G, rho, A, I1, I2, J = 7.0e10, 2.6e10, 2700.0, 3.2e-4, 2.5e-8, 1.5e-8, 4.0e-8
    np.testing.assert_allclose(s.positions_m[:, 0], np.arange(11) / 10, rtol=0, atol=ATOL_M)
    m = s.members
    assert len(m) == 10 and np.all(m.kind == BEAM)
    np.testing.assert_array_equal(m.nodes, np.stack([np.arange(10), np.arange(1, 11)], axis=1))
    np.testing.assert_allclose(m.EA_N, E * A, rtol=RTOL)
    np.testing.assert_allclose(m.EI_Nm2, np.tile([E * I1, E * I2], (10, 1)), rtol=RTOL)
    np.testing.assert_allclose(m.GJ_Nm2, G * J, rtol=RTOL)  # G as given, not from ν
    np.testing.assert_allclose(m.linear_density_kg_m, rho * A, rtol=RTOL)
    np.testing.assert_allclose(m.rest_length_m, 0.1, rtol=1e-14)  # differences of decimal positions
    np.testing.assert_array_equal(m.orientation, np.tile([0.0, 1.0, 0.0], (10, 1)))  # from BAROR
    np.testing.assert_array_equal(s.member_sets["pid7"], np.arange(10))  # PID from BAROR
    np.testing.assert_array_equal(np.flatnonzero(s.fixed_dofs.any(axis=1)), [0])
    assert s.fixed_dofs[0].all()
    # mass: ρA L of beam, lumped half at each end, and the 0.5 kg tip mass
    total, com, _ = s.mass_properties()
    assert total == pytest.approx(rho * A * 1.0 + 0.5, rel=1e-14)
    assert com[0] == pytest.approx((rho * A * 0.5 + 0.5 * 1.0) / total, rel=1e-14)
    assert messages == ["Nastran deck: skipped cards: EIGRL (1)"]


def conrods_of(materials: str):
    """EA and GJ of one CONROD (A = 2, J = 3) per MAT1 line given."""
    lines = materials.strip().splitlines()
    grids = "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\n"
    rods = "".join(f"CONROD,{k + 1},1,2,{k + 1},2.,3.\n" for k in range(len(lines)))
    deck, _ = deck_text("BEGIN BULK\n" + grids + materials.strip() + "\n" + rods)
    return deck.structure.members.EA_N, deck.rod_GJ_Nm2


def test_mat1_completion():
    EA, GJ = conrods_of(
        """
MAT1,1,2.6E3,,.3
MAT1,2,,1.E3,.3
MAT1,3,3.E3,1.E3,.3
MAT1,4,5.E3
MAT1,5,,7.E3
"""
    )
    # G = E / 2(1 + ν); E = 2 (1 + ν) G; both given: as given; E alone: G = 0; G alone: E = 0
    np.testing.assert_allclose(EA, [2.0 * 2.6e3, 2.0 * 2.6e3, 2.0 * 3e3, 2.0 * 5e3, 0.0], rtol=RTOL)
    np.testing.assert_allclose(GJ, [3.0 * 1e3, 3.0 * 1e3, 3.0 * 1e3, 0.0, 3.0 * 7e3], rtol=RTOL)


def test_mat1_needs_e_or_g():
    with pytest.raises(StructureError, match=r"line 4: MAT1 1: E \(field 3\) and G \(field 4\) are both blank"):
        conrods_of("MAT1,1,,,.3")


def test_conm2_point_masses_offsets_and_combined_rigid_part():
    text = """BEGIN BULK
CORD2C,2,,0.,0.,0.,0.,0.,1.
,1.,0.,0.
GRID,1,,0.,1.,0.
GRID,2,,2.,0.,0.
GRID,3,,3.,0.,0.
CONM2,1,2,,1.5
CONM2,2,2,,.5
CONM2,3,1,2,2.,.5,0.,0.
CONM2,4,1,-1,3.,0.,1.,2.
,.1,.01,.2,.02,.03,.3
CONM2,5,3,0,1.,0.,0.,0.
,0.,0.,0.,0.,0.,0.
"""
    deck, _ = deck_text(text)
    s = deck.structure
    np.testing.assert_array_equal(s.node_mass_kg, [0.0, 2.0, 1.0])  # CONM2 1 + 2 at GRID 2; 5 at GRID 3
    (part,) = s.rigid_parts
    assert part.name == "conm2_1" and part.mass_kg == 5.0
    np.testing.assert_array_equal(part.nodes, [0])
    # CONM2 3: offset 0.5 along e_r of cylindrical CID 2 at GRID 1 (θ = 90°: e_r = basic y) →
    # (0, 1.5, 0); CONM2 4: CID = -1, centre (0, 1, 2) in basic, inertia with −I21, −I31, −I32
    c3, c4 = np.array([0.0, 1.5, 0.0]), np.array([0.0, 1.0, 2.0])
    com = (2.0 * c3 + 3.0 * c4) / 5.0
    own = np.array([[0.1, -0.01, -0.02], [-0.01, 0.2, -0.03], [-0.02, -0.03, 0.3]])
    expected = own.copy()
    for mass, centre in ((2.0, c3), (3.0, c4)):
        d = centre - com
        expected += mass * (d @ d * np.eye(3) - np.outer(d, d))
    np.testing.assert_allclose(part.center_m, com, rtol=0, atol=ATOL_M)
    np.testing.assert_allclose(part.inertia_kg_m2, expected, rtol=0, atol=ATOL_M)


def test_spc1_thru_spcadd_and_selection():
    grids = "".join(f"GRID,{g},,{g}.,0.,0.\n" for g in (1, 2, 3, 5, 6, 7, 8, 9, 10))  # no GRID 4
    bulk = grids + "SPC1,1,123,1,THRU,5\nSPC1,2,456,7,9,\n,10\nSPC,3,2,1,0.,8,3\nSPCADD,9,1,3\n"
    deck, messages = deck_text("SOL 103\nCEND\nSPC = 9\nBEGIN BULK\n" + bulk)
    s = deck.structure
    # THRU 1-5 takes the existing GRIDs 1, 2, 3, 5 (nodes 0-3); set 9 = sets 1 and 3
    np.testing.assert_array_equal(s.node_sets["spc1"], [0, 1, 2, 3])
    np.testing.assert_array_equal(s.node_sets["spc2"], [5, 7, 8])  # continuation field: GRID 10
    np.testing.assert_array_equal(s.node_sets["spc3"], [1, 6])
    np.testing.assert_array_equal(s.node_sets["spc9"], [0, 1, 2, 3, 6])
    expected = np.zeros((9, 6), dtype=bool)
    expected[[0, 1, 2, 3], :3] = True
    expected[1, 0] = True
    expected[6, 2] = True
    np.testing.assert_array_equal(s.fixed_dofs, expected)
    assert messages == []
    # no selection: every set applies, and the warning says so
    deck, messages = deck_text("BEGIN BULK\n" + bulk)
    assert deck.structure.fixed_dofs[[0, 5, 6, 7, 8]].any(axis=1).all()
    assert len(messages) == 1 and "all sets applied (1, 2, 3)" in messages[0]


def test_grid_ps_grdset_and_cd_rules():
    text = "BEGIN BULK\nGRDSET,,,,,,,3\nGRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.,,456\nGRID,3,,2.,0.,0.,,0\n"
    fixed = deck_text(text)[0].structure.fixed_dofs
    np.testing.assert_array_equal(fixed.astype(int), [[0, 0, 1, 0, 0, 0], [0, 0, 0, 1, 1, 1], [0, 0, 0, 0, 0, 0]])
    partial = "BEGIN BULK\nCORD2C,2,,0.,0.,0.,0.,0.,1.\n,1.,0.,0.\nGRID,1,,0.,1.,0.,2,12\n"
    with pytest.raises(StructureError, match=r"line 4: GRID 1: CD \(field 7\) = 2: components 12 .*none or all"):
        nastran_deck_from_text(partial)
    whole = partial.replace(",2,12", ",2,123456")
    assert deck_text(whole)[0].structure.fixed_dofs.all()


def test_beam_orientation_in_the_displacement_system():
    base = "BEGIN BULK\nCORD2C,2,,0.,0.,0.,0.,0.,1.\n,1.,0.,0.\nGRID,1,,0.,1.,0.,2\nGRID,2,,0.,1.,1.\n"
    # GRID 1 has CD = cylindrical 2 at θ = 90°: e_r = basic y, e_θ = -basic x
    text = base + MATERIALS + "CBAR,1,20,1,2,0.,1.,0.\nCBAR,2,20,1,2,0.,1.,0.,BGG\nCBEAM,3,20,2,1,1.,0.,0.\n"
    line = line_of(text, "CBEAM")
    with pytest.raises(StructureError, match=rf"line {line}: CBEAM 3: PID \(field 3\) = 20: property 20 is a PBAR"):
        nastran_deck_from_text(text)
    text = text.replace("CBEAM,3,20", "CBAR,3,20")
    orientation = deck_text(text)[0].structure.members.orientation
    np.testing.assert_allclose(orientation, [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]], atol=ATOL_M)


def test_grid_ids_map_in_ascending_order():
    text = "BEGIN BULK\n" + MATERIALS + "GRID,101,,1.,0.,0.\nGRID,7,,2.,0.,0.\nGRID,55,,3.,0.,0.\n"
    text += "CROD,9,10,101,7\nCROD,3,10,55,101\n"
    deck = deck_text(text)[0]
    np.testing.assert_array_equal(deck.grid_ids, [7, 55, 101])
    np.testing.assert_array_equal(deck.structure.positions_m[:, 0], [2.0, 3.0, 1.0])
    np.testing.assert_array_equal(deck.element_ids, [3, 9])
    np.testing.assert_array_equal(deck.structure.members.nodes, [[1, 2], [2, 0]])


# ---------------------------------------------------------------------------------------------
# Skipped and unsupported cards, errors


def test_skipped_cards_are_named_with_their_counts_in_one_warning():
    text = "BEGIN BULK\nGRID,1,,0.,0.,0.\nPARAM,POST,-1\nPARAM,WTMASS,1.\nFORCE,1,1,,1.,1.,0.,0.\n"
    text += "FORCE,1,1,,1.,0.,1.,0.\nFORCE,1,1,,1.,0.,0.,1.\nGRAV,2,,9.81,0.,0.,-1.\nTSTEP,3,10,.1\n"
    with pytest.warns(NastranWarning) as record:
        nastran_deck_from_text(text)
    assert len(record) == 1
    assert str(record[0].message) == ("Nastran deck: skipped cards: FORCE (3), GRAV (1), PARAM (2), TSTEP (1)")
    assert record[0].filename == __file__  # points at the caller


UNSUPPORTED = """$ a plate on the truss
BEGIN BULK
GRID,1,,0.,0.,0.
GRID,2,,1.,0.,0.
GRID,3,,1.,1.,0.
GRID,4,,0.,1.,0.
CQUAD4,7,5,1,2,3,4
PSHELL,5,1,.001
CQUAD4,8,5,1,2,3,4
FOOBAR,1,2,3
MAT1,1,7.E10,,.33,2700.
PROD,10,1,1.E-4
CROD,1,10,1,2
"""


def test_unsupported_cards_are_errors_naming_card_and_line():
    with pytest.raises(StructureError) as error:
        nastran_deck_from_text(UNSUPPORTED)
    problems = error.value.problems
    assert problems[0].startswith("line 7: CQUAD4 is not supported (2 cards: lines 7, 9)")
    assert problems[1].startswith("line 8: PSHELL is not supported (1 card: line 8)")
    assert problems[2].startswith("line 10: FOOBAR is not supported")
    assert all("skip_unsupported=True" in problem for problem in problems)


def test_skip_unsupported_lists_them_in_the_warning():
    deck, messages = deck_text(UNSUPPORTED, skip_unsupported=True)
    assert deck.structure.n_members == 1 and deck.structure.n_nodes == 4
    assert messages == ["Nastran deck: skipped cards: CQUAD4 (2), FOOBAR (1), PSHELL (1)"]
    # an element whose property card was skipped says which card it is
    text = UNSUPPORTED.replace("CROD,1,10,1,2", "CROD,1,5,1,2")
    with pytest.raises(StructureError, match=r"line 13: CROD 1: PID \(field 3\) = 5: property 5 is a PSHELL"):
        nastran_deck_from_text(text, skip_unsupported=True)


GOOD = "BEGIN BULK\n" + MATERIALS + "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,0.,1.,0.\n"  # 7 lines


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ("CROD,12,5,1,2", r"line 8: CROD 12: PID \(field 3\) = 5: PROD 5 is not defined"),
        ("CROD,12,10,1,99", r"line 8: CROD 12: G2 \(field 5\) = 99: GRID 99 is not defined"),
        ("CONROD,12,1,2,4,1.", r"line 8: CONROD 12: MID \(field 5\) = 4: MAT1 4 is not defined"),
        ("CBAR,12,20,1,2,77", r"line 8: CBAR 12: X1 \(field 6\) = 77: GRID 77 is not defined"),
        ("CBAR,12,20,1,2,2", r"line 8: CBAR 12: G0 \(field 6\) = 2: G0 must differ from GA and GB"),
        ("CBAR,12,20,1,2", r"line 8: CBAR 12: X1-X3 or G0 \(fields 6-8\) required"),
        ("CBAR,12,20,1,2,0.,0.,1.\n,1", r"line 9: CBAR 12: PA \(continuation 1, field 2\) = '1': pin flags"),
        ("CBAR,12,20,1,2,0.,0.,1.\n,,,0.,.1", r"line 9: CBAR 12: W2A \(continuation 1, field 5\) = '.1': offsets"),
        ("PBAR,21,1,1.,1.,1.,1.\n,,,,,,,,\n,,,.5", r"line 10: PBAR 21: I12 \(continuation 2, field 4\) = 0.5: a non-"),
        ("GRID,3,,0.,1.,0.", r"line 8: GRID 3: ID 3 is defined again \(first: GRID on line 7\)"),
        ("GRID,4,,0.,1,0.", r"line 8: GRID 4: X2 \(field 5\) = '1': expected a real number with a decimal point"),
        ("GRID,4,,0.,1.2.3,0.", r"line 8: GRID 4: X2 \(field 5\) = '1.2.3': expected a real number"),
        ("GRID,4.,,0.,1.,0.", r"line 8: GRID 4\.: ID \(field 2\) = '4\.': expected an integer"),
        ("CROD,3,10,1,2\nCONM2,3,1,,1.", r"line 9: CONM2 3: element ID 3 is taken \(by CROD on line 8\)"),
        ("CONM2,30,9,,1.", r"line 8: CONM2 30: G \(field 3\) = 9: GRID 9 is not defined"),
        ("CONM2,30,1,", r"line 8: CONM2 30: M \(field 5\) is required"),
        ("SPC,1,1,12,.5", r"line 8: SPC 1: D1 \(field 5\) = 0.5: enforced displacements are not supported"),
        ("SPC1,1,127,1", r"line 8: SPC1 1: C \(field 3\) = '127': expected distinct digits 1-6"),
        ("SPC1,1,123,1,44", r"line 8: SPC1 1: G2 \(field 5\): GRID 44 is not defined"),
        ("SPC1,1,123,1,THRU", r"line 8: SPC1 1: G2 \(field 5\) = 'THRU': expected an ID"),
    ],
)
def test_errors_name_line_card_and_field(extra, message):
    with pytest.raises(StructureError, match=message):
        nastran_deck_from_text(GOOD + extra + "\n")


def test_pbeam_taper_is_noted():
    text = GOOD + "PBEAM,30,1,1.,2.,3.,0.,4.\n,,,,,,,,\n,YESA,1.,2.,2.,3.,0.,4.\nCBEAM,1,30,1,2,0.,0.,1.\n"
    deck, messages = deck_text(text)
    assert deck.structure.members.EA_N[0] == 7.0e10 * 1.0  # end A
    assert len(messages) == 1 and f"line {line_of(text, 'PBEAM')}: PBEAM 30: tapered section" in messages[0]
    untapered = text.replace(",YESA,1.,2.,2.,3.,0.,4.", ",YESA,1.,,,,,")
    assert deck_text(untapered)[1] == []  # blank end-B fields take end A's values
    # SO = YES: a station with its stress-point line; the taper is at end B, after it
    stations = ",YES,.5,1.,2.,3.,0.,4.\n,.1,.1,.1,.1,.1,.1,.1,.1\n,YESA,1.,2.\n"
    text = GOOD + "PBEAM,30,1,1.,2.,3.,0.,4.\n,,,,,,,,\n" + stations + "CBEAM,1,30,1,2,0.,0.,1.\n"
    assert "tapered section" in deck_text(text)[1][0]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("SOL 103\nCEND\nINCLUDE 'grids.bdf'\nBEGIN BULK\n", r"line 3: INCLUDE 'GRIDS.BDF': INCLUDE is not supported"),
        ("BEGIN BULK\nGRID,1,,0.,0.,0.\ninclude 'more.bdf'\n", r"line 3: .*INCLUDE is not supported"),
        ("SOL 103\nCEND\nGRID,1,,0.,0.,0.\n", r"line 1: 'SOL 103': the deck has no BEGIN BULK"),
        ("BEGIN BULK\n,1.,2.\n", r"line 2: continuation line with no card before it"),
        ("BEGIN BULK\nGRID,1,,0.,0.,0.,,,,+,extra\n", r"line 2: free-field entry GRID has 11 fields; at most 10"),
        ("BEGIN BULK\nGRID,1,,0.,0.,0.\nBEGIN SUPER=2\n", r"line 3: BEGIN SUPER=2: only one BEGIN BULK"),
        ("SOL 103\nCEND\nSPC = 4\nBEGIN BULK\nGRID,1,,0.,0.,0.\n", r"case control SPC = 4: no SPC, SPC1"),
    ],
)
def test_deck_layout_errors(text, message):
    with pytest.raises(StructureError, match=message):
        nastran_deck_from_text(text)


def test_deck_without_begin_bulk_and_file_errors(tmp_path):
    path = tmp_path / "bulk_only.dat"
    path.write_text("$ bulk data only\nGRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\n")
    deck, _ = read_quietly(path)
    np.testing.assert_array_equal(deck.structure.positions_m, [[0, 0, 0], [1, 0, 0]])
    path.write_text("GRID,1,,0.,0.,0.\nGRID,1,,1.,0.,0.\n")
    with pytest.raises(StructureError, match=rf"^{re.escape(str(path))}: line 2: GRID 1: ID 1 is defined again"):
        read_nastran(path)
    with pytest.raises(StructureError, match="cannot read the deck"):
        read_nastran(tmp_path / "missing.bdf")


# ---------------------------------------------------------------------------------------------
# Property: the three field formats read the same numbers


@st.composite
def nastran_numbers(draw):
    """(small-field text ≤ 8 characters, large-field text, free-field text, value) of one real."""
    sign = draw(st.sampled_from(["", "-"]))
    digits = draw(st.integers(0, 9999))
    exponent = draw(st.integers(-9, 9))
    mantissa = f"{sign}{digits // 1000}.{digits % 1000:03d}"
    value = float(f"{mantissa}e{exponent}")
    return f"{mantissa}{exponent:+d}", f"{mantissa}E{exponent:+03d}", f"{mantissa.lower()}e{exponent}", value


def format_deck(grids, rods, area, style):
    """The same GRIDs and CRODs in small (0), large (1) or free (2) field."""
    lines = ["BEGIN BULK", "MAT1,1,7.E10,,.3,2700.", f"PROD,5,1,{area[2]}"]
    for gid, coords in grids:
        values = [c[style] for c in coords]
        if style == 0:
            lines.append("GRID    " + "".join(f"{x:>8}" for x in (str(gid), "", *values)))
        elif style == 1:
            lines += ["GRID*   " + "".join(f"{x:>16}" for x in (str(gid), "", *values[:2])), f"*       {values[2]:>16}"]
        else:
            lines.append(",".join(["GRID", str(gid), "", *values]))
    for eid, (a, b) in enumerate(rods, start=1):
        fields = (str(eid), "5", str(a), str(b))
        lines.append("CROD    " + "".join(f"{x:>8}" for x in fields) if style == 0 else ",".join(["CROD", *fields]))
    return "\n".join(lines) + "\n"


@settings(max_examples=30, deadline=None)
@given(
    grids=st.lists(st.tuples(st.integers(1, 99999999), st.tuples(*[nastran_numbers()] * 3)), min_size=2, max_size=6),
    area=nastran_numbers(),
    data=st.data(),
)
def test_field_formats_read_identical_numbers(grids, area, data):
    grids = list(dict(grids).items())  # one GRID an ID
    ids = sorted(gid for gid, _ in grids)
    rods = data.draw(st.lists(st.tuples(st.sampled_from(ids), st.sampled_from(ids)), min_size=1, max_size=5))
    decks = [nastran_deck_from_text(format_deck(grids, rods, area, style)) for style in range(3)]
    expected = np.array([[c[3] for c in coords] for _, coords in sorted(grids)])
    for deck in decks:
        np.testing.assert_array_equal(deck.grid_ids, ids)
        np.testing.assert_array_equal(deck.structure.positions_m, expected)
        np.testing.assert_array_equal(deck.structure.members.EA_N, 7.0e10 * area[3])
        np.testing.assert_array_equal(deck.structure.members.nodes, np.searchsorted(ids, rods))


def test_large_generated_deck():
    n = 2000
    rng = np.random.default_rng(7)
    xyz = np.round(rng.uniform(-50, 50, (n, 3)), 3)
    lines = ["BEGIN BULK", "MAT1,1,7.E10,,.3,2700.", "PBAR,2,1,1.-4,1.-9,2.-9,3.-9", "PROD,3,1,1.-4"]
    lines += [f"GRID    {i + 1:>8}        " + "".join(f"{v:>8.3f}" for v in xyz[i]) for i in range(n)]
    lines += [
        f"CBAR    {i + 1:>8}       2{i + 1:>8}{i + 2:>8}      0.      0.      1."
        if i % 2
        else f"CROD,{i + 1},3,{i + 1},{i + 2}"
        for i in range(n - 1)
    ]
    deck = nastran_deck_from_text("\n".join(lines))
    np.testing.assert_array_equal(deck.structure.positions_m, [[float(f"{v:.3f}") for v in row] for row in xyz])
    np.testing.assert_array_equal(deck.structure.members.kind, np.where(np.arange(n - 1) % 2, BEAM, STRUT))
    np.testing.assert_allclose(deck.structure.members.rest_length_m, np.linalg.norm(np.diff(xyz, axis=0), axis=1))


def test_orientation_components_follow_the_spherical_axes_at_the_grid():
    # GRID 1 at r = 2, θ = 50°, φ = 20° of a spherical system turned 90° about basic z (its x is
    # basic y); v = (1, 0, 0), (0, 1, 0), (0, 0, 1) in that CD are the unit directions of growing
    # r, θ and φ, here differentiated numerically from the spherical map.
    text = "BEGIN BULK\nCORD2S,3,,1.,0.,0.,1.,0.,1.\n,1.,1.,0.\nGRID,1,3,2.,50.,20.,3\nGRID,2,,0.,0.,5.\n"
    text += MATERIALS + "CBAR,1,20,1,2,1.,0.,0.\nCBAR,2,20,1,2,0.,1.,0.\nCBAR,3,20,1,2,0.,0.,1.\n"
    deck = deck_text(text)[0]
    axes = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]).T  # columns: x, y, z of system 3

    def position(q):
        r, theta, phi = q[0], math.radians(q[1]), math.radians(q[2])
        local = [r * math.sin(theta) * math.cos(phi), r * math.sin(theta) * math.sin(phi), r * math.cos(theta)]
        return np.array([1.0, 0.0, 0.0]) + axes @ local

    q = np.array([2.0, 50.0, 20.0])
    np.testing.assert_allclose(deck.structure.positions_m[0], position(q), atol=ATOL_M)
    step = 1e-6
    for k in range(3):
        dq = np.zeros(3)
        dq[k] = step
        direction = position(q + dq) - position(q - dq)
        direction /= np.linalg.norm(direction)
        # central difference: error O(step²) ≈ 1e-12 relative; 1e-8 leaves room for rounding
        np.testing.assert_allclose(deck.structure.members.orientation[k], direction, atol=1e-8)
