"""Reproduce the distributed-vs-centralised torque experiment of the truss magnetorquer paper.

Runs the selected runs of the sweep file ``models/sweeps/truss_dist_vs_central.toml`` (configs
``magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_{a,b,c}_{distributed,central}_{bangbang,versine}.toml``)
with the sweep engine (:func:`magsail_mj.sweep.run_sweep`: Dask workers, valid earlier runs reused,
``sweep_summary.json``/``.csv``), then writes into ``--out``:

- one run folder per config (summary.json, timeseries.zarr, plots, manifest);
- ``comparison.md``: the table of summary figures of all runs, plus the central/distributed
  ratio of the maximum surface SD per case and profile;
- ``<profile>_cases.png``: φ, ω₁ and surface SD vs time, central and distributed, per case,
  with the rigid-body response overlaid (like the paper's Figs. 6–8 and 11–13); a run that
  ended early ends in an ✕ with its cause (structure failed: the strut and its strain);
- ``torque_profiles.png``: the two profiles (like Fig. 10);
- with ``--video``: ``case_<x>_<profile>_side_by_side.mp4`` (central | distributed).

    python scripts/dist_vs_central.py                               # all twelve
    python scripts/dist_vs_central.py --cases c --profiles bangbang --video   # the main job
"""  # noqa: E501

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from magsail_mj.control.profiles import bang_bang_off, versine
from magsail_mj.plotting import mark_run_end, new_figure, save_figure
from magsail_mj.records import STORE_NAME, lazy_arrays
from magsail_mj.render import render_run
from magsail_mj.render.ending import end_reason, read_end_status
from magsail_mj.sweep import FINISHED, load_sweep, run_sweep

REPO = Path(__file__).resolve().parents[1]
#: the series of a case figure, read from each run's record store
CASE_SERIES = ("t", "phi_rad", "omega_body_rad_s", "surface_sd_m", "phi_rigid_rad", "omega_rigid_rad_s")
SWEEP = REPO / "models" / "sweeps" / "truss_dist_vs_central.toml"
#: frames of each side-by-side video
VIDEO_FRAMES = 360
KEYS = (
    "status",
    "t_end_s",
    "rotation_x1_final_rad",
    "phi_rigid_final_rad",
    "off_axis_rotation_max_rad",
    "omega1_peak_rad_s",
    "surface_sd_max_m",
    "t_surface_sd_max_s",
    "strain_energy_max_J",
    "strut_strain_max",
    "surface_sd_after_off_mean_m",
    "failed",
)


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if v is None:
        return "–"
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def comparison_table(summaries: dict[str, dict]) -> str:
    """Markdown table of the runs' key figures and the central/distributed SD ratios."""
    lines = ["| run | " + " | ".join(KEYS) + " |", "|---" * (len(KEYS) + 1) + "|"]
    for name in sorted(summaries):
        lines.append(f"| {name} | " + " | ".join(_fmt(summaries[name].get(k)) for k in KEYS) + " |")
    lines += ["", "| case | profile | max SD central / distributed |", "|---|---|---|"]
    for name in sorted(summaries):
        if "_central_" not in name:
            continue
        other = name.replace("_central_", "_distributed_")
        if other in summaries:
            case, _, prof = name.split("_", 1)[1].partition("_central_")
            failed = [
                label
                for label, run in (("central", name), ("distributed", other))
                if summaries[run].get("status") != "completed"
            ]
            if failed:  # a failed structure is reported as failed, never put into a ratio
                cell = "no ratio: " + ", ".join(
                    f"{label} {summaries[run]['status']}"
                    for label, run in (("central", name), ("distributed", other))
                    if label in failed
                )
            else:
                cell = f"{summaries[name]['surface_sd_max_m'] / summaries[other]['surface_sd_max_m']:.3g}"
            lines.append(f"| {case.upper()} | {prof} | {cell} |")
    return "\n".join(lines) + "\n"


