r"""Run folders of a batch: each world's folder written as a single ``magsail run`` writes it.

:func:`run_batch_folders` runs a fresh batch with each world's records streamed to the record
store of its own folder, then finishes every folder with the run-folder writer of
:mod:`magsail_mj.run` (``model.xml``, ``timeseries.zarr`` with the derived series, ``summary.json``,
the plots, ``manifest.json`` last, with the file digests), from the world's own config, task and
records. A world's folder therefore has the form and the numbers of its single run's folder; what
differs is only what describes the process: ``wall_time_s`` and ``step_cost_us`` are the world's
share of the batch's step loop (its wall time in proportion to the steps each world took), and a
world's folder holds no ``checkpoint.npz`` of its own.

Checkpoints: when a world's config asks for them (``sim.checkpoint_every_s > 0``; the batch
checkpoints at the smallest such interval of its worlds, which changes no number), with
``stop_after_s``, and on ``resume``, the whole batch is checkpointed into one file,
:data:`~magsail_mj.batch.checkpoint.BATCH_CHECKPOINT_NAME` in the first world's folder (or
``checkpoint_path``; :mod:`magsail_mj.batch.checkpoint`), which names every world's folder, run
identity and record count. ``resume`` continues the batch from it — the same configs in the same
folders, checked before anything is touched; a file of another config, another set of folders or
one that was edited is refused (:class:`~magsail_mj.checkpoint.CheckpointError`) — and the resumed
folders equal the uninterrupted batch's in every record and summary value. Once every world has
ended (none ``stopped`` or ``interrupted``) and every folder is written, the file is removed: a
finished batch's folders hold what its single runs' hold.

The folders are checked (:func:`magsail_mj.io.prepare_run_dir`: an earlier run is replaced only
with ``overwrite`` or continued with ``resume``) and locked (:func:`magsail_mj.io.run_dir_lock`)
before the batch runs. Every BLAS pool is held to one thread during the run and the writing, as
for a single run.
"""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any, Sequence

from threadpoolctl import threadpool_limits

from magsail_mj.batch.checkpoint import BATCH_CHECKPOINT_NAME, read_batch_checkpoint
from magsail_mj.batch.runner import BatchSimulation
from magsail_mj.checkpoint import CheckpointError
from magsail_mj.io import prepare_run_dir, remove_earlier_run, run_dir_lock
from magsail_mj.records import STORE_NAME
from magsail_mj.run import RunInterrupted, RunOutcome, _run_locked, store_attrs
from magsail_mj.sim import RunResult

__all__ = ["run_batch_folders", "checkpoint_interval_s", "batch_checkpoint_time"]


class _FinishedWorld:
    """One world of a batch that has run, as the run-folder writer sees a simulation: its task
    (``scenario``), its recorder (streaming to the folder's store) and its :class:`RunResult`."""

    streams_records = True

    def __init__(self, scenario: Any, recorder: Any, result: RunResult) -> None:
        self.scenario, self.recorder, self._result = scenario, recorder, result

    def run(self, **_: Any) -> RunResult:
        """The world's result (the batch has run it; the options of a single run's ``run`` have
        nothing left to act on)."""
        return self._result


def checkpoint_interval_s(cfgs: Sequence[Any]) -> float:
    """The batch's checkpoint interval [s]: the smallest positive ``sim.checkpoint_every_s`` of
    its worlds (every world is checkpointed at least as often as it asks), 0 when none asks."""
    asked = [float(cfg.sim.checkpoint_every_s) for cfg in cfgs if float(cfg.sim.checkpoint_every_s) > 0]
    return min(asked) if asked else 0.0


def batch_checkpoint_time(sim: BatchSimulation, out_dirs: Sequence[str | Path]) -> float | None:
    """Simulated time [s] of the batch checkpoint in ``out_dirs[0]`` when ``sim`` may resume from it
    (its worlds' identities and folders are ``sim``'s and ``out_dirs``', its time within the
    duration), else None."""
    dirs = [Path(d) for d in out_dirs]
    path = dirs[0] / BATCH_CHECKPOINT_NAME
    if not path.is_file():
        return None
    try:
        header, _ = read_batch_checkpoint(path, identities=sim.identities, folders=[d.name for d in dirs])
        t_s = float(header["t_s"])
    except (CheckpointError, KeyError, TypeError, ValueError):
        return None
    return t_s if 0 <= int(header["step"]) <= sim.n_steps else None


