"""Thermal and length-scaling model of current loops (Robb et al. 2022b, Eqs. 2–11, with
our corrections of Eqs. 6, 7–9 and 10 and our reference temperature).

Tolerances:
- closed forms against the step-by-step chain: a few dozen flops and one cube root each, so 1e-12
  relative (double precision leaves ~1e-15; the margin covers powers like ``R_E¹²``);
- C1 against the hand-computed 3.2806e-7: half a unit of the last printed digit (5e-12 absolute);
- the geometry-A roots: brentq on ``ln h(λ) = ln λ_u`` to ``xtol = 1e-15``, so the implicit
  equation's relative residual is ≤ 1e-12; against the quartic ``κλ_u t⁴ − t³ + 1 = 0``
  (``1 + κλ = t³``) solved by ``numpy.roots`` (companion eigenvalues, ~1e-13 for well-separated
  roots) at 1e-9;
- Eq. 8 against a particle plate with exact point-mass gravity: the discrete plate's second moment
  ``D²/12 (1 − 1/n²)`` is put into the reference exactly; what remains is the neglected
  ``O((D/R_o)²) ≈ 1e-9`` of the tidal expansion and the ``g(R + r) − g(R)`` round-off
  (``ε R/r ≈ 1e-11``), so 1e-7 relative.
"""

from __future__ import annotations

import dataclasses
import json
import math
import runpy
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from magsail_mj.analysis.loop_scaling import (
    DEFAULT_CONSTANTS,
    NoLoopSolution,
    ThermalConstants,
    c1,
    conductor_mass,
    dipole_max,
    fold_A,
    geometry_factor,
    geometry_factor_b_loops,
    gravity_gradient_torque_max,
    h_A,
    joule_power,
    lambda_f,
    lambda_f_chain,
    lambda_u_A,
    loop_sizing,
    radiated_power,
    required_current,
    scaling_table,
    side_max,
    solve_lambda_A,
    sunlight_diameter_ratio,
    table1,
    trace_branches_A,
    wire_diameter,
)
from magsail_mj.cli import main

ROOT = Path(__file__).resolve().parents[1]

REPO = Path(__file__).resolve().parents[1]
K = DEFAULT_CONSTANTS


# ----------------------------------------------------------------------------- constants, Table 1


def test_constants_are_the_spec_defaults_and_frozen():
    assert (K.rho_c_kg_m3, K.T_ref_K, K.T_eq_K, K.rho_ref_ohmm, K.emissivity, K.alpha_per_K) == (
        8960.0,
        293.15,
        420.0,
        1.68e-8,
        0.7,
        0.00404,
    )
    assert (K.sigma_B, K.B0_T, K.mu_m3_s2, K.R_E_m) == (5.67e-8, 3.12e-5, 3.986e14, 6370e3)
    assert K.mu0_H_m == pytest.approx(4e-7 * math.pi, rel=1e-15)
    assert K.f_gamma == pytest.approx(1 + 0.00404 * (420 - 293.15), rel=1e-15)
    with pytest.raises(dataclasses.FrozenInstanceError):
        K.T_eq_K = 400.0  # type: ignore[misc]
    with pytest.raises(ValueError, match="ThermalConstants.emissivity"):
        ThermalConstants(emissivity=-0.1)


def test_c1_value():
    """C1 ≈ 3.2806e-7 m⁻¹ kg^{-1/3} with the table's constants."""
    assert abs(c1() - 3.2806e-7) < 0.5e-11


@pytest.mark.parametrize("N", [1, 2, 12, 19, 27, 60])
def test_geometry_factors_match_the_table1_formulas(N):
    n = math.ceil(N / 2)
    a_b = (n + 1) * (2 * n + 1) / (6 * n)
    assert geometry_factor("A", N) == 4.0
    assert geometry_factor("B", N) == pytest.approx(2 * (n + 1) / a_b ** (4 / 3), rel=1e-14)
    assert geometry_factor("B", N) == pytest.approx(geometry_factor_b_loops(n), rel=1e-15)
    assert geometry_factor("C", N) == pytest.approx(2 * (N + 1) ** (2 / 3) * N ** (1 / 3), rel=1e-13)
    g_d = (3 * (N + 1) ** 2 / (2 * N) + 1) / (3 * (N + 1) / (4 * N)) ** (4 / 3)
    assert geometry_factor("D", N) == pytest.approx(g_d, rel=1e-14)
    for g in "ABCD":  # G = D^{5/3} l / A_e^{4/3}, independent of D
        for D in (1.0, 250.0, 3e4):
            area, length = table1(g, N, D)
            assert D ** (5 / 3) * length / area ** (4 / 3) == pytest.approx(geometry_factor(g, N), rel=1e-12)


