"""Read the tables of a structure file (a parsed TOML tree) into a checked :class:`Structure`.

Tables are read in the order their values depend on: ``nodes`` (the node count), ``sets``,
``[[member_groups]]`` (members numbered across groups in file order; a group's ``name`` adds a
member set), ``member_sets``, ``[[panels]]``, ``[[rigid_parts]]`` and ``[[fixed]]`` (node set names
resolved). Every problem is collected and raised together, each naming its key path; a structure
that parses is then checked (:func:`~magsail_mj.structure.checks.check_structure`) and each finding
is named by the same key path, with a member's or panel's group and row added.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from magsail_mj.structure.checks import check_structure
from magsail_mj.structure.fileschema import FORMAT, MAX_COUNT, VERSION, table_keys
from magsail_mj.structure.filevalues import ValueReader, member_lengths_m
from magsail_mj.structure.model import (
    MEMBER_KINDS,
    Members,
    ModalDamping,
    Panels,
    RigidPart,
    Structure,
    StructureError,
)

__all__ = ["read_tree"]

_CHECK_ELEMENT = re.compile(r"^(members|panels)\[(\d+)\]")
_GROUP_TABLE = {"members": "member_groups", "panels": "panels"}
#: Member group keys parsed directly (the others derive EA, EI, GJ, density and rest length).
_MEMBER_PROPERTIES = [k for k in table_keys("member_groups") if k not in ("kind", "nodes", "name")]


def read_tree(
    tree: Any, *, base_dir: Path, prefix: str, in_file: bool, default_name: str
) -> tuple[Structure, dict[str, str]]:
    """The checked structure of ``tree`` and the SHA-256 of every companion file read
    (:class:`StructureError` naming every problem)."""
    r = ValueReader(base_dir, prefix=prefix)
    if not isinstance(tree, dict):
        raise r.error("", f"a table is needed, got {type(tree).__name__}")
    r.unknown(tree, "", "")
    _header(r, tree, in_file=in_file)
    name = r.guard(r.field, tree, "", "name", "", None) if "name" in tree else default_name
    nodes = r.guard(_nodes, r, tree.get("nodes"))
    if nodes is None:
        raise StructureError(r.problems)
    positions, masses = nodes
    node_sets = _index_table(r, tree, "sets")
    members, member_starts, group_sets = _member_groups(r, tree, positions)
    member_sets = _index_table(r, tree, "member_sets")
    for set_name, (g, indices) in group_sets.items():
        if set_name in member_sets:
            r.fail(f"member_groups[{g}].name", f"{set_name!r} is also a key of member_sets")
        member_sets[set_name] = indices
    panels, panel_starts = _panel_groups(r, tree)
    parts = _rigid_parts(r, tree, node_sets)
    fixed = _fixed(r, tree, positions.shape[0], node_sets)
    stiffness_model = r.guard(r.field, tree, "", "stiffness_model", "", None)
    modal_damping = r.guard(_modal_damping, r, tree)
    if r.problems:
        raise StructureError(r.problems)
    structure = Structure(
        name=name,
        positions_m=positions,
        node_mass_kg=masses,
        members=members,
        panels=panels,
        rigid_parts=parts,
        node_sets=node_sets,
        member_sets=member_sets,
        fixed_dofs=fixed,
        stiffness_model=stiffness_model,
        modal_damping=modal_damping,
    )
    try:
        check_structure(structure)
    except StructureError as err:
        starts = {"members": member_starts, "panels": panel_starts}
        raise StructureError([_locate(r, line, starts) for line in err.problems]) from None
    return structure, dict(r.files.sha256)


def _modal_damping(r: ValueReader, tree: dict) -> ModalDamping | None:
    """The ``[modal_damping]`` table (``None`` when absent)."""
    table = tree.get("modal_damping")
    if table is None:
        return None
    if not isinstance(table, dict):
        raise r.error("modal_damping", f"a table is needed, got {type(table).__name__}")
    r.unknown(table, "modal_damping", "modal_damping")
    values = {key: r.field(table, "modal_damping", key, "modal_damping", None) for key in table_keys("modal_damping")}
    for key in ("xi_low", "xi_cap", "rtol"):
        if not (np.isfinite(values[key]) and values[key] >= 0):
            raise r.error(f"modal_damping.{key}", f"must be finite and >= 0, got {values[key]!r}")
    if not 0 < values["rtol"] < 1:
        raise r.error("modal_damping.rtol", f"must be between 0 and 1, got {values['rtol']!r}")
    return ModalDamping(**values)


def _header(r: ValueReader, tree: dict, *, in_file: bool) -> None:
    for key in ("format", "version"):
        if in_file and key not in tree:
            expected = f'"{FORMAT}"' if key == "format" else VERSION
            r.fail(key, f"required in a structure file ({key} = {expected})")
    if "format" in tree and tree["format"] != FORMAT:
        r.fail("format", f'must be "{FORMAT}", got {tree["format"]!r}')
    version = tree.get("version", VERSION)
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        r.fail("version", f"a version number (an integer >= 1) is needed, got {version!r}")
    elif version > VERSION:
        r.fail("version", f"{version} is newer than the version this magsail_mj reads ({VERSION})")


def _locate(r: ValueReader, line: str, starts: dict[str, np.ndarray]) -> str:
    """A finding of the checks below the key prefix, a member's or panel's group and row added."""
    if line.startswith("structure:"):
        text = line.removeprefix("structure:").lstrip()
        return f"{r.prefix}: {text}" if r.prefix else text
    found = _CHECK_ELEMENT.match(line)
    if found and starts[found.group(1)].size:
        first = starts[found.group(1)]
        index = int(found.group(2))
        group = int(np.searchsorted(first, index, side="right")) - 1
        line += f" [{_GROUP_TABLE[found.group(1)]}[{group}], row {index - first[group]}]"
    return r.at(line)


def _nodes(r: ValueReader, value: Any) -> tuple[np.ndarray, np.ndarray]:
    if value is None:
        raise r.error("nodes", "required: a table with position_m, or { file = ... }")
    if not isinstance(value, dict):
        raise r.error("nodes", f"a table is needed, got {type(value).__name__}")
    r.unknown(value, "nodes", "nodes")
    if "file" in value:
        value = _nodes_from_file(r, value)
    positions = r.required(value, "nodes", "position_m", "nodes", None)
    if positions.shape[0] > MAX_COUNT:
        raise r.error("nodes.position_m", f"{positions.shape[0]} nodes, more than {MAX_COUNT}")
    masses = r.field(value, "nodes", "mass_kg", "nodes", positions.shape[0])
    return positions, masses


def _nodes_from_file(r: ValueReader, table: dict) -> dict[str, np.ndarray]:
    """``position_m`` and ``mass_kg`` of a whole-table companion (.csv columns x_m, y_m, z_m,
    mass_kg; .npz arrays position_m, mass_kg)."""
    if len(table) > 1:
        raise r.error("nodes", f"give either file or position_m and mass_kg, not both (keys: {', '.join(table)})")
    key, _ = r.files.resolve(table["file"], r.at("nodes.file"))
    if key.lower().endswith(".npz"):
        _, arrays = r.files.npz_arrays(table["file"], r.at("nodes.file"))
        extra = sorted(set(arrays) - {"position_m", "mass_kg"})
        if extra:
            raise r.error("nodes.file", f"{key!r}: unknown array {extra[0]!r} (position_m and mass_kg are read)")
        if "position_m" not in arrays:
            raise r.error("nodes.file", f"{key!r} has no array 'position_m'")
        return arrays
    csv = r.files.csv_table(table["file"], r.at("nodes.file"))
    extra = [name for name in csv.names if name not in ("x_m", "y_m", "z_m", "mass_kg")]
    if extra:
        raise r.error("nodes.file", f"{key!r}: unknown column {extra[0]!r} (x_m, y_m, z_m and mass_kg are read)")
    out = {"position_m": csv.columns(["x_m", "y_m", "z_m"], r.at("nodes.file"))}
    if "mass_kg" in csv.names:
        out["mass_kg"] = csv.columns(["mass_kg"], r.at("nodes.file"))[:, 0]
    return out


def _index_table(r: ValueReader, tree: dict, key: str) -> dict[str, np.ndarray]:
    """The named index sets of table ``key`` (``sets`` or ``member_sets``)."""
    value = tree.get(key, {})
    if not isinstance(value, dict):
        r.fail(key, f"a table of name = [indices] is needed, got {type(value).__name__}")
        return {}
    sets = {}
    for name, indices in value.items():
        if not name:
            r.fail(key, "a set needs a non-empty name")
            continue
        parsed = r.guard(r.form, indices, "indices", f"{key}[{name!r}]", None)
        if parsed is not None:
            sets[name] = parsed
    return sets


def _member_groups(r: ValueReader, tree: dict, positions: np.ndarray):
    """The member table, the first member of each group, and each named group's member set."""
    tables, starts, named = [], [], {}
    count = 0
    for g, group in enumerate(r.tables(tree, "member_groups")):
        where = f"member_groups[{g}]"
        before = len(r.problems)
        r.unknown(group, "member_groups", where)
        kind = r.guard(r.required, group, "member_groups", "kind", where, None)
        pairs = r.guard(r.required, group, "member_groups", "nodes", where, None)
        if pairs is None:
            continue
        if count + pairs.shape[0] > MAX_COUNT:
            r.fail(f"{where}.nodes", f"more than {MAX_COUNT} members in all")
            break
        values = {}
        for key in _MEMBER_PROPERTIES:
            if key in group:
                values[key] = r.guard(r.field, group, "member_groups", key, where, pairs.shape[0])
        name = r.guard(r.field, group, "member_groups", "name", where, None)
        if len(r.problems) > before or kind is None:
            continue
        members = r.guard(_member_table, r, where, kind, pairs, values, positions)
        if members is None:
            continue
        if name is not None:
            if name in named:
                r.fail(f"{where}.name", f"{name!r} also names member_groups[{named[name][0]}]")
            named[name] = (g, np.arange(count, count + len(members)))
        tables.append(members)
        starts.append(count)
        count += len(members)
    return _concatenate_members(tables), np.array(starts, dtype=np.int64), named


