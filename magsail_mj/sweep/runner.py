"""The worker side of a sweep: a Dask task supervises one run, which runs in its own process.

:func:`supervise` is what the sweep submits to Dask, once per run. It starts the run process
(``python -m magsail_mj.sweep``, a new session, so a terminal's Ctrl-C reaches the sweep
client only), waits for its record, and

* retries a run process killed by a signal (out of memory, ``kill``) up to ``retries`` times;
  every attempt resumes from the run's checkpoint when the folder holds one of the same config;
* counts attempts in the sweep folder (``.sweep.state/<call>/``), so an attempt started after the
  Dask worker itself died (Dask reschedules the task on another worker) is counted and resumes too;
* stops the run process (SIGTERM, then SIGKILL after the grace time) when the sweep client asks
  (the stop file ``.sweep.state/<call>/stop``).

:func:`supervise_batch` is the task of a batch of runs (:mod:`magsail_mj.sweep.batches`): one
run process runs them as the worlds of one batch (:func:`run_batch`), each into its single run's
folder, and the attempts stay per run: a killed batch process's unfinished runs resume as the
same batch from its checkpoint when it has advanced since the attempt began, else they are
retried one by one as single runs.

The run process holds the run's lock (:func:`~magsail_mj.sweep.common.run_lock`) while it runs,
dies with its supervisor (``PR_SET_PDEATHSIG`` and a parent-pid watch), and turns SIGTERM into an
interrupt, so a stopped run writes its outputs (status ``interrupted``) and its checkpoint.
"""

from __future__ import annotations

import contextlib
import ctypes
import hashlib
import json
import os
import pickle
import select
import signal
import subprocess
import sys
import threading
import time
import traceback
from pathlib import Path
from typing import Any

from distributed.diagnostics.plugin import WorkerPlugin

from magsail_mj.batch import load_batch
from magsail_mj.batch.checkpoint import BATCH_CHECKPOINT_NAME, checkpoint_folders
from magsail_mj.batch.folders import batch_checkpoint_time, run_batch_folders
from magsail_mj.checkpoint import CheckpointError, check_identity, read_checkpoint, run_identity
from magsail_mj.config import config_hash, load_config, numbers_hash
from magsail_mj.io import RunDirError, atomic_path, to_jsonable, write_json
from magsail_mj.run import run_scenario
from magsail_mj.sweep.common import FINISHED, STATE_DIR, SweepRun, _folder_check, _record, run_lock

__all__ = [
    "supervise",
    "supervise_batch",
    "run_one",
    "run_batch",
    "call_dir",
    "request_stop",
    "process_main",
    "IgnoreSigint",
]

_PR_SET_PDEATHSIG = 1
CHECKPOINT_NAME = "checkpoint.npz"
LOCK_WAIT_S = 60.0
"""How long a run process waits for an earlier process of the same run (a killed worker's orphan
writing its interrupted outputs) before it gives up."""


# ---------------------------------------------------------------------------------------------
# One attempt (in the run process)


def _checkpoint_time(run_dir: Path, cfg: Any) -> float | None:
    """Simulated time of the folder's checkpoint when it belongs to this config (else None)."""
    path = run_dir / CHECKPOINT_NAME
    if not path.is_file():
        return None
    try:
        header, _, _ = read_checkpoint(path)
        check_identity(header, run_identity(numbers_hash(cfg)), path=path)
        t_s = float(header.get("t_s"))
    except Exception:  # noqa: BLE001 - an unusable checkpoint means a fresh run
        return None
    return t_s if 0.0 <= t_s <= cfg.sim.duration_s else None  # a resume may extend a run, not shorten it


