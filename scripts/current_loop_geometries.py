"""Figures of the current-loop geometries on the truss lattice (current-loops spec §2).

One PNG per geometry: A, B, C_x, C_y, D_x, D_y, F (= B + D_x + D_y) and the section-5 set
C_x + C_y + B. Lattice struts in light grey; every circuit segment is an arrow along the
positive current direction, coloured by the circuit's dipole axis (x red, y green, z blue,
spec §2.6); segments with multiplicity 2 are drawn thicker. The title gives the realised
vector area [D²] and wire length [D] of each circuit.

    python scripts/current_loop_geometries.py --units 12 --out runs/current_loops/geometries

The plate depth is drawn ``--z-scale`` times its true size (default 3) so that the loops
through the depth can be seen; the scale is printed in each figure.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection  # noqa: E402

from magsail_mj.geometry.current_loops import Circuit, circuits  # noqa: E402
from magsail_mj.geometry.lattice import Lattice, make_lattice  # noqa: E402

AXIS_COLOURS = {0: "tab:red", 1: "tab:green", 2: "tab:blue"}
AXIS_LABELS = {0: "x-loops (dipole +x)", 1: "y-loops (dipole +y)", 2: "z-loops (dipole +z)"}
#: figure stem -> circuit names
FIGURES = {
    "A": ["A"], "B": ["B"], "C_x": ["C_x"], "C_y": ["C_y"], "D_x": ["D_x"], "D_y": ["D_y"],
    "F": ["F"], "set5_Cx_Cy_B": ["C_x", "C_y", "B"],
}


def draw(lat: Lattice, loops: list[Circuit], *, title: str, z_scale: float, path: Path, dpi: int) -> None:
    """Draw the lattice and ``loops`` in 3-D and save a PNG at ``path``."""
    D = lat.side_m
    w = lat.cube_edge_m
    P = lat.nodes * np.array([1.0, 1.0, z_scale])
    fig = plt.figure(figsize=(8.0, 7.0))
    ax = fig.add_subplot(projection="3d")
    ax.add_collection3d(Line3DCollection(P[lat.struts], colors="0.82", linewidths=0.4))
    n_loop = len(loops)
    for k, c in enumerate(loops):
        col = AXIS_COLOURS[c.axis]
        a, b = P[c.src], P[c.dst]
        # offset overlaid circuits slightly so shared struts stay visible
        off = (k - (n_loop - 1) / 2) * 0.04 * w * np.array([1.0, 1.0, z_scale])
        d = b - a
        lw = np.where(c.mult > 1, 2.6, 1.3)
        vertical = np.abs(d[:, 2]) > 0.5 * np.abs(d[:, :2]).max(axis=1)
        for m in np.unique(lw):
            for vert, ratio in ((False, 0.35), (True, 0.35 / z_scale)):   # same head size for all
                s = (lw == m) & (vertical == vert)
                if np.any(s):
                    ax.quiver(a[s, 0] + off[0], a[s, 1] + off[1], a[s, 2] + off[2], d[s, 0], d[s, 1],
                              d[s, 2], color=col, linewidths=m, arrow_length_ratio=ratio)
    ax.set_xlim(-D / 2, D / 2)
    ax.set_ylim(-D / 2, D / 2)
    ax.set_zlim(-D / 2, D / 2)
    ax.set_box_aspect((1.0, 1.0, max(0.15, z_scale * w / D * 1.6)))
    ax.set_zlim(P[:, 2].min() * 1.3, P[:, 2].max() * 1.3)
    ax.view_init(elev=28, azim=-58)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    handles = [Line2D([], [], color=AXIS_COLOURS[ax_], lw=2, label=AXIS_LABELS[ax_])
               for ax_ in sorted({c.axis for c in loops})]
    handles.append(Line2D([], [], color="0.75", lw=1, label="lattice struts"))
    ax.legend(handles=handles, loc="upper left", fontsize=8)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=dpi)
    plt.close(fig)
    tmp.replace(path)


def describe(lat: Lattice, c: Circuit) -> dict:
    D = lat.side_m
    a = c.vector_area(lat.nodes) / D**2
    return {"name": c.name, "axis": "xyz"[c.axis], "vector_area_D2": [round(float(v), 4) + 0.0 for v in a],
            "wire_length_D": round(c.length(lat.nodes) / D, 3), "segments": c.n_segments}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--units", type=int, default=12, help="cubes per side N (default 12)")
    p.add_argument("--side-m", type=float, default=250.0, help="plate side D [m] (default 250)")
    p.add_argument("--out", type=Path, default=Path("runs/current_loops/geometries"), help="output folder")
    p.add_argument("--z-scale", type=float, default=3.0, help="exaggeration of the plate depth (default 3)")
    p.add_argument("--dpi", type=int, default=130)
    p.add_argument("--only", nargs="*", choices=sorted(FIGURES), help="draw only these figures")
    args = p.parse_args(argv)
    if args.units < 1:
        p.error(f"--units: must be >= 1, got {args.units}")
    if not args.side_m > 0:
        p.error(f"--side-m: must be > 0, got {args.side_m}")
    if not args.z_scale > 0:
        p.error(f"--z-scale: must be > 0, got {args.z_scale}")
    lat = make_lattice(units=args.units, side_m=args.side_m)
    args.out.mkdir(parents=True, exist_ok=True)
    report = {"units": args.units, "side_m": args.side_m, "figures": {}}
    for stem, names in FIGURES.items():
        if args.only and stem not in args.only:
            continue
        loops = circuits(lat, names)
        info = [describe(lat, c) for c in loops]
        lines = [f"{d['name']}: a = ({d['vector_area_D2'][0]:.4f}, {d['vector_area_D2'][1]:.4f}, "
                 f"{d['vector_area_D2'][2]:.4f}) D², l = {d['wire_length_D']:.3f} D" for d in info]
        title = (f"{' + '.join(c.name for c in loops)}  —  N = {args.units}, D = {args.side_m:g} m, "
                 f"depth ×{args.z_scale:g}\n" + "\n".join(lines))
        path = args.out / f"{stem}.png"
        draw(lat, loops, title=title, z_scale=args.z_scale, path=path, dpi=args.dpi)
        report["figures"][stem] = {"file": str(path), "circuits": info}
    print(json.dumps(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
