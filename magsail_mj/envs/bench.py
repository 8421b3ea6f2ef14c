"""Speed of the environments: cost per simulated second through ``dm_control`` against the plain run.

For each concept, one task with its shipped config (and the overrides of :data:`CASES`, which keep
the measurement short) is run twice in the same process:

* plain: ``magsail_mj.load(config, overrides).run()`` — the runner with the shipped controller;
* environment: ``magsail_mj.envs.load(task, overrides, randomize=False)`` driven by
  :func:`magsail_mj.envs.shipped_policy` (the same controller, the same physics) from reset to the
  end of the episode.

The cost of each is its CPU time (``time.process_time``: the rollouts run in the calling thread) divided
by the simulated time; ``ratio`` = environment/plain is the overhead of the environment (the target is ≤
1.25). The shipped policy computes the shipped controller's command from the state (the runner's
kinematics and environment sample, then the controller: the work the plain run does inside its step),
which the environment then turns back into the command from the action: its own CPU time is measured
around each policy call, and ``ratio_without_policy`` = (environment − policy)/plain is the
environment's overhead alone, the cost of an agent's policy left out. The wall-clock costs and their
ratio are given too (``wall_ratio``); on a shared machine they move with its load, the CPU times much
less. Builds are not timed. Each measurement is repeated ``repeats`` times, alternating plain and
environment, and the smallest time of each is kept. The environments compute every observation the
shipped controller uses at every step; the truss's structural-health observations are refreshed at their
documented lower rate.

    .venv/bin/python scripts/bench_envs.py [--concepts cnusail msac] [--repeats 3]

prints one JSON object: concept → task, overrides, simulated time, environment steps, the CPU and
wall costs [s per simulated s] and their ratios, the policy's own share left out in
``ratio_without_policy`` (or ``error`` when a case could not run).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any, Sequence

import magsail_mj
from magsail_mj import envs
from magsail_mj.envs.core import task_entry

__all__ = ["CASES", "measure", "main"]

CASES: dict[str, tuple[str, tuple[str, ...], dict[str, Any]]] = {
    "truss_magnetorquer": ("truss/detumble", ("sim.duration_s=10",), {}),
    "truss_magnetorquer_3_units": ("truss/detumble", ("lattice.units=3", "sim.duration_s=60"), {}),
    "current_loops": ("current_loops/slew", ("sim.duration_s=20",), {}),
    "reflector": ("reflector/detumble", ("sim.duration_s=60",), {}),
    "cnusail": ("cnusail/detumble", ("sim.duration_s=600",), {}),
    "msac": ("msac/cycle", ("sim.duration_s=0.2",), {}),
    "msac_20_cycles_per_step": ("msac/cycle", ("sim.duration_s=0.2",), {"cycles_per_step": 20}),
    "structure": ("structure/detumble", ("sim.duration_s=60", "sim.progress=false"), {}),
}
"""Concept → (task, overrides, task options) of the measurement. The truss is measured with the
shipped lattice and with a 3-unit one (whose steps cost little, so the environment's fixed cost per
step weighs more). MSAC is measured at one cycle per
environment step (its default) and at 20: the runner's fixed cost per ``step`` call (a
``mujoco.rollout`` call, the re-tiled control table of a whole rollout chunk and the chunk
bookkeeping) is spread over more dynamics steps. The structure concept is measured on its shipped
100 m sail (control every 0.5 s: ten RK4 steps per environment step)."""


def _plain(task: str, overrides: Sequence[str]) -> tuple[float, float, float]:
    sim = magsail_mj.load(task_entry(task).config, list(overrides))
    t0, c0 = time.perf_counter(), time.process_time()
    result = sim.run()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    if result.status != "completed":
        raise RuntimeError(f"plain run of {task} ended {result.status!r}: {result.message}")
    return wall, cpu, float(result.t_end_s)


def _environment(
    task: str, overrides: Sequence[str], options: dict[str, Any]
) -> tuple[float, float, float, int, float]:
    env = envs.load(task, list(overrides), randomize=False, **options)
    policy = envs.shipped_policy(env)
    clock = time.process_time
    t0, c0 = time.perf_counter(), clock()
    ts = env.reset()
    steps, policy_cpu = 0, 0.0
    while not ts.last():
        p0 = clock()
        action = policy(ts)
        policy_cpu += clock() - p0
        ts = env.step(action)
        steps += 1
    wall, cpu = time.perf_counter() - t0, clock() - c0
    return wall, cpu, float(env.physics.time()), steps, policy_cpu


def measure(concept: str, *, repeats: int = 3) -> dict[str, Any]:
    """The costs and their ratio for ``concept`` (:data:`CASES`)."""
    if concept not in CASES:
        raise ValueError(f"concept: expected one of {', '.join(CASES)}, got {concept!r}")
    if int(repeats) != repeats or repeats < 1:
        raise ValueError(f"repeats: must be an integer >= 1, got {repeats!r}")
    task, overrides, options = CASES[concept]
    plain, env = [], []
    for _ in range(int(repeats)):
        plain.append(_plain(task, overrides))
        env.append(_environment(task, overrides, options))
    sim_p, sim_e, steps = plain[0][2], env[0][2], env[0][3]
    wall_p, wall_e = min(p[0] for p in plain) / sim_p, min(e[0] for e in env) / sim_e
    cpu_p, cpu_e = min(p[1] for p in plain) / sim_p, min(e[1] for e in env) / sim_e
    cpu_x = min(e[1] - e[4] for e in env) / sim_e
    return {
        "task": task,
        "overrides": list(overrides),
        "options": options,
        "simulated_s": sim_e,
        "env_steps": steps,
        "plain_cpu_s_per_sim_s": cpu_p,
        "env_cpu_s_per_sim_s": cpu_e,
        "ratio": cpu_e / cpu_p,
        "env_cpu_s_per_sim_s_without_policy": cpu_x,
        "ratio_without_policy": cpu_x / cpu_p,
        "plain_wall_s_per_sim_s": wall_p,
        "env_wall_s_per_sim_s": wall_e,
        "wall_ratio": wall_e / wall_p,
        "repeats": int(repeats),
    }


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description="environment overhead per concept (JSON)")
    ap.add_argument("--concepts", nargs="*", default=list(CASES), choices=list(CASES))
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    out: dict[str, Any] = {}
    for concept in args.concepts:
        try:
            out[concept] = measure(concept, repeats=args.repeats)
        except Exception as err:  # a case that cannot run is reported, the others still measured
            out[concept] = {"task": CASES[concept][0], "error": f"{type(err).__name__}: {err}"}
        print(json.dumps({concept: out[concept]}), file=sys.stderr, flush=True)
    print(json.dumps(out, indent=1))
    return out
