"""Torque allocation and Lloyd rod selection demonstration (Robb et al. 2022a, Sec. 3, Figs. 15–16).

Writes into ``--out`` (default ``runs/allocation_demo``):

- ``allocation_demo.png``: (a) the Voronoi diagram of 21 random points in the unit square with
  their generators (like Fig. 16a); (b) a 10 × 10 array, sites at the cell centres
  ``((i + ½)/10, (j + ½)/10)`` (our choice: the paper gives neither region nor sites),
  72 rods to activate: the final Lloyd cells, the
  generators and the 72 chosen sites among the 100 (like Fig. 16b); (c) the Fig. 15 example:
  single-rod torques τ1, τ2 for a field at an arbitrary angle to the array, a reference torque
  and its approximation ``N1 τ1 + N2 τ2`` with small integers, drawn in the plane normal to B;
- ``summary.json``: the summary keys ``n_sites``, ``n_active``, ``lloyd_iterations``,
  ``lloyd_tol_rel``, ``lloyd_time_s``, ``snap_time_s``, ``nn_spacing_cv`` plus the covering
  radius (largest distance from a point of the square to the nearest active site; the
  nearest-neighbour CV is a weak evenness measure at 72 % occupancy of a grid), the same two
  figures for the random start snapped, the seed, the machine and the Fig. 15 numbers; with
  ``--bench-truss`` also the cost of one control call (allocation + cached Lloyd look-up) on
  the 75 m truss's 380 + 380 rods and the one-off cost of the Lloyd runs of every count.

    python scripts/allocation_demo.py
    python scripts/allocation_demo.py --bench-truss --workers 2 --cache-dir runs/lloyd_cache
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from magsail_mj.control.allocation import TorqueDistributor, allocate
from magsail_mj.control.lloyd import (
    LloydSelector,
    covering_radius,
    initial_generators,
    lloyd,
    nn_spacing_cv,
    snap_to_sites,
    voronoi_cells,
)
from magsail_mj.io import write_json
import matplotlib.pyplot as plt
from magsail_mj.plotting import save_figure
from matplotlib.collections import PolyCollection
from magsail_mj.lattice.geometry import make_lattice
from magsail_mj.loads.magnetorquer_rods import rod_array, rod_dipole_Am2

UNIT = (0.0, 0.0, 1.0, 1.0)


def machine() -> dict:
    """A short description of the machine the timings come from."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        "platform": platform.platform(),
    }


def demo_array(*, n_side: int, n_active: int, seed: int, tol_rel: float, max_iter: int) -> dict:
    """Lloyd + snapping for ``n_active`` of the ``n_side²`` cell-centre sites of the unit square."""
    g = (np.arange(n_side) + 0.5) / n_side
    X, Y = np.meshgrid(g, g, indexing="xy")
    sites = np.column_stack([X.ravel(), Y.ravel()])
    res = lloyd(n_active, region=UNIT, seed=seed, tol_rel=tol_rel, max_iter=max_iter)
    t0 = time.perf_counter()
    chosen = snap_to_sites(res.generators, sites)
    snap_s = time.perf_counter() - t0
    return {
        "sites": sites,
        "result": res,
        "chosen": chosen,
        "snap_time_s": snap_s,
        "initial": initial_generators(n_active, UNIT, seed=seed),
    }


def fig15_example() -> dict:
    """Field at an arbitrary angle to the array; T_ref near 2 τ1 + 2 τ2 (unit rod dipole)."""
    B = 30e-6 * np.array([0.45, 0.35, 0.82]) / np.linalg.norm([0.45, 0.35, 0.82])
    m_rod = 1.0
    al0 = allocate([0, 0, 0], B, m_rod_Am2=m_rod, n_max=10)
    t1, t2 = np.asarray(al0.tau1_body), np.asarray(al0.tau2_body)
    T_ref = 2.2 * t1 + 1.85 * t2
    al = allocate(T_ref, B, m_rod_Am2=m_rod, n_max=10)
    return {
        "B_body_T": B,
        "m_rod_Am2": m_rod,
        "tau1_Nm": t1,
        "tau2_Nm": t2,
        "T_ref_Nm": T_ref,
        "N1": al.N1,
        "N2": al.N2,
        "T_Nm": al.torque_body,
        "error_Nm": float(np.linalg.norm(al.torque_body - T_ref)),
        "bound_Nm": 0.5 * float(np.linalg.norm(t1) + np.linalg.norm(t2)),
    }


