"""Nastran bulk data → :class:`~magsail_mj.structure.model.Structure` (a small reader, pure NumPy).

Reads the structural part of an MSC/NX Nastran input deck: grids in rectangular, cylindrical and
spherical coordinate systems, rods, bars and beams with their properties and isotropic materials,
concentrated masses and single-point constraints. It does not check the structure beyond what
reading needs (:mod:`magsail_mj.structure.checks` does that).

Deck layout
    Executive and case control, everything before ``BEGIN BULK``, are skipped, except that the
    case control's ``SPC = n`` selections are read (see constraints). A deck without
    ``BEGIN BULK`` is bulk data only if its first entry is a bulk data card. Reading stops at
    ``ENDDATA``. ``$`` starts a comment, to the end of the line. ``INCLUDE`` is refused (the
    reader reads one file: inline the included files). Names and values are case-insensitive;
    a tab moves to the next 8-column field.

Field formats (mixed freely within a deck, and within a card)
    small field: 8-column fields, the name in columns 1–8, 8 data fields in columns 9–72;
    large field: the name ends with ``*`` (``GRID*``), 4 data fields of 16 columns (9–72);
    free field: fields separated by commas (8 data fields a line; 4 when the name ends with
    ``*``), at most one trailing continuation field.
    A continuation line starts with ``+`` (small field), ``*`` (large field) or a blank first
    field, and continues the card above it (continuation markers are not matched: a continuation
    must follow its card). Two large-field lines make one small-field line's 8 fields; a
    small-field continuation after an odd number of large-field lines starts the next 8.
    Integers: ``[+-]digits``. Reals need a decimal point: ``1.5``, ``1.5E3``, ``1.5D3``,
    ``1.5+3`` (= 1.5e3), ``-2.-4`` (= −2e−4), ``.5``, ``7.``; an integer in a real field (or the
    reverse) is an error, as in Nastran, since it usually means a field shifted out of its
    columns. A blank field takes the card's default.

Cards read (all others: see below)
    ``GRID`` (position in coordinate system CP; CD only where noted; PS → fixed components),
    ``GRDSET`` (defaults for GRID's CP, CD, PS), ``CORD2R``/``CORD2C``/``CORD2S`` (points A, B, C
    in system RID, chains resolved, cycles refused), ``MAT1``, ``PROD``, ``PBAR``, ``PBEAM``,
    ``CROD``, ``CONROD``, ``CBAR``, ``CBEAM``, ``BAROR``/``BEAMOR`` (defaults for CBAR/CBEAM's
    PID and orientation), ``CONM2``, ``SPC``, ``SPC1`` (``THRU`` ranges), ``SPCADD``.

Cards skipped
    Cards that define no structure (loads, analysis parameters, output and design cards:
    :data:`SKIPPED_CARDS`) are skipped and named, with their counts, in one
    :class:`NastranWarning`. Any other card (shells, solids, springs, rigid elements, MPCs, other
    materials and properties, unknown names) is a :class:`StructureError` naming the card and its
    line, unless ``skip_unsupported=True`` (then it is named in the warning too).

Model
    Nodes: the GRIDs sorted by ID (node ``i`` is GRID ``grid_ids[i]``); positions in the basic
    system. Coordinate system CID with origin ``o`` and unit axes ``e1, e2, e3`` (basic
    components) maps local ``(x1, x2, x3)`` to ``o + e1 x + e2 y + e3 z`` with ``(x, y, z) =
    (x1, x2, x3)`` (rectangular), ``(r cos θ, r sin θ, z)`` for cylindrical ``(r, θ°, z)`` and
    ``(r sin θ cos φ, r sin θ sin φ, r cos θ)`` for spherical ``(r, θ°, φ°)``. A CORD2x's axes:
    ``e3 = (B − A)/|B − A|``, ``e1`` along the part of ``C − A`` normal to ``e3``,
    ``e2 = e3 × e1``, with A, B, C mapped from RID to basic first.

    Members: sorted by element ID (member ``j`` is element ``element_ids[j]``). CROD, CONROD →
    ``strut`` with ``EA = E A`` (a strut has no torsion: the rod's ``G J`` is kept, for
    information, in :attr:`NastranDeck.rod_GJ_Nm2`);
    CBAR, CBEAM → ``beam`` with ``EA = E A``, ``EI = (E I1, E I2)``, ``GJ = G J`` (PBEAM: end
    A's section; a tapered PBEAM is named in the warning). Linear density ``ρ A + NSM`` [kg/m],
    which the model lumps half at each end. Beam orientation: ``v = (X1, X2, X3)`` in the CD
    system of GA at GA (basic when OFFT starts with ``B``), or ``v = x(G0) − x(GA)``. Pin flags,
    offsets, warping points and non-principal sections (``I12 ≠ 0``) are refused.

    Masses: a CONM2 at a grid with no offset and no inertia adds its mass to the node's point
    mass; the others at a grid (offset in system CID at the grid, or the centre of gravity in
    basic for CID = −1; inertia ``[[I11, −I21, −I31], [−I21, I22, −I32], [−I31, −I32, I33]]``
    about the centre of gravity, CID axes) are combined into one :class:`RigidPart`
    ``conm2_<grid ID>`` holding that node (parallel-axis theorem).

    Constraints: each SPC/SPC1/SPCADD set ``SID`` is the node set ``spc<SID>``. The fixed
    components are the GRIDs' PS plus the sets the case control selects (``SPC = n``), or every
    set when it selects none (named in the warning when there are several). Components are in the
    grid's CD system; a grid with CD ≠ 0 may fix none or all of its translations (and of its
    rotations), since ``fixed_dofs`` are basic axes.

Units: the deck's numbers are taken as SI (m, kg, s, N, Pa, kg/m³); a deck in other units must be
converted before reading. Errors name the line, the card and its ID, and the field:
``line 17: CROD 12: PID (field 3) = 5: PROD 5 is not defined``.
"""

from __future__ import annotations

import re
import sys
import warnings
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from magsail_mj.structure.model import MEMBER_KINDS, Members, RigidPart, Structure, StructureError

__all__ = [
    "SKIPPED_CARDS",
    "SUPPORTED_CARDS",
    "BulkCard",
    "NastranDeck",
    "NastranWarning",
    "nastran_deck_from_text",
    "nastran_real",
    "parse_bulk",
    "read_nastran",
    "read_nastran_deck",
]

#: Cards the reader models.
SUPPORTED_CARDS = frozenset(
    "GRID GRDSET CORD2R CORD2C CORD2S MAT1 PROD PBAR PBEAM CROD CONROD CBAR CBEAM BAROR BEAMOR CONM2 "
    "SPC SPC1 SPCADD".split()
)

#: Cards that define no structure (loads, solution and output control, design): skipped, named in
#: the warning.
SKIPPED_CARDS = frozenset(
    """PARAM MDLPRM EIGRL EIGR EIGC EIGB EIGP FORCE FORCE1 FORCE2 MOMENT MOMENT1 MOMENT2 LOAD DLOAD
    RLOAD1 RLOAD2 TLOAD1 TLOAD2 DAREA DELAY DPHASE TEMP TEMPD TEMPP1 GRAV ACCEL ACCEL1 RFORCE PLOAD
    PLOAD1 PLOAD2 PLOAD4 SPCD TSTEP TSTEPNL FREQ FREQ1 FREQ2 FREQ3 FREQ4 FREQ5 NLPARM RANDPS
    TABLED1 TABLED2 TABLED3 TABLED4 TABDMP1 TABLEM1 TABLEM2 TABLEM3 TABLEM4 TABLES1 TABLEST DTI
    SET1 SET3 PLOTEL ASET ASET1 BSET BSET1 CSET CSET1 QSET QSET1 OMIT OMIT1 SUPORT SUPORT1 USET
    USET1 MAT4 MAT5 DOPTPRM DESVAR DRESP1 DRESP2 DCONSTR DCONADD DVPREL1 DVPREL2 DEQATN MONPNT1
    ECHOON ECHOOFF""".split()
)

#: Structural cards the reader recognises but cannot model (the list is for recognising a deck
#: without BEGIN BULK; any name not read or skipped is unsupported).
_KNOWN_UNSUPPORTED = frozenset(
    """CQUAD4 CQUAD8 CQUADR CTRIA3 CTRIA6 CTRIAR CSHEAR CHEXA CPENTA CTETRA CPYRAM PSHELL PCOMP PCOMPG
    PSOLID PSHEAR CBUSH CBUSH1D PBUSH CELAS1 CELAS2 CELAS3 CELAS4 PELAS CDAMP1 CDAMP2 CDAMP3 CDAMP4
    CDAMP5 PDAMP CVISC PVISC CGAP PGAP RBE1 RBE2 RBE3 RBAR RROD RSPLINE MPC MPCADD CONM1 CMASS1
    CMASS2 CMASS3 CMASS4 PMASS PBARL PBEAML PBCOMP CTUBE PTUBE CORD1R CORD1C CORD1S CORD3G MAT2 MAT3
    MAT8 MAT9 MATS1 SPOINT EPOINT DMIG GENEL CWELD CFAST""".split()
)

