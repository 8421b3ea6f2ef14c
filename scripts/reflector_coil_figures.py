"""Reflector coil deliverables (reflector spec §8.3 item 1): node lists, plan-view and 3-D zoom plots,
and the ``coil_torque`` JSON (same object as ``magsail torque coil``).

    python scripts/reflector_coil_figures.py --out runs/reflector/coil_torque
    python scripts/reflector_coil_figures.py --out /tmp/coil --side-m 20     # small lattice

Writes ``nodes.npz`` (``ycoil``, ``xcoil``, ``zloop``, ``perimeter_loop``, ``ycoil_p1``,
``ycoil_rows_plus1``: (K, 3) node arrays [m], structure frame), ``summary.json``,
``coil_plan.png`` (plan view of all paths, the y-coil's first columns highlighted) and
``coil_zoom3d.png`` (3-D view of the first few cells: 3/4 turns, y-steps and the connector).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from magsail_mj.analysis.coil_torque import coil_torque_report
from magsail_mj.geometry.reflector_coil import coil_x, coil_y, square_loop
from magsail_mj.io import to_jsonable, write_json, write_npz
from magsail_mj.scenarios.truss_plots import save_figure


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="output folder")
    ap.add_argument("--side-m", type=float, default=100.0)
    ap.add_argument("--segment-m", type=float, default=1.0)
    ap.add_argument("--current-a", type=float, default=10.0)
    ap.add_argument("--field-t", type=float, default=30e-6)
    args = ap.parse_args(argv)
    out = Path(args.out)
    d, L = args.side_m, args.segment_m
    report = coil_torque_report(side_m=d, segment_m=L, current_A=args.current_a, field_T=args.field_t)
    n = round(d / L)
    nodes = {"ycoil": coil_y(d, L), "xcoil": coil_x(d, L),
             "zloop": square_loop(report["zloop_side_m"], L, z=-L / 2, d=d),
             "ycoil_p1": coil_y(d, L, p=1), "ycoil_rows_plus1": coil_y(d, L, n_row=n + 1)}
    if n % 2 == 0:
        nodes["perimeter_loop"] = square_loop(d, L, z=-L / 2, d=d)
    write_npz(out / "nodes.npz", **nodes)
    write_json(out / "summary.json", to_jsonable({"scenario": "coil_torque", **report}))

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 8))
    for name, colour, lw in (("xcoil", "C9", 0.3), ("ycoil", "C1", 0.3), ("zloop", "C4", 1.5)):
        r = nodes[name]
        ax.plot(r[:, 0], r[:, 1], color=colour, lw=lw, label=name)
    y = nodes["ycoil"]
    first = y[: 4 * n * 2 + 3]
    ax.plot(first[:, 0], first[:, 1], "k", lw=1.2, label="y-coil, first two columns")
    ax.plot(*y[0, :2], "go", label="first node")
    ax.plot(*y[-1, :2], "rs", label="last node")
    ax.set_aspect("equal"), ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]")
    ax.set_title(f"plan view, d = {d:g} m, L = {L:g} m (T_max,y = {report['T_max_ycoil_N_m']:.4g} N m)")
    ax.legend(loc="upper right", fontsize=8)
    save_figure(fig, out / "coil_plan.png")

    fig = plt.figure(figsize=(9, 7))
    ax = fig.add_subplot(projection="3d")
    near = (y[:, 0] < -d / 2 + 4.5 * L) & (y[:, 1] < -d / 2 + 4.5 * L)
    idx = np.flatnonzero(near)
    runs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    for k, run in enumerate(runs):
        seg = y[run]
        ax.plot(seg[:, 0], seg[:, 1], seg[:, 2], "-o", ms=3, color=f"C{k % 10}",
                label="column 0" if k == 0 else ("connector / column 1" if k == 1 else None))
    ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]"), ax.set_zlabel("z [m]")
    ax.set_title("y-coil, first cells: 3/4 turn + y-step pattern, connector along +x")
    ax.legend()
    save_figure(fig, out / "coil_zoom3d.png")
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
