"""The detumble laws beside the proportional B-dot (:mod:`magsail_mj.control.detumble_laws`) and
their selection by ``control.bdot_law`` in the CNUSAIL flight controller.

Each law is checked against an analytic result or invariant (the torque ``τ = m × B`` takes energy
or momentum out at the instant, the saturated magnitudes, the gain formula, the stated special case,
the optimality of the two-step control), and a batch of worlds running the laws equals each
world's single run bit for bit (``np.array_equal``, no tolerance: the batch evaluates the same
component arithmetic on every world's row).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import magsail_mj
from magsail_mj.concepts.cnusail.model import CnusailModel, bcross_gain_of
from magsail_mj.config import ConfigError, load_config
from magsail_mj.control.detumble_laws import (
    avanzini_giulietti_gain,
    bang_bang_dipole,
    bcross_dipole,
    geomagnetic_inclination_rad,
    nonmonotonic_dipole,
)
from tests.conftest import REPO
from tests.test_batch_equals_single import run_and_compare

PRE = REPO / "magsail_mj/concepts/cnusail/configs/detumble_pre.toml"
M_MAX = np.array([0.2, 0.2, 0.1])


def _samples(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` body rates [rad/s] (up to ~10 °/s) and fields [T] (~50 µT) drawn at random."""
    rng = np.random.default_rng(seed)
    return rng.normal(scale=0.1, size=(n, 3)), rng.normal(scale=3e-5, size=(n, 3))


# ----------------------------------------------------------------------------- bang-bang


def test_bang_bang_is_full_dipole_on_every_axis_with_a_field_rate_and_takes_energy_out():
    omega, B = _samples(500, 1)
    B_dot = -np.cross(omega, B)  # a field fixed in inertial space seen from the turning body
    B_dot[:50, 1] = 0.0  # axes without a rate get no dipole
    m = bang_bang_dipole(B_dot, M_MAX)
    moving = B_dot != 0.0
    assert np.array_equal(np.abs(m)[moving], np.broadcast_to(M_MAX, m.shape)[moving])
    assert np.all(m[~moving] == 0.0) and (~moving).sum() == 50
    # τ·ω = m·(B × ω) = −Σ m_max,i |(ω × B)_i| for the rows with the exact rate (all of it used)
    work = np.einsum("ij,ij->i", np.cross(m, B), omega)[50:]
    expected = -np.sum(M_MAX * np.abs(np.cross(omega, B)), axis=1)[50:]
    assert np.all(work < 0.0)
    np.testing.assert_allclose(work, expected, rtol=1e-12, atol=0.0)  # rounding of two 3-term sums


# ----------------------------------------------------------------------------- B×ω (Avanzini & Giulietti)


def test_avanzini_giulietti_gain_matches_the_hand_computation():
    # a = 7000 km, μ = 3.986004418e14 m³/s²: n = √(μ/a³) = 1.078007e-3 rad/s; ξ_m = 30° (sin = ½);
    # J_min = 0.010 kg m²: k = 2 n (1 + ½) J_min = 3 n J_min = 3.234021e-5 N m s
    n = math.sqrt(3.986004418e14 / 7.0e6**3)
    k = avanzini_giulietti_gain(mean_motion_rad_s=n, xi_m_rad=math.radians(30.0), J_min_kgm2=0.010)
    assert k == pytest.approx(3.234021e-5, rel=1e-6)  # the hand value is rounded to 7 digits
    with pytest.raises(ValueError, match="J_min_kgm2"):
        avanzini_giulietti_gain(mean_motion_rad_s=n, xi_m_rad=0.3, J_min_kgm2=0.0)


def test_magnetic_inclination_of_an_orbit_about_an_aligned_dipole_is_its_inclination():
    for inc_deg, expected in ((0.0, 0.0), (51.6, 51.6), (98.0, 82.0), (180.0, 0.0)):
        i = math.radians(inc_deg)
        r = np.array([7.0e6, 0.0, 0.0])
        v = 7.5e3 * np.array([0.0, math.cos(i), math.sin(i)])
        xi = geomagnetic_inclination_rad(r, v, np.array([0.0, 0.0, -1.0]))
        assert math.degrees(xi) == pytest.approx(expected, abs=1e-9)  # acos rounding near 0°