_REAL_TEXT = r"[+-]?(?:\d+\.\d*|\.\d+)(?:[ED][+-]?\d+|[+-]\d+)?"
_INT_TEXT = r"[+-]?\d{1,18}"
_REAL = re.compile(r"([+-]?(?:\d+\.\d*|\.\d+))(?:[ED]([+-]?\d+)|([+-]\d+))?")
_INT = re.compile(_INT_TEXT)
_REAL_COLUMN = re.compile(rf"(?:{_REAL_TEXT})?(?:\n(?:{_REAL_TEXT})?)*")
_INT_COLUMN = re.compile(rf"(?:{_INT_TEXT})?(?:\n(?:{_INT_TEXT})?)*")
_BARE_EXPONENT = re.compile(r"(?<=[\d.])(?=[+-]\d)")
_BEGIN_BULK = re.compile(r"BEGIN\s*BULK")
_CASE_SPC = re.compile(r"SPC\s*=\s*(\d+)")
_PROBLEMS_SHOWN = 20

# Field names from field 2 on; the position in the tuple is the index in BulkCard.fields.
_CORD2 = ("CID", "RID", "A1", "A2", "A3", "B1", "B2", "B3", "C1", "C2", "C3")
_ORIENT = ("-", "PID", "-", "-", "X1", "X2", "X3", "OFFT")
_BAR = ("EID", "PID", "GA", "GB", "X1", "X2", "X3", "OFFT", "PA", "PB", "W1A", "W2A", "W3A", "W1B", "W2B", "W3B")
_FIELD_NAMES: dict[str, tuple[str, ...]] = {
    "GRID": ("ID", "CP", "X1", "X2", "X3", "CD", "PS", "SEID"),
    "GRDSET": ("-", "CP", "-", "-", "-", "CD", "PS", "SEID"),
    "CORD2R": _CORD2,
    "CORD2C": _CORD2,
    "CORD2S": _CORD2,
    "MAT1": ("MID", "E", "G", "NU", "RHO", "A", "TREF", "GE", "ST", "SC", "SS", "MCSID"),
    "PROD": ("PID", "MID", "A", "J", "C", "NSM"),
    "PBAR": ("PID", "MID", "A", "I1", "I2", "J", "NSM", "-", "C1", "C2", "D1", "D2", "E1", "E2", "F1", "F2")
    + ("K1", "K2", "I12"),
    "PBEAM": ("PID", "MID", "A", "I1", "I2", "I12", "J", "NSM"),
    "CROD": ("EID", "PID", "G1", "G2"),
    "CONROD": ("EID", "G1", "G2", "MID", "A", "J", "C", "NSM"),
    "CBAR": _BAR,
    "CBEAM": _BAR + ("SA", "SB"),
    "BAROR": _ORIENT,
    "BEAMOR": _ORIENT,
    "CONM2": ("EID", "G", "CID", "M", "X1", "X2", "X3", "-", "I11", "I21", "I22", "I31", "I32", "I33"),
    "SPC": ("SID", "G1", "C1", "D1", "G2", "C2", "D2"),
    "SPC1": ("SID", "C"),
    "SPCADD": ("SID",),
}


class NastranWarning(UserWarning):
    """Cards a Nastran deck holds that the reader skipped, and other notes on the reading."""


def nastran_real(text: str) -> float:
    """The value of a Nastran real field: a decimal point is required, the exponent is
    ``E``/``D`` with an optional sign or a bare sign (``1.5+3`` = 1.5e3, ``-2.-4`` = −2e−4)."""
    try:
        return _real_field(text.strip().upper())
    except ValueError:
        raise ValueError(f"{text!r} is not a Nastran real number (a decimal point is required)") from None


def _real_field(text: str) -> float:
    """:func:`nastran_real` of a stripped upper-case field."""
    match = _REAL.fullmatch(text)
    if match is None:
        raise ValueError(text)
    mantissa, exponent, bare = match.groups()
    exponent = exponent or bare
    return float(mantissa) if exponent is None else float(f"{mantissa}e{exponent}")


# ----------------------------------------------------------------------------------------------
# Lines → cards


@dataclass(slots=True)
class BulkCard:
    """One bulk data entry: its name (``GRID``, also for ``GRID*``), its data fields as upper-case
    stripped strings (``fields[0]`` is Nastran's field 2; each continuation adds 8 fields, two
    large-field lines make 8) and the deck line numbers (1-based) of its lines."""

    name: str
    fields: list[str]
    line: int
    more_lines: list[tuple[int, int]] | None = None  # (first field index, line) of each further line

    def field(self, index: int) -> str:
        """Field ``index`` (0 is Nastran's field 2), ``""`` when blank or absent."""
        return self.fields[index] if index < len(self.fields) else ""

    def line_of(self, index: int) -> int:
        """Deck line of field ``index``."""
        line = self.line
        for start, number in self.more_lines or ():
            if index >= start:
                line = number
        return line

    def label(self, index: int) -> str:
        """``'X2 (field 5)'``, ``'PA (continuation 1, field 2)'``."""
        names = _FIELD_NAMES.get(self.name, ())
        if index < len(names) and names[index] != "-":
            name = names[index]
        elif self.name == "SPC1":
            name = f"G{index - 1}"
        elif self.name == "SPCADD":
            name = f"S{index}"
        else:
            name = "field"
        where = f"field {index % 8 + 2}" if index < 8 else f"continuation {index // 8}, field {index % 8 + 2}"
        return f"{name} ({where})"

    def where(self, index: int | None = None) -> str:
        """``'line 17: CROD 12'`` (the line of field ``index`` when given)."""
        line = self.line if index is None else self.line_of(index)
        return f"line {line}: {self.name} {self.fields[0] if self.fields and self.fields[0] else '(no ID)'}"


def _strip_comment(raw: str) -> str:
    cut = raw.find("$")
    return raw if cut < 0 else raw[:cut]


def _split_free(text: str, line: int) -> tuple[str, list[str], bool]:
    parts = [part.strip() for part in text.split(",")]
    head = parts[0]
    large = head.endswith("*") or head.startswith("*")
    width = 4 if large else 8
    if len(parts) > width + 2:
        raise StructureError(
            f"line {line}: free-field entry {head or '(continuation)'} has {len(parts)} fields; at most "
            f"{width + 2} (name, {width} data fields, continuation) on one line"
        )
    data = parts[1 : 1 + width]
    return head, data + [""] * (width - len(data)), large


_SMALL_FIELDS = tuple(slice(8 + 8 * i, 16 + 8 * i) for i in range(8))
_LARGE_FIELDS = tuple(slice(8 + 16 * i, 24 + 16 * i) for i in range(4))


def _split_fixed(text: str) -> tuple[str, list[str], bool]:
    if "\t" in text:
        text = text.expandtabs(8)
    head = text[:8].strip()
    if head[:1] == "*" or head[-1:] == "*":
        return head, [text[s].strip() for s in _LARGE_FIELDS], True
    return head, [text[s].strip() for s in _SMALL_FIELDS], False


def _split_line(text: str, line: int) -> tuple[str, list[str], bool]:
    """(first field, data fields, large field?) of one upper-case line without its comment."""
    return _split_free(text, line) if "," in text else _split_fixed(text)


def _card_name(head: str) -> str:
    return head.rstrip("*").strip()


def _bulk_start(lines: list[str]) -> tuple[int, list[int]]:
    """Index of the first bulk data line and the case control's ``SPC = n`` selections."""
    for index, raw in enumerate(lines):
        text = _strip_comment(raw).strip().upper()
        if text.startswith("INCLUDE"):
            _refuse_include(text, index + 1)
        if _BEGIN_BULK.match(text):
            selected = [
                int(m.group(1)) for r in lines[:index] if (m := _CASE_SPC.match(_strip_comment(r).strip().upper()))
            ]
            return index + 1, selected
    for index, raw in enumerate(lines):
        text = _strip_comment(raw).upper()
        if text.strip():
            name = _card_name(_split_line(text, index + 1)[0])
            if name not in SUPPORTED_CARDS | SKIPPED_CARDS | _KNOWN_UNSUPPORTED:
                raise StructureError(
                    f"line {index + 1}: {text.strip()[:40]!r}: the deck has no BEGIN BULK and its first entry is not "
                    "a bulk data card"
                )
            break
    return 0, []


