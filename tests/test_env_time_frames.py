"""Time and frames: Julian date, GMST, ECI <-> ECEF, spherical coordinates, orbital frames,
quaternions.

Reference values are published ones, not outputs of this code:
* JD of J2000.0 (2000-01-01 12:00) = 2451545.0; Vallado Example 3-4: 1996-10-26 14:20 UT ->
  JD 2450383.09722222.
* GMST, Vallado Example 3-5: 1992-08-20 12:14 UT1 -> 152.578787886 deg (IAU-82); the
  CNUSAIL-1 epoch 2016-01-01 0h -> 100.09 deg (hand-computed, 2 decimals).
Round trips are exact algebra: tolerances are a few ulps of the magnitudes involved.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from magsail_mj.environment.frames import (
    cartesian_to_spherical,
    ecef_to_eci,
    eci_to_ecef,
    lvlh_frame,
    orbital_frame_R,
    quat_to_mat,
    spherical_to_cartesian,
    spherical_vector_to_cartesian,
)
from magsail_mj.environment.orbit import OrbitalElements, kepler_propagate
from magsail_mj.environment.timeutil import gmst_rad, gmst_rate_rad_s, julian_date, parse_epoch

finite = st.floats(-1e7, 1e7, allow_nan=False)


def test_julian_date_published_values():
    assert julian_date(parse_epoch("2000-01-01T12:00:00Z")) == pytest.approx(2451545.0, abs=1e-9)
    assert julian_date(parse_epoch("1996-10-26T14:20:00Z")) == pytest.approx(2450383.09722222, abs=1e-8)


def test_julian_date_matches_astropy():
    from astropy.time import Time

    for text in ("1972-03-01T06:00:00", "1987-04-10T19:21:00", "2020-01-01T00:00:00", "2025-06-30T23:59:00"):
        # astropy's UTC JD counts days of 86400 SI seconds, as this formula does
        assert julian_date(parse_epoch(text)) == pytest.approx(Time(text, scale="utc").jd, abs=1e-9)


@pytest.mark.parametrize(
    "epoch, gmst_deg, tol_deg",
    [
        ("1992-08-20T12:14:00Z", 152.578787886, 1e-6),  # Vallado Ex. 3-5 (9 digits given)
        ("2016-01-01T00:00:00Z", 100.09, 0.005),  # CNUSAIL-1 epoch (hand-computed, 2 decimals)
    ],
)
def test_gmst_published(epoch, gmst_deg, tol_deg):
    assert math.degrees(gmst_rad(julian_date(parse_epoch(epoch)))) == pytest.approx(gmst_deg, abs=tol_deg)


def test_gmst_rate_is_sidereal():
    # one sidereal day is 86164.0905 s: the rate is 2π over it (to the 1e-9 of the formula's T term)
    assert gmst_rate_rad_s(2458849.5) == pytest.approx(2 * math.pi / 86164.0905, rel=1e-8)


def test_parse_epoch_errors_name_epoch():
    with pytest.raises(ValueError, match="epoch"):
        parse_epoch("yesterday")
    with pytest.raises(ValueError, match="1900"):
        parse_epoch("2200-01-01T00:00:00Z")
    assert parse_epoch("2020-01-01T01:00:00+01:00") == parse_epoch("2020-01-01T00:00:00Z")


@settings(max_examples=50, deadline=None)
@given(st.tuples(finite, finite, finite), st.floats(-10, 10))
def test_eci_ecef_round_trip(v, theta):
    v = np.array(v)
    back = ecef_to_eci(eci_to_ecef(v, theta), theta)
    assert np.allclose(back, v, rtol=0, atol=1e-15 * max(1.0, np.abs(v).max()) * 8)
    assert np.linalg.norm(eci_to_ecef(v, theta)) == pytest.approx(np.linalg.norm(v), rel=1e-14, abs=1e-300)


def test_ecef_rotation_sense():
    # Greenwich (ECEF +x) lies at ECI right ascension θ_GMST
    th = 0.7
    assert np.allclose(eci_to_ecef(np.array([math.cos(th), math.sin(th), 0.0]), th), [1, 0, 0], atol=1e-15)


@settings(max_examples=50, deadline=None)
@given(st.floats(1.0, 1e8), st.floats(1e-6, math.pi - 1e-6), st.floats(-math.pi + 1e-9, math.pi))
def test_spherical_round_trip(rad, colat, lon):
    p = spherical_to_cartesian(rad, colat, lon)
    r2, c2, l2 = cartesian_to_spherical(p)
    assert r2 == pytest.approx(rad, rel=1e-14)
    assert c2 == pytest.approx(colat, abs=1e-12)
    assert math.cos(l2 - lon) == pytest.approx(1.0, abs=1e-12)


def test_spherical_unit_vectors_are_coordinate_derivatives():
    # ê_r, ê_θ, ê_φ from finite differences of the point map (independent of the closed forms)
    rad, th, ph, h = 7.0e6, 0.9, -2.1, 1e-6
    er = spherical_vector_to_cartesian(1.0, 0.0, 0.0, th, ph)
    et = spherical_vector_to_cartesian(0.0, 1.0, 0.0, th, ph)
    ep = spherical_vector_to_cartesian(0.0, 0.0, 1.0, th, ph)
    d_r = (spherical_to_cartesian(rad + 1.0, th, ph) - spherical_to_cartesian(rad - 1.0, th, ph)) / 2.0
    d_t = (spherical_to_cartesian(rad, th + h, ph) - spherical_to_cartesian(rad, th - h, ph)) / (2 * h * rad)
    d_p = (spherical_to_cartesian(rad, th, ph + h) - spherical_to_cartesian(rad, th, ph - h)) / (
        2 * h * rad * math.sin(th)
    )
    for a, b in ((er, d_r), (et, d_t), (ep, d_p)):
        assert np.allclose(a, b, atol=1e-8)


def test_orbital_frames():
    el = OrbitalElements(a=6963.1e3, e=0.01939, i=math.radians(98), raan=1.37, argp=0.0, nu0=0.3)
    r, v = kepler_propagate(el, np.array([0.0, 1000.0, 2500.0]))
    for Rm in (orbital_frame_R(r, v), lvlh_frame(r, v)):
        assert np.allclose(Rm @ np.swapaxes(Rm, -1, -2), np.eye(3), atol=1e-14)
        assert np.allclose(np.linalg.det(Rm), 1.0, atol=1e-14)
    R = orbital_frame_R(r, v)
    h = np.cross(r, v)
    assert np.allclose(R[:, 2], r / np.linalg.norm(r, axis=1)[:, None], atol=1e-15)  # zenith
    assert np.allclose(R[:, 1], -h / np.linalg.norm(h, axis=1)[:, None], atol=1e-15)  # −orbit normal
    # x_R ≈ −v̂ within the flight-path angle (≤ e = 0.019 rad)
    cosang = -np.einsum("ij,ij->i", R[:, 0], v / np.linalg.norm(v, axis=1)[:, None])
    assert np.all(cosang > math.cos(0.02))


@settings(max_examples=30, deadline=None)
@given(st.tuples(*[st.floats(-1, 1)] * 4).filter(lambda q: sum(c * c for c in q) > 1e-3))
def test_quat_to_mat_matches_mujoco(q):
    import mujoco

    q = np.array(q) / np.linalg.norm(q)
    m = np.zeros(9)
    mujoco.mju_quat2Mat(m, q)
    assert np.allclose(quat_to_mat(q), m.reshape(3, 3), atol=1e-14)
