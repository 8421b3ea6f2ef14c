"""A random policy on any environment: episode return and wall time per environment step.

    .venv/bin/python examples/random_policy.py [TASK_OR_CONFIG ...] [--set key=value ...] [--steps N]

Each named environment (a task of ``magsail_mj.envs.list()`` or a config path; default: every
registered task) is loaded with the overrides, reset with a seeded random episode start, and
driven by actions drawn uniformly within the action spec's bounds until the episode ends (or
``--steps`` steps). Printed per environment (one JSON line): steps, return, simulated time and wall
time per environment step.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import numpy as np

from magsail_mj import envs
from magsail_mj.concepts.cnusail import env as cnusail  # noqa: F401  (registers the CNUSAIL and MSAC tasks)
from magsail_mj.concepts.msac import env as msac  # noqa: F401  (registers the CNUSAIL and MSAC tasks)


def run_random(env: Any, *, seed: int = 0, max_steps: int | None = None) -> dict[str, Any]:
    """One episode of uniform random actions; returns steps, return and wall time per step."""
    rng = np.random.default_rng(seed)
    spec = env.action_spec()
    ts = env.reset()
    steps, ret = 0, 0.0
    wall0 = time.perf_counter()
    while not ts.last() and (max_steps is None or steps < max_steps):
        ts = env.step(rng.uniform(spec.minimum, spec.maximum).astype(spec.dtype))
        ret += float(ts.reward)
        steps += 1
    wall = time.perf_counter() - wall0
    return {
        "steps": steps,
        "return": ret,
        "simulated_s": float(env.physics.time()),
        "wall_per_step_s": wall / max(steps, 1),
        "last": bool(ts.last()),
        "discount": None if ts.discount is None else float(ts.discount),
    }


def main(argv: list[str] | None = None) -> list[dict[str, Any]]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="task names or config paths (default: every task)")
    ap.add_argument("--set", action="append", default=[], help="config override key=value (repeatable)")
    ap.add_argument("--steps", type=int, default=None, help="largest number of steps per episode")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    out = []
    for name in args.names or envs.list():
        env = envs.load(name, list(args.set), random=args.seed)
        row = {"env": name, **run_random(env, seed=args.seed, max_steps=args.steps)}
        print(json.dumps(row), flush=True)
        out.append(row)
    return out


if __name__ == "__main__":
    main()
