"""MSAC four-phase cycle generator (Vedant & Allison 2019): vectorised vs plain reference,
continuity of position and velocity, waypoints, derivatives, argument errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from magsail_mj.concepts.msac.cycle import CyclePath, blend, cycle_state, cycle_state_scalar

BLENDS = ("min_jerk", "cubic", "cosine")
PATTERNS = ("msac", "reversed", "bend_only", "extend_only")


def path(**kw) -> CyclePath:
    base = dict(
        phi_a_rad=math.radians(10),
        phi_b_rad=math.radians(-10),
        s_e_m=0.08,
        s_c_m=0.0,
        period_s=1e-3,
        fractions=(0.4, 0.1, 0.4, 0.1),
    )
    base.update(kw)
    return CyclePath(**base)


@pytest.mark.parametrize("bl", BLENDS)
@pytest.mark.parametrize("pattern", PATTERNS)
def test_vectorised_matches_plain_reference(bl, pattern):
    p = path(blend=bl, pattern=pattern, fractions=(0.35, 0.15, 0.3, 0.2))
    t = np.random.default_rng(1).uniform(0, 5e-3, 400)
    st = cycle_state(p, t)
    ref = np.array([cycle_state_scalar(p, float(x)) for x in t])
    got = np.stack([st.phi, st.phi_dot, st.phi_ddot, st.s, st.s_dot, st.s_ddot, st.phase], axis=1)
    # same arithmetic in a different order: relative 1e-12 of each column's scale
    scale = np.abs(ref).max(axis=0) + 1e-300
    assert np.all(np.abs(got - ref) <= 1e-12 * scale)


@pytest.mark.parametrize("bl", BLENDS)
def test_position_and_velocity_continuous_at_phase_and_cycle_boundaries(bl):
    p = path(blend=bl)
    bounds = np.concatenate([p.phase_bounds_s[1:], p.period_s + p.phase_bounds_s[1:2]])
    eps = 1e-12 * p.period_s
    lo, hi = cycle_state(p, bounds - eps), cycle_state(p, bounds + eps)
    # a jump would be O(stroke) or O(stroke/T); across 2 eps a smooth signal changes O(v eps)
    vmax = max(np.abs(cycle_state(p, np.linspace(0, p.period_s, 4001)).phi_dot).max(), 1.0)
    assert np.allclose(lo.phi, hi.phi, atol=1e-9) and np.allclose(lo.s, hi.s, atol=1e-9)
    assert np.allclose(lo.phi_dot, hi.phi_dot, atol=1e-6 * vmax)
    assert np.allclose(lo.s_dot, hi.s_dot, atol=1e-6 * vmax)
    if bl == "min_jerk":  # the quintic is also acceleration-continuous (zero at phase ends)
        amax = np.abs(cycle_state(p, np.linspace(0, p.period_s, 4001)).phi_ddot).max()
        assert np.allclose(lo.phi_ddot, hi.phi_ddot, atol=1e-6 * amax)


def test_waypoints_reached_and_velocity_zero_at_phase_ends():
    p = path()
    st = cycle_state(p, p.phase_bounds_s[:-1])
    wp = p.waypoints[:-1]
    assert np.allclose(st.phi, wp[:, 0], atol=1e-15) and np.allclose(st.s, wp[:, 1], atol=1e-15)
    assert np.allclose(st.phi_dot, 0, atol=1e-9) and np.allclose(st.s_dot, 0, atol=1e-9)
    # Phase I is (phi_a, s_e); the msac loop: bend extended, contract, bend back, extend
    assert p.initial == (math.radians(10), 0.08)
    assert np.allclose(
        wp, [[math.radians(10), 0.08], [math.radians(-10), 0.08], [math.radians(-10), 0.0], [math.radians(10), 0.0]]
    )


@pytest.mark.parametrize("bl", BLENDS)
def test_derivatives_match_finite_differences(bl):
    p = path(blend=bl)
    t = np.linspace(1e-6, 2e-3 - 1e-6, 777)
    h = 1e-9
    a, b = cycle_state(p, t - h), cycle_state(p, t + h)
    st = cycle_state(p, t)
    inside = np.isclose(cycle_state(p, t - h).phase, cycle_state(p, t + h).phase)
    # central difference error O(h² q''') ~ 1e-18·1e12 ≪ 1e-6 of the rate scale
    for q, qd in (("phi", "phi_dot"), ("s", "s_dot"), ("phi_dot", "phi_ddot"), ("s_dot", "s_ddot")):
        fd = (getattr(b, q) - getattr(a, q)) / (2 * h)
        scale = np.abs(getattr(st, qd)).max() + 1e-300
        assert np.all(np.abs(fd - getattr(st, qd))[inside] <= 1e-5 * scale), (q, bl)


def test_blend_endpoints():
    for bl in BLENDS:
        S, dS, _ = blend(np.array([0.0, 1.0]), bl)
        assert np.allclose(S, [0, 1]) and np.allclose(dS, [0, 0], atol=1e-15)


def test_periodic_in_time():
    p = path()
    t = np.linspace(0, 1e-3, 50, endpoint=False)
    a, b = cycle_state(p, t), cycle_state(p, t + 7e-3)
    assert np.allclose(a.phi, b.phi, atol=1e-12) and np.allclose(a.s, b.s, atol=1e-14)
    assert np.all(b.cycle == 7)


@pytest.mark.parametrize(
    "kw, word",
    [
        (dict(fractions=(0.5, 0.1, 0.4, 0.1)), "fractions"),
        (dict(fractions=(0.5, 0.0, 0.4, 0.1)), "fractions"),
        (dict(period_s=0.0), "period_s"),
        (dict(phi_a_rad=float("nan")), "phi_a_rad"),
        (dict(blend="linear"), "kind"),
        (dict(pattern="circle"), "pattern"),
    ],
)
def test_bad_arguments_are_named(kw, word):
    with pytest.raises(ValueError, match=word):
        path(**kw)


def test_negative_time_rejected():
    with pytest.raises(ValueError, match="t:"):
        cycle_state(path(), np.array([-1.0]))