def run_one(run: SweepRun, out_dir: str | Path, *, video: bool, fresh: bool = True) -> dict[str, Any]:
    """One attempt of a run into ``out_dir/<id>``; never raises an ``Exception``.

    With ``fresh`` the folder's earlier run is replaced; otherwise the run resumes from the
    folder's checkpoint when it belongs to this config (``resumed_from_s`` says from when), and
    starts afresh when there is none. The record says ``failed`` with the reason when the run
    raises (the video included) or when its folder does not verify afterwards; a
    KeyboardInterrupt propagates.
    """
    t0 = time.perf_counter()
    run_dir = Path(out_dir) / run.id
    record = _record(run, status="failed", message="", attempts=1)
    try:
        cfg = load_config(run.config, list(run.overrides))
        record["config_hash"] = config_hash(cfg)
        t_resume = None if fresh else _checkpoint_time(run_dir, cfg)
        record["resumed_from_s"] = t_resume
        # overwrite: the earlier run's files go first (its manifest last), so a stopped rerun never looks finished
        try:
            outcome = run_scenario(
                cfg,
                run_dir,
                video=video,
                resume=t_resume is not None,
                overwrite=t_resume is None,
                progress=False,
                plots=run.plots,
            )
        except CheckpointError:  # refused before anything was written: run afresh
            if t_resume is None:
                raise
            record["resumed_from_s"] = None
            outcome = run_scenario(cfg, run_dir, video=video, overwrite=True, progress=False, plots=run.plots)
        record.update(
            status=str(outcome.status),
            message=str(outcome.get("status_message") or ""),
            summary=to_jsonable(dict(outcome)),
        )
        if outcome.status in FINISHED:
            _, why = _folder_check(run_dir, config_hash=record["config_hash"], video=video)
            if why:
                record.update(status="failed", message=f"run folder does not verify after the run: {why}")
    except Exception as err:  # noqa: BLE001 - one failing run must not lose the others
        record.update(status="failed", message=f"{type(err).__name__}: {err}", traceback=traceback.format_exc(limit=-8))
    _write_params(run, run_dir, record["config_hash"])
    record["wall_time_s"] = time.perf_counter() - t0
    return record


PARAMS_NAME = "params.json"


def _write_params(run: SweepRun, run_dir: Path, digest: str) -> None:
    """``params.json`` in the run folder: the run's id, varied values (grid or drawn), config,
    overrides and config hash (beside the run's own manifest; nothing when the folder is absent)."""
    if not run_dir.is_dir():
        return
    try:
        write_json(
            run_dir / PARAMS_NAME,
            {
                "id": run.id,
                "params": dict(run.params),
                "config": str(run.config),
                "overrides": list(run.overrides),
                "config_hash": digest,
            },
        )
    except OSError:  # the record says what ran; a read-only folder must not fail the run
        pass


def _folder_summary(run_dir: Path) -> dict[str, Any] | None:
    """The run folder's ``summary.json`` (None when it does not parse)."""
    try:
        summary = json.loads((run_dir / "summary.json").read_text())
    except (OSError, ValueError):
        return None
    return summary if isinstance(summary, dict) else None


def finished_record(run: SweepRun, out_dir: str | Path) -> dict[str, Any] | None:
    """The record of a run whose folder holds a finished, intact run of its config now (its status,
    message, wall time and summary; its ``params.json`` written, should the run that wrote the
    folder have stopped before it), else None."""
    run_dir = Path(out_dir) / run.id
    manifest, _ = _folder_check(run_dir, config_hash=run.config_hash, video=False)
    summary = _folder_summary(run_dir) if manifest else None
    if summary is None:
        return None
    _write_params(run, run_dir, run.config_hash)
    return _record(
        run,
        status=str(manifest["status"]),
        message=str(manifest.get("status_message") or ""),
        wall_time_s=manifest.get("wall_time_s"),
        summary=summary,
    )


