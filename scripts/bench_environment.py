"""Benchmark of the environment precompute, ``Environment.sample`` and the environment loads.

Measures, in one run (issue 3 item 9, the part that does not need the runner):

1. IGRF precompute along a 2.5 h, 800 km polar orbit at 1 s (9 001 points, one vectorised
   ppigrf call per 8 000 points) and at the default 10 s; the scalar ppigrf cost for contrast;
2. ``Environment.sample(t)`` per call;
3. per-call cost of the tidal, SRP and drag loads on the 800-node (N = 20, 75 m) lattice,
   against plain NumPy baselines measured in the same run: (a) the naive vectorised tidal
   difference m(g(r+x) − g(r)); (b) one spring–dashpot force evaluation of the 3 402-strut parity
   lattice (truss spec §2.2, §2.4) and one classical RK4 step of it (4 evaluations), the
   reference cost of design.md.

The comparison with the MuJoCo step cost is added with the runner. Prints a JSON object.

Usage: python scripts/bench_environment.py [--repeat 2000]
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from datetime import datetime

import numpy as np

from magsail_mj.environment import AtmosphereConfig, Environment, FieldConfig, OrbitConfig, SunConfig
from magsail_mj.environment.constants import MU_EARTH
from magsail_mj.environment.field import igrf_eci
from magsail_mj.environment.surfaces import Optics, lattice_top_cells
from magsail_mj.environment.timeutil import gmst_rad
from magsail_mj.loads.base import StepState
from magsail_mj.loads.drag import LatticeDragLoad
from magsail_mj.loads.srp import LatticeSRPLoad
from magsail_mj.loads.tidal import TidalGravityLoad

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


def lattice(n: int = N, d: float = SIDE):
    """Nodes (index k n² + j n + i) and parity-rule struts of the two-layer lattice."""
    a = d / (n - 1)
    k, j, i = np.meshgrid(np.arange(2), np.arange(n), np.arange(n), indexing="ij")
    ijk = np.stack([i, j, k], -1).reshape(-1, 3)
    p = np.stack([ijk[:, 0] * a - d / 2, ijk[:, 1] * a - d / 2, (ijk[:, 2] - 0.5) * a], -1)
    idx = lambda i, j, k: k * n * n + j * n + i  # noqa: E731
    struts = []
    for kk in range(2):
        for jj in range(n):
            for ii in range(n):
                if ii + 1 < n:
                    struts.append((idx(ii, jj, kk), idx(ii + 1, jj, kk)))
                if jj + 1 < n:
                    struts.append((idx(ii, jj, kk), idx(ii, jj + 1, kk)))
                if kk == 0:
                    struts.append((idx(ii, jj, 0), idx(ii, jj, 1)))
    even = (ijk.sum(1) % 2) == 0
    diag = []
    for u in range(len(p)):
        if not even[u]:
            continue
        for v in range(u + 1, len(p)):
            if even[v] and np.sum(np.abs(ijk[u] - ijk[v])) == 2 and np.all(np.abs(ijk[u] - ijk[v]) <= 1):
                diag.append((u, v))
    return p, np.array(struts + diag), a


def numpy_rhs_factory(p0: np.ndarray, struts: np.ndarray, k_edge: float, gamma: float, m: float):
    """Plain NumPy spring–dashpot accelerations (the papers' formulation), scatter by bincount."""
    i, j = struts[:, 0], struts[:, 1]
    l0 = np.linalg.norm(p0[j] - p0[i], axis=1)
    k = k_edge * l0.min() / l0  # same EA on every strut: k = EA / l0
    nn = len(p0)

    def rhs(x, v):
        d = x[j] - x[i]
        ln = np.sqrt(np.einsum("ij,ij->i", d, d))
        e = d / ln[:, None]
        dv = v[j] - v[i]
        f = (k * (ln - l0) + gamma * np.einsum("ij,ij->i", dv, e))[:, None] * e
        F = np.empty_like(x)
        for c in range(3):
            F[:, c] = np.bincount(i, f[:, c], nn) - np.bincount(j, f[:, c], nn)
        return F / m

    return rhs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=2000, help="calls per timing round")
    args = ap.parse_args()
    out: dict[str, object] = {"machine": platform.processor() or platform.machine(),
                              "python": platform.python_version()}

    # 1. IGRF precompute
    env10 = Environment(orbit=ORBIT, field=FieldConfig(), atmosphere=AtmosphereConfig(), sun=SunConfig(),
                        duration_s=9000.0)
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
        Environment(orbit=ORBIT, field=FieldConfig(sample_step_s=step), atmosphere=AtmosphereConfig(),
                    sun=SunConfig(), duration_s=9000.0)
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
    from dataclasses import replace

    s = replace(s, in_shadow=False, srp_pressure_N_m2=4.563e-6, density_kg_m3=1e-14)
    state = StepState(t=1000.0, pos=pos, vel=vel, xquat=np.tile([1.0, 0, 0, 0], (len(pos), 1)),
                      omega=np.zeros_like(pos), env=s)
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
        xfrc[1:, :3] += m_col * (-MU_EARTH * R / np.linalg.norm(R, axis=1, keepdims=True) ** 3
                                 + MU_EARTH * r_ref / np.linalg.norm(r_ref) ** 3)

    out["baseline_naive_tidal_us"] = _best(naive_tidal, args.repeat) * 1e6
    rhs = numpy_rhs_factory(p, struts, k_edge=1.6258, gamma=0.090, m=MASS)
    out["baseline_numpy_rhs_us"] = _best(lambda: rhs(x, v), max(1, args.repeat // 4)) * 1e6
    out["baseline_numpy_rk4_step_us"] = 4 * out["baseline_numpy_rhs_us"]
    out["loads_over_numpy_rk4_step"] = out["loads_total_us"] / out["baseline_numpy_rk4_step_us"]
    out["date"] = datetime.now().isoformat(timespec="seconds")
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
