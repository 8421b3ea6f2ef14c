"""Peak memory of a whole run (simulation, records, post-processing, plots) at duration D and k·D.

Each case runs in a fresh Python process (``ru_maxrss`` is a process's high-water mark) through
``magsail_mj.run.run_scenario``, exactly as ``magsail run`` without a video, and prints one JSON line;
the last line is the summary with the ratio peak(k·D) / peak(D). The records go to the run folder's
``timeseries.zarr`` in chunks and post-processing reads them block by block, so the ratio stays
near 1 however long the run (the target: within 1.2 at k = 4).

    python scripts/measure_run_memory.py magsail_mj/concepts/current_loops/configs/slew.toml \\
        --duration-s 250 --set sim.record_every=1
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from magsail_mj.config import load_config
from magsail_mj.run import run_scenario


def measure_one(config: str, out: str, overrides: list[str]) -> dict:
    """Run ``config`` with ``overrides`` into ``out`` in this process; peak RSS [MiB] and wall time [s]."""
    cfg = load_config(config, overrides)
    t0 = time.perf_counter()
    outcome = run_scenario(cfg, out, overwrite=True, progress=False)
    return {
        "status": outcome.status,
        "wall_s": round(time.perf_counter() - t0, 2),
        "records": int(round(cfg.sim.duration_s / cfg.sim.timestep_s / cfg.sim.record_every)),
        "peak_rss_MiB": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("config", help="config file (TOML)")
    parser.add_argument("--duration-s", type=float, required=True, help="the shorter duration D [s]")
    parser.add_argument("--factor", type=float, default=4.0, help="the longer run lasts factor x D (default 4)")
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="config override, as on the magsail command line (repeatable)",
    )
    parser.add_argument("--one", metavar="OUT_DIR", help=argparse.SUPPRESS)  # internal: one case here
    args = parser.parse_args(argv)
    if args.duration_s <= 0 or args.factor <= 0:
        parser.error("--duration-s and --factor: must be positive")
    base = [*args.overrides, "sim.checkpoint_every_s=0"]
    if args.one:
        print(json.dumps(measure_one(args.config, args.one, [*base, f"sim.duration_s={args.duration_s}"])))
        return 0
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for duration in (args.duration_s, args.factor * args.duration_s):
            cmd = [
                sys.executable,
                __file__,
                args.config,
                "--duration-s",
                str(duration),
                "--one",
                str(Path(tmp) / f"run_{duration:g}"),
                *[f"--set={o}" for o in args.overrides],
            ]
            line = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout.strip().splitlines()[-1]
            rows.append({"duration_s": duration, **json.loads(line)})
            print(json.dumps(rows[-1]), flush=True)
    print(
        json.dumps(
            {
                "config": args.config,
                "overrides": args.overrides,
                "factor": args.factor,
                "peak_ratio": round(rows[1]["peak_rss_MiB"] / rows[0]["peak_rss_MiB"], 3),
            }
        )
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