def run_batch(runs: tuple[SweepRun, ...], out_dir: str | Path, *, resume: bool = False) -> list[dict[str, Any]]:
    """One attempt of ``runs`` (runs of one config file) as the worlds of one batch, each into
    ``out_dir/<id>`` with the form and numbers of its single run; never raises an ``Exception``.

    Each record is a single run's (:func:`run_one`): a world that diverges or fails is reported
    alone, with its own status and message, and the others complete; ``wall_time_s`` is the
    batch's wall time shared equally between its runs. With ``resume`` the batch continues from
    its checkpoint (:func:`~magsail_mj.batch.folders.run_batch_folders`) when the first run's
    folder holds one of these runs, configs and folders (``resumed_from_s`` says from when), and
    starts afresh otherwise or when the checkpoint is refused. When the batch itself cannot run or
    write (its loader refuses the worlds, a world's folder fails to write), every run without a
    finished folder then runs alone with :func:`run_one`, so a failure is its own run's. A
    KeyboardInterrupt propagates (every folder written ``interrupted`` first).
    """
    t0 = time.perf_counter()
    out = Path(out_dir)
    dirs = [out / run.id for run in runs]
    plots = all(run.plots for run in runs)  # one sweep's runs: all or none
    records = [_record(run, status="failed", message="", attempts=1) for run in runs]

    def build() -> Any:
        return load_batch(runs[0].config, world_overrides=[list(run.overrides) for run in runs])

    try:
        sim = build()
        for record, cfg in zip(records, sim.cfgs):
            record["config_hash"] = config_hash(cfg)
        t_resume = batch_checkpoint_time(sim, dirs) if resume else None
        try:
            outcomes = run_batch_folders(
                sim, dirs, overwrite=t_resume is None, resume=t_resume is not None, plots=plots
            )
        except RunDirError:  # the resume refused (a store that differs from its digests, a folder gone): afresh
            if t_resume is None:
                raise
            t_resume = None
            outcomes = run_batch_folders(build(), dirs, overwrite=True, plots=plots)
        for record in records:
            record["resumed_from_s"] = t_resume
    except Exception:  # noqa: BLE001 - the batch could not run: each run alone says why it fails, if it does
        alone = []
        for run in runs:
            record = finished_record(run, out) or run_one(run, out, video=False)
            alone.append(record)
        return alone
    share = (time.perf_counter() - t0) / len(runs)
    for run, record, outcome in zip(runs, records, outcomes):
        record.update(
            status=str(outcome.status),
            message=str(outcome.get("status_message") or ""),
            summary=to_jsonable(dict(outcome)),
        )
        if outcome.status in FINISHED:
            _, why = _folder_check(out / run.id, config_hash=record["config_hash"], video=False)
            if why:
                record.update(status="failed", message=f"run folder does not verify after the run: {why}")
        _write_params(run, out / run.id, record["config_hash"])
        record["wall_time_s"] = share
    return records


# ---------------------------------------------------------------------------------------------
# The run process


def _set_parent_death_signal(signum: int) -> bool:
    """Ask Linux to send ``signum`` to this process when its parent dies; False where unavailable."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(signum), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _watch_parent(parent_pid: int, *, period_s: float = 0.5, grace_s: float = 10.0) -> None:
    """Thread: once the parent is gone, stop this process (SIGTERM), then exit hard."""
    while os.getppid() == parent_pid:
        time.sleep(period_s)
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(grace_s)
    os._exit(1)


_STOP = threading.Event()
"""Set in a run process once it was asked to stop (SIGTERM from its supervisor, or its parent died)."""


def _on_sigterm(signum: int, frame: Any) -> None:
    """SIGTERM handler: stop the run (once) as a Ctrl-C would."""
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    _STOP.set()
    raise KeyboardInterrupt(f"run process stopped by {signal.Signals(signum).name}")


def _guard(parent_pid: int) -> None:
    """Run-process set-up: SIGINT ignored (the sweep client decides), SIGTERM or the parent's death stops the run."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _on_sigterm)
    _set_parent_death_signal(signal.SIGTERM)
    threading.Thread(target=_watch_parent, args=(parent_pid,), name="parent-watch", daemon=True).start()
    if os.getppid() != parent_pid:  # the parent died before the death signal was set
        os.kill(os.getpid(), signal.SIGTERM)


def _stopped_record(run: SweepRun, err: BaseException, *, wall_time_s: float) -> dict[str, Any]:
    """The record of a run that raised past :func:`run_one` (an interrupt, or an exit)."""
    if isinstance(err, KeyboardInterrupt):
        outcome = getattr(err, "outcome", None)  # RunInterrupted: the outputs up to then are written
        return _record(
            run,
            status="interrupted",
            message=f"stopped while running ({err})",
            wall_time_s=wall_time_s,
            summary=to_jsonable(dict(outcome)) if isinstance(outcome, dict) else None,
        )
    return _record(run, status="failed", message=f"{type(err).__name__}: {err}", wall_time_s=wall_time_s)


