"""Physical constants of the environment models (SI units).

Values follow the specs in ``spec/``: ``MU_EARTH`` is the value the truss spec (§12 item M2) and
the CNUSAIL spec (§5.1) prescribe; ``J2_EARTH``, ``R_J2`` and ``OMEGA_EARTH`` are from the
CNUSAIL spec §5.1; ``P_SUN_1AU`` from CNUSAIL §6.3; ``R_E_TRUSS`` is the truss paper's Earth
radius (truss spec §12 item O8); ``R_E_REFLECTOR`` the reflector spec's assumption A4.
"""

from __future__ import annotations

MU_EARTH: float = 3.986004418e14
"""Earth's gravitational parameter [m^3/s^2]."""

J2_EARTH: float = 1.08262668e-3
"""Second zonal harmonic of the geopotential [-] (referred to ``R_J2``)."""

R_J2: float = 6378137.0
"""Equatorial radius the J2 coefficient refers to [m] (WGS-84)."""

R_E_TRUSS: float = 6370e3
"""Earth radius of the truss paper [m] (truss spec §12 item O8)."""

R_E_REFLECTOR: float = 6371e3
"""Earth radius of the reflector paper [m] (reflector spec assumption A4)."""

R_E_WGS84: float = 6378137.0
"""WGS-84 equatorial radius [m] (CNUSAIL spec §5.1 uses it for altitudes)."""

R_IGRF: float = 6371.2e3
"""Geomagnetic reference radius of the IGRF Gauss coefficients [m]."""

OMEGA_EARTH: float = 7.2921159e-5
"""Earth's sidereal rotation rate [rad/s]."""

AU: float = 1.495978707e11
"""Astronomical unit [m]."""

P_SUN_1AU: float = 4.563e-6
"""Solar radiation pressure on a perfect absorber at 1 AU [N/m^2] (CNUSAIL spec §6.3)."""

B0_DIPOLE: float = 3.12e-5
"""Equatorial surface field of the centred dipole used by the reflector and current-loop
papers [T]."""

SECONDS_PER_DAY: float = 86400.0
