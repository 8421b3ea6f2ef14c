"""Strain energy, strut strain, relative kinetic energy, inverted cells (diagnostics of ours).

Point sets and struts are built without the lattice module: the two-layer truss lattice
(``tests.conftest.lattice_points``) and, as struts, every node pair closer than 1.01 a sqrt(2)
(cube edges plus both face diagonals). Energies are compared with closed forms to 1e-12 relative
(rounding of sums over a few thousand terms); "zero to rounding" means below 1e-12 of the total
energy.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

import magsail_mj.analysis.energy as energy_mod
from magsail_mj.analysis.energy import (
    inverted_cells,
    kinetic_energy_split,
    lattice_cube_tetrahedra,
    relative_kinetic_energy,
    signed_tet_volumes,
    strain_energy,
    structural_failure,
    strut_lengths,
    strut_strain,
)
from magsail_mj.estimation._arrays import map_time_blocks
from tests.conftest import lattice_points


N, D = 8, 20.0
A = D / (N - 1)
P = lattice_points(N, D)
STRUTS = np.array(sorted(cKDTree(P).query_pairs(1.01 * A * np.sqrt(2))))
L0 = np.linalg.norm(P[STRUTS[:, 1]] - P[STRUTS[:, 0]], axis=-1)
K = np.random.default_rng(0).uniform(1e3, 5e3, len(STRUTS))
M = np.random.default_rng(1).uniform(0.1, 0.3, len(P))


def test_strut_set_sanity():
    assert set(np.round(L0 / A, 12)) == {1.0, round(np.sqrt(2), 12)}


def test_uniform_stretch_closed_form():
    lam = 1.037
    R = Rotation.from_rotvec([0.2, 0.4, -1.0]).as_matrix()
    x = lam * P @ R.T + np.array([1.0, 2.0, -3.0])
    r = strut_lengths(x, STRUTS)
    assert np.allclose(r, lam * L0, rtol=1e-14)
    assert np.allclose(strut_strain(x, STRUTS, L0), lam - 1.0, rtol=0, atol=1e-14)
    E = strain_energy(x, STRUTS, K, L0)
    E_exact = 0.5 * np.sum(K * ((lam - 1.0) * L0) ** 2)
    assert isinstance(E, float)
    assert E == pytest.approx(E_exact, rel=1e-12)
    # scalar k, and the undeformed lattice has zero energy
    assert strain_energy(x, STRUTS, 2e3, L0) == pytest.approx(0.5 * 2e3 * (lam - 1) ** 2 * np.sum(L0**2), rel=1e-12)
    assert strain_energy(P @ R.T, STRUTS, K, L0) < 1e-20


def test_time_series_vectorised_and_blocked(monkeypatch):
    lams = np.linspace(0.9, 1.1, 25)
    Rs = Rotation.random(25, random_state=2).as_matrix()
    x = lams[:, None, None] * np.einsum("tij,nj->tni", Rs, P)
    E = strain_energy(x, STRUTS, K, L0)
    assert E.shape == (25,)
    E_exact = 0.5 * ((lams[:, None] - 1.0) ** 2 * L0**2) @ K
    assert np.allclose(E, E_exact, rtol=1e-11, atol=1e-18)
    # blocked evaluation (tiny blocks) gives identical numbers
    monkeypatch.setattr(energy_mod, "map_time_blocks", functools.partial(map_time_blocks, max_elems=1000))
    assert np.allclose(strain_energy(x, STRUTS, K, L0), E, rtol=1e-14, atol=0)
    eps = strut_strain(x, STRUTS, L0)
    assert eps.shape == (25, len(STRUTS))
    assert np.allclose(eps, lams[:, None] - 1.0, atol=1e-13)
    v = np.random.default_rng(3).normal(size=x.shape)
    ke_blocked = kinetic_energy_split(x, v, M)
    monkeypatch.undo()
    ke = kinetic_energy_split(x, v, M)
    for f1, f2 in zip(ke_blocked, ke):
        assert np.allclose(f1, f2, rtol=1e-13, atol=1e-15)


def rigid_velocity(x, omega, v0, masses):
    xc = np.average(x, axis=-2, weights=masses)
    return v0 + np.cross(omega, x - xc)


def test_relative_ke_of_rigid_spin_is_zero():
    R = Rotation.from_rotvec([0.7, -0.2, 0.4]).as_matrix()
    x = P @ R.T + np.array([10.0, -5.0, 2.0])
    omega = np.array([0.01, 0.007, -0.02])
    v = rigid_velocity(x, omega, np.array([0.3, -0.1, 0.05]), M)
    ks = kinetic_energy_split(x, v, M)
    assert ks.relative < 1e-12 * ks.total
    assert relative_kinetic_energy(x, v, M) == ks.relative
    assert np.allclose(ks.omega, omega, rtol=1e-12)
    assert ks.translational + ks.rotational == pytest.approx(ks.total, rel=1e-12)


def internal_velocity(x, masses, rng):
    """Velocity field v = S r with S symmetric and S_xz = S_yz = 0 in the plate frame: its
    angular momentum vanishes because the lattice's second-moment matrix is diag(c, c, c')."""
    S = rng.normal(size=(3, 3)) * 1e-3
    S = S + S.T
    S[0, 2] = S[2, 0] = S[1, 2] = S[2, 1] = 0.0
    xc = np.average(x, axis=-2, weights=masses)
    return (x - xc) @ S.T


def test_relative_ke_of_internal_vibration():
    rng = np.random.default_rng(7)
    m = np.full(len(P), 0.25)  # symmetric mass distribution -> L = 0 exactly
    R = Rotation.from_rotvec([-0.3, 0.1, 1.3]).as_matrix()
    x = P @ R.T
    u = internal_velocity(P, m, rng) @ R.T
    vc = np.array([0.02, -0.03, 0.01])
    v = u + vc
    ks = kinetic_energy_split(x, v, m)
    ke_com = 0.5 * m.sum() * vc @ vc
    assert np.abs(ks.omega).max() < 1e-14
    assert ks.relative == pytest.approx(ks.total - ke_com, rel=1e-12)
    assert ks.relative == pytest.approx(0.5 * np.sum(m[:, None] * u * u), rel=1e-12)
    # superposed on a rigid spin, the relative part is still the internal energy only
    omega = np.array([0.005, 0.0, 0.01])
    v2 = v + rigid_velocity(x, omega, np.zeros(3), m)
    ks2 = kinetic_energy_split(x, v2, m)
    assert np.allclose(ks2.omega, omega, rtol=1e-12)
    assert ks2.relative == pytest.approx(ks.relative, rel=1e-11)


def test_ke_time_series_shapes_and_errors():
    x = np.repeat(P[None], 4, axis=0)
    v = np.zeros_like(x)
    rel = relative_kinetic_energy(x, v, 0.1)
    assert rel.shape == (4,) and np.all(rel == 0)
    with pytest.raises(ValueError, match=r"vel: expected shape \(4, 128, 3\)"):
        relative_kinetic_energy(x, v[0], 0.1)
    with pytest.raises(ValueError, match=r"masses: expected a scalar or shape \(128,\)"):
        relative_kinetic_energy(x, v, np.ones(3))


def test_lattice_tetrahedra_positive_and_inversion():
    tets = lattice_cube_tetrahedra(N)
    assert tets.shape == (8 * (N - 1) ** 2, 4)
    vol = signed_tet_volumes(P, tets)
    assert np.allclose(vol, A**3 / 6, rtol=1e-12)
    assert not inverted_cells(P, tets).any()
    # push one top interior node down through the bottom layer: its cubes turn inside out
    node = 1 * N * N + 3 * N + 4
    x = P.copy()
    x[node, 2] -= 1.5 * A
    inv = inverted_cells(x, tets)
    touched = np.any(tets == node, axis=1)
    assert inv.any() and not inv[~touched].any()
    # the corner tets at that node (the corner being the node itself) all invert
    assert inv[tets[:, 0] == node].all()
    # a mirror image is entirely inside out; a rigid rotation is not
    R = Rotation.from_rotvec([1.0, 2.0, 0.5]).as_matrix()
    assert inverted_cells(P * np.array([1.0, 1.0, -1.0]), tets).all()
    assert not inverted_cells(P @ R.T + 3.0, tets).any()
    # time series and explicit references (positions or volumes, any orientation)
    series = np.stack([P, x, P @ R.T])
    inv_t = inverted_cells(series, tets[:, [0, 2, 1, 3]], reference=P)
    assert inv_t.shape == (3, len(tets))
    assert np.array_equal(inv_t[1], inv) and not inv_t[0].any() and not inv_t[2].any()
    flipped = tets[:, [0, 2, 1, 3]]
    assert np.array_equal(inverted_cells(x, flipped, reference=signed_tet_volumes(P, flipped)), inv)
    with pytest.raises(ValueError, match="reference: expected positions"):
        inverted_cells(x, tets, reference=np.ones(5))


def test_structural_failure_flag():
    tets = lattice_cube_tetrahedra(N)
    series = np.stack([P, 1.3 * P, 1.6 * P])
    fc = structural_failure(series, STRUTS, L0, tets=tets)
    assert fc.failed.tolist() == [False, False, True]
    assert np.allclose(fc.max_abs_strain, [0.0, 0.3, 0.6], atol=1e-12)
    x = P.copy()
    x[1 * N * N + 3 * N + 4, 2] -= 1.5 * A  # inverts cells (and overstrains struts)
    fc1 = structural_failure(x, STRUTS, L0, tets=tets, strain_limit=10.0)
    assert fc1.failed and fc1.n_inverted == 8 and fc1.max_abs_strain < 10.0
    assert not structural_failure(x, STRUTS, L0, strain_limit=10.0).failed
    assert structural_failure(x, STRUTS, L0).failed  # strain above the default 50 %


def test_errors_name_argument():
    with pytest.raises(ValueError, match=r"struts: expected shape \(m, 2\)"):
        strut_lengths(P, STRUTS[:, :1])
    with pytest.raises(ValueError, match=r"struts: node indices must lie in \[0, 128\)"):
        strut_lengths(P, STRUTS + 200)
    with pytest.raises(ValueError, match="struts: expected integer node indices"):
        strut_lengths(P, STRUTS.astype(float))
    with pytest.raises(ValueError, match=r"k: expected a scalar or shape"):
        strain_energy(P, STRUTS, K[:3], L0)
    with pytest.raises(ValueError, match="l0: rest lengths must be > 0"):
        strut_strain(P, STRUTS, 0.0)
    with pytest.raises(ValueError, match="nodes_per_side"):
        lattice_cube_tetrahedra(1)