def _batch_stopped(
    runs: tuple[SweepRun, ...], out: Path, err: BaseException, *, wall_time_s: float
) -> list[dict[str, Any]]:
    """The records of a batch that raised past :func:`run_batch` (an interrupt: every folder was
    written ``interrupted`` with its summary; or an exit)."""
    records = []
    for run in runs:
        record = _stopped_record(run, err, wall_time_s=wall_time_s)
        if isinstance(err, KeyboardInterrupt):
            record["summary"] = _folder_summary(out / run.id) or {}
        records.append(record)
    return records


def _batch_main(job: dict[str, Any]) -> None:
    """The run process of a batch: its runs' records (a JSON list) to the result descriptor."""
    runs: tuple[SweepRun, ...] = tuple(job["runs"])
    out = Path(job["out"])
    t0 = time.perf_counter()
    try:
        _guard(job["parent_pid"])
        with contextlib.ExitStack() as locks:
            for run in runs:
                locks.enter_context(run_lock(out, run.id, wait_s=LOCK_WAIT_S))
            records = run_batch(runs, out, resume=not job["fresh"])
    except BaseException as err:  # noqa: BLE001 - a run process reports what stopped it, never a traceback
        records = _batch_stopped(runs, out, err, wall_time_s=(time.perf_counter() - t0) / len(runs))
    for record in records:
        if _STOP.is_set() and record["status"] not in (*FINISHED, "interrupted"):
            record.update(status="interrupted", message=f"stopped while running ({record['message']})")
    try:
        with os.fdopen(job["result_fd"], "w") as fh:
            json.dump(records, fh)
    except (OSError, KeyboardInterrupt, ValueError):  # the supervisor is gone: nothing to report to
        pass


def process_main() -> None:
    """Entry of the run process: the job (pickled) on stdin, its record (JSON) to the result
    descriptor; a job of several runs (``runs``) is a batch (:func:`run_batch`), whose records
    go as a list."""
    job = pickle.load(sys.stdin.buffer)
    if "runs" in job:
        _batch_main(job)
        return
    run: SweepRun = job["run"]
    t0 = time.perf_counter()
    try:
        _guard(job["parent_pid"])
        with run_lock(Path(job["out"]), run.id, wait_s=LOCK_WAIT_S):
            record = run_one(run, job["out"], video=job["video"], fresh=job["fresh"])
    except BaseException as err:  # noqa: BLE001 - a run process reports what stopped it, never a traceback
        record = _stopped_record(run, err, wall_time_s=time.perf_counter() - t0)
    if _STOP.is_set() and record["status"] not in (*FINISHED, "interrupted"):  # e.g. an interrupt turned error
        record.update(status="interrupted", message=f"stopped while running ({record['message']})")
    try:
        with os.fdopen(job["result_fd"], "w") as fh:
            json.dump(record, fh)
    except (OSError, KeyboardInterrupt, ValueError):  # the supervisor is gone: nothing to report to
        pass


# ---------------------------------------------------------------------------------------------
# The supervisor (a Dask task)


class IgnoreSigint(WorkerPlugin):
    """Worker plugin of the sweep's own LocalCluster: its worker processes ignore SIGINT (a
    terminal's Ctrl-C reaches the whole process group; the sweep client stops them itself)."""

    name = "magsail-ignore-sigint"

    def setup(self, worker: Any) -> None:
        """Ignore SIGINT in this worker process (its event loop runs in the main thread)."""
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)


def call_dir(out: Path, token: str) -> Path:
    """The state folder of one sweep call (attempt counters, stop request)."""
    return out / STATE_DIR / token


def request_stop(out: Path, token: str, *, kill: bool = False) -> None:
    """Ask every supervisor of the call ``token`` to stop its run (``kill``: SIGKILL at once)."""
    folder = call_dir(out, token)
    folder.mkdir(parents=True, exist_ok=True)
    with atomic_path(folder / "stop") as tmp:
        tmp.write_text("kill" if kill else "stop")


def _stop_request(out: Path, token: str) -> str:
    try:
        return (call_dir(out, token) / "stop").read_text()
    except OSError:
        return ""


def _next_attempt(out: Path, token: str, run_id: str) -> int:
    """Count one more attempt of ``run_id`` in this call (kept in the sweep folder: survives a dead worker)."""
    folder = call_dir(out, token)
    path = folder / f"{_safe(run_id)}.json"
    try:
        n = int(json.loads(path.read_text())["attempts"]) + 1
    except (OSError, ValueError, KeyError, TypeError):
        n = 1
    try:
        folder.mkdir(parents=True, exist_ok=True)
        write_json(path, {"id": run_id, "attempts": n})
    except OSError:
        pass
    return n