def test_table1_agrees_with_the_realised_lattice_values_where_the_spec_says_it_does():
    """Table 1 areas: B equals the lattice at even N; C always; D's area when 4 | N + 1 (N = 19, 27)."""
    assert table1("B", 12, 1.0) == pytest.approx((2.5278, 14.000), abs=5e-5)
    assert table1("C", 12, 1.0) == pytest.approx((1.0833, 28.167), abs=5e-4)
    assert table1("C", 27, 1.0) == pytest.approx((1.0370, 58.074), abs=5e-4)
    assert table1("D", 19, 1.0)[0] == pytest.approx(0.7895, abs=5e-5)
    assert table1("D", 27, 1.0)[0] == pytest.approx(0.7778, abs=5e-5)
    # Odd N (equal spacing is off the lattice): the sizing area of B is a few percent above the lattice loops.
    assert table1("B", 19, 1.0)[0] / 3.6842 - 1 == pytest.approx(0.045, abs=0.005)
    assert table1("B", 27, 1.0)[0] / 5.0123 - 1 == pytest.approx(0.035, abs=0.005)


# ----------------------------------------------------------------------------- closed form = chain


@settings(max_examples=200, deadline=None)
@given(g=st.sampled_from("ABCD"), N=st.integers(1, 80), D=st.floats(1.0, 1e5), s=st.floats(1e-4, 1.0))
def test_closed_form_lambda_equals_the_chain(g, N, D, s):
    """Eq. 11 closed form = I (Eq. 9) → d (Eq. 6 with I²) → M_c (Eq. 10 with ρ_c) → λ_f (uniform mass)."""
    ch = lambda_f_chain(g, units=N, side_m=D, areal_density_kg_m2=s)
    closed = lambda_f(g, units=N, side_m=D, areal_density_kg_m2=s)
    assert ch["lambda_f"] == pytest.approx(closed, rel=1e-12)
    assert ch["lambda_f"] / (geometry_factor(g, N) * D ** (5 / 3) * s ** (1 / 3)) == pytest.approx(c1(), rel=1e-12)
    # The heat balance the diameter came from: I² R(Γ_e) = ε σ_B π d l Γ_e⁴ (l cancels).
    area, length = table1(g, N, D)
    assert joule_power(ch["current_A"], ch["wire_diameter_m"], length) == pytest.approx(
        radiated_power(ch["wire_diameter_m"], length), rel=1e-12
    )
    assert ch["conductor_mass_kg"] == pytest.approx(
        K.rho_c_kg_m3 * math.pi / 4 * ch["wire_diameter_m"] ** 2 * length, rel=1e-14
    )
    assert conductor_mass(ch["wire_diameter_m"], length) == ch["conductor_mass_kg"]
    assert ch["current_A"] * area == pytest.approx(dipole_max(D, s), rel=1e-12)


@pytest.mark.parametrize("g", "BCD")
def test_side_max_is_where_lambda_reaches_one(g):
    for s in (1e-3, 0.1):
        Dm = side_max(g, units=27, areal_density_kg_m2=s)
        assert lambda_f(g, units=27, side_m=Dm, areal_density_kg_m2=s) == pytest.approx(1.0, rel=1e-12)


def test_wire_diameter_carries_the_current_squared():
    """Eq. 6 with I² on the resistive side: d ∝ I^{2/3} (the printed Eq. 6 would give d independent of I)."""
    assert wire_diameter(8.0) / wire_diameter(1.0) == pytest.approx(4.0, rel=1e-13)
    d = wire_diameter(10.0)
    assert K.emissivity * K.sigma_B * math.pi * d * K.T_eq_K**4 == pytest.approx(
        4 * K.rho_ref_ohmm * 100.0 * K.f_gamma / (math.pi * d * d), rel=1e-12
    )


# ----------------------------------------------------------------------------- Eqs. 7–9


