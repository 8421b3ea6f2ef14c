"""Drift of the MSAC total angular momentum without projection, per drive and time step.

For each drive (``replay``: held torques plus joint servos; ``held_torque``: held torques with
a once-per-cycle trim; ``computed_torque``: the Python loop) and time step, runs the paper case
(``paper_1khz.toml``) for ``--cycles`` cycles with ``drive.momentum_projection = false`` and
prints the drift of the total angular momentum about Z per cycle (least-squares slope of its
value at the cycle starts, after the start-up cycle) [N m s], the spurious bus yaw it adds over
the run relative to the run's rotation, the same extrapolated to ``--extrapolate-s`` seconds
(``δψ = r t²/2 ⟨1/D⟩`` for a drift rate ``r``, ``D`` the system MOI about Z along the path)
and the wall time.

Usage: ``python scripts/msac_momentum_drift.py [--cycles 50] [--methods replay,held_torque]
[--timesteps 1e-5,5e-6,2.5e-6] [--extrapolate-s 600]``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import magsail_mj
import numpy as np

from magsail_mj.concepts.msac.cycle import cycle_state
from magsail_mj.concepts.msac.metrics import secular_rate_fit

CONFIG = Path(__file__).resolve().parents[1] / "magsail_mj" / "concepts" / "msac" / "configs" / "paper_1khz.toml"


def drift_row(*, method: str, timestep_s: float, cycles: int, extrapolate_s: float) -> dict[str, float | str]:
    """One run without projection: drift per cycle and the spurious yaw it adds."""
    sim = magsail_mj.load(
        CONFIG,
        [
            f"sim.duration_s={cycles * 1e-3}",
            f"sim.timestep_s={timestep_s}",
            "sim.record_every=1000000",
            "drive.momentum_projection=false",
            f"drive.method='{method}'",
            f"drive.chunk_cycles={min(cycles, 200)}",
        ],
    )
    task = sim.scenario
    t0 = time.perf_counter()
    res = sim.run()
    wall = time.perf_counter() - t0
    summary, _ = task.postprocess(res)
    L = res.records["strobe_angmom_Nms"][:, 2]
    T = task.path.period_s
    per_cycle, _ = secular_rate_fit(np.arange(1, L.size, dtype=float), L[1:])
    st = cycle_state(task.path, np.linspace(0.0, T, 2001))
    inv_D = float(np.mean(1.0 / task.planar.inertia_sum(st.phi, st.s)))
    rotation = abs(summary["theta_gamma_mujoco_rad"]) / T * extrapolate_s
    return {
        "method": method,
        "timestep_s": timestep_s,
        "cycles": cycles,
        "drift_per_cycle_Nms": per_cycle,
        "spurious_yaw_rel": summary["angmom_spurious_yaw_rel"],
        "spurious_yaw_rel_extrapolated": abs(per_cycle / T) * extrapolate_s**2 / 2 * inv_D / rotation,
        "theta_gamma_mujoco_rad": summary["theta_gamma_mujoco_rad"],
        "wall_s": wall,
        "wall_per_step_s": wall / max(res.steps, 1),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=50)
    ap.add_argument("--methods", default="replay,held_torque,computed_torque")
    ap.add_argument("--timesteps", default="1e-5,5e-6,2.5e-6")
    ap.add_argument("--extrapolate-s", type=float, default=600.0)
    args = ap.parse_args()
    for method in args.methods.split(","):
        for dt in (float(x) for x in args.timesteps.split(",")):
            row = drift_row(method=method, timestep_s=dt, cycles=args.cycles, extrapolate_s=args.extrapolate_s)
            print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
