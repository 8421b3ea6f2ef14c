"""MSAC sensitivity sweeps (F6) and actuator design chart (F7) after Vedant & Allison 2019's actuator study.

    python scripts/msac_sweeps.py                      # all runs of the sweep file -> runs/msac/sweeps/
    python scripts/msac_sweeps.py --only stroke extension --workers 2

The sweep configs (``magsail_mj/concepts/msac/configs/sweeps/*.toml``) are the runs of the sweep file
``models/sweeps/msac_sensitivity.toml``; they run through the sweep engine
(:func:`magsail_mj.sweep.run_sweep`: ``--workers`` Dask worker processes, valid earlier runs
reused) into ``runs/msac/sweeps/<name>/`` (its own ``sweep.png`` and ``summary.json``: per point
Eq. (6), the exact planar model and MuJoCo, secular rates, peak hinge torque and slide force),
with ``sweep_summary.json``/``.csv`` beside them. This script then draws

* ``F6_sensitivity.png``: one panel per sweep, the per-cycle rotation θ_γ from Eq. (6) (model
  inertias), the exact model and MuJoCo (20 cycles per point, first excluded);
* ``F7_design_chart.png``: the amplification trade-off of the paper's piezo actuators. Scaling model, anchored at the
  simple piezo actuator (a): extension ``ε = 0.1 %·a`` and attainable cycle frequency
  ``f = 4 kHz/a`` for an amplification factor ``a`` (stroke ±10°, all other parameters as the
  paper case). Curves: secular rate ``θ_γ(ε)·f`` from the exact planar model and from Eq. (7);
  MuJoCo points from the ``amplification`` sweep; the two operating points (a) 0.1 % at 4 kHz
  and (b) 1 % at 1 kHz (the paper case, evaluated by the references: it lies off the scaling
  line, which gives 1 % only at 400 Hz). Lower panel: the peak hinge torque and slide force the
  prescribed motion demands (MuJoCo, per wing), against the 200 N peak force of one piezo chip.

Assumptions of the chart (ours): rigid wings, prescribed kinematics (the actuator is assumed
to deliver whatever force the path needs), extension ∝ a and frequency ∝ 1/a exactly, no
structural dynamics. Writes ``runs/msac/sweeps/F6_F7.json`` with the plotted numbers.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from magsail_mj.config import ConfigError, load_config
from magsail_mj.io import to_jsonable, write_json
from magsail_mj.plotting import new_figure, save_figure
from magsail_mj.concepts.msac.config import point_config
from magsail_mj.concepts.msac.tasks import build_msac_scenario
from magsail_mj.sweep import FINISHED, load_sweep, run_sweep

REPO = Path(__file__).resolve().parents[1]
SWEEP_FILE = REPO / "models" / "sweeps" / "msac_sensitivity.toml"
PIEZO_PEAK_FORCE_N = 200.0  # Vedant & Allison 2019: one multilayer PZT chip


def run_sweeps(names: list[str] | None, out: Path, *, workers: int = 2) -> dict[str, dict]:
    """Run the named runs of the sweep file (all when None) on Dask; return ``{name: summary}``.

    Raises:
      SystemExit: a name is no run of the sweep file, or a run did not finish (its message).
    """
    try:
        sweep = load_sweep(SWEEP_FILE, only=names)
    except ConfigError as err:
        raise SystemExit(f"error: {err}") from None
    ids = [r.id for r in sweep.runs]
    unknown = sorted(set(names or []) - set(ids))
    if unknown:
        raise SystemExit(f"error: --only: {unknown} are no runs of {SWEEP_FILE} ({', '.join(ids)})")
    t0 = time.perf_counter()
    records = run_sweep(sweep, out, workers=workers, log=lambda line: print(line, file=sys.stderr))
    print(f"{len(sweep.selected)} sweeps in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    chosen = [r for r in records if names is None or r["id"] in names]
    bad = [f"{r['id']}: {r['status']} {r['message']}" for r in chosen if r["status"] not in FINISHED]
    if bad:
        raise SystemExit("error: runs did not finish: " + "; ".join(bad))
    return {r["id"]: r["summary"] for r in chosen}


def _labels(summary: dict) -> list[str]:
    return [
        ", ".join(f"{v:g}" if isinstance(v, (int, float)) else "/".join(f"{x:g}" for x in v) for v in p)
        for p in summary["sweep_points"]
    ]


def f6_figure(results: dict[str, dict], path: Path) -> Path:
    names = [n for n in results if n != "amplification"]
    cols = 4
    rows = math.ceil(len(names) / cols)
    fig, axs = new_figure(rows, cols, figsize=(4.2 * cols, 3.6 * rows), squeeze=False)
    for ax, name in zip(axs.flat, names):
        s = results[name]
        x = np.arange(len(s["sweep_points"]))
        ax.plot(x, s["sweep_theta_gamma_eq6_model_rad"], "s--", color="0.5", label="Eq. (6)")
        ax.plot(x, s["sweep_theta_gamma_exact_rad"], "ko-", mfc="none", label="exact model")
        ax.plot(x, s["sweep_theta_gamma_mujoco_rad"], "C3x", ms=9, mew=2, label="MuJoCo")
        ax.set_xticks(x, _labels(s), fontsize=8, rotation=20)
        ax.set_title(f"{name}: {', '.join(k.split('.')[-1] for k in s['sweep_keys'])}", fontsize=9)
        ax.set_yscale("log")
        ax.set_ylabel("θ_γ per cycle [rad]", fontsize=8)
        ax.grid(alpha=0.3)
    for ax in list(axs.flat)[len(names) :]:
        ax.axis("off")
    axs.flat[0].legend(fontsize=8)
    fig.suptitle("F6 MSAC sensitivity of the per-cycle rotation (base: paper_1khz; 20 cycles per point)", fontsize=11)
    fig.tight_layout()
    return save_figure(fig, path)


def design_curves(a: np.ndarray) -> dict[str, np.ndarray]:
    """Exact and Eq. (7) secular rates along the scaling model ``ε = 0.1 %·a``, ``f = 4 kHz/a``."""

    base = load_config(REPO / "magsail_mj/concepts/msac/configs/paper_1khz.toml")
    exact, eq7 = [], []
    for ai in a:
        cfg = point_config(base, ["cycle.extension_frac", "cycle.frequency_Hz"], [1e-3 * ai, 4000.0 / ai], cycles=3)
        ref = build_msac_scenario(cfg).references()
        exact.append(ref["predicted_rate_exact_rad_s"])
        eq7.append(ref["predicted_rate_lumped_rad_s"])
    return {"a": a, "rate_exact_rad_s": np.array(exact), "rate_eq7_rad_s": np.array(eq7)}


def operating_point(ext: float, f: float) -> dict:

    base = load_config(REPO / "magsail_mj/concepts/msac/configs/paper_1khz.toml")
    cfg = point_config(base, ["cycle.extension_frac", "cycle.frequency_Hz"], [ext, f], cycles=3)
    return build_msac_scenario(cfg).references()


def f7_figure(results: dict[str, dict], path: Path) -> tuple[Path, dict]:
    a = np.geomspace(1, 50, 60)
    cur = design_curves(a)
    op_a, op_b = operating_point(1e-3, 4000.0), operating_point(1e-2, 1000.0)
    fig, (ax, ax2) = new_figure(2, 1, figsize=(8, 8), sharex=True)
    ax.plot(a, cur["rate_exact_rad_s"], "k-", label="exact planar model")
    ax.plot(a, cur["rate_eq7_rad_s"], "--", color="0.5", label="Eq. (7) lumped")
    data = {"curves": cur, "op_a": op_a, "op_b": op_b}
    if "amplification" in results:
        s = results["amplification"]
        a_pts = np.array([p[0] / 1e-3 for p in s["sweep_points"]])
        ax.plot(a_pts, s["sweep_secular_rate_rad_s"], "C3x", ms=9, mew=2, label="MuJoCo (20 cycles)")
        ax2.plot(a_pts, s["sweep_hinge_torque_peak_Nm"], "C0o-", label="peak hinge torque [N m]")
        ax2.plot(a_pts, s["sweep_slide_force_peak_N"], "C1s-", label="peak slide force [N]")
        data["mujoco"] = {
            "a": a_pts,
            **{
                k: s[k]
                for k in (
                    "sweep_secular_rate_rad_s",
                    "sweep_hinge_torque_peak_Nm",
                    "sweep_slide_force_peak_N",
                    "sweep_theta_gamma_mujoco_rad",
                    "sweep_theta_gamma_exact_rad",
                )
            },
        }
    for x, op, marker, color, ms, what in (
        (1, op_a, "D", "C2", 10, "(a) 0.1 % at 4 kHz"),
        (10, op_b, "*", "C4", 14, "(b) 1 % at 1 kHz (paper)"),
    ):
        rate = op["predicted_rate_exact_rad_s"]
        ax.plot([x], [rate], marker, color=color, ms=ms, label=f"{what}: {rate:.3g} rad/s")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylabel("secular rate [rad/s]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    ax.set_title("F7 design chart: amplification a, extension 0.1 %·a at 4 kHz/a (stroke ±10°)", fontsize=10)
    ax2.axhline(PIEZO_PEAK_FORCE_N, color="k", ls=":", label="one piezo chip, 200 N peak")
    ax2.set_yscale("log")
    ax2.set_xlabel("amplification factor a")
    ax2.set_ylabel("demanded by the prescribed motion")
    ax2.grid(alpha=0.3, which="both")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path), data


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", help="run ids of models/sweeps/msac_sensitivity.toml (default: all)")
    ap.add_argument("--out", type=Path, default=REPO / "runs/msac/sweeps")
    ap.add_argument("--workers", type=int, default=2, help="Dask worker processes (default 2)")
    a = ap.parse_args(argv)
    results = run_sweeps(a.only or None, a.out, workers=a.workers)
    f6 = f6_figure(results, a.out / "F6_sensitivity.png")
    f7, data = f7_figure(results, a.out / "F7_design_chart.png")
    table = {name: {k: v for k, v in s.items() if k.startswith("sweep_")} for name, s in results.items()}
    write_json(a.out / "F6_F7.json", {"sweeps": table, "design_chart": data})
    print(
        json.dumps(
            to_jsonable(
                {
                    "F6": str(f6),
                    "F7": str(f7),
                    "max_mujoco_vs_exact_rel_diff": {
                        n: s["sweep_mujoco_vs_exact_rel_diff_max"] for n, s in results.items()
                    },
                }
            ),
            indent=2,
        )
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
