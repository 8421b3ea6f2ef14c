"""Argument checks and shared pieces of the structure generators: plate mass, strut damping,
uniform node masses and node-set helpers (pure NumPy)."""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "FLAT_PLATE_DRAG_COEFFICIENT",
    "check_count",
    "check_reflectivity",
    "check_positive",
    "plate_mass_kg",
    "strut_dashpot_Ns_m",
    "axial_rigidity_argument",
]


def check_positive(name: str, value: float, *, allow_zero: bool = False) -> float:
    """``value`` as a float, or a ``ValueError`` naming ``name`` unless it is finite and > 0
    (``>= 0`` with ``allow_zero``)."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: must be a number, got {value!r}") from None
    ok = math.isfinite(number) and (number >= 0 if allow_zero else number > 0)
    if not ok:
        raise ValueError(f"{name}: must be finite and {'>= 0' if allow_zero else '> 0'}, got {value!r}")
    return number


#: Free-molecular drag coefficient of a flat plate, the default of generated and imported panels.
FLAT_PLATE_DRAG_COEFFICIENT = 2.2
#: Tolerance of the sum of a reflectivity row's fractions to 1.
REFLECTIVITY_SUM_TOL = 1e-9


def check_reflectivity(name: str, value) -> np.ndarray:
    """(3,) fractions of sunlight reflected specularly, reflected diffusely and absorbed: each
    ``>= 0``, summing to 1 within :data:`REFLECTIVITY_SUM_TOL`, or a ``ValueError`` naming ``name``."""
    try:
        row = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        row = np.full(0, np.nan)
    if (
        row.shape != (3,)
        or not np.all(np.isfinite(row))
        or np.any(row < 0)
        or abs(row.sum() - 1.0) > REFLECTIVITY_SUM_TOL
    ):
        raise ValueError(
            f"{name}: must be three fractions >= 0 (specular, diffuse, absorbed) summing to 1, got {value!r}"
        )
    return row


def check_count(name: str, value: int, *, minimum: int) -> int:
    """``value`` as an int, or a ``ValueError`` naming ``name`` unless it is an integer ``>= minimum``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name}: must be an integer >= {minimum}, got {value!r}")
    return int(value)


def plate_mass_kg(*, total_mass_kg: float | None, areal_density_kg_m2: float | None, area_m2: float) -> float:
    """The plate's total mass [kg]: ``total_mass_kg``, or ``areal_density_kg_m2 · area_m2``
    (exactly one of the two must be given)."""
    if (total_mass_kg is None) == (areal_density_kg_m2 is None):
        raise ValueError(
            "total_mass_kg, areal_density_kg_m2: give exactly one, "
            f"got total_mass_kg={total_mass_kg!r}, areal_density_kg_m2={areal_density_kg_m2!r}"
        )
    if total_mass_kg is not None:
        return check_positive("total_mass_kg", total_mass_kg)
    return check_positive("areal_density_kg_m2", areal_density_kg_m2) * area_m2


def axial_rigidity_argument(EA_N: float | None, EI_Nm2: float | None) -> None:
    """Exactly one of ``EA_N`` (given directly) and ``EI_Nm2`` (calibrated to) must be given."""
    if (EA_N is None) == (EI_Nm2 is None):
        raise ValueError(f"EA_N, EI_Nm2: give exactly one, got EA_N={EA_N!r}, EI_Nm2={EI_Nm2!r}")
    if EA_N is not None:
        check_positive("EA_N", EA_N)
    else:
        check_positive("EI_Nm2", EI_Nm2)


def strut_dashpot_Ns_m(
    *,
    damping_Ns_m: float | None,
    zeta_strut: float | None,
    EA_N: float,
    shortest_m: float,
    particle_mass_kg: float,
) -> float:
    """The struts' dashpot constant ``c`` [N s/m]: ``damping_Ns_m`` as given, or from a damping
    ratio ``ζ`` as the shipped truss does, ``c = 2 ζ √(k m_p / 2)`` with ``k = EA / l_min`` the
    spring constant of the shortest strut and ``m_p`` the uniform particle mass (the two-mass
    oscillator of one strut between two particles has reduced mass ``m_p / 2``). Neither: 0."""
    if damping_Ns_m is not None and zeta_strut is not None:
        raise ValueError(f"damping_Ns_m, zeta_strut: give at most one, got {damping_Ns_m!r} and {zeta_strut!r}")
    if damping_Ns_m is not None:
        return check_positive("damping_Ns_m", damping_Ns_m, allow_zero=True)
    if zeta_strut is None:
        return 0.0
    zeta = check_positive("zeta_strut", zeta_strut, allow_zero=True)
    return 2.0 * zeta * math.sqrt(EA_N / shortest_m * particle_mass_kg / 2.0)
