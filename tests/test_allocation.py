"""Torque allocation N1/N2 (Robb et al. 2022a, Eqs. 10–13, with our symmetric rounding and clipping) and Lloyd
selection (Sec. 3, snapped one-to-one to 380 strut sites per family).

Tolerances: the allocation is a few flops on O(1) numbers; torque comparisons use 1e-12 of the
rod torque scale. Cell centroids from the vectorised Delaunay path are compared with the plain
polygon reference to 1e-12 of the region side.
"""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from magsail_mj.control.allocation import (
    TorqueDistributor,
    allocate,
    allocate_batch,
    allocation_mode_difference,
    rod_torques,
    round_half_away,
)
from magsail_mj.control.lloyd import (
    LloydSelector,
    covering_radius,
    initial_generators,
    lloyd,
    nn_spacing_cv,
    snap_to_sites,
    voronoi_cells,
    voronoi_centroids,
)
from tests.conftest import load_file_module

unit = st.floats(-1.0, 1.0, allow_nan=False)
vec = st.tuples(unit, unit, unit).map(np.array).filter(lambda v: np.linalg.norm(v) > 1e-2)
M_ROD = 26.315789473684212
B_SCALE = 3e-5


def field(v):
    return B_SCALE * np.asarray(v) / np.linalg.norm(v)


# ----------------------------------------------------------------------------- rounding, torques


def test_round_half_away_from_zero_t3():
    xs = [0.5, 1.5, 2.5, -0.5, -1.5, -2.5, 0.49999999999999994, -0.49999999999999994, 2.4999, 0.0, -0.0, 7.0]
    want = [1, 2, 3, -1, -2, -3, 0, 0, 2, 0, 0, 7]
    assert [round_half_away(x) for x in xs] == want
    np.testing.assert_array_equal(round_half_away(np.array(xs)), want)
    assert np.round(2.5) == 2.0  # why NumPy's rounding is not used (half to even)


@settings(max_examples=100, deadline=None)
@given(B=vec)
def test_rod_torques_and_their_dot_product_t2(B):
    B = field(B)
    t1, t2 = rod_torques(B, m_rod_Am2=M_ROD)
    np.testing.assert_allclose(t1, M_ROD * np.cross([1, 0, 0], B), rtol=0, atol=1e-18)
    np.testing.assert_allclose(t2, M_ROD * np.cross([0, 1, 0], B), rtol=0, atol=1e-18)
    # Corrected middle line of Eq. 10: τ1·τ2 = −m² (x̂1·B)(ŷ1·B).
    assert t1 @ t2 == pytest.approx(-(M_ROD**2) * B[0] * B[1], abs=1e-12 * (M_ROD * B_SCALE) ** 2)
    assert abs(t1 @ B) <= 1e-15 * M_ROD * B_SCALE**2 and abs(t2 @ B) <= 1e-15 * M_ROD * B_SCALE**2


# ----------------------------------------------------------------------------- Eqs. 11–13 tests


@settings(max_examples=100, deadline=None)
@given(
    B=vec, which=st.sampled_from([0, 1]), T_dir=vec, n=st.floats(0.0, 50.0), mode=st.sampled_from(["paper", "exact"])
)
def test_unsaturated_error_bound_with_orthogonal_rod_torques(B, which, T_dir, n, mode):
    """T_ref ⟂ B, τ1 ⟂ τ2 (B ⟂ x̂1 or ŷ1), unsaturated: |T − T_ref| ≤ ½(|τ1| + |τ2|)."""
    B = np.array(B, float)
    B[which] = 0.0
    assume(np.linalg.norm(B) > 1e-2)
    B = field(B)
    T_dir = T_dir - (T_dir @ B) * B / (B @ B)
    assume(np.linalg.norm(T_dir) > 1e-3)
    t1, t2 = rod_torques(B, m_rod_Am2=M_ROD)
    assume(np.linalg.norm(t1) > 1e-3 * M_ROD * B_SCALE and np.linalg.norm(t2) > 1e-3 * M_ROD * B_SCALE)
    T_ref = n * min(np.linalg.norm(t1), np.linalg.norm(t2)) * T_dir / np.linalg.norm(T_dir)
    al = allocate(T_ref, B, m_rod_Am2=M_ROD, n_max=380, mode=mode)
    assert not (al.clipped1 or al.clipped2)
    err = np.linalg.norm(al.torque_body - T_ref)
    assert err <= 0.5 * (np.linalg.norm(t1) + np.linalg.norm(t2)) * (1 + 1e-12)


