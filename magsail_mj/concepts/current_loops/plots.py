"""Plots of the current-loops runs ("Outputs per run", "Outputs").

Every function takes the run's series (``t`` [s] and the keys of
:mod:`magsail_mj.concepts.current_loops.metrics`) and the lattice and circuits it draws, writes
PNG files atomically (:func:`magsail_mj.plotting.save_figure`) and returns their paths.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from mpl_toolkits.mplot3d.art3d import Line3DCollection

from magsail_mj.estimation.attitude import BestFitRotation
from magsail_mj.geometry.current_loops import Circuit
from magsail_mj.lattice.geometry import Lattice
from magsail_mj.plotting import new_figure, save_figure

__all__ = ["structural_plots", "sweep_plots", "slew_plots", "snapshot_figure", "LOOP_COLOURS"]

LOOP_COLOURS = {0: "tab:red", 1: "tab:green", 2: "tab:blue"}
"""x-loops red (our choice), y-loops green and z-loops blue (the paper's colours)."""


def _save(fig, path: Path) -> Path:
    """Lay the panels out tightly and save (:func:`~magsail_mj.plotting.save_figure`)."""
    fig.tight_layout()
    return save_figure(fig, path)


def snapshot_figure(
    lattice: Lattice, circuits: list[Circuit], x: np.ndarray, path: Path, *, title: str, magnify: float | None = None
) -> Path:
    """Body-frame snapshot of node positions ``x`` (n, 3) [m]: struts black, loops coloured, the
    displacement from the best-fit rigid shape magnified (default: to 5 % of the side)."""
    lat = lattice
    p0 = lat.nodes - lat.nodes.mean(axis=0)
    R, _ = BestFitRotation(lat.nodes)(x)
    xb = (x - x.mean(axis=0)) @ R
    u = xb - p0
    umax = np.abs(u).max()
    if magnify is None:
        magnify = 0.05 * lat.side_m / umax if umax > 0 else 1.0
        magnify = max(1.0, magnify)
    y = p0 + magnify * u
    fig, ax = new_figure(figsize=(8, 6.5), subplot_kw={"projection": "3d"})
    segs = y[lat.struts]
    ax.add_collection3d(Line3DCollection(segs, colors="k", linewidths=0.25, alpha=0.5))
    for c in circuits:
        s = y[np.stack([c.src, c.dst], axis=1)]
        ax.add_collection3d(Line3DCollection(s, colors=LOOP_COLOURS[int(c.axis)], linewidths=1.6))
    h = lat.side_m / 2
    ax.set(xlim=(-h, h), ylim=(-h, h), zlim=(-h, h), xlabel="x_b [m]", ylabel="y_b [m]", zlabel="z_b [m]")
    ax.set_title(f"{title}\n(displacement from the best-fit rigid shape ×{magnify:.3g})", fontsize=9)
    ax.view_init(elev=25, azim=-60)
    return _save(fig, path)


def structural_plots(
    run_dir: Path,
    series: dict[str, np.ndarray],
    *,
    lattice: Lattice,
    circuits: list[Circuit],
    snapshot_x: np.ndarray | None = None,
    snapshot_title: str = "",
) -> list[Path]:
    """Flexible runs: ``strain_energy.png``, ``deformation.png`` (thickness, rigid-fit residual,
    largest strut strain), ``modal_amplitudes.png`` and, given the node positions ``snapshot_x``
    (n, 3) [m] at the time of maximum strain energy, ``snapshot_max_strain.png``."""
    run_dir = Path(run_dir)
    t = series["t"]
    out: list[Path] = []
    fig, ax = new_figure(figsize=(7, 3.5))
    ax.plot(t, series["strain_energy_J"], "k")
    ax.set(xlabel="t [s]", ylabel="U [J]", title="strain energy")
    out.append(_save(fig, run_dir / "strain_energy.png"))
    fig, axs = new_figure(3, 1, figsize=(7, 7), sharex=True)
    axs[0].plot(t, series["thickness_m"])
    axs[0].set_ylabel("thickness h [m]")
    axs[1].plot(t, series["rigid_fit_residual_m"])
    axs[1].set_ylabel("rigid-fit residual ρ [m]")
    axs[2].plot(t, series["strut_strain_max"])
    axs[2].set(ylabel="max strut strain", xlabel="t [s]")
    out.append(_save(fig, run_dir / "deformation.png"))
    if "modal_amplitude" in series:
        fig, ax = new_figure(figsize=(7, 3.5))
        q = series["modal_amplitude"]
        for n in range(q.shape[1]):
            ax.plot(t, q[:, n], lw=0.8, label=f"mode {n + 1}")
        ax.set(xlabel="t [s]", ylabel="q̂_n", title="normalised modal amplitudes (first elastic modes)")
        ax.legend(fontsize=6, ncol=5)
        out.append(_save(fig, run_dir / "modal_amplitudes.png"))
    if snapshot_x is not None:
        out.append(
            snapshot_figure(lattice, circuits, snapshot_x, run_dir / "snapshot_max_strain.png", title=snapshot_title)
        )
    return out


def sweep_plots(run_dir: Path, series: dict[str, np.ndarray]) -> list[Path]:
    """Sweep runs: ``rotation.png`` (flexible and rigid rotation angle, dipole–field angle) and
    ``energy_balance.png`` (Lorentz work, damping dissipation, residual)."""
    run_dir = Path(run_dir)
    t = series["t"]
    out: list[Path] = []
    fig, axs = new_figure(2, 1, figsize=(7, 5.5), sharex=True)
    axs[0].plot(t, np.degrees(series["rotation_angle_rad"]), "k", label="flexible (best fit)")
    axs[0].plot(t, np.degrees(series["rigid_rotation_angle_rad"]), "r--", label="rigid reference")
    axs[0].set_ylabel("rotation angle [deg]")
    axs[0].legend(fontsize=8)
    axs[1].plot(t, np.degrees(series["dipole_field_angle_rad"]))
    axs[1].set(xlabel="t [s]", ylabel="dipole–field angle [deg]")
    out.append(_save(fig, run_dir / "rotation.png"))
    fig, ax = new_figure(figsize=(7, 3.5))
    ax.plot(t, series["lorentz_work_J"], label="Lorentz work")
    ax.plot(t, -series["damping_work_J"], label="damping dissipation")
    ax.plot(t, series["energy_residual_J"], label="E_kin + U − W (residual)")
    ax.set(xlabel="t [s]", ylabel="energy [J]", title="energy balance")
    ax.legend(fontsize=8)
    out.append(_save(fig, run_dir / "energy_balance.png"))
    return out


def slew_plots(run_dir: Path, series: dict[str, np.ndarray]) -> list[Path]:
    """Slews: ``attitude.png`` (error, ZYX Euler angles), ``rates.png``, ``currents.png`` (dots:
    saturated), ``dipole.png`` (commanded and achieved) and ``torques.png`` (magnetic and
    gravity-gradient torque about the centre of mass)."""
    run_dir = Path(run_dir)
    t = series["t"]
    out = []
    fig, axs = new_figure(2, 1, figsize=(7, 6), sharex=True)
    axs[0].semilogy(t, np.maximum(series["error_angle_deg"], 1e-3), "k", label="attitude error")
    for lvl in (5, 2):
        axs[0].axhline(lvl, ls=":", c="grey", label="5° and 2° levels" if lvl == 5 else None)
    axs[0].set_ylabel("attitude error [deg]")
    axs[0].legend(fontsize=8)
    if "euler_zyx_rad" in series:
        e = np.unwrap(series["euler_zyx_rad"], axis=0)
        for k, lab in enumerate(("ψ (z)", "θ (y)", "φ (x)")):
            axs[1].plot(t, np.degrees(e[:, k]), label=lab)
        axs[1].legend(fontsize=8)
    axs[1].set(xlabel="t [s]", ylabel="Euler ZYX [deg]")
    out.append(_save(fig, run_dir / "attitude.png"))
    fig, ax = new_figure(figsize=(7, 3.5))
    for k, lab in enumerate("xyz"):
        ax.plot(t, series["omega_body_rad_s"][:, k], label=f"ω_{lab}")
    ax.set(xlabel="t [s]", ylabel="ω body [rad/s]", title="body rates")
    ax.legend(fontsize=8)
    out.append(_save(fig, run_dir / "rates.png"))
    fig, axs = new_figure(3, 1, figsize=(7, 7), sharex=True)
    cur = series["currents_axis_A"]
    sat = series["saturated"].astype(bool)
    for k, lab in enumerate("xyz"):
        axs[k].plot(t, cur[:, k], c=LOOP_COLOURS[k], label=f"{lab}-loop current")
        axs[k].plot(t[sat[:, k]], cur[sat[:, k], k], "k.", ms=1.5, label="saturated")
        axs[k].set_ylabel(f"I_{lab} [A]")
        axs[k].legend(fontsize=8, markerscale=4)
    axs[2].set_xlabel("t [s]")
    out.append(_save(fig, run_dir / "currents.png"))
    fig, axs = new_figure(3, 1, figsize=(7, 7), sharex=True)
    for k, lab in enumerate("xyz"):
        axs[k].plot(t, series["dipole_cmd_body_Am2"][:, k], "k:", lw=0.8, label="commanded")
        axs[k].plot(t, series["dipole_achieved_body_Am2"][:, k], c=LOOP_COLOURS[k], label="achieved")
        axs[k].set_ylabel(f"m_{lab} [A m²]")
    axs[0].legend(fontsize=8)
    axs[2].set_xlabel("t [s]")
    out.append(_save(fig, run_dir / "dipole.png"))
    fig, ax = new_figure(figsize=(7, 3.5))
    ax.plot(t, np.linalg.norm(series["mag_torque_world_Nm"], axis=1), "b", lw=0.8, label="actuation (magnetic)")
    ax.plot(t, np.linalg.norm(series["gg_torque_world_Nm"], axis=1), "r", lw=0.8, label="gravity gradient")
    ax.set(xlabel="t [s]", ylabel="|torque| about CM [N m]")
    ax.legend(fontsize=8)
    out.append(_save(fig, run_dir / "torques.png"))
    return out
