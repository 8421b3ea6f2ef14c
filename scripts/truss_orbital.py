"""Run the orbital truss scenarios (Robb et al. 2022a, Sec. 4.2–4.3: detumble, slews I–IV;
our ablation and sensitivity runs) and tabulate their summary keys.

    python scripts/truss_orbital.py                          # detumble + slew_i … slew_iv, 2 workers
    python scripts/truss_orbital.py detumble --video         # one scenario, with its MP4
    python scripts/truss_orbital.py --all                    # + gg_ablation_slew_i + sensitivity/*
    python scripts/truss_orbital.py slew_i --set sim.duration_s=1800 --out runs/short
    python scripts/truss_orbital.py --table-only             # re-tabulate existing run folders

Scenario ids are the run ids of the sweep file ``models/sweeps/truss_orbital.toml`` (config
stems under magsail_mj/concepts/truss_magnetorquer/configs/, ``sensitivity/<name>`` for the sensitivity runs).
The selected
runs go through the sweep engine (:func:`magsail_mj.sweep.run_sweep`: ``--workers`` Dask worker
processes, default 2; a valid earlier run folder is reused, a stopped one continues from its
checkpoint, ``--overwrite`` reruns) into ``<out>/<id>/`` (a normal run folder: summary.json,
timeseries.zarr, manifest.json, plots, video.mp4 with ``--video``), with ``sweep_summary.json``/
``.csv`` beside them. The script writes ``<out>/summary.md`` (one table for detumble-type runs,
one for slews) and ``<out>/summary.json`` (id → summary). ``--set key=value`` applies to every
run (e.g. ``sim.duration_s=600`` for a short check; the tables then say so in their ``t_end_s``
column). The first run on a machine without ``runs/lloyd_cache`` computes each new Lloyd count
once (~1.4 s each) and caches it there.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from pathlib import Path

from magsail_mj.config import ConfigError
from magsail_mj.io import atomic_path, to_jsonable, write_json
from magsail_mj.sweep import FINISHED, Sweep, load_sweep, run_sweep

REPO = Path(__file__).resolve().parents[1]
MODELS = REPO / "magsail_mj" / "concepts" / "truss_magnetorquer" / "configs"
SWEEP = REPO / "models" / "sweeps" / "truss_orbital.toml"
DEFAULT_IDS = ["detumble", "slew_i", "slew_ii", "slew_iii", "slew_iv"]

DETUMBLE_COLUMNS = [
    ("t_end_s", "t_end [s]"),
    ("time_rates_below_1e-3_s", "rates stay < 1e-3 from [s]"),
    ("t_rates_below_threshold_first_s", "first < 1e-3 [s]"),
    ("omega_rms_last_1800s_rad_s", "ω rms last 30 min [rad/s]"),
    ("surface_sd_max_m", "σ_SD max [m]"),
    ("t_surface_sd_max_s", "at [s]"),
    ("edge_angle_max_deg", "edge angle max [°]"),
    ("saturation_fraction", "saturated (either)"),
    ("sat_fraction_family1", "sat. x1"),
    ("sat_fraction_family2", "sat. y1"),
    ("strut_strain_max", "max strain"),
    ("failed", "failed"),
    ("wall_time_s", "wall [s]"),
]
SLEW_COLUMNS = [
    ("t_end_s", "t_end [s]"),
    ("final_error_deg", "final error [°]"),
    ("settle_time_s", "stays < 5° from [s]"),
    ("t_err_below_2deg_stay_s", "stays < 2° from [s]"),
    ("overshoot_deg", "overshoot [°]"),
    ("surface_sd_max_m", "σ_SD max [m]"),
    ("tumbled", "tumbled"),
    ("int_T_ac_Nms", "∫|T_ac| [N m s]"),
    ("low_authority_time_s", "low authority [s]"),
    ("saturation_fraction", "saturated"),
    ("strut_strain_max", "max strain"),
    ("failed", "failed"),
    ("wall_time_s", "wall [s]"),
]


def all_ids() -> list[str]:
    """Every run id of the sweep file: the defaults, the ablation and the sensitivity runs."""
    return [r.id for r in load_sweep(SWEEP).runs]


def select(ids: list[str], sets: list[str]) -> Sweep:
    """The sweep file with exactly ``ids`` selected (ValueError naming an unknown id)."""
    known = all_ids()
    unknown = [sid for sid in ids if sid not in known]
    if unknown:
        raise ValueError(
            f"scenario id {unknown[0]!r}: not a run of {SWEEP.relative_to(REPO)} (known: {', '.join(known)})"
        )
    sweep = load_sweep(SWEEP, extra_overrides=tuple(sets), only=ids)  # ids as substrings: a superset
    runs = tuple(dataclasses.replace(r, selected=r.id in ids) for r in sweep.runs)
    return dataclasses.replace(sweep, runs=runs, only=tuple(ids))


def run_all(sweep: Sweep, out: Path, *, workers: int, video: bool, overwrite: bool) -> dict[str, dict]:
    """Run the selected runs; id → summary (or status and error for a run that did not finish)."""
    records = run_sweep(
        sweep, out, workers=workers, video=video, overwrite=overwrite, log=lambda line: print(line, file=sys.stderr)
    )
    results = {}
    for rec in records:
        if rec["selected"]:
            ok = rec["status"] in FINISHED
            results[rec["id"]] = rec["summary"] if ok else {"status": rec["status"], "error": rec["message"]}
    return results


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
        lines += [
            f"## {kind}",
            "",
            "| id | status | " + " | ".join(h for _, h in cols) + " |",
            "|---|---|" + "---|" * len(cols),
        ]
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
    ap.add_argument("--table-only", action="store_true", help="only tabulate existing run folders")
    args = ap.parse_args(argv)
    if args.workers < 1:
        ap.error(f"--workers: must be >= 1, got {args.workers}")
    ids = list(args.ids) or (all_ids() if args.all else DEFAULT_IDS)
    if args.all and args.ids:
        ids = list(dict.fromkeys(ids + all_ids()))
    try:
        sweep = select(ids, args.set)
    except (ValueError, ConfigError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.table_only:
        results = load_existing(out, ids)
    else:
        results = run_all(sweep, out, workers=args.workers, video=args.video, overwrite=args.overwrite)
    write_json(out / "summary.json", to_jsonable(results))
    text = markdown(results, args.set)
    with atomic_path(out / "summary.md") as tmp:
        tmp.write_text(text)
    print(text)
    return 1 if any("error" in v for v in results.values()) else 0


if __name__ == "__main__":
    sys.exit(main())