def _refuse_include(text: str, line: int) -> None:
    raise StructureError(f"line {line}: {text.strip()[:60]}: INCLUDE is not supported; inline the included file")


def _refuse_in_bulk(name: str, text: str, line: int) -> None:
    if name.startswith("INCLUDE"):
        _refuse_include(text, line)
    raise StructureError(f"line {line}: {text.strip()[:40]}: only one BEGIN BULK section is supported")


def _deck_cards(text: str) -> tuple[list[BulkCard], list[int]]:
    """The bulk data cards of a deck and the case control's SPC selections."""
    lines = text.splitlines()
    start, selected = _bulk_start(lines)
    cards: list[BulkCard] = []
    current: BulkCard | None = None
    for index in range(start, len(lines)):
        text = lines[index]
        if "$" in text:
            text = text[: text.index("$")]
        if not text.strip():
            continue
        text = text.upper()
        if "," in text:
            head, data, large = _split_free(text, index + 1)
        else:  # _split_fixed, inlined: this loop runs once a line
            if "\t" in text:
                text = text.expandtabs(8)
            head = text[:8].strip()
            large = head[:1] == "*" or head[-1:] == "*"
            data = [text[s].strip() for s in (_LARGE_FIELDS if large else _SMALL_FIELDS)]
        if head and head[0] not in "+*":
            name = head.rstrip("*").strip()
            if name.startswith(("ENDDATA", "INCLUDE", "BEGIN")):
                if name == "ENDDATA":
                    break
                _refuse_in_bulk(name, text, index + 1)
            current = BulkCard(name, data, index + 1)
            cards.append(current)
            continue
        if current is None:
            raise StructureError(f"line {index + 1}: continuation line with no card before it")
        if not large and len(current.fields) % 8:
            current.fields.extend([""] * (8 - len(current.fields) % 8))
        if current.more_lines is None:
            current.more_lines = []
        current.more_lines.append((len(current.fields), index + 1))
        current.fields.extend(data)
    return cards, selected


def parse_bulk(text: str) -> list[BulkCard]:
    """The bulk data cards of a deck's text, in deck order (see the module doc for the formats)."""
    return _deck_cards(text)[0]


# ----------------------------------------------------------------------------------------------
# Fields → numbers (column by column)


class _Problems(list):
    """Findings of one reading stage; :meth:`raise_if_any` raises them as one StructureError."""

    def raise_if_any(self) -> None:
        if self:
            shown = self[:_PROBLEMS_SHOWN]
            if len(self) > _PROBLEMS_SHOWN:
                shown.append(f"... and {len(self) - _PROBLEMS_SHOWN} more")
            raise StructureError(shown)


_REQUIRED = object()


def _parse_int(text: str) -> int:
    if _INT.fullmatch(text) is None:
        raise ValueError("not an integer")
    return int(text)


def _numbers(texts: list[str], kind: type, default, problems: _Problems, where) -> np.ndarray:
    """Field strings → int64 or float array (blank → ``default``). Fast path: one regular
    expression checks the whole column and one substitution turns ``1.5+3`` into ``1.5E+3``;
    otherwise each bad field is a problem ``where(k) = 'text': expected ...``."""
    if not texts:
        return np.zeros(0, dtype=kind)
    joined = "\n".join(texts)
    column = _INT_COLUMN if kind is int else _REAL_COLUMN
    if column.fullmatch(joined) and (default is not _REQUIRED or "" not in texts):
        if kind is float:
            texts = _BARE_EXPONENT.sub("E", joined.replace("D", "E")).split("\n")
        return np.array([kind(text) if text else default for text in texts], dtype=kind)
    what = "an integer" if kind is int else "a real number with a decimal point"
    parse = _parse_int if kind is int else _real_field
    out = np.zeros(len(texts), dtype=kind)
    for k, text in enumerate(texts):
        if not text:
            if default is _REQUIRED:
                problems.append(f"{where(k)} is required ({what})")
            else:
                out[k] = default
            continue
        try:
            out[k] = parse(text)
        except ValueError:
            problems.append(f"{where(k)} = {text!r}: expected {what}")
    return out


def _field_where(cards: list[BulkCard], index: int):
    return lambda k: f"{cards[k].where(index)}: {cards[k].label(index)}"


def _ints(cards: list[BulkCard], index: int, problems: _Problems, default=_REQUIRED) -> np.ndarray:
    """Integer field ``index`` of each card (blank → ``default``; required when not given)."""
    return _numbers(_text(cards, index), int, default, problems, _field_where(cards, index))


def _reals(cards: list[BulkCard], index: int, problems: _Problems, default=_REQUIRED) -> np.ndarray:
    """Real field ``index`` of each card (blank → ``default``; required when not given)."""
    return _numbers(_text(cards, index), float, default, problems, _field_where(cards, index))


def _text(cards: list[BulkCard], index: int) -> list[str]:
    return [card.fields[index] if index < len(card.fields) else "" for card in cards]


