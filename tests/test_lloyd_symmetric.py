"""Mirror-symmetric Lloyd selections (``symmetry = "mirror_xy"``): orbits of the two mirrors, every
count's selection invariant under both, a centroidal Voronoi tessellation of the whole region from
the quadrant's generators, the cache keyed by the symmetry, and the config key reaching the
selector of an orbital truss run.

Tolerances: site coordinates are sums of a few grid steps, so mirror images coincide to 1e-9 of the
region side (rounding only); the mirrored generators are a CVT to the Lloyd stopping tolerance
(1e-7 of the side), checked at 1e-6.
"""

from __future__ import annotations

import numpy as np
import pytest

from magsail_mj.concepts import build_task
from magsail_mj.concepts.truss_magnetorquer.orbital import make_distributor
from magsail_mj.config import ConfigError, load_config
from magsail_mj.control.lloyd import LloydSelector, mirror_orbits, voronoi_centroids
from tests.conftest import REPO

SIDE = 6.0
REGION = (-3.0, -3.0, 3.0, 3.0)
MIRROR_TOL = 1e-9 * SIDE  # coordinates are sums of grid steps: only rounding separates images
DETUMBLE = REPO / "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml"


def _strut_sites(n: int) -> list[np.ndarray]:
    """Midpoints of the x- and y-struts of an (n + 1) × (n + 1) node grid on REGION (the truss's
    layout: family 0 along x, family 1 its transpose)."""
    a = SIDE / n
    i, j = np.meshgrid(np.arange(n), np.arange(n + 1), indexing="xy")
    f0 = np.column_stack([(i.ravel() + 0.5) * a - 3.0, j.ravel() * a - 3.0])
    return [f0, f0[:, ::-1].copy()]


def _cell_sites(n: int) -> list[np.ndarray]:
    """Cell centres of an n × n grid on REGION (odd n: one site at the centre)."""
    g = (np.arange(n) + 0.5) * SIDE / n - 3.0
    X, Y = np.meshgrid(g, g, indexing="xy")
    f = np.column_stack([X.ravel(), Y.ravel()])
    return [f, f.copy()]


def _mirror_invariant(points: np.ndarray) -> bool:
    """Whether ``points`` map onto themselves under x → −x and under y → −y (REGION's centre lines)."""
    if points.shape[0] == 0:
        return True
    for flip in ((-1.0, 1.0), (1.0, -1.0)):
        d = np.abs((points * flip)[:, None, :] - points[None, :, :]).sum(axis=2).min(axis=1)
        if d.max() > MIRROR_TOL:
            return False
    return True


def test_orbits_group_the_sites_by_both_mirrors():
    f0 = _strut_sites(5)[0]  # x at 5 cell centres (one on x = 0), y at 6 node rows (none on y = 0)
    orb = mirror_orbits(f0, REGION)
    assert np.bincount(orb.size, minlength=5).tolist() == [0, 0, 3, 0, 6]  # 3 pairs on x = 0, 6 quadruples
    assert orb.sites_of(np.arange(orb.size.size)).tolist() == list(range(f0.shape[0]))  # a partition
    pairs = orb.members[orb.size == 2]
    assert np.all(np.abs(f0[pairs, 0]) < MIRROR_TOL)  # the two-site orbits lie on x = 0
    assert np.all(orb.rep >= -MIRROR_TOL)  # quadrant points in the upper-right quadrant
    centre = mirror_orbits(_cell_sites(3)[0], REGION)
    assert sorted(centre.size.tolist()) == [1, 2, 2, 4]


def test_sites_without_mirror_images_are_refused_naming_the_site():
    sites = _strut_sites(4)[0].copy()
    sites[5, 0] += 0.1
    with pytest.raises(ValueError, match=r"sites: .*mirror image of site 5"):
        mirror_orbits(sites, REGION)
    with pytest.raises(ValueError, match="sites"):
        LloydSelector([sites], region=REGION, symmetry="mirror_xy")
    with pytest.raises(ValueError, match="symmetry: must be one of"):
        LloydSelector([sites], region=REGION, symmetry="diagonal")


