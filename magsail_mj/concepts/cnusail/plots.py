"""Plots of a CNUSAIL run: time in orbits for detumbling, minutes for slews;
dashed lines for limits (the run's ``events.json`` is written by the task's ``data_files``)."""

from __future__ import annotations

import math
from collections import ChainMap
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from magsail_mj.concepts.cnusail.disturbances import SOURCES
from magsail_mj.plotting import new_figure, save_figure
from magsail_mj.concepts.cnusail.config import CnusailConfig

__all__ = ["attitude_plots", "disturbance_orbit_figure", "lifetime_plots"]

_AX = ("x", "y", "z")
DEG = 180.0 / math.pi
_SRC_LABEL = {
    "gravity_gradient": "gravity gradient",
    "drag": "drag",
    "srp": "SRP",
    "residual_dipole": "residual dipole",
}


def _hlines(ax, values, *, color: str = "k", label: str | None = None) -> None:
    """Dashed horizontal reference lines at ``values``; the first one carries ``label`` (legend)."""
    for k, v in enumerate(values):
        ax.axhline(v, color=color, ls="--", lw=0.8, alpha=0.6, label=label if k == 0 else None)


def _components_figure(
    path: Path,
    x: np.ndarray,
    v: np.ndarray,
    *,
    names: tuple[str, ...],
    xlabel: str,
    ylabel: str,
    title: str,
    total: tuple[np.ndarray, str] | None = None,
    limits: tuple[tuple[list[float], str, str], ...] = (),
    lw: float = 0.6,
) -> Path:
    """One panel of the three columns of ``v`` (n, 3) against ``x``, named ``names``, with an
    optional ``total`` (values, label) in black and dashed reference lines ``limits`` ((values,
    colour, label), ...); written to ``path``."""
    fig, ax = new_figure(figsize=(9, 4.5))
    for j in range(3):
        ax.plot(x, v[:, j], lw=lw, label=names[j])
    if total is not None:
        ax.plot(x, total[0], "k", lw=1.0, label=total[1])
    for values, colour, label in limits:
        _hlines(ax, values, color=colour, label=label)
    ax.set(xlabel=xlabel, ylabel=ylabel, title=title)
    ax.legend(ncol=3, fontsize=8)
    ax.grid(alpha=0.3)
    return save_figure(fig, path)


