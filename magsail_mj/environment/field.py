"""Geomagnetic field models, evaluated in ECI components [T].

* **IGRF** (IGRF-14 through ``ppigrf.igrf_gc``): geocentric spherical input (radius [km],
  colatitude [deg], east longitude [deg]) in ECEF, output (B_r, B_θ south, B_φ east) [nT].
  :func:`igrf_eci` converts ECI points to ECEF with the GMST rotation, calls ppigrf **once per
  chunk of points** (vectorised; ~40 µs per point instead of ~13 ms per scalar call), rotates
  (B_r, B_θ, B_φ) to ECEF and back to ECI, and converts nT → T. One date (the epoch's) is used
  for a whole run: secular variation is ~0.1 nT/day.
* **Centred dipole**: B = B0 (R/r)³ [3 (m̂·r̂) r̂ − m̂], m̂ the unit dipole moment, B0 the
  equatorial field at radius R. *Aligned*: m̂ = −ẑ (Earth-like: the field points north at the
  equator). *Tilted*: m̂ fixed in ECEF from the IGRF degree-1 Gauss coefficients at the epoch,
  g⃗ = (g11, h11, g10): B = (a/r)³ [3 (g⃗·r̂) r̂ − g⃗], so m̂ = g⃗/|g⃗|, B0 = |g⃗|, R = a = 6371.2 km.
* **Planar dipole** of the reflector paper (Eq. 11, as printed): in the
  orbit plane xz with θ the in-plane angle from the equator,
  B_r = −2 B0 (R/r)³ sin θ, B_θ = −B0 (R/r)³ cos θ, ê_θ = (−sin θ, 0, cos θ). Its Cartesian
  form, extended axisymmetrically about z to points off the xz plane, is
  B = −B0 (R/r)³ [(z/r)(x/r), (z/r)(y/r), 1 + (z/r)²]. Note: the magnitude equals that of a
  centred aligned dipole, B0 (R/r)³ √(1 + 3 sin²θ), but the direction differs from a physical
  dipole away from the equator and the poles (the printed B_θ has the opposite sign relative to
  B_r); we take the overall sign of this field not to matter for the reflector runs and
  implement the formula as printed. Use ``model = "dipole"`` for the physical aligned dipole.
* **Constant**: a fixed vector in world (ECI-parallel) axes.
"""

from __future__ import annotations

from datetime import datetime, timezone
from functools import lru_cache

import numpy as np
import ppigrf

from magsail_mj.environment.constants import R_IGRF
from magsail_mj.environment.frames import (
    cartesian_to_spherical,
    ecef_to_eci,
    eci_to_ecef,
    spherical_vector_to_cartesian,
)

__all__ = [
    "igrf_ecef",
    "igrf_eci",
    "igrf_dipole_coefficients",
    "dipole_field",
    "aligned_dipole_field",
    "tilted_dipole_field_eci",
    "planar_dipole_field",
]

_CHUNK = 8000  # points per ppigrf call (bounds its (n, 208) work matrices to ~100 MB)
_POLE_GUARD_DEG = 1e-7  # ppigrf divides B_phi by sin(colatitude)


def _naive_utc(date: datetime) -> datetime:
    if date.tzinfo is not None:
        date = date.astimezone(timezone.utc).replace(tzinfo=None)
    return date


def igrf_ecef(r_ecef: np.ndarray, date: datetime, *, max_degree: int = 13) -> np.ndarray:
    """IGRF field [T] in ECEF components at ECEF points ``r_ecef`` (n, 3) [m], one ``date``.

    Vectorised: one ``ppigrf.igrf_gc`` call per chunk of up to 8000 points.
    """
    r_ecef = np.atleast_2d(np.asarray(r_ecef, dtype=float))
    rad, colat, lon = cartesian_to_spherical(r_ecef)
    colat_deg = np.clip(np.degrees(colat), _POLE_GUARD_DEG, 180.0 - _POLE_GUARD_DEG)
    lon_deg = np.degrees(lon)
    out = np.empty_like(r_ecef)
    d = _naive_utc(date)
    for s in range(0, len(r_ecef), _CHUNK):
        sl = slice(s, s + _CHUNK)
        Br, Bt, Bp = ppigrf.igrf_gc(rad[sl] / 1e3, colat_deg[sl], lon_deg[sl], d, max_degree=max_degree)
        out[sl] = spherical_vector_to_cartesian(Br[0], Bt[0], Bp[0], np.radians(colat_deg[sl]), np.radians(lon_deg[sl]))
    return out * 1e-9