def test_cnusail_gain_of_an_aligned_dipole_field_is_the_formula_of_its_orbit():
    """detumble_pre's orbit (a = 6963.1 km, i = 98°) in an aligned dipole: ξ_m = 82°, so
    k = 2 √(μ/a³) (1 + sin 82°) × 0.010 kg m² (the stowed J_min)."""
    cfg = load_config(PRE, ["sim.duration_s=10", 'field.model="dipole"', 'control.bdot_law="b_cross"'])
    cs = CnusailModel(cfg)
    n = math.sqrt(cfg.orbit.mu_m3_s2 / 6963.1e3**3)
    hand = 2.0 * n * (1.0 + math.sin(math.radians(82.0))) * 0.010
    assert bcross_gain_of(cfg, cs.environment) == pytest.approx(hand, rel=1e-12)  # float rounding only
    assert cs.make_controller().p.bcross_gain_Nms == pytest.approx(hand, rel=1e-12)
    given = load_config(PRE, ["sim.duration_s=10", 'control.bdot_law="b_cross"', "control.bcross_gain_Nms=2e-4"])
    assert bcross_gain_of(given, cs.environment) == 2e-4


def test_bcross_torque_is_the_rate_across_the_field_and_does_negative_work_when_clipped():
    omega, B = _samples(500, 2)
    k = 4e-5
    m = bcross_dipole(omega, B, k_Nms=k)
    b = B / np.linalg.norm(B, axis=1, keepdims=True)
    tau = np.cross(m, B)
    expected = -k * (omega - np.einsum("ij,ij->i", omega, b)[:, None] * b)
    np.testing.assert_allclose(tau, expected, rtol=1e-9, atol=1e-14 * k)  # products of ~1e-5 T terms
    clipped = np.clip(m, -M_MAX, M_MAX)
    assert (clipped != m).any()  # the clip acts on some rows
    assert np.all(np.einsum("ij,ij->i", np.cross(clipped, B), omega) <= 0.0)
    assert np.array_equal(bcross_dipole(omega[:1], np.zeros((1, 3)), k_Nms=k), np.zeros((1, 3)))


# ----------------------------------------------------------------------------- non-monotonic (Willis et al.)


def test_nonmonotonic_law_without_a_second_step_is_the_saturated_momentum_bcross_law():
    omega, B = _samples(200, 3)
    _, B2 = _samples(200, 4)
    J = np.diag([0.0506, 0.0506, 0.010])
    Js = np.broadcast_to(J, (200, 3, 3))
    k = 3e3
    m = nonmonotonic_dipole(omega, B, B2, Js, gain_per_Nms=k, alpha=0.0, m_max_Am2=M_MAX)
    h = omega @ J.T
    b = B / np.linalg.norm(B, axis=1, keepdims=True)
    np.testing.assert_allclose(m, M_MAX * np.tanh(0.5 * k * np.cross(h, b)), rtol=1e-9, atol=1e-15)  # 6×6 solve
    # every component has the sign of (h × B)_i: the momentum falls at the instant, h·τ ≤ 0
    assert np.all(np.einsum("ij,ij->i", h, np.cross(m, B)) <= 0.0)


