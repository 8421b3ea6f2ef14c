"""Largest plate side against the number of coils for B, C, D (Robb et al. 2022b, Fig. 5).

``D_max = (C1 G σ_A^{1/3})^{-3/5}`` where ``λ_f = 1``. The paper's axis "number of coils" is
ambiguous for B (our resolution): B is drawn both against its loop count ``n`` (``G_B(n)``,
the Table-1 meaning) and against the unit count ``N`` (``n = ceil(N/2)``); C and D against ``N``.
Geometry A's uniform-mass ``D_max`` and its fold (largest plate with a solution, κ = ``--kappa``)
are horizontal reference lines. One panel per ``σ_A``.

Writes ``fig5_dmax_vs_N.png``, ``fig5_dmax_vs_N.npz`` and ``fig5_dmax_vs_N.csv`` into ``--out``.

    python scripts/current_loops_fig5_dmax_vs_N.py [--n-max 60] [--areal-density-g-m2 1 10 100] [--out DIR]
"""

from __future__ import annotations

import argparse
import csv
import io
import sys
from pathlib import Path

import numpy as np

from magsail_mj.analysis.loop_scaling import c1, fold_A, geometry_factor_b_loops, side_max
from magsail_mj.io import atomic_path, write_npz
import matplotlib.pyplot as plt
from magsail_mj.plotting import save_figure


def dmax_table(counts: np.ndarray, sigma: float, kappa: float) -> dict[str, np.ndarray | float]:
    """``D_max`` [m] for every count: ``B_vs_n``, ``B_vs_N``, ``C``, ``D``; A's references."""
    s3 = np.cbrt(sigma)
    out: dict[str, np.ndarray | float] = {
        "B_vs_n": np.array([(c1() * geometry_factor_b_loops(int(n)) * s3) ** -0.6 for n in counts]),
        "B_vs_N": np.array([side_max("B", units=int(N), areal_density_kg_m2=sigma) for N in counts]),
        "C": np.array([side_max("C", units=int(N), areal_density_kg_m2=sigma) for N in counts]),
        "D": np.array([side_max("D", units=int(N), areal_density_kg_m2=sigma) for N in counts]),
        "A_uniform": float(side_max("A", units=1, areal_density_kg_m2=sigma)),
    }
    h_star = fold_A(kappa)[1]
    out["A_fold"] = float((h_star / (4.0 * c1() * s3)) ** 0.6) if np.isfinite(h_star) else float("nan")
    return out


def figure(path: Path, counts: np.ndarray, tables: dict[float, dict], kappa: float) -> Path:
    fig, axes = plt.subplots(1, len(tables), figsize=(4.6 * len(tables), 4.6), squeeze=False, sharey=False)
    for ax, (s, t) in zip(axes[0], tables.items()):
        ax.plot(counts, t["B_vs_n"], "-", color="tab:blue", label="B against loop count n")
        ax.plot(counts, t["B_vs_N"], "--", color="tab:blue", label="B against units N (n = ⌈N/2⌉)")
        ax.plot(counts, t["C"], "-", color="tab:green", label="C against N")
        ax.plot(counts, t["D"], "-", color="tab:red", label="D against N")
        ax.axhline(t["A_uniform"], color="0.3", lw=0.8, ls=":", label="A, uniform mass")
        if np.isfinite(t["A_fold"]):
            ax.axhline(t["A_fold"], color="0.3", lw=0.8, ls="-.", label=f"A fold (κ = {kappa:g})")
        ax.set_yscale("log")
        ax.set_xlabel("number of coils (n for B solid, N otherwise)")
        ax.set_title(f"σ_A = {s * 1e3:g} g/m²")
        ax.grid(True, which="both", alpha=0.25)
    axes[0, 0].set_ylabel("largest side D_max (λ_f = 1) [m]")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle("D_max = (C1 G σ_A^(1/3))^(-3/5)")
    fig.tight_layout()
    return save_figure(fig, path)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-min", type=int, default=2, help="smallest count")
    ap.add_argument("--n-max", type=int, default=60, help="largest count")
    ap.add_argument("--areal-density-g-m2", type=float, nargs="+", default=[1.0, 10.0, 100.0], help="σ_A [g/m²]")
    ap.add_argument("--kappa", type=float, default=15.0, help="geometry A rim-inertia factor κ (reference line)")
    ap.add_argument("--out", default="runs/current_loops/scaling", help="output folder")
    args = ap.parse_args(argv)
    if not 1 <= args.n_min < args.n_max:
        print(f"error: --n-min/--n-max: need 1 <= n_min < n_max, got {args.n_min}, {args.n_max}", file=sys.stderr)
        return 2
    counts = np.arange(args.n_min, args.n_max + 1)
    try:
        tables = {s * 1e-3: dmax_table(counts, s * 1e-3, args.kappa) for s in args.areal_density_g_m2}
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    arrays = {f"{k}_s{s * 1e3:g}": np.asarray(v) for s, t in tables.items() for k, v in t.items()}
    write_npz(out / "fig5_dmax_vs_N.npz", count=counts, kappa=np.array(args.kappa), **arrays)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["areal_density_kg_m2", "count", "B_vs_n_m", "B_vs_N_m", "C_m", "D_m"])
    for s, t in tables.items():
        for i, n in enumerate(counts):
            w.writerow([s, int(n), t["B_vs_n"][i], t["B_vs_N"][i], t["C"][i], t["D"][i]])
    with atomic_path(out / "fig5_dmax_vs_N.csv") as tmp:
        tmp.write_text(buf.getvalue())
    figure(out / "fig5_dmax_vs_N.png", counts, tables, args.kappa)
    for s, t in tables.items():
        sel = [i for i, n in enumerate(counts) if n in (12, 19, 27)]
        print(
            f"σ_A = {s * 1e3:g} g/m²: "
            + "; ".join(
                f"N = {counts[i]}: B {t['B_vs_N'][i]:.0f} m, C {t['C'][i]:.0f} m, D {t['D'][i]:.0f} m" for i in sel
            )
            + f"; A uniform {t['A_uniform']:.0f} m, A fold {t['A_fold']:.0f} m"
        )
    print(f"wrote {out}/fig5_dmax_vs_N.{{png,npz,csv}}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
