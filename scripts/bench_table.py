"""The performance table of the docs: ``magsail bench`` of one config per concept.

Runs ``magsail bench`` (``python -m magsail_mj bench``, one process per config, so that
``peak_rss_mb`` is the config's own) on the configs of :data:`ROWS`, each for its stated simulated
duration with ``--repeat`` timed passes (medians), and writes into ``--out`` (default
``docs/_static/bench``):

* ``bench.json`` — every JSON object ``magsail bench`` printed, with the time and the machine's
  load average before and after (``--only`` replaces the rows of those concepts, keeps the others);
* ``bench_table.csv`` — the table that ``docs/performance.md`` includes (``csv-table``).

Per config the table shows the all-in step on the Python path, the compiled loads' step where the
scenario has them (``us_per_step_compiled`` of the same ``magsail bench`` call), and, where the
concept has a batch (a ``batch`` module in its package), ``magsail bench --worlds N`` (default 256
worlds, one thread, ``--worlds-repeat`` passes) for the same steps: the batch's wall time per
world-step with Python loads and with compiled loads as CPU time (``cpu_us_per_world_step``,
``cpu_us_per_world_step_compiled``: one stepping thread, so on a free core its wall time; CPU time
stays meaningful when other processes share the cores), each against the CPU time of the bare
``mj_step`` timed after it in the same process.

The docs build only reads these files; rerun this script (minutes) to measure again:

    python scripts/bench_table.py                    # all rows, 3 passes each
    python scripts/bench_table.py --only cnusail     # one concept
    nice -n 10 python scripts/bench_table.py --worlds 64 --worlds-repeat 1
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

from magsail_mj.concepts import concept_modules

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
    "mj_step µs",
    "all-in µs/step (÷ mj_step)",
    "compiled µs/step (÷ mj_step)",
    "batch CPU µs/world-step (÷ mj_step CPU)",
    "compiled batch CPU µs/world-step (÷ mj_step CPU)",
    "steps/s",
    "realtime factor",
    "peak RSS MiB",
    "largest parts (µs/step)",
)

NONE = "—"
"""A cell of a figure the config's concept or scenario does not have."""


def _with_ratio(us: float | None, ratio: float | None) -> str:
    return NONE if us is None or ratio is None else f"{us:.3g} ({ratio:.2f}×)"


def _top_parts(parts: dict[str, float], n: int = 3) -> str:
    top = sorted(((k, v) for k, v in parts.items() if k not in ("mj_step",)), key=lambda kv: -kv[1])[:n]
    return "; ".join(f"{k} {v:.3g}" for k, v in top)


def table_row(concept: str, config: str, r: dict) -> list[str]:
    """One CSV row of a bench object (with its batch's object under ``"batch"``, if any)."""
    b = r.get("batch") or {}
    return [
        concept,
        Path(config).name,
        f"{r['steps']} × {r['timestep_s']:g} s ({r['integrator']})",
        f"{r['mj_step_us']:.3g}",
        _with_ratio(r["us_per_step"], r["ratio_to_mj_step"]),
        _with_ratio(r.get("us_per_step_compiled"), r.get("ratio_to_mj_step_compiled")),
        _with_ratio(b.get("cpu_us_per_world_step"), b.get("cpu_ratio_to_mj_step")),
        _with_ratio(b.get("cpu_us_per_world_step_compiled"), b.get("cpu_ratio_to_mj_step_compiled")),
        f"{r['steps_per_s']:.4g}",
        f"{r['realtime_factor']:.4g}",
        f"{r['peak_rss_mb']:.0f}",
        _top_parts(r["parts_us"]),
    ]


def has_batch(concept: str) -> bool:
    """Whether the concept's package has a ``batch`` module (its configs run as batched worlds)."""
    return concept in concept_modules("batch")


def run_bench(config: str, duration_s: float, repeat: int, *, worlds: int | None = None) -> dict:
    """The JSON object of ``magsail bench CONFIG --duration-s T --repeat N [--worlds W --threads 1]``
    (a fresh process)."""
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
    if worlds is not None:
        cmd += ["--worlds", str(worlds), "--threads", "1"]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"{config}: magsail bench exited {proc.returncode}: {proc.stderr.strip()}")
    return json.loads(proc.stdout)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=OUT, help="folder of bench.json and bench_table.csv")
    ap.add_argument("--repeat", type=int, default=3, help="timed passes per config (medians; default 3)")
    ap.add_argument("--only", action="append", metavar="CONCEPT", help="only these concepts (repeatable)")
    ap.add_argument("--worlds", type=int, default=256, help="worlds of the batch rows (default 256; 0: none)")
    ap.add_argument("--worlds-repeat", type=int, default=1, help="timed passes of a batch (default 1)")
    args = ap.parse_args(argv)
    if args.repeat < 1:
        ap.error(f"--repeat: must be >= 1, got {args.repeat}")
    if args.worlds < 0 or args.worlds_repeat < 1:
        ap.error(f"--worlds must be >= 0 and --worlds-repeat >= 1, got {args.worlds} and {args.worlds_repeat}")
    rows = [r for r in ROWS if not args.only or r[0] in args.only]
    results = {}
    for concept, config, duration in rows:
        t0 = time.perf_counter()
        load_before = os.getloadavg()
        r = run_bench(config, duration, args.repeat)
        batch = None
        if args.worlds and has_batch(concept):
            batch = run_bench(config, duration, args.worlds_repeat, worlds=args.worlds)
        print(
            f"{concept}: {r['us_per_step']:.3g} µs/step, {r['ratio_to_mj_step']:.2f}× mj_step"
            + (f", batch {batch['ratio_to_mj_step']:.2f}×" if batch else "")
            + f" ({time.perf_counter() - t0:.0f} s)",
            file=sys.stderr,
            flush=True,
        )
        results[concept] = {
            "concept": concept,
            **r,
            "batch": batch,
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
