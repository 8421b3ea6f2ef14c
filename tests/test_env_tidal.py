"""Tidal gravity of the orbit-following world and the classical gravity-gradient torque
(Robb et al. 2022a, Sec. 4.2; Yoo et al. 2016, Eq. 12).

Tolerances:
* Cancellation-free tidal form vs a 50-digit ``decimal`` evaluation of g(r+x) − g(r): the float64
  form is good to ~1e-15 relative; we assert 1e-12. The naive float64 difference loses
  log10(|r|/|x|) digits (shown, not asserted beyond "worse").
* Tidal vs linear gravity gradient: they differ at second order, |Δa| ≤ (15/2) μ|x|²/r⁴ (bound
  of the second-order Taylor term), asserted with that bound.
* Plate at 45°: the summed tidal torque and the classical torque differ by O((d/r)²) ≈ 1e-10
  relative; we assert 1e-6.
* Dumbbell: orbit-following integration vs direct ECI integration over one orbit, both DOP853
  at rtol 1e-13; the ECI one carries 7e6 m coordinates, so its round-off (~1e-9 m per step) sets
  the floor: measured agreement 1.4e-5 m on 37 m of relative motion; asserted 1e-4 m.
"""

from __future__ import annotations

import math
from decimal import Decimal, getcontext

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from magsail_mj.environment.constants import MU_EARTH
from magsail_mj.environment.gravity import (
    gravity_gradient_torque,
    j2_acceleration,
    point_mass_acceleration,
    tidal_acceleration,
    tidal_acceleration_linear,
)
from magsail_mj.environment.orbit import OrbitalElements, kepler_propagate
from magsail_mj.loads.base import StepState
from magsail_mj.loads.tidal import GravityGradientTorqueLoad, TidalGravityLoad

R_ORB = 7170e3


class _Env:
    def __init__(self, r_ref):
        self.r_ref_eci = np.asarray(r_ref, dtype=float)


def _decimal_tidal(r, x, mu=MU_EARTH):
    getcontext().prec = 50
    R = [Decimal(float(a)) + Decimal(float(b)) for a, b in zip(r, x)]
    rr = [Decimal(float(a)) for a in r]
    nR = sum(c * c for c in R).sqrt() ** 3
    nr = sum(c * c for c in rr).sqrt() ** 3
    m = Decimal(mu)
    return np.array([float(-m * R[k] / nR + m * rr[k] / nr) for k in range(3)])


vec = st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda v: sum(c * c for c in v) > 1e-4)


@settings(max_examples=60, deadline=None)
@given(vec, vec, st.floats(-3, 3))
def test_tidal_form_matches_high_precision(rdir, xdir, log_x):
    r = np.array(rdir) / np.linalg.norm(rdir) * R_ORB
    x = np.array(xdir) / np.linalg.norm(xdir) * 10.0**log_x  # 1 mm … 1 km
    a = tidal_acceleration(r, x[None])[0]
    ref = _decimal_tidal(r, x)
    assert np.linalg.norm(a - ref) <= 1e-12 * np.linalg.norm(ref)


def test_naive_difference_is_worse():
    r = np.array([R_ORB, 0.0, 0.0])
    x = np.array([[1e-3, 2e-3, -1e-3]])
    ref = _decimal_tidal(r, x[0])
    naive = point_mass_acceleration(r + x[0]) - point_mass_acceleration(r)
    err_naive = np.linalg.norm(naive - ref) / np.linalg.norm(ref)
    err_careful = np.linalg.norm(tidal_acceleration(r, x)[0] - ref) / np.linalg.norm(ref)
    assert err_careful < 1e-14 < err_naive


@settings(max_examples=60, deadline=None)
@given(vec, vec, st.floats(0.0, 2.5))
def test_tidal_vs_linear_gradient(rdir, xdir, log_x):
    r = np.array(rdir) / np.linalg.norm(rdir) * R_ORB
    x = np.array(xdir) / np.linalg.norm(xdir) * 10.0**log_x
    a = tidal_acceleration(r, x[None])[0]
    lin = tidal_acceleration_linear(r, x[None])[0]
    bound = 7.5 * MU_EARTH * (x @ x) / R_ORB**4
    assert np.linalg.norm(a - lin) <= bound


def test_j2_acceleration_is_gradient_of_potential():
    from magsail_mj.environment.constants import J2_EARTH, R_J2

    def phi(p):  # J2 part of Φ = −μ/r [1 − J2 (R/r)² P2(sin φ)] (potential energy per unit mass)
        r = np.linalg.norm(p)
        s = p[2] / r
        return MU_EARTH / r * J2_EARTH * (R_J2 / r) ** 2 * 0.5 * (3 * s * s - 1)

    p = np.array([3.1e6, -4.2e6, 4.4e6])
    h = 1.0
    grad = np.array([(phi(p + h * e) - phi(p - h * e)) / (2 * h) for e in np.eye(3)])
    assert np.allclose(j2_acceleration(p), -grad, rtol=1e-6, atol=0)  # a = −∇Φ


