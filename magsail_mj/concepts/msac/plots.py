"""Plots of an MSAC run (F1–F6).

F1 ``cycle_diagram.png`` (three cycles of φ, s and the bus yaw), F2 ``attitude_angles.png``
(ZYX angles wrapped to [−π, π] and the unwrapped yaw), F3 ``omega_world.png`` (raw world-frame
ω: per-cycle envelope of ω_z over the run, ω_x/ω_y at the records, and a ~5 ms full-rate zoom),
F4 ``omega_filtered.png`` (low-pass-filtered ω_z), F5 ``rate_comparison.png`` (slope, filtered
mean, Eq. 7, exact), ``cycle_increments.png`` (per-cycle rotation against the exact model), and
for sweeps ``sweep.png`` (F6 panel of one swept key).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from magsail_mj.concepts.msac.metrics import yaw_from_quat
from magsail_mj.concepts.msac.cycle import CyclePath
from magsail_mj.estimation.attitude import euler_zyx, matrix_from_quat
from magsail_mj.concepts.msac.mjcf import shape_indices
from magsail_mj.plotting import new_figure, save_figure
from magsail_mj.records import units_of
from magsail_mj.concepts.msac.config import MsacConfig

# save_figure stays importable from here until scripts/msac_sweeps.py takes it from magsail_mj.plotting
__all__ = ["msac_plots", "sweep_plot", "save_figure"]


def msac_plots(
    run_dir: Path, s: dict[str, Any], *, cfg: MsacConfig, path: CyclePath, model: mujoco.MjModel
) -> list[Path]:
    """Write F1–F5 and the increments plot of a multibody run; return their paths. ``s``: the
    records and series of the run plus ``_summary`` (its summary); ``path``: its cycle; ``model``:
    its MuJoCo model (shape joint addresses)."""
    out: list[Path] = []
    title = f"MSAC {cfg.description}".strip()
    T = path.period_s
    qa = shape_indices(model)["qpos"]
    summary = s.get("_summary", {})

    # ---- F1: three cycles at full rate (the first window, else the records)
    src = None
    if "win_t" in s and s["win_t"].size and np.sum(s["win_id"] == 0) * cfg.sim.timestep_s >= 3 * T * 0.999:
        sel = (s["win_id"] == 0) & (s["win_t"] <= 3 * T + 1e-12)
        src = (s["win_t"][sel], s["win_qpos"][sel])
    elif s["t"].size > 3:
        sel = s["t"] <= 3 * T + 1e-12
        src = (s["t"][sel], s["qpos"][sel])
    if src is not None and src[0].size > 2:
        t, q = src
        yaw = np.unwrap(yaw_from_quat(q[:, 3:7]))
        fig, ax = new_figure(figsize=(9, 4.5))
        ax.plot(t / T, np.degrees(q[:, qa[0]]), "k:", lw=1.5, label="φ, wing bend [deg]")
        ax.set_xlabel("t / Δt [cycles]")
        ax.set_ylabel("φ [deg]")
        ax2 = ax.twinx()
        ax2.plot(t / T, 1e3 * q[:, qa[1]], "C0--", lw=1.5, label="s, slide [mm]")
        ax2.plot(t / T, 1e3 * (yaw - yaw[0]), "C3-", lw=1.8, label="bus yaw ψ − ψ₀ [mrad]")
        ax2.set_ylabel("s [mm], ψ − ψ₀ [mrad]")
        for k in range(int(np.ceil(t[-1] / T - 1e-9))):
            for b in path.phase_bounds_s[:-1]:
                ax.axvline(k + b / T, color="0.85", lw=0.8, zorder=0)
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels()
        ax.legend(h1 + h2, l1 + l2, loc="lower left", fontsize=8)
        ax.set_title(
            f"{title} — F1 cycle diagram (phases I→II bend ext., II→III contract, III→IV bend contr., IV→I extend)",
            fontsize=9,
        )
        out.append(save_figure(fig, run_dir / "cycle_diagram.png"))

    # ---- F2: ZYX angles wrapped, and the unwrapped yaw
    if s["t"].size > 1:
        R = matrix_from_quat(s["qpos"][:, 3:7])
        psi, theta, phi = euler_zyx(R)
        fig, axs = new_figure(4, 1, figsize=(9, 9), sharex=True)
        for ax, val, lab in zip(
            axs, (psi, theta, phi), ("rotation angle 1 (yaw, Z)", "angle 2 (pitch, Y)", "angle 3 (roll, X)")
        ):
            ax.plot(s["t"], val, ",", color="C0") if val.size > 5000 else ax.plot(s["t"], val, "C0-", lw=0.8)
            ax.set_ylabel(f"{lab} [rad]", fontsize=8)
            ax.set_ylim(-np.pi * 1.05, np.pi * 1.05)
        st = s.get("strobe_t", s["t"])
        yu = s.get("strobe_yaw_unwrapped_rad", s["yaw_unwrapped_rad"])
        axs[3].plot(st[: yu.size], yu, "C3-", lw=1)
        axs[3].set_ylabel("yaw unwrapped,\nstroboscopic [rad]", fontsize=8)
        axs[3].set_xlabel("t [s]")
        axs[0].set_title(f"{title} — F2 bus rotation angles (wrapped to [−π, π]) and unwrapped yaw", fontsize=9)
        out.append(save_figure(fig, run_dir / "attitude_angles.png"))

    # ---- F3: raw ω in world axes
    fig, axs = new_figure(2, 1, figsize=(9, 7))
    if "omega_z_cycle_min_rad_s" in s and s["omega_z_cycle_min_rad_s"].size:
        tc = np.arange(s["omega_z_cycle_min_rad_s"].size) * T
        axs[0].fill_between(
            tc,
            s["omega_z_cycle_min_rad_s"],
            s["omega_z_cycle_max_rad_s"],
            color="C0",
            alpha=0.5,
            lw=0,
            label="ω_z per-cycle min…max (raw, every step)",
        )
    w = s["omega_world_rad_s"]
    axs[0].plot(s["t"], w[:, 0], "C1,", label="ω_x (records)")
    axs[0].plot(s["t"], w[:, 1], "C2,", label="ω_y (records)")
    axs[0].set_ylabel("ω world [rad/s]")
    axs[0].set_xlabel("t [s]")
    axs[0].legend(fontsize=8, loc="upper right")
    axs[0].set_title(f"{title} — F3 raw world-frame angular velocity", fontsize=9)
    if "win_t" in s and s["win_t"].size:
        wid = s["win_id"]
        pick = wid == (wid.max() // 2 if wid.max() > 0 else 0)
        tw = s["win_t"][pick]
        z = tw <= tw[0] + 5e-3
        for i, c in enumerate(("C1", "C2", "C0")):
            axs[1].plot(
                1e3 * (tw[z] - tw[0]), s["win_omega_world_rad_s"][pick][z, i], c + "-", lw=1, label=f"ω_{'xyz'[i]}"
            )
        axs[1].set_xlabel(f"t − {tw[0]:.4f} s [ms]")
        axs[1].set_ylabel("ω world [rad/s]")
        axs[1].legend(fontsize=8)
        axs[1].set_title("zoom: 5 ms at full rate", fontsize=9)
    fig.tight_layout()
    out.append(save_figure(fig, run_dir / "omega_world.png"))

    # ---- F4: filtered ω_z
    if "omega_z_filtered_rad_s" in s and np.isfinite(s["omega_z_filtered_rad_s"]).any():
        fig, ax = new_figure(figsize=(9, 4))
        ax.plot(
            s["omega_filt_t"],
            s["omega_z_filtered_rad_s"],
            "C0-",
            lw=1,
            label=f"ω_z, Butterworth {cfg.post.lowpass_order}th order {cfg.post.lowpass_cutoff_Hz:g} Hz, zero phase",
        )
        if summary:
            ax.axhline(summary.get("predicted_rate_exact_rad_s", np.nan), color="k", ls="--", lw=1, label="exact model")
        e = cfg.post.edge_discard_s
        tf, wf = s["omega_filt_t"], s["omega_z_filtered_rad_s"]
        ax.axvspan(tf[0], tf[0] + e, color="0.9")
        ax.axvspan(tf[-1] - e, tf[-1], color="0.9")
        inner = wf[(tf >= tf[0] + e) & (tf <= tf[-1] - e)]
        if inner.size:  # scale to the kept part: the filter's start-up transient is ~10² rad/s
            lo, hi = float(inner.min()), float(inner.max())
            pad = max(hi - lo, 1e-3 * abs(hi)) * 2
            ax.set_ylim(lo - pad, hi + pad)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("filtered ω_z [rad/s]")
        ax.legend(fontsize=8)
        ax.set_title(f"{title} — F4 low-pass-filtered ω_z (grey: discarded edges)", fontsize=9)
        out.append(save_figure(fig, run_dir / "omega_filtered.png"))

    # ---- F5: rate comparison and per-cycle increments
    if summary and np.isfinite(summary.get("rate_slope_rad_s", np.nan)):
        names = ["slope of yaw", "filtered mean ω_z", "Eq. (7) lumped", "exact model"]
        vals = [
            summary["rate_slope_rad_s"],
            summary["rate_filtered_mean_rad_s"],
            summary["omega_gamma_eq7_rad_s"],
            summary["predicted_rate_exact_rad_s"],
        ]
        fig, ax = new_figure(figsize=(7, 4))
        bars = ax.bar(names, vals, color=["C0", "C0", "C7", "k"])
        for b, v in zip(bars, vals):
            ax.text(b.get_x() + b.get_width() / 2, v, f"{v:.5g}", ha="center", va="bottom", fontsize=8)
        ax.set_ylabel("secular rate [rad/s]")
        ax.set_title(f"{title} — F5 secular rate", fontsize=9)
        out.append(save_figure(fig, run_dir / "rate_comparison.png"))
    if "strobe_increment_rad" in s and s["strobe_increment_rad"].size:
        inc = s["strobe_increment_rad"]
        fig, ax = new_figure(figsize=(9, 4))
        k = np.arange(1, inc.size + 1)
        ax.plot(k, inc, "C0.", ms=2, label="MuJoCo per-cycle rotation θ_γ,k")
        if summary:
            ax.axhline(summary["theta_gamma_exact_rad"], color="k", ls="--", lw=1, label="exact model")
        ax.set_xscale("log")
        ax.set_xlabel("cycle k")
        ax.set_ylabel("θ_γ,k [rad]")
        ax.legend(fontsize=8)
        ax.set_title(f"{title} — stroboscopic increments (cycle 1 = start-up, excluded from the mean)", fontsize=9)
        out.append(save_figure(fig, run_dir / "cycle_increments.png"))
    return out


def _key_with_unit(key: str) -> str:
    """A swept config key with the unit of its SI suffix, ``wings.length_m [m]`` (``[–]`` without one)."""
    unit = units_of(key.rpartition(".")[2])[0]
    return f"{key} [{'–' if unit == '1' else unit}]"


def sweep_plot(cfg: MsacConfig, run_dir: Path, s: dict[str, Any]) -> Path:
    """F6 panel of one sweep: per-cycle rotation (Eq. 6, exact, MuJoCo) against the swept value."""
    sw = cfg.sweep
    x = np.arange(len(sw.points))
    labels = [", ".join(f"{v}" for v in p) for p in sw.points]
    fig, axs = new_figure(1, 2, figsize=(11, 4))
    for key, style, lab in (
        ("sweep_theta_gamma_eq6_model_rad", "C7s--", "Eq. (6), model inertias"),
        ("sweep_theta_gamma_exact_rad", "ko-", "exact planar model"),
        ("sweep_theta_gamma_mujoco_rad", "C3x", "MuJoCo"),
    ):
        axs[0].plot(x, s[key], style, label=lab, ms=8)
    axs[0].set_ylabel("per-cycle rotation θ_γ [rad]")
    axs[1].plot(x, s["sweep_secular_rate_rad_s"], "C3x-", label="MuJoCo secular rate")
    axs[1].plot(x, s["sweep_predicted_rate_exact_rad_s"], "ko--", mfc="none", label="exact / Δt")
    axs[1].set_ylabel("secular rate [rad/s]")
    for ax in axs:
        ax.set_xticks(x, labels, rotation=30, fontsize=8)
        ax.set_xlabel(" + ".join(_key_with_unit(k) for k in sw.keys))
        ax.legend(fontsize=8)
    fig.suptitle(f"F6 sweep of {', '.join(sw.keys)} (base {sw.base}, {sw.cycles} cycles per point)", fontsize=10)
    return save_figure(fig, run_dir / "sweep.png")
