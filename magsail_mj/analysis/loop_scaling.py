"""Thermal and length-scaling model of current loops built into a printed truss.

Robb et al. 2022b, Eqs. 2–11, with a reconstructed Table 1 and the misprints corrected where each
equation is stated. SI units throughout (m, kg, s, A, T, W, K, Ω).

Heat balance of a solid round copper wire that only radiates (no Sun, Robb et al. 2022b, Eqs. 2–11)::

    P_J = I² R,   R = R_r [1 + α (Γ − Γ_r)],   R_r = 4 ρ_r l / (π d²)
    P_rad = ε σ_B π d l Γ⁴

At equilibrium ``P_J = P_rad`` at ``Γ = Γ_e``; the length ``l`` cancels and, with the ``I²`` the
printed Eq. 6 drops restored::

    d = [4 ρ_r f_Γ I² / (π² ε σ_B Γ_e⁴)]^{1/3},        f_Γ = 1 + α (Γ_e − Γ_r)

Dipole field over the equator ``B = B0 (R_E/R_o)³`` with ``R_o = R_E + h`` the geocentric radius
 (Eq. 7). Peak gravity-gradient torque of a uniform square plate, normal at 45° to nadir
(Eq. 8)::

    T_g,max = 3 μ (i3 − i1) / (2 R_o³) = μ M D² / (8 R_o³)

Setting ``I A_e B = T_g,max`` the ``R_o³`` cancels (Eq. 9, altitude independent)::

    I = μ σ_A D⁴ / (8 A_e B0 R_E³),        m_max = I A_e = μ σ_A D⁴ / (8 B0 R_E³)

Conductor mass fraction (Eqs. 10–11 with the copper density restored and the path length ``l``
read for the printed "I")::

    M_c = ρ_c π d² l / 4,   λ_f = M_c / (σ_A D²) = C1 G(N) D^{5/3} σ_A^{1/3}
    C1 = [μ⁴ ρ_c³ ρ_r² f_Γ² / (16384 π Γ_e⁸ ε² σ_B² B0⁴ R_E¹²)]^{1/3},   G = D^{5/3} l / A_e^{4/3}

Geometry A (one perimeter loop) carries its conductor at the rim; the paper's inertia
``i1 = [(M − M_c)/12 + k_c M_c] D²`` (``k_c = 4/3``) gives, with ``κ = 12 k_c − 1``::

    I_A = I_u (1 + κ λ_f),   λ_f = λ_u (1 + κ λ_f)^{4/3},   λ_u = 4 C1 D^{5/3} σ_A^{1/3}

``h(λ) = λ (1 + κλ)^{-4/3}`` peaks at ``λ* = 3/κ`` with ``h* = (3/κ) 4^{-4/3}``: below ``h*`` there
is a light and a heavy branch, above it no solution (:class:`NoLoopSolution`). Default ``κ = 15``
(paper); ``κ = 1`` is the physical value of a square perimeter wire.

``Γ_r = 293.15 K`` is assumed (value lost in the source). The B sizing uses the
Table-1 form with ``n = ceil(N/2)`` loops even for odd ``N``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from typing import Literal

import numpy as np
from scipy.optimize import brentq

from magsail_mj.analysis.scaling import require_finite

__all__ = [
    "DEFAULT_CONSTANTS",
    "GEOMETRIES",
    "NoLoopSolution",
    "ThermalConstants",
    "b_loop_count",
    "c1",
    "conductor_mass",
    "dipole_max",
    "field_magnitude",
    "fold_A",
    "geometry_factor",
    "geometry_factor_b_loops",
    "gravity_gradient_torque_max",
    "h_A",
    "joule_power",
    "lambda_f",
    "lambda_f_chain",
    "lambda_u_A",
    "loop_sizing",
    "normalize_geometry",
    "radiated_power",
    "required_current",
    "scaling_table",
    "side_max",
    "solve_lambda_A",
    "sunlight_diameter_ratio",
    "table1",
    "trace_branches_A",
    "uniform_curves",
    "wire_diameter",
]

GEOMETRIES: tuple[str, ...] = ("A", "B", "C", "D")
"""Loop geometries with a sizing form. C_x/C_y and D_x/D_y share the C and D forms."""


@dataclass(frozen=True)
class ThermalConstants:
    """Physical constants of the thermal/scaling model ("Table 2, lower-left block").

    Field names follow the ``thermal.*`` config keys where one exists.
    """

    rho_c_kg_m3: float = 8960.0
    """Copper density ρ_c [kg/m³]."""
    T_ref_K: float = 293.15
    """Reference temperature Γ_r [K] (assumed 20 °C)."""
    T_eq_K: float = 420.0
    """Equilibrium (maximum) wire temperature Γ_e [K]."""
    rho_ref_ohmm: float = 1.68e-8
    """Resistivity at Γ_r, ρ_r [Ω m]."""
    emissivity: float = 0.7
    """Grey-body emissivity ε [-] (also the solar absorptance in the sunlight check)."""
    alpha_per_K: float = 0.00404
    """Temperature coefficient of resistivity α [1/K]."""
    sigma_B: float = 5.67e-8
    """Stefan–Boltzmann constant σ_B [W m⁻² K⁻⁴]."""
    B0_T: float = 3.12e-5
    """Equatorial surface field of the dipole B0 [T]."""
    mu_m3_s2: float = 3.986e14
    """Earth's gravitational parameter μ [m³/s²] (this paper's value)."""
    R_E_m: float = 6370e3
    """Earth mean radius R_E [m]."""
    mu0_H_m: float = 4e-7 * math.pi
    """Vacuum permeability μ0 [H/m] (self-field estimates)."""
    solar_flux_W_m2: float = 1360.0
    """Solar constant of the optional sunlight check [W/m²]."""

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"ThermalConstants.{name}: must be a finite number > 0, got {value!r}")

    @property
    def f_gamma(self) -> float:
        """Resistance factor at equilibrium, ``f_Γ = 1 + α (Γ_e − Γ_r)`` [-]."""
        return 1.0 + self.alpha_per_K * (self.T_eq_K - self.T_ref_K)


DEFAULT_CONSTANTS = ThermalConstants()


class NoLoopSolution(ValueError):
    """Geometry A has no conductor fraction that balances the torque (``λ_u > h*``)."""


# ----------------------------------------------------------------------------- validation helpers


def _positive(name: str, value) -> np.ndarray:
    v = np.asarray(value, dtype=float)
    if v.size == 0 or not np.all(np.isfinite(v)) or np.any(v <= 0):
        raise ValueError(f"{name}: must be finite and > 0, got {value!r}")
    return v


def _out(v):
    return float(v) if np.ndim(v) == 0 else np.asarray(v)


def _units(units) -> int:
    if isinstance(units, bool) or not isinstance(units, (int, np.integer)) or units < 1:
        raise ValueError(f"units: must be an integer >= 1 (cubic units per side N), got {units!r}")
    return int(units)


def _kappa(kappa) -> float:
    try:
        k = float(kappa)
    except (TypeError, ValueError):
        raise ValueError(f"kappa: must be a finite number >= 0, got {kappa!r}") from None
    if not math.isfinite(k) or k < 0:
        raise ValueError(
            f"kappa: must be a finite number >= 0 (κ = 12 k_c − 1; paper 15, square perimeter wire 1), got {kappa!r}"
        )
    return k


def normalize_geometry(geometry: str) -> str:
    """``"A" | "B" | "C" | "D"`` from a geometry name (case-insensitive; ``Cx, Cy, Dx, Dy`` map to C, D)."""
    if isinstance(geometry, str):
        g = geometry.strip().upper().replace("_", "")
        if g in GEOMETRIES:
            return g
        if g in ("CX", "CY", "DX", "DY"):
            return g[0]
    raise ValueError(f"geometry: must be one of A, B, C, D (or Cx, Cy, Dx, Dy), got {geometry!r}")


# ----------------------------------------------------------------------------- Table 1


def b_loop_count(units: int) -> int:
    """Number of concentric loops of geometry B, ``n = ceil(N/2)``."""
    return (_units(units) + 1) // 2


def _table1_unit(g: str, N: int) -> tuple[float, float]:
    """Table-1 ``(A_e/D², l/D)`` of geometry ``g`` at ``N`` units per side."""
    if g == "A":
        return 1.0, 4.0
    if g == "B":
        n = (N + 1) // 2
        return (n + 1) * (2 * n + 1) / (6 * n), 2.0 * (n + 1)
    if g == "C":
        return (N + 1) / N, 2.0 * (N + 1) ** 2 / N
    return 0.75 * (N + 1) / N, 1.5 * (N + 1) ** 2 / N + 1.0


def table1(geometry: str, units: int, side_m):
    """Sizing-form enclosed area and path length ``(A_e [m²], l [m])`` (Table 1).

    ================  ==============================  =========================
    geometry          ``A_e``                         ``l``
    ================  ==============================  =========================
    A                 ``D²``                          ``4 D``
    B, n=ceil(N/2)    ``D² (n+1)(2n+1)/(6n)``         ``2 D (n+1)``
    C                 ``D² (N+1)/N``                  ``2 D (N+1)²/N``
    D                 ``¾ D² (N+1)/N``                ``D [3(N+1)²/(2N) + 1]``
    ================  ==============================  =========================

    B uses the Table-1 form also for odd ``N``, where the lattice loops enclose a few percent
    less; the realised lattice values come from ``magsail_mj.geometry.current_loops``.
    ``side_m`` may be an array.
    """
    g = normalize_geometry(geometry)
    a, l = _table1_unit(g, _units(units))
    D = _positive("side_m", side_m)
    return _out(a * D * D), _out(l * D)


def geometry_factor(geometry: str, units: int) -> float:
    """``G(N) = D^{5/3} l / A_e^{4/3}`` of the Table-1 form (independent of ``D``; A: ``G = 4``)."""
    a, l = _table1_unit(normalize_geometry(geometry), _units(units))
    return l / a ** (4.0 / 3.0)


def geometry_factor_b_loops(n_loops: int) -> float:
    """Geometry B's ``G`` as a function of the loop count ``n`` itself (Fig. 5, "number of coils")::

    G_B(n) = 2 (n+1) / [(n+1)(2n+1)/(6n)]^{4/3}
    """
    if isinstance(n_loops, bool) or not isinstance(n_loops, (int, np.integer)) or n_loops < 1:
        raise ValueError(f"n_loops: must be an integer >= 1, got {n_loops!r}")
    n = int(n_loops)
    return 2.0 * (n + 1) / ((n + 1) * (2 * n + 1) / (6 * n)) ** (4.0 / 3.0)


# ----------------------------------------------------------------------------- Eqs. 2–11


def c1(constants: ThermalConstants = DEFAULT_CONSTANTS) -> float:
    """Scaling constant ``C1`` [m⁻¹ kg^{-1/3}] of ``λ_f = C1 G D^{5/3} σ_A^{1/3}`` (Eq. 11)::

        C1 = [μ⁴ ρ_c³ ρ_r² f_Γ² / (16384 π Γ_e⁸ ε² σ_B² B0⁴ R_E¹²)]^{1/3}   ≈ 3.2806e-7

    (16384 = 64 · 4096 / 16 collects the ¼ of ``M_c``, the 4/π² of ``d³`` and the 1/8 of Eq. 9.)
    """
    k = constants
    num = k.mu_m3_s2**4 * k.rho_c_kg_m3**3 * k.rho_ref_ohmm**2 * k.f_gamma**2
    den = 16384.0 * math.pi * k.T_eq_K**8 * k.emissivity**2 * k.sigma_B**2 * k.B0_T**4 * k.R_E_m**12
    return (num / den) ** (1.0 / 3.0)


def field_magnitude(geocentric_radius_m, *, constants: ThermalConstants = DEFAULT_CONSTANTS):
    """Eq. 7: ``B = B0 (R_E / R_o)³`` [T], ``R_o`` the geocentric radius."""
    R = _positive("geocentric_radius_m", geocentric_radius_m)
    return _out(constants.B0_T * (constants.R_E_m / R) ** 3)


def gravity_gradient_torque_max(
    total_kg,
    side_m,
    geocentric_radius_m,
    *,
    kappa: float = 0.0,
    lambda_f=0.0,
    constants: ThermalConstants = DEFAULT_CONSTANTS,
):
    """Eq. 8: peak gravity-gradient torque of a square plate, normal at 45° to nadir [N m]::

        T_g,max = 3 μ (i3 − i1) / (2 R_o³) = μ M D² (1 + κ λ_f) / (8 R_o³)

    with ``i1 = i2 = M D² (1 + κ λ_f)/12``, ``i3 = 2 i1``. ``κ λ_f = 0`` is the uniform plate;
    geometry A's rim conductor adds ``κ λ_f`` (Robb et al. 2022b, Eqs. 2–11).
    """
    M = _positive("total_kg", total_kg)
    D = _positive("side_m", side_m)
    R = _positive("geocentric_radius_m", geocentric_radius_m)
    k = _kappa(kappa)
    lam = np.asarray(lambda_f, dtype=float)
    if not np.all(np.isfinite(lam)) or np.any(lam < 0):
        raise ValueError(f"lambda_f: must be finite and >= 0, got {lambda_f!r}")
    return _out(constants.mu_m3_s2 * M * D * D * (1.0 + k * lam) / (8.0 * R**3))


def dipole_max(side_m, areal_density_kg_m2, *, constants: ThermalConstants = DEFAULT_CONSTANTS):
    """Dipole that balances the peak gravity-gradient torque, ``m_max = μ σ_A D⁴ / (8 B0 R_E³)`` [A m²].

    The same for every uniform-mass geometry (B, C, D); geometry A needs ``m_max (1 + κ λ_f)``.
    """
    D = _positive("side_m", side_m)
    s = _positive("areal_density_kg_m2", areal_density_kg_m2)
    k = constants
    return _out(k.mu_m3_s2 * s * D**4 / (8.0 * k.B0_T * k.R_E_m**3))


def required_current(
    area_m2,
    side_m,
    areal_density_kg_m2,
    *,
    altitude_m=None,
    kappa: float = 0.0,
    lambda_f=0.0,
    constants: ThermalConstants = DEFAULT_CONSTANTS,
):
    """Eq. 9: current whose torque ``I A_e B`` equals ``T_g,max`` [A].

    Closed form (``altitude_m=None``)::

        I = μ σ_A D⁴ (1 + κ λ_f) / (8 A_e B0 R_E³)

    With ``altitude_m`` the ratio ``T_g,max(R_o) / (A_e B(R_o))`` is evaluated at ``R_o = R_E + h``
    instead; it gives the same value at every altitude (the ``R_o³`` cancels).
    """
    A = _positive("area_m2", area_m2)
    D = _positive("side_m", side_m)
    s = _positive("areal_density_kg_m2", areal_density_kg_m2)
    if altitude_m is None:
        return _out(dipole_max(D, s, constants=constants) * (1.0 + _kappa(kappa) * np.asarray(lambda_f, float)) / A)
    h = np.asarray(altitude_m, dtype=float)
    if not np.all(np.isfinite(h)) or np.any(h < 0):
        raise ValueError(f"altitude_m: must be finite and >= 0, got {altitude_m!r}")
    R = constants.R_E_m + h
    T = gravity_gradient_torque_max(s * D * D, D, R, kappa=kappa, lambda_f=lambda_f, constants=constants)
    return _out(T / (A * field_magnitude(R, constants=constants)))


def wire_diameter(current_A, *, constants: ThermalConstants = DEFAULT_CONSTANTS):
    """Equilibrium wire diameter [m] (Eq. 6 with ``I²``)::

    ε σ_B π d Γ_e⁴ = 4 ρ_r f_Γ I² / (π d²)   ⇒   d = [4 ρ_r f_Γ I² / (π² ε σ_B Γ_e⁴)]^{1/3}
    """
    I = np.asarray(current_A, dtype=float)
    if not np.all(np.isfinite(I)):
        raise ValueError(f"current_A: must be finite, got {current_A!r}")
    k = constants
    return _out(
        (4.0 * k.rho_ref_ohmm * k.f_gamma * I * I / (math.pi**2 * k.emissivity * k.sigma_B * k.T_eq_K**4))
        ** (1.0 / 3.0)
    )


def conductor_mass(wire_diameter_m, length_m, *, constants: ThermalConstants = DEFAULT_CONSTANTS):
    """Eq. 10 with the copper density: ``M_c = ρ_c π d² l / 4`` [kg]."""
    d = np.asarray(wire_diameter_m, dtype=float)
    l = np.asarray(length_m, dtype=float)
    return _out(constants.rho_c_kg_m3 * math.pi * d * d * l / 4.0)


def joule_power(current_A, wire_diameter_m, length_m, *, constants: ThermalConstants = DEFAULT_CONSTANTS):
    """Ohmic loss at the equilibrium temperature, ``P_J = I² R_r f_Γ`` with ``R_r = 4 ρ_r l / (π d²)`` [W]."""
    I = np.asarray(current_A, dtype=float)
    d = _positive("wire_diameter_m", wire_diameter_m)
    l = _positive("length_m", length_m)
    return _out(I * I * 4.0 * constants.rho_ref_ohmm * l * constants.f_gamma / (math.pi * d * d))


def radiated_power(wire_diameter_m, length_m, *, constants: ThermalConstants = DEFAULT_CONSTANTS):
    """Grey-body radiation of the wire at ``Γ_e``, ``P_rad = ε σ_B π d l Γ_e⁴`` [W] (= ``P_J`` at equilibrium)."""
    d = np.asarray(wire_diameter_m, dtype=float)
    l = np.asarray(length_m, dtype=float)
    k = constants
    return _out(k.emissivity * k.sigma_B * math.pi * d * l * k.T_eq_K**4)


def lambda_f(
    geometry: str, *, units: int, side_m, areal_density_kg_m2, constants: ThermalConstants = DEFAULT_CONSTANTS
):
    """Closed form ``λ_f = C1 G(N) D^{5/3} σ_A^{1/3}`` (Eq. 11) for uniform mass.

    For geometry A this is ``λ_u`` (the uniform-mass value); the sizing value with the rim
    conductor's inertia is :func:`solve_lambda_A`.
    """
    D = _positive("side_m", side_m)
    s = _positive("areal_density_kg_m2", areal_density_kg_m2)
    return _out(c1(constants) * geometry_factor(geometry, units) * D ** (5.0 / 3.0) * np.cbrt(s))


def lambda_f_chain(
    geometry: str,
    *,
    units: int,
    side_m: float,
    areal_density_kg_m2: float,
    kappa: float = 0.0,
    lambda_f_inertia: float = 0.0,
    constants: ThermalConstants = DEFAULT_CONSTANTS,
) -> dict[str, float]:
    """Step-by-step ``I → d → M_c → λ_f`` (Eqs. 9, 6, 10, 11), the check of the closed form.

    ``kappa`` and ``lambda_f_inertia`` enter the torque as ``(1 + κ λ_f)`` (geometry A); at the
    solution of :func:`solve_lambda_A` the returned ``lambda_f`` reproduces ``lambda_f_inertia``.
    """
    area, length = table1(geometry, units, side_m)
    I = required_current(area, side_m, areal_density_kg_m2, kappa=kappa, lambda_f=lambda_f_inertia, constants=constants)
    d = wire_diameter(I, constants=constants)
    Mc = conductor_mass(d, length, constants=constants)
    M = float(areal_density_kg_m2) * float(side_m) ** 2
    return {"current_A": I, "wire_diameter_m": d, "conductor_mass_kg": Mc, "total_mass_kg": M, "lambda_f": Mc / M}


def side_max(geometry: str, *, units: int, areal_density_kg_m2, constants: ThermalConstants = DEFAULT_CONSTANTS):
    """Largest plate side with ``λ_f ≤ 1``, ``D_max = (C1 G σ_A^{1/3})^{-3/5}`` [m] (uniform mass).

    For geometry A this is the uniform-mass value ``λ_u = 1``; with the rim conductor see
    :func:`fold_A` and :func:`trace_branches_A`.
    """
    s = _positive("areal_density_kg_m2", areal_density_kg_m2)
    return _out((c1(constants) * geometry_factor(geometry, units) * np.cbrt(s)) ** (-0.6))


# ----------------------------------------------------------------------------- geometry A


def lambda_u_A(side_m, areal_density_kg_m2, *, constants: ThermalConstants = DEFAULT_CONSTANTS):
    """Uniform-mass fraction of geometry A, ``λ_u = 4 C1 D^{5/3} σ_A^{1/3}``."""
    return lambda_f("A", units=1, side_m=side_m, areal_density_kg_m2=areal_density_kg_m2, constants=constants)


def h_A(lam, kappa: float = 15.0):
    """``h(λ) = λ (1 + κλ)^{-4/3}``: the ``λ_u`` at which ``λ`` solves geometry A's implicit equation."""
    lam = np.asarray(lam, dtype=float)
    return _out(lam * (1.0 + _kappa(kappa) * lam) ** (-4.0 / 3.0))