def _member_table(
    r: ValueReader, where: str, kind: str, pairs: np.ndarray, v: dict[str, np.ndarray], positions: np.ndarray
) -> Members:
    """One group's member table from its parsed keys ``v``, the derived properties computed."""
    m = pairs.shape[0]
    used: set[str] = set()
    problems: list[str] = []

    def take(*keys: str) -> list[np.ndarray | None]:
        used.update(k for k in keys if k in v)
        return [v.get(k) for k in keys]

    def conflict(*keys: str) -> bool:
        given = [k for k in keys if k in v]
        if len(given) > 1:
            problems.append(f"{r.at(where)}: give {' or '.join(keys)}, not {' and '.join(given)}")
        return len(given) > 1

    EA = _axial(r, where, v, take, conflict, problems)
    EI, GJ = _bending(r, where, kind, m, v, take, conflict, problems)
    density = _linear_density(r, where, m, v, take, conflict, problems)
    conflict("rest_length_m", "prestrain")
    rest, prestrain = take("rest_length_m", "prestrain")
    if prestrain is not None and not (prestrain > -1).all():
        bad = int(np.flatnonzero(~(prestrain > -1))[0])
        problems.append(
            f"{r.at(where)}.prestrain: must be > -1, got {float(prestrain[bad])!r} (member {bad} of the group)"
        )
    damping, strain_limit, orientation = take("damping_Ns_m", "strain_limit", "orientation")
    for key in sorted(set(v) - used):
        problems.append(f"{r.at(where)}.{key}: not used with the keys given (see the member group keys)")
    if problems:
        raise StructureError(problems)
    if rest is None:
        # A member naming a missing node (or a node whose position is not finite) has no finite length
        # (NaN, inf). The check refuses it by that node (``members[i].nodes: node 80 does not exist``,
        # ``nodes[j].position_m: not finite``); a placeholder length of 1 m keeps its derived rest
        # length from being reported as a second, knock-on problem.
        length = member_lengths_m(positions, pairs)
        length[~np.isfinite(length)] = 1.0
        rest = length / (1.0 + (0.0 if prestrain is None else prestrain))
    return Members(
        nodes=pairs,
        kind=np.full(m, MEMBER_KINDS.index(kind), dtype=np.int8),
        EA_N=EA,
        EI_Nm2=EI,
        GJ_Nm2=GJ,
        damping_Ns_m=np.zeros(m) if damping is None else damping,
        rest_length_m=rest,
        strain_limit=np.full(m, np.inf) if strain_limit is None else strain_limit,
        linear_density_kg_m=density,
        orientation=np.zeros((m, 3)) if orientation is None else orientation,
    )


