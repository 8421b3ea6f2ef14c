"""The Lloyd selections installed with the package: read after the user's cache, never written or
deleted, and complete for every shipped orbital truss config (a fresh checkout runs them without a
single Lloyd iteration)."""

from __future__ import annotations

import numpy as np
import pytest

from magsail_mj.concepts import build_task
from magsail_mj.concepts.truss_magnetorquer.orbital import lloyd_seed
from magsail_mj.config import load_config
from magsail_mj.control.lloyd import SHIPPED_DIR, LloydSelector
from tests.conftest import REPO

SITES = [np.random.default_rng(1).uniform(0, 1, (12, 2)), np.random.default_rng(2).uniform(0, 1, (10, 2))]
REGION = (0.0, 0.0, 1.0, 1.0)


def _selector(**kw) -> LloydSelector:
    return LloydSelector(SITES, region=REGION, seed=3, **kw)


def test_shipped_selections_are_read_after_the_cache_and_never_written(tmp_path):
    shipped = tmp_path / "shipped"
    _selector(cache_dir=shipped, shipped_dir=None).precompute([4])  # what the ship script writes
    files = sorted(p.relative_to(shipped) for p in shipped.rglob("*") if p.is_file())
    fresh = _selector(cache_dir=None, shipped_dir=shipped)
    reference = _selector(cache_dir=None, shipped_dir=None)
    for family in (0, 1):
        np.testing.assert_array_equal(fresh.selected(family, 4), reference.selected(family, 4))
    assert fresh.stats["lloyd_runs"] == 0 and fresh.stats["shipped_hits"] == 2  # the two snapped selections
    assert reference.stats["lloyd_runs"] == 1
    with_cache = _selector(cache_dir=tmp_path / "cache", shipped_dir=shipped)
    with_cache.selected(0, 4)
    assert with_cache.stats["shipped_hits"] == 1 and not (tmp_path / "cache").exists()  # read, not copied
    assert sorted(p.relative_to(shipped) for p in shipped.rglob("*") if p.is_file()) == files


def test_a_damaged_shipped_file_is_passed_over_not_deleted(tmp_path):
    shipped = tmp_path / "shipped"
    _selector(cache_dir=shipped, shipped_dir=None).precompute([5])
    damaged = next(shipped.glob("lloyd_*/n00005.npz"))
    damaged.write_bytes(b"PK\x03\x04 truncated")
    sel = _selector(cache_dir=None, shipped_dir=shipped)
    sel.result(5)
    assert sel.stats["lloyd_runs"] == 1 and damaged.read_bytes() == b"PK\x03\x04 truncated"


@pytest.mark.parametrize("config", ["detumble.toml", "slew_i.toml"])
def test_every_shipped_orbital_config_finds_all_its_selections_shipped(config):
    cfg = load_config(REPO / "magsail_mj/concepts/truss_magnetorquer/configs" / config)
    rods = build_task(cfg).rods().rods
    sel = LloydSelector(
        [rods.family_sites(0), rods.family_sites(1)],
        region=rods.region,
        seed=lloyd_seed(cfg.control, cfg.sim.seed),
        tol_rel=cfg.control.lloyd.tol_rel,
        max_iter=cfg.control.lloyd.max_iter,
        cache_dir=None,
    )
    assert sel.shipped_dir is not None and sel.shipped_dir.parent == SHIPPED_DIR
    counts = range(max(sel.n_sites) + 1)
    missing = [c for c in counts if c < max(sel.n_sites) and not sel._on_disk(c)]
    assert not missing, f"counts without shipped generators (run scripts/ship_lloyd_selections.py): {missing[:10]}"
    for family, n in enumerate(sel.n_sites):
        sites = [c for c in range(n) if not sel._snap_path(family, c, shipped=True).is_file()]
        assert not sites, f"family {family}: counts without a shipped selection: {sites[:10]}"