def fold_A(kappa: float = 15.0) -> tuple[float, float]:
    """Fold of ``λ = λ_u (1 + κλ)^{4/3}``: ``(λ*, h*) = (3/κ, (3/κ) 4^{-4/3})`` (``h'(λ*) = 0``).

    ``κ = 0`` (no rim term) has no fold: ``(inf, inf)``.
    """
    k = _kappa(kappa)
    if k == 0.0:
        return math.inf, math.inf
    lam = 3.0 / k
    return lam, lam * 4.0 ** (-4.0 / 3.0)


def solve_lambda_A(lambda_u: float, *, kappa: float = 15.0, branch: Literal["light", "heavy", "both"] = "light"):
    """Roots of geometry A's ``λ = λ_u (1 + κλ)^{4/3}`` (Robb et al. 2022b, Eqs. 2–11).

    ``branch="light"`` gives the root below the fold ``λ* = 3/κ`` (the sizing value), ``"heavy"``
    the one above, ``"both"`` the pair ``(light, heavy)``. Both are found by bracketing
    ``ln h(λ) = ln λ_u`` on either side of ``λ*`` (``h`` is monotone on each side; ``h → 0`` as
    ``λ → ∞`` like ``κ^{-4/3} λ^{-1/3}``, so the heavy root may exceed 1, i.e. be unphysical).

    Raises:
      NoLoopSolution: ``λ_u > h*`` — no conductor fraction balances the torque.
    """
    lu = float(_positive("lambda_u", lambda_u))
    k = _kappa(kappa)
    if branch not in ("light", "heavy", "both"):
        raise ValueError(f"branch: must be 'light', 'heavy' or 'both', got {branch!r}")
    if k == 0.0:
        if branch == "heavy":
            raise NoLoopSolution("kappa = 0 has a single (light) branch λ_f = λ_u")
        return lu if branch == "light" else (lu, math.inf)
    lam_star, h_star = fold_A(k)
    if lu > h_star * (1 + 1e-14):
        raise NoLoopSolution(
            f"lambda_u = {lu:.6g} exceeds the fold h* = (3/κ)·4^(-4/3) = {h_star:.6g} at kappa = {k:g}: "
            "geometry A has no conductor mass fraction that balances the gravity-gradient torque "
            "(plate too large or too dense)"
        )
    if lu >= h_star:
        return lam_star if branch != "both" else (lam_star, lam_star)
    x_star = math.log(lam_star)

    def g(x: float) -> float:
        return x - (4.0 / 3.0) * math.log1p(k * math.exp(x)) - math.log(lu)

    out = []
    if branch in ("light", "both"):
        # h(λ) < λ, so ln λ_u is a lower bound for ln λ on the light branch: g(ln λ_u) < 0 < g(x*).
        out.append(math.exp(brentq(g, math.log(lu), x_star, xtol=1e-15, rtol=1e-15, maxiter=200)))
    if branch in ("heavy", "both"):
        hi = x_star + 1.0
        while g(hi) > 0:
            hi = x_star + 2.0 * (hi - x_star)
        out.append(math.exp(brentq(g, x_star, hi, xtol=1e-15, rtol=1e-15, maxiter=200)))
    return out[0] if branch != "both" else tuple(out)


