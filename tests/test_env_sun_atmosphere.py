"""Sun ephemeris and shadow, and atmosphere.

Tolerances:
* Ephemeris vs astropy (builtin ephemeris, no internet), 60 dates over 2016, in the mean equator
  and equinox of date (astropy ``PrecessedGeocentric``): the low-precision formulae are quoted at
  ~0.01°; measured max 0.0072°, asserted 0.01°. Distance: measured 6e-5 relative, asserted 2e-4.
* Exponential table continuity: the published 4-digit base values leave jumps ≤ 0.14 % (25 km)
  and ≤ 1e-4 elsewhere; asserted < 0.2 %.
* Orders of magnitude at 400/600/800 km against the U.S. Standard Atmosphere 1976 values
  (2.803e-12, 1.137e-13, 1.136e-14 kg/m³): within a factor 2.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from magsail_mj.environment.atmosphere import (
    EXPONENTIAL_TABLE,
    exponential_density,
    exponential_density_scalar,
)
from magsail_mj.environment.constants import AU
from magsail_mj.environment.sun import in_cylindrical_shadow, sun_position_eci
from magsail_mj.environment.timeutil import julian_date, parse_epoch


def test_sun_ephemeris_matches_astropy_over_a_year():
    astropy = pytest.importorskip("astropy")
    from astropy import units as u
    from astropy.coordinates import PrecessedGeocentric, get_body, solar_system_ephemeris
    from astropy.time import Time
    from astropy.utils import iers

    iers.conf.auto_download = False
    assert astropy is not None
    times = Time("2016-01-01T00:00:00", scale="utc") + np.linspace(0, 366, 60) * u.day
    with solar_system_ephemeris.set("builtin"):
        sun = get_body("sun", times)
    worst_angle, worst_dist = 0.0, 0.0
    for k, t in enumerate(times):
        ref = sun[k].transform_to(PrecessedGeocentric(equinox=t, obstime=t)).cartesian.xyz.to_value(u.m)
        mine = sun_position_eci(t.utc.jd)
        cosang = ref @ mine / np.linalg.norm(ref) / np.linalg.norm(mine)
        worst_angle = max(worst_angle, math.degrees(math.acos(min(1.0, cosang))))
        worst_dist = max(worst_dist, abs(np.linalg.norm(mine) / np.linalg.norm(ref) - 1))
    assert worst_angle < 0.01
    assert worst_dist < 2e-4


def test_sun_at_equinox_and_solstice():
    # March equinox 2020-03-20 03:50 UT: RA ≈ 0, dec ≈ 0; June solstice 2020-06-20 21:44: dec = ε
    s = sun_position_eci(julian_date(parse_epoch("2020-03-20T03:50:00Z")))
    assert abs(math.degrees(math.asin(s[2] / np.linalg.norm(s)))) < 0.01
    s = sun_position_eci(julian_date(parse_epoch("2020-06-20T21:44:00Z")))
    assert math.degrees(math.asin(s[2] / np.linalg.norm(s))) == pytest.approx(23.4366, abs=0.01)
    assert np.linalg.norm(s) / AU == pytest.approx(1.0163, abs=0.0005)  # near aphelion


def test_cylindrical_shadow_geometry():
    R = 6371e3
    s = np.array([1.0, 0.0, 0.0])
    r = 7000e3
    assert in_cylindrical_shadow(np.array([-r, 0, 0]), s, R)  # behind the Earth
    assert not in_cylindrical_shadow(np.array([r, 0, 0]), s, R)  # sunlit side
    assert not in_cylindrical_shadow(np.array([-r, 0.99 * r, 0]), s, R)  # outside the cylinder
    assert in_cylindrical_shadow(np.array([-r, 0.9 * R, 0]), s, R)
    assert not in_cylindrical_shadow(np.array([0, r, 0]), s, R)  # terminator
    pts = np.array([[-r, 0, 0], [r, 0, 0]])
    assert in_cylindrical_shadow(pts, s, R).tolist() == [True, False]


def test_exponential_table_continuity():
    h0 = EXPONENTIAL_TABLE[:, 0] * 1e3
    eps = 1e-6
    below = exponential_density(h0[1:] - eps)
    above = exponential_density(h0[1:] + eps)
    jumps = np.abs(below / above - 1)
    assert jumps.max() < 2e-3
    assert np.median(jumps) < 1e-4


@pytest.mark.parametrize("h_km, us76", [(400, 2.803e-12), (600, 1.137e-13), (800, 1.136e-14)])
def test_exponential_orders_of_magnitude(h_km, us76):
    rho = float(exponential_density(h_km * 1e3))
    assert 0.5 < rho / us76 < 2.0
    assert exponential_density_scalar(h_km * 1e3) == pytest.approx(rho, rel=1e-14)


@settings(max_examples=60, deadline=None)
@given(st.floats(-5e3, 1.5e6), st.floats(1.0, 5e4))
def test_exponential_density_monotone(h, dh):
    assert exponential_density_scalar(h + dh) < exponential_density_scalar(h)
    assert exponential_density_scalar(h) == pytest.approx(float(exponential_density(h)), rel=1e-13)


def test_msis_density_orders_of_magnitude():
    pytest.importorskip("pymsis")
    from magsail_mj.environment.atmosphere import msis_density

    d = np.array(["2016-01-01T00:00"] * 3, dtype="datetime64[ms]")
    rho = msis_density(d, np.zeros(3), np.zeros(3), np.array([400.0, 600.0, 800.0]))
    ref = exponential_density(np.array([400e3, 600e3, 800e3]))
    assert np.all(np.abs(np.log10(rho / ref)) < 1.0)  # same decade at moderate activity
