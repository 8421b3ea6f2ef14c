"""Polynomial-plus-low-rank Caughey damping (magsail_mj.lattice.low_rank_polynomial) against the schedule.

A 6-unit plate (98 nodes, 294 DOF) with the paper's n_low = 100, so 182 elastic modes carry ξ = 10
and are fitted by the polynomial. The damping ratio each mode gets is read off the modal damping
matrix Φᵀ γ Φ (M-orthonormal Φ: ζ_n = φ_nᵀ γ φ_n / (2 ω_n)); tolerances are stated per assertion.
"""

from __future__ import annotations

import numpy as np
import pytest

from magsail_mj.estimation.attitude import so3_exp
from magsail_mj.lattice.geometry import make_lattice
from magsail_mj.lattice.low_rank_polynomial import caughey_polynomial, relative_minimax_chebyshev
from magsail_mj.lattice.modal_damping import ModalDampingLoad
from magsail_mj.lattice.modes import caughey_matrix, damping_ratios, lattice_modes
from magsail_mj.lattice.properties import strut_stiffness

SIDE = 60.0
SIGMA = 0.1
N_LOW = 100


@pytest.fixture(scope="module")
def plate(tmp_path_factory):
    lat = make_lattice(units=6, side_m=SIDE)
    k, _ = strut_stiffness(lat, EI_Nm2=1e4, calibration="formula")
    m = np.full(lat.n_nodes, SIGMA * SIDE**2 / lat.n_nodes)
    m[::5] *= 1.7  # unequal masses: the M^1/2 scaling is exercised
    modes = lattice_modes(lat.nodes, lat.struts, k, m, cache_dir=tmp_path_factory.mktemp("modes"))
    xi = damping_ratios(modes.omega, schedule="paper_max", n_low=N_LOW)
    return lat, k, m, modes, xi


def _build(plate, **kw):
    lat, k, m, modes, xi = plate
    return caughey_polynomial(modes, xi, nodes=lat.nodes, struts=lat.struts, k=k, n_low=N_LOW, **kw)


def _modal(g, modes) -> np.ndarray:
    """Φᵀ γ_p Φ [1/s] (the operator applied to every mode shape)."""
    return modes.phi.T @ g.apply(modes.phi.copy())


@pytest.mark.parametrize(("dtype", "exact_tol"), [(np.float64, 1e-9), (np.float32, 1e-5)])
def test_each_mode_gets_its_scheduled_ratio(plate, dtype, exact_tol):
    _, _, _, modes, xi = plate
    rtol = 0.02
    g = _build(plate, rtol=rtol, dtype=dtype)
    G = _modal(g, modes)
    om = modes.omega
    el = om > 0
    zeta = np.zeros_like(om)
    zeta[el] = np.diag(G)[el] / (2.0 * om[el])
    fitted = np.arange(modes.n_rigid + N_LOW, om.size)
    exact = np.arange(modes.n_rigid, modes.n_rigid + N_LOW)
    assert np.all(xi[fitted] == 10.0)  # the fitted set is the ξ = 10 branch of paper_max
    # fitted modes: within rtol of the schedule, and the error the object states is the one measured
    assert np.max(np.abs(zeta[fitted] / xi[fitted] - 1.0)) <= rtol
    assert np.allclose(np.abs(zeta[fitted] / xi[fitted] - 1.0), g.ratio_error[fitted], rtol=0, atol=10 * exact_tol)
    # corrected modes (ξ = 0.01): exact up to round-off of the cancelled p(λ) ~ 20 ω (relative to ξ_cap)
    assert np.max(np.abs(zeta[exact] - xi[exact])) <= exact_tol * 10.0
    # rigid modes undamped, no mode coupled to another (relative to the largest modal rate)
    off = G - np.diag(np.diag(G))
    scale = np.max(np.diag(G))
    assert np.max(np.abs(np.diag(G)[: modes.n_rigid])) <= exact_tol * scale
    assert np.max(np.abs(off)) <= exact_tol * scale
    assert np.allclose(g.effective_ratios(om)[el], zeta[el], rtol=0, atol=10 * exact_tol)


def test_force_error_bounded_by_rtol_in_the_mass_norm(plate):
    """‖(γ_p − γ) v‖_{M⁻¹} ≤ rtol ‖γ v‖_{M⁻¹} for any v (γ_p − γ is diagonal in the modes)."""
    _, _, m, modes, xi = plate
    gamma = caughey_matrix(modes, xi)
    m3 = np.repeat(m, 3)
    rng = np.random.default_rng(3)
    for rtol in (0.05, 0.01):
        g = _build(plate, rtol=rtol)
        for _ in range(5):
            v = rng.normal(size=m3.size)
            ref = gamma @ v
            err = g.apply(v) - ref
            assert np.sqrt(np.sum(err**2 / m3)) <= rtol * np.sqrt(np.sum(ref**2 / m3)) * (1 + 1e-9)
            assert np.linalg.norm(err) > 1e-6 * rtol * np.linalg.norm(ref)  # an approximation, not γ itself


