"""The structure of a ``structure`` config: read from a file or the ``[structure]`` table, rods added.

What validating a config needs, kept free of MuJoCo and Matplotlib (the config schema imports this
module; the model builder and the tasks import it too):

* :func:`read_source` — the checked :class:`~magsail_mj.structure.model.Structure` of a structure
  file (``.toml``, :func:`~magsail_mj.structure.fileformat.read_structure`), a Nastran deck
  (``.bdf``, ``.dat``, ``.nas``, :func:`~magsail_mj.structure.nastran.read_nastran`), any mesh
  meshio reads (``.msh`` and the others, :func:`~magsail_mj.structure.mesh.read_mesh`) or the
  inline tables of the structure format
  (:func:`~magsail_mj.structure.fileformat.structure_from_mapping`), with the SHA-256 of every file
  read;
* :func:`with_rods` — the structure with the rods' mass per length added to their members;
* :func:`model_counts` — the ``(nv, nbody, ntendon)`` of its MuJoCo model
  (:func:`~magsail_mj.structure.mjcf.build_structure_spec`), counted from the body layout without
  building it (the memory estimate reads them).
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from magsail_mj.structure.beams import BEAM_NODE, PARTICLE, body_layout
from magsail_mj.structure.fileformat import StructureSource, read_structure, structure_from_mapping
from magsail_mj.structure.mesh import read_mesh
from magsail_mj.structure.model import MEMBER_KINDS, Structure, StructureError
from magsail_mj.structure.nastran import read_nastran

__all__ = [
    "INLINE_KEYS",
    "collinear",
    "NASTRAN_SUFFIXES",
    "STRUCTURE_SUFFIXES",
    "file_kind",
    "model_counts",
    "read_source",
    "with_rods",
]

#: Keys of the structure format that may stand inline under ``[structure]``.
INLINE_KEYS = (
    "format",
    "version",
    "name",
    "nodes",
    "sets",
    "member_sets",
    "member_groups",
    "panels",
    "rigid_parts",
    "fixed",
)
#: Suffixes read as Nastran bulk-data decks.
NASTRAN_SUFFIXES = (".bdf", ".dat", ".nas")
#: Suffixes read as structure files; any other suffix is a mesh read by meshio.
STRUCTURE_SUFFIXES = (".toml",)
_BEAM = MEMBER_KINDS.index("beam")


def collinear(positions_m: np.ndarray) -> bool:
    """Whether the points lie on one line (or one point): the second principal extent below 1e-6
    of the first (the test :class:`~magsail_mj.estimation.attitude.BestFitRotation` refuses by)."""
    p = np.asarray(positions_m, dtype=float)
    pc = p - p.mean(axis=0)
    ev = np.linalg.eigvalsh(pc.T @ pc)
    return not ev[1] > 1e-12 * ev[2]


def file_kind(path: str | Path) -> str:
    """``"structure"``, ``"nastran"`` or ``"mesh"``: how the file at ``path`` is read (by suffix)."""
    suffix = Path(path).suffix.lower()
    if suffix in STRUCTURE_SUFFIXES:
        return "structure"
    return "nastran" if suffix in NASTRAN_SUFFIXES else "mesh"


def _file_digest(path: Path) -> dict[str, str]:
    try:
        return {path.name: hashlib.sha256(path.read_bytes()).hexdigest()}
    except OSError as err:
        raise StructureError(f"{path}: cannot be read: {err.strerror or err}") from None


def read_source(
    *,
    file: str | Path | None,
    inline: Mapping[str, Any],
    base_dir: Path,
    mesh_options: Mapping[str, Any] | None = None,
    skip_unsupported: bool = False,
) -> StructureSource:
    """The checked structure of a structure file, a deck or a mesh at ``file`` (relative to
    ``base_dir``), or of the ``inline`` tables (companion files relative to ``base_dir``).

    Args:
      file: the file, or ``None`` for the inline tables.
      inline: the structure format's tables (:data:`INLINE_KEYS`) when ``file`` is ``None``.
      base_dir: the folder relative paths start from [the config file's folder].
      mesh_options: keyword arguments of :func:`~magsail_mj.structure.mesh.read_mesh` (``groups``
        of member or panel properties, ``members``, ``panels``, ``skip``,
        ``merge_tolerance_m``, ``length_unit_m``); meshes only.
      skip_unsupported: skip the Nastran cards the reader does not model (decks only).

    Raises:
      StructureError: every problem, each naming its element (a file's problems start with its path).
    """
    if file is None:
        return structure_from_mapping(dict(inline), base_dir=base_dir, key_prefix="")
    path = Path(file) if Path(file).is_absolute() else Path(base_dir) / file
    kind = file_kind(path)
    if kind == "structure":
        return read_structure(path)
    if not path.is_file():
        raise StructureError(f"{path}: {'is not a file' if path.exists() else 'does not exist'}")
    if kind == "nastran":
        structure = read_nastran(path, skip_unsupported=skip_unsupported)
    else:
        structure = read_mesh(path, **dict(mesh_options or {}))
    return StructureSource(structure, _file_digest(path))


def with_rods(structure: Structure, members: np.ndarray, *, rod_linear_density_kg_m: float) -> Structure:
    """``structure`` with ``rod_linear_density_kg_m`` [kg/m] added to the linear density of
    ``members`` (the rods' mass, half lumped at each end like the member's own)."""
    rods = np.asarray(members, dtype=np.int64)
    if rod_linear_density_kg_m == 0 or rods.size == 0:
        return structure
    density = np.array(structure.members.linear_density_kg_m, dtype=float)
    density[rods] += float(rod_linear_density_kg_m)
    return replace(structure, members=replace(structure.members, linear_density_kg_m=density))


def model_counts(structure: Structure) -> tuple[int, int, int]:
    """``(nv, nbody, ntendon)`` of :func:`~magsail_mj.structure.mjcf.build_structure_spec`'s model
    of ``structure``: 3 slide dofs per particle less its fixed translations; 4 per beam joining a
    tree body to its parent and 4 per closing body of a cut beam (a beam that closes a cycle); at
    each tree root 6 (free), or its free translations plus 3 (ball) or its free rotations (hinges);
    one body per particle, beam node, rigid part and closing body (and the world); one tendon per
    strut and cable. Equality constraints (the closing welds, the world attachments of further held
    places) add no dofs."""
    layout = body_layout(structure)
    n = structure.n_nodes
    fixed = np.asarray(structure.fixed_dofs, dtype=bool)
    particle = layout.kind[:n] == PARTICLE
    nv = int((~fixed[particle, :3]).sum())
    tree = np.flatnonzero((layout.kind == BEAM_NODE) | (np.arange(layout.kind.size) >= n))
    roots = tree[layout.parent[tree] < 0]
    cuts = int(layout.cut_member.size)
    nv += 4 * int(tree.size - roots.size + cuts)
    for v in roots.tolist():
        if layout.anchor_node[v] < 0:
            nv += 6
            continue
        held = np.asarray(layout.root_fixed[v], dtype=bool)
        nv += int((~held[:3]).sum()) + (3 if not held[3:].any() else int((~held[3:]).sum()))
    nbody = 1 + int(particle.sum()) + int(tree.size) + cuts
    ntendon = int(np.count_nonzero(structure.members.kind != _BEAM))
    return nv, nbody, ntendon