def _axial(r, where, v, take, conflict, problems) -> np.ndarray | None:
    """``EA_N``, or ``E_Pa · area_m2`` (with ``EA_N`` given, ``E_Pa`` and ``area_m2`` serve only
    the bending, torsion and density; unused they are refused)."""
    if "EA_N" in v:
        return take("EA_N")[0]
    if "area_m2" in v and "E_Pa" in v:
        area, modulus = take("area_m2", "E_Pa")
        return modulus * area
    problems.append(f"{r.at(where)}.EA_N: required (or area_m2 with E_Pa)")
    return None


def _bending(r, where, kind, m, v, take, conflict, problems) -> tuple[np.ndarray, np.ndarray]:
    """``EI_Nm2`` or ``E_Pa · [I1_m4, I2_m4]``; ``GJ_Nm2`` or ``J_m4`` times ``G_Pa`` or
    ``E_Pa / (2 (1 + nu))`` (beams only for the section keys)."""
    section = [k for k in ("I1_m4", "I2_m4", "J_m4", "G_Pa", "nu") if k in v]
    if section and kind != "beam":
        problems.append(f"{r.at(where)}.{section[0]}: only beams take section bending and torsion (kind {kind!r})")
    EI = np.zeros((m, 2))
    if not conflict("EI_Nm2", "I1_m4") and not conflict("EI_Nm2", "I2_m4"):
        if "EI_Nm2" in v:
            EI = take("EI_Nm2")[0]
        elif "I1_m4" in v or "I2_m4" in v:
            if not all(k in v for k in ("I1_m4", "I2_m4", "E_Pa")):
                problems.append(f"{r.at(where)}: I1_m4 and I2_m4 go together, with E_Pa")
            else:
                I1, I2, modulus = take("I1_m4", "I2_m4", "E_Pa")
                EI = modulus[:, None] * np.stack([I1, I2], axis=1)
    GJ = np.zeros(m)
    if not conflict("GJ_Nm2", "J_m4") and not conflict("G_Pa", "nu"):
        if "GJ_Nm2" in v:
            GJ = take("GJ_Nm2")[0]
        elif "J_m4" in v:
            GJ = _torsion(r, where, v, take, problems)
    return EI, GJ


