"""``magsail`` command line: build | validate | run | render | sweep | scaling | torque.

Exit codes: 0 success, 2 invalid input (config, arguments, run folder), 3 the simulation
diverged (its outputs up to the divergence are still written).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, Callable

__all__ = ["main"]


def _cmd_build(args: argparse.Namespace) -> int:
    from magsail_mj.config import load_config
    from magsail_mj.io import atomic_path
    from magsail_mj.scenarios import build_scenario

    cfg = load_config(args.config, args.set)
    scenario = build_scenario(cfg)
    out = Path(args.output) if args.output else Path(args.config).with_suffix(".xml")
    with atomic_path(out) as tmp:
        tmp.write_text(scenario.spec.to_xml())
    size = scenario.manifest_extra().get("model_size", {})
    print(json.dumps({"mjcf": str(out), **size}))
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    from magsail_mj.config import load_config

    cfg = load_config(args.config, args.set)
    print(json.dumps({"config": args.config, "concept": cfg.concept, "scenario": cfg.scenario, "valid": True}))
    return 0


def _cmd_run(args: argparse.Namespace) -> int:
    from magsail_mj.config import load_config
    from magsail_mj.io import to_jsonable
    from magsail_mj.run import run_scenario

    cfg = load_config(args.config, args.set)
    outcome = run_scenario(cfg, args.out, video=args.video, resume=args.resume, overwrite=args.overwrite,
                           progress=False if args.no_progress else None)
    print(json.dumps(to_jsonable(dict(outcome)), indent=2))
    print(f"run folder: {outcome.run_dir}", file=sys.stderr)
    if args.video:
        print(f"video: {outcome.run_dir / 'video.mp4'}", file=sys.stderr)
    if outcome.status == "diverged":
        print(f"error: simulation diverged: {outcome.get('status_message')}", file=sys.stderr)
        return 3
    return 0


def _cmd_render(args: argparse.Namespace) -> int:
    from magsail_mj.render import render_run

    out = render_run(Path(args.run_dir), Path(args.output), compare=Path(args.compare) if args.compare else None,
                     labels=args.labels)
    print(str(out))
    return 0


def _print_report(make: Callable[[], Any], options: dict[str, str] | None = None) -> int:
    """Print the report ``make()`` as one JSON line (exit 0); a ``ValueError`` is printed as
    ``error: ...`` on stderr with its leading key renamed by ``options`` to the command-line
    option (exit 2)."""
    from magsail_mj.io import to_jsonable

    options = options or {}
    try:
        report = make()
    except ValueError as err:
        msg = str(err)
        name = msg.split(":", 1)[0]
        print(f"error: {options.get(name, name)}{msg[len(name):]}", file=sys.stderr)
        return 2
    print(json.dumps(to_jsonable(report)))
    return 0


def _cmd_scaling_magnetorquer(args: argparse.Namespace) -> int:
    from magsail_mj.analysis.scaling import scaling_report

    side = args.side_m[0] if len(args.side_m) == 1 else args.side_m
    kappa = args.kappa[0] if len(args.kappa) == 1 else args.kappa
    return _print_report(lambda: scaling_report(side, kappa, altitude_km=args.altitude_km, total_kg=args.total_kg,
                                                rod_mass_kg=args.rod_mass_kg))


def _cmd_sweep(args: argparse.Namespace) -> int:
    from magsail_mj.sweep import load_sweep, run_sweep

    if args.workers < 1:
        print(f"error: --workers: must be >= 1, got {args.workers}", file=sys.stderr)
        return 2
    sweep = load_sweep(args.sweep, extra_overrides=tuple(args.set), only=args.only)
    out = Path(args.out) if args.out else Path("runs") / sweep.name
    records = run_sweep(sweep, out, workers=args.workers, video=args.video, overwrite=args.overwrite,
                        log=lambda line: print(line, file=sys.stderr))
    print(json.dumps({"sweep": sweep.name, "out": str(out),
                      "status": {r["id"]: r["status"] for r in records}}, indent=2))
    return 1 if any(r["status"] == "failed" for r in records) else 0


def _cmd_scaling_loops(args: argparse.Namespace) -> int:
    from magsail_mj.analysis.loop_scaling import loop_sizing, scaling_table

    options = {"geometry": "--geometry", "units": "--units", "side_m": "--side-m",
               "areal_density_kg_m2": "--areal-density", "kappa": "--kappa"}

    def report():
        if args.table:
            return scaling_table(side_m=args.side_m, areal_density_kg_m2=args.areal_density, kappa=args.kappa)
        if args.geometry is None:
            raise ValueError("geometry: required unless --table is given (one of A, B, C, D)")
        return loop_sizing(args.geometry, units=args.units, side_m=args.side_m,
                           areal_density_kg_m2=args.areal_density, kappa=args.kappa)

    return _print_report(report, options)


def _cmd_torque_coil(args: argparse.Namespace) -> int:
    from magsail_mj.analysis.coil_torque import coil_torque_report

    options = {"side_m": "--side-m", "segment_m": "--segment-m", "depth_m": "--depth-m", "current_A": "--current-a",
               "field_T": "--field-t", "pitch_cells": "--pitch-cells", "rows": "--rows"}
    return _print_report(lambda: coil_torque_report(
        side_m=args.side_m, segment_m=args.segment_m, depth_m=args.depth_m, current_A=args.current_a,
        field_T=args.field_t, pitch_cells=args.pitch_cells, rows=args.rows), options)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="magsail", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)

    b = sub.add_parser("build", help="write the MJCF of a config and print the model size")
    b.add_argument("config")
    b.add_argument("-o", "--output", help="MJCF path (default: next to the config, same stem)")
    b.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    b.set_defaults(fn=_cmd_build)

    v = sub.add_parser("validate", help="check a config and exit")
    v.add_argument("config")
    v.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    v.set_defaults(fn=_cmd_validate)

    r = sub.add_parser("run", help="simulate a config into a run folder")
    r.add_argument("config")
    r.add_argument("--out", required=True, help="run folder")
    r.add_argument("--video", action="store_true", help="also render video.mp4")
    r.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a config key, e.g. --set sim.duration_s=60")
    r.add_argument("--resume", action="store_true", help="continue from the folder's checkpoint")
    r.add_argument("--overwrite", action="store_true", help="replace an earlier run in --out")
    r.add_argument("--no-progress", action="store_true")
    r.set_defaults(fn=_cmd_run)

    rr = sub.add_parser("render", help="render a run folder to MP4 (optionally side by side)")
    rr.add_argument("run_dir")
    rr.add_argument("-o", "--output", required=True)
    rr.add_argument("--compare", help="second run folder, shown on the right")
    rr.add_argument("--labels", nargs=2, metavar=("LEFT", "RIGHT"))
    rr.set_defaults(fn=_cmd_render)

    sw = sub.add_parser("sweep", help="run every config of a sweep file in parallel worker processes")
    sw.add_argument("sweep", help="sweep TOML ([[run]] tables with id and config)")
    sw.add_argument("--out", help="sweep folder (default: runs/<sweep name>)")
    sw.add_argument("--workers", type=int, default=1, help="worker processes (default 1)")
    sw.add_argument("--only", action="append", metavar="TEXT",
                    help="run only the ids containing this text (repeatable: any of them)")
    sw.add_argument("--video", action="store_true", help="render video.mp4 in every run folder")
    sw.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="override a key in every run, e.g. --set sim.duration_s=60")
    sw.add_argument("--overwrite", action="store_true", help="rerun runs that already finished")
    sw.set_defaults(fn=_cmd_sweep)

    sc = sub.add_parser("scaling", help="analytic scaling laws (one JSON object on stdout)")
    scs = sc.add_subparsers(dest="law", required=True)
    mt = scs.add_parser("magnetorquer", help="rod mass fraction λ_f(d, κ_τ) (truss spec §8)")
    mt.add_argument("--side-m", type=float, nargs="+", required=True, help="plate side(s) d [m]")
    mt.add_argument("--kappa", type=float, nargs="+", required=True, help="dipole per rod mass κ_τ [A m²/kg]")
    mt.add_argument("--altitude-km", type=float, default=800.0)
    mt.add_argument("--total-kg", type=float, default=200.0)
    mt.add_argument("--rod-mass-kg", type=float, default=100.0)
    mt.set_defaults(fn=_cmd_scaling_magnetorquer)
    lo = scs.add_parser("loops", help="current-loop sizing: Eq.-9 current, wire, λ_f, power (current-loops §3)")
    lo.add_argument("--geometry", help="loop geometry A, B, C or D (Cx/Cy/Dx/Dy accepted)")
    lo.add_argument("--units", type=int, default=19, help="cubic units per side N (default 19)")
    lo.add_argument("--side-m", type=float, default=250.0, help="plate side D [m] (default 250)")
    lo.add_argument("--areal-density", type=float, default=0.1, metavar="KG_M2",
                    help="areal density σ_A [kg/m²] (default 0.1)")
    lo.add_argument("--kappa", type=float, default=15.0,
                    help="geometry A rim-inertia factor κ = 12 k_c − 1 (paper 15, physical 1)")
    lo.add_argument("--table", action="store_true",
                    help="print the §7.2 scaling object (A–D × N = 12, 19, 27) instead of one sizing")
    lo.set_defaults(fn=_cmd_scaling_loops)
    tq = sub.add_parser("torque", help="analytic actuator torques (one JSON object on stdout)")
    tqs = tq.add_subparsers(dest="actuator", required=True)
    tc = tqs.add_parser("coil", help="reflector coil paths: capability T_max, torque vectors (reflector spec §3.6)")
    tc.add_argument("--side-m", type=float, default=100.0, help="structure side d [m] (default 100)")
    tc.add_argument("--segment-m", type=float, default=1.0, help="segment length = cell edge L [m] (default 1)")
    tc.add_argument("--depth-m", type=float, default=None, help="lattice depth h [m] (default L, A1)")
    tc.add_argument("--current-a", type=float, default=10.0, help="maximum current I_max [A] (default 10)")
    tc.add_argument("--field-t", type=float, default=30e-6, help="reference field B_ref [T] (default 30e-6)")
    tc.add_argument("--pitch-cells", type=int, default=2, help="coil column pitch p [cells] (default 2, A2)")
    tc.add_argument("--rows", type=int, default=None, help="3/4 turns per column N_row (default d/L)")
    tc.set_defaults(fn=_cmd_torque_coil)
    return p


def main(argv: list[str] | None = None) -> int:
    from magsail_mj.config import ConfigError
    from magsail_mj.io import RunDirError

    args = _parser().parse_args(argv)
    try:
        return args.fn(args)
    except (ConfigError, RunDirError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