def figure(path: Path, *, pts21: np.ndarray, demo: dict, fig15: dict) -> Path:
    fig, axs = plt.subplots(1, 3, figsize=(17, 5.6))
    ax = axs[0]
    ax.add_collection(PolyCollection(voronoi_cells(pts21, UNIT), facecolors="none", edgecolors="0.3", lw=0.8))
    ax.plot(pts21[:, 0], pts21[:, 1], "k.", ms=7)
    ax.set_title(f"(a) Voronoi diagram of {len(pts21)} random points")

    ax = axs[1]
    res, sites, chosen = demo["result"], demo["sites"], demo["chosen"]
    ax.add_collection(PolyCollection(voronoi_cells(res.generators, UNIT), facecolors="none", edgecolors="0.45", lw=0.8))
    off = np.setdiff1d(np.arange(len(sites)), chosen)
    ax.plot(sites[off, 0], sites[off, 1], "s", mfc="none", mec="0.6", ms=7, label="site (off)")
    ax.plot(sites[chosen, 0], sites[chosen, 1], "s", color="tab:red", ms=7, label="site (on)")
    ax.plot(res.generators[:, 0], res.generators[:, 1], "k.", ms=5, label="CVT generator")
    ax.set_title(f"(b) {len(chosen)} of {len(sites)} sites: Lloyd ({res.iterations} it.) + assignment")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.04), ncol=3, fontsize=8, frameon=False)
    for a in axs[:2]:
        a.set_xlim(0, 1)
        a.set_ylim(0, 1)
        a.set_aspect("equal")
        a.set_xticks([0, 0.5, 1])
        a.set_yticks([0, 0.5, 1])

    ax = axs[2]
    B = fig15["B_body_T"]
    t1, t2, Tr, T = fig15["tau1_Nm"], fig15["tau2_Nm"], fig15["T_ref_Nm"], fig15["T_Nm"]
    e1 = t1 / np.linalg.norm(t1)
    e2 = np.cross(B / np.linalg.norm(B), e1)
    P = lambda v: np.array([v @ e1, v @ e2])  # noqa: E731  (coordinates in the plane normal to B)
    ii, jj = np.meshgrid(np.arange(-1, 4), np.arange(-1, 4))
    grid = np.array([P(i * t1 + j * t2) for i, j in zip(ii.ravel(), jj.ravel())])
    ax.plot(grid[:, 0], grid[:, 1], ".", color="0.7", label="N1 τ1 + N2 τ2 (integers)")
    for v, c, lab in (
        (t1, "tab:blue", "τ1 = m x̂1 × B"),
        (t2, "tab:green", "τ2 = m ŷ1 × B"),
        (Tr, "k", "T_ref"),
        (T, "tab:red", f"N1 τ1 + N2 τ2, N1={fig15['N1']}, N2={fig15['N2']}"),
    ):
        p = P(v)
        ax.annotate("", xy=p, xytext=(0, 0), arrowprops=dict(arrowstyle="->", color=c, lw=1.8))
        ax.plot([], [], color=c, label=lab)
    ax.set_aspect("equal")
    ax.legend(fontsize=8, loc="lower left")
    ax.set_xlabel("along τ1 [N m]")
    ax.set_ylabel("along B̂ × τ̂1 [N m]")
    ax.set_title("(c) Fig. 15 example, plane normal to B (m_rod = 1 A m²)")
    fig.tight_layout()
    return save_figure(fig, path)


