"""Torque profiles of Robb et al. 2022a (Table 1; Eq. 9 with t_v in place of the misprinted t)
and the rigid-body reference."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from magsail_mj.control.profiles import bang_bang_off, torque_profile, versine
from magsail_mj.concepts.truss_magnetorquer.metrics import rigid_response

T_END, TAU = 1800.0, 0.1
T_V, T_MINUS, T_ZERO = T_END / 10, T_END / 3, 2 * T_END / 3


@pytest.mark.parametrize("t_b", [T_V, T_MINUS - T_V, T_MINUS + T_V, T_ZERO - T_V, T_ZERO])
def test_versine_continuous_at_breakpoints(t_b):
    eps = 1e-9
    left, right = versine([t_b - eps, t_b + eps], tau_max=TAU, t_end=T_END)
    # The profile has zero slope at every breakpoint, so the jump over 2 eps is O(eps^2) ≪ 1e-12.
    assert abs(left - right) < 1e-12


def test_versine_runs_plus_one_through_zero_to_minus_one():
    v = versine([T_MINUS - T_V, T_MINUS, T_MINUS + T_V], tau_max=1.0, t_end=T_END)
    np.testing.assert_allclose(v, [1.0, 0.0, -1.0], atol=1e-15)


def test_versine_equals_bang_bang_on_plateaus():
    t = np.concatenate(
        [
            np.linspace(T_V + 1, T_MINUS - T_V, 50),
            np.linspace(T_MINUS + T_V + 1, T_ZERO - T_V, 50),
            np.linspace(T_ZERO + 1, T_END, 20),
        ]
    )
    np.testing.assert_array_equal(versine(t, tau_max=TAU, t_end=T_END), bang_bang_off(t, tau_max=TAU, t_end=T_END))


@pytest.mark.parametrize("kind", ["bang_bang_off", "versine"])
def test_zero_net_impulse(kind):
    f = lambda t: float(torque_profile(kind, t, tau_max=TAU, t_end=T_END))  # noqa: E731
    pts = [T_V, T_MINUS - T_V, T_MINUS, T_MINUS + T_V, T_ZERO - T_V, T_ZERO]
    impulse, _ = quad(f, 0, T_END, points=pts, limit=200)
    positive, _ = quad(f, 0, T_MINUS, points=pts[:3], limit=200)
    assert abs(impulse) < 1e-9 * positive


def test_bang_bang_values():
    np.testing.assert_array_equal(
        bang_bang_off([0, 600, 600.1, 1200, 1200.1], tau_max=TAU, t_end=T_END), [TAU, TAU, -TAU, -TAU, 0.0]
    )


def test_rigid_response_bang_bang_closed_form():
    inertia = 6.0e4
    t = np.array([300.0, 600.0, 1200.0, 1800.0])
    phi, w = rigid_response("bang_bang_off", t, tau_max=TAU, t_end=T_END, t_v=None, inertia=inertia)
    a = TAU / inertia
    expected_phi = [0.5 * a * 300**2, 0.5 * a * 600**2, a * 600**2, a * 600**2]
    np.testing.assert_allclose(phi, expected_phi, rtol=1e-4)  # trapezoid on a 0.01 s grid
    np.testing.assert_allclose(w, [a * 300, a * 600, 0.0, 0.0], atol=a * 0.02)


def test_bad_ramp_time_is_named():
    with pytest.raises(ValueError, match="t_v"):
        versine(1.0, tau_max=TAU, t_end=T_END, t_v=T_END)
