"""Config → run folder: build, simulate, post-process, write outputs atomically.

A run folder holds ``model.xml`` (the MJCF of the run), ``timeseries.zarr`` (the records,
streamed in chunks during the run, and the derived series in its group ``series``; labelled
data, see :mod:`magsail_mj.records`; ``magsail export`` writes it as ``.npz`` or netCDF),
``summary.json`` (flat key figures, SI units in the names, with ``status`` and
``status_message``), ``manifest.json`` (config, its hashes, seed, package versions, thread
settings, status, file list with SHA-256 — of a store: of its files' names and bytes; written
last), the plots (``*.png``), ``checkpoint.npz`` when checkpointing (no records: their count),
and ``video.mp4`` when asked. No other copy of the records is written: analysis code reads the
store (:func:`magsail_mj.export.read_timeseries`, :func:`magsail_mj.records.lazy_arrays`).

Guarantees:

* Nothing is written before the config is valid, the scenario is built and the folder is
  usable; a ``resume`` is checked completely (checkpoint readable, same number-changing config
  keys, same magsail_mj/MuJoCo/NumPy versions, not beyond the new duration) before anything in the
  folder is touched.
* ``manifest.json`` is written last (after the video) and only states what is true: a video that
  fails makes the run ``"failed"`` (its numbers stay in the folder).
* Every run uses one BLAS/OpenMP thread (threadpoolctl), whatever started it, so the numbers
  do not depend on the entry point or the machine's core count; the settings are in the
  manifest.
* An interrupt (Ctrl-C, SIGTERM) during the simulation keeps what was recorded: the outputs are
  written with status ``"interrupted"`` and :class:`RunInterrupted` is raised. While the numbers'
  files (time series, summary, plots, manifest) are written, SIGINT and SIGTERM are held and act
  when the files are complete; the video can be interrupted at any time.
* One run at a time per folder: a run holds the folder's lock (:func:`magsail_mj.io.run_dir_lock`)
  while it writes, so a second run into it (a sweep worker, another ``magsail run``) is refused.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import json
import shutil
import signal
import threading
from pathlib import Path
from typing import Any, Iterator

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from magsail_mj.api import load
from magsail_mj.checkpoint import CheckpointError, check_identity, read_checkpoint, run_identity
from magsail_mj.config import ConfigError, config_hash, numbers_hash, numbers_tree
from magsail_mj.io import (
    atomic_path,
    file_sha256,
    package_versions,
    prepare_run_dir,
    remove_earlier_run,
    run_dir_lock,
    write_json,
)
from magsail_mj.records import (
    SERIES_GROUP,
    STORE_NAME,
    RecordStoreError,
    StoreRecords,
    open_records,
    store_length,
    update_attrs,
    write_group,
)
from magsail_mj.render import render_run

__all__ = ["run_scenario", "RunOutcome", "RunInterrupted", "CHECKPOINT_NAME"]

#: the checkpoint file of a run folder
CHECKPOINT_NAME = "checkpoint.npz"


class RunOutcome(dict):
    """The summary dict of a run, with ``run_dir`` and ``status`` attributes."""

    run_dir: Path
    status: str


class RunInterrupted(KeyboardInterrupt):
    """The run was interrupted; its outputs up to then are written with status ``interrupted``."""

    def __init__(self, outcome: RunOutcome):
        super().__init__(outcome.get("status_message", "interrupted"))
        self.outcome = outcome


def thread_settings() -> list[dict[str, Any]]:
    """The native thread pools (BLAS, OpenMP) and their current thread counts."""
    pools = [
        {k: info.get(k) for k in ("user_api", "internal_api", "num_threads", "version")} for info in threadpool_info()
    ]
    return sorted(pools, key=lambda p: json.dumps(p, sort_keys=True))


def check_resume(run_dir: Path, identity: dict[str, Any], n_steps: int) -> None:
    """Refuse a resume before anything is written: the checkpoint must exist, be readable, belong
    to this config and these versions, and not lie beyond the run's duration."""
    ckpt = Path(run_dir) / CHECKPOINT_NAME
    header, _, _ = read_checkpoint(ckpt)
    check_identity(header, identity, path=ckpt)
    n_records = header.get("n_records")
    if not isinstance(n_records, int) or header.get("records_store") != STORE_NAME:
        raise CheckpointError(
            f"--resume: checkpoint {ckpt} names no record count in {STORE_NAME} (a checkpoint of an older version)"
        )
    try:  # the records before the checkpoint must all be there
        held = store_length(Path(run_dir) / STORE_NAME)
    except RecordStoreError as err:
        raise CheckpointError(f"--resume: {err} (checkpoint {ckpt} needs its {n_records} records)") from None
    if held < n_records:
        raise CheckpointError(f"--resume: {STORE_NAME} holds {held} records, checkpoint {ckpt} needs {n_records}")
    step = int(header.get("step", -1))
    if not 0 <= step <= n_steps:
        raise CheckpointError(
            f"--resume: checkpoint {ckpt} is at t = {header.get('t_s')} s, beyond "
            f"sim.duration_s (a resume may extend a run, not shorten it)"
        )


