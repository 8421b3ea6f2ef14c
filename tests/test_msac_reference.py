"""MSAC reference models (Vedant & Allison 2019, Eqs. 1, 6, 7): the corrected lumped formula and the exact planar
model — quadrature vs a plain time-domain integration, limits and invariances."""

from __future__ import annotations

import math

import numpy as np
import pytest

from magsail_mj.concepts.msac.reference import (
    PlanarMsac,
    exact_rotation_ode,
    exact_rotation_path,
    exact_rotation_samples,
    lumped_rate,
    lumped_theta,
    wing_inertias,
)
from magsail_mj.concepts.msac.cycle import CyclePath, cycle_state

M, L, T = 60.0, 8.0, 0.03
ICM = M * (L * L + T * T) / 12


def model(**kw) -> PlanarMsac:
    base = dict(
        bus_izz_kgm2=2000.0,
        wing_mass_kg=M,
        wing_length_m=L,
        wing_icm_kgm2=ICM,
        hinge_offset_m=1.0,
        root_mass_kg=1e-3,
        root_inertia_kgm2=1e-6,
    )
    base.update(kw)
    return PlanarMsac(**base)


def path(**kw) -> CyclePath:
    base = dict(phi_a_rad=math.radians(10), phi_b_rad=math.radians(-10), s_e_m=0.08, s_c_m=0.0, period_s=1e-3)
    base.update(kw)
    return CyclePath(**base)


def test_quadrature_equals_plain_time_integration():
    # RK4 (= Simpson, the rate depends on t only) at 4000 steps/cycle: error ~1e-12 relative
    P, p = model(), path()
    quad = exact_rotation_path(P, p.waypoints).sum()
    ode = exact_rotation_ode(P, p, steps_per_cycle=4000)
    assert quad == pytest.approx(ode, rel=1e-9)
    assert exact_rotation_path(P, p.waypoints, nodes=64).sum() == pytest.approx(quad, rel=1e-13)


@pytest.mark.parametrize(
    "bl, fractions",
    [("cubic", (0.4, 0.1, 0.4, 0.1)), ("cosine", (0.3, 0.2, 0.3, 0.2)), ("min_jerk", (0.45, 0.05, 0.25, 0.25))],
)
def test_time_reparametrisation_invariance(bl, fractions):
    # the same closed path traversed with other blends, phase timings and periods: same rotation
    P = model()
    ref = exact_rotation_ode(P, path(), steps_per_cycle=4000)
    other = exact_rotation_ode(P, path(blend=bl, fractions=fractions, period_s=3.7), steps_per_cycle=4000)
    assert other == pytest.approx(ref, rel=1e-8)


@pytest.mark.parametrize("pattern", ["bend_only", "extend_only"])
def test_reciprocal_motion_gives_zero(pattern):
    P, p = model(), path(pattern=pattern)
    msac = exact_rotation_path(P, path().waypoints).sum()
    assert abs(exact_rotation_path(P, p.waypoints).sum()) <= 1e-14 * abs(msac) * 1e3
    assert abs(exact_rotation_ode(P, p, steps_per_cycle=2000)) <= 1e-10 * abs(msac)


def test_reversed_loop_changes_sign():
    P = model()
    a = exact_rotation_path(P, path().waypoints).sum()
    b = exact_rotation_path(P, path(pattern="reversed").waypoints).sum()
    assert b == pytest.approx(-a, rel=1e-13) and a > 0


@pytest.mark.parametrize("Ib", [1e6, 1e8, 1e10])
def test_large_bus_inertia_tends_to_lumped_formula(Ib):
    # with r0 = 0 and I_b -> inf the exact result -> Eq. (6) with the model's two-wing I_e, I_c;
    # the relative gap is O(I_wing / I_b) (I_wing ~ 1.3e3 kg m²)
    P, p = model(bus_izz_kgm2=Ib, hinge_offset_m=0.0), path()
    wi = wing_inertias(P, s_e_m=p.s_e_m, s_c_m=p.s_c_m)
    lump = lumped_theta(I_e=2 * wi.e_hinge, I_c=2 * wi.c_hinge, I_sat=Ib, phi_a=p.phi_a_rad, phi_b=p.phi_b_rad)
    exact = exact_rotation_path(P, p.waypoints).sum()
    assert abs(exact / lump - 1) <= 10 * 2 * wi.e_hinge / Ib


