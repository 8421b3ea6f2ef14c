"""Two detumble laws over the same benchmark conditions, condition by condition.

Reads the run folders of two grid points of detumble benchmark sweeps (``<sweep out>/<grid
point>/s<i>/summary.json``, as ``magsail sweep`` writes them; the two may be in different sweep
folders, e.g. the shipped benchmark and the tuned law's) and, for every sample present in both with
status ``completed``, writes one CSV row with both runs' figures, then prints how many conditions
the second law reaches 0.3 °/s sooner and later, the mean and median difference and both laws'
medians. A run that never stays below 0.3 °/s counts as +∞ (later than any time).

    python scripts/detumble_benchmark_paired.py runs/detumble_benchmark/bdot_law=non_monotonic \
        runs/detumble_benchmark_tuned/<grid point> --names shipped tuned \
        --out docs/_static/detumble_benchmark_tuned/paired_n1000.csv
"""

from __future__ import annotations

import argparse
import csv
import json
import math
from pathlib import Path

import numpy as np

FIGURES = (
    "detumble_time_below_1p0dps_s",
    "detumble_time_below_0p3dps_s",
    "mtq_dipole_effort_Am2s",
    "t_end_s",
    "detumbled",
)
TIME = "detumble_time_below_0p3dps_s"


def completed_summaries(point: Path) -> dict[str, dict]:
    """Sample id → summary of every completed run of a grid point's folder."""
    out: dict[str, dict] = {}
    for run in sorted(point.glob("s*")):
        manifest, summary = run / "manifest.json", run / "summary.json"
        if not (manifest.is_file() and summary.is_file()):
            continue
        if json.loads(manifest.read_text()).get("status") == "completed":
            out[run.name] = json.loads(summary.read_text())
    return out


def paired_rows(
    first: dict[str, dict], second: dict[str, dict], *, names: tuple[str, str] = ("first", "second")
) -> list[dict]:
    """One row per sample completed in both: ``<names[0]>_<figure>`` and ``<names[1]>_<figure>``."""
    rows = []
    for sample in sorted(first.keys() & second.keys()):
        row: dict = {"sample": sample}
        for name, summaries in zip(names, (first, second)):
            for figure in FIGURES:
                row[f"{name}_{figure}"] = summaries[sample].get(figure)
        rows.append(row)
    return rows


def _time(value: float | None) -> float:
    return math.inf if value is None else float(value)


def comparison(rows: list[dict], *, names: tuple[str, str] = ("first", "second")) -> dict[str, float]:
    """Counts and differences of the 0.3 °/s time (second minus first) over the paired rows."""
    a = np.array([_time(r[f"{names[0]}_{TIME}"]) for r in rows])
    b = np.array([_time(r[f"{names[1]}_{TIME}"]) for r in rows])
    both = np.isfinite(a) & np.isfinite(b)
    diff = b[both] - a[both]
    return {
        "n": len(rows),
        "second_sooner": int(np.sum(b < a)),
        "second_later": int(np.sum(b > a)),
        "equal": int(np.sum(b == a)),
        "first_never": int(np.sum(~np.isfinite(a))),
        "second_never": int(np.sum(~np.isfinite(b))),
        "mean_difference_s": float(diff.mean()) if diff.size else math.nan,
        "largest_later_s": float(diff.max()) if diff.size else math.nan,
        "first_median_s": float(np.median(a)),
        "second_median_s": float(np.median(b)),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("first", type=Path, help="grid point folder of the first law")
    parser.add_argument("second", type=Path, help="grid point folder of the second law")
    parser.add_argument("--out", type=Path, required=True, help="CSV to write")
    parser.add_argument("--names", nargs=2, default=["first", "second"], help="column prefixes of the two laws")
    args = parser.parse_args(argv)
    names = (args.names[0], args.names[1])
    for name in ("first", "second"):
        if not getattr(args, name).is_dir():
            parser.error(f"{name}: {getattr(args, name)} is not a folder")
    rows = paired_rows(completed_summaries(args.first), completed_summaries(args.second), names=names)
    if not rows:
        parser.error("no sample completed in both folders")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(json.dumps(comparison(rows, names=names), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
