"""The performance table of the docs: ``magsail bench`` of one config per concept.

Runs ``magsail bench`` (``python -m magsail_mj bench``, one process per config, so that
``peak_rss_mb`` is the config's own) on the configs of :data:`ROWS`, each for its stated simulated
duration with ``--repeat`` timed passes (medians), and writes into ``--out`` (default
``docs/_static/bench``):

* ``bench.json`` — every JSON object ``magsail bench`` printed, with the time and the machine's
  load average before and after (``--only`` replaces the rows of those concepts, keeps the others);
* ``bench_table.csv`` — the table that ``docs/performance.md`` includes (``csv-table``).

The docs build only reads these files; rerun this script (minutes) to measure again:

    python scripts/bench_table.py                    # all rows, 3 passes each
    python scripts/bench_table.py --only cnusail     # one concept
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "_static" / "bench"

ROWS: tuple[tuple[str, str, float], ...] = (
    ("truss_magnetorquer", "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml", 30.0),
    ("current_loops", "magsail_mj/concepts/current_loops/configs/slew.toml", 30.0),
    ("reflector", "magsail_mj/concepts/reflector/configs/tracking_10g.toml", 600.0),
    ("cnusail", "magsail_mj/concepts/cnusail/configs/detumble_pre.toml", 1800.0),
    ("msac", "magsail_mj/concepts/msac/configs/paper_1khz.toml", 0.5),
)
"""(concept, config, simulated seconds per pass)."""

HEADER = (
    "concept",
    "config",
    "steps × δt (integrator)",
    "all-in µs/step",
    "mj_step µs",
    "all-in / mj_step",
    "steps/s",
    "realtime factor",
    "peak RSS MiB",
    "largest parts (µs/step)",
)


def _top_parts(parts: dict[str, float], n: int = 3) -> str:
    top = sorted(((k, v) for k, v in parts.items() if k not in ("mj_step",)), key=lambda kv: -kv[1])[:n]
    return "; ".join(f"{k} {v:.3g}" for k, v in top)


def table_row(concept: str, config: str, r: dict) -> list[str]:
    """One CSV row of a bench object."""
    return [
        concept,
        Path(config).name,
        f"{r['steps']} × {r['timestep_s']:g} s ({r['integrator']})",
        f"{r['us_per_step']:.3g}",
        f"{r['mj_step_us']:.3g}",
        f"{r['ratio_to_mj_step']:.2f}",
        f"{r['steps_per_s']:.4g}",
        f"{r['realtime_factor']:.4g}",
        f"{r['peak_rss_mb']:.0f}",
        _top_parts(r["parts_us"]),
    ]


def run_bench(config: str, duration_s: float, repeat: int) -> dict:
    """The JSON object of ``magsail bench CONFIG --duration-s T --repeat N`` (a fresh process)."""
    cmd = [
        sys.executable,
        "-m",
        "magsail_mj",
        "bench",
        str(ROOT / config),
        "--duration-s",
        repr(duration_s),
        "--repeat",
        str(repeat),
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"{config}: magsail bench exited {proc.returncode}: {proc.stderr.strip()}")
    return json.loads(proc.stdout)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=OUT, help="folder of bench.json and bench_table.csv")
    ap.add_argument("--repeat", type=int, default=3, help="timed passes per config (medians; default 3)")
    ap.add_argument("--only", action="append", metavar="CONCEPT", help="only these concepts (repeatable)")
    args = ap.parse_args(argv)
    if args.repeat < 1:
        ap.error(f"--repeat: must be >= 1, got {args.repeat}")
    rows = [r for r in ROWS if not args.only or r[0] in args.only]
    results = {}
    for concept, config, duration in rows:
        t0 = time.perf_counter()
        load_before = os.getloadavg()
        r = run_bench(config, duration, args.repeat)
        print(
            f"{concept}: {r['us_per_step']:.3g} µs/step, {r['ratio_to_mj_step']:.2f}× mj_step "
            f"({time.perf_counter() - t0:.0f} s)",
            file=sys.stderr,
            flush=True,
        )
        results[concept] = {
            "concept": concept,
            **r,
            "config": config,
            "repeat": args.repeat,
            "measured": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            "load_average_before": load_before,
            "load_average_after": os.getloadavg(),
        }
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "bench.json"
    if args.only and path.is_file():  # keep the rows of the concepts not measured now
        results = {**{r["concept"]: r for r in json.loads(path.read_text())["rows"]}, **results}
    ordered = [results[c] for c, _, _ in ROWS if c in results]
    path.write_text(json.dumps({"rows": ordered}, indent=1) + "\n")
    with (args.out / "bench_table.csv").open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(HEADER)
        for res in ordered:
            w.writerow(table_row(res["concept"], res["config"], res))
    print(str(args.out / "bench_table.csv"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