@settings(max_examples=100, deadline=None)
@given(B=vec, c=st.floats(-1e3, 1e3), mode=st.sampled_from(["paper", "exact"]))
def test_torque_along_field_gives_nothing(B, c, mode):
    B = field(B)
    al = allocate(c * B / B_SCALE, B, m_rod_Am2=M_ROD, n_max=380, mode=mode)
    assert (al.N1, al.N2) == (0, 0)
    assert np.all(al.torque_body == 0)


def test_saturation_clips_n1_before_n2():
    B = field([0.3, -0.5, 0.8])
    t1, t2 = rod_torques(B, m_rod_Am2=M_ROD)
    T_ref = 1000.0 * t1 + 0.3 * t2  # far beyond 380 rods of family 1
    al = allocate(T_ref, B, m_rod_Am2=M_ROD, n_max=380)
    assert al.N1 == 380 and al.clipped1
    # N2 uses the clipped N1: residual projection with N1 = 380, not 1000.
    x2 = (T_ref @ t2 - 380 * (t1 @ t2)) / (t2 @ t2)
    assert al.N2 == max(-380, min(380, int(round_half_away(x2))))
    assert al.x2 == pytest.approx(x2, rel=1e-12)
    neg = allocate(-T_ref, B, m_rod_Am2=M_ROD, n_max=380)
    assert neg.N1 == -380 and neg.clipped1  # symmetric clipping: both signs saturate
    big = allocate(1e6 * np.cross(B, [1.0, 2.0, 0.5]), B, m_rod_Am2=M_ROD, n_max=(380, 200))
    assert abs(big.N1) <= 380 and abs(big.N2) <= 200
    assert abs(big.N2) == 200 and big.clipped2


@settings(max_examples=100, deadline=None)
@given(B=vec, T=vec, scale=st.floats(0.0, 2000.0), mode=st.sampled_from(["paper", "exact"]))
def test_sign_symmetry(B, T, scale, mode):
    B = field(B)
    T_ref = scale * M_ROD * B_SCALE * T
    a = allocate(T_ref, B, m_rod_Am2=M_ROD, n_max=380, mode=mode)
    b = allocate(-T_ref, B, m_rod_Am2=M_ROD, n_max=380, mode=mode)
    assert (b.N1, b.N2) == (-a.N1, -a.N2)
    assert b.mode == a.mode


@settings(max_examples=100, deadline=None)
@given(B=vec, x1=st.floats(-100, 100), x2=st.floats(-100, 100))
def test_exact_mode_reproduces_in_plane_torques(B, x1, x2):
    """Exact mode: T_ref = x1 τ1 + x2 τ2 (unsaturated) is met to within rounding."""
    B = field(B)
    t1, t2 = rod_torques(B, m_rod_Am2=M_ROD)
    a, b, c = t1 @ t1, t2 @ t2, t1 @ t2
    tiny = 1e-6 * (M_ROD * B_SCALE) ** 2
    assume(a > tiny and b > tiny and a * b - c * c >= 1e-6 * a * b * 1.01)  # no fallback
    T_ref = x1 * t1 + x2 * t2
    al = allocate(T_ref, B, m_rod_Am2=M_ROD, n_max=380, mode="exact")
    assert al.mode == "exact"
    err = np.linalg.norm(al.torque_body - T_ref)
    assert err <= 0.5 * (math.sqrt(a) + math.sqrt(b)) * (1 + 1e-9)
    # Integer combinations are hit exactly (away from the rounding half-way points).
    k1, k2 = round(x1), round(x2)
    ex = allocate(k1 * t1 + k2 * t2, B, m_rod_Am2=M_ROD, n_max=380, mode="exact")
    assert (ex.N1, ex.N2) == (k1, k2)