def check_stop_after(cfg: Any, out_dir: Path, *, resume: bool, stop_after_s: float | None) -> None:
    """Refuse a ``stop_after_s`` that would not advance the run by one time step: below
    ``sim.timestep_s`` on a fresh run (it stopped at t = 0 with no records and no checkpoint), or
    less than one step beyond the checkpoint's time on a resume (the summary and manifest said
    "stopped" at a time the records had passed). :class:`ConfigError` naming ``--stop-after-s``,
    the step and the checkpoint's time; a checkpoint that cannot be read is left to
    :func:`check_resume`."""
    if stop_after_s is None:
        return
    dt = float(cfg.sim.timestep_s)
    t0, where = 0.0, ""
    if resume:
        try:
            t0 = float(read_checkpoint(Path(out_dir) / CHECKPOINT_NAME)[0]["t_s"])
        except (CheckpointError, OSError, KeyError, TypeError, ValueError):
            return
        where = f" beyond the checkpoint's t = {t0:.6g} s"
    if stop_after_s < t0 + dt * (1 - 1e-9):
        raise ConfigError(
            [
                f"--stop-after-s: must be at least one time step (sim.timestep_s = {dt:.6g} s){where}, "
                f"got {stop_after_s:.6g} s"
            ]
        )


def run_scenario(
    cfg: Any,
    out_dir: str | Path,
    *,
    video: bool = False,
    resume: bool = False,
    overwrite: bool = False,
    progress: bool | None = None,
    stop_after_s: float | None = None,
    plots: bool = True,
) -> RunOutcome:
    """Run a validated config into ``out_dir`` and return its summary.

    Args:
      cfg: validated config (see :func:`magsail_mj.config.load_config`).
      out_dir: run folder; an earlier run there is replaced only with ``overwrite`` (its files are
        removed first) or continued with ``resume`` (from ``checkpoint.npz``).
      video: also render ``video.mp4``.
      progress: show a progress bar (default: ``cfg.sim.progress``).
      stop_after_s: stop early at this simulated time, leaving a checkpoint (used to test resume).
      plots: draw the scenario's PNG plots into the folder (False: records, series, summary and
        manifest only — for sweeps of many runs, where drawing costs as much as a short run).

    Raises:
      RunDirError: the folder cannot be used (holds a run and neither ``overwrite`` nor
        ``resume``; the resume is refused — :class:`~magsail_mj.checkpoint.CheckpointError`).
      RunInterrupted: Ctrl-C during the simulation (outputs written with status ``interrupted``).
    """
    with threadpool_limits(limits=1):
        return _run(
            cfg,
            Path(out_dir),
            video=video,
            resume=resume,
            overwrite=overwrite,
            progress=cfg.sim.progress if progress is None else progress,
            stop_after_s=stop_after_s,
            plots=plots,
        )


def _run(
    cfg: Any,
    out_dir: Path,
    *,
    video: bool,
    resume: bool,
    overwrite: bool,
    progress: bool,
    stop_after_s: float | None,
    plots: bool,
) -> RunOutcome:
    sim = load(cfg)
    scenario = sim.scenario
    if video and "video" in scenario.render_info():  # a scenario without motion says why
        raise ConfigError([f"--video: scenario {cfg.scenario!r} cannot be rendered: {scenario.render_info()['video']}"])
    if (resume or stop_after_s is not None) and not getattr(sim, "checkpoints", True):
        option = "--resume" if resume else "--stop-after-s"
        raise ConfigError(
            [f"{option}: scenario {cfg.scenario!r} ({type(sim).__name__}) has no checkpoints to stop at or resume from"]
        )
    check_stop_after(cfg, out_dir, resume=resume, stop_after_s=stop_after_s)
    identity = run_identity(numbers_hash(cfg), numbers_tree(cfg))
    run_dir = prepare_run_dir(
        out_dir,
        overwrite=overwrite,
        resume=resume,
        check=(lambda d: check_resume(d, identity, _n_steps(cfg))) if resume else None,
    )
    with run_dir_lock(run_dir):
        if overwrite:
            remove_earlier_run(run_dir)
        return _run_locked(
            cfg,
            sim,
            run_dir,
            identity,
            video=video,
            resume=resume,
            progress=progress,
            stop_after_s=stop_after_s,
            plots=plots,
        )


