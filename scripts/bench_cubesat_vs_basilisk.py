"""The CNUSAIL stowed detumble: the project's step loop against the Basilisk rebuild, back to back.

The peer is an independent Basilisk rebuild of ``detumble_pre.toml``, kept outside this
repository and given with ``--peer-dir`` (a folder holding ``bsk_detumble.py``: rigid hub, point
mass + J2, WMM field, B-dot as a Basilisk Python module, ``MtbEffector``, gravity gradient; RK4 at
0.1 s; it writes its wall time around ``ExecuteSimulation``). It needs ``bsk`` 2.12.1
in a separate environment (never a dependency of this package)::

    python3 -m venv /tmp/bsk && /tmp/bsk/bin/pip install bsk==2.12.1 numpy matplotlib

Each round runs, for the same simulated duration and step, first the peer (its own timer around
``ExecuteSimulation``: the whole loop with its recorders) in a subprocess, then
:func:`magsail_mj.bench.bench` of the project config with the sources the peer does not model
switched off (drag, SRP, residual dipole: the comparison of the peer's README); ``--rounds``
rounds alternate the two, and the medians are compared. Prints one JSON object:
``project_us_per_step``, ``basilisk_us_per_step``, ``cost_ratio`` (project / Basilisk, per
simulated second as both take the same steps; the target is ≤ 0.5), and the project's
``ratio_to_mj_step`` (target ≤ 3) with its parts. The same bench call times the project's compiled
loads (``sim.loads = "compiled"``, loads held over the step as above): ``project_us_per_step_compiled``
and ``cost_ratio_compiled``; ``--stage`` adds per round a bench of the compiled loads evaluated at
every RK4 stage (``sim.load_timing = "stage"``: fourth order, as Basilisk's torque rods, which it
evaluates at every stage): ``project_us_per_step_compiled_stage`` and ``cost_ratio_compiled_stage``.

    python scripts/bench_cubesat_vs_basilisk.py --duration 1800 --rounds 3 --stage
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from magsail_mj.bench import bench

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "magsail_mj/concepts/cnusail/configs/detumble_pre.toml"
SAME_PHYSICS = (
    "drag.enabled=false",
    "srp.enabled=false",
    "spacecraft.residual_dipole_Am2=[0.0, 0.0, 0.0]",
    "sim.integrator='RK4'",
    "sim.timestep_s=0.1",
    "sim.load_timing='start'",
    "sim.record_every=10",
)
"""The overrides that leave the physics the peer models (its README) and its integrator and step
(RK4 at 0.1 s, loads held over the step), so both loops take the same steps (the shipped config
steps 0.2 s with mid-step loads: its own cost per simulated second is lower still)."""


def peer_us_per_step(python: str, peer_dir: Path, duration_s: float) -> float:
    """µs per step of one run of the Basilisk rebuild (its timer around ``ExecuteSimulation``)."""
    with tempfile.TemporaryDirectory(prefix="bsk_bench_") as out:
        proc = subprocess.run(
            [python, str(peer_dir / "bsk_detumble.py"), "--out", out, "--duration", repr(duration_s)],
            capture_output=True,
            text=True,
            check=False,
        )
        if proc.returncode != 0:
            raise RuntimeError(f"--bsk-python: the peer run failed ({proc.returncode}): {proc.stderr.strip()[-500:]}")
        info = json.loads((Path(out) / "bsk_info.json").read_text())
    return info["wall_s"] / info["steps"] * 1e6


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=float, default=1800.0, help="simulated seconds per run (default 1800)")
    ap.add_argument("--rounds", type=int, default=3, help="alternating rounds; medians compared (default 3)")
    ap.add_argument(
        "--bsk-python",
        default=os.environ.get("BSK_PYTHON", "/tmp/bsk/bin/python"),
        help="Python of the environment with bsk 2.12.1 (default $BSK_PYTHON or /tmp/bsk/bin/python)",
    )
    ap.add_argument("--peer-dir", type=Path, required=True, help="folder of the rebuild's bsk_detumble.py")
    ap.add_argument("--stage", action="store_true", help="also time compiled loads evaluated at every RK4 stage")
    args = ap.parse_args(argv)
    if not (args.duration > 0 and args.rounds >= 1):
        ap.error("--duration must be > 0 and --rounds >= 1")
    if not Path(args.bsk_python).is_file():
        ap.error(f"--bsk-python: no such interpreter {args.bsk_python!r} (see the module docstring)")
    peer, ours, ratios, runs, compiled, stage = [], [], [], [], [], []
    for _ in range(args.rounds):
        peer.append(peer_us_per_step(args.bsk_python, args.peer_dir, args.duration))
        r = bench(CONFIG, overrides=SAME_PHYSICS, duration_s=args.duration)
        ours.append(r["us_per_step"])
        ratios.append(r["ratio_to_mj_step"])
        compiled.append(r.get("us_per_step_compiled", math.nan))
        runs.append(r)
        if args.stage:
            over = (*SAME_PHYSICS, "sim.loads='compiled'", "sim.load_timing='stage'")
            stage.append(bench(CONFIG, overrides=over, duration_s=args.duration)["us_per_step"])
    mid = runs[sorted(range(len(ours)), key=ours.__getitem__)[len(ours) // 2]]
    bsk = statistics.median(peer)
    extra = {
        "project_us_per_step_compiled": statistics.median(compiled),
        "cost_ratio_compiled": statistics.median(compiled) / bsk,
        "project_compiled_runs_us": compiled,
    }
    if stage:
        extra.update(
            project_us_per_step_compiled_stage=statistics.median(stage),
            cost_ratio_compiled_stage=statistics.median(stage) / bsk,
            project_compiled_stage_runs_us=stage,
        )
    out = {
        "duration_s": args.duration,
        "steps": mid["steps"],
        "rounds": args.rounds,
        "project_us_per_step": statistics.median(ours),
        "basilisk_us_per_step": statistics.median(peer),
        "cost_ratio": statistics.median(ours) / statistics.median(peer),
        "ratio_to_mj_step": statistics.median(ratios),
        **extra,
        "project_runs_us": ours,
        "basilisk_runs_us": peer,
        "project_parts_us": mid["parts_us"],
        "mj_step_us": mid["mj_step_us"],
        "platform": mid["platform"],
        "overrides": list(SAME_PHYSICS),
    }
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
