"""Rod mass fraction against plate size (Robb et al. 2022a, Sec. 4.1, like Fig. 17).

Writes into ``--out`` (default ``runs/scaling``):

- ``lambda_f_vs_side.png``: ``λ_f = μ d² / (8 B0 R_E³ κ_τ)`` against ``d ∈ [1, 200]`` m for
  ``κ_τ ∈ {10, 50, 100, 200}`` A m²/kg, with the lines ``λ_f = 1`` and ``λ_f = 0.5`` and the
  75 m design point (the required ``λ_f`` at ``κ_τ = 100`` and the design's 50 %);
- ``summary.json`` (and stdout): the ``scaling`` summary keys — ``lambda_f`` per ``κ_τ`` and ``d``,
  ``d_at_lambda_f_1_m`` per ``κ_τ``, ``T_grav_max_Nm``, ``T_ac_max_Nm``, ``B_dipole_T`` for the
  orbital truss of Robb et al. 2022a Sec. 4.2 at 800 km — and the inputs;
- ``table.md``: the same as a Markdown table.

Inputs: the ``[scaling]`` table of ``--config`` (e.g. ``magsail_mj/concepts/truss_magnetorquer/configs/scaling.toml``)
or the defaults (:class:`magsail_mj.analysis.scaling.ScalingInputs`).

    python scripts/scaling_magnetorquer.py [--config magsail_mj/concepts/truss_magnetorquer/configs/scaling.toml] [--out DIR]
"""  # noqa: E501

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from magsail_mj.analysis.scaling import (
    ScalingInputs,
    load_scaling_inputs,
    rod_mass_fraction,
    scaling_tables,
)
from magsail_mj.io import atomic_path, to_jsonable, write_json
import matplotlib.pyplot as plt
from magsail_mj.plotting import save_figure


def figure(path: Path, inputs: ScalingInputs, tables: dict) -> Path:
    kw = dict(mu=inputs.mu_m3_s2, B0_T=inputs.B0_T, R_E_m=inputs.R_E_km * 1e3)
    d = np.linspace(inputs.side_min_m, inputs.side_max_m, inputs.n_points)
    fig, ax = plt.subplots(figsize=(7.5, 5))
    for k in inputs.kappas_Am2_kg:
        ax.plot(d, rod_mass_fraction(d, k, **kw), label=f"κτ = {k:g} A m²/kg")
    ax.axhline(1.0, color="k", lw=1, ls="--", label="λf = 1")
    ax.axhline(0.5, color="0.4", lw=1, ls=":", label="λf = 0.5")
    dd, kd = inputs.design_side_m, inputs.design_kappa_Am2_kg
    needed, design = tables["lambda_f_design_required"], tables["lambda_f_design"]
    ax.plot([dd], [needed], "o", color="tab:red", ms=8, label=f"needed at d = {dd:g} m, κτ = {kd:g}: λf = {needed:.3f}")
    in_rods = f"design: {inputs.rod_mass_kg:g} of {inputs.total_kg:g} kg in rods (λf = {design:.2f})"
    ax.plot([dd], [design], "*", color="tab:red", ms=13, label=in_rods)
    ax.axvline(dd, color="tab:red", lw=0.6, alpha=0.5)
    ax.set_yscale("log")
    ax.set_xlim(inputs.side_min_m, inputs.side_max_m)
    ax.set_ylim(1e-3, 1e2)
    ax.set_xlabel("side length d [m]")
    ax.set_ylabel("rod mass fraction λf needed")
    ax.set_title("λf = μ d² / (8 B0 R_E³ κτ): actuator torque = peak gravity-gradient torque")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    return save_figure(fig, path)


def table_md(inputs: ScalingInputs, tables: dict) -> str:
    sides = inputs.table_sides_m
    lines = [
        "| κτ [A m²/kg] | "
        + " | ".join(f"λf at d = {d:g} m" for d in sides)
        + " | d at λf = 1 [m] | d at λf = 0.5 [m] |",
        "|---" * (len(sides) + 3) + "|",
    ]
    for k in inputs.kappas_Am2_kg:
        key = f"kappa={k:g}"
        lines.append(
            f"| {k:g} | "
            + " | ".join(f"{tables['lambda_f'][key][f'd={d:g}']:.4g}" for d in sides)
            + f" | {tables['d_at_lambda_f_1_m'][key]:.4g} | {tables['d_at_lambda_f_0p5_m'][key]:.4g} |"
        )
    lines += [
        "",
        f"Orbital truss (d = {inputs.design_side_m:g} m, M = {inputs.total_kg:g} kg, "
        f"M_τ = {inputs.rod_mass_kg:g} kg, κτ = {inputs.design_kappa_Am2_kg:g} A m²/kg, "
        f"{inputs.altitude_km:g} km):",
        f"B = {tables['B_dipole_T']:.4g} T, T_grav,max = {tables['T_grav_max_Nm']:.4g} N m, "
        f"T_ac,max = {tables['T_ac_max_Nm']:.4g} N m, margin T_ac/T_grav = {tables['authority_margin']:.3g}",
    ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default=None, help="TOML file with a [scaling] table")
    ap.add_argument("--out", default="runs/scaling", help="output folder")
    args = ap.parse_args(argv)
    inputs = load_scaling_inputs(args.config) if args.config else ScalingInputs()
    tables = scaling_tables(inputs)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    figure(out / "lambda_f_vs_side.png", inputs, tables)
    write_json(out / "summary.json", tables)
    with atomic_path(out / "table.md") as tmp:
        tmp.write_text(table_md(inputs, tables))
    print(json.dumps(to_jsonable(tables)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
