"""Atmosphere: exponential density table (0–1000 km) and NRLMSISE-00 / MSIS 2 through pymsis.

Exponential model (paper Eq. 14, base values of Vallado's Table 8-4):

    ρ(h) = ρ0 exp(−(h − h0)/H),

with the row of the largest base altitude h0 ≤ h; h = |r| − R_E (spherical Earth). Below 0 km
the first row, above 1000 km the last row is extrapolated. The published table is continuous to
0.14 % at its band edges (largest jump at 25 km; all others ≤ 1e-4), see the README (Atmosphere).

MSIS (optional extra ``magsail_mj[msis]``): ``pymsis.calculate`` with F10.7, F10.7A and Ap
always passed explicitly (otherwise pymsis tries to download space-weather files; the machines
have no internet).
"""

from __future__ import annotations

import bisect
import math
from datetime import datetime

import numpy as np

__all__ = ["EXPONENTIAL_TABLE", "exponential_density", "exponential_density_scalar", "msis_density"]

# h0 [km], rho0 [kg/m^3], H [km]
EXPONENTIAL_TABLE = np.array(
    [
        (0, 1.225, 7.249),
        (25, 3.899e-2, 6.349),
        (30, 1.774e-2, 6.682),
        (40, 3.972e-3, 7.554),
        (50, 1.057e-3, 8.382),
        (60, 3.206e-4, 7.714),
        (70, 8.770e-5, 6.549),
        (80, 1.905e-5, 5.799),
        (90, 3.396e-6, 5.382),
        (100, 5.297e-7, 5.877),
        (110, 9.661e-8, 7.263),
        (120, 2.438e-8, 9.473),
        (130, 8.484e-9, 12.636),
        (140, 3.845e-9, 16.149),
        (150, 2.070e-9, 22.523),
        (180, 5.464e-10, 29.740),
        (200, 2.789e-10, 37.105),
        (250, 7.248e-11, 45.546),
        (300, 2.418e-11, 53.628),
        (350, 9.518e-12, 53.298),
        (400, 3.725e-12, 58.515),
        (450, 1.585e-12, 60.828),
        (500, 6.967e-13, 63.822),
        (600, 1.454e-13, 71.835),
        (700, 3.614e-14, 88.667),
        (800, 1.170e-14, 124.64),
        (900, 5.245e-15, 181.05),
        (1000, 3.019e-15, 268.00),
    ]
)
_H0_KM = EXPONENTIAL_TABLE[:, 0].tolist()
_ROWS = [(float(h0) * 1e3, float(r0), float(H) * 1e3) for h0, r0, H in EXPONENTIAL_TABLE]


def exponential_density(h: np.ndarray | float) -> np.ndarray:
    """Density [kg/m³] of the exponential model at geometric altitudes ``h`` [m] (vectorised)."""
    h = np.asarray(h, dtype=float)
    k = np.clip(np.searchsorted(EXPONENTIAL_TABLE[:, 0] * 1e3, h, side="right") - 1, 0, len(_ROWS) - 1)
    h0 = EXPONENTIAL_TABLE[k, 0] * 1e3
    return EXPONENTIAL_TABLE[k, 1] * np.exp(-(h - h0) / (EXPONENTIAL_TABLE[k, 2] * 1e3))


def exponential_density_scalar(h: float) -> float:
    """Scalar fast path of :func:`exponential_density` (a few hundred ns; used per step)."""
    k = bisect.bisect_right(_H0_KM, h * 1e-3) - 1
    h0, r0, H = _ROWS[min(max(k, 0), len(_ROWS) - 1)]
    return r0 * math.exp(-(h - h0) / H)


def msis_density(
    dates: np.ndarray,
    lon_deg: np.ndarray,
    lat_deg: np.ndarray,
    alt_km: np.ndarray,
    *,
    f107: float = 150.0,
    f107a: float = 150.0,
    ap: float = 15.0,
    version: float = 0,
) -> np.ndarray:
    """Total mass density [kg/m³] from pymsis (NRLMSISE-00 for ``version=0``) at equal-length
    1-D arrays of UTC ``dates`` (numpy datetime64), geodetic longitude/latitude [deg] and
    altitude [km]. The space-weather indices are passed explicitly (all seven Ap values = ``ap``).

    Raises ImportError naming the ``msis`` extra when pymsis is not installed.
    """
    try:
        import pymsis
    except ModuleNotFoundError as err:  # pragma: no cover - depends on the install
        raise ImportError(
            "atmosphere.model = 'msis' needs the optional package pymsis (pip install 'magsail_mj[msis]')"
        ) from err
    n = len(alt_km)
    out = pymsis.calculate(
        np.asarray(dates, dtype="datetime64[ms]"),
        np.asarray(lon_deg, float),
        np.asarray(lat_deg, float),
        np.asarray(alt_km, float),
        f107s=np.full(n, float(f107)),
        f107as=np.full(n, float(f107a)),
        aps=np.full((n, 7), float(ap)),
        version=version,
    )
    return np.asarray(out, dtype=float).reshape(n, -1)[:, 0]


def ecef_to_geodetic(r_ecef: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Geodetic longitude [deg], latitude [deg] and height [km] on WGS-84 of ECEF points [m]
    (Bowring's method, iterated; sub-millimetre for LEO)."""
    a = 6378137.0
    f = 1 / 298.257223563
    e2 = f * (2 - f)
    b = a * (1 - f)
    x, y, z = r_ecef[..., 0], r_ecef[..., 1], r_ecef[..., 2]
    p = np.hypot(x, y)
    lon = np.arctan2(y, x)
    lat = np.arctan2(z, p * (1 - e2))
    for _ in range(5):
        N = a / np.sqrt(1 - e2 * np.sin(lat) ** 2)
        h = p / np.maximum(np.cos(lat), 1e-12) - N
        lat = np.arctan2(z, p * (1 - e2 * N / (N + h)))
    N = a / np.sqrt(1 - e2 * np.sin(lat) ** 2)
    h = np.where(np.abs(np.cos(lat)) > 1e-9, p / np.cos(lat) - N, np.abs(z) - b)
    return np.degrees(lon), np.degrees(lat), h / 1e3


def _as_datetime64(epoch: datetime, t: np.ndarray) -> np.ndarray:
    base = np.datetime64(epoch.replace(tzinfo=None), "ms")
    return base + np.round(np.asarray(t) * 1e3).astype("timedelta64[ms]")