def _run_locked(
    cfg: Any,
    sim: Any,
    run_dir: Path,
    identity: dict[str, Any],
    *,
    video: bool,
    resume: bool,
    progress: bool,
    stop_after_s: float | None,
    plots: bool = True,
) -> RunOutcome:
    scenario = sim.scenario
    with atomic_path(run_dir / "model.xml") as tmp:
        tmp.write_text(scenario.spec.to_xml())
    ckpt = run_dir / CHECKPOINT_NAME if (cfg.sim.checkpoint_every_s > 0 or stop_after_s is not None or resume) else None
    store = run_dir / STORE_NAME
    attrs = store_attrs(cfg, identity)
    if getattr(sim, "streams_records", False):
        result = sim.run(
            progress=progress,
            checkpoint_path=ckpt,
            resume=resume,
            stop_after_s=stop_after_s,
            records_path=store,
            records_attrs=attrs,
        )
    else:
        result = sim.run(progress=progress, checkpoint_path=ckpt, resume=resume, stop_after_s=stop_after_s)
    status, message = result.status, result.message
    with deferred_interrupts() as pending:  # the numbers' files are written whole, even on Ctrl-C
        result, digests = _stored(result, store, attrs, recorder=getattr(sim, "recorder", None))
        summary, series, plot_files, series_digests = _outputs(scenario, result, run_dir, plots=plots)
        digests.update(series_digests)
        overflowed = [k for k, v in series.items() if np.asarray(v).dtype.kind == "f" and np.isinf(v).any()]
        if status == "completed" and overflowed:  # NaN may mark an undefined value; ±inf never is a number
            status, message = (
                "failed",
                (
                    f"the derived series {', '.join(map(repr, overflowed))} overflowed to "
                    "infinity although the state stayed finite (an input too large for float64?)"
                ),
            )
        if status == "completed" and summary.get("failed") is True:  # found by post-processing (inverted cells)
            status, message = (
                "structure_failed",
                (
                    f"the structure failed at t = {summary.get('t_failed_s')} s "
                    "(post-processing found inverted cells or a strut strain "
                    "beyond sim.max_strain)"
                ),
            )
        summary = {
            "scenario": cfg.scenario,
            **summary,
            "t_end_s": result.t_end_s,
            "status": status,
            "status_message": message,
        }
        write_json(run_dir / "summary.json", summary)
        update_attrs(store, {"status": status, "status_message": message, "t_end_s": result.t_end_s})
        files = ["model.xml", STORE_NAME, "summary.json", *[p.name for p in plot_files]]
        manifest = {
            "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "concept": cfg.concept,
            "scenario": cfg.scenario,
            "config": cfg.model_dump(mode="json"),
            "config_hash": config_hash(cfg),
            "numbers_hash": identity["numbers_hash"],
            "seed": cfg.sim.seed,
            "versions": package_versions(),
            "threads": thread_settings(),
            "status": status,
            "status_message": message,
            "t_end_s": result.t_end_s,
            "steps": result.steps,
            "wall_time_s": result.wall_time_s,
            "render": scenario.render_info(),
            **scenario.manifest_extra(),
        }
        manifest["files"] = {name: file_sha256(run_dir / name) for name in files}
        manifest["records_digests"] = digests
        if ckpt is not None and ckpt.is_file():
            manifest["checkpoint"] = {"file": CHECKPOINT_NAME, "state_digest": read_checkpoint(ckpt)[0]["state_digest"]}
        if not video or status == "interrupted":
            write_json(run_dir / "manifest.json", manifest)
    if pending and video and status != "interrupted":  # Ctrl-C while the numbers were written: no video
        status, message = "interrupted", "interrupted before video.mp4 was rendered (the numbers are complete)"
        manifest.update(status=status, status_message=message)
        write_json(run_dir / "manifest.json", manifest)
    elif video and status != "interrupted":
        status, message = _render_video(run_dir, manifest)
        if status == "failed":  # the summary says so too (and the manifest lists its new digest)
            write_json(run_dir / "summary.json", {**summary, "status": status, "status_message": message})
            manifest["files"]["summary.json"] = file_sha256(run_dir / "summary.json")
        write_json(run_dir / "manifest.json", manifest)
    out = RunOutcome({**summary, "status": status, "status_message": message})
    out.run_dir = run_dir
    out.status = status
    if status == "interrupted" or pending:
        raise RunInterrupted(out)
    return out