@dataclass(frozen=True)
class _Table:
    """Cards with an ID, sorted by it: ``ids`` (k,), ``rows`` the cards, ``columns`` by name."""

    ids: np.ndarray
    cards: list[BulkCard]
    columns: dict[str, np.ndarray]

    def find(self, wanted: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(row index, found) of each ID in ``wanted``."""
        wanted = np.asarray(wanted, dtype=np.int64)
        if self.ids.size == 0:
            return np.zeros(wanted.shape, dtype=np.int64), np.zeros(wanted.shape, dtype=bool)
        row = np.minimum(np.searchsorted(self.ids, wanted), self.ids.size - 1)
        return row, self.ids[row] == wanted


def _table(cards: list[BulkCard], ids: np.ndarray, columns: dict[str, np.ndarray], problems: _Problems) -> _Table:
    """Sort by ID; a repeated ID is a problem naming both lines."""
    order = np.argsort(ids, kind="stable")
    ids = ids[order]
    repeated = np.flatnonzero(ids[1:] == ids[:-1]) + 1
    for k in repeated[:_PROBLEMS_SHOWN]:
        first, again = cards[order[k - 1]], cards[order[k]]
        problems.append(f"{again.where()}: ID {ids[k]} is defined again (first: {first.name} on line {first.line})")
    return _Table(ids, [cards[i] for i in order], {name: col[order] for name, col in columns.items()})


def _missing(cards: list[BulkCard], found: np.ndarray, index: int, values: np.ndarray, what: str, problems: _Problems):
    for k in np.flatnonzero(~found)[:_PROBLEMS_SHOWN]:
        card = cards[k]
        problems.append(f"{card.where(index)}: {card.label(index)} = {values[k]}: {what} {values[k]} is not defined")


# ----------------------------------------------------------------------------------------------
# Coordinate systems


@dataclass(frozen=True)
class _Frame:
    """A coordinate system: kind ``R``/``C``/``S``, origin (3,) and axes (3, 3), column ``i``
    the unit axis ``e_i`` in basic components."""

    kind: str
    origin: np.ndarray
    axes: np.ndarray


_BASIC = _Frame("R", np.zeros(3), np.eye(3))


def _local_cartesian(kind: str, coords: np.ndarray) -> np.ndarray:
    """(k, 3) local coordinates → Cartesian components along the system's axes."""
    if kind == "R":
        return coords
    r = coords[:, 0]
    theta = np.radians(coords[:, 1])
    if kind == "C":
        return np.stack([r * np.cos(theta), r * np.sin(theta), coords[:, 2]], axis=1)
    phi = np.radians(coords[:, 2])
    return np.stack([r * np.sin(theta) * np.cos(phi), r * np.sin(theta) * np.sin(phi), r * np.cos(theta)], axis=1)


def _to_basic(frame: _Frame, coords: np.ndarray) -> np.ndarray:
    """(k, 3) coordinates in ``frame`` → basic positions."""
    return frame.origin + _local_cartesian(frame.kind, np.asarray(coords, dtype=float)) @ frame.axes.T


def _axes_at(frame: _Frame, coords: np.ndarray) -> np.ndarray:
    """(k, 3, 3): column ``i`` is the unit direction of component ``i`` of ``frame`` at each point
    (basic components): the axes (R); ``e_r, e_θ, e_z`` (C); ``e_r, e_θ, e_φ`` (S)."""
    k = coords.shape[0]
    if frame.kind == "R":
        return np.broadcast_to(frame.axes, (k, 3, 3)).copy()
    theta = np.radians(coords[:, 1])
    local = np.zeros((k, 3, 3))
    if frame.kind == "C":
        c, s = np.cos(theta), np.sin(theta)
        local[:, 0, 0], local[:, 1, 0] = c, s
        local[:, 0, 1], local[:, 1, 1] = -s, c
        local[:, 2, 2] = 1.0
    else:
        phi = np.radians(coords[:, 2])
        st, ct, sp, cp = np.sin(theta), np.cos(theta), np.sin(phi), np.cos(phi)
        local[:, :, 0] = np.stack([st * cp, st * sp, ct], axis=1)
        local[:, :, 1] = np.stack([ct * cp, ct * sp, -st], axis=1)
        local[:, :, 2] = np.stack([-sp, cp, np.zeros(k)], axis=1)
    return frame.axes @ local


def _frame_from_points(card: BulkCard, points_basic: np.ndarray) -> _Frame:
    a, b, c = points_basic
    z = b - a
    scale = max(np.linalg.norm(a), np.linalg.norm(b), np.linalg.norm(c), 1.0)
    if np.linalg.norm(z) <= 1e-12 * scale:
        raise StructureError(f"{card.where(5)}: B (fields 7-9) coincides with A: the z axis is undefined")
    z = z / np.linalg.norm(z)
    x = (c - a) - ((c - a) @ z) * z
    if np.linalg.norm(x) <= 1e-12 * scale:
        raise StructureError(f"{card.where(8)}: C (continuation 1, fields 2-4) lies on the z axis A-B")
    x = x / np.linalg.norm(x)
    return _Frame(card.name[-1], a, np.stack([x, np.cross(z, x), z], axis=1))


def _frames(groups: dict[str, list[BulkCard]]) -> dict[int, _Frame]:
    """Every CORD2R/C/S as a frame in basic, chains of RIDs resolved."""
    cards = [card for name in ("CORD2R", "CORD2C", "CORD2S") for card in groups.get(name, [])]
    problems = _Problems()
    cid = _ints(cards, 0, problems)
    rid = _ints(cards, 1, problems, default=0)
    points = np.stack([_reals(cards, i, problems, default=0.0) for i in range(2, 11)], axis=1).reshape(-1, 3, 3)
    problems.raise_if_any()
    table = _table(cards, cid, {"rid": rid, "points": points}, problems)
    for k in np.flatnonzero(table.ids <= 0):
        problems.append(f"{table.cards[k].where(0)}: CID (field 2) = {table.ids[k]}: must be a positive integer")
    problems.raise_if_any()
    defined = {int(i): k for k, i in enumerate(table.ids)}
    frames: dict[int, _Frame] = {0: _BASIC}
    for start in defined:
        chain: list[int] = []
        current = start
        while current not in frames:
            if current in chain:
                names = " → ".join(f"{table.cards[defined[c]].name} {c}" for c in chain[chain.index(current) :])
                raise StructureError(f"{table.cards[defined[current]].where(1)}: RID cycle {names} → {current}")
            if current not in defined:
                card = table.cards[defined[chain[-1]]]
                raise StructureError(f"{card.where(1)}: {card.label(1)} = {current}: coordinate system not defined")
            chain.append(current)
            current = int(table.columns["rid"][defined[current]])
        for c in reversed(chain):
            k = defined[c]
            reference = frames[int(table.columns["rid"][k])]
            frames[c] = _frame_from_points(table.cards[k], _to_basic(reference, table.columns["points"][k]))
    return frames


def _frame_of(frames: dict[int, _Frame], ids: np.ndarray, cards: list[BulkCard], index: int, problems: _Problems):
    """Check that every coordinate system ID in ``ids`` is defined."""
    for k in np.flatnonzero(~np.isin(ids, list(frames)))[:_PROBLEMS_SHOWN]:
        problems.append(f"{cards[k].where(index)}: {cards[k].label(index)} = {ids[k]}: coordinate system not defined")


# ----------------------------------------------------------------------------------------------
# Grids, materials, properties


def _components(text: str) -> np.ndarray:
    """Component digits (``'123'``) → (6,) mask; blank or ``'0'`` → none."""
    mask = np.zeros(6, dtype=bool)
    if text in ("", "0"):
        return mask
    if not text.isdigit() or any(ch not in "123456" for ch in text) or len(set(text)) != len(text):
        raise ValueError(text)
    mask[[int(ch) - 1 for ch in text]] = True
    return mask


def _component_masks(cards: list[BulkCard], index: int, problems: _Problems, defaults: list[str] | None = None):
    """(k, 6) masks of the component fields at ``index`` (blank → ``defaults``)."""
    texts = _text(cards, index)
    if defaults is not None:
        texts = [t or d for t, d in zip(texts, defaults)]
    code: dict[str, int] = {}
    masks = []
    for k, text in enumerate(texts):
        if text in code:
            continue
        code[text] = len(masks)
        try:
            masks.append(_components(text))
        except ValueError:
            problems.append(
                f"{cards[k].where(index)}: {cards[k].label(index)} = {text!r}: expected distinct digits 1-6"
            )
            masks.append(np.zeros(6, dtype=bool))
    table = np.array(masks, dtype=bool).reshape(-1, 6)
    return table[np.array([code[text] for text in texts], dtype=np.int64)]


@dataclass(frozen=True)
class _Grids:
    ids: np.ndarray
    cards: list[BulkCard]
    positions_m: np.ndarray
    local: np.ndarray  # coordinates in CD's frame at each grid, for _axes_at
    cd: np.ndarray
    ps: np.ndarray

    def find(self, wanted: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return _Table(self.ids, self.cards, {}).find(wanted)

    def displacement_axes(self, nodes: np.ndarray, frames: dict[int, _Frame]) -> np.ndarray:
        """(k, 3, 3) axes of the CD systems at ``nodes`` (columns: basic components)."""
        out = np.broadcast_to(np.eye(3), (len(nodes), 3, 3)).copy()
        cd = self.cd[nodes]
        for system in np.unique(cd[cd != 0]):
            rows = np.flatnonzero(cd == system)
            out[rows] = _axes_at(frames[int(system)], self.local[nodes[rows]])
        return out


def _from_basic(frame: _Frame, positions: np.ndarray) -> np.ndarray:
    """Basic positions → coordinates in ``frame`` (inverse of :func:`_to_basic`)."""
    xyz = (positions - frame.origin) @ frame.axes
    if frame.kind == "R":
        return xyz
    r_cyl = np.hypot(xyz[:, 0], xyz[:, 1])
    azimuth = np.degrees(np.arctan2(xyz[:, 1], xyz[:, 0]))
    if frame.kind == "C":
        return np.stack([r_cyl, azimuth, xyz[:, 2]], axis=1)
    return np.stack([np.linalg.norm(xyz, axis=1), np.degrees(np.arctan2(r_cyl, xyz[:, 2])), azimuth], axis=1)


def _default_field(card: BulkCard, index: int, problems: _Problems) -> int:
    """Integer field of a GRDSET/BAROR-like defaults card (0 when blank)."""
    text = card.field(index)
    if text and not _INT.fullmatch(text):
        problems.append(f"{card.where(index)}: {card.label(index)} = {text!r}: expected an integer")
        return 0
    return int(text or 0)


def _single(groups: dict[str, list[BulkCard]], name: str, problems: _Problems) -> BulkCard:
    """The one defaults card ``name`` (GRDSET, BAROR, BEAMOR) or an empty one."""
    cards = groups.get(name, [])
    if len(cards) > 1:
        problems.append(f"{cards[1].where()}: only one {name} is allowed (first on line {cards[0].line})")
    return cards[0] if cards else BulkCard(name, [], 0)


def _grids(groups: dict[str, list[BulkCard]], frames: dict[int, _Frame]) -> _Grids:
    """GRIDs sorted by ID, positions in basic; GRDSET gives blank CP, CD and PS."""
    cards = groups.get("GRID", [])
    problems = _Problems()
    grdset = _single(groups, "GRDSET", problems)
    ids = _ints(cards, 0, problems)
    cp = _ints(cards, 1, problems, default=_default_field(grdset, 1, problems))
    coords = np.stack([_reals(cards, i, problems, default=0.0) for i in (2, 3, 4)], axis=1).reshape(-1, 3)
    cd = _ints(cards, 5, problems, default=_default_field(grdset, 5, problems))
    ps = _component_masks(cards, 6, problems, defaults=[grdset.field(6)] * len(cards))
    for k in np.flatnonzero(ids <= 0)[:_PROBLEMS_SHOWN]:
        problems.append(f"{cards[k].where(0)}: ID (field 2) = {ids[k]}: must be a positive integer")
    _frame_of(frames, cp, cards, 1, problems)
    _frame_of(frames, cd, cards, 5, problems)
    problems.raise_if_any()
    positions = np.array(coords)
    for system in np.unique(cp[cp != 0]):
        rows = cp == system
        positions[rows] = _to_basic(frames[int(system)], coords[rows])
    local = np.array(positions)
    for system in np.unique(cd[cd != 0]):
        rows = cd == system
        local[rows] = _from_basic(frames[int(system)], positions[rows])
    table = _table(cards, ids, {"positions": positions, "local": local, "cd": cd, "ps": ps}, problems)
    problems.raise_if_any()
    c = table.columns
    return _Grids(table.ids, table.cards, c["positions"], c["local"], c["cd"], c["ps"])


def _materials(groups: dict[str, list[BulkCard]]) -> _Table:
    """MAT1 with the missing one of E, G, ν completed from ``E = 2 (1 + ν) G``; E and ν both
    blank (or G and ν) → both 0; E and G both blank is an error."""
    cards = groups.get("MAT1", [])
    problems = _Problems()
    mid = _ints(cards, 0, problems)
    E, G, nu = (_reals(cards, i, problems, default=np.nan) for i in (1, 2, 3))
    rho = _reals(cards, 4, problems, default=0.0)
    problems.raise_if_any()
    for k in np.flatnonzero(np.isnan(E) & np.isnan(G))[:_PROBLEMS_SHOWN]:
        problems.append(f"{cards[k].where(1)}: E (field 3) and G (field 4) are both blank; give at least one")
    has_E, has_G, has_nu = ~np.isnan(E), ~np.isnan(G), ~np.isnan(nu)
    with np.errstate(divide="ignore", invalid="ignore"):
        G = np.where(has_E & has_nu & ~has_G, E / (2.0 * (1.0 + nu)), G)
        E = np.where(has_G & has_nu & ~has_E, 2.0 * (1.0 + nu) * G, E)
        nu = np.where(has_E & has_G & ~has_nu, E / (2.0 * G) - 1.0, nu)
    lone = has_E ^ has_G
    E = np.where(lone & ~has_nu & ~has_E, 0.0, E)
    G = np.where(lone & ~has_nu & ~has_G, 0.0, G)
    nu = np.where(lone & ~has_nu, 0.0, nu)
    table = _table(cards, mid, {"E": E, "G": G, "nu": nu, "rho": rho}, problems)
    problems.raise_if_any()
    return table


_PROPERTY_CODES = ("PROD", "PBAR", "PBEAM")


def _pbeam_tapered(card: BulkCard, end_a: tuple[float, ...]) -> bool:
    """Whether a PBEAM's later stations (after end A's two lines) differ from end A in A, I1,
    I2, I12 or J; a station's blank field takes end A's value."""
    index = 16
    while card.field(index) in ("YES", "YESA", "NO"):
        for offset, value in zip((2, 3, 4, 5, 6), end_a):
            text = card.field(index + offset)
            if text:
                try:
                    if _real_field(text) != value:
                        return True
                except ValueError:
                    raise StructureError(
                        f"{card.where(index + offset)}: {card.label(index + offset)} = {text!r}: expected a real "
                        "number with a decimal point"
                    ) from None
        index += 16 if card.field(index) == "YES" else 8
    return False


def _properties(groups: dict[str, list[BulkCard]], notes: list[str]) -> _Table:
    """PROD, PBAR and PBEAM in one table: code (index into _PROPERTY_CODES), MID, A, I1, I2, J, NSM."""
    problems = _Problems()
    parts = []
    for code, name in enumerate(_PROPERTY_CODES):
        cards = groups.get(name, [])
        if not cards:
            continue
        pid = _ints(cards, 0, problems)
        mid = _ints(cards, 1, problems)
        A = _reals(cards, 2, problems, default=0.0)
        if name == "PROD":
            I1 = I2 = I12 = np.zeros(len(cards))
            J, nsm = _reals(cards, 3, problems, 0.0), _reals(cards, 5, problems, 0.0)
            i12_index = 0
        elif name == "PBAR":
            I1, I2, J, nsm = (_reals(cards, i, problems, 0.0) for i in (3, 4, 5, 6))
            I12, i12_index = _reals(cards, 18, problems, 0.0), 18
        else:
            I1, I2, I12, J, nsm = (_reals(cards, i, problems, 0.0) for i in (3, 4, 5, 6, 7))
            i12_index = 5
            problems.raise_if_any()
            for k, card in enumerate(cards):
                if _pbeam_tapered(card, (A[k], I1[k], I2[k], I12[k], J[k])):
                    notes.append(f"{card.where()}: tapered section; end A's A, I1, I2, J used along the beam")
        for k in np.flatnonzero(I12 != 0.0)[:_PROBLEMS_SHOWN]:
            problems.append(
                f"{cards[k].where(i12_index)}: {cards[k].label(i12_index)} = {I12[k]}: a non-principal section "
                "(I12 ≠ 0) is not supported; give the principal moments and turn the orientation vector"
            )
        parts.append((cards, pid, np.full(len(cards), code), mid, A, I1, I2, J, nsm))
    problems.raise_if_any()
    if not parts:
        return _table(
            [], np.zeros(0, dtype=np.int64), {k: np.zeros(0) for k in "code mid A I1 I2 J nsm".split()}, problems
        )
    cards = [card for part in parts for card in part[0]]
    columns = [np.concatenate([part[i] for part in parts]) for i in range(1, 9)]
    names = ("code", "mid", "A", "I1", "I2", "J", "nsm")
    table = _table(cards, columns[0], dict(zip(names, columns[1:])), problems)
    problems.raise_if_any()
    return table


# ----------------------------------------------------------------------------------------------
# Elements


@dataclass(frozen=True)
class _Elements:
    """Element columns (one row per element card)."""

    cards: list[BulkCard]
    eid: np.ndarray
    type_name: np.ndarray  # (m,) card names
    ends: np.ndarray  # (m, 2) grid IDs
    pid: np.ndarray  # -1: inline (CONROD)
    inline: np.ndarray  # (m, 4) MID, A, J, NSM of a CONROD (zeros for the others)
    vector: np.ndarray  # (m, 3) orientation components (beams)
    g0: np.ndarray  # (m,) G0 grid ID, 0: none
    basic_vector: np.ndarray  # (m,) v in basic (OFFT starts with B)

    def end_index(self, k: int, end: int) -> int:
        """Field index of end ``end`` of element ``k``."""
        return (1 if self.type_name[k] == "CONROD" else 2) + end


def _offt_flags(offt: list[str], cards: list[BulkCard], problems: _Problems) -> np.ndarray:
    """(m,) whether v is in basic (OFFT starts with B); CBEAM's field 9 may hold BIT (a real)."""
    flags: dict[str, bool] = {}
    for k, text in enumerate(offt):
        if text in flags:
            continue
        flags[text] = text[:1] == "B"
        valid = len(text) == 3 and text[0] in "GB" and all(ch in "GBO" for ch in text)
        if text and not valid and _REAL.fullmatch(text) is None:
            problems.append(f"{cards[k].where(7)}: {cards[k].label(7)} = {text!r}: expected GGG, BGG, GGO, BOO, ...")
    return np.array([flags[text] for text in offt], dtype=bool)


def _beam_orientation(cards: list[BulkCard], defaults: BulkCard, problems: _Problems):
    """(v (m, 3), G0 (m,), v in basic (m,)) of CBAR/CBEAM cards: an integer X1 with X2, X3 blank
    is G0; fields 6-8 all blank take the BAROR/BEAMOR ones, and so does a blank OFFT."""
    m = len(cards)
    x1, x2, x3 = (_text(cards, i) for i in (4, 5, 6))
    for k in [k for k in range(m) if not (x1[k] or x2[k] or x3[k])]:
        x1[k], x2[k], x3[k] = (defaults.field(i) for i in (4, 5, 6))
        if not (x1[k] or x2[k] or x3[k]):
            problems.append(f"{cards[k].where(4)}: X1-X3 or G0 (fields 6-8) required (no {defaults.name} default)")
    by_g0 = np.array([bool(a) and not b and not c and "." not in a for a, b, c in zip(x1, x2, x3)], dtype=bool)
    rows_g0, rows_v = np.flatnonzero(by_g0), np.flatnonzero(~by_g0)
    g0 = np.zeros(m, dtype=np.int64)
    g0[rows_g0] = _numbers([x1[k] for k in rows_g0], int, 0, problems, lambda j: cards[rows_g0[j]].where(4) + ": G0")
    vector = np.zeros((m, 3))
    for axis, texts in enumerate((x1, x2, x3)):

        def where(j: int, axis: int = axis) -> str:
            return f"{cards[rows_v[j]].where(4 + axis)}: {cards[rows_v[j]].label(4 + axis)}"

        vector[rows_v, axis] = _numbers([texts[k] for k in rows_v], float, 0.0, problems, where)
    offt = [text or defaults.field(7) for text in _text(cards, 7)]
    return vector, g0, _offt_flags(offt, cards, problems)


def _refuse_nonzero(cards: list[BulkCard], indices: range, what: str, problems: _Problems) -> None:
    """A problem for each card with a nonzero value among the fields ``indices``."""
    for card in cards:
        for index in indices:
            text = card.field(index)
            if not text:
                continue
            try:
                zero = (_parse_int(text) if _INT.fullmatch(text) else _real_field(text)) == 0
            except ValueError:
                zero = False
            if not zero:
                problems.append(f"{card.where(index)}: {card.label(index)} = {text!r}: {what} are not supported")
                break


def _element_part(name: str, cards: list[BulkCard], groups: dict[str, list[BulkCard]], problems: _Problems):
    """Columns of the element cards ``name`` (CROD, CONROD, CBAR, CBEAM)."""
    m = len(cards)
    eid = _ints(cards, 0, problems)
    inline = np.zeros((m, 4))
    vector, g0, basic = np.zeros((m, 3)), np.zeros(m, dtype=np.int64), np.zeros(m, dtype=bool)
    if name == "CONROD":
        ends = np.stack([_ints(cards, 1, problems), _ints(cards, 2, problems)], axis=1)
        pid = np.full(m, -1, dtype=np.int64)
        mid = _ints(cards, 3, problems).astype(float)
        inline = np.stack([mid] + [_reals(cards, i, problems, 0.0) for i in (4, 5, 7)], axis=1)
        return eid, ends, pid, inline, vector, g0, basic
    orientation_card = {"CBAR": "BAROR", "CBEAM": "BEAMOR"}.get(name)
    defaults = _single(groups, orientation_card, problems) if orientation_card else BulkCard(name, [], 0)
    pid_default = _default_field(defaults, 1, problems)
    blank = np.iinfo(np.int64).min
    pid = _ints(cards, 1, problems, default=blank)  # blank: BAROR/BEAMOR PID, else the EID
    pid = np.where(pid == blank, pid_default if pid_default else eid, pid)
    ends = np.stack([_ints(cards, 2, problems), _ints(cards, 3, problems)], axis=1)
    if name != "CROD":
        vector, g0, basic = _beam_orientation(cards, defaults, problems)
        _refuse_nonzero(cards, range(8, 10), "pin flags (PA, PB)", problems)
        _refuse_nonzero(cards, range(10, 16), "offsets (W1A-W3B)", problems)
        if name == "CBEAM":
            _refuse_nonzero(cards, range(16, 18), "warping scalar points (SA, SB)", problems)
    return eid, ends, pid, inline, vector, g0, basic


def _elements(groups: dict[str, list[BulkCard]]) -> _Elements:
    """CROD, CONROD, CBAR and CBEAM sorted by element ID."""
    problems = _Problems()
    cards: list[BulkCard] = []
    parts = []
    for name in ("CROD", "CONROD", "CBAR", "CBEAM"):
        group = groups.get(name, [])
        cards += group
        parts.append((np.full(len(group), name, dtype="<U6"), *_element_part(name, group, groups, problems)))
    problems.raise_if_any()
    type_name, eid, ends, pid, inline, vector, g0, basic = (np.concatenate(column) for column in zip(*parts))
    columns = {"type_name": type_name, "ends": ends, "pid": pid, "inline": inline, "vector": vector, "g0": g0}
    table = _table(cards, eid.astype(np.int64), columns | {"basic_vector": basic}, problems)
    problems.raise_if_any()
    return _Elements(table.cards, table.ids, **table.columns)


def _members(
    elements: _Elements,
    grids: _Grids,
    properties: _Table,
    materials: _Table,
    frames: dict[int, _Frame],
    unsupported_ids: dict[int, str],
) -> tuple[Members, dict[str, np.ndarray], np.ndarray]:
    """Member table, ``pid<PID>`` member sets and the rods' ``G J`` from the element columns."""
    problems = _Problems()
    cards = elements.cards
    nodes = np.zeros(elements.ends.shape, dtype=np.int64)
    for end in (0, 1):
        nodes[:, end], found = grids.find(elements.ends[:, end])
        for k in np.flatnonzero(~found)[:_PROBLEMS_SHOWN]:
            index = elements.end_index(k, end)
            grid = elements.ends[k, end]
            problems.append(f"{cards[k].where(index)}: {cards[k].label(index)} = {grid}: GRID {grid} is not defined")
    is_conrod = elements.pid == -1
    row, found = properties.find(elements.pid)
    expected = np.select(
        [elements.type_name == "CROD", elements.type_name == "CBAR", elements.type_name == "CBEAM"], [0, 1, 2], -1
    )
    code = properties.columns["code"][row] if len(properties.ids) else np.zeros(len(cards), dtype=np.int64)
    for k in np.flatnonzero(~is_conrod & (~found | (code != expected)))[:_PROBLEMS_SHOWN]:
        want = _PROPERTY_CODES[expected[k]]
        pid = elements.pid[k]
        have = _PROPERTY_CODES[code[k]] if found[k] else unsupported_ids.get(int(pid))
        reason = f"{want} {pid} is not defined" if have is None else f"property {pid} is a {have}, not a {want}"
        problems.append(f"{cards[k].where(1)}: {cards[k].label(1)} = {pid}: {reason}")
    problems.raise_if_any()

    def pick(column: str, inline_col: int | None) -> np.ndarray:
        values = properties.columns[column][row] if len(properties.ids) else np.zeros(len(cards))
        if inline_col is None:
            return np.where(is_conrod, 0.0, values)
        return np.where(is_conrod, elements.inline[:, inline_col], values)

    mid = np.where(is_conrod, elements.inline[:, 0], pick("mid", None)).astype(np.int64)
    A, J, nsm = pick("A", 1), pick("J", 2), pick("nsm", 3)
    I1, I2 = pick("I1", None), pick("I2", None)
    mat, found = materials.find(mid)
    for k in np.flatnonzero(~found)[:_PROBLEMS_SHOWN]:
        owner = cards[k] if is_conrod[k] else properties.cards[row[k]]
        index = 3 if is_conrod[k] else 1
        have = unsupported_ids.get(int(mid[k]))
        reason = f"MAT1 {mid[k]} is not defined" if have is None else f"material {mid[k]} is a {have}, not a MAT1"
        problems.append(f"{owner.where(index)}: {owner.label(index)} = {mid[k]}: {reason}")
    problems.raise_if_any()
    E, G, rho = (materials.columns[c][mat] for c in ("E", "G", "rho"))
    beam = (elements.type_name == "CBAR") | (elements.type_name == "CBEAM")
    orientation = _orientations(elements, nodes, grids, frames, beam)
    kind = np.where(beam, MEMBER_KINDS.index("beam"), MEMBER_KINDS.index("strut"))
    members = Members.build(
        nodes,
        positions_m=grids.positions_m,
        kind=kind,
        EA_N=E * A,
        EI_Nm2=np.stack([E * I1, E * I2], axis=1),
        GJ_Nm2=np.where(beam, G * J, 0.0),
        linear_density_kg_m=rho * A + nsm,
        orientation=orientation,
    )
    sets = {}
    with_pid = np.flatnonzero(~is_conrod)
    for pid in np.unique(elements.pid[with_pid]):
        sets[f"pid{pid}"] = np.flatnonzero(elements.pid == pid)
    return members, sets, np.where(beam, 0.0, G * J)


def _orientations(elements: _Elements, nodes: np.ndarray, grids: _Grids, frames: dict[int, _Frame], beam: np.ndarray):
    """(m, 3) beam orientation vectors in basic: ``x(G0) − x(GA)``, or X1-X3 turned from GA's CD
    system (unless OFFT starts with B); zeros for struts."""
    problems = _Problems()
    cards = elements.cards
    out = np.zeros((len(cards), 3))
    by_g0 = beam & (elements.g0 != 0)
    g0, found = grids.find(elements.g0)
    _missing(cards, found | ~by_g0, 4, elements.g0, "GRID", problems)
    same = by_g0 & found & ((g0 == nodes[:, 0]) | (g0 == nodes[:, 1]))
    for k in np.flatnonzero(same)[:_PROBLEMS_SHOWN]:
        problems.append(f"{cards[k].where(4)}: G0 (field 6) = {elements.g0[k]}: G0 must differ from GA and GB")
    problems.raise_if_any()
    out[by_g0] = grids.positions_m[g0[by_g0]] - grids.positions_m[nodes[by_g0, 0]]
    by_vector = beam & ~by_g0
    turn = np.flatnonzero(by_vector & ~elements.basic_vector)
    axes = grids.displacement_axes(nodes[turn, 0], frames)
    out[turn] = np.einsum("kij,kj->ki", axes, elements.vector[turn])
    in_basic = by_vector & elements.basic_vector
    out[in_basic] = elements.vector[in_basic]
    return out


# ----------------------------------------------------------------------------------------------
# Masses and constraints


def _point_masses(groups: dict[str, list[BulkCard]], grids: _Grids, frames: dict[int, _Frame], elements: _Elements):
    """(node point masses (n,), rigid parts): CONM2 without offset or inertia → point mass; the
    others at one grid → one rigid part ``conm2_<grid ID>``. CONM2 IDs are element IDs."""
    cards = groups.get("CONM2", [])
    n = grids.ids.size
    problems = _Problems()
    eid = _ints(cards, 0, problems)
    grid_id = _ints(cards, 1, problems)
    cid = _ints(cards, 2, problems, default=0)
    mass = _reals(cards, 3, problems)
    x = np.stack([_reals(cards, i, problems, 0.0) for i in (4, 5, 6)], axis=1).reshape(-1, 3)
    i11, i21, i22, i31, i32, i33 = (_reals(cards, i, problems, 0.0) for i in range(8, 14))
    problems.raise_if_any()
    _table(cards, eid, {}, problems)
    row, taken = _Table(elements.eid, elements.cards, {}).find(eid)
    for k in np.flatnonzero(taken)[:_PROBLEMS_SHOWN]:
        other = elements.cards[row[k]]
        problems.append(f"{cards[k].where()}: element ID {eid[k]} is taken (by {other.name} on line {other.line})")
    node, found = grids.find(grid_id)
    _missing(cards, found, 1, grid_id, "GRID", problems)
    valid = np.isin(cid, [-1, *frames])
    for k in np.flatnonzero(~valid)[:_PROBLEMS_SHOWN]:
        problems.append(f"{cards[k].where(2)}: CID (field 4) = {cid[k]}: coordinate system not defined")
    problems.raise_if_any()
    grid_position = grids.positions_m[node]
    axes = np.broadcast_to(np.eye(3), (len(cards), 3, 3)).copy()
    for system in np.unique(cid[cid > 0]):
        rows = np.flatnonzero(cid == system)
        frame = frames[int(system)]
        axes[rows] = _axes_at(frame, _from_basic(frame, grid_position[rows]))
    centre = np.where((cid == -1)[:, None], x, grid_position + np.einsum("kij,kj->ki", axes, x))
    inertia_local = np.stack(
        [np.stack([i11, -i21, -i31], -1), np.stack([-i21, i22, -i32], -1), np.stack([-i31, -i32, i33], -1)], axis=1
    )
    inertia = axes @ inertia_local @ np.transpose(axes, (0, 2, 1))
    offset = np.linalg.norm(centre - grid_position, axis=1)
    scale = np.maximum(1.0, np.linalg.norm(grid_position, axis=1))
    as_part = (offset > 1e-12 * scale) | np.any(inertia_local != 0.0, axis=(1, 2))
    node_mass = np.zeros(n)
    np.add.at(node_mass, node[~as_part], mass[~as_part])
    parts = tuple(
        _combined_part(grids.ids[g], g, mass[rows], centre[rows], inertia[rows]) for g, rows in _by_node(node, as_part)
    )
    return node_mass, parts


def _by_node(node: np.ndarray, selected: np.ndarray):
    """(node, row indices) for each node among the selected rows."""
    rows = np.flatnonzero(selected)
    for g in np.unique(node[rows]):
        yield int(g), rows[node[rows] == g]


def _combined_part(grid_id: int, node: int, mass: np.ndarray, centre: np.ndarray, inertia: np.ndarray) -> RigidPart:
    """One rigid part of several masses: total mass, mass-weighted centre (the mean when the
    total is 0) and inertia about it (each about its own centre plus ``m (|d|² 1 − d dᵀ)``)."""
    total = float(mass.sum())
    com = mass @ centre / total if total != 0.0 else centre.mean(axis=0)
    d = centre - com
    shift = mass[:, None, None] * (
        np.einsum("ki,ki->k", d, d)[:, None, None] * np.eye(3) - np.einsum("ki,kj->kij", d, d)
    )
    return RigidPart(
        name=f"conm2_{grid_id}",
        mass_kg=total,
        center_m=np.asarray(com, dtype=float),
        inertia_kg_m2=(inertia + shift).sum(axis=0),
        nodes=np.array([node], dtype=np.int64),
    )


def _thru_list(card: BulkCard, start: int, problems: _Problems) -> tuple[list[tuple[int, int]], list[tuple[int, int]]]:
    """Explicit IDs as (field index, ID) and ``a THRU b`` ranges of the fields from ``start`` on
    (blank fields ignored)."""
    tokens = [(i, card.fields[i]) for i in range(start, len(card.fields)) if card.fields[i]]
    explicit: list[tuple[int, int]] = []
    ranges: list[tuple[int, int]] = []
    k = 0
    while k < len(tokens):
        index, text = tokens[k]
        if k + 2 < len(tokens) and tokens[k + 1][1] == "THRU":
            end = tokens[k + 2][1]
            if not (_INT.fullmatch(text) and _INT.fullmatch(end)) or int(end) < int(text):
                problems.append(f"{card.where(index)}: {card.label(index)}: '{text} THRU {end}' is not a rising range")
            else:
                ranges.append((int(text), int(end)))
            k += 3
            continue
        if _INT.fullmatch(text):
            explicit.append((index, int(text)))
        else:
            problems.append(f"{card.where(index)}: {card.label(index)} = {text!r}: expected an ID")
        k += 1
    return explicit, ranges


@dataclass
class _ConstraintRows:
    """One row per (set, grid) pair: set ID, node index, (6,) components, card, field index."""

    sid: list[int] = field(default_factory=list)
    node: list[int] = field(default_factory=list)
    mask: list[np.ndarray] = field(default_factory=list)


def _spc_rows(groups: dict[str, list[BulkCard]], grids: _Grids, problems: _Problems) -> _ConstraintRows:
    rows = _ConstraintRows()

    def add(card: BulkCard, indices: list[int], sid: int, grid_ids: list[int], mask: np.ndarray) -> None:
        node, found = grids.find(np.array(grid_ids, dtype=np.int64))
        for k in np.flatnonzero(~found)[:_PROBLEMS_SHOWN]:
            index = indices[k]
            problems.append(f"{card.where(index)}: {card.label(index)}: GRID {grid_ids[k]} is not defined")
        rows.sid.extend([sid] * int(found.sum()))
        rows.node.extend(node[found].tolist())
        rows.mask.extend([mask] * int(found.sum()))

    spc = groups.get("SPC", [])
    sid = _ints(spc, 0, problems)
    for pair in (0, 1):
        g_index, c_index, d_index = 1 + 3 * pair, 2 + 3 * pair, 3 + 3 * pair
        present = [k for k, card in enumerate(spc) if card.field(g_index)]
        chosen = [spc[k] for k in present]
        grid_id = _ints(chosen, g_index, problems)
        masks = _component_masks(chosen, c_index, problems)
        shift = _reals(chosen, d_index, problems, 0.0)
        for j, card in enumerate(chosen):
            if not masks[j].any():
                problems.append(f"{card.where(c_index)}: {card.label(c_index)} is required (component digits 1-6)")
            if shift[j] != 0.0:
                problems.append(
                    f"{card.where(d_index)}: {card.label(d_index)} = {shift[j]}: enforced displacements are not "
                    "supported (a constrained component is held at its reference value)"
                )
            add(card, [g_index], int(sid[present[j]]), [int(grid_id[j])], masks[j])
    spc1 = groups.get("SPC1", [])
    sid1 = _ints(spc1, 0, problems)
    masks1 = _component_masks(spc1, 1, problems)
    for k, card in enumerate(spc1):
        if not masks1[k].any():
            problems.append(f"{card.where(1)}: C (field 3) is required (component digits 1-6)")
        explicit, ranges = _thru_list(card, 2, problems)
        add(card, [i for i, _ in explicit], int(sid1[k]), [g for _, g in explicit], masks1[k])
        for low, high in ranges:  # grids of a THRU range need not all exist
            inside = grids.ids[(grids.ids >= low) & (grids.ids <= high)].tolist()
            add(card, [2] * len(inside), int(sid1[k]), inside, masks1[k])
    return rows


def _constraints(
    groups: dict[str, list[BulkCard]], grids: _Grids, selected: list[int], notes: list[str]
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(fixed components (n, 6), node sets ``spc<SID>``)."""
    problems = _Problems()
    rows = _spc_rows(groups, grids, problems)
    problems.raise_if_any()
    sid = np.array(rows.sid, dtype=np.int64)
    node = np.array(rows.node, dtype=np.int64)
    mask = np.array(rows.mask, dtype=bool).reshape(-1, 6)
    members_of = {int(s): np.unique(node[sid == s]) for s in np.unique(sid)}
    unions: dict[int, list[int]] = {}
    for card in groups.get("SPCADD", []):
        add_sid = _ints([card], 0, problems)[0]
        explicit, ranges = _thru_list(card, 1, problems)
        parts = [s for _, s in explicit] + [s for low, high in ranges for s in sorted(members_of) if low <= s <= high]
        if add_sid in members_of or add_sid in unions:
            problems.append(f"{card.where(0)}: SID (field 2) = {add_sid}: set {add_sid} is already defined")
        for s in parts:
            if s not in members_of:
                problems.append(f"{card.where(1)}: set {s} is not an SPC or SPC1 set")
        unions[int(add_sid)] = [s for s in parts if s in members_of]
    problems.raise_if_any()
    sets = {s: [s] for s in members_of} | unions
    for s in selected:
        if s not in sets:
            problems.append(f"case control SPC = {s}: no SPC, SPC1 or SPCADD set {s} in the bulk data")
    problems.raise_if_any()
    chosen = sorted({m for s in (selected or list(members_of)) for m in sets[s]})
    if not selected and len(members_of) > 1:
        notes.append(f"no SPC set selected in case control: all sets applied ({', '.join(map(str, chosen))})")
    fixed = np.array(grids.ps)
    use = np.isin(sid, chosen)
    np.logical_or.at(fixed, node[use], mask[use])
    _check_cd_components(grids, fixed)
    node_sets = {
        f"spc{s}": np.unique(np.concatenate([members_of[m] for m in parts] or [np.zeros(0, np.int64)]))
        for s, parts in sorted(sets.items())
    }
    return fixed, node_sets


def _check_cd_components(grids: _Grids, fixed: np.ndarray) -> None:
    """Components of a grid with CD ≠ 0 are along its CD axes: only none or all of its
    translations (rotations) can be expressed as basic-axis components."""
    partial = (grids.cd != 0) & (
        (fixed[:, :3].any(axis=1) & ~fixed[:, :3].all(axis=1)) | (fixed[:, 3:].any(axis=1) & ~fixed[:, 3:].all(axis=1))
    )
    problems = _Problems()
    for k in np.flatnonzero(partial)[:_PROBLEMS_SHOWN]:
        digits = "".join(str(i + 1) for i in np.flatnonzero(fixed[k]))
        problems.append(
            f"{grids.cards[k].where(5)}: CD (field 7) = {grids.cd[k]}: components {digits} are constrained in system "
            f"{grids.cd[k]}; with CD ≠ 0 constrain none or all of 123 and of 456"
        )
    problems.raise_if_any()


# ----------------------------------------------------------------------------------------------
# The deck


@dataclass(frozen=True)
class NastranDeck:
    """A Nastran deck read into a structure.

    Attributes:
      structure: the structure (positions in the basic system).
      grid_ids: (n,) GRID ID of each node (ascending).
      element_ids: (m,) element ID of each member (ascending).
      element_types: (m,) the element card of each member (``CROD``, ``CONROD``, ``CBAR``,
        ``CBEAM``).
      rod_GJ_Nm2: (m,) ``G J`` of each CROD/CONROD member [N m²] (0 for beams): a strut carries
        no torsion, so this is for information only.
      skipped: skipped card names → counts.
      notes: the other remarks of the warning (tapered PBEAMs, SPC sets applied).
    """

    structure: Structure
    grid_ids: np.ndarray
    element_ids: np.ndarray
    element_types: np.ndarray
    rod_GJ_Nm2: np.ndarray
    skipped: dict[str, int]
    notes: tuple[str, ...]


def _group(cards: list[BulkCard], skip_unsupported: bool) -> tuple[dict[str, list[BulkCard]], Counter, dict[int, str]]:
    """Cards by name, the skipped counts, and the IDs of the skipped unsupported cards."""
    groups: dict[str, list[BulkCard]] = {}
    for card in cards:
        groups.setdefault(card.name, []).append(card)
    skipped = Counter({name: len(group) for name, group in groups.items() if name in SKIPPED_CARDS})
    unsupported = {name: group for name, group in groups.items() if name not in SUPPORTED_CARDS | SKIPPED_CARDS}
    if unsupported and not skip_unsupported:
        problems = [
            f"line {group[0].line}: {name} is not supported ({len(group)} card{'s' * (len(group) > 1)}: line"
            f"{'s' * (len(group) > 1)} {', '.join(str(c.line) for c in group[:5])}{', ...' if len(group) > 5 else ''});"
            " the reader models "
            f"{', '.join(sorted(SUPPORTED_CARDS))}; pass skip_unsupported=True to skip such cards"
            for name, group in unsupported.items()
        ]
        raise StructureError(problems)
    skipped.update({name: len(group) for name, group in unsupported.items()})
    unsupported_ids = {
        int(card.field(0)): name
        for name, group in unsupported.items()
        for card in group
        if _INT.fullmatch(card.field(0))
    }
    return {n: g for n, g in groups.items() if n in SUPPORTED_CARDS}, skipped, unsupported_ids


def _warn(skipped: Counter, notes: list[str]) -> None:
    lines = []
    if skipped:
        lines.append("skipped cards: " + ", ".join(f"{name} ({count})" for name, count in sorted(skipped.items())))
    lines.extend(notes)
    if lines:
        warnings.warn("Nastran deck: " + "; ".join(lines), NastranWarning, stacklevel=_caller_level())


def _caller_level() -> int:
    """``stacklevel`` of the first frame outside this module, for warnings."""
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_globals.get("__name__") == __name__:
        frame, level = frame.f_back, level + 1
    return level


def nastran_deck_from_text(text: str, *, name: str = "nastran", skip_unsupported: bool = False) -> NastranDeck:
    """Read a deck's text (see the module doc); ``name`` names the structure."""
    cards, selected = _deck_cards(text)
    groups, skipped, unsupported_ids = _group(cards, skip_unsupported)
    notes: list[str] = []
    frames = _frames(groups)
    grids = _grids(groups, frames)
    materials = _materials(groups)
    properties = _properties(groups, notes)
    elements = _elements(groups)
    members, member_sets, rod_GJ_Nm2 = _members(elements, grids, properties, materials, frames, unsupported_ids)
    node_mass, parts = _point_masses(groups, grids, frames, elements)
    fixed, node_sets = _constraints(groups, grids, selected, notes)
    _warn(skipped, notes)
    structure = Structure(
        name=name,
        positions_m=grids.positions_m,
        node_mass_kg=node_mass,
        members=members,
        rigid_parts=parts,
        node_sets=node_sets,
        member_sets=member_sets,
        fixed_dofs=fixed,
    )
    return NastranDeck(structure, grids.ids, elements.eid, elements.type_name, rod_GJ_Nm2, dict(skipped), tuple(notes))


def read_nastran_deck(path: str | Path, *, skip_unsupported: bool = False) -> NastranDeck:
    """Read a Nastran deck file (``.bdf``, ``.dat``, ``.nas``); errors start with the path."""
    path = Path(path)
    try:
        text = path.read_text(encoding="latin-1")
    except OSError as error:
        raise StructureError(f"{path}: cannot read the deck ({error.strerror or error})") from None
    try:
        return nastran_deck_from_text(text, name=path.stem, skip_unsupported=skip_unsupported)
    except StructureError as error:
        raise StructureError([f"{path}: {problem}" for problem in error.problems]) from None


def read_nastran(path: str | Path, *, skip_unsupported: bool = False) -> Structure:
    """The structure of a Nastran deck file (see :func:`read_nastran_deck` for the ID maps)."""
    return read_nastran_deck(path, skip_unsupported=skip_unsupported).structure