def _tidal_torque(points_body: np.ndarray, masses: np.ndarray, R: float, theta: float) -> float:
    """Net gravity torque about the centre of mass, exact point-mass gravity, body rotated by θ about y.

    The centre of mass sits at (R, 0, 0); the body's normal (+z) is turned by θ towards +x, so it is
    at θ from the local vertical. Uses the tidal form g(R + r) − g(R) (the uniform part exerts no
    torque about the centre of mass).
    """
    c, s = math.cos(theta), math.sin(theta)
    rot = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    r = points_body @ rot.T
    Rv = np.array([R, 0.0, 0.0])
    pos = Rv + r

    def g(x):
        return -K.mu_m3_s2 * x / np.linalg.norm(x, axis=-1, keepdims=True) ** 3

    F = masses[:, None] * (g(pos) - g(Rv))
    T = np.cross(r, F).sum(axis=0)
    assert abs(T[0]) + abs(T[2]) < 1e-9 * abs(T[1])  # symmetric plate: torque about y only
    return float(T[1])


def _plate(n: int, D: float, M: float) -> tuple[np.ndarray, np.ndarray]:
    c = -D / 2 + (np.arange(n) + 0.5) * D / n
    X, Y = np.meshgrid(c, c, indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel(), np.zeros(n * n)], axis=1)
    return pts, np.full(n * n, M / (n * n))


@pytest.mark.parametrize("alt_km", [400.0, 800.0, 36_000.0])
def test_eq8_against_a_particle_plate_at_45_degrees(alt_km):
    """T_g,max = μ M D² / (8 R_o³) from summed point-mass gravity on an n×n particle plate."""
    n, D, M = 60, 250.0, 6250.0
    R = K.R_E_m + alt_km * 1e3
    pts, m = _plate(n, D, M)
    T45 = abs(_tidal_torque(pts, m, R, math.pi / 4))
    expect = gravity_gradient_torque_max(M, D, R) * (1 - 1 / n**2)  # discrete second moment
    assert T45 == pytest.approx(expect, rel=1e-7)
    # 45° is the maximum: T(θ) ∝ sin 2θ.
    for theta in (0.1, 0.5, 1.2):
        assert abs(_tidal_torque(pts, m, R, theta)) == pytest.approx(T45 * math.sin(2 * theta), rel=1e-6)


def test_eq8_from_the_inertia_tensor():
    """T_g = 3μ/R_o⁵ R_o × (i R_o) with i = diag(1, 1, 2) M D²/12, normal at 45° to nadir."""
    M, D, R = 6250.0, 250.0, 7170e3
    i = np.diag([1.0, 1.0, 2.0]) * M * D * D / 12
    Rb = R * np.array([math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4)])
    T = 3 * K.mu_m3_s2 / R**5 * np.cross(Rb, i @ Rb)
    assert np.linalg.norm(T) == pytest.approx(gravity_gradient_torque_max(M, D, R), rel=1e-13)


def test_rim_conductor_inertia_of_a_square_wire_is_kappa_one():
    """Geometry-A inertia: plate (M − M_c) + perimeter wire (M_c) gives T_g,max (1 + κλ) with κ = 1, not 15."""
    n, m_side, D, M, lam = 40, 400, 250.0, 6250.0, 0.2
    R = K.R_E_m + 800e3
    Mc = lam * M
    pts, mp = _plate(n, D, M - Mc)
    t = -D / 2 + (np.arange(m_side) + 0.5) * D / m_side
    h = np.full(m_side, D / 2)
    z = np.zeros(m_side)
    wire = np.concatenate(
        [np.stack([t, -h, z], 1), np.stack([h, t, z], 1), np.stack([-t, h, z], 1), np.stack([-h, -t, z], 1)]
    )
    mw = np.full(len(wire), Mc / len(wire))
    T = abs(_tidal_torque(np.vstack([pts, wire]), np.concatenate([mp, mw]), R, math.pi / 4))
    second_moment = (
        (M - Mc) * D**2 / 12 * (1 - 1 / n**2) + Mc * D**2 / 8 + Mc * D**2 / 24 * (1 - 1 / m_side**2)
    )  # Σ m x², discrete
    assert T == pytest.approx(3 * K.mu_m3_s2 / (2 * R**3) * second_moment, rel=1e-7)
    # Continuous closed form: the discrete plate's second moment is low by (1 − λ)/n² = 5e-4.
    assert T == pytest.approx(gravity_gradient_torque_max(M, D, R, kappa=1.0, lambda_f=lam), rel=1 / n**2)
    assert T < 0.5 * gravity_gradient_torque_max(M, D, R, kappa=15.0, lambda_f=lam)


