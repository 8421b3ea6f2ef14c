"""Can the truss slews be done with the rods at all? Authority along the orbit and the reachability bound.

Robb et al. 2022a, Sec. 4.3. For each slew config (orbit, epoch, field model, rods and attitudes
from the config itself; :mod:`magsail_mj.concepts.truss_magnetorquer.reachability`):

* the demanded rotation (angle, axis in body and inertial axes, inertia about it);
* the rest-to-rest bound ``θ_max(T)`` for any controller and any attitude path (dipole torque
  ``|m|_max |B(t)|`` plus the largest gravity-gradient torque, over ``J_min``) at the paper's
  1.5 h and at the run's duration, and the earliest time it allows the slew;
* the same for the eigenaxis paths (torque about the slew axis, its largest value over the path,
  over ``J_e``);
* the authority along a nominal eigenaxis path (versine rest-to-rest in 1.5 h, then held): the
  largest torque about the slew axis, the torque that path needs and the share of it along ``B``
  (which no dipole makes), and the authority about the body axes at the target.

It prints one table per quantity and writes ``reachability.json`` and ``authority.png`` to
``--out`` (``--figure`` also copies the figure there, e.g. for the docs).

    python scripts/truss_slew_reachability.py                      # I–IV and the reversed III, IV
    python scripts/truss_slew_reachability.py slew_iv --out /tmp/r
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
from pathlib import Path

import numpy as np

import magsail_mj
from magsail_mj.concepts.truss_magnetorquer import reachability as rc
from magsail_mj.estimation.attitude import particle_inertia
from magsail_mj.io import atomic_path
from magsail_mj.plotting import new_figure, save_figure
from magsail_mj.quaternion import quat_to_matrix

MODELS = Path(__file__).resolve().parents[1] / "magsail_mj" / "concepts" / "truss_magnetorquer" / "configs"
DEFAULT_IDS = (
    "slew_i",
    "slew_ii",
    "slew_iii",
    "slew_iv",
    "sensitivity/slew_iii_q_ref_Rz_minus90",
    "sensitivity/slew_iv_q_ref_Ry_minus90",
)
PAPER_TIME_S = 5400.0
"""The paper's 'within about 1.5 h'."""
SAMPLE_S = 10.0
"""Field sampling of the analysis [s] (the runs' own field table is sampled every 10 s)."""


def slew_inputs(config_id: str) -> dict:
    """Rods, inertia, attitudes and the field history of one slew config."""
    sc = magsail_mj.load(MODELS / f"{config_id}.toml").scenario
    cfg = sc.cfg
    rl, lat = sc.rod_load, sc.tm.lattice
    d = lat.nodes[rl.rods.ends[:, 1]] - lat.nodes[rl.rods.ends[:, 0]]
    t = np.arange(0.0, cfg.sim.duration_s + 0.5 * SAMPLE_S, SAMPLE_S)
    env = sc.environment.sample_many(t)
    return {
        "zono": rc.rod_dipole_zonotope(d, rl.m_of_rod, rl.rods.family),
        "J": particle_inertia(lat.nodes, sc.tm.masses).tensor,
        "q0": np.asarray(cfg.q0_wxyz, float),
        "q_ref": np.asarray(cfg.maneuver.q_ref_wxyz, float),
        "t": t,
        "B": env["B_eci"],
        "r": env["r_ref_eci"],
        "mu": float(sc.environment.mu),
        "duration_s": float(cfg.sim.duration_s),
    }


def nominal_path(inp: dict, rot: rc.SlewRotation) -> dict:
    """Authority and demand along the versine eigenaxis path of ``PAPER_TIME_S`` (then held)."""
    t, J, e = inp["t"], inp["J"], rot.axis_body
    phi = rot.angle_rad * rc.versine_fraction(t, PAPER_TIME_S)
    tau = np.clip(t / PAPER_TIME_S, 0.0, 1.0)
    phi_dd = np.where(t <= PAPER_TIME_S, rot.angle_rad * 2 * np.pi / PAPER_TIME_S**2 * np.sin(2 * np.pi * tau), 0.0)
    Rs = np.array([quat_to_matrix(q) for q in rc.eigenaxis_attitudes(rot, inp["q0"], phi)])
    B_b = np.einsum("kji,kj->ki", Rs, inp["B"])
    r_b = np.einsum("kji,kj->ki", Rs, inp["r"])
    rn = np.linalg.norm(r_b, axis=1, keepdims=True)
    u = r_b / rn
    T_gg = 3 * inp["mu"] / rn**3 * np.cross(u, u @ J.T)
    phi_d = np.where(t <= PAPER_TIME_S, rot.angle_rad / PAPER_TIME_S * (1 - np.cos(2 * np.pi * tau)), 0.0)
    # J ω̇ + ω × J ω − T_gg with ω = φ̇ e
    T_req = phi_dd[:, None] * (J @ e)[None, :] + (phi_d**2)[:, None] * np.cross(e, J @ e)[None, :] - T_gg
    b = B_b / np.linalg.norm(B_b, axis=1, keepdims=True)
    along_B = np.abs(np.einsum("ki,ki->k", T_req, b))
    h_e = rc.max_torque_about_Nm(inp["zono"], B_b, e)
    R_end = quat_to_matrix(inp["q_ref"])
    B_end = inp["B"] @ R_end  # Rᵀ B for every row
    return {
        "h_e": h_e,
        "T_req_norm": np.linalg.norm(T_req, axis=1),
        "along_B": along_B,
        "h_target_body": np.stack([rc.max_torque_about_Nm(inp["zono"], B_end, a) for a in np.eye(3)], axis=1),
        "h_target_axis": rc.max_torque_about_Nm(inp["zono"], B_end, e),
        "h_path_body": np.stack([rc.max_torque_about_Nm(inp["zono"], B_b, a) for a in np.eye(3)], axis=1),
        "h_path_inertial": np.stack(
            [rc.max_torque_about_Nm(inp["zono"], B_b, np.einsum("kji,j->ki", Rs, a)) for a in np.eye(3)], axis=1
        ),
    }