def igrf_eci(r_eci: np.ndarray, gmst: np.ndarray, date: datetime, *, max_degree: int = 13) -> np.ndarray:
    """IGRF field [T] in ECI components at ECI points ``r_eci`` (n, 3) [m] with GMST angles
    ``gmst`` (n,) [rad] (ECEF = R3(θ) ECI), one coefficient ``date`` for all points."""
    r_ecef = eci_to_ecef(r_eci, gmst)
    return ecef_to_eci(igrf_ecef(r_ecef, date, max_degree=max_degree), gmst)


@lru_cache(maxsize=32)
def _dipole_coeffs_cached(date: datetime) -> tuple[float, float, float]:
    # Degree-1 field at r = a on the equator at longitude 0 (r̂ = x̂): B = 3 (g⃗·x̂) x̂ − g⃗ =
    # (2 g11, −h11, −g10) in ECEF, with ê_r = x̂, ê_θ = −ẑ, ê_φ = ŷ there.
    Br, Bt, Bp = ppigrf.igrf_gc(R_IGRF / 1e3, 90.0, 0.0, date, max_degree=1)
    return float(Bt.ravel()[0]), float(Br.ravel()[0]) / 2.0, -float(Bp.ravel()[0])


def igrf_dipole_coefficients(date: datetime) -> tuple[float, float, float]:
    """IGRF degree-1 Gauss coefficients (g10, g11, h11) [nT] at ``date``, recovered from one
    degree-1 ``ppigrf.igrf_gc`` evaluation (so they are interpolated in time exactly as ppigrf
    interpolates the full model)."""
    return _dipole_coeffs_cached(_naive_utc(date))


def dipole_field(r: np.ndarray, m_hat: np.ndarray, *, B0: float, R: float) -> np.ndarray:
    """Centred dipole B = B0 (R/r)³ [3 (m̂·r̂) r̂ − m̂] [T] at points ``r`` (..., 3) [m].

    ``m_hat`` (3,) or (..., 3): unit moment direction in the same frame as ``r``; ``B0`` [T] the
    equatorial field at radius ``R`` [m].
    """
    r = np.asarray(r, dtype=float)
    m = np.asarray(m_hat, dtype=float)
    rn = np.linalg.norm(r, axis=-1, keepdims=True)
    u = r / rn
    mu_ = np.einsum("...i,...i->...", m, u)[..., None]
    return B0 * (R / rn) ** 3 * (3.0 * mu_ * u - m)


def aligned_dipole_field(r: np.ndarray, *, B0: float, R: float) -> np.ndarray:
    """Centred dipole aligned with the rotation axis, moment along −z (ECI = ECEF here) [T]."""
    return dipole_field(r, np.array([0.0, 0.0, -1.0]), B0=B0, R=R)


def tilted_dipole_field_eci(
    r_eci: np.ndarray, gmst: np.ndarray, m_hat_ecef: np.ndarray, *, B0: float, R: float
) -> np.ndarray:
    """Tilted centred dipole fixed in ECEF (moment ``m_hat_ecef``), evaluated at ECI points
    ``r_eci`` (n, 3) with GMST angles ``gmst`` (n,); result in ECI components [T]."""
    m_eci = ecef_to_eci(np.broadcast_to(np.asarray(m_hat_ecef, float), np.shape(r_eci)), gmst)
    return dipole_field(r_eci, m_eci, B0=B0, R=R)


def planar_dipole_field(r: np.ndarray, *, B0: float, R: float) -> np.ndarray:
    """Reflector paper's planar dipole field (Eq. 11 as printed; module docstring) [T]:
    B = −B0 (R/r)³ [(z/r)(x/r), (z/r)(y/r), 1 + (z/r)²] at points ``r`` (..., 3) [m]."""
    r = np.asarray(r, dtype=float)
    rn = np.linalg.norm(r, axis=-1)
    s = r[..., 2] / rn
    k = -B0 * (R / rn) ** 3
    return np.stack([k * s * r[..., 0] / rn, k * s * r[..., 1] / rn, k * (1.0 + s * s)], -1)


def igrf_dipole(date: datetime) -> tuple[np.ndarray, float, float]:
    """Tilted-dipole parameters from IGRF at ``date``: (m̂ in ECEF, B0 [T], R [m])."""
    g10, g11, h11 = igrf_dipole_coefficients(date)
    g = np.array([g11, h11, g10])
    B0 = float(np.linalg.norm(g))
    return g / B0, B0 * 1e-9, R_IGRF