def _safe(run_id: str) -> str:
    """A file name standing for ``run_id`` (distinct ids, distinct names)."""
    return hashlib.sha256(run_id.encode()).hexdigest()[:32]


def _start(
    run: SweepRun | tuple[SweepRun, ...], out: Path, *, video: bool, fresh: bool
) -> tuple[subprocess.Popen, int]:
    """Start the run process of a run, or of a batch of runs (a tuple); returns it and the read
    end of its result pipe."""
    read_fd, write_fd = os.pipe()
    batch = isinstance(run, tuple)
    # the run ids on the command line name the process in ps/top (the job itself comes on stdin)
    name = ["--batch", *(r.id for r in run)] if batch else ["--run", run.id]
    try:
        proc = subprocess.Popen(
            [sys.executable, "-m", "magsail_mj.sweep", *name],
            stdin=subprocess.PIPE,
            pass_fds=(write_fd,),
            start_new_session=True,
        )
    finally:
        os.close(write_fd)
    job = {
        "runs" if batch else "run": run,
        "out": str(out),
        "video": video,
        "fresh": fresh,
        "parent_pid": os.getpid(),
        "result_fd": write_fd,
    }
    try:
        proc.stdin.write(pickle.dumps(job))
        proc.stdin.close()
    except OSError:  # it died at once: its exit status says so
        pass
    return proc, read_fd


def _wait(proc: subprocess.Popen, read_fd: int, *, out: Path, token: str, grace_s: float) -> tuple[bytes, bool]:
    """Read the run process's result until it ends; stop it when asked. ``(result, stopped)``."""
    chunks: list[bytes] = []
    stopped, deadline = False, None
    with os.fdopen(read_fd, "rb", buffering=0) as pipe:
        while True:
            ready, _, _ = select.select([pipe], [], [], 0.25)
            if ready:
                data = pipe.read(65536)
                if not data:
                    break
                chunks.append(data)
            if proc.poll() is not None and not ready:
                break
            request = _stop_request(out, token)
            if request and not stopped:
                stopped, deadline = True, time.monotonic() + (0.0 if request == "kill" else grace_s)
                proc.terminate()
            if stopped and (time.monotonic() > deadline or _stop_request(out, token) == "kill"):
                proc.kill()
    proc.wait()
    return b"".join(chunks), stopped


def _lost(run: SweepRun, proc: subprocess.Popen, attempts: int) -> dict[str, Any]:
    code = proc.returncode
    how = f"signal {signal.Signals(-code).name}" if code and code < 0 else f"exit code {code}"
    return _record(
        run,
        status="failed",
        attempts=attempts,
        message=f"run process ended without a result ({how}) in attempt {attempts}",
    )


def supervise(
    run: SweepRun, out_dir: str, *, video: bool, fresh: bool, token: str, run_retries: int, grace_s: float
) -> dict[str, Any]:
    """Dask task: run ``run`` in a run process, retrying (and resuming) one killed by a signal.

    Returns the run's record (``attempts`` counts every attempt of this sweep call, also those
    of workers that died; ``not_run`` when the sweep was stopped before it started).
    """
    out = Path(out_dir)
    t0 = time.perf_counter()
    if _stop_request(out, token):
        return _record(run, status="not_run", message="not started: the sweep was interrupted")
    return _supervised(run, out, video=video, fresh=fresh, token=token, run_retries=run_retries, grace_s=grace_s, t0=t0)


def _supervised(
    run: SweepRun, out: Path, *, video: bool, fresh: bool, token: str, run_retries: int, grace_s: float, t0: float
) -> dict[str, Any]:
    """The attempts of one run in run processes (:func:`supervise`), counted from this call's earlier ones."""
    while True:
        attempts = _next_attempt(out, token, run.id)
        proc, read_fd = _start(run, out, video=video, fresh=fresh and attempts == 1)
        result, stopped = _wait(proc, read_fd, out=out, token=token, grace_s=grace_s)
        try:
            record = json.loads(result.decode()) if result else None
        except ValueError:
            record = None
        killed = proc.returncode is not None and proc.returncode < 0
        if record is None and killed and not stopped and attempts <= run_retries:
            continue
        record = record or _lost(run, proc, attempts)
        if stopped and record["status"] not in FINISHED:
            record.update(status="interrupted", message=record["message"] or "stopped while running")
        record.update(attempts=attempts, wall_time_s=time.perf_counter() - t0)
        return record


