"""First twist frequencies of the truss plates against the free square Kirchhoff plate.

    .venv/bin/python scripts/plate_frequencies.py [--units 19] [--side-m 75] [--EI-Nm2 1e3] [--mass-kg 200] [--nu 0.3]

Three plates of side ``d = --side-m``, each calibrated by the cantilever rule to the bending
stiffness ``EI = --EI-Nm2`` and of total mass ``M = --mass-kg`` (uniform node masses): the shipped
two-layer cubic lattice (parity diagonals, ``--units`` cubes per side), the octet plate (rim
chords, ``--units`` cubes) and the offset grid (corner braces, ``--units`` cells). Their free modes
come from :func:`magsail_mj.structure.modes.structure_modes`, each classed by the symmetry of its
deflection ``w`` over the nodes' ``(x, y)``
(:func:`magsail_mj.structure.plate_theory.square_symmetry_class`: ``B2`` the twist ``w ∝ x y``,
``B1`` the saddle ``w ∝ x² − y²``, the twist about the diagonals).

Reference: the isotropic Kirchhoff plate of ``D = EI / d``, Poisson ratio ``--nu`` and
``ρ_A = M / d²`` (Argyris element, :func:`~magsail_mj.structure.plate_theory.free_plate_modes`),
whose first mode is its twist (``λ² = 13.468`` at ν = 0.3). Frequencies as ``λ² = ω d² √(ρ_A/D)``
and in Hz. For the cubic lattice the table adds its own Kirchhoff plate: the homogenised
rigidities of its struts (``ν = 0.261``, twisting rigidity ``1/√2`` of the isotropic plate's,
:func:`~magsail_mj.structure.plate_theory.cubic_lattice_rigidity`); the octet and the offset grid
have none (their chords leave the saddle, respectively the twist, to the bracing alone).
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

import numpy as np

from magsail_mj.structure.generators import octet_plate, offset_grid_plate, square_plate_lattice
from magsail_mj.structure.model import Structure
from magsail_mj.structure.modes import structure_modes
from magsail_mj.structure.plate_theory import (
    PlateRigidity,
    cubic_lattice_rigidity,
    free_plate_modes,
    frequency_parameter,
    square_mesh,
    square_symmetry_class,
)

#: Elastic modes solved per plate (the offset grid's saddle comes after four others).
ELASTIC_MODES = 10
#: Divisions of the Kirchhoff reference's square mesh (λ² converged to 10⁻⁵).
KIRCHHOFF_DIVISIONS = 8


@dataclass(frozen=True)
class PlateReading:
    """One plate's row: ``name``, strut ``EA_N`` [N], the classes and ``λ²`` of its first
    elastic modes, ``twist_Hz`` / ``twist_lambda2`` of its first ``B2`` mode, ``saddle_lambda2`` of
    its first ``B1`` mode, and ``own_twist_lambda2``: its homogenised Kirchhoff plate's ``B2``
    (``nan`` where that plate has a mechanism)."""

    name: str
    EA_N: float
    classes: list[str]
    lambda2: np.ndarray
    twist_Hz: float
    twist_lambda2: float
    saddle_lambda2: float
    own_twist_lambda2: float


def mode_classes(structure: Structure, count: int) -> tuple[np.ndarray, list[str]]:
    """``ω`` [rad/s] and symmetry classes of the ``count`` lowest elastic modes of a free plate."""
    modes = structure_modes(structure, k=6 + count)
    if modes.n_zero != 6:
        raise ValueError(f"structure: {structure.name!r} has {modes.n_zero} zero modes, not the 6 rigid ones")
    w = modes.node_translations()[6:, :, 2]
    return modes.omega_rad_s[6:], square_symmetry_class(structure.positions_m, w)


def first_of(classes: list[str], values: np.ndarray, name: str) -> float:
    """The value of the first mode of class ``name`` (``nan`` if none)."""
    hits = [i for i, c in enumerate(classes) if c == name]
    return float(values[hits[0]]) if hits else math.nan


def kirchhoff_lambda2(rigidity: PlateRigidity) -> tuple[np.ndarray, list[str]]:
    """``λ²`` (per ``D11``) and classes of the free unit square plate's first modes."""
    modes = free_plate_modes(
        square_mesh(side_m=1.0, divisions=KIRCHHOFF_DIVISIONS),
        rigidity,
        areal_density_kg_m2=1.0,
        count=ELASTIC_MODES,
    )
    lam2 = frequency_parameter(modes.omega_rad_s, length_m=1.0, D_Nm=rigidity.D11_Nm, areal_density_kg_m2=1.0)
    return lam2, square_symmetry_class(modes.points_m, modes.deflection)


