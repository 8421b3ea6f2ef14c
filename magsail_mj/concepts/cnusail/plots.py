"""Plots of a CNUSAIL run (CNUSAIL spec §11): time in orbits for detumbling, minutes for slews;
dashed lines for limits. Also writes ``events.json`` (mode changes, manoeuvre starts, gain
recalculations with time, angle and gains)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from magsail_mj.io import write_json
from magsail_mj.concepts.cnusail.disturbances import SOURCES
from magsail_mj.plotting import new_figure, save_figure
from magsail_mj.concepts.cnusail.config import CnusailConfig

__all__ = ["attitude_plots", "disturbance_orbit_figure", "lifetime_plots"]

_AX = ("x", "y", "z")
_SRC_LABEL = {"gravity_gradient": "gravity gradient", "drag": "drag", "srp": "SRP",
              "residual_dipole": "residual dipole"}


def _hlines(ax, values, **kw) -> None:
    for v in values:
        ax.axhline(v, color=kw.get("color", "k"), ls="--", lw=0.8, alpha=0.6)


def disturbance_orbit_figure(series: dict[str, np.ndarray], period_s: float, title: str) -> Figure:
    """Figure: ‖T‖ [N m] of each disturbance source over one orbit (time in orbits of ``period_s``
    [s]), nadir and deorbit attitudes."""
    fig, axes = new_figure(1, 2, figsize=(12, 4.2), sharey=True)
    for ax, m in zip(axes, ("nadir", "deorbit")):
        ts = series[f"dist_orbit_t_{m}_s"]
        tq = series[f"dist_orbit_{m}_N_m"]
        scale = float(np.max(np.linalg.norm(tq, axis=2)))
        for k, src in enumerate(SOURCES):
            mag = np.linalg.norm(tq[:, k], axis=1)
            # below 1e-12 of the largest torque is rounding (the gravity gradient is exactly zero here)
            ax.semilogy(ts / period_s, np.where(mag > 1e-12 * scale, mag, np.nan), color=f"C{k}",
                        label=_SRC_LABEL[src] + (" (≡ 0)" if np.all(mag <= 1e-12 * scale) else ""))
        if f"dist_orbit_{m}_gg_5deg_N_m" in series:
            g5 = np.linalg.norm(series[f"dist_orbit_{m}_gg_5deg_N_m"], axis=1)
            ax.semilogy(series[f"dist_orbit_t_{m}_gg_5deg_s"] / period_s, g5, "--", color="C0",
                        label="gravity gradient, 5° off about y_B")
        ax.set_xlabel("time [orbits]")
        ax.set_title(f"{m} attitude (held exactly; SRP zero in eclipse)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("|torque| [N m]")
    axes[0].legend(fontsize=8)
    fig.suptitle(title)
    return fig


def attitude_plots(run_dir: Path, series: dict[str, np.ndarray], *, cfg: CnusailConfig, orbit_period_s: float,
                   events: list[dict[str, Any]]) -> list[Path]:
    """Write the run's figures and ``events.json`` (the controller's ``events``) into ``run_dir``;
    return their paths. Time axes in orbits of ``orbit_period_s`` [s] (detumbling) or minutes."""
    t = series["t"]
    period = orbit_period_s
    out: list[Path] = []
    out.append(write_json(run_dir / "events.json", {"count": len(events), "events": events}))
    title = f"CNUSAIL-1 {cfg.scenario} ({cfg.spacecraft.configuration}, {cfg.control.mode})"
    npz = np.load(run_dir / "timeseries.npz")
    rec = {k: npz[k] for k in npz.files}
    deg = 180.0 / math.pi
    limits = cfg.actuators.mtq.limit_vector
    wheels = cfg.actuators.wheels

    if cfg.control.mode == "bdot" or cfg.control.modes.enabled:
        x = t / period
        fig, ax = new_figure(figsize=(9, 4.5))
        w = series["omega_body_rad_s"] * deg
        for j in range(3):
            ax.plot(x, w[:, j], lw=0.7, label=f"ω_{_AX[j]}")
        ax.plot(x, series["omega_norm_deg_s"], "k", lw=1.2, label="|ω|")
        _hlines(ax, [1.0, -1.0], color="r")
        _hlines(ax, [cfg.analysis.detumble_threshold_deg_s], color="g")
        ax.set(xlabel="time [orbits]", ylabel="body rate [°/s]", title=title + ": body rates")
        ax.legend(ncol=4, fontsize=8)
        ax.grid(alpha=0.3)
        out.append(save_figure(fig, run_dir / "rates.png"))

        fig, axes = new_figure(3, 1, figsize=(9, 7), sharex=True)
        dip = rec["dipole_cmd_A_m2"]
        for j, ax in enumerate(axes):
            ax.plot(x, dip[:, j], lw=0.6)
            _hlines(ax, [limits[j], -limits[j]], color="r")
            ax.set_ylabel(f"M_{_AX[j]} [A m²]")
            ax.grid(alpha=0.3)
        axes[0].set_title(title + ": magnetorquer dipole commands")
        axes[-1].set_xlabel("time [orbits]")
        out.append(save_figure(fig, run_dir / "dipole.png"))

        fig, ax = new_figure(figsize=(9, 4))
        P = series["mtq_power_W"]
        for j in range(3):
            ax.plot(x, P[:, j], lw=0.6, label=f"axis {_AX[j]}")
        ax.plot(x, P.sum(axis=1), "k", lw=0.8, label="total")
        _hlines(ax, [cfg.actuators.mtq.power_max_W], color="r")
        ax.set(xlabel="time [orbits]", ylabel="power [W]", title=title + ": magnetorquer power (assumed model)")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        out.append(save_figure(fig, run_dir / "mtq_power.png"))

        fig, ax = new_figure(figsize=(9, 4))
        B = series["B_body_T"] * 1e6
        for j in range(3):
            ax.plot(x, B[:, j], lw=0.6, label=f"B_{_AX[j]}")
        ax.plot(x, np.linalg.norm(B, axis=1), "k", lw=0.8, label="|B|")
        ax.set(xlabel="time [orbits]", ylabel="field [µT]", title=title + ": geomagnetic field, body axes")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        out.append(save_figure(fig, run_dir / "field_body.png"))

    if cfg.control.mode in ("eigen_axis", "pd"):
        x = t / 60.0
        marks = [e["t_s"] / 60.0 for e in events if e["kind"] in ("gain_recalc", "manoeuvre_start", "mode")]
        thr = cfg.analysis.pointing_threshold_deg
        fig, axes = new_figure(2, 1, figsize=(9, 7), sharex=True)
        axes[0].plot(x, series["theta_e_deg"], "k", label="θ_e (eigen-angle)")
        axes[0].axhspan(-thr, thr, color="g", alpha=0.15)
        axes[0].set_ylabel("θ_e [deg]")
        e321 = series["error_321_deg"]
        for j, name in enumerate(("yaw (3)", "pitch (2)", "roll (1)")):
            axes[1].plot(x, e321[:, j], lw=0.8, label=name)
        axes[1].axhspan(-thr, thr, color="g", alpha=0.15)
        axes[1].set_ylabel("3-2-1 error angles [deg]")
        for ax in axes:
            for m in marks:
                ax.axvline(m, color="m", ls=":", lw=0.8)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        axes[0].set_title(title + ": attitude error"
                          + (" (dotted: manoeuvre start / gain recalculation)" if marks else ""))
        axes[1].set_xlabel("time [min]")
        out.append(save_figure(fig, run_dir / "attitude_error.png"))

        fig, ax = new_figure(figsize=(9, 4.5))
        we = rec["omega_e_rad_s"] * deg
        for j in range(3):
            ax.plot(x, we[:, j], lw=0.7, label=f"ω_e,{_AX[j]}")
        ax.plot(x, np.linalg.norm(we, axis=1), "k", lw=1.0, label="|ω_e|")
        rmax = cfg.control.slew_rate_max_deg_s
        _hlines(ax, [0.1, -0.1], color="g")
        _hlines(ax, [rmax, -rmax], color="r")
        ax.set(xlabel="time [min]", ylabel="rate error [°/s]", title=title + ": rate error (±0.1 green, ±θ̇_max red)")
        ax.legend(ncol=4, fontsize=8)
        ax.grid(alpha=0.3)
        out.append(save_figure(fig, run_dir / "rate_error.png"))

        fig, ax = new_figure(figsize=(9, 4.5))
        rpm = series["wheel_speed_rpm"]
        for j in range(3):
            ax.plot(x, rpm[:, j], lw=0.8, label=f"wheel {_AX[j]}")
        thr_rpm = cfg.control.unloading.threshold_rpm
        _hlines(ax, [thr_rpm, -thr_rpm], color="orange")
        _hlines(ax, [wheels.speed_max_rpm, -wheels.speed_max_rpm], color="r")
        ax.set(xlabel="time [min]", ylabel="relative wheel speed [rpm]",
               title=title + f": wheel speeds (±{thr_rpm:g} unloading, ±{wheels.speed_max_rpm:g} limit)")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        out.append(save_figure(fig, run_dir / "wheel_speeds.png"))

        fig, axes = new_figure(3, 1, figsize=(9, 7.5), sharex=True)
        u = rec["u_cmd_N_m"]
        wt = series["wheel_torque_body_N_m"]
        tau = wheels.torque_max_N_m
        for j, ax in enumerate(axes):
            ax.plot(x, u[:, j], lw=0.8, label="commanded u")
            ax.plot(x, wt[:, j], lw=0.8, ls="--", label="delivered by wheel")
            _hlines(ax, [tau, -tau], color="r")
            ax.set_ylabel(f"{_AX[j]} [N m]")
            ax.grid(alpha=0.3)
        axes[0].legend(fontsize=8)
        axes[0].set_title(title + ": control torque (±τ_max dashed)")
        axes[-1].set_xlabel("time [min]")
        out.append(save_figure(fig, run_dir / "torques.png"))

        fig, ax = new_figure(figsize=(9, 4))
        dip = rec["dipole_cmd_A_m2"]
        for j in range(3):
            ax.plot(x, dip[:, j], lw=0.8, label=f"m_{_AX[j]}")
        _hlines(ax, [limits.max(), -limits.max()], color="r")
        ax.set(xlabel="time [min]", ylabel="dipole [A m²]", title=title + ": unloading dipole")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        out.append(save_figure(fig, run_dir / "unloading.png"))

        if "dist_orbit_nadir_N_m" in series:
            fig = disturbance_orbit_figure(series, period, f"CNUSAIL-1 {cfg.spacecraft.configuration}: "
                                                           "disturbance torques over one orbit")
            out.append(save_figure(fig, run_dir / "disturbances_orbit.png"))

        if cfg.control.command == "deorbit" or cfg.control.modes.deorbit_at_s is not None:
            fig, axes = new_figure(3, 1, figsize=(9, 8), sharex=True)
            axes[0].plot(x, series["altitude_m"] / 1e3, "b")
            axes[0].set_ylabel("altitude [km]", color="b")
            a2 = axes[0].twinx()
            a2.semilogy(x, series["density_kg_m3"], "r", lw=0.8)
            a2.set_ylabel("density [kg/m³]", color="r")
            axes[1].plot(x, np.abs(series["sail_flow_cos"]), "k")
            axes[1].set_ylabel("|ẑ_B · V̂| (projected area fraction)")
            axes[2].plot(x, series["sail_normal_flow_angle_deg"], "k")
            axes[2].axhline(5.0, color="g", ls="--", lw=0.8)
            axes[2].set_ylabel("sail normal to flow [deg]")
            for ax in axes:
                for m in marks:
                    ax.axvline(m, color="m", ls=":", lw=0.8)
                ax.grid(alpha=0.3)
            axes[0].set_title(title + ": orbit and sail-to-flow geometry")
            axes[-1].set_xlabel("time [min]")
            out.append(save_figure(fig, run_dir / "deorbit_flow.png"))

    # disturbance torques along the run, every mode
    x = t / (period if cfg.control.mode == "bdot" else 60.0)
    fig, ax = new_figure(figsize=(9, 4.5))
    dist = rec["torque_dist_body_N_m"]
    for k, src in enumerate(SOURCES):
        mag = np.linalg.norm(dist[:, k], axis=1)
        ax.semilogy(x, np.where(mag > 0, mag, np.nan), lw=0.7, label=_SRC_LABEL[src])
    mag = np.linalg.norm(rec["torque_mtq_body_N_m"], axis=1)
    ax.semilogy(x, np.where(mag > 0, mag, np.nan), lw=0.5, alpha=0.6, label="magnetorquer")
    ax.set(xlabel="time [orbits]" if cfg.control.mode == "bdot" else "time [min]", ylabel="|torque| [N m]",
           title=title + ": disturbance torques by source")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    out.append(save_figure(fig, run_dir / "disturbances.png"))
    return out


def lifetime_plots(run_dir: Path, series: dict[str, np.ndarray], table: list[dict[str, Any]],
                   comparison: dict[str, Any], title: str) -> list[Path]:
    """S8: altitude vs time for the three regimes (one plot) and the lifetime comparison chart."""
    out: list[Path] = []
    fig, ax = new_figure(figsize=(10, 5))
    colours = {"nadir": "tab:blue", "deorbit": "tab:red", "tumbling": "tab:green"}
    for reg in ("nadir", "deorbit", "tumbling"):
        for method, ls in (("cowell", "-"), ("averaged", "--")):
            key = f"{reg}_{method}_exp"
            if f"t_{key}_s" not in series:
                continue
            td = series[f"t_{key}_s"] / 86400.0
            a_alt = series[f"a_alt_{key}_m"] / 1e3
            # the osculating a of the last Cowell samples (re-entry spiral) is not a mean altitude
            a_alt = np.where(a_alt > 100.0, a_alt, np.nan)
            ax.plot(td, a_alt, ls, color=colours[reg], lw=1.2, label=f"{reg} ({method}): a − R_E")
            ax.fill_between(td, series[f"perigee_{key}_m"] / 1e3, series[f"apogee_{key}_m"] / 1e3,
                            color=colours[reg], alpha=0.08 if method == "cowell" else 0.04)
    ax.set_xscale("symlog", linthresh=10.0)
    ax.axhline(120.0, color="k", ls=":", lw=0.8)
    ax.set(xlabel="time [days] (linear to 10, log beyond)", ylabel="altitude [km]",
           title=title + ": orbit decay, exponential atmosphere (bands: perigee–apogee)")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    out.append(save_figure(fig, run_dir / "altitude_decay.png"))

    fig, ax = new_figure(figsize=(10, 5.5))
    g = comparison["generic"]
    capped = np.asarray(g.get("reached_cap", [False] * len(g["altitude_km"])), dtype=bool)
    alt, days = np.asarray(g["altitude_km"], float), np.asarray(g["lifetime_days"], float)
    ax.semilogy(alt[~capped], days[~capped], "o", color="green", label="generic 3U cubesat (0.035 m², 4 kg)")
    if capped.any():
        ax.semilogy(alt[capped], days[capped], "^", color="green", mfc="none", label="generic 3U (≥ time cap)")
    for row in comparison["cnusail"]:
        ax.errorbar(row["mean_alt_km"], row["lifetime_days"],
                    xerr=[[row["mean_alt_km"] - row["perigee_km"]], [row["apogee_km"] - row["mean_alt_km"]]],
                    fmt="s", color=colours[row["regime"]], capsize=4, label=f"CNUSAIL-1 {row['regime']}")
    for ref in comparison.get("references", []):
        ax.plot(ref["altitude_km"], ref["observed_days"], "*", ms=12, label=f"{ref['name']} (observed)")
        if ref.get("predicted_days") is not None:
            ax.plot(ref["altitude_km"], ref["predicted_days"], "x", ms=9, label=f"{ref['name']} (this model)")
    ax.set(xlabel="initial (mean) altitude [km]", ylabel="lifetime [days]",
           title=title + ": lifetime comparison (exponential atmosphere)")
    ax.legend(fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    out.append(save_figure(fig, run_dir / "lifetime_comparison.png"))
    return out
