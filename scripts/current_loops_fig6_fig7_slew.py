"""Slew outputs of the 90° slew (Robb et al. 2022b, Figs. 6–7): flexible run against its rigid-body surrogate.

    magsail run magsail_mj/concepts/current_loops/configs/slew.toml --out runs/current_loops/slew --video
    magsail run magsail_mj/concepts/current_loops/configs/slew_rigid.toml --out runs/current_loops/slew_rigid
    python scripts/current_loops_fig6_fig7_slew.py

Writes into the flexible run folder ``fig6_attitude_vs_rigid.png`` (attitude error of both on a
log axis, with the 5° and 2° lines), ``fig7_torques_strain.png`` (magnetic and gravity-gradient
torque about the CM, strain energy and normalised modal amplitudes) and prints the key figures
of both ``summary.json`` files side by side.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import matplotlib.pyplot as plt

from magsail_mj.records import STORE_NAME, lazy_arrays

KEYS = (
    "time_to_target_s",
    "t_err_below_2deg_s",
    "attitude_error_max_after_target_deg",
    "t_err_max_after_settle_s",
    "err_final_rad",
    "saturation_fraction",
    "mag_torque_max_Nm",
    "gg_torque_max_Nm",
    "strain_energy_max_J",
    "time_strain_max_s",
)
SERIES = ("t", "error_angle_deg", "mag_torque_world_Nm", "gg_torque_world_Nm", "strain_energy_J", "modal_amplitude")


def read_series(run_dir: Path, names: tuple[str, ...] = SERIES) -> dict[str, np.ndarray]:
    """The named records/series of a run folder's ``timeseries.zarr`` that it holds, as NumPy arrays
    (only these are read: a long lattice run's ``qpos`` stays on disk)."""
    arrays = lazy_arrays(run_dir)
    return {name: arrays[name][...] for name in names if name in arrays}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--flex", default="runs/current_loops/slew")
    ap.add_argument("--rigid", default="runs/current_loops/slew_rigid")
    args = ap.parse_args(argv)
    flex, rigid = Path(args.flex), Path(args.rigid)

    zf = read_series(flex)
    zr = read_series(rigid) if (rigid / STORE_NAME).is_dir() else None
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.semilogy(zf["t"], np.maximum(zf["error_angle_deg"], 1e-3), "k", label="flexible lattice (N = 19)")
    if zr is not None:
        ax.semilogy(zr["t"], np.maximum(zr["error_angle_deg"], 1e-3), "r--", label="rigid surrogate")
    for lvl in (5.0, 2.0):
        ax.axhline(lvl, c="grey", ls=":")
    ax.set(xlabel="t [s]", ylabel="attitude error [deg]", title="90° slew about inertial y")
    ax.legend()
    fig.tight_layout()
    fig.savefig(flex / "fig6_attitude_vs_rigid.png", dpi=120)
    plt.close(fig)

    fig, axs = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    axs[0].plot(zf["t"], np.linalg.norm(zf["mag_torque_world_Nm"], axis=1), "b", lw=0.7, label="actuation")
    axs[0].plot(zf["t"], np.linalg.norm(zf["gg_torque_world_Nm"], axis=1), "r", lw=0.7, label="gravity gradient")
    axs[0].set_ylabel("|torque| [N m]")
    axs[0].legend(fontsize=8)
    axs[1].plot(zf["t"], zf["strain_energy_J"], "k", lw=0.8)
    axs[1].set_ylabel("U [J]")
    if "modal_amplitude" in zf:
        q = zf["modal_amplitude"]
        for n in range(q.shape[1]):
            axs[2].plot(zf["t"], q[:, n], lw=0.6, label=f"{n + 1}")
        axs[2].legend(fontsize=6, ncol=5, title="elastic mode", title_fontsize=7)
    axs[2].set(xlabel="t [s]", ylabel="q̂_n")
    fig.tight_layout()
    fig.savefig(flex / "fig7_torques_strain.png", dpi=120)
    plt.close(fig)

    sf = json.loads((flex / "summary.json").read_text())
    sr = json.loads((rigid / "summary.json").read_text()) if (rigid / "summary.json").exists() else {}
    print(f"{'key':40s} {'flexible':>14s} {'rigid':>14s}")
    for k in KEYS:
        print(f"{k:40s} {str(sf.get(k)):>14.14s} {str(sr.get(k, '–')):>14.14s}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
