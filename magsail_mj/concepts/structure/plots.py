"""Plots of a ``structure`` run: body rates, shape deviation, strain and energy, angular momentum,
the actuators' torques, the loops' currents and, for a slew, the attitude error.

Every function takes the run's series (``t`` [s] and the keys of
:mod:`magsail_mj.concepts.structure.metrics`) and records, writes PNG files atomically
(:func:`magsail_mj.plotting.save_figure`) and returns their paths.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from magsail_mj.plotting import new_figure, save_figure

__all__ = ["structure_plots", "rod_plots", "slew_plot"]

_COLOURS = ("C0", "C1", "C2")


def structure_plots(run_dir: Path, series: dict[str, np.ndarray], records: Any, *, title: str) -> list[Path]:
    """``body_rates.png`` (best-fit body rates and ``|ω|``), ``shape.png`` (RMS and largest node
    deviation from the best-fit reference shape), ``strain.png`` (largest member strain and the
    springs' strain energy) and ``angular_momentum.png`` (``|H|`` about the centre of mass)."""
    t = np.asarray(series["t"], dtype=float)
    out = []
    fig, axs = new_figure(2, 1, figsize=(8, 6), sharex=True)
    w = series["omega_body_rad_s"]
    for i, c in enumerate(_COLOURS):
        axs[0].plot(t, w[:, i], color=c, lw=0.8, label=f"ω{'xyz'[i]}")
    axs[0].set(ylabel="body rate [rad/s]", title=f"{title} — best-fit body rates")
    axs[0].legend(ncol=3)
    axs[1].semilogy(t, np.maximum(series["omega_norm_rad_s"], 1e-12), "k", lw=0.8, label="|ω|")
    axs[1].set(xlabel="t [s]", ylabel="|ω| [rad/s]")
    axs[1].legend()
    out.append(save_figure(fig, run_dir / "body_rates.png"))

    fig, ax = new_figure(figsize=(8, 4))
    ax.plot(t, np.asarray(records["shape_rms_m"]), "C0", label="RMS node deviation")
    ax.plot(t, np.asarray(records["shape_max_m"]), "C3", label="largest node deviation")
    ax.set(xlabel="t [s]", ylabel="deviation [m]", title=f"{title} — deviation from the best-fit reference shape")
    ax.legend()
    out.append(save_figure(fig, run_dir / "shape.png"))

    fig, axs = new_figure(2, 1, figsize=(8, 6), sharex=True)
    axs[0].plot(t, np.asarray(records["member_strain_max"]), "C2", label="largest |strain|")
    axs[0].set(ylabel="strain [–]", title=f"{title} — members")
    axs[0].legend()
    axs[1].plot(t, np.asarray(records["strain_energy_J"]), "C4", label="strain energy")
    axs[1].set(xlabel="t [s]", ylabel="energy [J]")
    axs[1].legend()
    out.append(save_figure(fig, run_dir / "strain.png"))

    fig, ax = new_figure(figsize=(8, 4))
    ax.plot(t, series["angmom_norm_Nms"], "k", label="|H| about the centre of mass")
    ax.set(xlabel="t [s]", ylabel="|H| [N m s]", title=f"{title} — angular momentum")
    ax.legend()
    out.append(save_figure(fig, run_dir / "angular_momentum.png"))
    return out


def rod_plots(run_dir: Path, series: dict[str, np.ndarray], records: Any, *, title: str) -> list[Path]:
    """``torques.png``: the law's reference torque and the torque of the allocated dipole (body
    axes) and the allocated dipole's size; with current loops, ``loop_currents.png``: each loop's
    current."""
    t = np.asarray(series["t"], dtype=float)
    T_ref = np.asarray(records["torque_ref_body_Nm"], dtype=float)
    T_alloc = np.asarray(records["torque_alloc_body_Nm"], dtype=float)
    fig, axs = new_figure(2, 1, figsize=(8, 6), sharex=True)
    for i, c in enumerate(_COLOURS):
        axs[0].plot(t, T_alloc[:, i], color=c, lw=0.8, label=f"allocated {'xyz'[i]}")
        axs[0].plot(t, T_ref[:, i], color=c, ls=":", lw=0.8, label=f"reference {'xyz'[i]}")
    lim = 1.2 * max(float(np.max(np.abs(T_alloc))), 1e-12)
    axs[0].set(ylabel="torque, body axes [N m]", ylim=(-lim, lim), title=f"{title} — actuator torques")
    axs[0].legend(ncol=3, fontsize=7)
    axs[1].plot(t, np.linalg.norm(np.asarray(records["dipole_body_Am2"], dtype=float), axis=1), "k", label="|m|")
    axs[1].set(xlabel="t [s]", ylabel="allocated dipole [A m²]")
    axs[1].legend()
    out = [save_figure(fig, run_dir / "torques.png")]
    if "loop_currents_A" in records:
        current = np.asarray(records["loop_currents_A"], dtype=float)
        fig, ax = new_figure(figsize=(8, 4))
        for k in range(current.shape[1]):
            ax.plot(t, current[:, k], lw=0.8, label=f"loop {k}")
        ax.set(xlabel="t [s]", ylabel="current [A]", title=f"{title} — loop currents")
        ax.legend()
        out.append(save_figure(fig, run_dir / "loop_currents.png"))
    return out


def slew_plot(run_dir: Path, series: dict[str, np.ndarray], *, title: str) -> list[Path]:
    """``attitude_error.png``: the slew's error angle (log scale) with the 5° and 2° lines."""
    t = np.asarray(series["t"], dtype=float)
    fig, ax = new_figure(figsize=(8, 4))
    ax.semilogy(t, np.maximum(series["error_angle_deg"], 1e-6), "C3", label="error angle")
    for level, style in ((5.0, "--"), (2.0, ":")):
        ax.axhline(level, color="k", ls=style, lw=0.8, label=f"{level:g}°")
    ax.set(xlabel="t [s]", ylabel="error [deg]", title=f"{title} — attitude error")
    ax.legend()
    return [save_figure(fig, run_dir / "attitude_error.png")]