def analyse(config_id: str) -> tuple[dict, dict]:
    """One slew's figures (JSON-ready) and its series for the figure."""
    inp = slew_inputs(config_id)
    rot = rc.slew_rotation(inp["q0"], inp["q_ref"])
    t, J, zono = inp["t"], inp["J"], inp["zono"]
    J_min = float(np.linalg.eigvalsh(J)[0])
    J_e = float(rot.axis_body @ J @ rot.axis_body)
    B_norm = np.linalg.norm(inp["B"], axis=1)
    tau_mag = rc.attitude_free_torque_bound_Nm(zono, B_norm)
    tau_gg = rc.gravity_gradient_bound_Nm(np.linalg.norm(inp["r"], axis=1), J, mu=inp["mu"])
    tau_any = tau_mag + tau_gg
    th_any = rc.angle_bound_history_rad(t, tau_any, J_min)
    tau_eig = rc.eigenaxis_torque_bound_Nm(zono, rot, inp["q0"], inp["B"], inp["r"], J, mu=inp["mu"])
    th_eig = rc.angle_bound_history_rad(t, tau_eig, J_e)
    nom = nominal_path(inp, rot)
    during = t <= PAPER_TIME_S
    T_run = inp["duration_s"]
    row = {
        "id": config_id,
        "angle_deg": math.degrees(rot.angle_rad),
        "axis_body": np.round(rot.axis_body, 6).tolist(),
        "axis_inertial": np.round(rot.axis_inertial, 6).tolist(),
        "J_axis_kgm2": J_e,
        "J_min_kgm2": J_min,
        "tau_dipole_bound_Nm_range": [float(tau_mag.min()), float(tau_mag.max())],
        "tau_gg_bound_Nm": float(tau_gg.max()),
        "theta_max_any_path_1p5h_deg": math.degrees(float(np.interp(PAPER_TIME_S, t, th_any))),
        "theta_max_any_path_run_deg": math.degrees(float(th_any[-1])),
        "t_earliest_any_path_s": rc.earliest_time_s(t, th_any, rot.angle_rad),
        "tau_eigenaxis_bound_Nm_range": [float(tau_eig.min()), float(tau_eig.max())],
        "theta_max_eigenaxis_1p5h_deg": math.degrees(float(np.interp(PAPER_TIME_S, t, th_eig))),
        "t_earliest_eigenaxis_s": rc.earliest_time_s(t, th_eig, rot.angle_rad),
        "run_duration_s": T_run,
        "nominal_h_axis_Nm_mean_min_max": [
            float(nom["h_e"][during].mean()),
            float(nom["h_e"][during].min()),
            float(nom["h_e"][during].max()),
        ],
        "nominal_h_axis_below_0p02Nm_fraction": float(np.mean(nom["h_e"][during] < 0.02)),
        "nominal_T_req_Nm_max": float(nom["T_req_norm"][during].max()),
        "nominal_along_B_share": float(nom["along_B"][during].sum() / nom["T_req_norm"][during].sum()),
        "target_h_body_Nm_mean": nom["h_target_body"].mean(axis=0).round(4).tolist(),
        "nominal_h_body_xyz_Nm_mean": nom["h_path_body"][during].mean(axis=0).round(4).tolist(),
        "nominal_h_inertial_xyz_Nm_mean": nom["h_path_inertial"][during].mean(axis=0).round(4).tolist(),
        "verdict": "not ruled out"
        if math.degrees(rot.angle_rad) <= math.degrees(float(np.interp(PAPER_TIME_S, t, th_any)))
        else "impossible",
    }
    series = {"t": t, "B_norm": B_norm, "tau_any": tau_any, "th_any": th_any, "th_eig": th_eig, **nom}
    return row, series