def bench_truss(*, seed: int, tol_rel: float, max_iter: int, workers: int, cache_dir: str | None, n_calls: int) -> dict:
    """Per-call cost of allocation + selection on the 75 m truss (380 + 380 rods)."""
    rods = rod_array(make_lattice(units=19, side_m=75.0))
    m = rod_dipole_Am2(kappa_Am2_kg=100.0, rod_mass_kg=100.0, rods_per_family=rods.n_per_family)
    dist = TorqueDistributor.for_rods(
        rods, m_rod_Am2=m, seed=seed, tol_rel=tol_rel, max_iter=max_iter, cache_dir=cache_dir
    )
    sel: LloydSelector = dist.selector
    t0 = time.perf_counter()
    sel.precompute(workers=workers)
    pre_wall = time.perf_counter() - t0
    counts = [c for c in range(max(sel.n_sites)) if c > 0]
    lt = np.array([sel.result(c).time_s for c in counts])
    its = np.array([sel.result(c).iterations for c in counts])
    rng = np.random.default_rng(1)
    u = rng.normal(size=(n_calls, 3))
    Bs = (20e-6 + 25e-6 * rng.random((n_calls, 1))) * u / np.linalg.norm(u, axis=1, keepdims=True)
    v = rng.normal(size=(n_calls, 3))
    Ts = 10 ** rng.uniform(-4, 0, (n_calls, 1)) * v / np.linalg.norm(v, axis=1, keepdims=True)
    for k in range(min(n_calls, 200)):  # warm-up
        dist(Ts[k], Bs[k])
    per = np.empty(n_calls)
    for k in range(n_calls):
        t = time.perf_counter()
        dist(Ts[k], Bs[k])
        per[k] = time.perf_counter() - t
    alloc = np.empty(n_calls)
    for k in range(n_calls):
        t = time.perf_counter()
        allocate(Ts[k], Bs[k], m_rod_Am2=m, n_max=380)
        alloc[k] = time.perf_counter() - t
    return {
        "truss_sites_per_family": list(sel.n_sites),
        "truss_m_rod_Am2": list(m),
        "precompute_wall_s": pre_wall,
        "precompute_workers": workers,
        "precompute_from_disk_counts": sel.stats["disk_hits"],
        "lloyd_time_per_count_mean_s": float(lt.mean()),
        "lloyd_time_per_count_max_s": float(lt.max()),
        "lloyd_time_all_counts_sum_s": float(lt.sum()),
        "lloyd_iterations_per_count_mean": float(its.mean()),
        "lloyd_iterations_per_count_max": int(its.max()),
        "lloyd_all_converged": bool(all(sel.result(c).converged for c in counts)),
        "call_time_median_us": float(np.median(per) * 1e6),
        "call_time_mean_us": float(per.mean() * 1e6),
        "call_time_p99_us": float(np.quantile(per, 0.99) * 1e6),
        "allocate_time_median_us": float(np.median(alloc) * 1e6),
        "n_calls": n_calls,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="runs/allocation_demo", help="output folder")
    ap.add_argument("--seed", type=int, default=0, help="Lloyd seed (sim.seed)")
    ap.add_argument("--tol-rel", type=float, default=1e-6)
    ap.add_argument("--max-iter", type=int, default=10_000)
    ap.add_argument("--n-side", type=int, default=10, help="demonstration array is n × n")
    ap.add_argument("--n-active", type=int, default=72)
    ap.add_argument(
        "--bench-truss",
        action="store_true",
        help="also time allocation + selection on the 380 + 380 rods of the 75 m truss",
    )
    ap.add_argument("--workers", type=int, default=1, help="processes for the truss precompute")
    ap.add_argument("--cache-dir", default=None, help="on-disk Lloyd cache for --bench-truss")
    ap.add_argument("--n-calls", type=int, default=20_000)
    args = ap.parse_args(argv)
    if not 0 <= args.n_active <= args.n_side**2:
        ap.error(f"--n-active: must be between 0 and {args.n_side**2}, got {args.n_active}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    pts21 = initial_generators(21, UNIT, seed=args.seed)
    demo = demo_array(
        n_side=args.n_side, n_active=args.n_active, seed=args.seed, tol_rel=args.tol_rel, max_iter=args.max_iter
    )
    f15 = fig15_example()
    figure(out / "allocation_demo.png", pts21=pts21, demo=demo, fig15=f15)
    res = demo["result"]
    sites = demo["sites"]
    rand = snap_to_sites(demo["initial"], sites)  # the random start snapped, for comparison
    summary = {
        "n_sites": int(args.n_side**2),
        "n_active": int(args.n_active),
        "lloyd_iterations": res.iterations,
        "lloyd_converged": res.converged,
        "lloyd_tol_rel": args.tol_rel,
        "lloyd_max_iter": args.max_iter,
        "lloyd_final_move_rel": res.max_move / (UNIT[2] - UNIT[0]),
        "lloyd_time_s": res.time_s,
        "snap_time_s": demo["snap_time_s"],
        "nn_spacing_cv": nn_spacing_cv(sites[demo["chosen"]]),
        "nn_spacing_cv_initial_snapped": nn_spacing_cv(sites[rand]),
        "covering_radius": covering_radius(sites[demo["chosen"]], UNIT),
        "covering_radius_initial_snapped": covering_radius(sites[rand], UNIT),
        "seed": args.seed,
        "chosen_sites": demo["chosen"],
        "fig15": f15,
        "machine": machine(),
    }
    if args.bench_truss:
        summary["truss_bench"] = bench_truss(
            seed=args.seed,
            tol_rel=args.tol_rel,
            max_iter=args.max_iter,
            workers=args.workers,
            cache_dir=args.cache_dir,
            n_calls=args.n_calls,
        )
    write_json(out / "summary.json", summary)
    print(
        json.dumps(
            {k: v for k, v in summary.items() if k not in ("chosen_sites", "fig15", "machine")},
            default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o),
            indent=1,
        )
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
