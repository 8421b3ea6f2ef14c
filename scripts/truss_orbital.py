"""Run the orbital truss scenarios (spec §9: detumble, slews I–IV, ablation, sensitivity) and
tabulate their summary keys.

    python scripts/truss_orbital.py                          # detumble + slew_i … slew_iv, 2 workers
    python scripts/truss_orbital.py detumble --video         # one scenario, with its MP4
    python scripts/truss_orbital.py --all                    # + gg_ablation_slew_i + sensitivity/*
    python scripts/truss_orbital.py slew_i --set sim.duration_s=1800 --out runs/short
    python scripts/truss_orbital.py --table-only             # re-tabulate existing run folders

Scenario ids are config stems under models/truss_magnetorquer/ (``sensitivity/<name>`` for the
§9.6 runs). Each run goes to ``<out>/<id>/`` (a normal run folder: summary.json, timeseries.npz,
manifest.json, plots, video.mp4 with ``--video``). The script writes ``<out>/summary.md`` (one
table for detumble-type runs, one for slews) and ``<out>/summary.json`` (id → summary).
``--set key=value`` applies to every run (e.g. ``sim.duration_s=600`` for a short check; the
tables then say so in their ``t_end_s`` column). Runs execute in ``--workers`` processes
(default 2). The first run on a machine without ``runs/lloyd_cache`` computes each new
Lloyd count once (~1.4 s each) and caches it there.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MODELS = REPO / "models" / "truss_magnetorquer"
DEFAULT_IDS = ["detumble", "slew_i", "slew_ii", "slew_iii", "slew_iv"]

DETUMBLE_COLUMNS = [
    ("t_end_s", "t_end [s]"), ("time_rates_below_1e-3_s", "rates stay < 1e-3 from [s]"),
    ("t_rates_below_threshold_first_s", "first < 1e-3 [s]"),
    ("omega_rms_last_1800s_rad_s", "ω rms last 30 min [rad/s]"),
    ("surface_sd_max_m", "σ_SD max [m]"), ("t_surface_sd_max_s", "at [s]"),
    ("edge_angle_max_deg", "edge angle max [°]"),
    ("saturation_fraction", "saturated (either)"), ("sat_fraction_family1", "sat. x1"),
    ("sat_fraction_family2", "sat. y1"),
    ("strut_strain_max", "max strain"), ("failed", "failed"), ("wall_time_s", "wall [s]"),
]
SLEW_COLUMNS = [
    ("t_end_s", "t_end [s]"), ("final_error_deg", "final error [°]"), ("settle_time_s", "stays < 5° from [s]"),
    ("t_err_below_2deg_stay_s", "stays < 2° from [s]"), ("overshoot_deg", "overshoot [°]"),
    ("surface_sd_max_m", "σ_SD max [m]"), ("tumbled", "tumbled"), ("int_T_ac_Nms", "∫|T_ac| [N m s]"),
    ("low_authority_time_s", "low authority [s]"), ("saturation_fraction", "saturated"),
    ("strut_strain_max", "max strain"), ("failed", "failed"), ("wall_time_s", "wall [s]"),
]


def config_path(sid: str) -> Path:
    """``models/truss_magnetorquer/<sid>.toml`` (ValueError naming ``sid`` when missing)."""
    path = MODELS / f"{sid}.toml"
    if not path.is_file():
        raise ValueError(f"scenario id {sid!r}: no config {path.relative_to(REPO)}")
    return path


def all_ids() -> list[str]:
    """Default ids, the ablation and every sensitivity config."""
    sens = sorted(f"sensitivity/{p.stem}" for p in (MODELS / "sensitivity").glob("*.toml")
                  if "scenario = \"detumble\"" in p.read_text() or "scenario = \"slew\"" in p.read_text())
    return DEFAULT_IDS + ["gg_ablation_slew_i"] + sens


def run_one(sid: str, out: str, sets: list[str], video: bool, overwrite: bool, resume: bool) -> dict:
    """Run one scenario into ``<out>/<sid>`` (in a worker process); returns its summary."""
    from magsail_mj.config import load_config
    from magsail_mj.run import run_scenario

    t0 = time.perf_counter()
    cfg = load_config(config_path(sid), sets)
    res = run_scenario(cfg, Path(out) / sid, video=video, overwrite=overwrite, resume=resume, progress=False)
    summary = dict(res)
    summary["script_wall_time_s"] = time.perf_counter() - t0
    return summary


def _fmt(v) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def markdown(results: dict[str, dict], sets: list[str]) -> str:
    """The two summary tables (detumble-type and slew runs) as markdown."""
    lines = ["# Orbital truss scenarios — summary", ""]
    if sets:
        lines += [f"Overrides applied to every run: `{' '.join(sets)}`.", ""]
    for kind, cols in (("detumble", DETUMBLE_COLUMNS), ("slew", SLEW_COLUMNS)):
        rows = {k: v for k, v in results.items() if v.get("scenario") == kind}
        if not rows:
            continue
        lines += [f"## {kind}", "", "| id | status | " + " | ".join(h for _, h in cols) + " |",
                  "|---|---|" + "---|" * len(cols)]
        for sid, s in rows.items():
            lines.append(f"| {sid} | {s.get('status', '?')} | " + " | ".join(_fmt(s.get(k)) for k, _ in cols) + " |")
        lines.append("")
    errors = {k: v for k, v in results.items() if "error" in v}
    if errors:
        lines += ["## errors", ""] + [f"- {k}: {v['error']}" for k, v in errors.items()] + [""]
    return "\n".join(lines)


def load_existing(out: Path, ids: list[str]) -> dict[str, dict]:
    """Summaries of existing run folders ``<out>/<id>/summary.json``."""
    res = {}
    for sid in ids:
        p = out / sid / "summary.json"
        if p.is_file():
            res[sid] = json.loads(p.read_text())
    return res


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ids", nargs="*", help=f"scenario ids (default: {' '.join(DEFAULT_IDS)})")
    ap.add_argument("--all", action="store_true", help="also the ablation and every sensitivity run")
    ap.add_argument("--out", default="runs/truss_orbital", help="output folder (default runs/truss_orbital)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override for every run")
    ap.add_argument("--workers", type=int, default=2, help="parallel runs (default 2)")
    ap.add_argument("--video", action="store_true", help="render video.mp4 in each run folder")
    ap.add_argument("--overwrite", action="store_true", help="replace earlier run folders")
    ap.add_argument("--resume", action="store_true", help="continue runs from their checkpoints")
    ap.add_argument("--table-only", action="store_true", help="only tabulate existing run folders")
    args = ap.parse_args(argv)
    if args.workers < 1:
        ap.error(f"--workers: must be >= 1, got {args.workers}")
    ids = list(args.ids) or (all_ids() if args.all else DEFAULT_IDS)
    if args.all and args.ids:
        ids = list(dict.fromkeys(ids + all_ids()))
    try:
        for sid in ids:
            config_path(sid)
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    results: dict[str, dict] = {}
    if args.table_only:
        results = load_existing(out, ids)
    else:
        with ProcessPoolExecutor(max_workers=args.workers) as ex:
            futs = {ex.submit(run_one, sid, str(out), args.set, args.video, args.overwrite, args.resume): sid
                    for sid in ids}
            for fut in as_completed(futs):
                sid = futs[fut]
                try:
                    results[sid] = fut.result()
                    s = results[sid]
                    print(f"{sid}: {s.get('status')} in {s.get('script_wall_time_s', float('nan')):.0f} s",
                          file=sys.stderr)
                except Exception as err:  # keep the other runs going; report at the end
                    results[sid] = {"status": "error", "error": f"{type(err).__name__}: {err}"}
                    traceback.print_exc()
        results = {sid: results[sid] for sid in ids if sid in results}
    from magsail_mj.io import atomic_path, to_jsonable, write_json

    write_json(out / "summary.json", to_jsonable(results))
    text = markdown(results, args.set)
    with atomic_path(out / "summary.md") as tmp:
        tmp.write_text(text)
    print(text)
    return 1 if any(v.get("status") == "error" for v in results.values()) else 0


if __name__ == "__main__":
    sys.exit(main())
