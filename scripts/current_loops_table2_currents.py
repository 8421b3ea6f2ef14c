"""Loop currents and thermal sizing for the simulations (Robb et al. 2022b, Eqs. 2–11 and Table 2).

For geometries A–D and ``N ∈ {12, 19, 27}`` at ``D = 250 m``, ``σ_A = 100 g/m²`` (A on the light
branch, ``κ = 15``): the Eq.-9 current ``I``, the equilibrium wire diameter ``d``, the conductor
mass fraction ``λ_f``, the Joule power per plate area ``P_J/D²`` and the dipole ``m_max = I A_e``.

Writes into ``--out`` (default ``runs/current_loops/scaling``):

- ``table2_currents.csv`` (one row per geometry and N) and ``table2_currents.md``;
- ``table2_currents.json``: the ``scaling`` summary object plus ``C1`` and the sunlight check;
- ``table2_currents.png``: the four quantities as grouped bars.

Also prints the Markdown table on stdout.

    python scripts/current_loops_table2_currents.py [--side-m 250] [--areal-density-g-m2 100] [--kappa 15] [--out DIR]
"""

from __future__ import annotations

import argparse
import csv
import io
import sys
from pathlib import Path

import numpy as np

from magsail_mj.analysis.loop_scaling import (
    GEOMETRIES,
    c1,
    loop_sizing,
    scaling_table,
    sunlight_diameter_ratio,
)
from magsail_mj.io import atomic_path, write_json
import matplotlib.pyplot as plt
from magsail_mj.plotting import save_figure

UNITS = (12, 19, 27)
COLUMNS = (
    "geometry",
    "units",
    "current_A",
    "wire_diameter_m",
    "lambda_f",
    "power_per_area_W_m2",
    "dipole_max_Am2",
    "area_m2",
    "path_length_m",
    "conductor_mass_kg",
)


def rows(side_m: float, sigma: float, kappa: float) -> list[dict]:
    """One :func:`loop_sizing` dict per geometry and ``N``."""
    return [
        loop_sizing(g, units=N, side_m=side_m, areal_density_kg_m2=sigma, kappa=kappa)
        for g in GEOMETRIES
        for N in UNITS
    ]


def table_md(table: list[dict], side_m: float, sigma: float, kappa: float) -> str:
    lines = [
        f"D = {side_m:g} m, σ_A = {sigma * 1e3:g} g/m², κ = {kappa:g} (A, light branch), C1 = {c1():.5e} m⁻¹ kg^(-1/3)",
        "",
        "| geometry | N | I [A] | d [mm] | λ_f [%] | P_J/D² [W/m²] | m_max [A m²] | l [m] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in table:
        lines.append(
            f"| {r['geometry']} | {r['units']} | {r['current_A']:.2f} | {r['wire_diameter_m'] * 1e3:.3f} "
            f"| {r['lambda_f'] * 100:.3f} | {r['power_per_area_W_m2']:.3f} "
            f"| {r['dipole_max_Am2']:.4e} | {r['path_length_m']:.0f} |"
        )
    return "\n".join(lines) + "\n"


def figure(path: Path, table: list[dict]) -> Path:
    panels = [
        ("current_A", "current I [A]", 1.0),
        ("wire_diameter_m", "wire diameter d [mm]", 1e3),
        ("lambda_f", "conductor mass fraction λ_f [%]", 100.0),
        ("power_per_area_W_m2", "Joule power P_J/D² [W/m²]", 1.0),
    ]
    fig, axes = plt.subplots(2, 2, figsize=(10, 7))
    x = np.arange(len(GEOMETRIES))
    width = 0.26
    for ax, (key, label, scale) in zip(axes.ravel(), panels):
        for j, N in enumerate(UNITS):
            vals = [scale * next(r[key] for r in table if r["geometry"] == g and r["units"] == N) for g in GEOMETRIES]
            bars = ax.bar(x + (j - 1) * width, vals, width, label=f"N = {N}")
            ax.bar_label(bars, fmt="%.3g", fontsize=6, padding=1)
        ax.set_xticks(x, GEOMETRIES)
        ax.set_ylabel(label)
        ax.grid(True, axis="y", alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    D, s = table[0]["side_m"], table[0]["areal_density_kg_m2"]
    fig.suptitle(f"Eq.-9 loop sizing, D = {D:g} m, σ_A = {s * 1e3:g} g/m² (A: light branch)")
    fig.tight_layout()
    return save_figure(fig, path)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--side-m", type=float, default=250.0, help="plate side D [m]")
    ap.add_argument("--areal-density-g-m2", type=float, default=100.0, help="σ_A [g/m²]")
    ap.add_argument("--kappa", type=float, default=15.0, help="geometry A rim-inertia factor κ")
    ap.add_argument("--out", default="runs/current_loops/scaling", help="output folder")
    args = ap.parse_args(argv)
    sigma = args.areal_density_g_m2 * 1e-3
    try:
        table = rows(args.side_m, sigma, args.kappa)
        summary = scaling_table(side_m=args.side_m, areal_density_kg_m2=sigma, kappa=args.kappa)
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    summary["sunlight_diameter_ratio"] = sunlight_diameter_ratio()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=COLUMNS, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    writer.writerows(table)
    with atomic_path(out / "table2_currents.csv") as tmp:
        tmp.write_text(buf.getvalue())
    md = table_md(table, args.side_m, sigma, args.kappa)
    with atomic_path(out / "table2_currents.md") as tmp:
        tmp.write_text(md)
    write_json(out / "table2_currents.json", summary)
    figure(out / "table2_currents.png", table)
    print(md, end="")
    print(f"wrote {out}/table2_currents.{{csv,md,json,png}}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
