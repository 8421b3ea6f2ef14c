"""The CNUSAIL-1 108° slew with the PD law (Yoo et al. 2016, Eq. 40) and the eigen-axis law (Eqs. 28–38), compared.

    python scripts/cnusail_pd_vs_eigenaxis.py [--out runs/cnusail/pd_vs_eigenaxis_cmp] [--video]

Runs ``magsail_mj/concepts/cnusail/configs/pd_vs_eigenaxis.toml`` twice (``control.mode = "pd"`` and ``"eigen_axis"``,
everything else equal: same k = 2ω_n², c = 2ζω_n, wheels, limits, disturbances), writes both run
folders, an overlay figure of the error histories and of the rotation-axis deviation from the
initial eigen-axis (``comparison.png``), ``comparison.json`` with both summaries side by side and,
with ``--video``, a side-by-side MP4 (S5a | S5b).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import magsail_mj  # noqa: F401  (chooses the GL backend before mujoco is imported)
from magsail_mj.config import load_config
from magsail_mj.export import read_timeseries
from magsail_mj.io import write_json
from magsail_mj.plotting import save_figure
from magsail_mj.render import render_run
from magsail_mj.run import run_scenario

ROOT = Path(__file__).resolve().parents[1]
KEYS = (
    "slew_time_s",
    "slew_time_ideal_s",
    "max_slew_rate_deg_s",
    "time_rate_above_1p05_limit_s",
    "axis_deviation_max_rad",
    "pointing_error_max_deg",
    "wheel_speed_max_rpm",
    "torque_saturated_time_s",
    "unloading_active_fraction",
    "eigen_angle_initial_deg",
)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "runs" / "cnusail" / "pd_vs_eigenaxis_cmp"))
    ap.add_argument("--video", action="store_true")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    out = Path(args.out)
    res = {}
    for law in ("pd", "eigen_axis"):
        cfg = load_config(
            ROOT / "magsail_mj" / "concepts" / "cnusail" / "configs" / "pd_vs_eigenaxis.toml",
            [*args.set, f"control.mode={law}"],
        )  # noqa: E501
        res[law] = run_scenario(cfg, out / law, overwrite=True, progress=False, video=args.video)
    table = {law: {k: res[law].get(k) for k in KEYS} for law in res}
    write_json(out / "comparison.json", table)
    print(json.dumps(table, indent=2))

    fig, axes = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
    for law, ls in (("pd", "--"), ("eigen_axis", "-")):
        ts = read_timeseries(out / law)
        x = ts["t"] / 60
        axes[0].plot(x, ts["theta_e_deg"], ls, label=law)
        axes[1].plot(x, np.degrees(np.linalg.norm(ts["omega_e_rad_s"], axis=1)), ls, label=law)
        axes[2].plot(x, ts["axis_deviation_deg"], ls, label=law)
    axes[0].axhspan(0, 5, color="g", alpha=0.15)
    axes[0].set_ylabel("θ_e [deg]")
    axes[1].axhline(0.3, color="r", ls=":", lw=0.8)
    axes[1].set_ylabel("|ω_e| [°/s]")
    axes[2].set_ylabel("axis deviation from initial eigen-axis [deg]")
    axes[2].set_xlabel("time [min]")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend()
    axes[0].set_title("CNUSAIL-1: 108° slew, PD vs eigen-axis")
    save_figure(fig, out / "comparison.png")
    if args.video:
        render_run(
            out / "pd",
            out / "pd_vs_eigenaxis.mp4",
            compare=out / "eigen_axis",
            labels=["PD (S5a)", "eigen-axis (S5b)"],
            fps=30,
            max_frames=json.loads((out / "pd" / "manifest.json").read_text())["render"]["max_frames"],
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
