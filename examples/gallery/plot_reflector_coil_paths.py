"""
Reflector coil paths
====================

The reflector is steered by three current paths built into its lattice: an *x-coil* and a
*y-coil* (columns of 3/4 turns about the x or y axis, joined by steps along the lattice) and an
in-plane *z-loop*. A current ``I`` in a path of vector area ``A`` has the dipole ``m = I A``
[A·m²] and feels the torque ``T = m × B`` [N·m] in the field ``B`` [T].

This example builds the paths of a 20 m lattice with 1 m cells (the paper's reflector is 100 m;
the pattern is the same) with :mod:`magsail_mj.geometry.reflector_coil`, and asks
:func:`magsail_mj.analysis.coil_torque.coil_torque_report` for the torque capability of each path
at 10 A in a 30 µT field (the numbers of ``magsail torque coil --side-m 20``).
"""

import matplotlib.pyplot as plt
import numpy as np

from magsail_mj.analysis.coil_torque import coil_torque_report
from magsail_mj.geometry.reflector_coil import coil_x, coil_y, square_loop

SIDE_M, CELL_M, CURRENT_A, FIELD_T = 20.0, 1.0, 10.0, 30e-6
report = coil_torque_report(side_m=SIDE_M, segment_m=CELL_M, current_A=CURRENT_A, field_T=FIELD_T)
paths = {
    "x-coil": coil_x(SIDE_M, CELL_M),
    "y-coil": coil_y(SIDE_M, CELL_M),
    "z-loop": square_loop(report["zloop_side_m"], CELL_M, z=-CELL_M / 2, d=SIDE_M),
}
for key in sorted(k for k in report if k.startswith("T_max")):
    print(f"{key} = {report[key]:.4g}")

# %%
# Plan view
# ---------
# All three paths seen from +z (structure frame, metres). The first two columns of the y-coil are
# drawn in black; the green dot and red square are its first and last node.

n_cells = round(SIDE_M / CELL_M)
fig, ax = plt.subplots(figsize=(7, 7))
for (name, nodes), colour, width in zip(paths.items(), ("C9", "C1", "C4"), (0.5, 0.5, 1.5)):
    ax.plot(nodes[:, 0], nodes[:, 1], color=colour, lw=width, label=name)
y_nodes = paths["y-coil"]
first = y_nodes[: 4 * n_cells * 2 + 3]
ax.plot(first[:, 0], first[:, 1], "k", lw=1.2, label="y-coil, first two columns")
ax.plot(*y_nodes[0, :2], "go", label="y-coil first node")
ax.plot(*y_nodes[-1, :2], "rs", label="y-coil last node")
ax.set_aspect("equal")
ax.set_xlabel("x [m]")
ax.set_ylabel("y [m]")
ax.set_title(
    f"coil paths, side {SIDE_M:g} m, cell {CELL_M:g} m; "
    f"T_max,y = {report['T_max_ycoil_Nm']:.3g} N·m at {CURRENT_A:g} A, {FIELD_T * 1e6:g} µT",
    fontsize=9,
)
ax.legend(loc="upper right", fontsize=8)

# %%
# The first cells in 3-D
# ----------------------
# Each column of the y-coil is a chain of 3/4 turns about the y axis with a step along y between
# turns; a connector along +x leads to the next column.

fig = plt.figure(figsize=(7, 6))
ax3 = fig.add_subplot(projection="3d")
near = (y_nodes[:, 0] < -SIDE_M / 2 + 4.5 * CELL_M) & (y_nodes[:, 1] < -SIDE_M / 2 + 4.5 * CELL_M)
index = np.flatnonzero(near)
for k, run in enumerate(np.split(index, np.flatnonzero(np.diff(index) > 1) + 1)):
    seg = y_nodes[run]
    ax3.plot(
        seg[:, 0],
        seg[:, 1],
        seg[:, 2],
        "-o",
        ms=3,
        color=f"C{k % 10}",
        label="column 0" if k == 0 else ("connector, then column 1" if k == 1 else None),
    )
ax3.set_xlabel("x [m]")
ax3.set_ylabel("y [m]")
ax3.set_zlabel("z [m]")
ax3.set_title("y-coil, first cells: 3/4 turns and y-steps", fontsize=9)
ax3.legend(fontsize=8)
plt.show()
