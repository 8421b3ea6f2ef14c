"""Rigid-body counterparts of the orbital truss slews (diagnostic; Robb et al. 2022a, Sec. 4.3).

Each id is a config stem under magsail_mj/concepts/truss_magnetorquer/configs/ (``sensitivity/<name>`` allowed). The
scenario's controller, allocation, Lloyd selection, rod dipoles, IGRF field and orbit are kept;
the lattice becomes one rigid body with the particle inertia and the classical gravity-gradient
torque (:mod:`magsail_mj.concepts.truss_magnetorquer.rigid_orbital`). A slew that fails here as on the
flexible lattice fails because of the law, its gains or the manoeuvre definition.

    python scripts/truss_rigid_slew.py slew_i slew_iii slew_iv          # 15 120 s each
    python scripts/truss_rigid_slew.py slew_iii --duration 3600 --out /tmp/rigid.json
    python scripts/truss_rigid_slew.py slew_iii --actuation ideal_perp_B   # unsaturated, T ⊥ B
    python scripts/truss_rigid_slew.py mpc/slew_iv_mpc --dt 1.0         # receding-horizon control
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

import magsail_mj
from magsail_mj.concepts.truss_magnetorquer.rigid_orbital import simulate_rigid
from magsail_mj.estimation.attitude import particle_inertia
from magsail_mj.io import atomic_path
from magsail_mj.concepts.truss_magnetorquer.orbital import first_time_below, stay_time_below, tumbled

MODELS = Path(__file__).resolve().parents[1] / "magsail_mj" / "concepts" / "truss_magnetorquer" / "configs"


def rigid_slew(
    config_id: str,
    *,
    duration_s: float | None,
    gravity_gradient: bool,
    actuation: str = "rods",
    dt_s: float | None = None,
) -> dict:
    """Run one slew config rigidly; its summary figures (same definitions as the flexible run).

    ``dt_s``: RK4 step and controller call interval [s] (default the config's ``sim.timestep_s``).
    ``max_error_after_arrival_deg``: the largest error after the first sample within 5°;
    ``int_T_mag_Nms``: ``∫|m × B| dt`` (trapezoid over the 10 s records)."""
    sc = magsail_mj.load(MODELS / f"{config_id}.toml").scenario  # the scenario with its rod load wired
    cfg = sc.cfg
    if cfg.control.kind not in ("quat_pd", "mpc"):
        raise SystemExit(f"{config_id}: control.kind is {cfg.control.kind!r}; only slews (quat_pd, mpc) run here")
    controller = sc.make_controller()
    duration = float(duration_s if duration_s is not None else cfg.sim.duration_s)
    t0 = time.perf_counter()
    run = simulate_rigid(
        controller=controller,
        rod_load=sc.rod_load,
        environment=sc.environment,
        nodes_body=sc.tm.lattice.nodes,
        masses=sc.tm.masses,
        inertia=particle_inertia(sc.tm.lattice.nodes, sc.tm.masses).tensor,
        q0_wxyz=np.asarray(cfg.q0_wxyz),
        omega0_body=np.asarray(cfg.initial.omega0_rad_s),
        q_ref_wxyz=np.asarray(cfg.maneuver.q_ref_wxyz),
        duration_s=duration,
        dt=dt_s if dt_s is not None else cfg.sim.timestep_s,
        gravity_gradient=gravity_gradient,
        actuation=actuation,
    )
    err = np.radians(run.err_deg)
    w_norm = np.linalg.norm(run.omega, axis=1)
    steps = np.arange(1800.0, run.t[-1] + 1e-9, 1800.0)
    arrived = np.flatnonzero(run.err_deg < 5.0)
    T_norm = np.linalg.norm(run.T_mag, axis=1)
    return {
        "id": config_id,
        "gravity_gradient": gravity_gradient,
        "actuation": actuation,
        "duration_s": duration,
        "final_error_deg": float(run.err_deg[-1]),
        "settle_time_s": stay_time_below(run.t, err, math.radians(5.0)),
        "t_err_below_5deg_first_s": first_time_below(run.t, err, math.radians(5.0)),
        "tumbled": tumbled(err, w_norm),
        "saturation_fraction": float(controller.stats[3] / max(controller.stats[0], 1)),
        "err_at_0p5h_steps_deg": [round(float(np.interp(s, run.t, run.err_deg)), 1) for s in steps],
        "max_error_after_arrival_deg": float(run.err_deg[arrived[0] :].max()) if arrived.size else math.nan,
        "omega_final_rad_s": float(w_norm[-1]),
        "int_T_mag_Nms": float(np.sum(0.5 * (T_norm[1:] + T_norm[:-1]) * np.diff(run.t))),
        "T_mag_max_Nm": float(T_norm.max()),
        "T_gg_max_Nm": float(np.linalg.norm(run.T_gg, axis=1).max()),
        "wall_time_s": time.perf_counter() - t0,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ids", nargs="+", help="slew config stems (e.g. slew_iii sensitivity/slew_iv_q_ref_Ry_minus90)")
    ap.add_argument("--duration", type=float, default=None, help="simulated seconds (default: the config's)")
    ap.add_argument("--no-gg", action="store_true", help="drop the gravity-gradient torque")
    ap.add_argument(
        "--actuation",
        choices=("rods", "ideal", "ideal_perp_B"),
        default="rods",
        help="rods (the scenario's), ideal (T_ref itself) or ideal_perp_B (T_ref less its part along B)",
    )
    ap.add_argument("--dt", type=float, default=None, help="RK4 and controller step [s] (default: the config's)")
    ap.add_argument("--out", type=Path, default=None, help="also write the figures as JSON here")
    args = ap.parse_args(argv)
    for config_id in args.ids:
        if not (MODELS / f"{config_id}.toml").exists():
            print(
                f"error: ids: no config magsail_mj/concepts/truss_magnetorquer/configs/{config_id}.toml",
                file=sys.stderr,
            )  # noqa: E501
            return 2
    rows = []
    for config_id in args.ids:
        row = rigid_slew(
            config_id,
            duration_s=args.duration,
            gravity_gradient=not args.no_gg,
            actuation=args.actuation,
            dt_s=args.dt,
        )
        rows.append(row)
        print(json.dumps(row))
    if args.out is not None:
        with atomic_path(args.out) as tmp:
            tmp.write_text(json.dumps(rows, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