def case_figure(out: Path, profile: str, cases: list[str]) -> Path:
    """φ, ω₁ and surface SD vs time for each case, central and distributed side by side.

    A run that ended early (structure failed, diverged, stopped: its ``summary.json``) has its
    curves end in an ✕, and the cause written beside the surface SD curve's end
    (``central: structure failed at 646 s: strut 1330 strain 0.501 > 0.5``)."""
    fig, axs = new_figure(3, len(cases), figsize=(5 * len(cases), 8), squeeze=False, sharex=True)
    for col, case in enumerate(cases):
        for place, style in (("central", "-"), ("distributed", "-")):
            run = out / f"case_{case}_{place}_{profile}"
            if not (run / STORE_NAME).is_dir():
                continue
            stored = lazy_arrays(run)  # the figure's series only (not the lattice's qpos)
            ts = {name: stored[name][...] for name in CASE_SERIES}
            curves = [
                axs[0, col].plot(ts["t"], ts["phi_rad"], style, label=place)[0],
                axs[1, col].plot(ts["t"], ts["omega_body_rad_s"][:, 0], style, label=place)[0],
                axs[2, col].plot(ts["t"], ts["surface_sd_m"], style, label=place)[0],
            ]
            end = read_end_status(run)
            if end.get("status") not in (None, "completed"):
                reason = end_reason(end, t_last_s=float(ts["t"][-1]))
                for row, curve in enumerate(curves):
                    mark_run_end(
                        axs[row, col],
                        curve.get_xdata(),
                        curve.get_ydata(),
                        f"{place}: {reason}".replace(" s: ", " s:\n", 1),
                        colour=curve.get_color(),
                        annotate=row == 2,
                    )
            rigid_t, rigid_phi, rigid_w = ts["t"], ts["phi_rigid_rad"], ts["omega_rigid_rad_s"]
        axs[0, col].plot(rigid_t, rigid_phi, "k--", lw=1, label="rigid")
        axs[1, col].plot(rigid_t, rigid_w, "k--", lw=1, label="rigid")
        axs[0, col].set_title(f"Case {case.upper()} ({profile})")
        axs[0, col].set_ylabel("φ [rad]")
        axs[1, col].set_ylabel("ω₁ [rad/s]")
        axs[2, col].set_ylabel("surface SD [m]")
        axs[2, col].set_xlabel("t [s]")
        axs[0, col].legend()
    return save_figure(fig, out / f"{profile}_cases.png")


def profile_figure(out: Path) -> Path:

    t = np.linspace(0, 1800, 3601)
    fig, ax = new_figure(figsize=(7, 3.5))
    ax.plot(t, bang_bang_off(t, tau_max=0.1, t_end=1800), label="bang-bang-off")
    ax.plot(t, versine(t, tau_max=0.1, t_end=1800), label="versine (Eq. 9, corrected)")
    ax.set(xlabel="t [s]", ylabel="τ about x1 [N m]")
    ax.legend()
    return save_figure(fig, out / "torque_profiles.png")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="runs/dist_vs_central", help="output folder")
    ap.add_argument("--cases", nargs="+", default=["a", "b", "c"], choices=["a", "b", "c"])
    ap.add_argument("--profiles", nargs="+", default=["bangbang", "versine"], choices=["bangbang", "versine"])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--video", action="store_true", help="render the side-by-side MP4s")
    ap.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override for every run, e.g. --set sim.duration_s=120",
    )
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    ids = [f"case_{c}_{p}_{prof}" for c in args.cases for prof in args.profiles for p in ("central", "distributed")]
    t0 = time.perf_counter()
    sweep = load_sweep(SWEEP, extra_overrides=tuple(args.set), only=ids)
    records = run_sweep(sweep, out, workers=args.workers, log=lambda line: print(line, file=sys.stderr))
    summaries = {r["id"]: r["summary"] for r in records if r["id"] in ids and r["status"] in FINISHED}
    for name in sorted(summaries):
        summary = summaries[name]
        print(
            f"{name}: {summary['status']}, "
            f"φ_end = {summary.get('rotation_x1_final_rad', float('nan')):.4g} rad, "
            f"max SD = {summary['surface_sd_max_m']:.4g} m",
            file=sys.stderr,
        )
    table = comparison_table(summaries)
    (out / "comparison.md").write_text(table)
    for prof in args.profiles:
        case_figure(out, prof, args.cases)
    profile_figure(out)
    videos = []
    if args.video:
        for c in args.cases:
            for prof in args.profiles:
                central, dist = out / f"case_{c}_central_{prof}", out / f"case_{c}_distributed_{prof}"
                if central.name in summaries and dist.name in summaries:
                    videos.append(
                        render_run(
                            central,
                            out / f"case_{c}_{prof}_side_by_side.mp4",
                            compare=dist,
                            labels=["centralised", "distributed"],
                            max_frames=VIDEO_FRAMES,
                            fps=30,
                        )
                    )
    print(table)
    print(
        json.dumps(
            {
                "runs": len(summaries),
                "wall_time_s": round(time.perf_counter() - t0, 1),
                "comparison": str(out / "comparison.md"),
                "videos": [str(v) for v in videos],
            },
            indent=2,
        )
    )
    return 0 if len(summaries) == len(ids) else 1


if __name__ == "__main__":
    sys.exit(main())
