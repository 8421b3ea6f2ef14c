"""Plots of a truss run: Euler angles, body rates, libration, surface SD,
strain energy, surface-angle map, cantilever settle.

Every function takes the run's series (``t`` [s] and the keys of
:mod:`magsail_mj.concepts.truss_magnetorquer.metrics`) and the few config values it draws, writes PNG files
atomically (:func:`magsail_mj.plotting.save_figure`) and returns their paths.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from magsail_mj.plotting import new_figure, save_figure

__all__ = ["truss_plots", "cantilever_plot", "save_figure"]


def cantilever_plot(
    run_dir: Path, series: dict[str, np.ndarray], *, title: str, load_N: float, EI_Nm2: float, side_m: float
) -> list[Path]:
    """``tip_deflection.png``: the MuJoCo settle of the tip against the beam value P L³ / (3 EI) [m]."""
    fig, ax = new_figure(figsize=(7, 4))
    ax.plot(series["t"], series["tip_deflection_m"], label="MuJoCo settle")
    ax.axhline(load_N * side_m**3 / (3 * EI_Nm2), color="k", ls="--", label="beam PL³/3EI")
    ax.set(xlabel="t [s]", ylabel="tip deflection [m]", title=title)
    ax.legend()
    return [save_figure(fig, run_dir / "tip_deflection.png")]


def truss_plots(run_dir: Path, series: dict[str, np.ndarray], *, title: str) -> list[Path]:
    """The figures of a dynamic run (``dist_vs_central``, ``free``): ``euler_angles.png`` and
    ``body_rates.png`` (with the rigid-body response when the series has it), ``libration.png``
    (LVLH attitude, orbital runs), ``surface_sd.png`` and ``surface_angle_map.png``."""
    out: list[Path] = []
    if "phi_rad" in series:
        out.extend(_attitude_plots(run_dir, series, title=title))
    if "lvlh_roll_rad" in series:
        out.append(_libration_plot(run_dir, series, title=title))
    out.append(_surface_sd_plot(run_dir, series, title=title))
    if "surface_angle_map_rad" in series:
        out.append(_surface_angle_plot(run_dir, series))
    return out


def _attitude_plots(run_dir: Path, series: dict[str, np.ndarray], *, title: str) -> list[Path]:
    t = series["t"]
    fig, axs = new_figure(3, 1, figsize=(8, 7), sharex=True)
    for ax, key, label in zip(axs, ("psi_rad", "theta_rad", "phi_rad"), ("ψ (z)", "θ (y)", "φ (x)")):
        ax.plot(t, series[key], label=label)
        ax.set_ylabel(f"{label} [rad]")
    if "phi_rigid_rad" in series:
        axs[2].plot(t, series["phi_rigid_rad"], "k--", lw=1, label="rigid body")
        axs[2].legend()
    axs[0].set_title(title + " — ZYX Euler angles")
    axs[-1].set_xlabel("t [s]")
    out = [save_figure(fig, run_dir / "euler_angles.png")]

    fig, ax = new_figure(figsize=(8, 4))
    w = series["omega_body_rad_s"]
    for i in range(3):
        ax.plot(t, w[:, i], label=f"ω{i + 1}")
    if "omega_rigid_rad_s" in series:
        ax.plot(t, series["omega_rigid_rad_s"], "k--", lw=1, label="rigid ω1")
    ax.set(xlabel="t [s]", ylabel="body rate [rad/s]", title=title + " — body rates")
    ax.legend()
    out.append(save_figure(fig, run_dir / "body_rates.png"))
    return out


def _libration_plot(run_dir: Path, series: dict[str, np.ndarray], *, title: str) -> Path:
    t = series["t"]
    fig, axs = new_figure(2, 1, figsize=(8, 6), sharex=True)
    for key, label in (("lvlh_roll_rad", "roll"), ("lvlh_pitch_rad", "pitch"), ("lvlh_yaw_rad", "yaw")):
        axs[0].plot(t, np.degrees(series[key]), label=label)
    axs[0].set(ylabel="attitude in LVLH [deg]", title=title + " — libration")
    axs[0].legend()
    axs[1].plot(t, np.degrees(series["normal_to_orbit_normal_rad"]))
    axs[1].set(xlabel="t [s]", ylabel="plate normal to orbit normal [deg]")
    return save_figure(fig, run_dir / "libration.png")


def _surface_sd_plot(run_dir: Path, series: dict[str, np.ndarray], *, title: str) -> Path:
    t = series["t"]
    fig, axs = new_figure(2, 1, figsize=(8, 6), sharex=True)
    axs[0].plot(t, series["surface_sd_m"])
    axs[0].set(ylabel="surface SD [m]", title=title + " — flatness and strain energy")
    axs[1].plot(t, series["strain_energy_J"])
    axs[1].set(xlabel="t [s]", ylabel="strain energy [J]")
    return save_figure(fig, run_dir / "surface_sd.png")


def _surface_angle_plot(run_dir: Path, series: dict[str, np.ndarray]) -> Path:
    t = series["t"]
    fig, ax = new_figure(figsize=(6, 5))
    alpha = np.degrees(series["surface_angle_map_rad"])
    im = ax.pcolormesh(series["surface_angle_u_m"], series["surface_angle_v_m"], alpha, shading="auto", cmap="viridis")
    fig.colorbar(im, ax=ax, label="local surface angle [deg]")
    k = int(np.nanargmax(series["surface_sd_m"]))
    ax.set(xlabel="u [m]", ylabel="v [m]", aspect="equal", title=f"surface angle at max SD (t = {t[k]:.0f} s)")
    return save_figure(fig, run_dir / "surface_angle_map.png")
