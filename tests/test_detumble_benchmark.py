"""The detumble benchmark (``magsail_mj/concepts/cnusail/configs/detumble_benchmark.toml``): a grid of
the four detumble laws crossed with a Monte Carlo of initial conditions, and its report per law.

Every law must see the same draws (sample i's values depend on the seed, i and the key only), and
every point's config loads with the benchmark's stop rule and duration.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from magsail_mj.config import load_config, read_toml
from magsail_mj.sweep.design import design_points

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "magsail_mj" / "concepts" / "cnusail" / "configs"
BENCH = CONFIGS / "detumble_benchmark.toml"
BENCH_DEPLOYED = CONFIGS / "detumble_benchmark_deployed.toml"
SHIPPED_MC = CONFIGS / "monte_carlo_detumble.toml"
LAWS = ["proportional", "bang_bang", "b_cross", "non_monotonic"]
FIGURES = ["detumble_time_below_1p0dps_s", "detumble_time_below_0p3dps_s", "mtq_dipole_effort_Am2s"]


@pytest.mark.parametrize("path", [BENCH, BENCH_DEPLOYED])
def test_every_law_sees_the_same_conditions(path):
    tree = read_toml(path)
    points = design_points(tree)
    assert len(points) == 4 * 1000
    by_law: dict[str, dict[str, dict]] = {}
    for p in points:
        law, sample = p.id.split("/")
        assert law == f"bdot_law={p.params['control.bdot_law']}"
        by_law.setdefault(p.params["control.bdot_law"], {})[sample] = {
            k: v for k, v in p.params.items() if k != "control.bdot_law"
        }
    assert list(by_law) == LAWS
    for law in LAWS[1:]:
        assert by_law[law] == by_law[LAWS[0]], law
    # the shipped 200-sample Monte Carlo's draws are the first 200 conditions (same seed and keys)
    shipped = design_points(read_toml(SHIPPED_MC))
    assert [p.params for p in shipped] == [by_law["b_cross"][f"s{i:03d}"] for i in range(200)]
    rates = np.array([np.linalg.norm(c["initial.omega0_deg_s"]) for c in by_law["proportional"].values()])
    assert 2.0 <= rates.min() and rates.max() <= 10.0
    # every point's config loads (one per law: the others differ only in the drawn values)
    for p in points[::1000]:
        cfg = load_config(path.parent / tree["config"], [*tree["set"], *p.overrides])
        assert (cfg.sim.stop_rate_deg_s, cfg.sim.stop_hold_s, cfg.sim.duration_s) == (0.3, 600.0, 17347.5)
