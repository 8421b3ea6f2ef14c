"""Sun: low-precision solar ephemeris and the cylindrical Earth shadow.

Ephemeris (Astronomical Almanac low-precision formulae as given by Vallado),
accuracy about 0.01° for 1950–2050. With T = (JD − 2451545.0)/36525 (UT1 ≈ UTC):

    λ_M = 280.460° + 36000.771° T,          M = 357.5291092° + 35999.05034° T,
    λ   = λ_M + 1.914666471° sin M + 0.019994643° sin 2M,
    r_⊙ = 1.000140612 − 0.016708617 cos M − 0.000139589 cos 2M   [AU],
    ε   = 23.439291° − 0.0130042° T,
    r⃗_⊙ = r_⊙ [cos λ, cos ε sin λ, sin ε sin λ]                   [AU, ECI of date].

The result is referred to the mean equator and equinox of date, the ECI of this package
(precession neglected, see :mod:`magsail_mj.environment.frames`).

Shadow: a point r is in the cylindrical shadow when r·ŝ_⊙ < 0 and
|r − (r·ŝ_⊙) ŝ_⊙| < R_E (ŝ_⊙ the geocentric Sun direction).
"""

from __future__ import annotations

import numpy as np

from magsail_mj.environment.constants import AU
from magsail_mj.environment.timeutil import J2000_JD

__all__ = ["sun_position_eci", "sun_right_ascension", "in_cylindrical_shadow"]


def sun_position_eci(jd: float | np.ndarray) -> np.ndarray:
    """Geocentric Sun position [m] in ECI (of date) at Julian date(s) ``jd`` (..., 3)."""
    jd = np.asarray(jd, dtype=float)
    T = (jd - J2000_JD) / 36525.0
    lam_M = np.radians(280.460 + 36000.771 * T)
    M = np.radians(357.5291092 + 35999.05034 * T)
    lam = lam_M + np.radians(1.914666471 * np.sin(M) + 0.019994643 * np.sin(2 * M))
    r_au = 1.000140612 - 0.016708617 * np.cos(M) - 0.000139589 * np.cos(2 * M)
    eps = np.radians(23.439291 - 0.0130042 * T)
    return (r_au * AU)[..., None] * np.stack([np.cos(lam), np.cos(eps) * np.sin(lam), np.sin(eps) * np.sin(lam)], -1)


def sun_right_ascension(jd: float) -> float:
    """Right ascension of the Sun [rad] in [0, 2π) at Julian date ``jd``."""
    s = sun_position_eci(jd)
    return float(np.mod(np.arctan2(s[1], s[0]), 2 * np.pi))


def in_cylindrical_shadow(r: np.ndarray, sun_dir: np.ndarray, R_E: float) -> np.ndarray | bool:
    """True where the points ``r`` (..., 3) [m] lie in the cylindrical Earth shadow of radius
    ``R_E`` [m] for the geocentric Sun unit vector ``sun_dir`` (..., 3)."""
    r = np.asarray(r, dtype=float)
    s = np.asarray(sun_dir, dtype=float)
    d = np.einsum("...i,...i->...", r, s)
    perp = r - d[..., None] * s
    out = (d < 0) & (np.einsum("...i,...i->...", perp, perp) < R_E * R_E)
    return bool(out) if np.ndim(out) == 0 else out
