"""``magsail sweep``: every run of a sweep file on Dask (local workers, a scheduler, or batch jobs)."""

from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path
from typing import Any

from magsail_mj.cli import CliInputError
from dask.utils import parse_bytes

from magsail_mj.batch.groups import batch_bytes, world_key
from magsail_mj.config import load_config
from magsail_mj.io import check_output_folder
from magsail_mj.resources import check_memory, estimate_run_bytes
from magsail_mj.sweep import check_walltime, load_sweep, make_cluster, run_sweep, sweep_exit_code
from magsail_mj.sweep.report import ReportError, write_report
from magsail_mj.verbs.common import input_file, output_dir

__all__ = ["sweep"]

LOG = logging.getLogger("magsail_mj")


def _check_engine_options(args: argparse.Namespace) -> None:
    """CliInputError for engine options that do not fit together or a malformed ``--walltime``
    (checked before the sweep file is loaded)."""
    queue_opts = {
        "--jobs": args.jobs,
        "--cores-per-job": args.cores_per_job,
        "--memory-per-job": args.memory_per_job,
        "--walltime": args.walltime,
        "--queue": args.queue,
        "--account": args.account,
    }
    given = [opt for opt, value in queue_opts.items() if value is not None]
    if args.scheduler is not None and args.cluster is not None:
        raise CliInputError(f"--scheduler {args.scheduler!r} and --cluster {args.cluster!r}: choose one")
    if args.scheduler is not None and not args.scheduler.strip():
        raise CliInputError(
            f"--scheduler: must be a scheduler address such as tcp://127.0.0.1:8786, got {args.scheduler!r}"
        )
    if args.cluster is None:
        if given:
            raise CliInputError(f"{given[0]}: only with --cluster slurm|pbs")
        return
    if args.workers != 1:
        raise CliInputError(f"--workers {args.workers}: not with --cluster (use --jobs and --cores-per-job)")
    if args.walltime is not None:
        check_walltime(args.walltime)


def _engine(args: argparse.Namespace) -> Any:
    """The Dask cluster of ``--cluster`` (jobs not yet submitted), else None."""
    if args.cluster is None:
        return None
    return make_cluster(
        args.cluster,
        cores_per_job=args.cores_per_job or 1,
        memory_per_job=args.memory_per_job or "4GB",
        walltime=args.walltime or "01:00:00",
        queue=args.queue,
        account=args.account,
    )


def _check_local_memory(args: argparse.Namespace, sweep: Any) -> None:
    """MemoryLimitError when ``--workers`` times the largest task (a run, or a batch of
    ``--batch-size`` runs that may share one) is above the memory limit; the default batch size is
    chosen within it."""
    biggest, worlds = 0.0, 1
    cfgs = [load_config(run.config, list(run.overrides)) for run in sweep.selected]
    for cfg in cfgs:
        biggest = max(biggest, estimate_run_bytes(cfg))
    if args.batch_size is not None and args.batch_size > 1 and not args.video:
        batchable = [cfg for cfg in cfgs if not world_key(cfg)[1]]
        worlds = min(args.batch_size, len(batchable)) if batchable else 1
        for cfg in batchable:
            biggest = max(biggest, batch_bytes(cfg, worlds))
    workers = min(args.workers, max(1, len(sweep.selected)))
    task = "largest run" if worlds == 1 else f"largest batch of {worlds} runs (--batch-size {args.batch_size})"
    check_memory(workers * biggest, what=f"sweep {args.sweep} ({workers} worker(s), {task})")


def _cluster_resources(args: argparse.Namespace) -> tuple[int, float] | None:
    """``(cores, bytes per core)`` of ``--cluster``'s jobs (the default batch size is chosen for
    them, not for the submitting machine); None without ``--cluster``."""
    if args.cluster is None:
        return None
    cores = args.cores_per_job or 1
    return (args.jobs or 1) * cores, parse_bytes(args.memory_per_job or "4GB") / cores


def sweep(args: argparse.Namespace) -> int:
    """Run the sweep, print its statuses (and report); :func:`magsail_mj.sweep.sweep_exit_code`."""
    path = input_file(args.sweep, "SWEEP")
    out = output_dir(args.out, "--out") if args.out is not None else None
    _check_engine_options(args)
    try:
        plots = False if args.no_plots else None  # None: the sweep file's own plots key
        sweep = load_sweep(path, extra_overrides=tuple(args.set), only=args.only, plots=plots)
    except UnicodeDecodeError:
        raise CliInputError(f"SWEEP: {str(path)!r} is not a UTF-8 text (TOML) file") from None
    out = out or output_dir(str(Path("runs") / sweep.name), "--out")
    check_output_folder(out, option="--out")
    cluster = _engine(args)
    if args.scheduler is None and cluster is None:  # runs on this machine: they must fit its memory
        _check_local_memory(args, sweep)
    try:
        if cluster is not None:
            cluster.adapt(minimum_jobs=args.jobs or 1, maximum_jobs=args.jobs or 1)  # jobs that end are replaced
        records = run_sweep(
            sweep,
            out,
            workers=args.workers,
            video=args.video,
            overwrite=args.overwrite,
            scheduler=args.scheduler,
            cluster=cluster,
            retries=args.retries,
            batch_size=args.batch_size,
            batch_resources=_cluster_resources(args),
            log=LOG.info,
            progress=False if args.no_progress else None,
        )
    finally:
        if cluster is not None:
            cluster.close()
    result: dict[str, Any] = {"sweep": sweep.name, "out": str(out), "status": {r["id"]: r["status"] for r in records}}
    code = sweep_exit_code(records)
    if args.report:
        try:
            result["report"] = [str(p) for p in write_report(out)]
        except ReportError as err:  # e.g. no run finished with a figure to report: the runs stay as they are
            LOG.error("report: %s", err)
            result["report_error"] = str(err)
            code = code or 1
    print(json.dumps(result, indent=2))
    return code
