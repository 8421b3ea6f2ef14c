r"""Run folders of a batch: each world's folder written as a single ``magsail run`` writes it.

:func:`run_batch_folders` runs a fresh batch with each world's records streamed to the record
store of its own folder, then finishes every folder with the run-folder writer of
:mod:`magsail_mj.run` (``model.xml``, ``timeseries.zarr`` with the derived series, ``summary.json``,
the plots, ``manifest.json`` last, with the file digests), from the world's own config, task and
records. A world's folder therefore has the form and the numbers of its single run's folder; what
differs is only what describes the process: ``wall_time_s`` and ``step_cost_us`` are the world's
share of the batch's step loop (its wall time in proportion to the steps each world took), and a
batch writes no ``checkpoint.npz``.

The folders are checked (:func:`magsail_mj.io.prepare_run_dir`: an earlier run is replaced only
with ``overwrite``) and locked (:func:`magsail_mj.io.run_dir_lock`) before the batch runs. Every
BLAS pool is held to one thread during the run and the writing, as for a single run.
"""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any, Sequence

from threadpoolctl import threadpool_limits

from magsail_mj.batch.runner import BatchSimulation
from magsail_mj.io import prepare_run_dir, remove_earlier_run, run_dir_lock
from magsail_mj.records import STORE_NAME
from magsail_mj.run import RunInterrupted, RunOutcome, _run_locked, store_attrs
from magsail_mj.sim import RunResult

__all__ = ["run_batch_folders"]


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


def run_batch_folders(
    sim: BatchSimulation, out_dirs: Sequence[str | Path], *, overwrite: bool = False, progress: bool = False
) -> list[RunOutcome]:
    """Run the fresh batch ``sim`` into one run folder per world and return each world's summary.

    Args:
      sim: a batch at its start (built by :func:`magsail_mj.batch.load_batch`, or after ``reset()``).
      out_dirs: world k's folder is ``out_dirs[k]`` (distinct folders, one per world).
      overwrite: replace an earlier run in a folder (else a folder holding one is refused).
      progress: show a progress bar of the batch's steps on stderr.

    Raises:
      ValueError: ``out_dirs`` is not one distinct folder per world, or ``sim`` is not at its start.
      RunDirError: a folder cannot be used (nothing is run).
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
    run_dirs = [prepare_run_dir(d, overwrite=overwrite) for d in dirs]
    attrs = [store_attrs(cfg, ident) for cfg, ident in zip(sim.cfgs, sim.identities)]
    outcomes: list[RunOutcome] = []
    interrupted: RunInterrupted | None = None
    with threadpool_limits(limits=1), contextlib.ExitStack() as locks:
        for d in run_dirs:
            locks.enter_context(run_dir_lock(d))
            if overwrite:
                remove_earlier_run(d)
        result = sim.run(progress=progress, records_paths=[d / STORE_NAME for d in run_dirs], records_attrs=attrs)
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
                )
            except RunInterrupted as err:
                outcome, interrupted = err.outcome, interrupted or err
            outcomes.append(outcome)
    if interrupted is not None:
        raise interrupted
    return outcomes
