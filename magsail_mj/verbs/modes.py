"""``magsail modes SOURCE [--count K] [--plot DIR] [--set KEY=VALUE ...]``: the lowest modes of a structure.

``SOURCE`` is one of

* a structure file (``*.toml`` with ``format = "magsail-structure"``,
  :func:`magsail_mj.structure.fileformat.read_structure`);
* a config whose concept registers the structure it models
  (:func:`magsail_mj.concepts.structure_of`: the truss and current-loop lattices with the
  concept's particle masses and strut axial rigidities, the truss ``cantilever`` with its clamped
  edge, the structure concept's structure); another concept's config has none (exit 2);
* a gmsh mesh (``.msh``, :func:`magsail_mj.structure.mesh.read_mesh` without properties: only a
  mesh whose elements need none; a mesh's member and panel properties are given in a ``structure``
  config, ``[structure] file = "<mesh>"`` with ``[structure.mesh.groups.<group>]`` tables, whose
  modes this verb computes, or in Python, the mesh read and saved as a structure file);
* a Nastran bulk-data deck (``.bdf``, ``.dat``, ``.nas``,
  :func:`magsail_mj.structure.nastran.read_nastran`).

``--set KEY=VALUE`` (repeatable) overrides a key of a config ``SOURCE`` as ``magsail run`` and
``magsail validate`` do (the same parser and validation, :func:`magsail_mj.config.load_config`),
so the modes are those of the structure the overridden config runs; for a structure file, a mesh
or a Nastran deck it is refused (exit 2, naming ``--set``).

The modes are :func:`magsail_mj.structure.modes.structure_modes` (lumped mass). The JSON object:
``frequencies_Hz`` (ascending, the zero modes first), ``rigid_body_modes`` (the number of zero
modes: rigid-body motions and mechanisms; ``zero_mode_rule`` states the clamp), ``participation``
(rigid-body directions, effective masses and their fractions per mode), ``share`` (in-plane,
bending and twist per mode, and the principal axes), ``n_dof`` (the independent coordinates),
``count`` (modes computed: ``--count``, at most ``n_dof``), ``solver``, ``source`` (path and
kind) and ``prestress``: the modes are about the static equilibrium of the members' prestrain
(:mod:`magsail_mj.structure.assembly`, "Prestress"), and this block gives the prestrained members'
count, each member kind's axial force range there ``[min, max]`` [N] (tension positive: the
booms' compression under a tensioned net), the cables that end in compression there (the linear
model keeps them; a real cable would go slack) and the solve's relative residual. ``--plot DIR`` writes
``mode_NN.png`` for the elastic modes among them (at most :data:`MAX_PLOTS`): the structure's
members undeformed and in the mode shape, scaled so the largest node displacement is a tenth of
the structure's size; their paths are listed in ``plots``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from mpl_toolkits.mplot3d.art3d import Line3DCollection

from magsail_mj.io import check_output_folder
from magsail_mj.resources import check_memory
from magsail_mj.plotting import new_figure, save_figure
from magsail_mj.structure.assembly import assemble, dof_layout
from magsail_mj.structure.model import MEMBER_KINDS, Structure
from magsail_mj.structure.modes import ROUNDING_FLOOR, RIGID_DIRECTIONS, StructureModes, structure_modes
from magsail_mj.verbs.common import output_dir, print_json
from magsail_mj.verbs.sources import read_source

__all__ = ["MAX_PLOTS", "modes"]

MAX_PLOTS = 12
"""The most mode-shape PNGs ``--plot`` writes."""
# Memory of a solve per independent coordinate: 477 MB peak RSS measured for the 20 000-node
# lattice (60 000 coordinates, SuperLU fill 12.5 M), about 8 kB per coordinate with the interpreter;
# twice that leaves room for structures whose factor fills more.
_BYTES_PER_DOF = 16_384
_PLOT_FRACTION = 0.1


def _report(result: StructureModes, structure: Structure, *, source: str, kind: str, count: int) -> dict[str, Any]:
    p, s = result.participation, result.share
    return {
        "frequencies_Hz": result.frequencies_Hz,
        "rigid_body_modes": result.n_zero,
        "zero_mode_rule": f"|omega^2| <= {result.zero_tol:g} |phi|^T |K| |phi| or <= {ROUNDING_FLOOR:.3g} "
        "max K_ii/M_ii (clamped to 0)",
        "participation": {
            "directions": list(RIGID_DIRECTIONS),
            "about": "centre of mass, structure axes",
            "center_of_mass_m": result.assembly.center_m,
            "reference": p.reference,
            "effective_mass": p.effective_mass,
            "fraction": p.fraction,
        },
        "share": {
            "in_plane": s.in_plane,
            "bending": s.bending,
            "twist": s.twist,
            "axes": {"e1": s.axes[0], "e2": s.axes[1], "normal": s.axes[2]},
            "symmetric": s.symmetric,
        },
        "prestress": _prestress_report(result, structure),
        "n_dof": result.assembly.n_dof,
        "count": count,
        "solver": result.solver,
        "source": {"path": source, "kind": kind},
    }


def _prestress_report(result: StructureModes, structure: Structure) -> dict[str, Any]:
    """The prestress equilibrium the modes are taken about: the prestrained members' count, the
    range ``[min, max]`` of each member kind's axial force there [N] (tension positive), the
    cables in compression there and the solve's relative residual
    (:class:`~magsail_mj.structure.assembly.Prestress`)."""
    prestress = result.assembly.prestress
    kinds = np.asarray(MEMBER_KINDS)[structure.members.kind]
    force = prestress.force_N
    return {
        "prestrained_members": int(np.count_nonzero(prestress.reference_force_N)),
        "force_N": {
            kind: [float(force[kinds == kind].min()), float(force[kinds == kind].max())]
            for kind in MEMBER_KINDS
            if np.any(kinds == kind)
        },
        "compressed_cables": prestress.compressed_cables,
        "residual": prestress.residual,
    }


def _plot(result: StructureModes, structure: Structure, folder: Path) -> list[Path]:
    """``mode_NN.png`` of the first elastic modes (at most :data:`MAX_PLOTS`) in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    p = structure.positions_m
    ends = structure.members.nodes
    size = float(np.ptp(p, axis=0).max()) or 1.0
    shapes = result.node_translations()
    written = []
    for n in range(result.n_zero, min(result.frequencies_Hz.size, result.n_zero + MAX_PLOTS)):
        u = shapes[n]
        u = u * (_PLOT_FRACTION * size / max(float(np.linalg.norm(u, axis=1).max()), 1e-300))
        fig, ax = new_figure(figsize=(6.0, 5.0), subplot_kw={"projection": "3d"})
        for points, colour, style, label in (
            (p, "0.45", "--", "undeformed"),
            (p + u, "C0", "-", "mode shape (scaled)"),
        ):
            if len(ends):
                segments = np.stack([points[ends[:, 0]], points[ends[:, 1]]], axis=1)
                lines = Line3DCollection(segments, colors=colour, linewidths=0.8, linestyles=style, label=label)
                ax.add_collection3d(lines)
            else:
                ax.scatter(*points.T, s=2, color=colour, label=label)
        limits = [(p[:, i].min() - 0.1 * size, p[:, i].max() + 0.1 * size) for i in range(3)]
        ax.auto_scale_xyz(*limits)
        ax.set_box_aspect([hi - lo for lo, hi in limits])  # one scale on all three axes
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_zlabel("z [m]")
        ax.set_title(
            f"mode {n + 1}: {result.frequencies_Hz[n]:.4g} Hz (in-plane {result.share.in_plane[n]:.2f}, "
            f"bending {result.share.bending[n]:.2f}, twist {result.share.twist[n]:.2f})",
            fontsize=9,
        )
        ax.legend(loc="upper left", fontsize=8)
        written.append(save_figure(fig, folder / f"mode_{n + 1:02d}.png"))
    return written


def modes(args: argparse.Namespace) -> int:
    """Print the modes of ``SOURCE`` as one JSON object (module docstring)."""
    plot_dir = None
    if args.plot is not None:
        plot_dir = output_dir(args.plot, "--plot")
        check_output_folder(plot_dir, option="--plot")
    structure, kind = read_source(args.source, args.set)
    check_memory(_BYTES_PER_DOF * dof_layout(structure).n_dof, what=f"modes {args.source}")
    assembly = assemble(structure)
    count = min(int(args.count), assembly.n_dof)
    result = structure_modes(structure, k=count, assembly=assembly)
    report = _report(result, structure, source=args.source, kind=kind, count=count)
    if plot_dir is not None:
        report["plots"] = [str(path) for path in _plot(result, structure, plot_dir)]
    print_json(report, what="SOURCE")
    return 0