@pytest.mark.parametrize("g", "ABCD")
def test_current_is_independent_of_altitude(g):
    """Eq. 9: T_g,max / (A_e B) has R_o³ in numerator and denominator."""
    area, _ = table1(g, 19, 250.0)
    kw = dict(kappa=15.0, lambda_f=0.01) if g == "A" else {}
    closed = required_current(area, 250.0, 0.1, **kw)
    for h in (0.0, 400e3, 800e3, 35_786e3, 1e9):
        assert required_current(area, 250.0, 0.1, altitude_m=h, **kw) == pytest.approx(closed, rel=1e-12)


def test_dipole_max_is_common_to_the_uniform_geometries():
    t = scaling_table()
    m = dipole_max(250.0, 0.1)
    assert m == pytest.approx(K.mu_m3_s2 * 0.1 * 250.0**4 / (8 * K.B0_T * K.R_E_m**3), rel=1e-15)
    for g in "BCD":
        for N in (12, 19, 27):
            assert t[f"{g}_N{N}_dipole_max_Am2"] == pytest.approx(m, rel=1e-12)
    lam = t["A_N19_lambda_f"]
    assert t["A_N19_dipole_max_Am2"] == pytest.approx(m * (1 + 15 * lam), rel=1e-12)


# ----------------------------------------------------------------------------- geometry A


def _quartic_roots(lambda_u: float, kappa: float) -> list[float]:
    """Positive real roots λ of λ = λ_u (1 + κλ)^{4/3} via t³ = 1 + κλ: κλ_u t⁴ − t³ + 1 = 0."""
    t = np.roots([kappa * lambda_u, -1.0, 0.0, 0.0, 1.0])
    t = np.sort(t[(np.abs(t.imag) < 1e-9) & (t.real > 1.0)].real)
    return [(x**3 - 1) / kappa for x in t]


@pytest.mark.parametrize("kappa", [15.0, 1.0, 4.0])
@pytest.mark.parametrize("frac", [1e-6, 1e-3, 0.3, 0.9])
def test_solver_finds_both_roots(kappa, frac):
    lam_star, h_star = fold_A(kappa)
    lu = frac * h_star
    light, heavy = solve_lambda_A(lu, kappa=kappa, branch="both")
    assert 0 < light < lam_star < heavy
    for lam in (light, heavy):
        assert abs(lam - lu * (1 + kappa * lam) ** (4 / 3)) <= 1e-12 * lam
    ref = _quartic_roots(lu, kappa)
    assert len(ref) == 2
    assert light == pytest.approx(ref[0], rel=1e-9)
    assert heavy == pytest.approx(ref[1], rel=1e-9)
    assert solve_lambda_A(lu, kappa=kappa) == light
    assert solve_lambda_A(lu, kappa=kappa, branch="heavy") == heavy


@pytest.mark.parametrize("kappa", [15.0, 1.0])
def test_fold_at_three_over_kappa(kappa):
    lam_star, h_star = fold_A(kappa)
    assert lam_star == pytest.approx(3 / kappa, rel=1e-15)
    assert h_star == pytest.approx(3 / kappa * 4 ** (-4 / 3), rel=1e-15)
    assert h_A(lam_star, kappa) == pytest.approx(h_star, rel=1e-14)
    # h' = 0 at λ* (central difference, step 1e-5 λ*: truncation ~ h''' step² ≈ 1e-10 h*).
    eps = 1e-5 * lam_star
    slope = (h_A(lam_star + eps, kappa) - h_A(lam_star - eps, kappa)) / (2 * eps)
    assert abs(slope) < 1e-8
    grid = np.linspace(0.2 * lam_star, 5 * lam_star, 200_001)
    assert grid[np.argmax(h_A(grid, kappa))] == pytest.approx(lam_star, abs=grid[1] - grid[0])
    # Approaching the fold the branches merge: |λ − λ*| ~ sqrt(2δ h*/|h''|) for λ_u = h*(1 − δ).
    light, heavy = solve_lambda_A(h_star * (1 - 1e-10), kappa=kappa, branch="both")
    assert abs(light - lam_star) < 1e-4 * lam_star and abs(heavy - lam_star) < 1e-4 * lam_star
    assert solve_lambda_A(h_star, kappa=kappa, branch="both") == (lam_star, lam_star)
    with pytest.raises(NoLoopSolution, match="exceeds the fold"):
        solve_lambda_A(h_star * 1.001, kappa=kappa)


