"""Batched worlds: the CNUSAIL detumble's cost per world-step in a batch, against MuJoCo's bare step.

The config is ``magsail_mj/concepts/cnusail/configs/detumble_pre.toml`` (S1: stowed cubesat, B-dot,
RK4 at 0.2 s with mid-step loads), cut to ``--steps`` steps. For N = 1, 16, 64, 256 worlds
(``--worlds``) on 1 and 2 threads (``--threads``), a batch (:func:`magsail_mj.batch.load_batch`)
whose worlds differ in their initial rate (direction uniform on the sphere, magnitude uniform in
2–10 °/s, seeded; with ``--epochs`` each world also gets its own epoch in 2016, hence its own
environment tables) is run for the steps, records kept in memory, and the table gives per
world-step:

* the wall time of the batch's step loop (``us/ws``) and the process's CPU time over it, every
  thread counted (``cpu us/ws``);
* their ratios to the bare single-thread ``mujoco.mj_step`` of the same model from world 0's
  initial state, one Python call per step (wall to its wall, CPU to its CPU: the same pass is
  timed both ways), and to the single run's all-in step (:class:`magsail_mj.sim.Simulation` of
  the same config, records in memory, wall);
* the build time of the batch.

``--loads compiled`` runs the batches and the single run with compiled loads (``sim.loads =
"compiled"``: the plugin inside each world's step, Python only at the controller's samples and the
records); the bare step is still that of the model without the plugin.

Everything is measured in one run of this script, so the ratios compare like with like on the
machine as it is then; absolute times move with the machine and its load.

    nice -n 10 python scripts/bench_batch.py              # 2000 steps (400 s) per pass, ≈ 5 min
    python scripts/bench_batch.py --steps 500 --worlds 1 16 --threads 1
    python scripts/bench_batch.py --epochs --json bench_batch.json
    nice -n 10 python scripts/bench_batch.py --loads compiled --worlds 256 --threads 1
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time
from pathlib import Path

import magsail_mj  # first: chooses the GL backend before mujoco is imported
import mujoco
import numpy as np

CONFIG = Path(__file__).resolve().parents[1] / "magsail_mj/concepts/cnusail/configs/detumble_pre.toml"
_PHYSICS = mujoco.mjtState.mjSTATE_PHYSICS


def world_overrides(n: int, *, epochs: bool, seed: int = 2016) -> list[list[str]]:
    """Per world: an initial rate of uniform direction and magnitude in 2–10 °/s (and an epoch in 2016)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        d = rng.normal(size=3)
        w = (d / np.linalg.norm(d) * rng.uniform(2.0, 10.0)).tolist()
        sets = [f"initial.omega0_deg_s=[{w[0]!r}, {w[1]!r}, {w[2]!r}]"]
        if epochs:
            t = np.datetime64("2016-01-01T00:00:00") + np.timedelta64(int(rng.integers(0, 366 * 86400)), "s")
            sets.append(f'orbit.epoch="{t}Z"')
        out.append(sets)
    return out


def bare_step(model: mujoco.MjModel, physics: np.ndarray, steps: int) -> dict[str, float]:
    """µs per bare ``mj_step`` (one Python call each): wall and CPU of the same pass, and native nstep."""
    d = mujoco.MjData(model)
    mujoco.mj_setState(model, d, physics, _PHYSICS)
    t0, c0 = time.perf_counter(), time.thread_time()
    for _ in range(steps):
        mujoco.mj_step(model, d)
    wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
    mujoco.mj_setState(model, d, physics, _PHYSICS)
    t0 = time.perf_counter()
    mujoco.mj_step(model, d, steps)
    native = time.perf_counter() - t0
    return {"wall_us": wall / steps * 1e6, "cpu_us": cpu / steps * 1e6, "native_us": native / steps * 1e6}


def single_step_us(overrides: list[str], steps: int) -> float:
    """µs per step of the single run's loop (all-in, records in memory)."""
    result = magsail_mj.load(CONFIG, overrides).run()
    if result.status != "completed":
        raise RuntimeError(f"single run: {result.status}: {result.message}")
    return result.wall_time_s / steps * 1e6