def test_paper_mode_is_one_gauss_seidel_sweep_t5():
    """With τ1 ⟂̸ τ2 the paper's sequential projection can miss an integer combination that the
    exact mode hits."""
    B = field([0.7, 0.6, 0.3])
    t1, t2 = rod_torques(B, m_rod_Am2=M_ROD)
    T_ref = 5 * t1 + 3 * t2
    p = allocate(T_ref, B, m_rod_Am2=M_ROD, n_max=380, mode="paper")
    e = allocate(T_ref, B, m_rod_Am2=M_ROD, n_max=380, mode="exact")
    assert (e.N1, e.N2) == (5, 3)
    assert p.N1 == round_half_away(T_ref @ t1 / (t1 @ t1))
    assert p.N2 == round_half_away((T_ref @ t2 - p.N1 * (t1 @ t2)) / (t2 @ t2))
    assert (p.N1, p.N2) != (5, 3)


def test_singular_gram_falls_back_and_tiny_torque_gives_zero():
    B = field([0.6, -0.8, 0.0])  # field in the plate plane: τ1 ∥ τ2
    T_ref = np.array([0.0, 0.0, 0.05])
    e = allocate(T_ref, B, m_rod_Am2=M_ROD, n_max=380, mode="exact")
    p = allocate(T_ref, B, m_rod_Am2=M_ROD, n_max=380, mode="paper")
    assert e.mode == "exact_fallback" and p.mode == "paper"
    assert (e.N1, e.N2) == (p.N1, p.N2)
    # Field along x̂1: |τ1| = 0, so N1 = 0 and family 2 does the work.
    Bx = field([1.0, 0.0, 0.0])
    al = allocate([0.0, 0.01, 0.02], Bx, m_rod_Am2=M_ROD, n_max=380)
    assert al.N1 == 0 and al.N2 != 0
    zero = allocate([1.0, 1.0, 1.0], [0.0, 0.0, 0.0], m_rod_Am2=M_ROD, n_max=380, mode="exact")
    assert (zero.N1, zero.N2) == (0, 0)


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), mode=st.sampled_from(["paper", "exact"]))
def test_batch_matches_scalar(seed, mode):
    rng = np.random.default_rng(seed)
    K = 40
    B = rng.normal(size=(K, 3)) * B_SCALE
    B[::7, 2] = 0.0  # in-plane fields (fallback)
    B[::11, 1:] = 0.0  # fields along x̂1 (tiny τ1)
    T = rng.normal(size=(K, 3)) * 10.0 ** rng.uniform(-4, 1, (K, 1))
    m = (M_ROD, 0.7 * M_ROD)
    bt = allocate_batch(T, B, m_rod_Am2=m, n_max=(380, 300), mode=mode)
    for k in range(K):
        al = allocate(T[k], B[k], m_rod_Am2=m, n_max=(380, 300), mode=mode)
        assert (al.N1, al.N2) == (bt.N1[k], bt.N2[k])
        assert (al.mode == "exact_fallback") == bool(bt.fallback[k])
        assert (al.clipped1, al.clipped2) == (bt.clipped1[k], bt.clipped2[k])
    np.testing.assert_allclose(
        bt.torque_body[0], allocate(T[0], B[0], m_rod_Am2=m, n_max=(380, 300), mode=mode).torque_body, rtol=1e-15
    )
    d = allocation_mode_difference(T, B, m_rod_Am2=m, n_max=(380, 300))
    assert d["n_samples"] == K and 0 <= d["fraction_counts_differ"] <= 1
    assert d["fraction_exact_fallback"] >= 6 / K


def test_allocation_input_errors_name_the_argument():
    with pytest.raises(ValueError, match="mode"):
        allocate([0, 0, 0], [0, 0, 1e-5], m_rod_Am2=1.0, n_max=10, mode="lsq")
    with pytest.raises(ValueError, match="T_ref_body"):
        allocate([0, 0], [0, 0, 1e-5], m_rod_Am2=1.0, n_max=10)
    with pytest.raises(ValueError, match="T_ref_body"):
        allocate([0, np.nan, 0], [0, 0, 1e-5], m_rod_Am2=1.0, n_max=10)
    with pytest.raises(ValueError, match="B_body"):
        allocate([0, 0, 0], [0, 0, np.inf], m_rod_Am2=1.0, n_max=10)
    with pytest.raises(ValueError, match="m_rod_Am2"):
        allocate([0, 0, 0], [0, 0, 1e-5], m_rod_Am2=-1.0, n_max=10)
    with pytest.raises(ValueError, match="n_max"):
        allocate([0, 0, 0], [0, 0, 1e-5], m_rod_Am2=1.0, n_max=2.5)
    with pytest.raises(ValueError, match="B_body"):
        allocate_batch(np.zeros((3, 3)), np.zeros((2, 3)), m_rod_Am2=1.0, n_max=10)