def plate_readings(*, units: int, side_m: float, EI_Nm2: float, mass_kg: float) -> list[PlateReading]:
    """The three plates' rows (module docstring)."""
    common = {"side_m": side_m, "EI_Nm2": EI_Nm2, "total_mass_kg": mass_kg}
    plates = [
        square_plate_lattice(units=units, **common),
        octet_plate(units=units, **common),
        offset_grid_plate(cells=units, **common),
    ]
    D, rho = EI_Nm2 / side_m, mass_kg / side_m**2
    rows = []
    for structure in plates:
        omega, classes = mode_classes(structure, ELASTIC_MODES)
        lam2 = frequency_parameter(omega, length_m=side_m, D_Nm=D, areal_density_kg_m2=rho)
        EA = float(structure.members.EA_N[0])
        own = math.nan
        if structure.name == "square_plate_lattice":
            rigidity = cubic_lattice_rigidity(EA_N=EA, cube_edge_m=side_m / units)
            own_lam2, own_classes = kirchhoff_lambda2(rigidity)
            own = first_of(own_classes, own_lam2, "B2") * math.sqrt(rigidity.D11_Nm / D)
        rows.append(
            PlateReading(
                name=structure.name,
                EA_N=EA,
                classes=classes,
                lambda2=lam2,
                twist_Hz=first_of(classes, omega, "B2") / (2.0 * math.pi),
                twist_lambda2=first_of(classes, lam2, "B2"),
                saddle_lambda2=first_of(classes, lam2, "B1"),
                own_twist_lambda2=own,
            )
        )
    return rows


def table(rows: list[PlateReading], *, nu: float) -> str:
    """The rows as a Markdown table against the isotropic plate of Poisson ratio ``nu``."""
    lam2, classes = kirchhoff_lambda2(PlateRigidity.isotropic(1.0, nu))
    twist, saddle = first_of(classes, lam2, "B2"), first_of(classes, lam2, "B1")
    lines = [
        f"Kirchhoff (isotropic, ν = {nu:g}): twist B2 λ² = {twist:.4f}, saddle B1 λ² = {saddle:.4f}",
        "",
        "| plate | EA [N] | first modes (class λ²) | twist B2 [mHz] | twist λ² | / Kirchhoff | saddle B1 / Kirchhoff "
        "| twist / own Kirchhoff |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        first = ", ".join(f"{c} {v:.3f}" for c, v in zip(r.classes[:3], r.lambda2[:3]))
        own = "—" if math.isnan(r.own_twist_lambda2) else f"{r.twist_lambda2 / r.own_twist_lambda2:.4f}"
        lines.append(
            f"| {r.name} | {r.EA_N:.6g} | {first} | {1e3 * r.twist_Hz:.4f} | {r.twist_lambda2:.4f} "
            f"| {r.twist_lambda2 / twist:.4f} | {r.saddle_lambda2 / saddle:.4f} | {own} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--units", type=int, default=19, help="cubes (cells) per side (default 19: 20 nodes)")
    parser.add_argument("--side-m", type=float, default=75.0, help="plate side [m] (default 75)")
    parser.add_argument("--EI-Nm2", type=float, default=1e3, help="calibrated bending stiffness [N m²] (default 1e3)")
    parser.add_argument("--mass-kg", type=float, default=200.0, help="total mass [kg] (default 200)")
    parser.add_argument("--nu", type=float, default=0.3, help="the Kirchhoff plate's Poisson ratio (default 0.3)")
    args = parser.parse_args()
    rows = plate_readings(units=args.units, side_m=args.side_m, EI_Nm2=args.EI_Nm2, mass_kg=args.mass_kg)
    print(table(rows, nu=args.nu))


if __name__ == "__main__":
    main()