@pytest.mark.parametrize("layout", ["struts", "cells"])
def test_every_count_selects_a_mirror_symmetric_set(layout):
    sites = _strut_sites(6) if layout == "struts" else _cell_sites(7)
    sel = LloydSelector(sites, region=REGION, seed=3, tol_rel=1e-5, symmetry="mirror_xy", shipped_dir=None)
    has_centre = layout == "cells"
    for family in (0, 1):
        n = sel.n_sites[family]
        for count in range(n + 1):
            s = sel.selected(family, count)
            assert np.unique(s).size == s.size and (s.size == 0 or (s.min() >= 0 and s.max() < n))
            assert _mirror_invariant(sites[family][s]), (family, count)
            # exact for even counts; an odd count needs the centre site, else it has one site fewer
            expected = count if (count % 2 == 0 or has_centre or count == n) else count - 1
            assert s.size == sel.selection_size(family, count) == expected, (family, count)
    pol = sel.polarity((5, -8))
    assert np.count_nonzero(pol) == sel.selection_size(0, 5) + 8 and pol.min() == -1


def test_quadrant_generators_mirrored_are_a_cvt_of_the_whole_region():
    sel = LloydSelector(_strut_sites(6), region=REGION, seed=5, tol_rel=1e-7, symmetry="mirror_xy", shipped_dir=None)
    assert sel.lloyd_region == (0.0, 0.0, 3.0, 3.0)
    g = sel.result(7).generators
    assert g.shape == (7, 2) and np.all(g > 0)
    full = np.concatenate([g * flip for flip in ((1, 1), (-1, 1), (1, -1), (-1, -1))])
    centroids, areas = voronoi_centroids(full, REGION)
    assert np.abs(centroids - full).max() < 1e-6 * SIDE
    assert areas.sum() == pytest.approx(SIDE**2, rel=1e-12)
    # a count of 4q takes the q four-site orbits its generators snap to, and no other site
    orb = sel.orbits[0]
    quads = np.flatnonzero(orb.size == 4)
    chosen = sel.selected(0, 28)
    assert chosen.size == 28 and np.all(np.isin(chosen, orb.members[quads].ravel()))


def test_symmetric_cache_is_keyed_apart_and_precomputes_quadrant_counts_only(tmp_path):
    sites = _strut_sites(6)
    plain = LloydSelector(sites, region=REGION, seed=3, tol_rel=1e-5, cache_dir=tmp_path)
    sym = LloydSelector(sites, region=REGION, seed=3, tol_rel=1e-5, cache_dir=tmp_path, symmetry="mirror_xy")
    assert sym.cache_key() != plain.cache_key()
    # the plain key is the one every cache and shipped selection has had (no symmetry field)
    assert plain.cache_key() == LloydSelector(sites, region=REGION, seed=3, tol_rel=1e-5).cache_key()
    sym.precompute(workers=2)
    quads = int(np.count_nonzero(sym.orbits[0].size == 4))  # 3 × 3 four-site orbits per family
    assert sym.stats["lloyd_runs"] == quads - 1  # q = 1 … quads − 1 (all orbits need no Lloyd run)
    again = LloydSelector(sites, region=REGION, seed=3, tol_rel=1e-5, cache_dir=tmp_path, symmetry="mirror_xy")
    for family in (0, 1):
        for count in range(sym.n_sites[family] + 1):
            np.testing.assert_array_equal(again.selected(family, count), sym.selected(family, count))
    assert again.stats["lloyd_runs"] == 0 and again.stats["snap_disk_hits"] == sum(sym.n_sites)


def test_the_config_key_reaches_the_truss_selector():
    cfg = load_config(DETUMBLE, ["control.lloyd.symmetry=mirror_xy", "control.lloyd.seed=1", 'control.cache_dir=""'])
    rod_load = build_task(cfg).rods()
    dist = make_distributor(cfg.control, rod_load, sim_seed=cfg.sim.seed)
    assert dist.selector.symmetry == "mirror_xy" and dist.selector.seed == 1
    s = dist.selector.selected(0, 150)
    assert s.size == 150 and _mirror_invariant(rod_load.rods.family_sites(0)[s])
    assert load_config(DETUMBLE).control.lloyd.symmetry == "none"
    with pytest.raises(ConfigError, match="symmetry"):
        load_config(DETUMBLE, ["control.lloyd.symmetry=diagonal"])
