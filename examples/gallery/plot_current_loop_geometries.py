"""
Current-loop geometries on the truss lattice
============================================

The current-loop spacecraft carries its actuators in its structure: circuits of lattice struts
that carry a current. A closed circuit of vector area ``a`` [m²] with current ``I`` [A] has the
dipole ``m = I a`` [A·m²], with ``a = ½ Σ r_a × r_b`` over its directed struts ``a → b``. The
geometries of the paper: **A** one perimeter loop on the top layer; **B** concentric rings,
alternately on the top and bottom layer; **C_x / C_y** one D × w loop in every lattice plane
normal to x / y, all in series; **D_x / D_y** one continuous winding of 3/4 turns per lattice
plane with a unit step to the next.

This example builds a 6 × 6 unit lattice of side 250 m (:func:`magsail_mj.lattice.geometry.make_lattice`)
and its circuits (:func:`magsail_mj.geometry.current_loops.circuits`), prints each circuit's vector
area in units of D² and its wire length in units of D, and draws four of them; the depth is drawn
3 times its size so that the loops through it can be seen.
"""

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.lines import Line2D
from mpl_toolkits.mplot3d.art3d import Line3DCollection

from magsail_mj.geometry.current_loops import circuits
from magsail_mj.lattice.geometry import make_lattice

UNITS, SIDE_M, Z_SCALE = 6, 250.0, 3.0
AXIS_COLOURS = ("tab:red", "tab:green", "tab:blue")
AXIS_LABELS = ("dipole along x", "dipole along y", "dipole along z")

lattice = make_lattice(units=UNITS, side_m=SIDE_M)
for circuit in circuits(lattice, ["A", "B", "C_x", "C_y", "D_x", "D_y"]):
    area_D2 = np.round(circuit.vector_area(lattice.nodes) / SIDE_M**2, 4) + 0.0  # no '-0.0000'
    print(
        f"{circuit.name:4s} vector area = ({area_D2[0]:+.4f}, {area_D2[1]:+.4f}, {area_D2[2]:+.4f}) D², "
        f"wire length = {circuit.length(lattice.nodes) / SIDE_M:.3f} D"
    )

# %%
# Four geometries
# ---------------
# Grey: the lattice struts. Arrows: the circuit's struts along the positive current, coloured by
# the circuit's dipole axis; struts used twice are drawn thicker.

scaled = lattice.nodes * np.array([1.0, 1.0, Z_SCALE])
fig = plt.figure(figsize=(10, 8))
for k, name in enumerate(["A", "B", "C_y", "D_y"]):
    ax = fig.add_subplot(2, 2, k + 1, projection="3d")
    ax.add_collection3d(Line3DCollection(scaled[lattice.struts], colors="0.82", linewidths=0.3))
    for circuit in circuits(lattice, [name]):
        start, delta = scaled[circuit.src], scaled[circuit.dst] - scaled[circuit.src]
        widths = np.where(circuit.mult > 1, 2.4, 1.2)
        for width in np.unique(widths):
            sel = widths == width
            ax.quiver(
                *start[sel].T, *delta[sel].T, color=AXIS_COLOURS[circuit.axis], linewidths=width, arrow_length_ratio=0.3
            )
    ax.set_xlim(-SIDE_M / 2, SIDE_M / 2)
    ax.set_ylim(-SIDE_M / 2, SIDE_M / 2)
    ax.set_zlim(scaled[:, 2].min() * 1.3, scaled[:, 2].max() * 1.3)
    ax.set_box_aspect((1.0, 1.0, 0.3))
    ax.view_init(elev=28, azim=-58)
    ax.set_xlabel("x [m]", fontsize=7)
    ax.set_ylabel("y [m]", fontsize=7)
    ax.set_zlabel(f"z [m] (×{Z_SCALE:g})", fontsize=7)
    ax.tick_params(labelsize=6)
    ax.set_title(f"geometry {name}", fontsize=9)
axes_drawn = sorted({c.axis for name in ["A", "B", "C_y", "D_y"] for c in circuits(lattice, [name])})
handles = [Line2D([], [], color=AXIS_COLOURS[k], lw=2, label=AXIS_LABELS[k]) for k in axes_drawn]
handles.append(Line2D([], [], color="0.75", lw=1, label="lattice struts"))
fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=8)
fig.suptitle(f"current-loop geometries, N = {UNITS} units, D = {SIDE_M:g} m", fontsize=10)
plt.show()
