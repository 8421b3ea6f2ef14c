"""The declared schema of the structure file: every table and key, its form, default and meaning.

One table, :data:`SLOTS`, is what the reader accepts (a key not declared here is refused), how it
parses each value (by the slot's :data:`FORMS` entry) and what the reference page
``docs/structure_file.md`` lists (the unit of a key is read from its suffix by
:func:`magsail_mj.units_grammar.unit_label`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

__all__ = [
    "CHOICES",
    "FORMAT",
    "FORMS",
    "MAX_COUNT",
    "MAX_FILE_BYTES",
    "SLOTS",
    "TABLES",
    "VERSION",
    "Slot",
    "slot",
    "table_keys",
]

#: Value of the ``format`` key of a structure file.
FORMAT = "magsail-structure"
#: The version this code reads and writes.
VERSION = 1
#: Most nodes, members, panels or set entries a structure may have (refused before allocating).
MAX_COUNT = 10_000_000
#: Largest structure file read [bytes]; large arrays belong in companion files.
MAX_FILE_BYTES = 256 * 1024**2


@dataclass(frozen=True)
class Slot:
    """One key of one table of the format.

    Attributes:
      table: the table (``""``: top level; ``member_groups``, ``panels``, ``rigid_parts``,
        ``fixed``: arrays of tables; ``file``: a companion reference).
      key: the key.
      form: how the value is read (a key of :data:`FORMS`).
      default: the value when absent (``None``: required or derived, see ``default_doc``).
      meaning: what it is, for the reference page.
      default_doc: the default as the reference page states it, when not ``default`` itself.
    """

    table: str
    key: str
    form: str
    default: Any
    meaning: str
    default_doc: str | None = None


#: Documentation type of each value form.
FORMS = {
    "string": "string",
    "integer": "integer",
    "number": "number",
    "kind": '`"strut"`, `"cable"` or `"beam"`',
    "table": "table",
    "tables": "array of tables",
    "path": "string: a relative path",
    "names": "string, or array of strings",
    "positions": "n rows `[x, y, z]`",
    "per_node": "number, or n numbers",
    "index_table": "table: name = array of indices",
    "pairs": "m rows `[a, b]` of node indices",
    "per_member": "number, or m numbers",
    "per_member_axes": "number, m numbers, or m rows `[axis 1, axis 2]`",
    "vector_per_member": "`[x, y, z]`, or m rows of them",
    "corners": "p rows of 3 (triangle) or 4 (quad) node indices",
    "per_panel": "number, or p numbers",
    "triple_per_panel": "`[specular, diffuse, absorbed]`, or p rows of them",
    "vector": "`[x, y, z]`",
    "inertia": "3, 6 or 9 numbers",
    "node_refs": "array of node indices, or a node set's name",
    "dofs": 'string of the digits 1–6 (e.g. `"123"`)',
    "stiffness_model": '`"members"`, `"corotational"` or `"paper_literal"`',
    "damping_schedule": '`"paper_max"` or `"capped_rayleigh"`',
    "damping_frame": '`"body"` or `"inertial"`',
    "damping_form": '`"dense"` or `"polynomial"`',
}

#: the values of the choice forms
CHOICES = {
    "stiffness_model": ("members", "corotational", "paper_literal"),
    "damping_schedule": ("paper_max", "capped_rayleigh"),
    "damping_frame": ("body", "inertial"),
    "damping_form": ("dense", "polynomial"),
}

#: The tables, in file order, with their meaning for the reference page.
TABLES = {
    "": "The top level of a structure file (or the `[structure]` table of a task config).",
    "nodes": "The nodes: undeformed positions in the structure frame and lumped point masses. "
    'The whole table may instead be one companion file: `nodes = { file = "nodes.csv" }` with columns '
    "`x_m`, `y_m`, `z_m` and optionally `mass_kg`, or an `.npz` with arrays `position_m` and optionally `mass_kg`.",
    "sets": "Named node sets, `name = [indices]` (0-based node indices): boundary conditions, rigid parts, "
    "sensors, metrics.",
    "member_sets": "Named member sets, `name = [indices]` (0-based member indices, members numbered across "
    "`[[member_groups]]` in file order).",
    "member_groups": "`[[member_groups]]`: members of one kind sharing a way of giving their properties. Every "
    "property is one number for the whole group or an array of one value per member.",
    "panels": "`[[panels]]`: membranes and reflector facets, triangles or quads, corners counter-clockwise "
    "about the panel's front normal. Their mass (areal density × area) is shared equally by the corners.",
    "rigid_parts": "`[[rigid_parts]]`: rigid bodies (a bus, a hub) welded to some nodes, with their own mass "
    "and inertia.",
    "fixed": "`[[fixed]]` (or `fixed = [ { ... }, ... ]`): constrained components of some nodes, held at their "
    "reference values.",
    "modal_damping": "`[modal_damping]`: Caughey damping γ = M Φ diag(2 ξ_n ω_n) Φᵀ M over the free structure's "
    "modes (Robb et al. 2022b, Eqs. 13–15), applied as a load beside or instead of member dashpots.",
    "file": "A companion reference: any value that is an array may instead be this inline table, naming a "
    "file beside the structure file.",
}

_REQUIRED = "required"
SLOTS: tuple[Slot, ...] = (
    Slot(
        "",
        "format",
        "string",
        None,
        f'the file format, `"{FORMAT}"`',
        "required in a file; optional under `[structure]`",
    ),
    Slot("", "version", "integer", None, f"the format's version, `{VERSION}`", "as `format`"),
    Slot("", "name", "string", None, "the structure's name", "the file's stem (`structure` in a config)"),
    Slot("", "nodes", "table", None, "the nodes (below)", _REQUIRED),
    Slot("", "sets", "index_table", {}, "named node sets (below)"),
    Slot("", "member_sets", "index_table", {}, "named member sets (below)"),
    Slot("", "member_groups", "tables", [], "member groups (below)"),
    Slot("", "panels", "tables", [], "panel groups (below)"),
    Slot("", "rigid_parts", "tables", [], "rigid parts (below)"),
    Slot("", "fixed", "tables", [], "constraints (below)"),
    Slot(
        "",
        "stiffness_model",
        "stiffness_model",
        "members",
        "how the elastic forces are computed: `members`, each member's own spring (exact at large rotations); "
        "`corotational`, the struts' linear stiffness K assembled once and co-rotated with the best-fit rotation "
        "R̃, F = −R̃ K [R̃ᵀ(r − c) − (r₀ − c₀)] (Robb et al. 2022b, Eq. 12 with its rotation); `paper_literal`, "
        "Eq. 12 as printed, F = −K (r − R̃ r₀) (small rotations only). The linear forms hold struts only.",
    ),
    Slot("", "modal_damping", "table", None, "structure-level Caughey modal damping (below)", "none"),
    Slot(
        "modal_damping",
        "schedule",
        "damping_schedule",
        "paper_max",
        "the damping ratios ξ_n of the elastic modes: `paper_max` (the paper's schedule) or `capped_rayleigh`",
    ),
    Slot("modal_damping", "xi_low", "number", 0.01, "damping ratio of the low modes"),
    Slot("modal_damping", "n_low", "integer", 100, "the number of low elastic modes at `xi_low`"),
    Slot("modal_damping", "xi_cap", "number", 10.0, "the largest damping ratio"),
    Slot(
        "modal_damping",
        "frame",
        "damping_frame",
        "body",
        "`body`: γ co-rotated with the structure; `inertial`: assembled once in inertial axes",
    ),
    Slot(
        "modal_damping",
        "form",
        "damping_form",
        "dense",
        "`dense`: the exact matrix; `polynomial`: a matrix polynomial within `rtol` above the low modes",
    ),
    Slot("modal_damping", "rtol", "number", 0.02, "relative tolerance of the polynomial form"),
    Slot("nodes", "position_m", "positions", None, "undeformed node positions, structure frame", _REQUIRED),
    Slot("nodes", "mass_kg", "per_node", 0.0, "point mass at each node (members, panels and parts add theirs)"),
    Slot("nodes", "file", "path", None, "companion file holding the whole table (instead of the keys above)", "—"),
    Slot(
        "member_groups",
        "kind",
        "kind",
        None,
        "strut: axial spring–dashpot; cable: the same in tension only; beam: axial, bending and torsion",
        _REQUIRED,
    ),
    Slot("member_groups", "nodes", "pairs", None, "end nodes of each member", _REQUIRED),
    Slot("member_groups", "name", "string", None, "makes the group's members a member set of this name", "—"),
    Slot("member_groups", "EA_N", "per_member", None, "axial rigidity E·A", "`E_Pa` × `area_m2`"),
    Slot(
        "member_groups",
        "area_m2",
        "per_member",
        None,
        "section area (for `EA_N` with `E_Pa`, for the linear density with `density_kg_m3`)",
        "—",
    ),
    Slot("member_groups", "E_Pa", "per_member", None, "Young's modulus", "—"),
    Slot(
        "member_groups",
        "I1_m4",
        "per_member",
        None,
        "second moment of area about section axis 1 (beams; with `E_Pa` and `I2_m4`)",
        "—",
    ),
    Slot("member_groups", "I2_m4", "per_member", None, "second moment of area about section axis 2 (beams)", "—"),
    Slot("member_groups", "J_m4", "per_member", None, "torsion constant (beams; with `G_Pa`, or `nu` and `E_Pa`)", "—"),
    Slot("member_groups", "G_Pa", "per_member", None, "shear modulus", "`E_Pa` / (2 (1 + `nu`))"),
    Slot("member_groups", "nu", "per_member", None, "Poisson's ratio, −1 < ν < 1/2 (instead of `G_Pa`)", "—"),
    Slot(
        "member_groups",
        "EI_Nm2",
        "per_member_axes",
        None,
        "bending rigidities about section axes 1 and 2 (one value: both)",
        "`E_Pa` × [`I1_m4`, `I2_m4`], else 0",
    ),
    Slot("member_groups", "GJ_Nm2", "per_member", None, "torsional rigidity", "`G_Pa` × `J_m4`, else 0"),
    Slot(
        "member_groups",
        "damping_Ns_m",
        "per_member",
        0.0,
        "axial dashpot c (force −c l̇); a beam's bending and torsion are damped in proportion, β = c l0 / EA times "
        "each hinge's stiffness (EI/l0, GJ/l0), so each mode of beams of one β has the damping ratio β ω / 2",
    ),
    Slot(
        "member_groups",
        "rest_length_m",
        "per_member",
        None,
        "unstrained length l0 (instead of `prestrain`)",
        "node distance / (1 + `prestrain`)",
    ),
    Slot(
        "member_groups",
        "prestrain",
        "per_member",
        0.0,
        "strain ε0 > −1 at the undeformed positions: "
        "l0 = node distance / (1 + ε0), in tension for ε0 > 0 (instead of `rest_length_m`)",
    ),
    Slot(
        "member_groups",
        "strain_limit",
        "per_member",
        math.inf,
        "largest |l / l0 − 1| before the structure counts as failed (`inf`: none)",
    ),
    Slot(
        "member_groups",
        "linear_density_kg_m",
        "per_member",
        None,
        "mass per length, half lumped at each end",
        "`density_kg_m3` × `area_m2`, else 0",
    ),
    Slot("member_groups", "density_kg_m3", "per_member", None, "material density (with `area_m2`)", "—"),
    Slot(
        "member_groups",
        "orientation",
        "vector_per_member",
        0.0,
        "a vector in the plane of section axis 1 (beams; zeros: the builder chooses)",
        "`[0, 0, 0]`",
    ),
    Slot("panels", "nodes", "corners", None, "corner nodes, counter-clockwise about the front normal", _REQUIRED),
    Slot("panels", "areal_density_kg_m2", "per_panel", 0.0, "mass per area"),
    Slot(
        "panels",
        "reflectivity",
        "triple_per_panel",
        None,
        "fractions of sunlight reflected specularly, reflected diffusely and absorbed (each row sums to 1)",
        _REQUIRED,
    ),
    Slot("panels", "drag_coefficient", "per_panel", 2.2, "free-molecular drag coefficient C_D"),
    Slot("rigid_parts", "name", "string", None, "the part's name (unique)", _REQUIRED),
    Slot(
        "rigid_parts", "mass_kg", "number", None, "mass of the part itself (its nodes' masses not counted)", _REQUIRED
    ),
    Slot("rigid_parts", "center_m", "vector", None, "its centre of mass, structure frame", _REQUIRED),
    Slot(
        "rigid_parts",
        "inertia_kgm2",
        "inertia",
        None,
        "its inertia tensor about `center_m`, structure axes: "
        "3 numbers `[Ixx, Iyy, Izz]` (a diagonal tensor), 6 `[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]` (the tensor's entries, "
        "i.e. minus the products of inertia) or 9 (the matrix, row by row)",
        _REQUIRED,
    ),
    Slot("rigid_parts", "nodes", "node_refs", None, "the nodes welded to the part", _REQUIRED),
    Slot("fixed", "nodes", "node_refs", None, "the constrained nodes", _REQUIRED),
    Slot(
        "fixed",
        "dofs",
        "dofs",
        "123456",
        "constrained components: 1, 2, 3 translations along x, y, z; 4, 5, 6 rotations about x, y, z",
        '`"123456"`',
    ),
    Slot(
        "file",
        "file",
        "path",
        None,
        "the companion file, relative to the structure file's folder: `.npz` or `.csv`",
        _REQUIRED,
    ),
    Slot("file", "array", "string", None, "the array's name in an `.npz` file", "required for `.npz`"),
    Slot(
        "file",
        "columns",
        "names",
        None,
        "the columns of a `.csv` file, in this order (a single string: that column as a 1-D array)",
        "all columns",
    ),
)

_SLOT = {(s.table, s.key): s for s in SLOTS}
_KEYS = {table: [s.key for s in SLOTS if s.table == table] for table in TABLES}


def slot(table: str, key: str) -> Slot:
    """The slot of ``key`` in ``table``."""
    return _SLOT[(table, key)]


def table_keys(table: str) -> list[str]:
    """The keys ``table`` accepts, in declared order."""
    return _KEYS[table]