def _torsion(r, where, v, take, problems) -> np.ndarray:
    (J,) = take("J_m4")
    if "G_Pa" in v:
        return take("G_Pa")[0] * J
    if "nu" in v and "E_Pa" in v:
        nu, modulus = take("nu", "E_Pa")
        if not ((nu > -1) & (nu < 0.5)).all():
            bad = int(np.flatnonzero(~((nu > -1) & (nu < 0.5)))[0])
            problems.append(
                f"{r.at(where)}.nu: must be in (-1, 0.5), got {float(nu[bad])!r} (member {bad} of the group)"
            )
        return modulus / (2.0 * (1.0 + nu)) * J
    problems.append(f"{r.at(where)}.J_m4: needs G_Pa, or nu with E_Pa")
    return np.zeros_like(J)


def _linear_density(r, where, m, v, take, conflict, problems) -> np.ndarray:
    """``linear_density_kg_m``, or ``density_kg_m3 · area_m2``, or 0."""
    if conflict("linear_density_kg_m", "density_kg_m3"):
        return np.zeros(m)
    if "linear_density_kg_m" in v:
        return take("linear_density_kg_m")[0]
    if "density_kg_m3" in v:
        if "area_m2" not in v:
            problems.append(f"{r.at(where)}.density_kg_m3: needs area_m2")
            return np.zeros(m)
        rho, area = take("density_kg_m3", "area_m2")
        return rho * area
    return np.zeros(m)


