"""Time: scenario epochs (UTC), Julian dates and Greenwich mean sidereal time.

UT1 is taken equal to UTC (|UT1 − UTC| < 0.9 s, i.e. < 4e-3° of Earth rotation), as the CNUSAIL
prescribes. Simulation time ``t`` is seconds since the scenario epoch.
"""

from __future__ import annotations

import math
from datetime import datetime, timezone

import numpy as np

__all__ = [
    "parse_epoch",
    "julian_date",
    "gmst_rad",
    "gmst_rate_rad_s",
    "J2000_JD",
]

J2000_JD = 2451545.0
"""Julian date of the J2000.0 epoch (2000-01-01 12:00 TT, used here on the UT1 scale)."""


def parse_epoch(text: str) -> datetime:
    """Parse an ISO 8601 date-time into an aware UTC ``datetime``.

    Accepts ``"2020-01-01T00:00:00Z"``, ``"2020-01-01T00:00:00+00:00"``, ``"2020-01-01 00:00"``
    and plain dates ``"2020-01-01"``; a string without an offset is read as UTC.

    Raises:
      ValueError naming ``epoch`` when ``text`` is not ISO 8601 or lies outside 1900–2100
      (the range of the Julian-date formula).
    """
    if not isinstance(text, str):
        raise ValueError(f"epoch: must be an ISO 8601 UTC string such as '2020-01-01T00:00:00Z', got {text!r}")
    try:
        dt = datetime.fromisoformat(text.strip().replace("z", "Z"))
    except ValueError:
        raise ValueError(
            f"epoch: must be an ISO 8601 UTC string such as '2020-01-01T00:00:00Z', got {text!r}"
        ) from None
    dt = dt.replace(tzinfo=timezone.utc) if dt.tzinfo is None else dt.astimezone(timezone.utc)
    if not 1900 <= dt.year <= 2100:
        raise ValueError(f"epoch: year must be within 1900–2100, got {text!r}")
    return dt


def julian_date(dt: datetime) -> float:
    """Julian date of a UTC date-time (UT1 = UTC), Vallado's algorithm:

    JD = 367 Y − ⌊7 (Y + ⌊(M + 9)/12⌋)/4⌋ + ⌊275 M/9⌋ + D + 1721013.5 + (h + (m + s/60)/60)/24,

    valid 1900–2100. A naive ``datetime`` is read as UTC.
    """
    if dt.tzinfo is not None:
        dt = dt.astimezone(timezone.utc)
    y, mo, d = dt.year, dt.month, dt.day
    sec = dt.second + dt.microsecond * 1e-6
    jd_day = 367 * y - (7 * (y + (mo + 9) // 12)) // 4 + (275 * mo) // 9 + d + 1721013.5
    return jd_day + (dt.hour + (dt.minute + sec / 60.0) / 60.0) / 24.0


def gmst_rad(jd_ut1: float | np.ndarray) -> float | np.ndarray:
    """Greenwich mean sidereal time [rad] in [0, 2π), IAU-82:

    T = (JD − 2451545.0)/36525,
    θ[s] = 67310.54841 + (876600·3600 + 8640184.812866) T + 0.093104 T² − 6.2e-6 T³ (mod 86400),
    θ[rad] = θ[s] · 2π/86400.

    Vectorised over ``jd_ut1``. ECEF = R_z(θ) · ECI (precession/nutation neglected).
    """
    jd = np.asarray(jd_ut1, dtype=float)
    T = (jd - J2000_JD) / 36525.0
    sec = 67310.54841 + (876600.0 * 3600.0 + 8640184.812866) * T + 0.093104 * T**2 - 6.2e-6 * T**3
    theta = np.mod(sec, 86400.0) * (2.0 * math.pi / 86400.0)
    return float(theta) if theta.ndim == 0 else theta


def gmst_rate_rad_s(jd_ut1: float) -> float:
    """Time derivative of :func:`gmst_rad` [rad/s] at ``jd_ut1`` (≈ 7.2921159e-5 rad/s)."""
    T = (jd_ut1 - J2000_JD) / 36525.0
    dsec_dT = (876600.0 * 3600.0 + 8640184.812866) + 2 * 0.093104 * T - 3 * 6.2e-6 * T**2
    return dsec_dT / (36525.0 * 86400.0) * (2.0 * math.pi / 86400.0)