def _curves(side_m, current_A, length_m, lam, constants: ThermalConstants) -> dict[str, np.ndarray]:
    d = np.asarray(wire_diameter(current_A, constants=constants))
    P = np.asarray(radiated_power(d, length_m, constants=constants))
    return {
        "side_m": np.asarray(side_m, float),
        "lambda_f": np.asarray(lam, float),
        "current_A": np.asarray(current_A, float),
        "wire_diameter_m": d,
        "power_per_area_W_m2": P / np.asarray(side_m, float) ** 2,
    }


def trace_branches_A(
    areal_density_kg_m2: float, *, kappa: float = 15.0, lambdas=None, constants: ThermalConstants = DEFAULT_CONSTANTS
) -> dict[str, np.ndarray]:
    """Both branches of geometry A, parametrised by ``λ`` (Robb et al. 2022b, Eqs. 2–11, Fig. 3)::

        λ_u = h(λ),   D = (λ_u / (4 C1 σ_A^{1/3}))^{3/5},   I = I_u(D) (1 + κλ),   d(I),   P_J = ε σ_B π d (4D) Γ_e⁴

    Args:
      lambdas: increasing conductor fractions in ``(0, λ_max]``; default 400 log-spaced points in
        ``[1e-12, 1]``.

    Returns:
      arrays ``lambda_f, side_m, current_A, wire_diameter_m, power_per_area_W_m2`` and the boolean
      ``heavy`` (``λ > 3/κ``).
    """
    s = float(_positive("areal_density_kg_m2", areal_density_kg_m2))
    k = _kappa(kappa)
    lam = np.logspace(-12, 0, 400) if lambdas is None else _positive("lambdas", lambdas)
    lu = np.asarray(h_A(lam, k))
    D = (lu / (4.0 * c1(constants) * np.cbrt(s))) ** 0.6
    I = dipole_max(D, s, constants=constants) / (D * D) * (1.0 + k * lam)
    out = _curves(D, I, 4.0 * D, lam, constants)
    out["heavy"] = lam > fold_A(k)[0]
    return out


