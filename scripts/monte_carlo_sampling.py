"""Percentiles of a finished Monte Carlo sweep, of its first samples, and their sampling error.

For a figure of the sweep's summaries (``magsail report``'s statistics,
:func:`magsail_mj.sweep.report.figure_stats`: inverted empirical CDF, runs that never reach the
threshold as +inf) this prints one JSON object with, per figure: the percentiles over all ``n``
runs; over the first ``--first`` runs (``s000`` …, the draws a smaller sweep with the same seed
made); and the 95 % interval of a ``--first``-sample percentile when ``--first`` runs are drawn
at random from the ``n`` (bootstrap, ``--draws`` resamples with replacement, seed 0): a smaller
sweep's percentile outside that interval is not explained by its sample size.

    python scripts/monte_carlo_sampling.py runs/mc1000 --first 200 \\
        --figure detumble_time_below_1p0dps_s --figure detumble_time_below_0p3dps_s
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from magsail_mj.sweep.report import PERCENTILES, figure_stats


def bootstrap_interval(values: np.ndarray, *, size: int, draws: int, seed: int = 0) -> dict[str, list[float | None]]:
    """The 2.5 % and 97.5 % quantiles of each :data:`PERCENTILES` percentile of ``size`` values
    drawn with replacement from ``values`` (+inf for never), over ``draws`` resamples."""
    rng = np.random.default_rng(seed)
    samples = np.sort(rng.choice(values, size=(draws, size), replace=True), axis=1)
    out = {}
    for p in PERCENTILES:
        k = max(1, math.ceil(p * size / 100.0))
        lo, hi = np.quantile(samples[:, k - 1], [0.025, 0.975], method="inverted_cdf")
        out[f"p{p:g}"] = [float(v) if math.isfinite(v) else None for v in (lo, hi)]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("sweep_dir", type=Path)
    ap.add_argument("--figure", action="append", required=True)
    ap.add_argument("--first", type=int, default=200)
    ap.add_argument("--draws", type=int, default=10_000)
    args = ap.parse_args()
    records = sorted(json.loads((args.sweep_dir / "sweep_summary.json").read_text()), key=lambda r: r["id"])
    result = {"n": len(records), "first": args.first}
    for figure in args.figure:
        every = figure_stats(records, figure)
        values = np.array(
            [
                math.inf if (x := (r.get("summary") or {}).get(figure)) is None or r.get("status") != "completed" else x
                for r in records
            ],
            dtype=float,
        )
        result[figure] = {
            "all": every,
            "first": figure_stats(records[: args.first], figure),
            "interval_of_first_size": bootstrap_interval(values, size=args.first, draws=args.draws),
        }
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
