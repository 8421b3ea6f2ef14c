"""Outputs of the 36-run structural sweep (Robb et al. 2022b, Tables 3–4): summary table,
U(t) panels, ratio tables, videos.

    magsail sweep magsail_mj/concepts/current_loops/configs/sweep36.toml --workers 2 --out runs/current_loops/sweep36
    python scripts/current_loops_tables3_4_sweep.py --sweep runs/current_loops/sweep36 [--videos]

Reads every run folder ``sweep/<g>_n<N>_ei<E>`` that exists (runs not done yet are listed as
such) and writes into the sweep folder:

* ``table_s4.md`` / ``table_s4.csv``: max U, time of max U, h_max, ρ_max, max strain, final
  rotation, rigid-reference deviation, classification, wall time for every run;
* ``ratios_s4.md``: max U_B / max U_A and max U_D / max U_C for each N and EI;
* ``fig_strain_energy_A.png`` (geometry A, all nine runs) and ``fig_strain_energy_BCD.png``
  (B, C_y, D_y at EI = 1e4);
* with ``--videos``: side-by-side MP4s A vs B and C_y vs D_y at EI = 1e4, and geometry A at
  EI = 1e3 vs 1e5, all at N = ``--video-units`` (default 19; 12 when only the N = 12 runs exist).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib.pyplot as plt
from magsail_mj.records import lazy_arrays
from magsail_mj.render import render_run

GEOMS = {"a": "A", "b": "B", "cy": "C_y", "dy": "D_y"}
UNITS = (12, 19, 27)
EIS = ("1e3", "1e4", "1e5")


def _load(sweep: Path, g: str, N: int, E: str) -> dict | None:
    run = sweep / "sweep" / f"{g}_n{N}_ei{E}"
    try:
        summary = json.loads((run / "summary.json").read_text())
        manifest = json.loads((run / "manifest.json").read_text())
    except (OSError, ValueError):
        return None
    summary["_wall_s"] = manifest.get("wall_time_s")
    summary["_dir"] = run
    return summary


def _fmt(v, spec: str = ".4g") -> str:
    return "–" if v is None else format(v, spec) if isinstance(v, (int, float)) else str(v)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sweep", default="runs/current_loops/sweep36", help="sweep output folder")
    ap.add_argument("--videos", action="store_true", help="also render the side-by-side MP4s")
    ap.add_argument("--video-units", type=int, default=19, choices=UNITS, help="N of the video runs (default 19)")
    args = ap.parse_args(argv)
    sweep = Path(args.sweep)
    runs = {(g, N, E): _load(sweep, g, N, E) for g in GEOMS for N in UNITS for E in EIS}

    cols = [
        "run",
        "geometry",
        "N",
        "EI",
        "status",
        "U_max_J",
        "t_U_max_s",
        "h_max_m",
        "rho_max_m",
        "strain_max",
        "rot_final_rad",
        "rot_dev_rigid_max_rad",
        "class",
        "wall_s",
    ]
    rows = []
    for (g, N, E), s in runs.items():
        if s is None:
            rows.append([f"{g}_n{N}_ei{E}", GEOMS[g], N, E, "not run"] + [None] * 9)
            continue
        rows.append(
            [
                f"{g}_n{N}_ei{E}",
                GEOMS[g],
                N,
                E,
                s.get("status"),
                s.get("strain_energy_max_J"),
                s.get("t_strain_energy_max_s"),
                s.get("thickness_max_m"),
                s.get("rigid_fit_residual_max_m"),
                s.get("strut_strain_max"),
                s.get("rotation_angle_final_rad"),
                s.get("rotation_dev_from_rigid_max_rad"),
                s.get("classification"),
                s.get("_wall_s"),
            ]
        )
    md = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    md += ["| " + " | ".join(_fmt(v) for v in r) + " |" for r in rows]
    (sweep / "table_s4.md").write_text("\n".join(md) + "\n")
    (sweep / "table_s4.csv").write_text("\n".join(",".join(_fmt(v) for v in r) for r in [cols, *rows]) + "\n")

    def ratio(num: str, den: str) -> list[str]:
        out = [
            f"| max U_{GEOMS[num]} / max U_{GEOMS[den]} | " + " | ".join(f"EI={E}" for E in EIS) + " |",
            "|---|" + "---|" * len(EIS),
        ]
        for N in UNITS:
            vals = []
            for E in EIS:
                a, b = runs[(num, N, E)], runs[(den, N, E)]
                ok = a is not None and b is not None and b.get("strain_energy_max_J")
                vals.append(_fmt(a["strain_energy_max_J"] / b["strain_energy_max_J"], ".3g") if ok else "–")
            out.append(f"| N = {N} | " + " | ".join(vals) + " |")
        return out

    (sweep / "ratios_s4.md").write_text("\n".join(ratio("b", "a") + [""] + ratio("dy", "cy")) + "\n")

    def panel(ax, key, label):
        s = runs[key]
        if s is None:
            ax.text(0.5, 0.5, "not run", ha="center", transform=ax.transAxes)
            return
        z = lazy_arrays(s["_dir"])  # the two series only, read from the run's record store
        ax.plot(z["t"][:], z["strain_energy_J"][:], lw=0.8, label=label)

    def grid(cells, name: str) -> None:
        """3 × 3 U(t) panels; ``cells[i][j]`` = (run key, legend label, panel title)."""
        fig, axs = plt.subplots(3, 3, figsize=(11, 8), sharex=True)
        for i, row in enumerate(cells):
            for j, (key, label, title) in enumerate(row):
                panel(axs[i, j], key, label)
                axs[i, j].set_title(title, fontsize=9)
                axs[i, j].set_ylabel("U [J]")
        for ax in axs[-1]:
            ax.set_xlabel("t [s]")
        fig.tight_layout()
        fig.savefig(sweep / name, dpi=110)
        plt.close(fig)

    grid(
        [[(("a", N, E), f"A N={N} EI={E}", f"A: N = {N}, EI = {E} N m²") for E in EIS] for N in UNITS],
        "fig_strain_energy_A.png",
    )
    grid(
        [
            [((g, N, "1e4"), f"{GEOMS[g]} N={N}", f"{GEOMS[g]}: N = {N}, EI = 1e4 N m²") for N in UNITS]
            for g in ("b", "cy", "dy")
        ],
        "fig_strain_energy_BCD.png",
    )

    if args.videos:
        n = args.video_units
        pairs = [
            (("a", n, "1e4"), ("b", n, "1e4"), f"video_A_vs_B_n{n}_ei1e4.mp4"),
            (("cy", n, "1e4"), ("dy", n, "1e4"), f"video_Cy_vs_Dy_n{n}_ei1e4.mp4"),
            (("a", n, "1e3"), ("a", n, "1e5"), f"video_A_ei1e3_vs_ei1e5_n{n}.mp4"),
        ]
        for left, right, name in pairs:
            if runs[left] is None or runs[right] is None:
                print(f"skipped {name}: a run is missing")
                continue
            labels = [f"{GEOMS[k[0]]} N={k[1]} EI={k[2]}" for k in (left, right)]
            out = render_run(runs[left]["_dir"], sweep / name, compare=runs[right]["_dir"], labels=labels)
            print(f"wrote {out}")
    print((sweep / "table_s4.md").read_text())
    print((sweep / "ratios_s4.md").read_text())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
