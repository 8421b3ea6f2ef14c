"""Batched worlds: a detumble's cost per world-step in a batch, against MuJoCo's bare step.

``--config cnusail`` (the default): ``magsail_mj/concepts/cnusail/configs/detumble_pre.toml`` (S1:
stowed cubesat, B-dot, RK4 at 0.2 s with mid-step loads), N = 1, 16, 64, 256 worlds, 2000 steps.
``--config truss``: ``magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml`` (the 800-node
truss lattice, 2 400 DOF and 3 402 spring tendons, RK4 at 0.1 s; tidal gravity on every particle,
760 magnetorquer rods, B-dot through the rod allocation every step), N = 8, 16 worlds, 300 steps.
The config is cut to ``--steps`` steps. For each N (``--worlds``) on 1 and 2 threads
(``--threads``), a batch (:func:`magsail_mj.batch.load_batch`) whose worlds differ in their initial
rate (direction uniform on the sphere, magnitude uniform in 2–10 °/s for the cubesat, 0.005–0.015
rad/s for the truss, seeded; with ``--epochs`` each world also gets its own epoch in 2016, hence its
own environment tables) is run for the steps, records kept in memory, and the table gives per
world-step:

* the wall time of the batch's step loop (``us/ws``) and the process's CPU time over it, every
  thread counted (``cpu us/ws``);
* their ratios to the bare single-thread ``mujoco.mj_step`` of the same model from world 0's
  initial state, one Python call per step (wall to its wall, CPU to its CPU: the same pass is
  timed both ways), and to the single run's all-in step (:class:`magsail_mj.sim.Simulation` of
  the same config, records in memory, wall);
* the Python share of the step loop: the part of its wall time outside MuJoCo's batched
  ``Batch.step`` (the plant's controller, probes and loads, the runner's checks and records), and
  the calling thread's CPU time outside it per world-step (``Python CPU``);
* the build time of the batch;
* per N, the wall-time ratio of the 1-thread pass to the 2-thread pass (the thread speed-up), and
  the speed-up the 1-thread pass's CPU times allow, ``(P + M)/(P + M/2)`` with the Python CPU ``P``
  serial and the rest ``M`` split evenly over two cores (CPU times do not stretch when other
  processes share the cores; wall times do).

``--loads compiled`` runs the batches and the single run with compiled loads (``sim.loads =
"compiled"``: the plugin inside each world's step, Python only at the controller's samples and the
records); the bare step is still that of the model without the plugin.

Everything is measured in one run of this script, so the ratios compare like with like on the
machine as it is then; absolute times move with the machine and its load.

    nice -n 10 python scripts/bench_batch.py              # 2000 steps (400 s) per pass, ≈ 5 min
    python scripts/bench_batch.py --steps 500 --worlds 1 16 --threads 1
    python scripts/bench_batch.py --epochs --json bench_batch.json
    nice -n 10 python scripts/bench_batch.py --loads compiled --worlds 256 --threads 1
    nice -n 10 python scripts/bench_batch.py --config truss   # 8 and 16 worlds, 300 steps, ≈ 3 min
    nice -n 10 python scripts/bench_batch.py --config truss --warm   # each batch's second run timed
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

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = {
    "cnusail": ROOT / "magsail_mj/concepts/cnusail/configs/detumble_pre.toml",
    "truss": ROOT / "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml",
}
#: per config: time step [s], initial-rate key, rate range (in the key's unit), default worlds and steps
SETUP = {
    "cnusail": (0.2, "initial.omega0_deg_s", (2.0, 10.0), [1, 16, 64, 256], 2000),
    "truss": (0.1, "initial.omega0_rad_s", (0.005, 0.015), [8, 16], 300),
}
CONFIG = CONFIGS["cnusail"]
_PHYSICS = mujoco.mjtState.mjSTATE_PHYSICS


class TimedBatch:
    """A :class:`mujoco.batch.Batch` whose ``step`` calls are timed (``step_s`` [s] of wall time in
    them, ``step_cpu_s`` [s] of the calling thread's CPU time); everything else is the batch's own."""

    def __init__(self, batch: object) -> None:
        self._batch = batch
        self.step_s = 0.0
        self.step_cpu_s = 0.0

    def step(self, *args: object) -> object:
        t0, c0 = time.perf_counter(), time.thread_time()
        try:
            return self._batch.step(*args)
        finally:
            self.step_s += time.perf_counter() - t0
            self.step_cpu_s += time.thread_time() - c0

    def __getattr__(self, name: str) -> object:
        return getattr(self._batch, name)


def world_overrides(
    n: int,
    *,
    epochs: bool,
    seed: int = 2016,
    key: str = "initial.omega0_deg_s",
    rate: tuple[float, float] = (2.0, 10.0),
) -> list[list[str]]:
    """Per world: an initial rate ``key`` of uniform direction and magnitude uniform in ``rate`` (and
    an epoch in 2016)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        d = rng.normal(size=3)
        w = (d / np.linalg.norm(d) * rng.uniform(*rate)).tolist()
        sets = [f"{key}=[{w[0]!r}, {w[1]!r}, {w[2]!r}]"]
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


def single_step_us(overrides: list[str], steps: int, *, config: Path = CONFIG) -> float:
    """µs per step of the single run's loop (all-in, records in memory)."""
    result = magsail_mj.load(config, overrides).run()
    if result.status != "completed":
        raise RuntimeError(f"single run: {result.status}: {result.message}")
    return result.wall_time_s / steps * 1e6


def batch_pass(
    overrides: list[str],
    n: int,
    nthread: int,
    *,
    epochs: bool,
    config: Path = CONFIG,
    setup: tuple = SETUP["cnusail"],
    warm: bool = False,
) -> dict[str, float]:
    """One batch of ``n`` worlds on ``nthread`` threads: µs per world-step (wall, CPU), the Python
    share of the loop's wall time and the build s. ``warm``: run the steps once first and time the
    run after ``reset()`` (what a world computes once and keeps, such as the truss's Lloyd rod
    selections of each new rod count, is then already there, as through most of a long run)."""
    _, key, rate, _, _ = setup
    t0 = time.perf_counter()
    worlds = world_overrides(n, epochs=epochs, key=key, rate=rate)
    sim = magsail_mj.load(config, overrides, world_overrides=worlds, nthread=nthread)
    build = time.perf_counter() - t0
    if warm:
        sim.run()
        sim.reset()
    timed = sim.batch = TimedBatch(sim.batch)
    c0, m0 = time.process_time(), time.thread_time()
    result = sim.run()
    cpu, main_cpu = time.process_time() - c0, time.thread_time() - m0
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
        "python_share": 1.0 - timed.step_s / result.wall_time_s,
        "python_cpu_us_per_world_step": (main_cpu - timed.step_cpu_s) / result.world_steps * 1e6,
        "build_s": build,
        "physics": physics,
        "model": model,
    }


