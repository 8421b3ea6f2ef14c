"""Reflector coil paths (Robb et al. 2020, Fig. 1) and their Lorentz torque (Eqs. 1–4): generator properties,
closed-turn and helix sanity checks, torque matrix, capability metric, report keys."""

from __future__ import annotations

import numpy as np
import pytest

from magsail_mj.analysis.coil_torque import (
    capability,
    closed_lead_dipole,
    coil_torque_report,
    net_force,
    path_torque,
    segment_torques,
    torque_matrix,
)
from magsail_mj.geometry.reflector_coil import CoilPath, coil_node_count, coil_x, coil_y, square_loop
from tests.conftest import COIL_REPORT_KEYS


def _members(nodes: np.ndarray) -> list[tuple]:
    a, b = np.round(nodes[:-1], 9), np.round(nodes[1:], 9)
    return [tuple(sorted((tuple(p), tuple(q)))) for p, q in zip(a, b)]


@pytest.mark.parametrize(
    "d,L,p,n_row",
    [
        (10, 1, 2, None),
        (12, 1, 2, None),
        (10, 1, 1, None),
        (10, 1, 2, 11),
        (20, 2, 2, None),
        (9, 1, 3, None),
        (100, 1, 2, None),
    ],
)
def test_coil_segments_axis_aligned_length_L_and_node_count(d, L, p, n_row):
    y = coil_y(d, L, p=p, n_row=n_row)
    n = round(d / L)
    assert y.shape == (coil_node_count(n, p=p, n_row=n_row), 3)
    seg = np.diff(y, axis=0)
    assert np.allclose(np.linalg.norm(seg, axis=1), L, rtol=0, atol=1e-12)
    assert np.all(np.count_nonzero(np.abs(seg) > 1e-12, axis=1) == 1)  # axis-aligned
    # every node is a lattice node inside the structure
    ij = (y[:, :2] + d / 2) / L
    assert np.allclose(ij, np.round(ij)) and ij.min() >= 0 and ij.max() <= n
    assert np.allclose(np.abs(y[:, 2]), L / 2)
    assert np.allclose(y[0], [-d / 2, -d / 2, -L / 2])


def test_baseline_traverses_no_member_twice_and_p1_shares_verticals():
    base = _members(coil_y(20, 1))
    assert len(base) == len(set(base))
    dense = _members(coil_y(20, 1, p=1))
    assert len(dense) > len(set(dense))
    seen, dup = set(), []
    for m in dense:
        if m in seen:
            dup.append(m)
        seen.add(m)
    assert all(abs(a[2] - b[2]) > 0 for a, b in dup)  # only vertical members are shared


def test_three_quarter_turn_pattern_and_connector():
    y = coil_y(6, 1)  # 3 columns of 6 rows
    seg = np.diff(y, axis=0)
    first = seg[:12]
    # sides used cyclically +x, +z, −x | −z, +x, +z | −x, −z, +x | +z, −x, −z, each followed by +y
    expect = [
        (1, 0, 0),
        (0, 0, 1),
        (-1, 0, 0),
        (0, 1, 0),
        (0, 0, -1),
        (1, 0, 0),
        (0, 0, 1),
        (0, 1, 0),
        (-1, 0, 0),
        (0, 0, -1),
        (1, 0, 0),
        (0, 1, 0),
    ]
    assert np.allclose(first, expect)
    # connector: after column 0's last 3/4 turn, two +x segments at constant y and z
    k = 4 * 6 - 1
    assert np.allclose(seg[k : k + 2], [(1, 0, 0), (1, 0, 0)])
    assert np.allclose(y[k + 1 : k + 3, 1], 2.0)  # last row of column 0: y = −3 + 5
    # column 1 runs towards −y
    assert y[k + 2 + 4 * 5, 1] < y[k + 2, 1]


def test_x_coil_is_y_coil_rotated_and_dipole_signs():
    y = coil_y(10, 1)
    x = coil_x(10, 1)
    assert np.allclose(x, np.column_stack([-y[:, 1], y[:, 0], y[:, 2]]))
    # node order: y-coil turns give a −y axial dipole (s_path = −1), the x-coil +x (s_path = +1)
    assert closed_lead_dipole(y, current=1.0)[1] < 0
    assert closed_lead_dipole(x, current=1.0)[0] > 0


def test_single_closed_turn_gives_m_cross_B():
    L, h, I = 1.0, 0.7, 3.0
    X, y0 = 2.0, -1.5  # off-centre: a closed loop's torque is independent of it
    turn = np.array([(X, y0, -h / 2), (X + L, y0, -h / 2), (X + L, y0, h / 2), (X, y0, h / 2), (X, y0, -h / 2)])
    m = closed_lead_dipole(turn, current=I)
    assert np.allclose(m, [0, -I * L * h, 0])
    rng = np.random.default_rng(0)
    for _ in range(5):
        B = rng.normal(size=3) * 3e-5
        assert np.allclose(path_torque(turn, B, current=I), np.cross(m, B), rtol=1e-12, atol=1e-18)


