"""Plots of a truss run (spec §6.6): Euler angles, body rates, surface SD, energy, angle map."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from magsail_mj.io import atomic_path

if TYPE_CHECKING:
    from magsail_mj.scenarios.truss import TrussScenario

__all__ = ["truss_plots", "save_figure"]


def save_figure(fig, path: Path) -> Path:
    """Save a matplotlib figure atomically as PNG and close it."""
    import matplotlib.pyplot as plt

    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=120, bbox_inches="tight", format="png")
    plt.close(fig)
    return path


def truss_plots(sc: "TrussScenario", run_dir: Path, series: dict[str, np.ndarray]) -> list[Path]:
    """Write the run's PNG figures into ``run_dir`` and return their paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = series["t"]
    out: list[Path] = []
    title = f"{sc.cfg.scenario}: {sc.cfg.description}".strip(": ")
    if "tip_deflection_m" in series:
        fig, ax = plt.subplots(figsize=(7, 4))
        ax.plot(t, series["tip_deflection_m"], label="MuJoCo settle")
        P, EI, L = sc.cfg.cantilever.load_N, sc.cfg.stiffness.EI_Nm2, sc.cfg.lattice.side_m
        ax.axhline(P * L**3 / (3 * EI), color="k", ls="--", label="beam PL³/3EI")
        ax.set(xlabel="t [s]", ylabel="tip deflection [m]", title=title)
        ax.legend()
        return [save_figure(fig, run_dir / "tip_deflection.png")]

    if "phi_rad" in series:
        fig, axs = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
        for ax, key, label in zip(axs, ("psi_rad", "theta_rad", "phi_rad"), ("ψ (z)", "θ (y)", "φ (x)")):
            ax.plot(t, series[key], label=label)
            ax.set_ylabel(f"{label} [rad]")
        if "phi_rigid_rad" in series:
            axs[2].plot(t, series["phi_rigid_rad"], "k--", lw=1, label="rigid body")
            axs[2].legend()
        axs[0].set_title(title + " — ZYX Euler angles")
        axs[-1].set_xlabel("t [s]")
        out.append(save_figure(fig, run_dir / "euler_angles.png"))

        fig, ax = plt.subplots(figsize=(8, 4))
        w = series["omega_body_rad_s"]
        for i in range(3):
            ax.plot(t, w[:, i], label=f"ω{i + 1}")
        if "omega_rigid_rad_s" in series:
            ax.plot(t, series["omega_rigid_rad_s"], "k--", lw=1, label="rigid ω1")
        ax.set(xlabel="t [s]", ylabel="body rate [rad/s]", title=title + " — body rates")
        ax.legend()
        out.append(save_figure(fig, run_dir / "body_rates.png"))

    if "lvlh_roll_rad" in series:
        fig, axs = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
        for key, label in (("lvlh_roll_rad", "roll"), ("lvlh_pitch_rad", "pitch"), ("lvlh_yaw_rad", "yaw")):
            axs[0].plot(t, np.degrees(series[key]), label=label)
        axs[0].set(ylabel="attitude in LVLH [deg]", title=title + " — libration")
        axs[0].legend()
        axs[1].plot(t, np.degrees(series["normal_to_orbit_normal_rad"]))
        axs[1].set(xlabel="t [s]", ylabel="plate normal to orbit normal [deg]")
        out.append(save_figure(fig, run_dir / "libration.png"))

    fig, axs = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    axs[0].plot(t, series["surface_sd_m"])
    axs[0].set(ylabel="surface SD [m]", title=title + " — flatness and strain energy")
    axs[1].plot(t, series["strain_energy_J"])
    axs[1].set(xlabel="t [s]", ylabel="strain energy [J]")
    out.append(save_figure(fig, run_dir / "surface_sd.png"))

    if "surface_angle_map_rad" in series:
        fig, ax = plt.subplots(figsize=(6, 5))
        alpha = np.degrees(series["surface_angle_map_rad"])
        im = ax.pcolormesh(series["surface_angle_u_m"], series["surface_angle_v_m"], alpha, shading="auto",
                           cmap="viridis")
        fig.colorbar(im, ax=ax, label="local surface angle [deg]")
        k = int(np.nanargmax(series["surface_sd_m"]))
        ax.set(xlabel="u [m]", ylabel="v [m]", aspect="equal",
               title=f"surface angle at max SD (t = {t[k]:.0f} s)")
        out.append(save_figure(fig, run_dir / "surface_angle_map.png"))
    return out