def test_degree_grows_as_rtol_shrinks_and_the_limit_is_named(plate):
    d_loose = _build(plate, rtol=0.05).degree
    d_tight = _build(plate, rtol=0.002).degree
    assert 1 <= d_loose < d_tight
    with pytest.raises(ValueError, match="rtol"):
        _build(plate, rtol=1e-8, max_degree=2)
    with pytest.raises(ValueError, match="rtol"):
        _build(plate, rtol=1.5)
    with pytest.raises(ValueError, match="dtype"):
        _build(plate, dtype=np.int32)


def test_capped_rayleigh_is_a_degree_one_polynomial(plate):
    """capped_rayleigh: c_n = 4 ξ_low ω_n² / ω_nlow above n_low (∝ λ), fitted exactly at degree 1."""
    lat, k, _, modes, _ = plate
    xi = damping_ratios(modes.omega, schedule="capped_rayleigh", n_low=N_LOW)
    g = caughey_polynomial(modes, xi, nodes=lat.nodes, struts=lat.struts, k=k, n_low=N_LOW, rtol=1e-6)
    assert g.degree == 1
    ref = caughey_matrix(modes, xi)
    v = np.random.default_rng(0).normal(size=ref.shape[0])
    assert np.linalg.norm(g.apply(v) - ref @ v) <= 1e-9 * np.linalg.norm(ref @ v)


def test_relative_minimax_of_sqrt_equioscillates():
    """The fit of √λ on [1, 50] at degree 3: degree + 2 = 5 local extrema of the relative error with
    alternating signs, each at least 0.9 of the largest. By de la Vallée Poussin's theorem the
    minimax error is then at least 0.9 of ours: the fit is within 10 % of the best possible."""
    lam = np.linspace(1.0, 50.0, 2000)
    t = np.sqrt(lam)
    coef, err = relative_minimax_chebyshev(lam, t, degree=3, interval=(1.0, 50.0))
    r = np.polynomial.chebyshev.chebval((2 * lam - 51.0) / 49.0, coef) / t - 1.0
    assert np.isclose(np.abs(r).max(), err)
    inner = np.flatnonzero((np.abs(r[1:-1]) > np.abs(r[:-2])) & (np.abs(r[1:-1]) >= np.abs(r[2:]))) + 1
    ext = r[np.r_[0, inner, lam.size - 1]]
    ext = ext[np.abs(ext) >= 0.9 * err]
    assert ext.size >= 5 and np.all(np.sign(ext[1:]) == -np.sign(ext[:-1]))


def test_load_polynomial_matches_dense_and_leaves_rigid_motion_undamped(plate):
    lat, k, m, modes, _ = plate
    kw = dict(nodes=lat.nodes, struts=lat.struts, k=k, masses=m, modes=modes, n_low=N_LOW, dtype=np.float64)
    dense = ModalDampingLoad.for_lattice(**kw)
    poly = ModalDampingLoad.for_lattice(form="polynomial", rtol=0.01, **kw)
    rng = np.random.default_rng(1)
    R = so3_exp(np.array([0.4, -1.1, 0.7]))
    pos = lat.nodes @ R.T + np.array([5.0, -3.0, 2.0]) + 0.05 * rng.normal(size=lat.nodes.shape)
    vel = rng.normal(size=pos.shape)
    Fd, Fp = dense.forces(pos, vel), poly.forces(pos, vel)
    m3 = np.repeat(m, 3)
    err = (Fp - Fd).ravel()
    assert np.sqrt(np.sum(err**2 / m3)) <= 0.01 * np.sqrt(np.sum(Fd.ravel() ** 2 / m3)) * (1 + 1e-9)
    # the undeformed plate, rotated and shifted, spinning about its centre of mass and drifting:
    # no force (relative to the forces of the flexible case above)
    pos0 = lat.nodes @ R.T + np.array([5.0, -3.0, 2.0])
    c = (m @ pos0) / m.sum()
    v_rigid = np.cross(np.array([0.02, -0.01, 0.03]), pos0 - c) + np.array([0.3, 0.0, -0.1])
    assert np.abs(poly.forces(pos0, v_rigid)).max() <= 1e-9 * np.abs(Fd).max()
    assert poly.effective_ratios is not None and np.all(poly.tendon_damping(k) == 0.0)


def test_for_lattice_names_a_bad_form(plate):
    lat, k, m, modes, _ = plate
    with pytest.raises(ValueError, match="form"):
        ModalDampingLoad.for_lattice(nodes=lat.nodes, struts=lat.struts, k=k, masses=m, modes=modes, form="cheby")