def test_kappa_zero_is_the_uniform_plate():
    assert solve_lambda_A(0.05, kappa=0.0) == 0.05
    assert fold_A(0.0) == (math.inf, math.inf)


def test_loop_sizing_A_is_self_consistent_on_the_light_branch():
    """The chain at the solved λ reproduces λ; I_A = I_u (1 + κλ)."""
    r = loop_sizing("A", units=19, side_m=250.0, areal_density_kg_m2=0.1, kappa=15.0)
    lam = solve_lambda_A(lambda_u_A(250.0, 0.1), kappa=15.0)
    assert r["lambda_f"] == pytest.approx(lam, rel=1e-12)
    assert r["lambda_f"] < fold_A(15.0)[0]
    I_u = required_current(250.0**2, 250.0, 0.1)
    assert r["current_A"] == pytest.approx(I_u * (1 + 15 * lam), rel=1e-12)
    assert r["path_length_m"] == 1000.0
    assert r["power_W"] == pytest.approx(joule_power(r["current_A"], r["wire_diameter_m"], 1000.0), rel=1e-12)
    r1 = loop_sizing("A", units=19, side_m=250.0, areal_density_kg_m2=0.1, kappa=1.0)
    assert r1["current_A"] < r["current_A"]


def test_trace_branches_round_trip():
    s = 0.1
    tr = trace_branches_A(s, kappa=15.0, lambdas=np.logspace(-8, 0, 301))
    D, lam, heavy = tr["side_m"], tr["lambda_f"], tr["heavy"]
    assert np.all(np.diff(D[~heavy]) > 0) and np.all(np.diff(D[heavy]) < 0)
    for i in range(0, 301, 25):
        branch = "heavy" if heavy[i] else "light"
        assert solve_lambda_A(lambda_u_A(D[i], s), kappa=15.0, branch=branch) == pytest.approx(lam[i], rel=1e-9)
    i = 150
    if not heavy[i]:
        r = loop_sizing("A", units=1, side_m=float(D[i]), areal_density_kg_m2=s)
        assert r["current_A"] == pytest.approx(tr["current_A"][i], rel=1e-9)
        assert r["power_per_area_W_m2"] == pytest.approx(tr["power_per_area_W_m2"][i], rel=1e-9)
    assert D.max() <= scaling_table(areal_density_kg_m2=s)["A_side_fold_m"] * (1 + 1e-12)
    with pytest.raises(NoLoopSolution, match="side_m"):
        loop_sizing(
            "A", units=1, side_m=1.01 * scaling_table(areal_density_kg_m2=s)["A_side_fold_m"], areal_density_kg_m2=s
        )


def test_reference_temperature_moves_only_the_A_current():
    """Reference temperature (we take 293.15 K): Γ_r changes A's current by ~0.02 %/K, not B–D's."""
    warm = ThermalConstants(T_ref_K=294.15)
    a0 = loop_sizing("A", units=19, side_m=250.0, areal_density_kg_m2=0.1)["current_A"]
    a1 = loop_sizing("A", units=19, side_m=250.0, areal_density_kg_m2=0.1, constants=warm)["current_A"]
    assert abs(a1 / a0 - 1) == pytest.approx(2e-4, rel=0.5)
    for g in "BCD":
        b0 = loop_sizing(g, units=19, side_m=250.0, areal_density_kg_m2=0.1)
        b1 = loop_sizing(g, units=19, side_m=250.0, areal_density_kg_m2=0.1, constants=warm)
        assert b1["current_A"] == b0["current_A"]
        assert b1["wire_diameter_m"] != b0["wire_diameter_m"]


# ----------------------------------------------------------------------------- table, sunlight, errors


def test_scaling_table_has_every_spec_key():
    t = scaling_table()
    for g in "ABCD":
        for N in (12, 19, 27):
            for q in (
                "current_A",
                "wire_diameter_m",
                "lambda_f",
                "power_per_area_W_m2",
                "dipole_max_Am2",
                "path_length_m",
            ):
                assert math.isfinite(t[f"{g}_N{N}_{q}"]) and t[f"{g}_N{N}_{q}"] > 0
    assert t["c1_per_m_per_cbrt_kg"] == c1() and t["kappa"] == 15.0 and t["A_lambda_fold"] == 0.2
    assert t["B_N19_current_A"] == pytest.approx(10.0298, rel=1e-5)  # README table
    assert t["A_N19_current_A"] == pytest.approx(42.6054, rel=1e-5)