def _row(n: int, nthread: int, row: dict[str, float], bare: dict[str, float], single: float) -> dict[str, float]:
    return {
        "worlds": n,
        "nthread": nthread,
        "us_per_world_step": row["us_per_world_step"],
        "cpu_us_per_world_step": row["cpu_us_per_world_step"],
        "ratio_to_mj_step": row["us_per_world_step"] / bare["wall_us"],
        "cpu_ratio_to_mj_step": row["cpu_us_per_world_step"] / bare["cpu_us"],
        "ratio_to_single_step": row["us_per_world_step"] / single,
        "python_share": row["python_share"],
        "python_cpu_us_per_world_step": row["python_cpu_us_per_world_step"],
        "python_cpu_share": row["python_cpu_us_per_world_step"] / row["cpu_us_per_world_step"],
        "build_s": row["build_s"],
    }


def _speedups(rows: list[dict[str, float]]) -> dict[int, float]:
    """Per batch size with a 1- and a 2-thread pass: wall(1 thread) / wall(2 threads)."""
    wall = {(r["worlds"], r["nthread"]): r["us_per_world_step"] for r in rows}
    return {n: wall[(n, 1)] / wall[(n, 2)] for n, t in wall if t == 1 and (n, 2) in wall}


def _amdahl(rows: list[dict[str, float]]) -> dict[int, float]:
    """Per batch size with a 1-thread pass: the 2-thread speed-up its CPU times allow when MuJoCo's
    part splits evenly over two cores and the Python part does not, ``(P + M) / (P + M/2)`` with
    ``P`` the Python CPU and ``M`` the rest of the pass's CPU per world-step (robust to other
    processes on the machine, which stretch the wall times)."""
    out = {}
    for r in rows:
        if r["nthread"] == 1:
            P = r["python_cpu_us_per_world_step"]
            M = r["cpu_us_per_world_step"] - P
            out[r["worlds"]] = (P + M) / (P + 0.5 * M)
    return out


