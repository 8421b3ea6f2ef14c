"""Geometry A (one perimeter loop) against plate size, both branches.

Robb et al. 2022b, Eqs. 2–11 and Fig. 3 (output ``fig3_scaling_A``).

The rim conductor's inertia makes ``λ_f = λ_u (1 + κ λ_f)^{4/3}`` implicit. Each branch is traced
by its parameter ``λ ∈ (0, 1]`` (:func:`magsail_mj.analysis.loop_scaling.trace_branches_A`):
``λ_u = h(λ)``, ``D(λ_u)``, ``I = I_u (1 + κλ)``, ``d(I)``, ``P_J``. Light branch (``λ < 3/κ``)
solid, heavy branch dashed, the fold ``λ* = 3/κ`` as a circle and ``λ_f = 1`` as a star; log axes
over ``D`` = 10 m–100 km for ``σ_A`` ∈ ``--areal-density-g-m2`` (default 1, 10, 100 g/m²).

Writes ``fig3_scaling_A.png`` and ``fig3_scaling_A.npz`` (arrays ``<quantity>_s<σ in g/m²>``,
plus ``heavy_s…``) into ``--out`` (default ``runs/current_loops/scaling``).

    python scripts/current_loops_fig3_scaling_A.py [--areal-density-g-m2 1 10 100] [--kappa 15] [--out DIR]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from magsail_mj.analysis.loop_scaling import fold_A, trace_branches_A
from magsail_mj.io import write_npz
import matplotlib.pyplot as plt
from magsail_mj.plotting import save_figure
from matplotlib.lines import Line2D

PANELS = (
    ("lambda_f", "conductor mass fraction λ_f", 1.0),
    ("wire_diameter_m", "wire diameter d [m]", 1.0),
    ("current_A", "current I [A]", 1.0),
    ("power_per_area_W_m2", "Joule power P_J/D² [W/m²]", 1.0),
)
D_RANGE_M = (10.0, 1e5)


def curves(sigmas_kg_m2: list[float], kappa: float) -> dict[float, dict[str, np.ndarray]]:
    """Both branches for each areal density, with the fold point included exactly."""
    lam_star = fold_A(kappa)[0]
    lam = np.logspace(-14, 0, 800)
    if lam_star < 1.0:
        lam = np.unique(np.append(lam, lam_star))
    return {s: trace_branches_A(s, kappa=kappa, lambdas=lam) for s in sigmas_kg_m2}


def figure(path: Path, data: dict[float, dict[str, np.ndarray]], kappa: float) -> Path:
    lam_star = fold_A(kappa)[0]
    fig, axes = plt.subplots(2, 2, figsize=(11, 8), sharex=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (s, c) in enumerate(data.items()):
        col = colors[i % len(colors)]
        heavy = c["heavy"]
        light_idx = np.flatnonzero(~heavy & (c["side_m"] >= D_RANGE_M[0] / 1.05))  # autoscale on the shown range
        heavy_idx = np.concatenate([light_idx[-1:], np.flatnonzero(heavy)])  # join at the fold
        i_star = int(np.argmin(np.abs(c["lambda_f"] - lam_star)))
        i_one = int(np.argmin(np.abs(c["lambda_f"] - 1.0)))
        branches = [("light", light_idx, "-")] + ([("heavy", heavy_idx, "--")] if heavy.any() else [])
        for ax, (key, label, scale) in zip(axes.ravel(), PANELS):
            y = c[key] * scale
            for branch, idx, style in branches:
                name = f"σ_A = {s * 1e3:g} g/m², {branch}" if key == "lambda_f" else None
                ax.plot(c["side_m"][idx], y[idx], style, color=col, label=name)
            if lam_star <= 1.0:
                ax.plot(c["side_m"][i_star], y[i_star], "o", color=col, mfc="white", ms=7)
            ax.plot(c["side_m"][i_one], y[i_one], "*", color=col, ms=12)
    for ax, (key, label, _) in zip(axes.ravel(), PANELS):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(*D_RANGE_M)
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.25)
    axes[0, 0].axhline(1.0, color="k", lw=0.8, ls=":")
    axes[0, 0].set_ylim(1e-6, 2.0)
    axes[0, 0].text(
        0.97,
        0.55,
        "no solution beyond the fold\n(λ_u > h* = (3/κ)·4^(-4/3))",
        transform=axes[0, 0].transAxes,
        ha="right",
        fontsize=8,
        color="0.35",
    )
    for ax in axes[1]:
        ax.set_xlabel("plate side D [m]")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    handles += [
        Line2D([], [], ls="", marker="o", mfc="white", color="k"),
        Line2D([], [], ls="", marker="*", color="k", ms=10),
    ]
    labels += [f"fold λ* = 3/κ = {lam_star:.3g}", "λ_f = 1"]
    axes[0, 0].legend(handles, labels, fontsize=7, loc="lower right")
    fig.suptitle(f"Geometry A (perimeter loop), κ = {kappa:g}: λ_f = λ_u (1 + κ λ_f)^(4/3), both branches")
    fig.tight_layout()
    return save_figure(fig, path)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--areal-density-g-m2", type=float, nargs="+", default=[1.0, 10.0, 100.0], help="σ_A [g/m²]")
    ap.add_argument("--kappa", type=float, default=15.0, help="rim-inertia factor κ (paper 15, physical 1)")
    ap.add_argument("--out", default="runs/current_loops/scaling", help="output folder")
    args = ap.parse_args(argv)
    try:
        data = curves([s * 1e-3 for s in args.areal_density_g_m2], args.kappa)
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    arrays = {f"{k}_s{s * 1e3:g}": v for s, c in data.items() for k, v in c.items()}
    write_npz(
        out / "fig3_scaling_A.npz", kappa=np.array(args.kappa), areal_density_kg_m2=np.array(list(data)), **arrays
    )
    figure(out / "fig3_scaling_A.png", data, args.kappa)
    for s, c in data.items():
        i_star = int(np.argmax(c["side_m"]))
        i_one = int(np.argmin(np.abs(c["lambda_f"] - 1.0)))
        print(
            f"σ_A = {s * 1e3:g} g/m²: fold at D = {c['side_m'][i_star]:.1f} m (λ_f = {c['lambda_f'][i_star]:.3g}); "
            f"λ_f = 1 at D = {c['side_m'][i_one]:.1f} m"
        )
    print(f"wrote {out}/fig3_scaling_A.{{png,npz}}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
