"""Willis et al. (2024)'s detumble Monte Carlo reproduced: our figures beside theirs, with tolerances.

Reads the run folders of a finished ``willis_manchester_mc.toml`` sweep (``<dir>/bdot_law=<law>/s*/
summary.json``, figure ``detumble_time_h_1pct_s``: the first time ‖J ω‖ < 1 % of its start) and
prints, per law, the figures their plot (``final/pgfplot_monte_carlo_controllers.jl`` of their
repository) marks, computed their way:

* the 50 % mark: their plot pins the first bin (width 0.02 h, the 2 h span over 100) where the share
  detumbled exceeds 50 %, i.e. the ⌊n/2⌋ + 1-th smallest time rounded up to the 0.02 h grid; here the
  ⌊n/2⌋ + 1-th smallest time [h] and its grid value;
* the share detumbled: their label counts the runs done by the bin before the last (1.98 h); here
  within 1.98 h and within the 2 h run.

Tolerance: each figure's 95 % bootstrap interval over ``--draws`` resamples of the n runs (seed 0),
widened by √2 about our value, since their figure is itself a 100-run estimate with about the same
sampling error (the difference of two independent estimates has √2 times the standard error of
one). Their number inside that band counts as reproduced. Prints one JSON object.

    python scripts/willis_manchester_compare.py runs/willis_manchester_mc
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

FIGURE = "detumble_time_h_1pct_s"
LAWS = {"non_monotonic": "Discrete Non-monotonic", "proportional": "B-dot", "b_cross": "B-cross"}
#: their figs/detumble_time_cumulative_no_noise_30deg_s.tikz: (50 % mark [h], share done [%])
THEIRS = {"non_monotonic": (0.60, 100.0), "proportional": (1.54, 73.0), "b_cross": (1.78, 55.0)}
BIN_H = 0.02
SHARE_AT_H = 1.98


def times_h(sweep_dir: Path, law: str) -> np.ndarray:
    """The figure of every run of ``law`` [h], +inf where it was never reached."""
    paths = sorted((sweep_dir / f"bdot_law={law}").glob("s*/summary.json"))
    values = [json.loads(p.read_text()).get(FIGURE) for p in paths]
    return np.array([math.inf if v is None else v / 3600.0 for v in values])


def half_mark_h(t: np.ndarray) -> float:
    """The ⌊n/2⌋ + 1-th smallest value (their plot's first bin above 50 %, before rounding)."""
    return float(np.sort(t)[len(t) // 2])


def share_pct(t: np.ndarray, within_h: float) -> float:
    return 100.0 * float(np.mean(t <= within_h))


def band(value: float, samples: np.ndarray) -> list[float]:
    """The 95 % bootstrap interval of ``samples`` widened by √2 about ``value``."""
    lo, hi = np.quantile(samples, [0.025, 0.975], method="inverted_cdf")
    return [value - math.sqrt(2.0) * (value - float(lo)), value + math.sqrt(2.0) * (float(hi) - value)]


def compare(sweep_dir: Path, *, draws: int) -> dict[str, dict]:
    rng = np.random.default_rng(0)
    out = {}
    for law, name in LAWS.items():
        t = times_h(sweep_dir, law)
        if t.size == 0:
            continue
        resampled = rng.choice(t, size=(draws, t.size), replace=True)
        half = half_mark_h(t)
        halves = np.sort(resampled, axis=1)[:, t.size // 2]
        share = share_pct(t, SHARE_AT_H)
        shares = 100.0 * np.mean(resampled <= SHARE_AT_H, axis=1)
        their_half, their_share = THEIRS[law]
        half_band = band(half, halves) if math.isfinite(half) else [math.inf, math.inf]
        share_band = band(share, shares)
        out[law] = {
            "their_name": name,
            "n": int(t.size),
            "half_mark_h": half,
            "half_mark_grid_h": round(math.ceil(half / BIN_H - 1e-9) * BIN_H, 2) if math.isfinite(half) else None,
            "half_mark_band_h": half_band,
            "their_half_mark_h": their_half,
            "half_mark_reproduced": bool(half_band[0] <= their_half <= half_band[1]),
            "share_within_1p98h_pct": share,
            "share_within_2h_pct": share_pct(t, 2.0),
            "share_band_pct": share_band,
            "their_share_pct": their_share,
            "share_reproduced": bool(share_band[0] <= their_share <= share_band[1]),
            "median_report_h": float(np.sort(t)[max(1, math.ceil(t.size / 2)) - 1]),
        }
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sweep_dir", type=Path)
    ap.add_argument("--draws", type=int, default=20000)
    args = ap.parse_args()
    print(json.dumps(compare(args.sweep_dir, draws=args.draws), indent=2))


if __name__ == "__main__":
    main()
