"""Physical constants of the environment models (SI units).

``MU_EARTH`` is the value used for the truss orbit (Robb et al. 2022a) and the CNUSAIL-1 orbit
(Yoo et al. 2016, Table 1); ``J2_EARTH``, ``R_J2`` and ``OMEGA_EARTH`` are the standard values for
the CNUSAIL-1 J2 orbit; ``P_SUN_1AU`` is the solar radiation pressure of the CNUSAIL-1 sail model
(Yoo et al. 2016, Eqs. 16–22); ``R_E_TRUSS`` is the truss paper's Earth radius; ``R_E_REFLECTOR``
the Earth radius we assume for the reflector (Robb et al. 2020 does not state one).
"""

from __future__ import annotations

MU_EARTH: float = 3.986004418e14
"""Earth's gravitational parameter [m^3/s^2]."""

J2_EARTH: float = 1.08262668e-3
"""Second zonal harmonic of the geopotential [-] (referred to ``R_J2``)."""

R_J2: float = 6378137.0
"""Equatorial radius the J2 coefficient refers to [m] (WGS-84)."""

R_E_TRUSS: float = 6370e3
"""Earth radius of the truss paper [m]."""

R_E_REFLECTOR: float = 6371e3
"""Earth radius of the reflector paper [m] (assumed; Robb et al. 2020 does not state it)."""

R_E_WGS84: float = 6378137.0
"""WGS-84 equatorial radius [m] (uses it for altitudes)."""

R_IGRF: float = 6371.2e3
"""Geomagnetic reference radius of the IGRF Gauss coefficients [m]."""

OMEGA_EARTH: float = 7.2921159e-5
"""Earth's sidereal rotation rate [rad/s]."""

AU: float = 1.495978707e11
"""Astronomical unit [m]."""

P_SUN_1AU: float = 4.563e-6
"""Solar radiation pressure on a perfect absorber at 1 AU [N/m^2] (Yoo et al. 2016, Eqs. 16–22)."""

B0_DIPOLE: float = 3.12e-5
"""Equatorial surface field of the centred dipole used by the reflector and current-loop
papers [T]."""

SECONDS_PER_DAY: float = 86400.0