def supervise_batch(
    runs: tuple[SweepRun, ...], out_dir: str, *, fresh: bool, token: str, run_retries: int, grace_s: float
) -> list[dict[str, Any]]:
    """Dask task: run ``runs`` (of one config file) as the worlds of one batch in one run process
    (:func:`run_batch`); returns their records in order, as :func:`supervise` returns one.

    Retries are per run. A task started again after its worker died (Dask reschedules it; the
    attempt counters say so) keeps the runs whose folders that attempt finished (unless ``fresh``:
    they may be an earlier call's) and runs the others as a batch again; unless ``fresh``, a batch
    resumes from the checkpoint of exactly these runs in the first one's folder. When the batch
    process is killed by a signal and its checkpoint of these runs has advanced since the attempt
    began, the batch is started again from it while every run's attempts are within
    ``run_retries``; otherwise the runs it did not finish are retried one by one as single runs
    (:func:`supervise`'s attempts: a world that takes its process down, so that the checkpoint
    stops advancing, is then alone), each while its attempts are within ``run_retries``; otherwise
    they fail, naming the signal.
    """
    out = Path(out_dir)
    if _stop_request(out, token):
        return [_record(run, status="not_run", message="not started: the sweep was interrupted") for run in runs]
    attempts = {run.id: _next_attempt(out, token, run.id) for run in runs}
    records: dict[str, dict[str, Any]] = {}
    if not fresh and max(attempts.values()) > 1:
        for run in runs:
            record = finished_record(run, out)
            if record is not None:
                records[run.id] = {**record, "attempts": attempts[run.id]}
    todo = tuple(run for run in runs if run.id not in records)
    resume, t_from = not fresh, _batch_checkpoint_s(todo, out) if not fresh else None
    while todo:
        proc, read_fd = _start(todo, out, video=False, fresh=not resume)
        result, stopped = _wait(proc, read_fd, out=out, token=token, grace_s=grace_s)
        try:
            done = json.loads(result.decode()) if result else None
        except ValueError:
            done = None
        if isinstance(done, list) and len(done) == len(todo):
            for run, record in zip(todo, done):
                if stopped and record["status"] not in FINISHED:
                    record.update(status="interrupted", message=record["message"] or "stopped while running")
                records[run.id] = {**record, "attempts": attempts[run.id]}
            break
        killed = proc.returncode is not None and proc.returncode < 0
        again = killed and not stopped and not _stop_request(out, token)
        t_now = _batch_checkpoint_s(todo, out) if again else None
        if t_now is not None and t_now > (-1.0 if t_from is None else t_from):
            if all(attempts[run.id] <= run_retries for run in todo):  # progress since: resume the batch
                attempts = {**attempts, **{run.id: _next_attempt(out, token, run.id) for run in todo}}
                resume, t_from = True, t_now
                continue
        for run in todo:
            record = finished_record(run, out) if not stopped else None
            if record is not None:
                records[run.id] = {**record, "attempts": attempts[run.id]}
            elif again and attempts[run.id] <= run_retries:
                records[run.id] = _supervised(
                    run,
                    out,
                    video=False,
                    fresh=False,
                    token=token,
                    run_retries=run_retries,
                    grace_s=grace_s,
                    t0=time.perf_counter(),
                )
            else:
                record = _lost(run, proc, attempts[run.id])
                if stopped:
                    record.update(status="interrupted", message="stopped while running")
                records[run.id] = record
        break
    return [records[run.id] for run in runs]


def _batch_checkpoint_s(runs: tuple[SweepRun, ...], out: Path) -> float | None:
    """Simulated time [s] of the batch checkpoint of exactly ``runs`` (in their order) in the first
    run's folder, else None (none there, another set of folders, or unreadable). Its identities
    are checked by the batch process that resumes it."""
    found = checkpoint_folders(out / runs[0].id / BATCH_CHECKPOINT_NAME)
    if found is None or found[0] != [run.id for run in runs]:
        return None
    return found[1]
