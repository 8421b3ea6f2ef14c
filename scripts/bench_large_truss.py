"""The 100 m truss at 60 × 60 × 2 nodes against the 800-node Case A lattice: cost, step, memory.

Benchmarks the distributed bang-bang Case A of the distributed-torque experiment (100 m, 100 kg,
EI = 1000 N m², torque 0.1 N m about x1; Robb et al. 2022a) at two lattice sizes, each in its own
process (so that ``peak_rss_mb`` is the size's own), and prints one JSON object:

* ``sizes`` — per size: ``nodes`` (2 (units + 1)²), ``struts``, ``dofs``, ``build_s`` (the wall
  time of :func:`magsail_mj.load`: lattice, calibration, MJCF, compile; generic actuators have no
  Lloyd selection, so ``lloyd_selection_s`` is ``null``), ``omega_max_rad_s`` (the highest
  natural frequency √λ_max(M⁻¹K) of the free, undamped lattice, from a sparse eigensolve) with
  the explicit stability bounds 2/ω_max (symplectic Euler) and 2.83/ω_max (RK4) [s], and the
  :func:`magsail_mj.bench.bench` figures of a short run (``us_per_step`` all-in,
  ``mj_step_us`` bare, ``ratio_to_mj_step``, ``parts_us``, ``peak_rss_mb``), plus
  ``cost_per_sim_s_ms`` = ``us_per_step`` / δt / 1000 (wall ms per simulated second) and
  ``us_per_step_per_node``;
* ``ratios`` — large over small: per step (all-in and bare ``mj_step``), per node, per simulated
  second, and the node ratio itself (cost per step growing no faster than the node count means
  ``per_step ≤ nodes``).

Both sizes run with the large config's integrator, each at its own config step (the 800-node
config at its papers' 0.1 s unless ``--small-dt`` says otherwise), so that the per-step ratio
compares like with like; the per-simulated-second ratio then includes the smaller stable step.

    python scripts/bench_large_truss.py                       # 20 s simulated per size (minutes)
    python scripts/bench_large_truss.py --duration-s 60 --repeat 3

Timings are wall-clock on a shared machine: compare the ratios measured in one call.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from scipy.sparse import diags
from scipy.sparse.linalg import eigsh

import magsail_mj
from magsail_mj.bench import bench
from magsail_mj.config import load_config
from magsail_mj.lattice.geometry import stiffness_matrix

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_a_distributed_bangbang.toml"
LARGE = ROOT / "models/truss_magnetorquer/large/case_a_100m_distributed.toml"

#: the RK4 stability limit of the undamped oscillator: |ω δt| < 2√2
RK4_BOUND = 2.0 * np.sqrt(2.0)


def omega_max_rad_s(tm) -> float:
    """Highest natural frequency √λ_max(M⁻¹K) [rad/s] of the free lattice (linear, undamped)."""
    K = stiffness_matrix(tm.lattice.nodes, tm.lattice.struts, tm.k)
    s = diags(np.repeat(1.0 / np.sqrt(tm.masses), 3))
    return float(np.sqrt(eigsh(s @ K @ s, k=1, which="LA", return_eigenvectors=False)[0]))


def one_size(config: str, *, overrides: list[str], duration_s: float, repeat: int) -> dict:
    """The figures of one lattice size (run in its own process)."""
    t0 = time.perf_counter()
    sim = magsail_mj.load(config, overrides + [f"sim.duration_s={duration_s!r}"])
    build_s = time.perf_counter() - t0
    tm = sim.scenario.tm
    w = omega_max_rad_s(tm)
    dt = float(sim.model.opt.timestep)
    del sim
    cfg = load_config(config, overrides)
    out = bench(cfg, duration_s=duration_s, repeat=repeat)
    nodes = int(tm.lattice.nodes.shape[0])
    return {
        "config": str(config),
        "overrides": overrides,
        "units": int(cfg.lattice.units),
        "nodes": nodes,
        "struts": int(len(tm.lattice.struts)),
        "dofs": 3 * nodes,
        "build_s": build_s,
        "lloyd_selection_s": None,
        "omega_max_rad_s": w,
        "euler_bound_s": 2.0 / w,
        "rk4_bound_s": RK4_BOUND / w,
        "omega_max_dt": w * dt,
        "cost_per_sim_s_ms": out["us_per_step"] / dt / 1e3,
        "us_per_step_per_node": out["us_per_step"] / nodes,
        **out,
    }


def _child(args: argparse.Namespace) -> int:
    res = one_size(args.child, overrides=args.set, duration_s=args.duration_s, repeat=args.repeat)
    print(json.dumps(res), flush=True)
    return 0


def _run_child(config: Path, overrides: list[str], args: argparse.Namespace) -> dict:
    cmd = [sys.executable, __file__, "--child", str(config), "--duration-s", repr(args.duration_s)]
    cmd += ["--repeat", str(args.repeat)] + [a for o in overrides for a in ("--set", o)]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"error: {config}: the benchmark process failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def ratios(small: dict, large: dict) -> dict:
    """Large over small: per step, per bare step, per node, per simulated second, node count."""
    return {
        "nodes": large["nodes"] / small["nodes"],
        "per_step": large["us_per_step"] / small["us_per_step"],
        "per_bare_mj_step": large["mj_step_us"] / small["mj_step_us"],
        "per_node_per_step": large["us_per_step_per_node"] / small["us_per_step_per_node"],
        "per_sim_s": large["cost_per_sim_s_ms"] / small["cost_per_sim_s_ms"],
        "peak_rss": large["peak_rss_mb"] / small["peak_rss_mb"],
        "build": large["build_s"] / small["build_s"],
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--duration-s", type=float, default=20.0, help="simulated seconds per pass (default 20)")
    p.add_argument("--repeat", type=int, default=1, help="timed passes per size (medians; default 1)")
    p.add_argument("--large", default=str(LARGE), help="the large config (default: the shipped 7 200-node one)")
    p.add_argument("--small-dt", type=float, default=None, help="step of the 800-node run [s] (default: its own)")
    p.add_argument("--child", default=None, help=argparse.SUPPRESS)
    p.add_argument("--set", action="append", default=[], help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        return _child(args)
    large_cfg = load_config(args.large)
    same = [f"sim.integrator='{large_cfg.sim.integrator}'"]
    same += [f"sim.timestep_s={args.small_dt!r}"] if args.small_dt is not None else []
    small = _run_child(SMALL, same, args)
    large = _run_child(Path(args.large), [], args)
    print(
        json.dumps({"duration_s": args.duration_s, "sizes": [small, large], "ratios": ratios(small, large)}, indent=1)
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