def _print_table(rows: list[dict[str, float]]) -> None:
    print(
        "| worlds | threads | µs/world-step | CPU µs/world-step | ÷ mj_step | CPU ÷ mj_step | ÷ single step "
        "| Python share | Python CPU µs/world-step | build s |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(
            f"| {r['worlds']} | {r['nthread']} | {r['us_per_world_step']:.2f} | {r['cpu_us_per_world_step']:.2f} | "
            f"{r['ratio_to_mj_step']:.2f} | {r['cpu_ratio_to_mj_step']:.2f} | {r['ratio_to_single_step']:.3f} | "
            f"{r['python_share']:.3f} | {r['python_cpu_us_per_world_step']:.1f} | {r['build_s']:.1f} |"
        )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", choices=sorted(CONFIGS), default="cnusail", help="the detumble (default cnusail)")
    ap.add_argument("--steps", type=int, default=None, help="steps per pass (default 2000 cnusail, 300 truss)")
    ap.add_argument("--worlds", type=int, nargs="+", default=None, help="batch sizes (default 1 16 64 256; 8 16)")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2], help="batch thread counts")
    ap.add_argument("--epochs", action="store_true", help="each world its own epoch (own environment tables)")
    ap.add_argument("--json", type=Path, default=None, help="also write the figures as JSON")
    ap.add_argument("--loads", choices=("python", "compiled"), default="python", help="sim.loads (default python)")
    ap.add_argument("--warm", action="store_true", help="time each batch's second run of the steps (after reset)")
    args = ap.parse_args()
    config, setup = CONFIGS[args.config], SETUP[args.config]
    dt, _, _, default_worlds, default_steps = setup
    steps = args.steps if args.steps is not None else default_steps
    worlds = args.worlds if args.worlds is not None else default_worlds
    if args.loads == "compiled" and args.config == "truss":
        ap.error("--loads: the truss batch runs its loads in NumPy (python) only")
    overrides = [f"sim.duration_s={steps * dt!r}", f"sim.loads={args.loads!r}"]
    single = single_step_us(overrides, steps, config=config)
    rows = []
    bare = None
    for n in worlds:
        for nthread in args.threads:
            row = batch_pass(overrides, n, nthread, epochs=args.epochs, config=config, setup=setup, warm=args.warm)
            if bare is None:  # the bare step of the same model, right after the first batch
                bare = bare_step(row["model"], row["physics"], steps)
            rows.append(_row(n, nthread, row, bare, single))
            print(
                f"N={n:4d} threads={nthread}: {row['us_per_world_step']:8.2f} us/ws wall, "
                f"{row['cpu_us_per_world_step']:8.2f} cpu, Python share {row['python_share']:.3f}",
                flush=True,
            )
    assert bare is not None
    print()
    print(
        f"config {config.name}, {steps} steps, loads {args.loads}, epochs per world: {args.epochs}, "
        f"warm: {args.warm}; "
        f"bare mj_step {bare['wall_us']:.2f} us wall, {bare['cpu_us']:.2f} us CPU "
        f"(native nstep {bare['native_us']:.2f} us); single run {single:.2f} us/step "
        f"(÷ mj_step {single / bare['wall_us']:.2f})"
    )
    print()
    _print_table(rows)
    speedups, amdahl = _speedups(rows), _amdahl(rows)
    print()
    if speedups:
        print(
            "thread speed-up (wall, 1 thread ÷ 2 threads): "
            + ", ".join(f"N={n}: {v:.2f}x" for n, v in speedups.items())
        )
    print(
        "2-thread speed-up the 1-thread CPU times allow (Python serial, MuJoCo split evenly): "
        + ", ".join(f"N={n}: {v:.2f}x" for n, v in amdahl.items())
    )
    if args.json is not None:
        out = {
            "config": str(config),
            "steps": steps,
            "epochs": args.epochs,
            "loads": args.loads,
            "warm": args.warm,
            "mj_step": bare,
            "single_us_per_step": single,
            "rows": rows,
            "speedup_1_to_2_threads": {str(n): v for n, v in speedups.items()},
            "speedup_bound_from_cpu": {str(n): v for n, v in amdahl.items()},
            "platform": {"python": platform.python_version(), "mujoco": mujoco.__version__, "numpy": np.__version__},
        }
        args.json.write_text(json.dumps(out, indent=1, allow_nan=False))
    return 0 if all(math.isfinite(r["us_per_world_step"]) for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