def uniform_curves(
    geometry: str, *, units: int, side_m, areal_density_kg_m2, constants: ThermalConstants = DEFAULT_CONSTANTS
) -> dict[str, np.ndarray]:
    """``λ_f, I, d, P_J/D²`` against ``side_m`` for a uniform-mass geometry (B, C, D; Fig. 4)."""
    area, length = table1(geometry, units, side_m)
    I = required_current(area, side_m, areal_density_kg_m2, constants=constants)
    lam = lambda_f(geometry, units=units, side_m=side_m, areal_density_kg_m2=areal_density_kg_m2, constants=constants)
    return _curves(side_m, I, length, lam, constants)


# ----------------------------------------------------------------------------- sizing and tables


def loop_sizing(
    geometry: str,
    *,
    units: int,
    side_m: float,
    areal_density_kg_m2: float,
    kappa: float = 15.0,
    constants: ThermalConstants = DEFAULT_CONSTANTS,
) -> dict:
    """Eq.-9 current and thermal sizing of one loop geometry.

    Returns a dict with ``current_A`` (A on the light branch), ``wire_diameter_m``, ``lambda_f``,
    ``power_W`` and ``power_per_area_W_m2`` (``P_J = ε σ_B π d l Γ_e⁴``), ``dipole_max_Am2``
    (``I A_e``), ``area_m2`` and ``path_length_m`` (Table-1 forms), ``conductor_mass_kg``, and the
    inputs. ``kappa`` matters only for A.

    Raises:
      ValueError: a bad argument (the message names it); :class:`NoLoopSolution` for A beyond its fold.
    """
    g = normalize_geometry(geometry)
    N = _units(units)
    D = float(_positive("side_m", side_m))
    s = float(_positive("areal_density_kg_m2", areal_density_kg_m2))
    k = _kappa(kappa)
    area, length = table1(g, N, D)
    lam_inertia = 0.0
    if g == "A":
        try:
            lam_inertia = solve_lambda_A(lambda_u_A(D, s, constants=constants), kappa=k, branch="light")
        except NoLoopSolution as err:
            d_fold = (fold_A(k)[1] / (4.0 * c1(constants) * np.cbrt(s))) ** 0.6
            raise NoLoopSolution(
                f"side_m: {D:g} m is beyond geometry A's fold; at areal_density_kg_m2 = "
                f"{s:g} and kappa = {k:g} the largest plate is {d_fold:.6g} m ({err})"
            ) from None
    ch = lambda_f_chain(
        g,
        units=N,
        side_m=D,
        areal_density_kg_m2=s,
        kappa=k if g == "A" else 0.0,
        lambda_f_inertia=lam_inertia,
        constants=constants,
    )
    P = radiated_power(ch["wire_diameter_m"], length, constants=constants)
    out = {
        "geometry": g,
        "units": N,
        "side_m": D,
        "areal_density_kg_m2": s,
        "current_A": ch["current_A"],
        "wire_diameter_m": ch["wire_diameter_m"],
        "lambda_f": ch["lambda_f"],
        "power_W": P,
        "power_per_area_W_m2": P / (D * D),
        "dipole_max_Am2": ch["current_A"] * area,
        "area_m2": area,
        "path_length_m": length,
        "conductor_mass_kg": ch["conductor_mass_kg"],
    }
    if g == "A":
        out.update(kappa=k, branch="light", lambda_u=lambda_u_A(D, s, constants=constants))
    return require_finite(
        out,
        inputs={
            "geometry": geometry,
            "units": units,
            "side_m": side_m,
            "areal_density_kg_m2": areal_density_kg_m2,
            "kappa": kappa,
        },
    )


