"""Run CNUSAIL-1 scenarios (Yoo et al. 2016) into run folders and print their key figures.

One line per scenario (run folder ``runs/cnusail/<id>`` by default):

    python scripts/cnusail_scenarios.py detumble_pre          # B-dot, stowed
    python scripts/cnusail_scenarios.py detumble_post         # B-dot, deployed
    python scripts/cnusail_scenarios.py nadir_pre             # eigen-axis nadir slew, stowed
    python scripts/cnusail_scenarios.py nadir_post            # eigen-axis nadir slew, deployed
    python scripts/cnusail_scenarios.py pd_vs_eigenaxis       # S5b (scripts/cnusail_pd_vs_eigenaxis.py: S5a + S5b)
    python scripts/cnusail_scenarios.py deorbit               # deorbit, fixed gains
    python scripts/cnusail_scenarios.py deorbit_recalc        # deorbit, gain recalculation
    python scripts/cnusail_scenarios.py lifetime              # orbital lifetime (scripts/cnusail_lifetime.py)
    python scripts/cnusail_scenarios.py --all [--video]       # all of them

Each is the same as ``magsail run magsail_mj/concepts/cnusail/configs/<id>.toml --out runs/cnusail/<id>``; ``--set``
overrides config keys (e.g. ``--set sim.duration_s=600`` for a quick look).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import magsail_mj  # noqa: F401  (chooses the GL backend before mujoco is imported)
from magsail_mj.config import load_config
from magsail_mj.run import run_scenario

ROOT = Path(__file__).resolve().parents[1]
IDS = (
    "detumble_pre",
    "detumble_post",
    "nadir_pre",
    "nadir_post",
    "pd_vs_eigenaxis",
    "deorbit",
    "deorbit_recalc",
    "lifetime",
)
KEYS = (
    "detumble_time_s",
    "slew_time_s",
    "max_slew_rate_deg_s",
    "pointing_error_max_deg",
    "wheel_speed_max_rpm",
    "unloading_active_fraction",
    "eigen_angle_initial_deg",
    "slew_time_ideal_s",
    "axis_deviation_max_rad",
    "detumble_time_below_1p0dps_s",
    "rate_mean_last_orbit_rad_s",
    "mtq_energy_J",
    "sail_area_mean_m2",
    "fraction_normal_within_5deg_of_flow",
    "gain_recalc_count",
    "error_max_after_perigee_1_rad",
    "error_max_after_perigee_2_rad",
    "lifetime_nadir_days",
    "lifetime_deorbit_days",
    "lifetime_tumbling_days",
    "step_cost_us",
    "wall_time_s",
)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ids", nargs="*", help="scenario ids (default with --all: every one)")
    ap.add_argument("--all", action="store_true", help="run every scenario")
    ap.add_argument("--out", default=str(ROOT / "runs" / "cnusail"), help="parent folder of the run folders")
    ap.add_argument("--video", action="store_true", help="also render video.mp4 (attitude runs)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    ids = list(IDS) if args.all else args.ids
    if not ids:
        ap.error("give scenario ids or --all")
    table = {}
    for sid in ids:
        cfg = load_config(ROOT / "magsail_mj" / "concepts" / "cnusail" / "configs" / f"{sid}.toml", args.set)
        out = run_scenario(
            cfg, Path(args.out) / sid, overwrite=True, progress=False, video=args.video and cfg.kind == "attitude"
        )
        table[sid] = {k: out[k] for k in KEYS if k in out}
        print(json.dumps({sid: table[sid]}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