def _render_video(run_dir: Path, manifest: dict[str, Any]) -> tuple[str, str]:
    """Render ``video.mp4`` and update ``manifest`` (files, or status ``failed`` with the reason);
    an interrupt writes the manifest as ``interrupted`` and propagates."""
    info = manifest["render"]
    try:
        render_run(
            run_dir,
            run_dir / "video.mp4",
            fps=info.get("fps", 30),
            max_frames=info.get("max_frames", 600),
            render_info=info,
            verify=False,  # this run is writing the folder: its manifest comes after the video
        )
    except KeyboardInterrupt:
        write_json(
            run_dir / "manifest.json",
            {**manifest, "status": "interrupted", "status_message": "interrupted while rendering video.mp4"},
        )
        raise
    except Exception as err:  # noqa: BLE001 - the run's numbers stay; the run is marked failed
        manifest.update(status="failed", status_message=f"video.mp4 could not be rendered: {type(err).__name__}: {err}")
    else:
        manifest["files"]["video.mp4"] = file_sha256(run_dir / "video.mp4")
    return manifest["status"], manifest["status_message"]


@contextlib.contextmanager
def deferred_interrupts() -> Iterator[list[int]]:
    """Hold SIGINT and SIGTERM while a block writes files that belong together; yields the list of
    signals that arrived (empty: none). Outside the main thread signals cannot be held: no-op."""
    pending: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield pending
        return
    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    for sig in previous:
        signal.signal(sig, lambda signum, _frame: pending.append(signum))
    try:
        yield pending
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def store_attrs(cfg: Any, identity: dict[str, Any]) -> dict[str, Any]:
    """The attributes of a run's record store: concept, scenario, config and numbers hashes, and
    the package versions (one ``version_<package>`` string each, so netCDF can hold them)."""
    versions = {f"version_{k.replace('-', '_')}": str(v) for k, v in package_versions().items()}
    return {
        "concept": cfg.concept,
        "scenario": cfg.scenario,
        "config_hash": config_hash(cfg),
        "numbers_hash": identity["numbers_hash"],
        **versions,
    }


def _stored(result: Any, store: Path, attrs: dict[str, Any], *, recorder: Any) -> tuple[Any, dict[str, Any]]:
    """The result with its records in ``store``, and the digests of every stored chunk: a runner
    that streams has written them (``recorder`` holds their digests; its end-of-run arrays,
    ``extra``, are added); the others' records are written now."""
    records = result.records
    if isinstance(records, StoreRecords):
        digests = {}
        if recorder is not None:
            recorder.flush()
            digests = recorder.digest_table()
        if records.extra:
            digests.update(write_group(store, records.extra))
        result.records = open_records(store.parent)
        return result, digests
    n_time = len(records["t"]) if "t" in records and np.ndim(records["t"]) == 1 else None
    if store.exists():
        shutil.rmtree(store)
    digests = write_group(store, records, n_time=n_time, attrs=attrs)
    result.records = open_records(store.parent)
    return result, digests


def _outputs(
    scenario: Any, result: Any, run_dir: Path, *, plots: bool = True
) -> tuple[dict[str, Any], dict[str, Any], list[Path], dict[str, Any]]:
    """Summary, series, the files of a run (its scenario's ``data_files`` and, with ``plots``,
    its plots) and the digests of the stored series; the series go to the store's group ``series``
    here.

    A run that did not complete may have too few records for the scenario's metrics (a state
    that was bad from the start has none): its records are still written, and the summary then
    holds ``postprocess_error`` instead of metrics. A completed run's post-processing errors
    propagate (they are bugs, not outcomes)."""
    try:
        summary, series = scenario.postprocess(result)
    except Exception as err:  # noqa: BLE001 - only for runs that did not complete, see above
        if result.status == "completed":
            raise
        return {"t_end_s": result.t_end_s, "postprocess_error": f"{type(err).__name__}: {err}"}, {}, [], {}
    series = {"t": result.records["t"], **series}
    digests = write_group(run_dir / STORE_NAME, series, group=SERIES_GROUP, n_time=len(series["t"]))
    data_files = getattr(scenario, "data_files", None)
    files = [] if data_files is None else list(data_files(run_dir, result, series))
    if not plots:
        return summary, series, files, digests
    try:
        files += scenario.plots(run_dir, result, series)
    except Exception as err:  # noqa: BLE001 - same rule as above
        if result.status == "completed":
            raise
        summary = {**summary, "plots_error": f"{type(err).__name__}: {err}"}
    return summary, series, files, digests


def _n_steps(cfg: Any) -> int:
    return int(round(cfg.sim.duration_s / cfg.sim.timestep_s))