def run_batch_folders(
    sim: BatchSimulation,
    out_dirs: Sequence[str | Path],
    *,
    overwrite: bool = False,
    progress: bool = False,
    resume: bool = False,
    stop_after_s: float | None = None,
    checkpoint_path: str | Path | None = None,
    plots: bool = True,
) -> list[RunOutcome]:
    """Run the fresh batch ``sim`` into one run folder per world and return each world's summary.

    Args:
      sim: a batch at its start (built by :func:`magsail_mj.batch.load_batch`, or after ``reset()``).
      out_dirs: world k's folder is ``out_dirs[k]`` (distinct folders, one per world).
      overwrite: replace an earlier run in a folder (else a folder holding one is refused).
      progress: show a progress bar of the batch's steps on stderr.
      resume: continue the batch from its checkpoint (module docstring).
      stop_after_s: stop every running world at this simulated time [s], leaving a checkpoint
        (status ``stopped``).
      checkpoint_path: the batch checkpoint (default: ``out_dirs[0]/checkpoint-batch.npz``).
      plots: draw each world's PNG plots (as :func:`magsail_mj.run.run_scenario`).

    Raises:
      ValueError: ``out_dirs`` is not one distinct folder per world, ``sim`` is not at its start, or
        ``stop_after_s`` is less than one time step beyond the start (or the checkpoint).
      RunDirError: a folder cannot be used (nothing is run); with ``resume``, a checkpoint that is
        missing or refused (:class:`~magsail_mj.checkpoint.CheckpointError`, naming the world,
        its folder and what differs).
      RunInterrupted: Ctrl-C during the run: every folder is written with status ``interrupted``
        first, then the first world's is raised.
    """
    dirs = [Path(d) for d in out_dirs]
    if len(dirs) != sim.n_worlds:
        raise ValueError(f"out_dirs: {len(dirs)} folders for {sim.n_worlds} worlds")
    if len({d.resolve() for d in dirs}) != len(dirs):
        raise ValueError("out_dirs: every world needs its own folder (two are the same)")
    if sim.step_index != 0 or any(s != "running" for s in sim.status):
        raise ValueError("sim: run folders are written from the start of a fresh batch (call sim.reset() first)")
    ckpt = Path(checkpoint_path) if checkpoint_path is not None else dirs[0] / BATCH_CHECKPOINT_NAME
    every_s = checkpoint_interval_s(sim.cfgs)
    t0_s = 0.0
    if resume:  # refused before any folder is touched
        t0_s = float(read_batch_checkpoint(ckpt, identities=sim.identities, folders=[d.name for d in dirs])[0]["t_s"])
    if stop_after_s is not None and not stop_after_s >= t0_s + sim.dt * (1 - 1e-9):
        raise ValueError(
            f"stop_after_s: must be at least one time step ({sim.dt:.6g} s) beyond t = {t0_s:.6g} s, "
            f"got {stop_after_s!r}"
        )
    run_dirs = [prepare_run_dir(d, overwrite=overwrite, resume=resume) for d in dirs]
    attrs = [store_attrs(cfg, ident) for cfg, ident in zip(sim.cfgs, sim.identities)]
    outcomes: list[RunOutcome] = []
    interrupted: RunInterrupted | None = None
    with threadpool_limits(limits=1), contextlib.ExitStack() as locks:
        for d in run_dirs:
            locks.enter_context(run_dir_lock(d))
            if overwrite:
                remove_earlier_run(d)
        checkpointed = every_s > 0 or stop_after_s is not None or resume
        result = sim.run(
            progress=progress,
            stop_after_s=stop_after_s,
            records_paths=[d / STORE_NAME for d in run_dirs],
            records_attrs=attrs,
            checkpoint_path=ckpt if checkpointed else None,
            checkpoint_every_s=every_s,
            resume=resume,
        )
        for k, d in enumerate(run_dirs):
            world = _FinishedWorld(sim.worlds.scenario(k), sim.recorders[k], result.worlds[k])
            try:
                outcome = _run_locked(
                    sim.cfgs[k],
                    world,
                    d,
                    sim.identities[k],
                    video=False,
                    resume=False,
                    progress=False,
                    stop_after_s=None,
                    plots=plots,
                )
            except RunInterrupted as err:
                outcome, interrupted = err.outcome, interrupted or err
            outcomes.append(outcome)
        if checkpointed and interrupted is None and not any(o.status in ("stopped", "interrupted") for o in outcomes):
            ckpt.unlink(missing_ok=True)
    if interrupted is not None:
        raise interrupted
    return outcomes