@pytest.mark.parametrize("mode", ["paper", "exact"])
def test_extreme_rod_dipoles_neither_overflow_nor_change_the_counts(mode):
    """The allocation is scale-free: scaling the dipole and the reference torque by the same power
    of two (exact in floats) gives the same counts, up to m = 2^900 ≈ 8e270 A m² and down to
    2^-900; (m B)² overflowed float64 for a 1e300 A m² rod (``actuators.kappa_Am2_kg = 1e300``:
    OverflowError). A rod so weak that the demand overflows to infinity saturates its family."""
    rng = np.random.default_rng(5)
    B = rng.normal(size=(20, 3)) * B_SCALE
    T = rng.normal(size=(20, 3)) * 0.3
    ref = allocate_batch(T, B, m_rod_Am2=M_ROD, n_max=380, mode=mode)
    for s in (2.0**900, 2.0**-900):
        got = allocate_batch(T * s, B, m_rod_Am2=M_ROD * s, n_max=380, mode=mode)
        np.testing.assert_array_equal(got.N1, ref.N1)
        np.testing.assert_array_equal(got.N2, ref.N2)
        for k in range(3):
            al = allocate(T[k] * s, B[k], m_rod_Am2=M_ROD * s, n_max=380, mode=mode)
            assert (al.N1, al.N2) == (ref.N1[k], ref.N2[k])
    al = allocate(T[0], B[0], m_rod_Am2=1e300, n_max=380, mode=mode)
    assert (al.N1, al.N2) == (0, 0) and not (al.clipped1 or al.clipped2)
    weak = allocate([0.0, 1.0, 0.0], [0.0, 0.0, 3e-5], m_rod_Am2=1e-310, n_max=380, mode=mode)
    assert math.isinf(weak.x1) and weak.N1 == -380 and weak.clipped1
    batch = allocate_batch(np.array([[0.0, 1.0, 0.0]]), np.array([[0.0, 0.0, 3e-5]]), m_rod_Am2=1e-310, n_max=380)
    assert batch.N1[0] == -380 and batch.clipped1[0]


# ----------------------------------------------------------------------------- Lloyd


