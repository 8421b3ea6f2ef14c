"""Lorentz node forces of Robb et al. 2022b, Eq. 16.

Tolerances. For a closed circuit the net force and the torque defect Σ r_i × F_i − m × B vanish
identically; in floating point they are sums of up to a few thousand terms of size |I| |B| w
and |I| |B| w |r|. Net force: ≤ 1e-14 |I| |B| l (l = wire length). Torque: ≤ 1e-13 |m| |B|
(nodes move by at most 0.2 w, so |m| stays near its nominal value). Over 400 random cases of this
test's distribution the worst values were 3e-16 and 2e-15 respectively.
Vectorised against the plain loop: 1e-12 of the largest node force. Sign reversal: exact.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from magsail_mj.geometry.current_loops import CIRCUIT_NAMES, circuits
from magsail_mj.lattice.geometry import make_lattice
from magsail_mj.loads.base import Load, StepState
from magsail_mj.concepts.current_loops.lorentz import (
    MU0,
    CircuitSegments,
    LorentzLoad,
    lorentz_node_forces,
    lorentz_wrench,
    self_field_max_T,
    total_dipole,
    vector_areas,
)

NAME_SETS = [["A"], ["B"], ["C_x"], ["C_y"], ["D_x"], ["D_y"], ["F"], ["C_x", "C_y", "B"]]


def _deformed(lat, rng, amp):
    """Lattice nodes moved by uniform noise of ±amp·w, then rotated and shifted rigidly."""
    w = lat.cube_edge_m
    pos = lat.nodes + amp * w * rng.uniform(-1, 1, lat.nodes.shape)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    R = q * np.sign(np.linalg.det(q))
    return pos @ R.T + rng.uniform(-0.5, 0.5, 3) * lat.side_m


def reference_forces(pos, segs, currents_A, B):
    """Plain per-segment loop of Eq. 16 (the reference for the vectorised code)."""
    F = np.zeros((pos.shape[0], 3))
    for a, b, s, k in zip(segs.src, segs.dst, segs.mult, segs.circuit_id):
        f = 0.5 * s * currents_A[k] * np.cross(pos[b] - pos[a], B)
        F[a] += f
        F[b] += f
    return F


@settings(max_examples=60, deadline=None)
@given(
    units=st.integers(1, 7),
    names=st.sampled_from(NAME_SETS),
    seed=st.integers(0, 2**32 - 1),
    amp=st.floats(0.0, 0.2),
    side=st.floats(0.5, 300.0),
    I_scale=st.floats(1e-3, 1e3),
    B_exp=st.floats(-9.0, -3.0),
)
def test_closed_circuits_zero_force_and_dipole_torque(units, names, seed, amp, side, I_scale, B_exp):
    """Each circuit alone: Σ F = 0 and Σ r_i × F_i = m × B, m = I a(pos), on deformed positions."""
    rng = np.random.default_rng(seed)
    lat = make_lattice(units=units, side_m=side)
    segs = CircuitSegments(circuits(lat, names))
    pos = _deformed(lat, rng, amp)
    B = 10.0**B_exp * rng.normal(size=3)
    currents = I_scale * rng.uniform(-1, 1, segs.n_circuits)
    a = vector_areas(pos, segs)
    for k, c in enumerate(segs.circuits):
        I = np.zeros(segs.n_circuits)
        I[k] = currents[k]
        F = lorentz_node_forces(pos, segs, I, B)
        m = I[k] * a[k]
        np.testing.assert_allclose(m, I[k] * c.vector_area(pos), rtol=1e-13, atol=1e-15 * np.abs(m).max())
        scale_m = np.linalg.norm(m) * np.linalg.norm(B)
        l = c.length(pos)
        assert np.abs(F.sum(axis=0)).max() <= 1e-14 * abs(I[k]) * np.linalg.norm(B) * l
        tau = np.cross(pos, F).sum(axis=0)
        np.testing.assert_allclose(tau, np.cross(m, B), rtol=0, atol=1e-13 * scale_m)
    # all circuits together: the same for the total dipole, about any point
    about = rng.normal(size=3) * side
    force, torque = lorentz_wrench(pos, segs, currents, B, about)
    m = total_dipole(pos, segs, currents)
    np.testing.assert_allclose(
        m, (currents[:, None] * a).sum(axis=0), rtol=0, atol=1e-13 * np.abs(currents[:, None] * a).sum()
    )
    scale = np.abs(currents[:, None] * a).sum() * np.linalg.norm(B)
    np.testing.assert_allclose(torque, np.cross(m, B), rtol=0, atol=1e-13 * scale)


@settings(max_examples=25, deadline=None)
@given(units=st.integers(1, 6), names=st.sampled_from(NAME_SETS), seed=st.integers(0, 2**32 - 1))
def test_vectorised_matches_plain_loop(units, names, seed):
    rng = np.random.default_rng(seed)
    lat = make_lattice(units=units, side_m=20.0)
    segs = CircuitSegments(circuits(lat, names))
    pos = _deformed(lat, rng, 0.2)
    I = rng.uniform(-50, 50, segs.n_circuits)
    B = rng.normal(size=3) * 3e-5
    F = lorentz_node_forces(pos, segs, I, B)
    F_ref = reference_forces(pos, segs, I, B)
    np.testing.assert_allclose(F, F_ref, rtol=0, atol=1e-12 * np.abs(F_ref).max())


def test_negative_current_reverses_every_force():
    lat = make_lattice(units=6, side_m=30.0)
    segs = CircuitSegments(circuits(lat, ["F", "A"]))
    rng = np.random.default_rng(1)
    pos = _deformed(lat, rng, 0.15)
    I = np.array([2.0, -3.0, 5.0, 7.0])
    B = np.array([1e-5, -2e-5, 3e-5])
    F = lorentz_node_forces(pos, segs, I, B)
    assert np.array_equal(lorentz_node_forces(pos, segs, -I, B), -F)
    assert np.abs(F).max() > 0


def test_single_loop_known_forces():
    """Loop A in B = B_z ẑ, I > 0: corner nodes feel ½ I w B (√2 outward), edge nodes I w B outward."""
    lat = make_lattice(units=4, side_m=8.0)
    segs = CircuitSegments(circuits(lat, ["A"]))
    I, Bz, w = 3.0, 2e-5, 2.0
    F = lorentz_node_forces(lat.nodes, segs, [I], [0, 0, Bz])
    # (dl × B) for CCW current in +z field points outward: dl=+x at y=−D/2 → dl × ẑ = −ŷ (outward)
    N = 5
    k_mid = N * N + 0 * N + 2  # node (2, 0, top): middle of the y = −D/2 side
    np.testing.assert_allclose(F[k_mid], [0, -I * w * Bz, 0], rtol=1e-14, atol=0)
    k_corner = N * N  # node (0, 0, top)
    np.testing.assert_allclose(F[k_corner], [-0.5 * I * w * Bz, -0.5 * I * w * Bz, 0], rtol=1e-14)
    assert np.all(F[: N * N] == 0)


def _state(n_nodes, pos_nodes, *, ctrl=None, env=None, t=0.0):
    nb = n_nodes + 2  # world + nodes + one extra body after them
    pos = np.zeros((nb, 3))
    pos[1 : n_nodes + 1] = pos_nodes
    pos[-1] = [1e3, 0, 0]
    z = np.zeros((nb, 3))
    return StepState(t=t, pos=pos, vel=z, xquat=np.tile([1.0, 0, 0, 0], (nb, 1)), omega=z, env=env, ctrl=ctrl)


def test_load_writes_only_node_force_rows():
    lat = make_lattice(units=3, side_m=12.0)
    cs = circuits(lat, ["C_x", "C_y", "B"])
    load = LorentzLoad(cs, n_nodes=lat.n_nodes, currents_A=[1.0, -2.0, 0.5], B_world=[0, 2e-5, 1e-5])
    assert isinstance(load, Load) and load.name == "lorentz"
    rng = np.random.default_rng(5)
    pos = _deformed(lat, rng, 0.1)
    st_ = _state(lat.n_nodes, pos)
    x0 = rng.normal(size=(lat.n_nodes + 2, 6))
    x = x0.copy()
    load.add(st_, x)
    F = lorentz_node_forces(pos, load.segs, [1.0, -2.0, 0.5], [0, 2e-5, 1e-5])
    assert np.array_equal(x[0], x0[0]) and np.array_equal(x[-1], x0[-1])
    assert np.array_equal(x[:, 3:], x0[:, 3:])
    np.testing.assert_allclose(x[1:-1, :3] - x0[1:-1, :3], F, rtol=0, atol=1e-15)
    assert np.array_equal(load.last_forces, F)
    m = total_dipole(pos, load.segs, [1.0, -2.0, 0.5])
    cm = pos.mean(axis=0)
    np.testing.assert_allclose(
        load.torque_about(pos, cm), np.cross(m, [0, 2e-5, 1e-5]), rtol=0, atol=1e-12 * np.linalg.norm(m) * 2.3e-5
    )


def test_load_currents_from_controller_and_field_from_env():
    lat = make_lattice(units=3, side_m=12.0)
    load = LorentzLoad(circuits(lat, ["C_x", "C_y", "B"]), n_nodes=lat.n_nodes, currents_A=[1.0, 1.0, 1.0])
    env = SimpleNamespace(B_eci=np.array([3e-5, 0.0, 0.0]))
    ctrl = SimpleNamespace(currents_A=np.array([0.0, 0.0, 4.0]))
    x = np.zeros((lat.n_nodes + 2, 6))
    load.add(_state(lat.n_nodes, lat.nodes, ctrl=ctrl, env=env), x)
    np.testing.assert_array_equal(load.last_currents_A, [0, 0, 4.0])
    np.testing.assert_array_equal(load.last_B, [3e-5, 0, 0])
    F = lorentz_node_forces(lat.nodes, load.segs, [0, 0, 4.0], [3e-5, 0, 0])
    np.testing.assert_array_equal(x[1:-1, :3], F)
    # a command without currents_A falls back to the fixed currents
    x[:] = 0
    load.add(_state(lat.n_nodes, lat.nodes, ctrl=SimpleNamespace(dipole=1), env=env), x)
    np.testing.assert_array_equal(load.last_currents_A, [1.0, 1.0, 1.0])
    # nothing to take currents or field from
    bare = LorentzLoad(circuits(lat, ["A"]), n_nodes=lat.n_nodes)
    with pytest.raises(ValueError, match="currents"):
        bare.add(_state(lat.n_nodes, lat.nodes, env=env), x)
    with pytest.raises(ValueError, match="field"):
        bare.add(_state(lat.n_nodes, lat.nodes, ctrl=ctrl), x)


def test_argument_errors():
    lat = make_lattice(units=2, side_m=2.0)
    segs = CircuitSegments(circuits(lat, ["A", "B"]))
    with pytest.raises(ValueError, match="currents_A"):
        lorentz_node_forces(lat.nodes, segs, [1.0], [0, 0, 1])
    with pytest.raises(ValueError, match="B"):
        lorentz_node_forces(lat.nodes, segs, [1.0, 1.0], [0, 1])
    with pytest.raises(ValueError, match="pos"):
        lorentz_node_forces(lat.nodes[:3], segs, [1.0, 1.0], [0, 0, 1])
    with pytest.raises(ValueError, match="circuits"):
        CircuitSegments([])
    with pytest.raises(ValueError, match="n_nodes"):
        LorentzLoad(segs, n_nodes=3)
    with pytest.raises(ValueError, match="currents_A"):
        LorentzLoad(segs, currents_A=[1, 2, 3])


def test_segments_stacking():
    lat = make_lattice(units=5, side_m=5.0)
    cs = circuits(lat, ["F"])
    segs = CircuitSegments(cs)
    assert segs.names == ("B", "D_x", "D_y") and list(segs.axes) == [2, 0, 1]
    assert segs.n_circuits == 3 and segs.n_segments == sum(c.n_segments for c in cs)
    assert np.array_equal(np.bincount(segs.circuit_id), [c.n_segments for c in cs])
    np.testing.assert_allclose(vector_areas(lat.nodes, segs), [c.vector_area(lat.nodes) for c in cs], rtol=1e-14)


def test_self_field_diagnostic():
    """Nearest parallel abreast element: w for C_x, C_y and B; D for the single loop A."""
    lat = make_lattice(units=3, side_m=12.0)
    w, D, I = 4.0, 12.0, 7.0
    A = CircuitSegments(circuits(lat, ["A"]))
    assert self_field_max_T(lat.nodes, A, [I]) == pytest.approx(MU0 * I / (2 * np.pi * D), rel=1e-12)
    for names in (["C_x"], ["C_y"], ["B"]):
        s = CircuitSegments(circuits(lat, names))
        assert self_field_max_T(lat.nodes, s, [I]) == pytest.approx(MU0 * I / (2 * np.pi * w), rel=1e-12)
    # C_x and C_y share the corner verticals: wires on one strut are one bundle, not r = 0
    s = CircuitSegments(circuits(lat, ["C_x", "C_y", "B"]))
    val = self_field_max_T(lat.nodes, s, [I, 2 * I, 0.0])
    assert val == pytest.approx(MU0 * 2 * I / (2 * np.pi * w), rel=1e-12)
    assert self_field_max_T(lat.nodes, s, [0.0, 0.0, 0.0]) == 0.0
    # chunking does not change the answer; rigid motion does not either
    rng = np.random.default_rng(2)
    pos = _deformed(lat, rng, 0.1)
    assert self_field_max_T(pos, s, [1, 2, 3], chunk=7) == pytest.approx(self_field_max_T(pos, s, [1, 2, 3]), rel=1e-12)


@pytest.mark.parametrize("name", CIRCUIT_NAMES)
def test_rigid_rotation_of_forces(name):
    """Rotating geometry and field together rotates every node force (frame independence)."""
    lat = make_lattice(units=4, side_m=10.0)
    segs = CircuitSegments(circuits(lat, [name]))
    rng = np.random.default_rng(9)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    R = q * np.sign(np.linalg.det(q))
    B = np.array([1e-5, 2e-5, -1e-5])
    F = lorentz_node_forces(lat.nodes, segs, [3.0], B)
    F_rot = lorentz_node_forces(lat.nodes @ R.T, segs, [3.0], R @ B)
    np.testing.assert_allclose(F_rot, F @ R.T, rtol=0, atol=1e-12 * np.abs(F).max())
