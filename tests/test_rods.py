"""Magnetorquer rods in struts (Robb et al. 2022a, Eq. 4 corrected: no factor ½, sign giving +m × B;
rod dipoles per family, Sec. 4.2).

Tolerances: the force pair is a handful of flops per rod, so the midpoint torque is asserted to
1e-12 of ``m |B|`` and the axial component to 1e-12 of ``m |B| / |r|`` (corrected Eq. 4). Whole-lattice
sums over 760 rods are asserted to 1e-12 of ``Σ m |B|`` (rounding ~ 760 eps).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from magsail_mj.lattice.geometry import make_lattice
from magsail_mj.loads.base import Load, StepState
from magsail_mj.loads.magnetorquer_rods import (
    MagnetorquerRodLoad,
    rod_array,
    rod_dipole_Am2,
    rod_pair_forces,
)

finite = st.floats(-1.0, 1.0, allow_nan=False)
vec = st.tuples(finite, finite, finite).map(np.array).filter(lambda v: np.linalg.norm(v) > 1e-3)


def reference_force(r_i, r_j, s, m, B):
    """Plain per-rod reference: F_j = (m × B) × r / r² with m = s m r̂ (corrected Eq. 4)."""
    r = np.asarray(r_j, float) - np.asarray(r_i, float)
    m_vec = s * m * r / np.linalg.norm(r)
    return np.cross(np.cross(m_vec, B), r) / (r @ r)


def paper_printed_force_i(r_i, r_j, m, B):
    """The paper's printed Eq. 4, F_i = (1/r)(m B − (½ m B·r̂_ji) r̂_ji), kept to show its defects
    (a spurious factor ½ and the sign)."""
    r_ji = np.asarray(r_i, float) - np.asarray(r_j, float)
    e = r_ji / np.linalg.norm(r_ji)
    return (m * B - 0.5 * m * (B @ e) * e) / np.linalg.norm(r_ji)


@settings(max_examples=300, deadline=None)
@given(
    r_i=vec,
    d=vec,
    B_dir=vec,
    B_exp=st.floats(-9, -3),
    length=st.floats(0.05, 100.0),
    s=st.sampled_from([-1, 1]),
    m=st.floats(0.01, 1e3),
)
def test_force_pair_torque_force_and_direction(r_i, d, B_dir, B_exp, length, s, m):
    """Midpoint torque = m × B (1e-12 rel.), zero net force, forces ⟂ strut."""
    r_i = 50.0 * r_i
    r_j = r_i + length * d / np.linalg.norm(d)
    B = 10.0**B_exp * B_dir / np.linalg.norm(B_dir)
    F_j = rod_pair_forces(r_i[None], r_j[None], np.array([s * m]), B)[0]
    F_i = -F_j
    mid = 0.5 * (r_i + r_j)
    tau = np.cross(r_i - mid, F_i) + np.cross(r_j - mid, F_j)
    m_vec = s * m * (r_j - r_i) / np.linalg.norm(r_j - r_i)
    scale = m * np.linalg.norm(B)
    np.testing.assert_allclose(tau, np.cross(m_vec, B), rtol=0, atol=1e-12 * scale)
    assert np.all(F_i + F_j == 0)
    e = (r_j - r_i) / length
    assert abs(F_j @ e) <= 1e-12 * scale / length
    np.testing.assert_allclose(F_j, reference_force(r_i, r_j, s, m, B), rtol=0, atol=1e-12 * scale / length)


def test_force_pair_vectorised_matches_reference_per_rod_field():
    rng = np.random.default_rng(3)
    r_i = rng.normal(size=(64, 3)) * 10
    r_j = r_i + rng.normal(size=(64, 3))
    dip = rng.choice([-1, 0, 1], 64) * rng.uniform(1, 30, 64)
    B = rng.normal(size=(64, 3)) * 3e-5
    F = rod_pair_forces(r_i, r_j, dip, B)
    ref = np.array([reference_force(r_i[k], r_j[k], 1.0, dip[k], B[k]) for k in range(64)])
    np.testing.assert_allclose(F, ref, rtol=0, atol=1e-13 * np.abs(F).max())


def test_printed_paper_form_has_the_factor_and_sign_defects():
    """Printed Eq. 4: the pair gives −m × B and an axial component; the corrected form does not."""
    r_i, r_j = np.array([0.0, 0.0, 0.0]), np.array([2.0, 0.5, -0.3])
    B, m = np.array([1e-5, -2e-5, 3e-5]), 7.0
    F_i = paper_printed_force_i(r_i, r_j, m, B)
    r_ji = r_i - r_j
    m_vec = m * (r_j - r_i) / np.linalg.norm(r_j - r_i)
    np.testing.assert_allclose(np.cross(r_ji, F_i), -np.cross(m_vec, B), rtol=1e-12)
    assert abs(F_i @ r_ji) > 1e-3 * np.linalg.norm(F_i) * np.linalg.norm(r_ji)
    F_j = rod_pair_forces(r_i[None], r_j[None], np.array([m]), B)[0]
    np.testing.assert_allclose(np.cross(r_j - r_i, F_j), np.cross(m_vec, B), rtol=1e-12)


# ----------------------------------------------------------------------------- rod array


def test_rod_array_of_the_20x20_lattice():
    lat = make_lattice(units=19, side_m=75.0)
    rods = rod_array(lat)
    assert rods.n_per_family == (380, 380) and rods.n_rods == 760
    assert rods.region == (-37.5, -37.5, 37.5, 37.5)
    p = lat.nodes[rods.ends]
    d = p[:, 1] - p[:, 0]
    a = 75.0 / 19
    np.testing.assert_allclose(d[:380], np.tile([a, 0, 0], (380, 1)), atol=1e-12)
    np.testing.assert_allclose(d[380:], np.tile([0, a, 0], (380, 1)), atol=1e-12)
    assert np.all(lat.ijk[rods.ends][..., 2] == 1)  # top layer
    assert len(set(rods.struts.tolist())) == 760
    # Family 1 sites: a 19 × 20 grid of strut midpoints; family 2: 20 × 19.
    s1, s2 = rods.family_sites(0), rods.family_sites(1)
    assert len(np.unique(s1[:, 0])) == 19 and len(np.unique(s1[:, 1])) == 20
    assert len(np.unique(s2[:, 0])) == 20 and len(np.unique(s2[:, 1])) == 19
    np.testing.assert_allclose(np.sort(s2[:, ::-1], axis=0), np.sort(s1, axis=0))


def test_rod_dipole_basis_o4():
    per = rod_dipole_Am2(kappa_Am2_kg=100.0, rod_mass_kg=100.0, rods_per_family=(380, 380))
    tot = rod_dipole_Am2(kappa_Am2_kg=100.0, rod_mass_kg=100.0, rods_per_family=(380, 380), basis="total")
    assert per == pytest.approx((10_000 / 380, 10_000 / 380), rel=1e-15)
    assert tot == pytest.approx((10_000 / 760, 10_000 / 760), rel=1e-15)
    # Robb et al. 2022a, Sec. 4.2 rod dipoles (10 000 A m² per family / in total)
    assert round(per[0], 2) == 26.32 and round(tot[0], 2) == 13.16
    with pytest.raises(ValueError, match="basis"):
        rod_dipole_Am2(kappa_Am2_kg=1, rod_mass_kg=1, rods_per_family=(1, 1), basis="both")
    with pytest.raises(ValueError, match="kappa_Am2_kg"):
        rod_dipole_Am2(kappa_Am2_kg=-1, rod_mass_kg=1, rods_per_family=(1, 1))


# ----------------------------------------------------------------------------- the load


def _state(pos_nodes, polarity=None, *, env=None):
    pos = np.vstack([np.zeros(3), pos_nodes])
    ctrl = None if polarity is None else SimpleNamespace(polarity=polarity)
    return StepState(
        t=0.0,
        pos=pos,
        vel=np.zeros_like(pos),
        xquat=np.tile([1.0, 0, 0, 0], (len(pos), 1)),
        omega=np.zeros_like(pos),
        env=env,
        ctrl=ctrl,
    )


def _plain_reference_xfrc(load, pos, polarity, B):
    """Loop over rods, one pair at a time (the slow reference of ``add``)."""
    out = np.zeros((pos.shape[0], 6))
    for r in range(load.n_rods):
        if polarity[r] == 0:
            continue
        i, j = load.rods.ends[r] + 1
        F = reference_force(pos[i], pos[j], polarity[r], load.m_of_rod[r], B)
        out[j, :3] += F
        out[i, :3] -= F
    return out


@pytest.fixture(scope="module")
def lat75():
    return make_lattice(units=19, side_m=75.0)


@pytest.mark.parametrize("deform", [0.0, 0.05])
def test_load_total_torque_equals_sum_m_cross_B(lat75, deform):
    """Σ over nodes of x × F = Σ_r m_r × B (= torque_world); zero net force; matches the loop."""
    rng = np.random.default_rng(7)
    load = MagnetorquerRodLoad.from_basis(lat75, kappa_Am2_kg=100.0, rod_mass_kg=100.0, B_eci=[2.1e-5, -1.3e-5, 3.4e-5])
    assert isinstance(load, Load)
    a = lat75.cube_edge_m
    nodes = lat75.nodes + deform * a * rng.normal(size=lat75.nodes.shape)
    pol = rng.integers(-1, 2, load.n_rods).astype(np.int8)
    st_ = _state(nodes, pol)
    xfrc = np.zeros((lat75.n_nodes + 1, 6))
    load.add(st_, xfrc)
    B = load.B_fixed
    total = np.cross(st_.pos, xfrc[:, :3]).sum(axis=0)
    m_sum = load.dipoles_world(st_.pos, pol)
    expect = np.cross(m_sum, B).sum(axis=0)
    scale = np.abs(pol).sum() * load.m_rod_Am2[0] * np.linalg.norm(B)
    np.testing.assert_allclose(total, expect, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(load.torque_world(st_), expect, rtol=0, atol=1e-13 * scale)
    assert np.abs(xfrc[:, :3].sum(axis=0)).max() <= 1e-14 * scale / a
    assert np.all(xfrc[:, 3:] == 0)
    ref = _plain_reference_xfrc(load, st_.pos, pol, B)
    np.testing.assert_allclose(xfrc, ref, rtol=0, atol=1e-13 * scale / a)
    if deform == 0.0:
        # Undeformed: the dipoles are exactly ±m x̂1 and ±m ŷ1.
        n1 = load.rods.n_per_family[0]
        m_body = load.m_rod_Am2[0] * np.array([pol[:n1].sum(), pol[n1:].sum(), 0.0])
        np.testing.assert_allclose(load.torque_world(st_), np.cross(m_body, B), rtol=1e-12)


def test_load_reads_field_from_environment_and_accumulates():
    lat = make_lattice(units=3, side_m=12.0)
    env = SimpleNamespace(B_eci=np.array([1e-5, 2e-5, -3e-5]))
    fixed = MagnetorquerRodLoad(lat, m_rod_Am2=(2.0, 5.0), B_eci=env.B_eci)
    live = MagnetorquerRodLoad(lat, m_rod_Am2=(2.0, 5.0))
    assert live.rods.n_per_family == (12, 12)
    pol = np.ones(24, dtype=np.int8)
    pol[::3] = -1
    pol[1::5] = 0
    st_ = _state(lat.nodes, pol, env=env)
    x1 = np.full((lat.n_nodes + 1, 6), 0.25)
    x2 = np.full((lat.n_nodes + 1, 6), 0.25)
    fixed.add(st_, x1)
    live.add(st_, x2)
    np.testing.assert_array_equal(x1, x2)
    assert np.any(x1[:, :3] != 0.25)
    np.testing.assert_allclose(
        live.total_dipole_world(st_.pos, pol)[:2], [2.0 * pol[:12].sum(), 5.0 * pol[12:].sum()], rtol=1e-12
    )
    act = live.activity(lat.n_struts)
    assert act.shape == (lat.n_struts,)
    np.testing.assert_array_equal(act[live.rods.struts], pol)
    assert np.count_nonzero(act) == np.count_nonzero(pol)


def test_load_off_and_bad_inputs():
    lat = make_lattice(units=2, side_m=4.0)
    load = MagnetorquerRodLoad(lat, m_rod_Am2=1.0, B_eci=[0, 0, 1e-5])
    x = np.zeros((lat.n_nodes + 1, 6))
    load.add(_state(lat.nodes, None), x)  # no command: all rods off
    load.add(_state(lat.nodes, np.zeros(load.n_rods, np.int8)), x)
    assert np.all(x == 0)
    with pytest.raises(ValueError, match="polarity"):
        load.add(_state(lat.nodes, np.zeros(load.n_rods + 1, np.int8)), x)
    with pytest.raises(ValueError, match="polarity"):
        load.add(_state(lat.nodes, np.full(load.n_rods, 2, np.int8)), x)
    with pytest.raises(ValueError, match="polarity"):
        load.add(_state(lat.nodes, np.zeros(load.n_rods)), x)  # floats are not polarities
    with pytest.raises(ValueError, match="state.ctrl"):
        load.add(StepState(0.0, np.vstack([[0, 0, 0], lat.nodes]), None, None, None, ctrl=object()), x)
    live = MagnetorquerRodLoad(lat, m_rod_Am2=1.0)
    with pytest.raises(ValueError, match="state.env"):
        live.add(_state(lat.nodes, np.ones(live.n_rods, np.int8)), x)
    with pytest.raises(ValueError, match="m_rod_Am2"):
        MagnetorquerRodLoad(lat, m_rod_Am2=(1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match="B_eci"):
        MagnetorquerRodLoad(lat, m_rod_Am2=1.0, B_eci=[1.0, 2.0])


def test_held_command_is_reused_and_changes_are_seen():
    """Between control samples the same command is held: its dipoles are reused; a new command,
    or the same polarity array changed in place, gives the forces of the new polarities."""
    lat = make_lattice(units=3, side_m=6.0)
    B = np.array([1e-5, -2e-5, 3e-5])
    load = MagnetorquerRodLoad(lat, m_rod_Am2=2.0, B_eci=B)
    rng = np.random.default_rng(5)
    pos = lat.nodes + rng.normal(scale=0.05, size=lat.nodes.shape)
    pol = rng.integers(-1, 2, size=load.n_rods).astype(np.int8)
    st_ = _state(pos, pol)
    for _ in range(2):  # second call: the held dipoles
        x = np.zeros((lat.n_nodes + 1, 6))
        load.add(st_, x)
        np.testing.assert_allclose(x, _plain_reference_xfrc(load, st_.pos, pol, B), rtol=1e-12, atol=1e-20)
    pol[:] = -pol  # same array, new values
    x = np.zeros((lat.n_nodes + 1, 6))
    load.add(st_, x)
    np.testing.assert_allclose(x, _plain_reference_xfrc(load, st_.pos, pol, B), rtol=1e-12, atol=1e-20)
    pol2 = np.zeros_like(pol)  # a new command with every rod off
    x = np.zeros((lat.n_nodes + 1, 6))
    load.add(_state(pos, pol2), x)
    assert np.all(x == 0) and not load.last_polarity.any()