def _plate(n=20, d=75.0, m=0.25):
    """Two layers of n × n points (the truss lattice), centred at the centre of mass."""
    a = d / (n - 1)
    i, j, k = np.meshgrid(np.arange(n), np.arange(n), np.arange(2), indexing="ij")
    p = np.stack([i * a - d / 2, j * a - d / 2, (k - 0.5) * a], -1).reshape(-1, 3)
    return p, np.full(len(p), m)


def _inertia(p, m):
    """I = Σ m (|p|² E − p pᵀ) about the origin."""
    return np.sum(m * np.einsum("ij,ij->i", p, p)) * np.eye(3) - np.einsum("i,ij,ik->jk", m, p, p)


@pytest.mark.parametrize("axis", ["x", "y"])
def test_plate_at_45_degrees_tidal_equals_classical(axis):
    p_body, m = _plate()
    r = np.array([0.0, R_ORB, 0.0])  # local vertical = world y
    # 'x': normal (0, −1, 1)/√2: tilted 45° from the vertical (world y) about the in-plane x₁ axis;
    # 'y': normal (1, −1, 0)/√2: in the xy plane at 45° to the vertical
    if axis == "x":
        rot = Rotation.from_euler("x", 45, degrees=True)
    else:
        rot = Rotation.from_euler("z", 45, degrees=True) * Rotation.from_euler("x", 90, degrees=True)
    x = rot.apply(p_body)
    nrm = rot.apply([0, 0, 1])
    assert abs(abs(nrm @ r) / R_ORB - math.cos(math.pi / 4)) < 1e-12
    load = TidalGravityLoad(np.arange(1, len(x) + 1), m)
    xfrc = np.zeros((len(x) + 1, 6))
    load.add(StepState(t=0.0, pos=np.vstack([np.zeros(3), x]), vel=None, xquat=None, omega=None, env=_Env(r)), xfrc)
    tau_tidal = np.cross(x, xfrc[1:, :3]).sum(axis=0)
    tau_classical = gravity_gradient_torque(r, _inertia(x, m))
    assert np.linalg.norm(tau_classical) > 1e-3  # not a trivial zero (≈ 0.1 N m here)
    assert np.linalg.norm(tau_tidal - tau_classical) <= 1e-6 * np.linalg.norm(tau_classical)


@pytest.mark.parametrize("seed", range(4))
def test_six_point_masses_reproduce_classical_torque(seed):
    """Point-mass model of a rigid body: pairs at ±d_k on each body axis with μ_k d_k² = (tr I − 2 I_kk)/2
    reproduce the deployed inertia; their tidal torque equals Eq. 12 within 1 %."""
    I = np.array([0.3104, 0.3121, 0.5757])
    mu_d2 = (I.sum() - 2 * I) / 2
    dk = np.array([0.5, 0.5, 0.5])
    mk = mu_d2 / dk**2
    pts = np.concatenate([np.diag(dk), -np.diag(dk)])
    masses = np.concatenate([mk, mk]) / 2  # μ_k is the mass of the pair
    assert np.allclose(_inertia(pts, masses), np.diag(I), atol=1e-15)
    q = Rotation.random(random_state=seed)
    r = np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5]) * 6963e3
    x = q.apply(pts)
    a = tidal_acceleration(r, x)
    tau = np.cross(x, masses[:, None] * a).sum(axis=0)
    quat = q.as_quat(scalar_first=True)
    st_ = StepState(
        t=0.0, pos=np.zeros((2, 3)), vel=None, xquat=np.array([[1, 0, 0, 0], quat]), omega=None, env=_Env(r)
    )
    tau_cl = GravityGradientTorqueLoad(1, I).torque_world(st_)
    assert np.linalg.norm(tau - tau_cl) <= 0.01 * np.linalg.norm(tau_cl)


def test_gravity_gradient_torque_zero_on_principal_axes():
    r = np.array([0.0, 0.0, 7e6])
    assert np.allclose(gravity_gradient_torque(r, np.diag([1.0, 2.0, 3.0])), 0.0, atol=1e-25)


