"""
CubeSat slew: PD against eigen-axis control
===========================================

The sail-carrying cubesat turns 108° with its reaction wheels, twice: with a quaternion PD law
(``control.mode = "pd"``) and with the eigen-axis law (``"eigen_axis"``), which limits the rate
to 0.3 °/s and keeps the rotation about the initial eigen-axis. Everything else is equal (gains
``k = 2ω_n²``, ``c = 2ζω_n``, wheel limits, disturbances).

The two runs go through :func:`magsail_mj.load`. **Reduced duration**: 900 s of the 5782 s (one
orbit) of ``magsail_mj/concepts/cnusail/configs/pd_vs_eigenaxis.toml``; the slew itself ends within it. The full runs,
with run folders and a side-by-side video, are made by ``scripts/cnusail_pd_vs_eigenaxis.py``.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import magsail_mj

# the repository root: the nearest folder from here upwards that holds models/ (the docs build
# runs this script in examples/gallery, a reader from the root)
ROOT = next(folder for folder in (Path.cwd(), *Path.cwd().parents) if (folder / "magsail_mj" / "concepts").is_dir())
CONFIG = ROOT / "magsail_mj" / "concepts" / "cnusail" / "configs" / "pd_vs_eigenaxis.toml"
LAWS = {"pd": ("PD", "C1--"), "eigen_axis": ("eigen-axis", "C0-")}

results = {}
for law in LAWS:
    sim = magsail_mj.load(CONFIG, ["sim.duration_s=900", f"control.mode={law}"])
    run = sim.run()
    summary, series = sim.scenario.postprocess(run)
    results[law] = (run.records["t"], series)
    print(
        f"{LAWS[law][0]:10s}: slew time {summary['slew_time_s']:.0f} s, "
        f"max slew rate {summary['max_slew_rate_deg_s']:.3f} °/s, "
        f"max axis deviation {np.degrees(summary['axis_deviation_max_rad']):.1f}°"
    )

# %%
# Error angle, body rate and axis deviation
# -----------------------------------------
# Green band: the 5° pointing window; red dotted line: the 0.3 °/s rate limit of the eigen-axis law.
# The axis deviation is defined while the spacecraft slews (the series ends when the slew does).

fig, axes = plt.subplots(3, 1, figsize=(7, 7.5), sharex=True)
for law, (label, style) in LAWS.items():
    t_s, series = results[law]
    minutes = np.asarray(t_s) / 60.0
    axes[0].plot(minutes, series["theta_e_deg"], style, label=label)
    axes[1].plot(minutes, series["omega_norm_deg_s"], style, label=label)
    axes[2].plot(minutes, series["axis_deviation_deg"], style, label=label)
axes[0].axhspan(0.0, 5.0, color="g", alpha=0.15, label="within 5°")
axes[1].axhline(0.3, color="r", ls=":", lw=0.8, label="0.3 °/s limit")
axes[0].set_ylabel("error angle θ_e [deg]")
axes[1].set_ylabel("body rate |ω| [°/s]")
axes[2].set_ylabel("rotation axis vs initial\neigen-axis [deg] (while slewing)")
axes[2].set_xlabel("time [min]")
for ax in axes:
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
axes[0].set_title("CNUSAIL 108° slew (900 s of the one-orbit run)", fontsize=10)
plt.show()