def _polygon_centroid(p):
    x, y = p[:, 0], p[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    c = x * yn - xn * y
    A = c.sum() / 2
    return np.array([((x + xn) * c).sum(), ((y + yn) * c).sum()]) / (6 * A), A


@pytest.mark.parametrize("n", [1, 2, 3, 7, 40, 200])
def test_cell_centroids_match_plain_polygon_reference(n):
    region = (-1.0, 0.5, 2.0, 2.5)
    P = initial_generators(n, region, seed=n)
    C, A = voronoi_centroids(P, region)
    ref = [_polygon_centroid(c) for c in voronoi_cells(P, region)]
    np.testing.assert_allclose(C, [r[0] for r in ref], rtol=0, atol=1e-12 * 3)
    np.testing.assert_allclose(A, [r[1] for r in ref], rtol=0, atol=1e-12 * 6)
    assert A.sum() == pytest.approx(6.0, rel=1e-12)


def test_lloyd_converges_to_a_cvt_and_triangulation_reuse_changes_nothing():
    reg = (0.0, 0.0, 1.0, 1.0)
    a = lloyd(20, region=reg, seed=4, tol_rel=1e-7)
    b = lloyd(20, region=reg, seed=4, tol_rel=1e-7, reuse_triangulation=False)
    assert a.converged and a.iterations == b.iterations
    np.testing.assert_allclose(a.generators, b.generators, rtol=0, atol=1e-12)
    C, A = voronoi_centroids(a.generators, reg)
    assert np.abs(C - a.generators).max() < 1e-7
    # A CVT spreads the cells evenly: areas within a factor ~1.5 of the mean (random: ~10).
    assert A.max() / A.min() < 1.6
    capped = lloyd(20, region=reg, seed=4, max_iter=3)
    assert capped.iterations == 3 and not capped.converged


def _brute_force_assignment(G, S):
    best, arg = np.inf, None
    for perm in itertools.permutations(range(len(S)), len(G)):
        cost = sum(((G[i] - S[p]) ** 2).sum() for i, p in enumerate(perm))
        if cost < best - 1e-15:
            best, arg = cost, perm
    return best, arg


def test_snapping_is_the_optimal_one_to_one_assignment_t4():
    rng = np.random.default_rng(0)
    S = rng.uniform(size=(7, 2))
    for _ in range(5):
        G = rng.uniform(size=(4, 2))
        sel = snap_to_sites(G, S)
        assert len(set(sel.tolist())) == 4
        best, _ = _brute_force_assignment(G, S)
        # cost of the chosen set under its optimal pairing equals the brute-force optimum
        best_sel, _ = _brute_force_assignment(G, S[sel])
        assert best_sel == pytest.approx(best, rel=1e-12)
    # Two generators at the same site: nearest-site snapping would pick it twice.
    G = np.array([[0.5, 0.5], [0.51, 0.5]])
    S2 = np.array([[0.5, 0.5], [0.0, 0.0], [0.7, 0.5]])
    assert snap_to_sites(G, S2).tolist() == [0, 2]
    assert snap_to_sites(np.zeros((0, 2)), S2).size == 0
    with pytest.raises(ValueError, match="generators"):
        snap_to_sites(np.zeros((4, 2)), S2)


@pytest.fixture(scope="module")
def small_selector():
    """A 6 × 7 / 7 × 6 two-family array on [−3, 3]² (like the truss's x1/y1 strut midpoints)."""
    a = 1.0
    i, j = np.meshgrid(np.arange(6), np.arange(7), indexing="xy")
    f1 = np.column_stack([(i.ravel() + 0.5) * a - 3, j.ravel() * a - 3])
    f2 = f1[:, ::-1].copy()
    return LloydSelector([f1, f2], region=(-3, -3, 3, 3), seed=11, tol_rel=1e-4)


def test_selection_determinism_counts_and_extremes(small_selector):
    sel = small_selector
    n = sel.n_sites[0]
    for count in (0, 1, 5, 17, n - 1, n):
        for f in (0, 1):
            s = sel.selected(f, count)
            assert s.size == count and len(set(s.tolist())) == count
            assert s.min(initial=0) >= 0 and s.max(initial=0) < n
    assert sel.selected(0, n).tolist() == list(range(n))  # all sites for N_max
    assert sel.selected(1, 0).size == 0  # none for 0
    again = LloydSelector(sel.sites, region=sel.region, seed=11, tol_rel=1e-4)
    for count in (5, 17):
        np.testing.assert_array_equal(again.selected(0, count), sel.selected(0, count))
        np.testing.assert_array_equal(again.result(count).generators, sel.result(count).generators)
    other = LloydSelector(sel.sites, region=sel.region, seed=12, tol_rel=1e-4)
    assert not np.array_equal(other.result(17).generators, sel.result(17).generators)
    with pytest.raises(ValueError, match="count"):
        sel.selected(0, n + 1)
    with pytest.raises(ValueError, match="family"):
        sel.selected(2, 1)


def test_polarity_vector_and_distributor(small_selector):
    sel = small_selector
    pol = sel.polarity((5, -9))
    n1 = sel.n_sites[0]
    assert pol.dtype == np.int8 and pol.shape == (sel.n_rods,)
    assert np.all(pol[:n1][sel.selected(0, 5)] == 1) and np.count_nonzero(pol[:n1]) == 5
    assert np.all(pol[n1:][sel.selected(1, 9)] == -1) and np.count_nonzero(pol[n1:]) == 9
    dist = TorqueDistributor(sel, m_rod_Am2=2.0, mode="exact")
    B = field([0.2, 0.4, 0.9])
    t1, t2 = rod_torques(B, m_rod_Am2=2.0)
    pol, al = dist(3 * t1 - 7 * t2, B)
    assert (al.N1, al.N2) == (3, -7)
    assert pol[:n1].sum() == 3 and pol[n1:].sum() == -7
    assert np.count_nonzero(pol) == 10
    pol, al = dist(1e3 * (t1 + t2), B)  # saturated: every rod of both families
    assert np.all(pol == 1)


def test_disk_cache_and_parallel_precompute(tmp_path, small_selector):
    sites, region = small_selector.sites, small_selector.region
    a = LloydSelector(sites, region=region, seed=11, tol_rel=1e-4, cache_dir=tmp_path)
    a.precompute(counts=[3, 8, 20], workers=2)
    assert a.stats["lloyd_runs"] == 3
    b = LloydSelector(sites, region=region, seed=11, tol_rel=1e-4, cache_dir=tmp_path)
    for c in (3, 8, 20):
        np.testing.assert_array_equal(b.selected(0, c), small_selector.selected(0, c))
        np.testing.assert_array_equal(b.selected(1, c), small_selector.selected(1, c))
    # precompute also snapped both families: b reads the six selections, no generators, no Lloyd
    assert b.stats["snap_disk_hits"] == 6 and b.stats["disk_hits"] == 0 and b.stats["lloyd_runs"] == 0
    assert len(list(a.cache_dir.glob("sites_*/n*.npy"))) == 6
    # without the snapped files the generators come from disk and are snapped again, identically
    for f in a.cache_dir.glob("sites_*/n*.npy"):
        f.unlink()
    b2 = LloydSelector(sites, region=region, seed=11, tol_rel=1e-4, cache_dir=tmp_path)
    np.testing.assert_array_equal(b2.selected(1, 8), small_selector.selected(1, 8))
    assert b2.stats["disk_hits"] == 1 and b2.stats["snap_disk_hits"] == 0 and b2.stats["lloyd_runs"] == 0
    c = LloydSelector(sites, region=region, seed=11, tol_rel=1e-5, cache_dir=tmp_path)
    assert c.cache_dir != a.cache_dir
    assert c.cache_key() != a.cache_key()  # keyed by tolerance (and seed, region)
    with pytest.raises(ValueError, match="tol_rel"):
        LloydSelector(sites, region=region, tol_rel=0.0)
    with pytest.raises(ValueError, match="region"):
        LloydSelector(sites, region=(0, 0, -1, 1))


def test_demo_case_72_of_100_t6():
    """Fig. 16b: 10 × 10 cell-centre sites of the unit square (our choice), 72 active."""
    g = (np.arange(10) + 0.5) / 10
    X, Y = np.meshgrid(g, g, indexing="xy")
    sites = np.column_stack([X.ravel(), Y.ravel()])
    res = lloyd(72, region=(0, 0, 1, 1), seed=0)
    assert res.converged and res.max_move < 1e-6
    chosen = snap_to_sites(res.generators, sites)
    assert chosen.size == 72 and len(set(chosen.tolist())) == 72
    # Evenly spread: no point of the square is far from an active site — the covering radius is
    # well below that of the snapped random start (0.117 against 0.189 for seed 0).
    rand = snap_to_sites(initial_generators(72, (0, 0, 1, 1), seed=0), sites)
    assert covering_radius(sites[chosen], (0, 0, 1, 1)) < 0.8 * covering_radius(sites[rand], (0, 0, 1, 1))
    assert np.isfinite(nn_spacing_cv(sites[chosen]))


def test_allocation_demo_script(tmp_path):
    """Demonstration script: figure and the summary keys."""
    mod = load_file_module("scripts", "allocation_demo")
    assert mod.main(["--out", str(tmp_path), "--tol-rel", "1e-4"]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    for key in (
        "n_sites",
        "n_active",
        "lloyd_iterations",
        "lloyd_tol_rel",
        "lloyd_time_s",
        "snap_time_s",
        "nn_spacing_cv",
    ):
        assert key in summary
    assert summary["n_sites"] == 100 and summary["n_active"] == 72 and summary["lloyd_tol_rel"] == 1e-4
    assert len(set(summary["chosen_sites"])) == 72
    assert (summary["fig15"]["N1"], summary["fig15"]["N2"]) == (2, 2)
    assert summary["fig15"]["error_Nm"] <= summary["fig15"]["bound_Nm"]
    assert (tmp_path / "allocation_demo.png").stat().st_size > 20_000