def test_nonmonotonic_two_step_control_costs_no_more_than_doing_nothing():
    """The optimum of ½‖ū‖² + ½‖h − [b₁]×u₁‖² + (α/2)‖h − [b₁]×u₁ − [b₂]×u₂‖² is at most its value at
    ū = 0, ½ (1 + α)‖h‖²: on average over the two steps the momentum falls."""
    omega, B = _samples(300, 5)
    _, B2 = _samples(300, 6)
    J = np.broadcast_to(np.diag([0.31, 0.31, 0.58]), (300, 3, 3))
    h = np.einsum("nij,nj->ni", J, omega)
    n1 = np.linalg.norm(B, axis=1, keepdims=True)
    b1, b2 = B / n1, B2 / n1
    for alpha in (0.0, 1.0, 100.0):
        # the unsaturated u₁ from the law: k small keeps tanh(k u) = k u to 1e-12 relative
        k = 1e-6
        u1 = np.arctanh(nonmonotonic_dipole(omega, B, B2, J, gain_per_Nms=k, alpha=alpha, m_max_Am2=np.ones(3))) / k
        # u₂ of the optimum, given u₁: (I + α [b₂]×ᵀ[b₂]×) u₂ = α [b₂]×ᵀ (h − [b₁]× u₁)
        h1 = h - np.cross(b1, u1)
        A2 = np.stack([np.cross(b2, e) for e in np.eye(3)], axis=2)  # [b₂]× per row
        lhs = np.eye(3) + alpha * np.einsum("nki,nkj->nij", A2, A2)
        u2 = np.linalg.solve(lhs, alpha * np.einsum("nki,nk->ni", A2, h1)[:, :, None])[:, :, 0]
        h2 = h1 - np.cross(b2, u2)
        cost = 0.5 * (np.sum(u1**2 + u2**2, 1) + np.sum(h1**2, 1) + alpha * np.sum(h2**2, 1))
        assert np.all(cost <= 0.5 * (1.0 + alpha) * np.sum(h**2, 1))
        assert np.all(np.sum(h2**2, 1) < np.sum(h**2, 1))  # and it ends below the start


# ----------------------------------------------------------------------------- config and the batch


def test_unknown_law_is_refused_naming_the_key_and_value():
    with pytest.raises(ConfigError, match=r"control\.bdot_law.*'cubic'"):
        load_config(PRE, ['control.bdot_law="cubic"'])
    with pytest.raises(ConfigError, match=r"control\.nonmonotonic_alpha"):
        load_config(PRE, ["control.nonmonotonic_alpha=1e7"])


def test_laws_change_the_commands():
    dipoles = {}
    for law in ("proportional", "bang_bang", "b_cross", "non_monotonic"):
        r = magsail_mj.load(str(PRE), ["sim.duration_s=6", f'control.bdot_law="{law}"']).run()
        dipoles[law] = np.asarray(r.records["dipole_cmd_Am2"])[2]
    assert np.array_equal(np.abs(dipoles["bang_bang"]), M_MAX)
    assert len({d.tobytes() for d in dipoles.values()}) == 4


def test_worlds_of_every_law_equal_their_single_runs():
    worlds = [
        ['control.bdot_law="bang_bang"'],
        ['control.bdot_law="bang_bang"', 'control.bdot_form="filtered"', "initial.omega0_deg_s=[2.0, 9.0, -4.0]"],
        ['control.bdot_law="b_cross"'],
        ['control.bdot_law="b_cross"', "control.bcross_gain_Nms=2e-4", 'orbit.epoch="2016-06-01T12:00:00Z"'],
        ['control.bdot_law="non_monotonic"', "initial.omega0_deg_s=[-3.0, 1.0, 8.0]"],
        ['control.bdot_law="non_monotonic"', "control.nonmonotonic_alpha=0.0", 'actuators.mtq.limits="half_watt"'],
        [],
    ]
    _, result = run_and_compare(str(PRE), ["sim.duration_s=30"], worlds, nthread=2)
    assert result.status == ["completed"] * len(worlds)


def test_nonmonotonic_worlds_reading_inside_the_table_equal_their_single_runs():
    """A 5 s look-ahead stays inside the field table (the 600 s default of a 30 s run reads its end)."""
    shared = ["sim.duration_s=30", 'control.bdot_law="non_monotonic"', "control.nonmonotonic_lookahead_s=5.0"]
    worlds = [[], ["control.nonmonotonic_gain_per_Nms=50.0", "spacecraft.inertia_kgm2=[0.07, 0.06, 0.015]"]]
    run_and_compare(str(PRE), shared, worlds)
    with pytest.raises(ValueError, match=r"control\.nonmonotonic_lookahead_s"):
        magsail_mj.load(str(PRE), shared, world_overrides=[[], ["control.nonmonotonic_lookahead_s=6.0"]])
