"""The Lloyd selections installed with the package: read after the user's cache, never written or
deleted, and complete for every shipped orbital truss config and for the reproduction registry's
runs that vary a shipped config's Lloyd keys (a fresh checkout runs them without a single Lloyd
iteration)."""

from __future__ import annotations

import numpy as np
import pytest

from magsail_mj.concepts import build_task
from magsail_mj.concepts.truss_magnetorquer.orbital import lloyd_seed
from magsail_mj.config import load_config
from magsail_mj.control.lloyd import SHIPPED_DIR, LloydSelector
from magsail_mj.report.registry import load_registry
from tests.conftest import REPO

TRUSS_CONFIGS = "magsail_mj/concepts/truss_magnetorquer/configs/"

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


def _registry_runs_with_lloyd_overrides() -> list[tuple[str, LloydSelector]]:
    """(run id, selector reading only the shipped data) of every registry run that sets Lloyd keys
    on a shipped truss config."""
    out = []
    for paper in load_registry().values():
        for spec in paper.run:
            if spec.config.startswith(TRUSS_CONFIGS) and any(s.startswith("control.lloyd.") for s in spec.set):
                cfg = load_config(REPO / spec.config, list(spec.set))
                rods = build_task(cfg).rods().rods
                c = cfg.control
                sel = LloydSelector(
                    [rods.family_sites(0), rods.family_sites(1)],
                    region=rods.region,
                    seed=lloyd_seed(c, cfg.sim.seed),
                    tol_rel=c.lloyd.tol_rel,
                    max_iter=c.lloyd.max_iter,
                    cache_dir=None,
                    symmetry=c.lloyd.symmetry,
                )
                out.append((f"{paper.paper}/{spec.id}", sel))
    return out


def test_registry_runs_with_other_lloyd_keys_find_their_selections_shipped():
    runs = _registry_runs_with_lloyd_overrides()
    assert len(runs) >= 7  # the detumble with five other seeds and two mirror-symmetric selections
    keys = {sel.cache_key() for _, sel in runs}
    assert len(keys) == len(runs)  # each reading a selection of its own
    for run_id, sel in runs:
        for family, n in enumerate(sel.n_sites):
            missing = [c for c in range(n) if not sel._snap_path(family, c, shipped=True).is_file()]
            assert not missing, f"{run_id}, family {family}: counts without a shipped selection: {missing[:10]}"
        for family, count in ((0, 1), (1, 77), (0, 379)):  # read from the shipped data, no Lloyd run
            assert sel.selected(family, count).size == sel.selection_size(family, count)
        assert sel.stats["lloyd_runs"] == 0 and sel.stats["shipped_hits"] == 3