def test_tidal_load_validation_and_accumulation():
    with pytest.raises(ValueError, match="masses"):
        TidalGravityLoad([1, 2], [1.0])
    with pytest.raises(ValueError, match="body_ids"):
        TidalGravityLoad([1, 1], [1.0, 1.0])
    load = TidalGravityLoad([2, 4], [1.0, 2.0])  # non-contiguous ids
    pos = np.zeros((5, 3))
    pos[2] = [10.0, 0, 0]
    pos[4] = [0, 5.0, 0]
    xfrc = np.ones((5, 6))
    st_ = StepState(t=0.0, pos=pos, vel=None, xquat=None, omega=None, env=_Env([R_ORB, 0, 0]))
    load.add(st_, xfrc)
    n2 = MU_EARTH / R_ORB**3
    assert xfrc[2, 0] - 1.0 == pytest.approx(2 * n2 * 10.0, rel=1e-5)  # radial stretch 2n²x
    assert xfrc[4, 1] - 1.0 == pytest.approx(-n2 * 5.0 * 2.0, rel=1e-5)  # lateral −n²y, m = 2
    assert np.all(xfrc[[0, 1, 3]] == 1.0) and np.all(xfrc[:, 3:] == 1.0)


def _dumbbell_rhs_relative(el, k, L, m):
    def rhs(t, y):
        x1, x2, v1, v2 = y[:3], y[3:6], y[6:9], y[9:]
        r_ref, _ = kepler_propagate(el, t)
        a = tidal_acceleration(r_ref, np.stack([x1, x2]))
        d = x2 - x1
        ln = np.linalg.norm(d)
        f = k * (ln - L) * d / ln  # on 1, towards 2 when stretched
        return np.r_[v1, v2, a[0] + f / m, a[1] - f / m]

    return rhs


def _dumbbell_rhs_inertial(k, L, m):
    def rhs(_t, y):
        R1, R2, V1, V2 = y[:3], y[3:6], y[6:9], y[9:]
        d = R2 - R1
        ln = np.linalg.norm(d)
        f = k * (ln - L) * d / ln
        g = point_mass_acceleration(np.stack([R1, R2]))
        return np.r_[V1, V2, g[0] + f / m, g[1] - f / m]

    return rhs


def test_dumbbell_orbit_following_matches_inertial():
    """A two-node dumbbell (1 kg each, 40 m spring, k = 1e-3 N/m) released inertially still at 30°
    from the local vertical librates and stretches; its motion relative to r_ref(t) is the same
    computed in the orbit-following world (tidal forces) and directly in ECI (full gravity)."""
    el = OrbitalElements.circular(radius=R_ORB, inclination=math.pi / 2, raan=math.pi / 2)
    T = el.period()
    m, k, L = 1.0, 1e-3, 40.0
    r0, v0 = kepler_propagate(el, 0.0)
    u = Rotation.from_euler("x", 30, degrees=True).apply(r0 / np.linalg.norm(r0))
    x1, x2 = -0.5 * L * u, 0.5 * L * u
    t_eval = np.linspace(0, T, 61)
    y0 = np.r_[x1, x2, np.zeros(6)]
    rel = solve_ivp(
        _dumbbell_rhs_relative(el, k, L, m), (0, T), y0, method="DOP853", rtol=1e-13, atol=1e-12, t_eval=t_eval
    )
    Y0 = np.r_[r0 + x1, r0 + x2, v0, v0]
    ine = solve_ivp(_dumbbell_rhs_inertial(k, L, m), (0, T), Y0, method="DOP853", rtol=1e-13, atol=1e-9, t_eval=t_eval)
    r_ref, _ = kepler_propagate(el, t_eval)
    x_from_eci = np.concatenate([ine.y[:3].T - r_ref, ine.y[3:6].T - r_ref], axis=1)
    x_rel = rel.y[:6].T
    err = np.abs(x_from_eci - x_rel).max()
    motion = np.abs(x_rel - x_rel[0]).max()
    assert motion > 1.0  # the dumbbell really moves (metres)
    assert err < 1e-4


def test_tidal_load_with_j2():
    """With J2 the tidal acceleration is g_J2(r+x) − g_J2(r) on top of the two-body part; the
    naive float64 difference of the full accelerations is good to ~1e-9 of the result for
    x ~ 100 m (cancellation of 8 m/s² terms), which bounds the check."""
    from magsail_mj.environment.gravity import gravity_acceleration

    r = np.array([3.0e6, -4.0e6, 4.9e6])
    x = np.random.default_rng(6).normal(scale=60.0, size=(5, 3))
    load = TidalGravityLoad(np.arange(1, 6), np.full(5, 2.0), j2=True)
    xfrc = np.zeros((6, 6))
    load.add(StepState(0.0, np.vstack([np.zeros(3), x]), None, None, None, _Env(r)), xfrc)
    naive = gravity_acceleration(r + x, j2=True) - gravity_acceleration(r, j2=True)
    assert np.allclose(xfrc[1:, :3], 2.0 * naive, rtol=0, atol=1e-8 * np.abs(naive).max())
    two_body = tidal_acceleration(r, x)
    assert np.abs(naive - two_body).max() > 1e-3 * np.abs(two_body).max()  # J2 part is visible
