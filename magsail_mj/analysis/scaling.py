"""Scaling law of the distributed magnetorquer array: rod mass fraction against plate size.

Robb et al. 2022a, Sec. 4.1, Eqs. 14–17. SI units;
``μ = 3.986004418e14`` m³/s², ``B0 = 3.12e-5`` T, ``R_E = 6370`` km.

- Rigid-body gravity-gradient torque (Eq. 14), ``r_b`` the centre-of-mass position from the
  Earth's centre in body components, ``I`` the inertia tensor about the centre of mass::

      T_grav = 3 μ / r⁵ · r_b × (I r_b)                                           [N m]

- Its maximum for a thin square plate (``I1 = I2 = M d²/12``, ``I3 = M d²/6``), at 45° between
  the local vertical and the plate normal::

      T_grav,max = 3 μ r⁻³ (I3 − I1) sin45° cos45° = μ M d² / (8 r³)

- Largest actuator torque with rod dipole ``κ_τ M_τ`` perpendicular to the field, in the dipole
  field magnitude ``B = B0 (R_E / r)³``::

      T_ac,max = κ_τ M_τ B

- Setting ``T_ac,max = T_grav,max`` with ``M_τ = λ_f M`` gives the rod mass fraction needed,
  independent of ``r`` and ``M``::

      λ_f = μ d² / (8 B0 R_E³ κ_τ),        d(λ_f) = sqrt(8 B0 R_E³ κ_τ λ_f / μ).

:func:`scaling_report` is what ``magsail scaling magnetorquer --side-m D --kappa K`` prints.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from pydantic import Field, ValidationError, model_validator

from magsail_mj.config import ConfigError, StrictModel, read_toml, validation_problems
from magsail_mj.environment.constants import B0_DIPOLE, MU_EARTH, R_E_TRUSS
from magsail_mj.resources import check_memory

__all__ = [
    "ScalingInputs",
    "actuator_torque_max",
    "dipole_field_magnitude",
    "gravity_gradient_torque",
    "gravity_gradient_torque_max",
    "load_scaling_inputs",
    "plate_inertia",
    "require_finite",
    "rod_mass_fraction",
    "scaling_report",
    "scaling_tables",
    "side_at_rod_mass_fraction",
]


def _positive(name: str, value) -> np.ndarray:
    v = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(v)) or np.any(v <= 0):
        raise ValueError(f"{name}: must be finite and > 0, got {value!r}")
    return v


def _out(v: np.ndarray):
    return float(v) if np.ndim(v) == 0 else v


def require_finite(report: dict, *, inputs: dict) -> dict:
    """Return ``report`` if every number in it is finite, else raise ``ValueError`` naming the
    first non-finite key and the ``inputs`` (``{name: value}``): no report carries a non-finite
    number it was asked to compute (``None`` entries, meaning "not applicable", are allowed)."""
    for key, value in report.items():
        if value is None or isinstance(value, (str, bool)):
            continue
        if isinstance(value, dict):
            require_finite(value, inputs=inputs)
            continue
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            continue
        if not np.all(np.isfinite(arr)):
            names = ", ".join(inputs)
            given = ", ".join(f"{k} = {v!r}" for k, v in inputs.items())
            raise ValueError(
                f"{names}: the result {key} is not finite for {given} "
                "(the inputs are outside the range where it can be computed)"
            )
    return report


def plate_inertia(total_kg: float, side_m: float) -> np.ndarray:
    """(3, 3) inertia of a thin square plate about its centre, ``diag(M d²/12, M d²/12, M d²/6)`` [kg m²]."""
    M = float(_positive("total_kg", total_kg))
    d = float(_positive("side_m", side_m))
    return np.diag([M * d * d / 12.0, M * d * d / 12.0, M * d * d / 6.0])


def gravity_gradient_torque(r_body, inertia, *, mu: float = MU_EARTH) -> np.ndarray:
    """Eq. 14: ``T = 3 μ / r⁵ · r_b × (I r_b)`` [N m], body components.

    Args:
      r_body: (3,) or (K, 3) centre-of-mass position from the Earth's centre, body components [m].
      inertia: (3, 3) inertia tensor about the centre of mass, body components [kg m²].
      mu: gravitational parameter [m³/s²].
    """
    r = np.asarray(r_body, dtype=float)
    I = np.asarray(inertia, dtype=float)
    if r.shape[-1:] != (3,):
        raise ValueError(f"r_body: expected (3,) or (K, 3) [m], got shape {r.shape}")
    if I.shape != (3, 3):
        raise ValueError(f"inertia: expected a (3, 3) tensor [kg m²], got shape {I.shape}")
    _positive("mu", mu)
    rn = np.linalg.norm(r, axis=-1, keepdims=True)
    if np.any(rn == 0):
        raise ValueError("r_body: must be non-zero")
    return 3.0 * mu / rn**5 * np.cross(r, r @ I.T)


def gravity_gradient_torque_max(total_kg, side_m, radius_m, *, mu: float = MU_EARTH):
    """``T_grav,max = μ M d² / (8 r³)`` [N m] of a thin square plate; broadcasts."""
    M = _positive("total_kg", total_kg)
    d = _positive("side_m", side_m)
    r = _positive("radius_m", radius_m)
    _positive("mu", mu)
    return _out(mu * M * d**2 / (8.0 * r**3))


def dipole_field_magnitude(radius_m, *, B0_T: float = B0_DIPOLE, R_E_m: float = R_E_TRUSS):
    """Dipole field magnitude for the scaling, ``B = B0 (R_E / r)³`` [T]; broadcasts."""
    r = _positive("radius_m", radius_m)
    _positive("B0_T", B0_T)
    _positive("R_E_m", R_E_m)
    return _out(B0_T * (R_E_m / r) ** 3)


def actuator_torque_max(kappa_Am2_kg, rod_mass_kg, B_T):
    """``T_ac,max = κ_τ M_τ B`` [N m]: all rod dipole perpendicular to the field (Eq. 16)."""
    k = _positive("kappa_Am2_kg", kappa_Am2_kg)
    m = np.asarray(rod_mass_kg, dtype=float)
    if not np.all(np.isfinite(m)) or np.any(m < 0):
        raise ValueError(f"rod_mass_kg: must be finite and >= 0, got {rod_mass_kg!r}")
    B = np.asarray(B_T, dtype=float)
    if not np.all(np.isfinite(B)) or np.any(B < 0):
        raise ValueError(f"B_T: must be a finite magnitude >= 0, got {B_T!r}")
    return _out(k * m * B)


def rod_mass_fraction(side_m, kappa_Am2_kg, *, mu: float = MU_EARTH, B0_T: float = B0_DIPOLE, R_E_m: float = R_E_TRUSS):
    """Rod mass fraction needed to match the peak gravity-gradient torque (Eq. 17):
    ``λ_f = μ d² / (8 B0 R_E³ κ_τ)`` (dimensionless); broadcasts over ``side_m`` and ``kappa``."""
    d = _positive("side_m", side_m)
    k = _positive("kappa_Am2_kg", kappa_Am2_kg)
    _positive("mu", mu)
    _positive("B0_T", B0_T)
    _positive("R_E_m", R_E_m)
    return _out(mu * d**2 / (8.0 * B0_T * R_E_m**3 * k))


def side_at_rod_mass_fraction(
    lambda_f, kappa_Am2_kg, *, mu: float = MU_EARTH, B0_T: float = B0_DIPOLE, R_E_m: float = R_E_TRUSS
):
    """Side length [m] at which the needed fraction equals ``lambda_f``:
    ``d = sqrt(8 B0 R_E³ κ_τ λ_f / μ)``; broadcasts."""
    lam = _positive("lambda_f", lambda_f)
    k = _positive("kappa_Am2_kg", kappa_Am2_kg)
    _positive("mu", mu)
    _positive("B0_T", B0_T)
    _positive("R_E_m", R_E_m)
    return _out(np.sqrt(8.0 * B0_T * R_E_m**3 * k * lam / mu))


def scaling_report(
    side_m: float | Sequence[float],
    kappa: float | Sequence[float],
    *,
    altitude_km: float = 800.0,
    total_kg: float = 200.0,
    rod_mass_kg: float = 100.0,
    mu: float = MU_EARTH,
    B0_T: float = B0_DIPOLE,
    R_E_m: float = R_E_TRUSS,
) -> dict:
    """The scaling-law figures for plate side(s) ``side_m`` [m] and dipole-to-mass ratio(s) ``kappa``
    [A m²/kg], as one flat JSON-ready dict (the output of ``magsail scaling magnetorquer``).

    The orbit radius is ``r = R_E + altitude``; ``total_kg`` and ``rod_mass_kg``
    (defaults: the truss, 200 kg of which 100 kg rods) enter only the torques, not ``λ_f``.

    Keys (SI in the names): ``side_m``, ``kappa_Am2_kg``, ``altitude_km``, ``radius_m``,
    ``total_kg``, ``rod_mass_kg``, ``mu_m3_s2``, ``B0_T``, ``R_E_m``;
    ``lambda_f`` — rod mass fraction needed (Eq. 17);
    ``d_at_lambda_f_1_m`` — side at which ``λ_f = 1`` (all mass in rods);
    ``d_at_lambda_f_0p5_m`` — side at which ``λ_f = 0.5``;
    ``B_dipole_T`` — ``B0 (R_E/r)³``; ``T_grav_max_Nm`` — ``μ M d²/(8 r³)``;
    ``T_ac_max_Nm`` — ``κ_τ M_τ B``; ``lambda_f_design`` — ``M_τ / M``;
    ``authority_margin`` — ``T_ac,max / T_grav,max = λ_design / λ_f``.

    Scalars in, scalars out. When ``side_m`` or ``kappa`` is a list, ``lambda_f`` and
    ``authority_margin`` are nested lists ``[i_kappa][i_side]`` (a scalar counting as a list of
    one), and ``d_at_*``, ``T_ac_max_Nm`` follow ``kappa``, ``T_grav_max_Nm`` follows ``side_m``.
    """
    d = _positive("side_m", side_m)
    k = _positive("kappa", kappa)
    if d.ndim > 1 or k.ndim > 1:
        raise ValueError("side_m, kappa: expected numbers or flat lists of numbers")
    check_memory(8.0 * 6 * (d.size * k.size + d.size + k.size), what=f"scaling: {d.size} sides x {k.size} kappas")
    alt = float(np.asarray(altitude_km, dtype=float))
    if not (math.isfinite(alt) and alt >= 0):
        raise ValueError(f"altitude_km: must be finite and >= 0, got {altitude_km!r}")
    M = float(_positive("total_kg", total_kg))
    Mt = float(np.asarray(rod_mass_kg, dtype=float))
    if not (math.isfinite(Mt) and 0 <= Mt <= M):
        raise ValueError(f"rod_mass_kg: must be between 0 and total_kg ({M}), got {rod_mass_kg!r}")
    with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
        report = _scaling_figures(d, k, alt=alt, M=M, Mt=Mt, mu=mu, B0_T=B0_T, R_E_m=R_E_m)
    return require_finite(
        report,
        inputs={
            "side_m": side_m,
            "kappa": kappa,
            "altitude_km": altitude_km,
            "total_kg": total_kg,
            "rod_mass_kg": rod_mass_kg,
        },
    )


def _scaling_figures(
    d: np.ndarray, k: np.ndarray, *, alt: float, M: float, Mt: float, mu: float, B0_T: float, R_E_m: float
) -> dict:
    """The figures of :func:`scaling_report` for checked inputs (may hold inf/NaN on overflow)."""
    r = R_E_m + alt * 1e3
    B = dipole_field_magnitude(r, B0_T=B0_T, R_E_m=R_E_m)
    if d.ndim == 0 and k.ndim == 0:
        lam = np.asarray(rod_mass_fraction(d, k, mu=mu, B0_T=B0_T, R_E_m=R_E_m))
    else:
        lam = np.asarray(
            rod_mass_fraction(np.atleast_1d(d)[None, :], np.atleast_1d(k)[:, None], mu=mu, B0_T=B0_T, R_E_m=R_E_m)
        )
    T_grav = np.asarray(gravity_gradient_torque_max(M, d, r, mu=mu))
    T_ac = np.asarray(actuator_torque_max(k, Mt, B))
    lam_design = Mt / M
    return {
        "side_m": d.tolist(),
        "kappa_Am2_kg": k.tolist(),
        "altitude_km": alt,
        "radius_m": r,
        "total_kg": M,
        "rod_mass_kg": Mt,
        "mu_m3_s2": float(mu),
        "B0_T": float(B0_T),
        "R_E_m": float(R_E_m),
        "lambda_f": lam.tolist(),
        "d_at_lambda_f_1_m": np.asarray(side_at_rod_mass_fraction(1.0, k, mu=mu, B0_T=B0_T, R_E_m=R_E_m)).tolist(),
        "d_at_lambda_f_0p5_m": np.asarray(side_at_rod_mass_fraction(0.5, k, mu=mu, B0_T=B0_T, R_E_m=R_E_m)).tolist(),
        "B_dipole_T": float(B),
        "T_grav_max_Nm": T_grav.tolist(),
        "T_ac_max_Nm": T_ac.tolist(),
        "lambda_f_design": lam_design,
        "authority_margin": (lam_design / lam).tolist(),
    }


# ----------------------------------------------------------------------------- plot inputs


class ScalingInputs(StrictModel):
    """Inputs of the ``scaling`` figure (the ``[scaling]`` table of
    ``magsail_mj/concepts/truss_magnetorquer/configs/scaling.toml``; defaults are the values of Robb et al.
    2022a, Sec. 4.1 and Table 2).
    Strict like every config table: finite numbers, no strings or booleans for numbers."""

    kappas_Am2_kg: list[float] = Field(default=[10.0, 50.0, 100.0, 200.0], min_length=1)
    side_min_m: float = Field(default=1.0, gt=0)
    side_max_m: float = Field(default=200.0, gt=0)
    n_points: int = Field(default=400, ge=2)
    table_sides_m: list[float] = Field(default=[75.0, 100.0], min_length=1)
    altitude_km: float = Field(default=800.0, ge=0)
    total_kg: float = Field(default=200.0, gt=0)
    rod_mass_kg: float = Field(default=100.0, ge=0)
    design_side_m: float = Field(default=75.0, gt=0)
    design_kappa_Am2_kg: float = Field(default=100.0, gt=0)
    mu_m3_s2: float = Field(default=MU_EARTH, gt=0)
    B0_T: float = Field(default=B0_DIPOLE, gt=0)
    R_E_km: float = Field(default=R_E_TRUSS / 1e3, gt=0)

    @model_validator(mode="after")
    def _consistent(self) -> ScalingInputs:
        if self.side_max_m <= self.side_min_m:
            raise ValueError(f"side_max_m: must exceed side_min_m = {self.side_min_m!r}, got {self.side_max_m!r}")
        if self.rod_mass_kg > self.total_kg:
            raise ValueError(f"rod_mass_kg: must not exceed total_kg = {self.total_kg!r}, got {self.rod_mass_kg!r}")
        if any(k <= 0 for k in self.kappas_Am2_kg):
            raise ValueError("kappas_Am2_kg: every value must be > 0")
        if any(d <= 0 for d in self.table_sides_m):
            raise ValueError("table_sides_m: every value must be > 0")
        return self


def load_scaling_inputs(path: str | Path) -> ScalingInputs:
    """Read and validate the ``[scaling]`` table of a TOML file (other top-level keys ignored)."""
    path = Path(path)
    tree = read_toml(path)
    table = tree.get("scaling", {})
    if not isinstance(table, dict):
        raise ConfigError([f"scaling: must be a table, got {table!r}"], source=str(path))
    try:
        return ScalingInputs.model_validate(table)
    except ValidationError as err:
        raise ConfigError(validation_problems(err, prefix="scaling."), source=str(path)) from None


def scaling_tables(inputs: ScalingInputs) -> dict:
    """The scaling-law outputs for ``inputs``, JSON-ready (the ``scaling`` summary).

    Keys: ``lambda_f`` (``{"kappa=<κ>": {"d=<d>": λ_f}}`` over ``table_sides_m``),
    ``d_at_lambda_f_1_m`` and ``d_at_lambda_f_0p5_m`` (``{"kappa=<κ>": d}``), and for the Table 2 truss
    at the design point ``T_grav_max_Nm``, ``T_ac_max_Nm``, ``B_dipole_T``,
    ``lambda_f_design_required``, ``lambda_f_design``, ``authority_margin``, plus the inputs.
    """
    kw = {"mu": inputs.mu_m3_s2, "B0_T": inputs.B0_T, "R_E_m": inputs.R_E_km * 1e3}
    lam = {
        f"kappa={k:g}": {f"d={d:g}": float(rod_mass_fraction(d, k, **kw)) for d in inputs.table_sides_m}
        for k in inputs.kappas_Am2_kg
    }
    d1 = {f"kappa={k:g}": float(side_at_rod_mass_fraction(1.0, k, **kw)) for k in inputs.kappas_Am2_kg}
    d05 = {f"kappa={k:g}": float(side_at_rod_mass_fraction(0.5, k, **kw)) for k in inputs.kappas_Am2_kg}
    design = scaling_report(
        inputs.design_side_m,
        inputs.design_kappa_Am2_kg,
        altitude_km=inputs.altitude_km,
        total_kg=inputs.total_kg,
        rod_mass_kg=inputs.rod_mass_kg,
        **kw,
    )
    return {
        "lambda_f": lam,
        "d_at_lambda_f_1_m": d1,
        "d_at_lambda_f_0p5_m": d05,
        "T_grav_max_Nm": design["T_grav_max_Nm"],
        "T_ac_max_Nm": design["T_ac_max_Nm"],
        "B_dipole_T": design["B_dipole_T"],
        "lambda_f_design_required": design["lambda_f"],
        "lambda_f_design": design["lambda_f_design"],
        "authority_margin": design["authority_margin"],
        "design_side_m": inputs.design_side_m,
        "design_kappa_Am2_kg": inputs.design_kappa_Am2_kg,
        "altitude_km": inputs.altitude_km,
        "radius_m": design["radius_m"],
        "total_kg": inputs.total_kg,
        "rod_mass_kg": inputs.rod_mass_kg,
        "mu_m3_s2": inputs.mu_m3_s2,
        "B0_T": inputs.B0_T,
        "R_E_m": inputs.R_E_km * 1e3,
    }
