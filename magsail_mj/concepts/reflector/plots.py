"""Plots of a reflector run: time in hours, caps as dashed lines.

Detumble: ``body_rates.png`` (3 components), ``omega_norm.png`` (log), ``torque.png`` (components
and |T| with the per-path cap), ``currents.png``, ``momentum.png`` (|h| with the bound
|h₀| − T_cap t, and h·B̂).

Pitch: ``psi_tracking.png`` ((a) ψ actual and reference, unwrapped and wrapped to [0, π); (b) ψ̇),
``attitude_error.png`` (linear and log), ``torque.png`` (T_ref and T_act against the cap),
``reference.png`` (ψ_c, ψ̇, ψ̈ over the nominal run), ``feedforward_torque.png`` (I₂|ψ̈| for both
densities, log, with the cap), ``field.png`` (B_x, B_z, |B| along the orbit); the per-pass table
``passes.json`` is written by the pitch task's ``data_files``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from magsail_mj.plotting import new_figure, save_figure
from magsail_mj.concepts.reflector.config import ReflectorConfig

__all__ = ["detumble_plots", "pitch_plots"]


def _positive(x: np.ndarray) -> np.ndarray:
    return np.where(x > 0, x, np.nan)


def detumble_plots(run_dir: Path, series: dict[str, np.ndarray], *, cfg: ReflectorConfig, cap_Nm: float) -> list[Path]:
    """Scenario A figures (module docstring) of the series of
    :func:`magsail_mj.concepts.reflector.metrics.detumble_outputs`; ``cap_Nm``: per-path torque cap."""
    run_dir = Path(run_dir)
    th = series["time_h"]
    cap = cap_Nm
    label = f"{cfg.scenario} ({cfg.control.law}, ω_k = {cfg.control.omega_k_rad_s:g} rad/s, field {cfg.field.frame})"
    out = []

    fig, ax = new_figure(figsize=(9, 4))
    for k, c in enumerate("xyz"):
        ax.plot(th, series["omega_body_rad_s"][:, k], label=f"ω_{c}")
    ax.set_xlabel("time [h]"), ax.set_ylabel("body rate [rad/s]"), ax.set_title(label)
    ax.grid(alpha=0.3), ax.legend()
    out.append(save_figure(fig, run_dir / "body_rates.png"))

    fig, ax = new_figure(figsize=(9, 4))
    ax.semilogy(th, _positive(series["omega_norm_rad_s"]))
    for v in (1e-2, 1e-3, 1e-4):
        ax.axhline(v, color="k", ls="--", lw=0.7, alpha=0.5)
    ax.set_xlabel("time [h]"), ax.set_ylabel("|ω| [rad/s]"), ax.set_title(label)
    ax.grid(alpha=0.3, which="both")
    out.append(save_figure(fig, run_dir / "omega_norm.png"))

    T = np.asarray(series["torque_body_Nm"]) if "torque_body_Nm" in series else None
    fig, ax = new_figure(figsize=(9, 4))
    if T is not None:
        for k, c in enumerate("xyz"):
            ax.plot(th, T[:, k], lw=0.8, label=f"T_{c}")
    ax.plot(th, series["T_norm_Nm"], "k", lw=1.0, label="|T|")
    for v in (cap, -cap):
        ax.axhline(v, color="r", ls="--", lw=0.8)
    ax.set_xlabel("time [h]"), ax.set_ylabel("torque, body axes [N m]")
    ax.set_title(f"torque; per-path cap T_max = {cap:.4g} N m (dashed)")
    ax.grid(alpha=0.3), ax.legend()
    out.append(save_figure(fig, run_dir / "torque.png"))

    fig, ax = new_figure(figsize=(9, 4))
    cur = series.get("currents_A")
    if cur is not None:
        ax.plot(th, cur[:, 0], label="x-coil")
        ax.plot(th, cur[:, 1], label="y-coil")
    I_max = cfg.coil.I_max_A
    for v in (I_max, -I_max):
        ax.axhline(v, color="r", ls="--", lw=0.8)
    ax.set_xlabel("time [h]"), ax.set_ylabel("path current [A]")
    ax.set_title("path currents (positive = dipole along the path's +axis)")
    ax.grid(alpha=0.3), ax.legend()
    out.append(save_figure(fig, run_dir / "currents.png"))

    fig, ax = new_figure(figsize=(9, 4))
    h = series["h_norm_Nms"]
    t = th * 3600.0
    ax.plot(th, h, label="|h|")
    ax.plot(th, np.maximum(h[0] - cap * t, 0.0), "r--", lw=0.8, label="|h₀| − T_max t")
    ax.plot(th, series["h_along_B_Nms"], label="h·B̂")
    ax.set_xlabel("time [h]"), ax.set_ylabel("angular momentum [N m s]")
    ax.grid(alpha=0.3), ax.legend()
    out.append(save_figure(fig, run_dir / "momentum.png"))
    return out


def pitch_plots(
    run_dir: Path,
    series: dict[str, np.ndarray],
    *,
    cfg: ReflectorConfig,
    cap_Nm: float,
    orbit_period_s: float,
) -> list[Path]:
    """Scenario B figures (module docstring) of the series of
    :func:`magsail_mj.concepts.reflector.metrics.pitch_outputs`; time axes in hours, the orbit of
    ``orbit_period_s`` [s], the cap ``cap_Nm`` [N m]."""
    run_dir = Path(run_dir)
    th = series["time_h"]
    cap = cap_Nm
    sigma = 1e3 * cfg.plate.areal_density_kg_m2
    label = (
        f"{cfg.scenario}: σ = {sigma:g} g/m², rate term {cfg.control.rate_term}"
        + (", feed-forward" if cfg.control.feedforward else "")
        + f", cap {cap:.3g} N m"
    )
    out = []
    psi_ref = np.radians(series["psi_ref_deg"])

    fig, axes = new_figure(3, 1, figsize=(10, 9), sharex=True)
    ax = axes[0]
    ax.plot(th, np.degrees(psi_ref), "k", lw=1.2, label="ψ_ref (unwrapped)")
    ax.plot(th, series["psi_act_deg"], "C1--", lw=1.0, label="ψ actual")
    ax.set_ylabel("ψ [deg]"), ax.set_title("(a) " + label), ax.legend(), ax.grid(alpha=0.3)
    ax = axes[1]
    ax.plot(th, np.degrees(series["psi_ref_wrapped_rad"]), "k.", ms=1, label="ψ_ref mod π (Eq. 12)")
    ax.plot(th, np.degrees(series["psi_act_wrapped_rad"]), "C1.", ms=0.6, label="ψ actual mod π")
    ax.set_ylabel("ψ in [0, 180) [deg]"), ax.legend(markerscale=8), ax.grid(alpha=0.3)
    ax = axes[2]
    ax.plot(th, np.degrees(series.get("psi_dot_ref_rad_s", np.full_like(th, np.nan))), "k", lw=1.2, label="ψ̇_ref")
    ax.plot(th, np.degrees(series["psi_dot_act_rad_s"]), "C1--", lw=1.0, label="ψ̇ actual")
    ax.set_ylabel("ψ̇ [deg/s]"), ax.set_xlabel("time [h]"), ax.set_title("(b)"), ax.legend(), ax.grid(alpha=0.3)
    out.append(save_figure(fig, run_dir / "psi_tracking.png"))

    fig, axes = new_figure(2, 1, figsize=(10, 6), sharex=True)
    axes[0].plot(th, series["err_deg"])
    axes[0].set_ylabel("attitude error [deg]"), axes[0].set_title(label)
    axes[1].semilogy(th, _positive(series["err_deg"]))
    axes[1].set_ylabel("attitude error [deg] (log)"), axes[1].set_xlabel("time [h]")
    for a in axes:
        for v in (1.0, 5.0):
            a.axhline(v, color="r", ls="--", lw=0.7)
        a.grid(alpha=0.3, which="both")
    out.append(save_figure(fig, run_dir / "attitude_error.png"))

    fig, ax = new_figure(figsize=(10, 4))
    ax.plot(th, series["T_ref_norm_Nm"], lw=0.9, label="|T_ref|")
    ax.plot(th, series["T_act_norm_Nm"], "--", lw=0.9, label="|T_act|")
    ax.axhline(cap, color="r", ls="--", lw=0.8, label="cap")
    ax.set_yscale("log"), ax.set_xlabel("time [h]"), ax.set_ylabel("torque [N m]"), ax.set_title(label)
    ax.grid(alpha=0.3, which="both"), ax.legend()
    out.append(save_figure(fig, run_dir / "torque.png"))

    rt = series["ref_t_s"] / 3600.0
    fig, axes = new_figure(3, 1, figsize=(10, 8), sharex=True)
    axes[0].plot(rt, np.degrees(series["ref_psi_c_rad"]))
    axes[0].set_ylabel("ψ_c [deg]")
    axes[1].plot(rt, np.degrees(series["ref_psi_dot_rad_s"]))
    axes[1].set_ylabel("ψ̇ [deg/s]")
    axes[2].plot(rt, np.degrees(series["ref_psi_ddot_rad_s2"]))
    axes[2].set_ylabel("ψ̈ [deg/s²]"), axes[2].set_xlabel("time [h]")
    axes[0].set_title("steering reference over the nominal run (no dynamics)")
    for a in axes:
        a.grid(alpha=0.3)
    out.append(save_figure(fig, run_dir / "reference.png"))

    fig, ax = new_figure(figsize=(10, 4))
    ax.semilogy(rt, _positive(series["ref_torque_ff_sigma100_Nm"]), label="I₂|ψ̈|, σ = 100 g/m²")
    ax.semilogy(rt, _positive(series["ref_torque_ff_sigma10_Nm"]), label="I₂|ψ̈|, σ = 10 g/m²")
    ax.axhline(cap, color="r", ls="--", lw=0.9, label=f"cap {cap:.3g} N m")
    ax.set_xlabel("time [h]"), ax.set_ylabel("feed-forward pitch torque [N m]")
    ax.grid(alpha=0.3, which="both"), ax.legend()
    out.append(save_figure(fig, run_dir / "feedforward_torque.png"))

    fig, ax = new_figure(figsize=(10, 4))
    B = series["ref_B_T"] * 1e6
    ax.plot(rt, B[:, 0], label="B_x")
    ax.plot(rt, B[:, 2], label="B_z")
    ax.plot(rt, np.linalg.norm(B, axis=1), "k", label="|B|")
    ax.set_xlabel("time [h]"), ax.set_ylabel("field [µT]"), ax.set_title("dipole field along the orbit (Eq. 11)")
    ax.grid(alpha=0.3), ax.legend()
    out.append(save_figure(fig, run_dir / "field.png"))
    return out
