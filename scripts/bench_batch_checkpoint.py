"""Batch checkpoints: what writing one costs, against the batch's step loop and a single run's checkpoint.

A CNUSAIL B-dot batch (``detumble_pre.toml``, worlds differing in initial rate) runs ``--duration``
simulated seconds with every world's records streamed to its own store in a temporary folder and
the batch checkpointed every ``--every`` seconds (:mod:`magsail_mj.batch.checkpoint`). Printed per
batch size N (``--worlds``):

* the mean wall time of writing one checkpoint (every world's store flushed, the file written),
  per checkpoint and per world, and the file's size;
* its ratio to the batch's step-loop wall time over one checkpoint interval (the share a
  checkpoint adds at this interval);
* the single run's checkpoint of the same config (one world, its store flushed, the file written),
  measured in the same run, and the ratio of the batch's cost per world to it.

Everything is measured in one run of this script, so the ratios compare like with like on the
machine as it is then; absolute times move with the machine and its load.

    nice -n 10 python scripts/bench_batch_checkpoint.py                 # 16 and 64 worlds, ≈ 2 min
    python scripts/bench_batch_checkpoint.py --worlds 8 --duration 60 --every 20
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import magsail_mj  # first: chooses the GL backend before mujoco is imported
import numpy as np

from magsail_mj.batch import checkpoint as batch_checkpoint
from magsail_mj.batch import runner
from magsail_mj.sim import Simulation

CONFIG = Path(__file__).resolve().parents[1] / "magsail_mj/concepts/cnusail/configs/detumble_pre.toml"


def _timed_writes(target: object, name: str, times: list[float]) -> object:
    """Replace ``target.name`` by a wrapper that appends each call's wall time [s] to ``times``;
    returns the original."""
    real = getattr(target, name)

    def timed(*args: object, **kwargs: object) -> None:
        t0 = time.perf_counter()
        real(*args, **kwargs)
        times.append(time.perf_counter() - t0)

    setattr(target, name, timed)
    return real


def batch_cost(worlds: int, *, duration_s: float, every_s: float, folder: Path) -> dict[str, float]:
    """One batch of ``worlds`` worlds run with checkpoints: mean write [s], file size [bytes], step
    loop per interval [s]."""
    rng = np.random.default_rng(2016)
    overrides = [[f"initial.omega0_deg_s={np.round(rng.uniform(-6.0, 6.0, 3), 3).tolist()}"] for _ in range(worlds)]
    sim = magsail_mj.load(CONFIG, [f"sim.duration_s={duration_s}"], world_overrides=overrides)
    times: list[float] = []
    real = _timed_writes(runner, "write_batch_checkpoint", times)
    try:
        ckpt = folder / f"n{worlds}" / batch_checkpoint.BATCH_CHECKPOINT_NAME
        result = sim.run(
            records_paths=[folder / f"n{worlds}" / f"w{k}" / "timeseries.zarr" for k in range(worlds)],
            checkpoint_path=ckpt,
            checkpoint_every_s=every_s,
        )
    finally:
        runner.write_batch_checkpoint = real
    loop_s = result.wall_time_s - sum(times)  # the step loop alone
    intervals = duration_s / every_s
    return {"write_s": float(np.mean(times)), "bytes": ckpt.stat().st_size, "loop_per_interval_s": loop_s / intervals}


def single_cost(*, duration_s: float, every_s: float, folder: Path) -> float:
    """Mean wall time [s] of the single run's checkpoint of the same config."""
    sim = magsail_mj.load(CONFIG, [f"sim.duration_s={duration_s}", f"sim.checkpoint_every_s={every_s}"])
    times: list[float] = []
    real = _timed_writes(Simulation, "_checkpoint", times)
    try:
        run_dir = folder / "single"
        sim.run(checkpoint_path=run_dir / "checkpoint.npz", records_path=run_dir / "timeseries.zarr")
    finally:
        Simulation._checkpoint = real
    return float(np.mean(times))


def main() -> None:
    """Parse the options, run the batches and the single run, print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, nargs="+", default=[16, 64], help="batch sizes")
    parser.add_argument("--duration", type=float, default=120.0, help="simulated time of each run [s]")
    parser.add_argument("--every", type=float, default=20.0, help="checkpoint interval [s]")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        single_s = single_cost(duration_s=args.duration, every_s=args.every, folder=folder)
        print(f"single run: {1e3 * single_s:.1f} ms per checkpoint")
        print("worlds | ms/checkpoint | ms/world | kB file | ÷ step loop per interval | per world ÷ single")
        for n in args.worlds:
            c = batch_cost(n, duration_s=args.duration, every_s=args.every, folder=folder)
            print(
                f"{n:6d} | {1e3 * c['write_s']:13.1f} | {1e3 * c['write_s'] / n:8.2f} | {c['bytes'] / 1e3:7.1f} | "
                f"{c['write_s'] / c['loop_per_interval_s']:24.3f} | {c['write_s'] / n / single_s:18.2f}"
            )


if __name__ == "__main__":
    main()
