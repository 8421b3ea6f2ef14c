"""``magsail scaling magnetorquer|loops`` and ``magsail torque coil``: analytic reports, one JSON object."""

from __future__ import annotations

import argparse

from magsail_mj.analysis.coil_torque import coil_torque_report
from magsail_mj.analysis.loop_scaling import loop_sizing, scaling_table
from magsail_mj.analysis.scaling import scaling_report
from magsail_mj.cli import CliInputError
from magsail_mj.resources import check_memory
from magsail_mj.verbs.common import print_json

__all__ = ["scaling_loops", "scaling_magnetorquer", "torque_coil"]

_SMALL_REPORT_BYTES = 1 << 20  # analytic reports of fixed size (loop sizing, the A–D × N scaling table)
_SCALING_ENTRY_BYTES = 200  # one entry of the λ_f(d, κ) table, see scaling_magnetorquer


def scaling_magnetorquer(args: argparse.Namespace) -> int:
    """The rod mass fraction λ_f(d, κ_τ) for every side and κ given."""
    # the report is a len(side) × len(kappa) table of λ_f, built as floats, Python objects and JSON
    # text: 172–178 bytes per entry measured (max RSS over the base process, 1e6 and 9e6 entries)
    check_memory(
        _SCALING_ENTRY_BYTES * len(args.side_m) * len(args.kappa) + _SMALL_REPORT_BYTES,
        what=f"scaling magnetorquer ({len(args.side_m)} × {len(args.kappa)} table)",
    )
    side = args.side_m[0] if len(args.side_m) == 1 else args.side_m
    kappa = args.kappa[0] if len(args.kappa) == 1 else args.kappa
    report = scaling_report(
        side, kappa, altitude_km=args.altitude_km, total_kg=args.total_kg, rod_mass_kg=args.rod_mass_kg
    )
    print_json(report, what="--side-m, --kappa, --altitude-km, --total-kg, --rod-mass-kg")
    return 0


def scaling_loops(args: argparse.Namespace) -> int:
    """One current-loop sizing, or the A–D × N table with ``--table``."""
    check_memory(_SMALL_REPORT_BYTES, what="scaling loops")
    if args.table:
        report = scaling_table(side_m=args.side_m, areal_density_kg_m2=args.areal_density, kappa=args.kappa)
    elif args.geometry is None:
        raise CliInputError("--geometry: required unless --table is given (one of A, B, C, D)")
    else:
        report = loop_sizing(
            args.geometry,
            units=args.units,
            side_m=args.side_m,
            areal_density_kg_m2=args.areal_density,
            kappa=args.kappa,
        )
    print_json(report, what="--geometry, --units, --side-m, --areal-density, --kappa")
    return 0


def torque_coil(args: argparse.Namespace) -> int:
    """The capability of a reflector coil path."""
    report = coil_torque_report(
        side_m=args.side_m,
        segment_m=args.segment_m,
        depth_m=args.depth_m,
        current_A=args.current_a,
        field_T=args.field_t,
        pitch_cells=args.pitch_cells,
        rows=args.rows,
    )
    print_json(report, what="--side-m, --segment-m, --depth-m, --current-a, --field-t, --pitch-cells, --rows")
    return 0
