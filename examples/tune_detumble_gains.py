"""CMA-ES search of the CNUSAIL detumble law's parameters over a training set of initial conditions.

    .venv/bin/python examples/tune_detumble_gains.py [--law non_monotonic] [--samples 64] [--seed 2017]
        [--horizon-s 11565] [--popsize 6] [--generations 6] [--max-cpu-s 1200] [--out search.json]

The training conditions are drawn from the detumble benchmark's ``[monte_carlo]`` table with
another seed (``--seed``; the benchmark's own, 2016, is the held-out set). The objective is
:class:`magsail_mj.control.tuning.DetumbleObjective`: the mean time to stay below 0.3 °/s over the
training worlds, run as one batch per parameter vector, a run that does not detumble within the
horizon counted at the horizon plus ``--penalty-s`` times its last-orbit rate over 0.3 °/s. CMA-ES
(Hansen's ``cma`` package) searches the law's parameters in log10 space from the shipped values;
the shipped point is evaluated first, so the best evaluated point scores at most as it does.
Printed and written to ``--out`` after every generation (JSON): the shipped and the best
parameters and scores, every evaluation, and the process time of the batches.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import asdict
from pathlib import Path

import cma

from magsail_mj.config import load_config, read_toml
from magsail_mj.control.tuning import DetumbleObjective, draw_conditions

BENCH = Path("magsail_mj/concepts/cnusail/configs/detumble_benchmark.toml")
NONMON = {"control.nonmonotonic_gain_per_Nms": (1.0, 6.0), "control.nonmonotonic_alpha": (-2.0, 4.0)}
LAWS = {  # tuned keys and their log10 bounds
    "non_monotonic": {**NONMON, "control.nonmonotonic_lookahead_s": (1.0, 3.5)},
    "proportional": {"control.bdot_gain_Am2s_T": (3.0, 6.0)},
}


def report(args: argparse.Namespace, objective: DetumbleObjective, generations: int, wall0: float) -> dict:
    """The search so far as JSON data, written to ``--out``."""
    evaluations = [asdict(e) for e in objective.evaluations]
    out = {"law": args.law, "training": {"samples": args.samples, "seed": args.seed, "horizon_s": args.horizon_s}}
    out |= {"penalty_s": args.penalty_s, "popsize": args.popsize, "generations": generations}
    out |= {"shipped": evaluations[0], "best": min(evaluations, key=lambda e: e["score_s"])}
    out |= {"evaluations": evaluations, "cpu_s": sum(e["cpu_s"] for e in evaluations)}
    out["wall_s"] = time.perf_counter() - wall0
    if args.out is not None:
        args.out.write_text(json.dumps(out, indent=1) + "\n")
    return out


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--law", choices=sorted(LAWS), default="non_monotonic")
    ap.add_argument("--samples", type=int, default=64, help="training conditions")
    ap.add_argument("--seed", type=int, default=2017, help="seed of the training draws (2016: held-out)")
    ap.add_argument("--horizon-s", type=float, default=11565.0, help="run length (default 2 orbits)")
    ap.add_argument("--penalty-s", type=float, default=5782.5, help="P of the objective (default 1 orbit)")
    ap.add_argument("--popsize", type=int, default=6)
    ap.add_argument("--generations", type=int, default=6)
    ap.add_argument("--sigma0", type=float, default=0.4, help="initial step [decades]")
    ap.add_argument("--max-cpu-s", type=float, default=1200.0, help="no generation starts that would pass it")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    wall0 = time.perf_counter()
    tree = read_toml(BENCH)
    config = BENCH.parent / tree["config"]
    shared = [s for s in tree["set"] if not s.startswith("sim.duration_s=")]
    shared += [f"sim.duration_s={args.horizon_s}", f'control.bdot_law="{args.law}"']
    bounds = LAWS[args.law]
    shipped = load_config(config, shared).control.model_dump()
    x0 = [math.log10(shipped[key.removeprefix("control.")]) for key in bounds]
    training = draw_conditions(BENCH, samples=args.samples, seed=args.seed)
    objective = DetumbleObjective(
        config=config, overrides=shared, conditions=training, keys=list(bounds), penalty_s=args.penalty_s
    )
    objective(x0)  # the shipped point
    low, high = zip(*bounds.values())
    opts = {"popsize": args.popsize, "bounds": [list(low), list(high)], "seed": 1, "verbose": -9}
    es, generations = cma.CMAEvolutionStrategy(x0, args.sigma0, opts), 0
    out = report(args, objective, generations, wall0)
    while not es.stop() and generations < args.generations:
        cpu = sum(e.cpu_s for e in objective.evaluations)
        if cpu + args.popsize * cpu / len(objective.evaluations) > args.max_cpu_s:
            break
        xs = es.ask()
        es.tell(xs, [objective(x) for x in xs])
        generations += 1
        out = report(args, objective, generations, wall0)  # the search so far, after every generation
        print(generations, json.dumps(out["best"]), file=sys.stderr)
    print(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