def test_sunlight_check():
    """d_sun/d from the per-length balance with absorbed sunlight, solved numerically."""
    I = 40.0
    d = wire_diameter(I)

    def balance(x):
        return (
            4 * K.rho_ref_ohmm * K.f_gamma * I * I / (math.pi * x * x)
            + 1360 * K.emissivity * x
            - K.emissivity * K.sigma_B * math.pi * x * K.T_eq_K**4
        )

    d_sun = brentq(balance, d, 2 * d, xtol=1e-18, rtol=1e-15)
    assert d_sun / d == pytest.approx(sunlight_diameter_ratio(), rel=1e-10)
    assert sunlight_diameter_ratio() == pytest.approx(1.098, abs=1e-3)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(units=0), "units"),
        (dict(units=2.5), "units"),
        (dict(side_m=-1.0), "side_m"),
        (dict(areal_density_kg_m2=0.0), "areal_density_kg_m2"),
        (dict(kappa=-1.0), "kappa"),
    ],
)
def test_bad_arguments_name_themselves(kwargs, name):
    base = dict(units=19, side_m=250.0, areal_density_kg_m2=0.1)
    with pytest.raises(ValueError, match=f"^{name}:"):
        loop_sizing("A", **{**base, **kwargs})
    with pytest.raises(ValueError, match="^geometry:"):
        loop_sizing("E", **base)
    assert loop_sizing("cy", **base)["current_A"] == loop_sizing("C", **base)["current_A"]


# ----------------------------------------------------------------------------- CLI and scripts


def test_cli_prints_one_sizing_as_json(capsys):
    assert (
        main(["scaling", "loops", "--geometry", "D", "--units", "27", "--side-m", "250", "--areal-density", "0.1"]) == 0
    )
    out = json.loads(capsys.readouterr().out)
    ref = loop_sizing("D", units=27, side_m=250.0, areal_density_kg_m2=0.1)
    for key in ("current_A", "wire_diameter_m", "lambda_f", "power_per_area_W_m2", "dipole_max_Am2", "path_length_m"):
        assert out[key] == pytest.approx(ref[key], rel=1e-15)


def test_cli_table(capsys):
    assert main(["scaling", "loops", "--table", "--kappa", "1"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["kappa"] == 1.0 and out["A_lambda_fold"] == 3.0
    assert out == pytest.approx(json.loads(json.dumps(scaling_table(kappa=1.0))))


@pytest.mark.parametrize(
    "argv, option, value",
    [
        (["--geometry", "E"], "--geometry", "'E'"),
        (["--geometry", "B", "--units", "0"], "--units", "0"),
        (["--geometry", "C", "--side-m", "-5"], "--side-m", "-5"),
        (["--geometry", "C", "--areal-density", "0"], "--areal-density", "0"),
        (["--geometry", "A", "--kappa", "-2"], "--kappa", "-2"),
        (["--geometry", "A", "--side-m", "5000"], "--side-m", "5000"),
        ([], "--geometry", "A, B, C, D"),
    ],
)
def test_cli_bad_option(capsys, argv, option, value):
    assert main(["scaling", "loops", *argv]) == 2
    cap = capsys.readouterr()
    assert cap.out == ""
    assert cap.err.startswith(f"error: {option}:") and value in cap.err


def test_cli_non_number_is_an_argument_error(capsys):
    assert main(["scaling", "loops", "--geometry", "B", "--units", "many"]) == 2
    assert "error: --units" in capsys.readouterr().err


def test_sizing_example_prints_table_2_and_the_limits(tmp_path, monkeypatch, capsys):
    """The gallery's sizing example (Table 2, Figs. 3-5) prints the library's numbers."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(plt, "show", lambda *a, **k: None)
    runpy.run_path(str(ROOT / "examples" / "gallery" / "plot_current_loop_sizing.py"), run_name="__main__")
    plt.close("all")
    out = capsys.readouterr().out
    table = scaling_table()
    for g, n in (("A", 12), ("B", 19), ("C", 27), ("D", 27)):
        row = next(line for line in out.splitlines() if line.startswith(f"| {g} | {n} |"))
        assert float(row.split("|")[3]) == pytest.approx(table[f"{g}_N{n}_current_A"], abs=0.005)
    assert f"B, N = 27, σ_A = 100 g/m²: D_max = {side_max('B', units=27, areal_density_kg_m2=0.1):.0f} m" in out
    assert "A, σ_A = 100 g/m²: fold at D = 673 m" in out
