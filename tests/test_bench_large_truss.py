"""The large-truss configs are Case A with nine times the nodes: same geometry, mass, stiffness, load."""

from __future__ import annotations

import pytest

from magsail_mj.config import load_config
from magsail_mj.resources import lattice_counts
from tests.conftest import REPO

LARGE = REPO / "models" / "truss_magnetorquer" / "large"
CASE_A = REPO / "magsail_mj" / "concepts" / "truss_magnetorquer" / "configs" / "dist_vs_central"
SAME = ("lattice.side_m", "lattice.diagonals", "mass", "stiffness", "damping", "actuators", "profile", "initial")


def _get(cfg, dotted: str):
    for part in dotted.split("."):
        cfg = getattr(cfg, part)
    return cfg.model_dump() if hasattr(cfg, "model_dump") else cfg


@pytest.mark.parametrize("placement", ["distributed", "central"])
def test_large_config_is_case_a_with_60_by_60_by_2_nodes(placement):
    large = load_config(LARGE / f"case_a_100m_{placement}.toml")
    small = load_config(CASE_A / f"case_a_{placement}_bangbang.toml")
    for key in SAME:
        assert _get(large, key) == _get(small, key), key
    assert large.lattice.units == 59
    nodes, struts = lattice_counts(59, diagonals=large.lattice.diagonals)
    assert (nodes, struts) == (7200, 31802)
    # one record per simulated second, as the 800-node Case A
    assert large.sim.timestep_s * large.sim.record_every == pytest.approx(small.sim.timestep_s * small.sim.record_every)
    assert large.sim.duration_s == small.sim.duration_s == 1800.0
