"""Write a :class:`Structure` as a structure file that reads back to the same arrays, bit for bit.

Members are written as one ``[[member_groups]]`` per run of consecutive members of one kind,
panels as one ``[[panels]]`` per run of triangles or of quads, constraints as one ``[[fixed]]`` per
distinct pattern of constrained components. A per-element column whose values are all the same
bits is written as one number, a column equal to its key's default (bit for bit) is left out,
a rest length equal to the end nodes' distance is left out (the reader computes the same
``|x_b − x_a|``), and every other column is written whole: inline, or with ``arrays="npz"`` as a
named array of the companion ``<stem>.npz`` beside the file.
"""

from __future__ import annotations

import dataclasses

from typing import Any

import numpy as np

from magsail_mj.structure.fileschema import FORMAT, VERSION, slot
from magsail_mj.structure.filevalues import member_lengths_m
from magsail_mj.structure.model import MEMBER_KINDS, Structure
from magsail_mj.structure.tomlwrite import Inline

__all__ = ["structure_tree"]


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    a = np.ascontiguousarray(a, dtype=float)
    b = np.ascontiguousarray(np.broadcast_to(b, a.shape), dtype=float)
    return bool(np.array_equal(a.view(np.int64), b.view(np.int64)))


def _runs(codes: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` of each run of equal consecutive values of ``codes``."""
    edges = np.flatnonzero(np.diff(codes)) + 1
    bounds = np.concatenate([[0], edges, [codes.shape[0]]]).astype(int)
    return [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]


class _Arrays:
    """Where the whole columns go: inline, or into the companion ``.npz`` under a key."""

    def __init__(self, mode: str, npz_name: str):
        self.mode = mode
        self.npz_name = npz_name
        self.store: dict[str, np.ndarray] = {}

    def put(self, key: str, array: np.ndarray) -> Any:
        if self.mode == "npz" and array.size:
            self.store[key] = np.ascontiguousarray(array)
            return Inline(file=self.npz_name, array=key)
        return array

    def column(self, table: dict, key: str, array: np.ndarray, store_key: str, default: Any = None) -> None:
        """Set ``table[key]`` to ``array`` as compactly as reads back exactly: nothing when it is the
        default; one number when all values are the same bits, one row when all rows are and the
        key takes one row for all (``[x, y, z]``, a reflectivity triple)."""
        if default is not None and _same_bits(array, default):
            return
        if array.ndim == 1 and _same_bits(array, array[0]):
            table[key] = float(array[0])
        elif array.ndim == 2 and array.shape[1] == 3 and _same_bits(array, array[0]):
            table[key] = array[0]
        else:
            table[key] = self.put(store_key, array)


def structure_tree(structure: Structure, *, arrays: str, npz_name: str) -> tuple[dict, dict[str, np.ndarray]]:
    """The TOML tree of ``structure`` and the arrays of its companion ``.npz`` (empty unless
    ``arrays == "npz"``)."""
    out = _Arrays(arrays, npz_name)
    s = structure
    tree: dict[str, Any] = {"format": FORMAT, "version": VERSION, "name": s.name}
    nodes = {"position_m": out.put("position_m", s.positions_m)}
    if s.n_nodes:
        out.column(nodes, "mass_kg", s.node_mass_kg, "mass_kg", default=0.0)
    tree["nodes"] = nodes
    for key, sets in (("sets", s.node_sets), ("member_sets", s.member_sets)):
        if sets:
            tree[key] = {name: out.put(f"{key}.{i}", np.asarray(v)) for i, (name, v) in enumerate(sets.items())}
    groups = [_member_group(s, start, stop, out, g) for g, (start, stop) in enumerate(_runs(s.members.kind))]
    panel_kind = s.panels.nodes[:, 3] >= 0
    panels = [_panel_group(s, start, stop, out, g) for g, (start, stop) in enumerate(_runs(panel_kind))]
    parts = [_rigid_part(part, out, k) for k, part in enumerate(s.rigid_parts)]
    for key, value in (
        ("member_groups", groups),
        ("panels", panels),
        ("rigid_parts", parts),
        ("fixed", _fixed(s, out)),
    ):
        if value:
            tree[key] = value
    if s.stiffness_model != "members":
        tree["stiffness_model"] = s.stiffness_model
    if s.modal_damping is not None:
        tree["modal_damping"] = dataclasses.asdict(s.modal_damping)
    return tree, out.store


def _member_group(s: Structure, start: int, stop: int, out: _Arrays, g: int) -> dict:
    mm = s.members
    rows = slice(start, stop)
    pairs = mm.nodes[rows]
    group: dict[str, Any] = {"kind": MEMBER_KINDS[mm.kind[start]], "nodes": out.put(f"member_groups.{g}.nodes", pairs)}

    def column(key: str, array: np.ndarray, default: Any) -> None:
        out.column(group, key, array, f"member_groups.{g}.{key}", default)

    column("EA_N", mm.EA_N[rows], None)
    EI = mm.EI_Nm2[rows]
    column("EI_Nm2", EI[:, 0] if _same_bits(EI[:, 0], EI[:, 1]) else EI, 0.0)
    column("GJ_Nm2", mm.GJ_Nm2[rows], 0.0)
    for key in ("damping_Ns_m", "strain_limit"):
        column(key, getattr(mm, key)[rows], slot("member_groups", key).default)
    column("rest_length_m", mm.rest_length_m[rows], member_lengths_m(s.positions_m, pairs))
    column("linear_density_kg_m", mm.linear_density_kg_m[rows], 0.0)
    column("orientation", mm.orientation[rows], 0.0)
    return group


def _panel_group(s: Structure, start: int, stop: int, out: _Arrays, g: int) -> dict:
    pn = s.panels
    rows = slice(start, stop)
    corners = pn.nodes[rows] if pn.nodes[start, 3] >= 0 else pn.nodes[rows, :3]
    group: dict[str, Any] = {"nodes": out.put(f"panels.{g}.nodes", corners)}
    for key in ("areal_density_kg_m2", "reflectivity", "drag_coefficient"):
        out.column(group, key, getattr(pn, key)[rows], f"panels.{g}.{key}", slot("panels", key).default)
    return group


def _rigid_part(part, out: _Arrays, k: int) -> dict:
    inertia = np.asarray(part.inertia_kg_m2, dtype=float)
    if _same_bits(inertia, inertia.T):
        off = inertia[[0, 0, 1], [1, 2, 2]]
        values = np.diag(inertia) if _same_bits(off, 0.0) else np.concatenate([np.diag(inertia), off])
    else:
        values = inertia.ravel()
    return {
        "name": part.name,
        "mass_kg": float(part.mass_kg),
        "center_m": np.asarray(part.center_m, dtype=float),
        "inertia_kgm2": values,
        "nodes": out.put(f"rigid_parts.{k}.nodes", np.asarray(part.nodes, dtype=np.int64)),
    }


def _fixed(s: Structure, out: _Arrays) -> list[dict]:
    """One entry per distinct non-empty pattern of constrained components."""
    if not s.fixed_dofs.any():
        return []
    patterns, which = np.unique(s.fixed_dofs, axis=0, return_inverse=True)
    entries = []
    for j, pattern in enumerate(patterns):
        if pattern.any():
            dofs = "".join(str(c + 1) for c in np.flatnonzero(pattern))
            nodes = np.flatnonzero(which.ravel() == j)
            entries.append({"nodes": out.put(f"fixed.{len(entries)}.nodes", nodes), "dofs": dofs})
    return entries