def test_helix_of_N_turns_gives_axial_dipole_N_I_L_h():
    L, h, I, N = 1.0, 1.0, 10.0, 7
    pts = []
    for k in range(N):
        y = float(k) * L
        pts += [(0, y, -h / 2), (L, y, -h / 2), (L, y, h / 2), (0, y, h / 2), (0, y, -h / 2)]
    helix = np.array(pts, dtype=float)
    helix = helix[np.r_[True, np.any(np.diff(helix, axis=0) != 0, axis=1)]]
    B = 30e-6
    T = path_torque(helix, np.array([B, 0, 0]), current=I)
    assert T[2] == pytest.approx(N * I * L * h * B, rel=1e-12)  # ẑ·T = (m × B)_z = +N I L h B for m = −N I L h ŷ


def test_torque_matrix_equals_eq4_and_is_linear():
    y = coil_y(12, 1)
    M = torque_matrix(y)
    rng = np.random.default_rng(1)
    for _ in range(3):
        B = rng.normal(size=3) * 3e-5
        I = float(rng.uniform(-10, 10))
        direct = segment_torques(y, B, current=I).sum(axis=0)
        assert np.allclose(I * M @ B, direct, rtol=1e-12, atol=1e-15)
    assert np.allclose(net_force(y, np.array([0, 0, 1.0]), current=1.0), np.cross(y[-1] - y[0], [0, 0, 1.0]))


def test_capability_metric_counts_the_coil_turns():
    # the z component for B ∥ x comes only from the vertical members: 3/4 of a turn per row,
    # N_row rows per column, N_col columns: T_max = 0.75 N_row N_col I L h B_ref (exact when N_row is a
    # multiple of 4, i.e. whole numbers of the 4-turn corner cycle)
    for d, p, rows in ((100, 2, 100), (100, 1, 100), (40, 2, 40), (40, 2, 36)):
        y = CoilPath("ycoil", coil_y(d, 1.0, p=p, n_row=rows), axis=1, s_path=-1)
        expect = 0.75 * rows * (d // p) * 10.0 * 1.0 * 1.0 * 30e-6
        assert capability(y, current_A=10.0, field_T=30e-6) == pytest.approx(expect, rel=1e-12)
    x = CoilPath("xcoil", coil_x(100, 1.0), axis=0, s_path=1)
    assert capability(x, current_A=10.0, field_T=30e-6) == pytest.approx(1.125, rel=1e-12)


def test_capability_independent_of_reference_point():
    """Baseline path starts and ends at the same height: ẑ·T(B x̂) does not depend on the origin."""
    y = coil_y(20, 1)
    B = np.array([30e-6, 0, 0])
    T0 = path_torque(y, B, current=10.0)
    T1 = path_torque(y + np.array([3.0, -7.0, 0.0]), B, current=10.0)
    assert T1[2] == pytest.approx(T0[2], rel=1e-12)


def test_square_loop_closed_ccw_and_capability():
    loop = square_loop(6.0, 1.0, z=-0.5)
    assert np.allclose(loop[0], loop[-1]) and loop.shape == (25, 3)
    assert np.allclose(np.linalg.norm(np.diff(loop, axis=0), axis=1), 1.0)
    assert np.allclose(closed_lead_dipole(loop, current=2.0), [0, 0, 2.0 * 36.0])
    path = CoilPath("zloop", loop, axis=2, s_path=1)
    assert capability(path, current_A=10.0, field_T=30e-6) == pytest.approx(10 * 36 * 30e-6, rel=1e-12)
    with pytest.raises(ValueError, match="side"):
        square_loop(5.0, 1.0, z=0.0)


def test_coil_torque_report_keys_and_baseline_values():
    r = coil_torque_report(side_m=100, segment_m=1, current_A=10, field_T=30e-6)
    assert set(COIL_REPORT_KEYS) <= set(r)
    assert r["T_max_ycoil_Nm"] == pytest.approx(1.125)
    assert r["T_max_xcoil_Nm"] == pytest.approx(1.125)
    assert r["m_max_Am2"] == pytest.approx(37500.0)
    assert r["zloop_side_m"] == 62.0  # 62² · 10 A · 30 µT = 1.153 N m, closest to 1.125
    assert r["T_max_perimeter_loop_Nm"] == pytest.approx(3.0)
    assert r["T_max_ycoil_p1_Nm"] == pytest.approx(2.25)
    assert r["node_count"] == 20049 and r["segment_count"] == 20048 and r["path_length_m"] == pytest.approx(20048)
    assert r["closed_lead_dipole_y_Am2"] > 0  # positive current gives +y
    y = r["paths"]["ycoil"]
    assert y["T_Bx_Nm"][2] == pytest.approx(-1.125)  # m ∥ +y, B ∥ x: (m × B)_z = −m B
    assert len(y["singular_values_Nm"]) == 3
    with pytest.raises(ValueError, match="side_m"):
        coil_torque_report(side_m=100.5, segment_m=1)