def batch_pass(overrides: list[str], n: int, nthread: int, *, epochs: bool) -> dict[str, float]:
    """One batch of ``n`` worlds on ``nthread`` threads: µs per world-step (wall, CPU) and build s."""
    t0 = time.perf_counter()
    sim = magsail_mj.load(CONFIG, overrides, world_overrides=world_overrides(n, epochs=epochs), nthread=nthread)
    build = time.perf_counter() - t0
    c0 = time.process_time()
    result = sim.run()
    cpu = time.process_time() - c0
    bad = [f"world {k}: {w.status}" for k, w in enumerate(result.worlds) if w.status != "completed"]
    if bad:
        raise RuntimeError(f"batch of {n}: {', '.join(bad[:3])}")
    model = getattr(sim.worlds, "bare_model", sim.model)  # without the compiled loads' plugin
    physics = np.empty(mujoco.mj_stateSize(model, _PHYSICS))
    data = mujoco.MjData(model)
    sim.worlds.init_state(0, data)
    mujoco.mj_getState(model, data, physics, _PHYSICS)
    return {
        "us_per_world_step": result.wall_time_s / result.world_steps * 1e6,
        "cpu_us_per_world_step": cpu / result.world_steps * 1e6,
        "build_s": build,
        "physics": physics,
        "model": model,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=2000, help="steps per pass (default 2000 = 400 s)")
    ap.add_argument("--worlds", type=int, nargs="+", default=[1, 16, 64, 256], help="batch sizes")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2], help="batch thread counts")
    ap.add_argument("--epochs", action="store_true", help="each world its own epoch (own environment tables)")
    ap.add_argument("--json", type=Path, default=None, help="also write the figures as JSON")
    ap.add_argument("--loads", choices=("python", "compiled"), default="python", help="sim.loads (default python)")
    args = ap.parse_args()
    overrides = [f"sim.duration_s={args.steps * 0.2!r}", f"sim.loads={args.loads!r}"]
    single = single_step_us(overrides, args.steps)
    rows = []
    bare = None
    for n in args.worlds:
        for nthread in args.threads:
            row = batch_pass(overrides, n, nthread, epochs=args.epochs)
            if bare is None:  # the bare step of the same model, right after the first batch
                bare = bare_step(row["model"], row["physics"], args.steps)
            rows.append(
                {
                    "worlds": n,
                    "nthread": nthread,
                    "us_per_world_step": row["us_per_world_step"],
                    "cpu_us_per_world_step": row["cpu_us_per_world_step"],
                    "ratio_to_mj_step": row["us_per_world_step"] / bare["wall_us"],
                    "cpu_ratio_to_mj_step": row["cpu_us_per_world_step"] / bare["cpu_us"],
                    "ratio_to_single_step": row["us_per_world_step"] / single,
                    "build_s": row["build_s"],
                }
            )
            print(
                f"N={n:4d} threads={nthread}: {row['us_per_world_step']:8.2f} us/ws wall, "
                f"{row['cpu_us_per_world_step']:8.2f} cpu",
                flush=True,
            )
    assert bare is not None
    print()
    print(
        f"config {CONFIG.name}, {args.steps} steps, loads {args.loads}, epochs per world: {args.epochs}; "
        f"bare mj_step {bare['wall_us']:.2f} us wall, {bare['cpu_us']:.2f} us CPU "
        f"(native nstep {bare['native_us']:.2f} us); single run {single:.2f} us/step "
        f"(÷ mj_step {single / bare['wall_us']:.2f})"
    )
    print()
    print(
        "| worlds | threads | µs/world-step | CPU µs/world-step | ÷ mj_step | CPU ÷ mj_step | ÷ single step | build s |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(
            f"| {r['worlds']} | {r['nthread']} | {r['us_per_world_step']:.2f} | {r['cpu_us_per_world_step']:.2f} | "
            f"{r['ratio_to_mj_step']:.2f} | {r['cpu_ratio_to_mj_step']:.2f} | {r['ratio_to_single_step']:.3f} | "
            f"{r['build_s']:.1f} |"
        )
    if args.json is not None:
        out = {
            "config": str(CONFIG),
            "steps": args.steps,
            "epochs": args.epochs,
            "loads": args.loads,
            "mj_step": bare,
            "single_us_per_step": single,
            "rows": rows,
            "platform": {"python": platform.python_version(), "mujoco": mujoco.__version__, "numpy": np.__version__},
        }
        args.json.write_text(json.dumps(out, indent=1, allow_nan=False))
    return 0 if all(math.isfinite(r["us_per_world_step"]) for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
