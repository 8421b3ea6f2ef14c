"""Benchmark of the environment precompute, ``Environment.sample`` and the environment loads.

Measures, in one run (the part that does not need the runner):

1. IGRF precompute along a 2.5 h, 800 km polar orbit at 1 s (9 001 points, one vectorised
   ppigrf call per 8 000 points) and at the default 10 s; the scalar ppigrf cost for contrast;
2. ``Environment.sample(t)`` per call;
3. per-call cost of the tidal, SRP and drag loads on the 800-node (N = 20, 75 m) lattice,
   against plain NumPy baselines measured in the same run: (a) the naive vectorised tidal
   difference m(g(r+x) − g(r)); (b) one spring–dashpot force evaluation of the 3 402-strut parity
   lattice (one face diagonal per square face, linear spring–dashpot struts) and one classical RK4
   step of it (4 evaluations), the reference cost a MuJoCo step is compared with.

4. the runner's cost per MuJoCo RK4 step of the 75 m lattice, bare and with all environment
   loads (tidal, SRP, drag) — the target: the loads add at most 50 % to the bare step.

Prints a JSON object.

Usage: python scripts/bench_environment.py [--repeat 2000]
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from dataclasses import replace
from datetime import datetime
from pathlib import Path

import numpy as np

import magsail_mj
from magsail_mj.config import load_config
from magsail_mj.environment import AtmosphereConfig, Environment, FieldConfig, OrbitConfig, SunConfig
from magsail_mj.environment.constants import MU_EARTH
from magsail_mj.environment.field import igrf_eci
from magsail_mj.environment.surfaces import Optics, lattice_top_cells
from magsail_mj.environment.timeutil import gmst_rad
from magsail_mj.lattice.geometry import make_lattice
from magsail_mj.loads.base import StepState
from magsail_mj.loads.drag import LatticeDragLoad
from magsail_mj.loads.srp import LatticeSRPLoad
from magsail_mj.loads.tidal import TidalGravityLoad
from magsail_mj.reference.numpy_rk4 import SpringMassLattice
from magsail_mj.sim import Simulation

REPO = Path(__file__).resolve().parents[1]

N, SIDE, MASS = 20, 75.0, 0.25
ORBIT = OrbitConfig(altitude_km=800, inclination_deg=90, raan_deg=90)


def _best(fn, repeat: int, rounds: int = 5) -> float:
    """Best-of-``rounds`` mean seconds per call over ``repeat`` calls."""
    best = np.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(repeat):
            fn()
        best = min(best, (time.perf_counter() - t0) / repeat)
    return best


def lattice():
    """Nodes, parity-rule struts and cube edge of the 800-node, 75 m lattice (Robb et al. 2022a, Sec. 2.1)."""
    lat = make_lattice(units=N - 1, side_m=SIDE)
    return lat.nodes, lat.struts, lat.cube_edge_m


def numpy_rhs_factory(p0: np.ndarray, struts: np.ndarray, k_edge: float, gamma: float, m: float):
    """Plain NumPy spring–dashpot forces of the reference integrator (same EA on every strut)."""
    l0 = np.linalg.norm(p0[struts[:, 1]] - p0[struts[:, 0]], axis=1)
    system = SpringMassLattice(masses=np.full(len(p0), m), struts=struts, k=k_edge * l0.min() / l0, l0=l0, gamma=gamma)
    return system.forces


def mujoco_step_costs(steps: int) -> dict[str, float]:
    """Runner cost per step of the 75 m orbital lattice (libration config, MuJoCo RK4 at 0.1 s):
    bare (no loads, no environment) and with all environment loads (tidal, SRP, drag), in one run.

    The model, its initial state and its environment come from :func:`magsail_mj.load`; the two
    timed simulations are built on that model with only the loads compared (none, or the
    environment loads), so that the difference is the loads' cost alone."""
    cfg = load_config(
        REPO / "magsail_mj/concepts/truss_magnetorquer/configs/libration.toml",
        [
            "srp.enabled=true",
            "drag.enabled=true",
            "atmosphere.model='exponential'",
            "sun.model='ephemeris'",
            f"sim.duration_s={steps * 0.1}",
            "sim.progress=false",
        ],
    )
    sc = magsail_mj.load(cfg).scenario
    out = {}
    for name, loads, env in (("bare", [], None), ("env_loads", sc.environment_loads(), sc.environment)):
        times = []
        for _ in range(2):
            sim = Simulation(
                model=sc.model,
                duration_s=cfg.sim.duration_s,
                loads=loads,
                environment=env,
                record_every=10**9,
                init=sc.init_state,
            )
            times.append(sim.run().wall_time_s / steps)
        out[f"mujoco_rk4_step_{name}_ms"] = min(times) * 1e3
    out["env_loads_added_fraction_of_step"] = out["mujoco_rk4_step_env_loads_ms"] / out["mujoco_rk4_step_bare_ms"] - 1.0
    out["env_loads"] = [type(ld).__name__ for ld in sc.environment_loads()]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=2000, help="calls per timing round")
    ap.add_argument("--steps", type=int, default=600, help="MuJoCo steps per runner timing")
    args = ap.parse_args()
    out: dict[str, object] = {
        "machine": platform.processor() or platform.machine(),
        "python": platform.python_version(),
    }

    # 1. IGRF precompute
    env10 = Environment(
        orbit=ORBIT, field=FieldConfig(), atmosphere=AtmosphereConfig(), sun=SunConfig(), duration_s=9000.0
    )
    t = np.arange(0.0, 9000.0 + 1.0, 1.0)
    r, _ = env10.orbit.state(t)
    g = gmst_rad(env10.jd0 + t / 86400)
    t0 = time.perf_counter()
    igrf_eci(r, g, env10.epoch)
    out["igrf_precompute_2p5h_1s_s"] = time.perf_counter() - t0
    out["igrf_precompute_points"] = len(t)
    out["igrf_precompute_per_point_us"] = out["igrf_precompute_2p5h_1s_s"] / len(t) * 1e6
    t0 = time.perf_counter()
    for kk in range(5):
        igrf_eci(r[kk : kk + 1], g[kk : kk + 1], env10.epoch)
    out["igrf_scalar_call_ms"] = (time.perf_counter() - t0) / 5 * 1e3
    for step in (1.0, 10.0):
        t0 = time.perf_counter()
        Environment(
            orbit=ORBIT,
            field=FieldConfig(sample_step_s=step),
            atmosphere=AtmosphereConfig(),
            sun=SunConfig(),
            duration_s=9000.0,
        )
        out[f"environment_build_2p5h_{int(step)}s_s"] = time.perf_counter() - t0

    # 2. sample(t)
    ts = iter(np.random.default_rng(0).uniform(0, 9000, 10 * args.repeat * 5 + 10).tolist())
    out["sample_us"] = _best(lambda: env10.sample(next(ts)), args.repeat) * 1e6

    # 3. loads on the 800-node lattice
    p, struts, a = lattice()
    out["lattice_nodes"], out["lattice_struts"] = len(p), len(struts)
    rng = np.random.default_rng(1)
    x = p + rng.normal(scale=1e-3, size=p.shape)
    v = rng.normal(scale=1e-3, size=p.shape)
    pos = np.vstack([np.zeros(3), x])
    vel = np.vstack([np.zeros(3), v])
    s = env10.sample(1000.0)
    s = replace(s, in_shadow=False, srp_pressure_N_m2=4.563e-6, density_kg_m3=1e-14)
    state = StepState(
        t=1000.0, pos=pos, vel=vel, xquat=np.tile([1.0, 0, 0, 0], (len(pos), 1)), omega=np.zeros_like(pos), env=s
    )
    xfrc = np.zeros((len(pos), 6))
    cells = lattice_top_cells(N)
    loads = {
        "tidal": TidalGravityLoad(np.arange(1, len(p) + 1), np.full(len(p), MASS)),
        "srp_lattice": LatticeSRPLoad(cells, optics=Optics.cnusail_sail()),
        "drag_lattice": LatticeDragLoad(cells),
    }
    for name, ld in loads.items():
        out[f"load_{name}_us"] = _best(lambda ld=ld: ld.add(state, xfrc), args.repeat) * 1e6
    out["loads_total_us"] = sum(out[f"load_{k}_us"] for k in loads) + out["sample_us"]

    m_col = np.full((len(p), 1), MASS)
    r_ref = s.r_ref_eci

    def naive_tidal():
        R = r_ref + x
        xfrc[1:, :3] += m_col * (
            -MU_EARTH * R / np.linalg.norm(R, axis=1, keepdims=True) ** 3
            + MU_EARTH * r_ref / np.linalg.norm(r_ref) ** 3
        )

    out["baseline_naive_tidal_us"] = _best(naive_tidal, args.repeat) * 1e6
    rhs = numpy_rhs_factory(p, struts, k_edge=1.6258, gamma=0.090, m=MASS)
    out["baseline_numpy_rhs_us"] = _best(lambda: rhs(x, v), max(1, args.repeat // 4)) * 1e6
    out["baseline_numpy_rk4_step_us"] = 4 * out["baseline_numpy_rhs_us"]
    out["loads_over_numpy_rk4_step"] = out["loads_total_us"] / out["baseline_numpy_rk4_step_us"]
    out.update(mujoco_step_costs(args.steps))
    out["date"] = datetime.now().isoformat(timespec="seconds")
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