def test_lumped_formula_signed_stroke():
    # a symmetric ±10° motion gives a non-zero result, (I_e − I_c)(φa − φb)/I_sat
    th = lumped_theta(I_e=2.0, I_c=1.0, I_sat=10.0, phi_a=0.2, phi_b=-0.2)
    assert th == pytest.approx(0.04)
    assert lumped_rate(I_e=2.0, I_c=1.0, I_sat=10.0, phi_a=0.2, phi_b=-0.2, period_s=1e-3) == pytest.approx(40.0)
    with pytest.raises(ValueError, match="I_sat"):
        lumped_theta(I_e=2.0, I_c=1.0, I_sat=0.0, phi_a=0.2, phi_b=-0.2)


def test_rigid_slide_inertia_ratio():
    # thin rigid panel on a slide, I_e/I_c = 1 + 3ε + 3ε²; stretched panel (1+ε)²
    eps = 0.01
    P = model(wing_icm_kgm2=M * L * L / 12)
    wi = wing_inertias(P, s_e_m=eps * L, s_c_m=0.0)
    assert wi.e_hinge / wi.c_hinge == pytest.approx(1 + 3 * eps + 3 * eps**2, rel=1e-13)
    assert wi.e_stretch / wi.c_stretch == pytest.approx((1 + eps) ** 2, rel=1e-13)
    assert wi.rest_centre == pytest.approx(M * L * L / 12 + M * (1.0 + L / 2) ** 2)


def test_samples_integration_converges_to_path_integral():
    P, p = model(), path()
    t = np.linspace(0, p.period_s, 40001)
    st = cycle_state(p, t)
    psi = exact_rotation_samples(P, st.phi, st.s)
    assert psi[-1] == pytest.approx(exact_rotation_path(P, p.waypoints).sum(), rel=1e-6)


def test_samples_integration_matches_plain_loop():
    P = model()
    rng = np.random.default_rng(3)
    phi, s = rng.uniform(-0.2, 0.2, 50), rng.uniform(0, 0.1, 50)
    got = exact_rotation_samples(P, phi, s)
    ref, acc = [0.0], 0.0
    for i in range(49):
        pm, sm = 0.5 * (phi[i] + phi[i + 1]), 0.5 * (s[i] + s[i + 1])
        ap, as_ = P.connection(pm, sm)
        acc += float(ap) * (phi[i + 1] - phi[i]) + float(as_) * (s[i + 1] - s[i])
        ref.append(acc)
    assert np.allclose(got, ref, rtol=1e-12, atol=1e-16)


def test_angular_momentum_zero_along_connection():
    P = model()
    rng = np.random.default_rng(0)
    phi, s, pd, sd = rng.normal(size=(4, 20))
    ap, as_ = P.connection(phi, s)
    L = P.angular_momentum(phi=phi, s=s, psi_dot=ap * pd + as_ * sd, phi_dot=pd, s_dot=sd)
    assert np.allclose(L, 0.0, atol=1e-10)


def test_point_mass_check_of_the_momentum_formula():
    # direct computation: wing = two point masses m/2 at c ± d along the wing (MOI about COM m d²)
    # plus a point at the hinge; sum r × v about the bus centre for both point-symmetric wings
    rng = np.random.default_rng(5)
    d = 1.7
    P = model(wing_icm_kgm2=M * d * d, root_mass_kg=0.3, root_inertia_kgm2=0.0)
    for _ in range(10):
        psi, phi, s, psid, phid, sd = rng.normal(size=6)
        Ltot = P.bus_izz_kgm2 * psid
        for sign in (1.0, -1.0):
            e = lambda a: sign * np.array([math.cos(a), math.sin(a)])  # noqa: E731
            ep = lambda a: sign * np.array([-math.sin(a), math.cos(a)])  # noqa: E731
            a = psi + phi
            c = s + L / 2
            pts = [(P.root_mass_kg, P.hinge_offset_m * e(psi), P.hinge_offset_m * psid * ep(psi))]
            for off in (c - d, c + d):
                pos = P.hinge_offset_m * e(psi) + off * e(a)
                vel = P.hinge_offset_m * psid * ep(psi) + sd * e(a) + off * (psid + phid) * ep(a)
                pts.append((M / 2, pos, vel))
            Ltot += sum(m * (p[0] * v[1] - p[1] * v[0]) for m, p, v in pts)
        got = P.angular_momentum(phi=phi, s=s, psi_dot=psid, phi_dot=phid, s_dot=sd)
        assert float(got) == pytest.approx(Ltot, rel=1e-12)


def test_bad_parameters_are_named():
    with pytest.raises(ValueError, match="bus_izz_kgm2"):
        model(bus_izz_kgm2=-1.0)
    with pytest.raises(ValueError, match="waypoints"):
        exact_rotation_path(model(), np.zeros((1, 2)))
    with pytest.raises(ValueError, match="nodes"):
        exact_rotation_path(model(), path().waypoints, nodes=1)