def scaling_table(
    *,
    side_m: float = 250.0,
    areal_density_kg_m2: float = 0.1,
    kappa: float = 15.0,
    geometries: Iterable[str] = GEOMETRIES,
    units: Iterable[int] = (12, 19, 27),
    constants: ThermalConstants = DEFAULT_CONSTANTS,
) -> dict:
    """The ``scaling`` object (stdout of ``magsail scaling loops --table``).

    Keys ``{g}_N{N}_current_A``, ``_wire_diameter_m``, ``_lambda_f``, ``_power_per_area_W_m2``,
    ``_dipole_max_Am2``, ``_path_length_m`` for every geometry and ``N``; ``c1_per_m_per_cbrt_kg``,
    ``kappa``, ``A_lambda_fold`` (``λ* = 3/κ``); and, in addition, the inputs ``side_m``,
    ``areal_density_kg_m2`` and ``A_side_fold_m`` (largest A plate with a solution).
    """
    out: dict = {}
    keys = ("current_A", "wire_diameter_m", "lambda_f", "power_per_area_W_m2", "dipole_max_Am2", "path_length_m")
    for g in geometries:
        for N in units:
            row = loop_sizing(
                g, units=N, side_m=side_m, areal_density_kg_m2=areal_density_kg_m2, kappa=kappa, constants=constants
            )
            for key in keys:
                out[f"{row['geometry']}_N{N}_{key}"] = row[key]
    lam_star, h_star = fold_A(kappa)
    s = float(_positive("areal_density_kg_m2", areal_density_kg_m2))
    out.update(
        c1_per_m_per_cbrt_kg=c1(constants),
        kappa=_kappa(kappa),
        A_lambda_fold=lam_star,
        side_m=float(side_m),
        areal_density_kg_m2=s,
        A_side_fold_m=(h_star / (4.0 * c1(constants) * np.cbrt(s))) ** 0.6,
    )
    return require_finite(out, inputs={"side_m": side_m, "areal_density_kg_m2": areal_density_kg_m2, "kappa": kappa})


def sunlight_diameter_ratio(constants: ThermalConstants = DEFAULT_CONSTANTS) -> float:
    """Optional side check: wire diameter increase if the wire is sunlit (derived; not in the paper).

    Absorbed sunlight ``P_S = S ε l d`` (absorptance = ε, projected area ``l d``) joins the
    balance ``4 ρ_r f_Γ I² / (π d²) + S ε d = ε σ_B π d Γ_e⁴``, so at the same current::

        d_sun / d = [1 − S / (σ_B π Γ_e⁴)]^{-1/3}

    Raises ``ValueError`` when sunlight alone would exceed the radiated power at ``Γ_e``.
    """
    k = constants
    ratio = k.solar_flux_W_m2 / (k.sigma_B * math.pi * k.T_eq_K**4)
    if ratio >= 1.0:
        raise ValueError(
            f"solar_flux_W_m2: sunlight ({k.solar_flux_W_m2} W/m²) alone heats the wire above T_eq_K = {k.T_eq_K} K"
        )
    return (1.0 - ratio) ** (-1.0 / 3.0)
