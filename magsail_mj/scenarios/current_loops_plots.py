"""Plots of the current-loops runs (spec §5 "Outputs per run", §6 "Outputs")."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["loops_plots", "snapshot_figure", "LOOP_COLOURS"]

LOOP_COLOURS = {0: "tab:red", 1: "tab:green", 2: "tab:blue"}
"""x-loops red (our choice), y-loops green and z-loops blue (the paper's colours), spec §2.6."""


def _fig(nrows: int = 1, ncols: int = 1, **kw):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.subplots(nrows, ncols, **kw)


def _save(fig, path: Path) -> Path:
    import matplotlib.pyplot as plt

    from magsail_mj.io import atomic_path

    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
    return path


def snapshot_figure(sc, x: np.ndarray, path: Path, *, title: str, magnify: float | None = None) -> Path:
    """Body-frame snapshot of node positions ``x`` (n, 3): struts black, loops coloured, the
    displacement from the best-fit rigid shape magnified (default: to 5 % of the side)."""
    from magsail_mj.estimation.attitude import BestFitRotation

    lat = sc.lm.lattice
    p0 = lat.nodes - lat.nodes.mean(axis=0)
    R, _ = BestFitRotation(lat.nodes)(x)
    xb = (x - x.mean(axis=0)) @ R
    u = xb - p0
    umax = np.abs(u).max()
    if magnify is None:
        magnify = 0.05 * lat.side_m / umax if umax > 0 else 1.0
        magnify = max(1.0, magnify)
    y = p0 + magnify * u
    fig = _fig(figsize=(8, 6.5), subplot_kw={"projection": "3d"})[0]
    ax = fig.axes[0]
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    segs = y[lat.struts]
    ax.add_collection3d(Line3DCollection(segs, colors="k", linewidths=0.25, alpha=0.5))
    for c in sc.lm.circuits:
        s = y[np.stack([c.src, c.dst], axis=1)]
        ax.add_collection3d(Line3DCollection(s, colors=LOOP_COLOURS[int(c.axis)], linewidths=1.6))
    h = lat.side_m / 2
    ax.set(xlim=(-h, h), ylim=(-h, h), zlim=(-h, h), xlabel="x_b [m]", ylabel="y_b [m]", zlabel="z_b [m]")
    ax.set_title(f"{title}\n(displacement from the best-fit rigid shape ×{magnify:.3g})", fontsize=9)
    ax.view_init(elev=25, azim=-60)
    return _save(fig, path)


def loops_plots(sc, run_dir: Path, series: dict[str, np.ndarray], qpos: np.ndarray | None = None) -> list[Path]:
    run_dir = Path(run_dir)
    t = series["t"]
    out: list[Path] = []
    if "strain_energy_J" in series:
        fig, ax = _fig(figsize=(7, 3.5))
        ax.plot(t, series["strain_energy_J"], "k")
        ax.set(xlabel="t [s]", ylabel="U [J]", title="strain energy")
        out.append(_save(fig, run_dir / "strain_energy.png"))
        fig, axs = _fig(3, 1, figsize=(7, 7), sharex=True)
        axs[0].plot(t, series["thickness_m"])
        axs[0].set_ylabel("thickness h [m]")
        axs[1].plot(t, series["rigid_fit_residual_m"])
        axs[1].set_ylabel("rigid-fit residual ρ [m]")
        axs[2].plot(t, series["strut_strain_max"])
        axs[2].set(ylabel="max strut strain", xlabel="t [s]")
        out.append(_save(fig, run_dir / "deformation.png"))
        if "modal_amplitude" in series:
            fig, ax = _fig(figsize=(7, 3.5))
            q = series["modal_amplitude"]
            for n in range(q.shape[1]):
                ax.plot(t, q[:, n], lw=0.8, label=f"mode {n + 1}")
            ax.set(xlabel="t [s]", ylabel="q̂_n", title="normalised modal amplitudes (first elastic modes)")
            ax.legend(fontsize=6, ncol=5)
            out.append(_save(fig, run_dir / "modal_amplitudes.png"))
        if "snapshot_index" in series and qpos is not None:
            from magsail_mj.mjcf.truss import node_positions_from_qpos

            i = int(series["snapshot_index"])
            x = node_positions_from_qpos(sc.model, qpos[i], n_nodes=sc.lm.lattice.n_nodes)
            out.append(snapshot_figure(sc, x, run_dir / "snapshot_max_strain.png",
                                       title=f"{sc.cfg.description or sc.cfg.scenario}: max strain energy "
                                             f"at t = {t[i]:.0f} s"))
    if sc.cfg.scenario == "sweep":
        fig, axs = _fig(2, 1, figsize=(7, 5.5), sharex=True)
        axs[0].plot(t, np.degrees(series["rotation_angle_rad"]), "k", label="flexible (best fit)")
        axs[0].plot(t, np.degrees(series["rigid_rotation_angle_rad"]), "r--", label="rigid reference")
        axs[0].set_ylabel("rotation angle [deg]")
        axs[0].legend(fontsize=8)
        axs[1].plot(t, np.degrees(series["dipole_field_angle_rad"]))
        axs[1].set(xlabel="t [s]", ylabel="dipole–field angle [deg]")
        out.append(_save(fig, run_dir / "rotation.png"))
        fig, ax = _fig(figsize=(7, 3.5))
        ax.plot(t, series["lorentz_work_J"], label="Lorentz work")
        ax.plot(t, -series["damping_work_J"], label="damping dissipation")
        ax.plot(t, series["energy_residual_J"], label="E_kin + U − W (residual)")
        ax.set(xlabel="t [s]", ylabel="[J]", title="energy balance")
        ax.legend(fontsize=8)
        out.append(_save(fig, run_dir / "energy_balance.png"))
    else:
        out.extend(_slew_plots(sc, run_dir, series))
    return out


def _slew_plots(sc, run_dir: Path, series: dict[str, np.ndarray]) -> list[Path]:
    t = series["t"]
    out = []
    fig, axs = _fig(2, 1, figsize=(7, 6), sharex=True)
    axs[0].semilogy(t, np.maximum(series["error_angle_deg"], 1e-3), "k")
    for lvl in (5, 2):
        axs[0].axhline(lvl, ls=":", c="grey")
    axs[0].set_ylabel("attitude error [deg]")
    if "euler_zyx_rad" in series:
        e = np.unwrap(series["euler_zyx_rad"], axis=0)
        for k, lab in enumerate(("ψ (z)", "θ (y)", "φ (x)")):
            axs[1].plot(t, np.degrees(e[:, k]), label=lab)
        axs[1].legend(fontsize=8)
    axs[1].set(xlabel="t [s]", ylabel="Euler ZYX [deg]")
    out.append(_save(fig, run_dir / "attitude.png"))
    fig, ax = _fig(figsize=(7, 3.5))
    ax.plot(t, series["omega_body_rad_s"])
    ax.set(xlabel="t [s]", ylabel="ω body [rad/s]", title="body rates")
    out.append(_save(fig, run_dir / "rates.png"))
    fig, axs = _fig(3, 1, figsize=(7, 7), sharex=True)
    cur = series["currents_axis_A"]
    sat = series["saturated"].astype(bool)
    for k, lab in enumerate("xyz"):
        axs[k].plot(t, cur[:, k], c=LOOP_COLOURS[k])
        axs[k].plot(t[sat[:, k]], cur[sat[:, k], k], "k.", ms=1.5)
        axs[k].set_ylabel(f"I_{lab} [A]")
    axs[2].set_xlabel("t [s] (dots: saturated)")
    out.append(_save(fig, run_dir / "currents.png"))
    fig, axs = _fig(3, 1, figsize=(7, 7), sharex=True)
    for k, lab in enumerate("xyz"):
        axs[k].plot(t, series["dipole_cmd_body_Am2"][:, k], "k:", lw=0.8, label="commanded")
        axs[k].plot(t, series["dipole_achieved_body_Am2"][:, k], c=LOOP_COLOURS[k], label="achieved")
        axs[k].set_ylabel(f"m_{lab} [A m²]")
    axs[0].legend(fontsize=8)
    axs[2].set_xlabel("t [s]")
    out.append(_save(fig, run_dir / "dipole.png"))
    fig, ax = _fig(figsize=(7, 3.5))
    ax.plot(t, np.linalg.norm(series["mag_torque_world_Nm"], axis=1), "b", lw=0.8, label="actuation (magnetic)")
    ax.plot(t, np.linalg.norm(series["gg_torque_world_Nm"], axis=1), "r", lw=0.8, label="gravity gradient")
    ax.set(xlabel="t [s]", ylabel="|torque| about CM [N m]")
    ax.legend(fontsize=8)
    out.append(_save(fig, run_dir / "torques.png"))
    return out
