"""The paper's MSAC run (Vedant & Allison 2019): 1 kHz cycle, 600 s, 1.2·10⁸ RK4 steps, with its wall time.

    python scripts/msac_paper_run.py                            # full 600 s -> runs/msac/paper_1khz
    python scripts/msac_paper_run.py --duration 10 --out runs/msac/paper_1khz_10s
    python scripts/msac_paper_run.py --video                    # also V2 (time-lapse) from the run

Equivalent to ``magsail run magsail_mj/concepts/msac/configs/paper_1khz.toml --out runs/msac/paper_1khz`` plus timing:
the MuJoCo stepping runs natively through ``mujoco.rollout`` in chunks of 200 cycles (no
Python per step; see ``magsail_mj/concepts/msac/runner.py``), checkpointing every 20 simulated
seconds so an interrupted run continues with ``--resume``. Prints one JSON object: the key
figures of ``summary.json`` (MuJoCo vs exact vs lumped per-cycle rotation and secular rates,
angular-momentum drift, actuator loads) and the wall times (total, stepping, per step).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from magsail_mj.config import load_config
from magsail_mj.io import to_jsonable
from magsail_mj.run import run_scenario

REPO = Path(__file__).resolve().parents[1]
KEYS = (
    "theta_gamma_mujoco_rad",
    "theta_gamma_mujoco_std_rad",
    "theta_gamma_first_cycle_rad",
    "theta_gamma_exact_rad",
    "theta_gamma_eq6_model_rad",
    "theta_gamma_eq6_stretch_rad",
    "mujoco_vs_exact_rel_diff",
    "secular_rate_rad_s",
    "rate_slope_rad_s",
    "rate_filtered_mean_rad_s",
    "rate_estimates_rel_diff",
    "predicted_rate_exact_rad_s",
    "predicted_rate_lumped_rad_s",
    "net_rotation_rad",
    "angular_momentum_drift",
    "angmom_drift_max_Nms",
    "angmom_drift_rate_unprojected_Nms_s",
    "hinge_torque_peak_Nm",
    "slide_force_peak_N",
    "tracking_error_bend_max_rad",
    "tracking_error_slide_max_m",
    "cycles_simulated",
    "simulated_time_s",
    "steps",
    "wall_time_s",
    "wall_time_per_step_s",
)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=None, help="simulated seconds (default: the config's 600)")
    ap.add_argument("--out", type=Path, default=REPO / "runs/msac/paper_1khz")
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--video", action="store_true", help="render V2 (time-lapse) into <out>/v2.mp4")
    a = ap.parse_args(argv)
    overrides = ["sim.checkpoint_every_s=20"]
    if a.duration is not None:
        overrides.append(f"sim.duration_s={a.duration}")
    cfg = load_config(REPO / "magsail_mj/concepts/msac/configs/paper_1khz.toml", overrides)
    t0 = time.perf_counter()
    summary = run_scenario(cfg, a.out, overwrite=not a.resume, resume=a.resume, progress=True)
    total = time.perf_counter() - t0
    out = {k: summary.get(k) for k in KEYS}
    out["wall_time_total_s"] = total
    out["run_dir"] = str(summary.run_dir)
    if a.video:
        sys.path.insert(0, str(REPO / "scripts"))
        from msac_videos import make_v2

        t1 = time.perf_counter()
        out["video_v2"] = str(
            make_v2(summary.run_dir, summary.run_dir / "v2.mp4", max_deg_per_frame=20.0, max_frames=3000, fps=60.0)
        )
        out["video_wall_time_s"] = time.perf_counter() - t1
    print(json.dumps(to_jsonable(out), indent=2))
    return 0 if summary.status == "completed" else 3


if __name__ == "__main__":
    sys.exit(main())
