"""Torque profiles of Robb et al. 2022a (Table 1; Eq. 9 with t_v in place of the misprinted t, and
Eq. 9 exactly as printed) and the rigid-body reference."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

import tomllib
from pydantic import ValidationError

from magsail_mj.config import load_config
from magsail_mj.control.profiles import bang_bang_off, torque_profile, versine, versine_printed
from magsail_mj.concepts.truss_magnetorquer.config import ProfileConfig
from magsail_mj.concepts.truss_magnetorquer.metrics import commanded_impulse_Nms, rigid_response
from tests.conftest import REPO

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


# --- Eq. 9 exactly as printed: cos(π/2 · (t₋ − t_v − t)/t) on (t₋ − t_v, t₋ + t_v] -------------------------

WINDOW = (T_MINUS - T_V, T_MINUS + T_V)
PRINTED_CONFIG = (
    "magsail_mj/concepts/truss_magnetorquer/configs/paper_literal/case_a_central_versine_long_eq9_printed.toml"  # noqa: E501
)
CORRECTED_CONFIG = "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_a_central_versine_long.toml"


def _printed_line(t: float) -> float:
    """The printed third line of Eq. 9 divided by τ_max, written out here independently."""
    return float(np.cos(0.5 * np.pi * (T_MINUS - T_V - t) / t))


def _printed_net_impulse() -> float:
    """τ_max ∫ over the window of the printed line: the rest of the profile is the corrected one,
    whose net impulse is zero, and the corrected third line integrates to zero over the window."""
    value, _ = quad(_printed_line, *WINDOW, epsabs=0.0, epsrel=1e-13, limit=200)
    return TAU * value


def test_versine_printed_equals_corrected_outside_the_window():
    t = np.linspace(-10.0, T_END + 100.0, 200_001)
    t = np.concatenate([t, [0.0, T_V, WINDOW[0], np.nextafter(WINDOW[1], np.inf), T_ZERO - T_V, T_ZERO]])
    outside = (t <= WINDOW[0]) | (t > WINDOW[1])
    printed = versine_printed(t[outside], tau_max=TAU, t_end=T_END)
    np.testing.assert_array_equal(printed, versine(t[outside], tau_max=TAU, t_end=T_END))
    inside = t[~outside]
    assert inside.size > 1000
    assert (
        np.max(np.abs(versine_printed(inside, tau_max=TAU, t_end=T_END) - versine(inside, tau_max=TAU, t_end=T_END)))
        > 0.1 * TAU
    )  # noqa: E501


def test_versine_printed_is_the_printed_line_inside_the_window():
    t = np.linspace(WINDOW[0], WINDOW[1], 1001)[1:]
    expected = [TAU * _printed_line(x) for x in t]
    np.testing.assert_allclose(versine_printed(t, tau_max=TAU, t_end=T_END), expected, rtol=0, atol=1e-15)


def test_versine_printed_jumps_at_the_end_of_the_window():
    """+1 at t₋ − t_v (continuous with the plateau), cos(π t_v/(t₋ + t_v)) ≈ 0.75 at t₋ + t_v, then −1."""
    end_value = np.cos(np.pi * T_V / (T_MINUS + T_V))
    eps = 1e-10  # the line's slope there is ~7e-4 /s: it moves by < 1e-13 over eps
    start, before, at, after = versine_printed(
        [WINDOW[0] + eps, WINDOW[1] - eps, WINDOW[1], WINDOW[1] + eps], tau_max=1.0, t_end=T_END
    )
    assert abs(start - 1.0) < 1e-12
    assert abs(before - end_value) < 1e-12
    assert abs(at - end_value) < 1e-12
    assert after == -1.0
    assert abs((after - before) - (-1.0 - end_value)) < 1e-12
    assert 0.74 < end_value < 0.75


def test_versine_printed_net_impulse_is_the_analytic_integral():
    """Trapezoid on a fine grid that splits at every breakpoint (the jump at t₋ + t_v gets a point
    on each side) against τ_max ∫ of the printed line: equal to 1e-6 relative, and far from zero."""
    edges = [0.0, T_V, WINDOW[0], WINDOW[1], T_ZERO - T_V, T_ZERO, T_END]
    impulse = 0.0
    for a, b in zip(edges[:-1], edges[1:]):
        lo = np.nextafter(a, np.inf) if a == WINDOW[1] else a  # right of the jump: the −1 plateau
        t = np.linspace(lo, b, 200_001)
        impulse += float(np.trapezoid(versine_printed(t, tau_max=TAU, t_end=T_END), t))
    expected = _printed_net_impulse()
    assert impulse == pytest.approx(expected, rel=1e-6)
    assert abs(expected) > 0.5 * TAU * T_V  # 1.77 τ_max t_v: not rest-to-rest
    f = lambda t: float(torque_profile("versine_printed", t, tau_max=TAU, t_end=T_END))  # noqa: E731
    by_quad, _ = quad(f, 0, T_END, points=edges[1:-1], limit=400)
    assert by_quad == pytest.approx(expected, rel=1e-6)


def test_rigid_reference_integrates_the_printed_profile():
    """The rigid reference keeps the printed profile's net impulse: ω = J/I after t₀, φ grows at that rate."""
    inertia = 6.0e4
    t = np.array([T_ZERO + 100.0, T_END, 3600.0])
    phi, w = rigid_response("versine_printed", t, tau_max=TAU, t_end=T_END, t_v=None, inertia=inertia)
    rate = _printed_net_impulse() / inertia
    np.testing.assert_allclose(w, rate, rtol=1e-4)  # trapezoid on a 0.01 s grid across the jump
    assert phi[2] - phi[1] == pytest.approx(rate * (3600.0 - T_END), rel=1e-4)


def test_commanded_impulse_of_the_printed_profile():
    """The run's commanded impulse (mid-point rule, δt = 0.1 s) ends at the printed profile's net impulse."""
    p = ProfileConfig(kind="versine_printed", tau_max_Nm=TAU, t_end_s=T_END)
    (cmd,) = commanded_impulse_Nms(p, np.array([T_END]), timestep_s=0.1, load_timing="midpoint")
    assert cmd == pytest.approx(_printed_net_impulse(), abs=0.1 * TAU * 2)  # one step across the jump


def test_profile_config_takes_the_printed_kind_and_names_a_wrong_one():
    p = ProfileConfig(kind="versine_printed", tau_max_Nm=TAU, t_end_s=T_END)
    assert p.kind == "versine_printed"
    with pytest.raises(ValidationError, match="kind"):
        ProfileConfig(kind="versine_as_printed", tau_max_Nm=TAU, t_end_s=T_END)
    with pytest.raises(ValueError, match="kind"):
        torque_profile("versine_as_printed", 1.0, tau_max=TAU, t_end=T_END)


def test_printed_reading_config_differs_from_the_long_run_in_the_profile_kind_only():
    printed = tomllib.loads((REPO / PRINTED_CONFIG).read_text())
    corrected = tomllib.loads((REPO / CORRECTED_CONFIG).read_text())
    assert printed["profile"].pop("kind") == "versine_printed"
    assert corrected["profile"].pop("kind") == "versine"
    printed.pop("description"), corrected.pop("description")
    assert printed == corrected
    assert load_config(REPO / PRINTED_CONFIG).profile.kind == "versine_printed"
