"""Geometries B, C, D at N = 27 against plate size (Robb et al. 2022b, Eqs. 2–11 and Fig. 4).

Uniform mass, so every quantity is a power law in ``D``::

    λ_f = C1 G(N) D^{5/3} σ_A^{1/3},   I = μ σ_A D⁴ / (8 A_e B0 R_E³),   d ∝ I^{2/3},   P_J = ε σ_B π d l Γ_e⁴

Panels λ_f, d, I, P_J/D² on log axes over ``D`` = 10 m–100 km; colour = geometry, line style =
``σ_A``; solid up to ``D_max`` (λ_f = 1, star), faint beyond. Writes ``fig4_scaling_BCD.png`` and
``fig4_scaling_BCD.npz`` (``side_m`` and ``<g>_<quantity>_s<σ in g/m²>``) into ``--out``.

    python scripts/current_loops_fig4_scaling_BCD.py [--units 27] [--areal-density-g-m2 1 10 100] [--out DIR]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from magsail_mj.analysis.loop_scaling import side_max, uniform_curves
from magsail_mj.io import write_npz
import matplotlib.pyplot as plt
from magsail_mj.plotting import save_figure
from magsail_mj.analysis.loop_scaling import radiated_power, required_current, table1, wire_diameter

GEOMS = ("B", "C", "D")
PANELS = (
    ("lambda_f", "conductor mass fraction λ_f"),
    ("wire_diameter_m", "wire diameter d [m]"),
    ("current_A", "current I [A]"),
    ("power_per_area_W_m2", "Joule power P_J/D² [W/m²]"),
)
STYLES = ("-", "--", ":", "-.")


def curves(units: int, sigmas_kg_m2: list[float], side_m: np.ndarray) -> dict:
    """``{(g, σ): curves}`` and ``{(g, σ): D_max}``."""
    data = {
        (g, s): uniform_curves(g, units=units, side_m=side_m, areal_density_kg_m2=s)
        for g in GEOMS
        for s in sigmas_kg_m2
    }
    dmax = {(g, s): side_max(g, units=units, areal_density_kg_m2=s) for g in GEOMS for s in sigmas_kg_m2}
    return {"curves": data, "side_max_m": dmax}


def figure(path: Path, res: dict, units: int, sigmas: list[float]) -> Path:
    colors = dict(zip(GEOMS, ("tab:blue", "tab:green", "tab:red")))
    fig, axes = plt.subplots(2, 2, figsize=(11, 8), sharex=True)
    for (g, s), c in res["curves"].items():
        style = STYLES[sigmas.index(s) % len(STYLES)]
        Dm = res["side_max_m"][(g, s)]
        ok = c["side_m"] <= Dm
        area, length = table1(g, units, Dm)
        I_m = required_current(area, Dm, s)
        d_m = wire_diameter(I_m)
        at_max = {
            "lambda_f": 1.0,
            "current_A": I_m,
            "wire_diameter_m": d_m,
            "power_per_area_W_m2": radiated_power(d_m, length) / Dm**2,
        }
        for ax, (key, label) in zip(axes.ravel(), PANELS):
            ax.plot(
                c["side_m"][ok],
                c[key][ok],
                style,
                color=colors[g],
                label=f"{g}, σ_A = {s * 1e3:g} g/m²" if key == "lambda_f" else None,
            )
            ax.plot(c["side_m"][~ok], c[key][~ok], style, color=colors[g], alpha=0.25)
            ax.plot(Dm, at_max[key], "*", color=colors[g], ms=10)
    for ax, (key, label) in zip(axes.ravel(), PANELS):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(c["side_m"][0], c["side_m"][-1])
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.25)
    axes[0, 0].axhline(1.0, color="k", lw=0.8, ls=":")
    axes[0, 0].set_ylim(1e-6, 1e2)
    for ax in axes[1]:
        ax.set_xlabel("plate side D [m]")
    axes[0, 0].legend(fontsize=7, loc="upper left", ncol=1)
    fig.suptitle(f"Geometries B, C, D at N = {units} (uniform mass); ★ = D_max (λ_f = 1), faint = λ_f > 1")
    fig.tight_layout()
    return save_figure(fig, path)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--units", type=int, default=27, help="cubic units per side N")
    ap.add_argument("--areal-density-g-m2", type=float, nargs="+", default=[1.0, 10.0, 100.0], help="σ_A [g/m²]")
    ap.add_argument("--out", default="runs/current_loops/scaling", help="output folder")
    args = ap.parse_args(argv)
    sigmas = [s * 1e-3 for s in args.areal_density_g_m2]
    side = np.logspace(1, 5, 401)
    try:
        res = curves(args.units, sigmas, side)
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    arrays = {f"{g}_{k}_s{s * 1e3:g}": v for (g, s), c in res["curves"].items() for k, v in c.items() if k != "side_m"}
    arrays.update({f"{g}_side_max_m_s{s * 1e3:g}": np.array(v) for (g, s), v in res["side_max_m"].items()})
    write_npz(out / "fig4_scaling_BCD.npz", side_m=side, units=np.array(args.units), **arrays)
    figure(out / "fig4_scaling_BCD.png", res, args.units, sigmas)
    for (g, s), v in res["side_max_m"].items():
        print(f"{g}, N = {args.units}, σ_A = {s * 1e3:g} g/m²: D_max = {v:.1f} m")
    print(f"wrote {out}/fig4_scaling_BCD.{{png,npz}}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