def print_tables(rows: list[dict]) -> None:
    """The per-slew figures as two Markdown tables."""
    print(
        "| slew | angle [°] | axis body | axis inertial | J_axis [kg m²] | θ_max any path 1.5 h [°] | "
        "θ_max run [°] | earliest any path [s] | θ_max eigenaxis 1.5 h [°] | earliest eigenaxis [s] | verdict |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['id']} | {r['angle_deg']:.1f} | {r['axis_body']} | {r['axis_inertial']} | {r['J_axis_kgm2']:.4g} | "
            f"{r['theta_max_any_path_1p5h_deg']:.0f} | {r['theta_max_any_path_run_deg']:.0f} | "
            f"{r['t_earliest_any_path_s']:.0f} | {r['theta_max_eigenaxis_1p5h_deg']:.0f} | "
            f"{r['t_earliest_eigenaxis_s']:.0f} | {r['verdict']} |"
        )
    print()
    print(
        "| slew | h about axis on the 1.5 h path: mean / min / max [N m] | time < 0.02 N m | "
        "largest torque the path needs [N m] | its share along B | target: mean h about body x, y, z [N m] |"
    )
    print("|---|---|---|---|---|---|")
    for r in rows:
        m = r["nominal_h_axis_Nm_mean_min_max"]
        low = 100 * r["nominal_h_axis_below_0p02Nm_fraction"]
        print(
            f"| {r['id']} | {m[0]:.3f} / {m[1]:.4f} / {m[2]:.3f} | {low:.1f} % | "
            f"{r['nominal_T_req_Nm_max']:.3f} | {r['nominal_along_B_share']:.2f} | {r['target_h_body_Nm_mean']} |"
        )
    print()
    print("| slew | 1.5 h path: mean largest torque about body x, y, z [N m] | about inertial x, y, z [N m] |")
    print("|---|---|---|")
    for r in rows:
        print(f"| {r['id']} | {r['nominal_h_body_xyz_Nm_mean']} | {r['nominal_h_inertial_xyz_Nm_mean']} |")


def plot(series: dict[str, dict], path: Path) -> Path:
    """Authority along the orbit and the bound ``θ_max(T)`` for every slew analysed."""
    fig, ax = new_figure(3, 1, figsize=(8.0, 9.0), sharex=True)
    first = next(iter(series.values()))
    t_h = first["t"] / 3600.0
    ax[0].plot(t_h, first["tau_any"], "k", label="any attitude: |m|max|B| + gravity-gradient bound")
    for cid, s in series.items():
        ax[0].plot(t_h, s["h_e"], lw=0.9, label=f"{cid}: about the slew axis, 1.5 h eigenaxis path")
    ax[0].set_ylabel("largest torque [N m]")
    ax[0].set_title("Rod authority along the orbit of each slew config", fontsize=9)
    ax[0].legend(fontsize=7)
    for cid, s in series.items():
        ax[1].plot(t_h, s["h_target_axis"], lw=0.9, label=f"{cid}: held at the target, about the slew axis")
    ax[1].set_ylabel("largest torque [N m]")
    ax[1].legend(fontsize=7)
    ax[2].semilogy(t_h[1:], np.degrees(first["th_any"][1:]), "k", label="any path (true bound)")
    for cid, s in series.items():
        ax[2].semilogy(t_h[1:], np.degrees(s["th_eig"][1:]), lw=0.9, label=f"{cid}: eigenaxis paths")
    ax[2].axhline(90.0, color="r", ls="--", label="demanded 90°")
    ax[2].axvline(PAPER_TIME_S / 3600.0, color="0.5", ls=":", label="1.5 h")
    ax[2].set_ylabel("reachable angle θ_max(T) [°]")
    ax[2].set_xlabel("slew time T from the start of the run [h]")
    ax[2].legend(fontsize=7)
    return save_figure(fig, path)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ids", nargs="*", default=list(DEFAULT_IDS), help="slew config stems")
    ap.add_argument("--out", type=Path, default=Path("runs/truss_slew_reachability"), help="output folder")
    ap.add_argument("--figure", type=Path, default=None, help="also copy the figure here")
    args = ap.parse_args(argv)
    for cid in args.ids:
        if not (MODELS / f"{cid}.toml").exists():
            print(f"error: ids: no config magsail_mj/concepts/truss_magnetorquer/configs/{cid}.toml", file=sys.stderr)
            return 2
    rows, series = [], {}
    for cid in args.ids:
        row, s = analyse(cid)
        rows.append(row)
        series[cid] = s
    print_tables(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    with atomic_path(args.out / "reachability.json") as tmp:
        tmp.write_text(json.dumps(rows, indent=2))
    shown = {k: v for k, v in series.items() if k in ("slew_i", "slew_iii", "slew_iv")} or series
    fig_path = plot(shown, args.out / "authority.png")
    if args.figure is not None:
        shutil.copyfile(fig_path, args.figure)
    return 0


if __name__ == "__main__":
    sys.exit(main())