def disturbance_orbit_figure(series: dict[str, np.ndarray], period_s: float, title: str) -> Figure:
    """Figure: ‖T‖ [N m] of each disturbance source over one orbit (time in orbits of ``period_s``
    [s]), nadir and deorbit attitudes."""
    fig, axes = new_figure(1, 2, figsize=(12, 4.2), sharey=True)
    for ax, m in zip(axes, ("nadir", "deorbit")):
        ts = series[f"dist_orbit_t_{m}_s"]
        tq = series[f"dist_orbit_{m}_Nm"]
        scale = float(np.max(np.linalg.norm(tq, axis=2)))
        for k, src in enumerate(SOURCES):
            mag = np.linalg.norm(tq[:, k], axis=1)
            # below 1e-12 of the largest torque is rounding (the gravity gradient is exactly zero here)
            ax.semilogy(
                ts / period_s,
                np.where(mag > 1e-12 * scale, mag, np.nan),
                color=f"C{k}",
                label=_SRC_LABEL[src] + (" (≡ 0)" if np.all(mag <= 1e-12 * scale) else ""),
            )
        if f"dist_orbit_{m}_gg_5deg_Nm" in series:
            g5 = np.linalg.norm(series[f"dist_orbit_{m}_gg_5deg_Nm"], axis=1)
            ax.semilogy(
                series[f"dist_orbit_t_{m}_gg_5deg_s"] / period_s,
                g5,
                "--",
                color="C0",
                label="gravity gradient, 5° off about y_B",
            )
        ax.set_xlabel("time [orbits]")
        ax.set_title(f"{m} attitude (held exactly; SRP zero in eclipse)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("|torque| [N m]")
    axes[0].legend(fontsize=8)
    fig.suptitle(title)
    return fig


def attitude_plots(
    run_dir: Path,
    series: dict[str, np.ndarray],
    *,
    records: Mapping[str, np.ndarray],
    cfg: CnusailConfig,
    orbit_period_s: float,
    events: list[dict[str, Any]],
) -> list[Path]:
    """Write the run's figures into ``run_dir``; return their paths. ``records``: the run's records
    (a series of the same name replaces a record); ``events``: the controller's events (gain
    recalculations drawn on the pointing plots). Time axes in orbits of ``orbit_period_s`` [s]
    (detumbling) or minutes."""
    out: list[Path] = []
    rec = ChainMap(series, records)
    title = f"CNUSAIL-1 {cfg.scenario} ({cfg.spacecraft.configuration}, {cfg.control.mode})"
    if cfg.control.mode == "bdot" or cfg.control.modes.enabled:
        out += _detumble_plots(run_dir, rec, cfg=cfg, x=series["t"] / orbit_period_s, title=title)
    if cfg.control.mode in ("eigen_axis", "pd"):
        out += _pointing_plots(run_dir, rec, cfg=cfg, orbit_period_s=orbit_period_s, events=events, title=title)
    out.append(_disturbance_plot(run_dir, rec, cfg=cfg, orbit_period_s=orbit_period_s, title=title))
    return out


def _detumble_plots(
    run_dir: Path, rec: Mapping[str, np.ndarray], *, cfg: CnusailConfig, x: np.ndarray, title: str
) -> list[Path]:
    """Body rates, magnetorquer dipoles, magnetorquer power and the field in body axes against
    ``x`` [orbits]."""
    limits = cfg.actuators.mtq.limit_vector
    thr = cfg.analysis.detumble_threshold_deg_s
    out = [
        _components_figure(
            run_dir / "rates.png",
            x,
            rec["omega_body_rad_s"] * DEG,
            names=tuple(f"ω_{a}" for a in _AX),
            total=(rec["omega_norm_deg_s"], "|ω|"),
            xlabel="time [orbits]",
            ylabel="body rate [°/s]",
            title=title + ": body rates",
            lw=0.7,
            limits=(([1.0, -1.0], "r", "±1 °/s (detumbling entry)"), ([thr], "g", f"{thr:g} °/s (detumbled)")),
        )
    ]

    fig, axes = new_figure(3, 1, figsize=(9, 7), sharex=True)
    dip = rec["dipole_cmd_Am2"]
    for j, ax in enumerate(axes):
        ax.plot(x, dip[:, j], lw=0.6, label="commanded (held) dipole")
        _hlines(ax, [limits[j], -limits[j]], color="r", label="±dipole limit")
        ax.set_ylabel(f"M_{_AX[j]} [A m²]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[0].set_title(title + ": magnetorquer dipole commands")
    axes[-1].set_xlabel("time [orbits]")
    out.append(save_figure(fig, run_dir / "dipole.png"))

    P = rec["mtq_power_W"]
    out.append(
        _components_figure(
            run_dir / "mtq_power.png",
            x,
            P,
            names=tuple(f"axis {a}" for a in _AX),
            total=(P.sum(axis=1), "total"),
            xlabel="time [orbits]",
            ylabel="power [W]",
            title=title + ": magnetorquer power (assumed model)",
            limits=(([cfg.actuators.mtq.power_max_W], "r", "power limit"),),
        )
    )
    B = rec["B_body_T"] * 1e6
    out.append(
        _components_figure(
            run_dir / "field_body.png",
            x,
            B,
            names=tuple(f"B_{a}" for a in _AX),
            total=(np.linalg.norm(B, axis=1), "|B|"),
            xlabel="time [orbits]",
            ylabel="field [µT]",
            title=title + ": geomagnetic field, body axes",
        )
    )
    return out


def _event_lines(axes, marks: list[float]) -> None:
    """Magenta dotted lines at the event times ``marks`` [min] on every panel (one legend entry)."""
    for ax in axes:
        for k, m in enumerate(marks):
            ax.axvline(m, color="m", ls=":", lw=0.8, label="manoeuvre start / gain recalculation" if k == 0 else None)
        ax.grid(alpha=0.3)


def _pointing_plots(
    run_dir: Path,
    rec: Mapping[str, np.ndarray],
    *,
    cfg: CnusailConfig,
    orbit_period_s: float,
    events: list[dict[str, Any]],
    title: str,
) -> list[Path]:
    """Attitude error, rate error, wheel speeds, torques, unloading dipole, the orbit's
    disturbances and (deorbit) the sail-to-flow geometry against time [min]."""
    x = rec["t"] / 60.0
    marks = [e["t_s"] / 60.0 for e in events if e["kind"] in ("gain_recalc", "manoeuvre_start", "mode")]
    thr = cfg.analysis.pointing_threshold_deg
    wheels = cfg.actuators.wheels
    out = []
    fig, axes = new_figure(2, 1, figsize=(9, 7), sharex=True)
    axes[0].plot(x, rec["theta_e_deg"], "k", label="θ_e (eigen-angle)")
    axes[0].set_ylabel("θ_e [deg]")
    for j, name in enumerate(("yaw (3)", "pitch (2)", "roll (1)")):
        axes[1].plot(x, rec["error_321_deg"][:, j], lw=0.8, label=name)
    axes[1].set_ylabel("3-2-1 error angles [deg]")
    for ax in axes:
        ax.axhspan(-thr, thr, color="g", alpha=0.15, label=f"±{thr:g}° pointing threshold")
    _event_lines(axes, marks)
    for ax in axes:
        ax.legend(fontsize=8)
    axes[0].set_title(title + ": attitude error")
    axes[1].set_xlabel("time [min]")
    out.append(save_figure(fig, run_dir / "attitude_error.png"))

    we = rec["omega_e_rad_s"] * DEG
    rmax = cfg.control.slew_rate_max_deg_s
    out.append(
        _components_figure(
            run_dir / "rate_error.png",
            x,
            we,
            names=tuple(f"ω_e,{a}" for a in _AX),
            total=(np.linalg.norm(we, axis=1), "|ω_e|"),
            xlabel="time [min]",
            ylabel="rate error [°/s]",
            title=title + ": rate error",
            lw=0.7,
            limits=(([0.1, -0.1], "g", "±0.1 °/s"), ([rmax, -rmax], "r", "±θ̇_max (slew rate limit)")),
        )
    )
    thr_rpm = cfg.control.unloading.threshold_rpm
    out.append(
        _components_figure(
            run_dir / "wheel_speeds.png",
            x,
            rec["wheel_speed_rpm"],
            names=tuple(f"wheel {a}" for a in _AX),
            xlabel="time [min]",
            ylabel="relative wheel speed [rpm]",
            title=title + ": wheel speeds",
            lw=0.8,
            limits=(
                ([thr_rpm, -thr_rpm], "orange", f"±{thr_rpm:g} rpm (unloading)"),
                ([wheels.speed_max_rpm, -wheels.speed_max_rpm], "r", f"±{wheels.speed_max_rpm:g} rpm (limit)"),
            ),
        )
    )

    fig, axes = new_figure(3, 1, figsize=(9, 7.5), sharex=True)
    tau = wheels.torque_max_Nm
    for j, ax in enumerate(axes):
        ax.plot(x, rec["u_cmd_Nm"][:, j], lw=0.8, label="commanded u")
        ax.plot(x, rec["wheel_torque_body_Nm"][:, j], lw=0.8, ls="--", label="delivered by wheel")
        _hlines(ax, [tau, -tau], color="r", label="±τ_max")
        ax.set_ylabel(f"{_AX[j]} [N m]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[0].set_title(title + ": control torque")
    axes[-1].set_xlabel("time [min]")
    out.append(save_figure(fig, run_dir / "torques.png"))

    limit = cfg.actuators.mtq.limit_vector.max()
    out.append(
        _components_figure(
            run_dir / "unloading.png",
            x,
            rec["dipole_cmd_Am2"],
            names=tuple(f"m_{a}" for a in _AX),
            xlabel="time [min]",
            ylabel="dipole [A m²]",
            title=title + ": unloading dipole",
            lw=0.8,
            limits=(([limit, -limit], "r", "±dipole limit"),),
        )
    )

    if "dist_orbit_nadir_Nm" in rec:
        fig = disturbance_orbit_figure(
            rec, orbit_period_s, f"CNUSAIL-1 {cfg.spacecraft.configuration}: disturbance torques over one orbit"
        )
        out.append(save_figure(fig, run_dir / "disturbances_orbit.png"))
    if cfg.control.command == "deorbit" or cfg.control.modes.deorbit_at_s is not None:
        out.append(_deorbit_plot(run_dir, rec, x=x, marks=marks, title=title))
    return out


def _deorbit_plot(
    run_dir: Path, rec: Mapping[str, np.ndarray], *, x: np.ndarray, marks: list[float], title: str
) -> Path:
    """Altitude and density, projected sail area fraction and the sail-normal-to-flow angle [min]."""
    fig, axes = new_figure(3, 1, figsize=(9, 8), sharex=True)
    axes[0].plot(x, rec["altitude_m"] / 1e3, "b")
    axes[0].set_ylabel("altitude [km]", color="b")
    a2 = axes[0].twinx()
    a2.semilogy(x, rec["density_kg_m3"], "r", lw=0.8)
    a2.set_ylabel("density [kg/m³]", color="r")
    axes[1].plot(x, np.abs(rec["sail_flow_cos"]), "k")
    axes[1].set_ylabel("|ẑ_B · V̂| (projected area fraction)")
    axes[2].plot(x, rec["sail_normal_flow_angle_deg"], "k")
    axes[2].axhline(5.0, color="g", ls="--", lw=0.8, label="5° (deorbit pointing goal)")
    axes[2].set_ylabel("sail normal to flow [deg]")
    _event_lines(axes, marks)
    axes[2].legend(fontsize=8)
    axes[0].set_title(title + ": orbit and sail-to-flow geometry")
    axes[-1].set_xlabel("time [min]")
    return save_figure(fig, run_dir / "deorbit_flow.png")


def _disturbance_plot(
    run_dir: Path, rec: Mapping[str, np.ndarray], *, cfg: CnusailConfig, orbit_period_s: float, title: str
) -> Path:
    """|torque| of each disturbance source and of the magnetorquers along the run (every mode)."""
    bdot = cfg.control.mode == "bdot"
    x = rec["t"] / (orbit_period_s if bdot else 60.0)
    fig, ax = new_figure(figsize=(9, 4.5))
    dist = rec["torque_dist_body_Nm"]
    for k, src in enumerate(SOURCES):
        mag = np.linalg.norm(dist[:, k], axis=1)
        ax.semilogy(x, np.where(mag > 0, mag, np.nan), lw=0.7, label=_SRC_LABEL[src])
    mag = np.linalg.norm(rec["torque_mtq_body_Nm"], axis=1)
    ax.semilogy(x, np.where(mag > 0, mag, np.nan), lw=0.5, alpha=0.6, label="magnetorquer")
    ax.set(
        xlabel="time [orbits]" if bdot else "time [min]",
        ylabel="|torque| [N m]",
        title=title + ": disturbance torques by source",
    )
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    return save_figure(fig, run_dir / "disturbances.png")


def lifetime_plots(
    run_dir: Path, series: dict[str, np.ndarray], table: list[dict[str, Any]], comparison: dict[str, Any], title: str
) -> list[Path]:
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
            ax.fill_between(
                td,
                series[f"perigee_{key}_m"] / 1e3,
                series[f"apogee_{key}_m"] / 1e3,
                color=colours[reg],
                alpha=0.08 if method == "cowell" else 0.04,
            )
    ax.set_xscale("symlog", linthresh=10.0)
    ax.axhline(120.0, color="k", ls=":", lw=0.8, label="120 km (re-entry)")
    ax.set(
        xlabel="time [days] (linear to 10, log beyond)",
        ylabel="altitude [km]",
        title=title + ": orbit decay, exponential atmosphere (bands: perigee–apogee)",
    )
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
        ax.errorbar(
            row["mean_alt_km"],
            row["lifetime_days"],
            xerr=[[row["mean_alt_km"] - row["perigee_km"]], [row["apogee_km"] - row["mean_alt_km"]]],
            fmt="s",
            color=colours[row["regime"]],
            capsize=4,
            label=f"CNUSAIL-1 {row['regime']}",
        )
    for ref in comparison.get("references", []):
        ax.plot(ref["altitude_km"], ref["observed_days"], "*", ms=12, label=f"{ref['name']} (observed)")
        if ref.get("predicted_days") is not None:
            ax.plot(ref["altitude_km"], ref["predicted_days"], "x", ms=9, label=f"{ref['name']} (this model)")
    ax.set(
        xlabel="initial (mean) altitude [km]",
        ylabel="lifetime [days]",
        title=title + ": lifetime comparison (exponential atmosphere)",
    )
    ax.legend(fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    out.append(save_figure(fig, run_dir / "lifetime_comparison.png"))
    return out
