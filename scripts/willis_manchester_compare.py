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

    python scripts/willis_manchester_compare.py runs/willis_manchester_mc [--plot cdf.png]

With several sweep folders each law is read from the first that holds it. ``--plot`` draws each law's
empirical CDF of the time to 1 % [h] over the 2 h, their 50 % mark and their share at 2 h beside it.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

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


def law_times_h(sweep_dirs: list[Path]) -> dict[str, np.ndarray]:
    """Each law's times [h] from the first of ``sweep_dirs`` that holds its runs."""
    out = {}
    for law in LAWS:
        for d in sweep_dirs:
            t = times_h(d, law)
            if t.size:
                out[law] = t
                break
    return out


def plot_cdf(times: dict[str, np.ndarray], path: Path) -> None:
    """Empirical CDF [%] of each law's time to 1 % [h], with their 50 % mark and share at 2 h."""
    fig = Figure(figsize=(9.5, 4.0))
    ax = fig.add_subplot()
    for (law, t), color in zip(times.items(), ("C0", "C1", "C2")):
        x = np.sort(t[np.isfinite(t)])
        y = 100.0 * np.arange(1, x.size + 1) / t.size
        ax.step(
            np.r_[0.0, x, 2.0],
            np.r_[0.0, y, y[-1] if y.size else 0.0],
            where="post",
            color=color,
            label=f"{law} (here)",
        )
        half, share = THEIRS[law]
        ax.plot([half], [50.0], "o", color=color, mfc="none", label=f"{LAWS[law]}: their 50 % mark")
        ax.plot([2.0], [share], "s", color=color, mfc="none", label=f"{LAWS[law]}: their share at 2 h")
    ax.set_xlim(0.0, 2.05)
    ax.set_ylim(0.0, 102.0)
    ax.set_xlabel("time to ‖Jω‖ < 1 % of its start [h]")
    ax.set_ylabel("runs detumbled [%]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def compare(times: dict[str, np.ndarray], *, draws: int) -> dict[str, dict]:
    rng = np.random.default_rng(0)
    out = {}
    for law, t in times.items():
        name = LAWS[law]
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
    ap.add_argument("sweep_dirs", type=Path, nargs="+")
    ap.add_argument("--draws", type=int, default=20000)
    ap.add_argument("--plot", type=Path)
    args = ap.parse_args()
    times = law_times_h(args.sweep_dirs)
    print(json.dumps(compare(times, draws=args.draws), indent=2))
    if args.plot:
        plot_cdf(times, args.plot)


if __name__ == "__main__":
    main()