def _concatenate_members(tables: list[Members]) -> Members:
    if tables:
        return Members.concatenate(tables)
    empty = np.zeros(0)
    return Members(
        nodes=np.zeros((0, 2), dtype=np.int64),
        kind=np.zeros(0, dtype=np.int8),
        EA_N=empty.copy(),
        EI_Nm2=np.zeros((0, 2)),
        GJ_Nm2=empty.copy(),
        damping_Ns_m=empty.copy(),
        rest_length_m=empty.copy(),
        strain_limit=empty.copy(),
        linear_density_kg_m=empty.copy(),
        orientation=np.zeros((0, 3)),
    )


def _panel_groups(r: ValueReader, tree: dict) -> tuple[Panels, np.ndarray]:
    groups, starts, count = [], [], 0
    for g, group in enumerate(r.tables(tree, "panels")):
        where = f"panels[{g}]"
        r.unknown(group, "panels", where)
        corners = r.guard(r.required, group, "panels", "nodes", where, None)
        if corners is None:
            continue
        if count + corners.shape[0] > MAX_COUNT:
            r.fail(f"{where}.nodes", f"more than {MAX_COUNT} panels in all")
            break
        p = corners.shape[0]
        density = r.guard(r.field, group, "panels", "areal_density_kg_m2", where, p)
        reflectivity = r.guard(r.required, group, "panels", "reflectivity", where, p)
        drag = r.guard(r.field, group, "panels", "drag_coefficient", where, p)
        if density is None or reflectivity is None or drag is None:
            continue
        groups.append(Panels(corners, density, reflectivity, drag))
        starts.append(count)
        count += p
    if not groups:
        return Panels.empty(), np.zeros(0, dtype=np.int64)
    columns = {name: np.concatenate([getattr(p, name) for p in groups]) for name in Panels.__dataclass_fields__}
    return Panels(**columns), np.array(starts, dtype=np.int64)


def _rigid_parts(r: ValueReader, tree: dict, node_sets: dict[str, np.ndarray]) -> tuple[RigidPart, ...]:
    parts = []
    for k, table in enumerate(r.tables(tree, "rigid_parts")):
        where = f"rigid_parts[{k}]"
        r.unknown(table, "rigid_parts", where)
        values = [
            r.guard(r.required, table, "rigid_parts", key, where, None, node_sets)
            for key in ("name", "mass_kg", "center_m", "inertia_kgm2", "nodes")
        ]
        if all(value is not None for value in values):
            name, mass, center, inertia, nodes = values
            parts.append(RigidPart(name=name, mass_kg=mass, center_m=center, inertia_kg_m2=inertia, nodes=nodes))
    return tuple(parts)


def _fixed(r: ValueReader, tree: dict, n: int, node_sets: dict[str, np.ndarray]) -> np.ndarray:
    """(n, 6) constrained components: the union of every ``[[fixed]]`` entry."""
    fixed = np.zeros((n, 6), dtype=bool)
    for k, table in enumerate(r.tables(tree, "fixed")):
        where = f"fixed[{k}]"
        r.unknown(table, "fixed", where)
        nodes = r.guard(r.required, table, "fixed", "nodes", where, None, node_sets)
        dofs = r.guard(r.field, table, "fixed", "dofs", where, None)
        if nodes is None or dofs is None:
            continue
        bad = (nodes < 0) | (nodes >= n)
        if bad.any():
            r.fail(f"{where}.nodes", f"node {nodes[bad][0]} does not exist ({n} nodes)")
            continue
        columns = np.array([int(d) - 1 for d in dofs])
        fixed[nodes[:, None], columns[None, :]] = True
    return fixed
