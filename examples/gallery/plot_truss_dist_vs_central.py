"""
Distributed against central torque on a flexible truss
======================================================

The same body torque, a bang-bang profile of ±0.1 N·m about the x axis, is applied to a flexible
square truss in two ways: by one actuator on the central cube (*central*) or spread as force
pairs over every top-layer strut (*distributed*). The surface deviation ``σ_d`` [m] is the RMS
distance of the top-layer nodes from their best-fit plane; the central torque bends the plate
far more.

Both runs go through :func:`magsail_mj.load` with ``--set``-style overrides. **Reduced size**:
the paper's Case C is a 19 × 19 unit lattice of 100 m for 1800 s; here 7 × 7 units for 300 s
(the bang-bang profile compressed to 300 s), so that the example runs in seconds. The full-size
runs are ``magsail sweep models/sweeps/truss_dist_vs_central.toml`` (see the truss concept page).
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import magsail_mj

# the repository root: the nearest folder from here upwards that holds models/ (the docs build
# runs this script in examples/gallery, a reader from the root)
ROOT = next(folder for folder in (Path.cwd(), *Path.cwd().parents) if (folder / "magsail_mj" / "concepts").is_dir())
CASES = ROOT / "magsail_mj" / "concepts" / "truss_magnetorquer" / "configs" / "dist_vs_central"
REDUCED = ["lattice.units=7", "sim.duration_s=300", "profile.t_end_s=300"]

results = {}
for placement in ("central", "distributed"):
    sim = magsail_mj.load(CASES / f"case_c_{placement}_bangbang.toml", REDUCED)
    run = sim.run()
    summary, series = sim.scenario.postprocess(run)
    results[placement] = (run.records["t"], series)
    print(
        f"{placement:11s}: status {summary['status']}, max surface deviation "
        f"{summary['surface_sd_max_m']:.3f} m at t = {summary['t_surface_sd_max_s']:.0f} s"
    )

# %%
# Surface deviation and rotation angle
# ------------------------------------

fig, (ax_sd, ax_phi) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
for placement, style in (("central", "C3-"), ("distributed", "C0-")):
    t_s, series = results[placement]
    ax_sd.plot(t_s, series["surface_sd_m"], style, label=placement)
    ax_phi.plot(t_s, np.degrees(series["phi_rad"]), style, label=placement)
ax_sd.set_ylabel("surface deviation σ_d [m]")
ax_phi.set_ylabel("rotation about x, φ [deg]")
ax_phi.set_xlabel("time [s]")
for ax in (ax_sd, ax_phi):
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
ax_sd.set_title("truss Case C, reduced to 7 × 7 units, 300 s: same torque, central vs distributed", fontsize=10)
plt.show()
