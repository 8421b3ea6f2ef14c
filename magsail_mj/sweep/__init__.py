"""Sweeps: many independent runs from one sweep file, on dask.distributed (laptop to cluster).

A sweep file is a TOML document listing scenario configs::

    name = "sweep36"
    description = "current-loops: geometries A-D x EI x N"
    set = ["sim.record_every=20"]          # optional overrides applied to every run

    [[run]]
    id = "sweep/a_n12_ei1e3"                # run folder below the sweep's output folder
    config = "sweep/a_n12_ei1e3.toml"       # relative to the sweep file
    set = []                                # optional per-run overrides

or varying keys of one base config (top-level ``config``) with ``[grid]`` and ``[monte_carlo]``
tables (:mod:`magsail_mj.sweep.design`). Every config is loaded and validated before anything is
written (a bad one names its run id, key, value and what is allowed); run ids must name distinct,
non-nested folders below the sweep folder (``""``, ``"."``, ``"a/.."``, ``"a"`` beside ``"a/"``
are refused with the run index).

Engine: every run is a Dask task (:func:`magsail_mj.sweep.runner.supervise`) on a LocalCluster of
``workers`` single-thread processes (default), on a running scheduler (``scheduler``), or on a
dask-jobqueue cluster (:func:`make_cluster`). The task runs the run in its own process (one BLAS
thread, :func:`magsail_mj.run.run_scenario` into ``OUT/<id>``), so results do not depend on how a
worker was started. A run that raises, diverges or whose video fails is recorded with its status
and message; the others go on. Runs of one compiled model that a batch takes run as the worlds of
batches of up to ``batch_size`` runs, one task each (:mod:`magsail_mj.sweep.batches`,
:func:`magsail_mj.sweep.runner.supervise_batch`), with the single runs' folders, records and
numbers.

Guarantees:

* **Reuse only of what is valid now.** A run folder is reused (not rerun) only when its
  ``manifest.json`` has a finished status (:data:`FINISHED`: completed, a studied failure such as
  structure_failed, or diverged), the ``config_hash`` of the config the sweep would run now (same
  overrides), every file it lists with the recorded sha256, and ``video.mp4`` when a video is
  asked. Anything else is rerun into that folder. ``overwrite`` reruns every selected run.
* **Nothing lost.** A run process killed by a signal (out of memory, ``kill``) is retried up to
  ``retries`` times; a task whose Dask worker died (killed, a cluster job's wall time) is
  rescheduled by Dask on another worker. A retried run, and a run whose folder holds the
  checkpoint of an earlier stopped run, resumes from the checkpoint when it belongs to the same
  numbers (bit-identical to an uninterrupted run); ``attempts`` and ``resumed_from_s`` say so in
  its record. The summaries are rewritten as each run finishes, so a crash of the client loses
  nothing that finished.
* **Summaries merge.** ``sweep_summary.json``/``.csv`` always list every run of the sweep file:
  runs outside ``only`` keep their record when their folder is still valid, else ``not_run``.
* **Interrupts stop promptly.** SIGINT or SIGTERM asks every running run to stop (SIGTERM;
  SIGKILL after a grace time or at a second interrupt), writes the summaries (stopped runs
  ``interrupted``, unstarted ones ``not_run``), closes the cluster and raises
  :class:`SweepInterrupted`.
* **No orphans, no concurrent sweeps.** The LocalCluster's workers die with the sweep process
  (Dask's parent watch), and every run process dies with its worker (``PR_SET_PDEATHSIG`` on
  Linux, a parent-pid watch elsewhere), writing its interrupted outputs first. The sweep folder
  is locked (``fcntl.flock`` on ``.sweep.lock``) and every run process holds a lock of its own
  run (``.sweep.state/runs.lock``): a second sweep into a folder where a sweep or any run process
  of one still runs raises :class:`~magsail_mj.io.RunDirError`, and a retried run waits for its
  orphan to end.
* **Failed means failed.** A run whose video (or anything else) failed has status ``failed`` and
  a message saying why; so has a run whose folder does not verify right after it ran. Only
  :data:`FINISHED` folders are ever reused. :func:`sweep_exit_code` gives 1 when a run of this
  call failed or was stopped, else 3 when one diverged, else 0.

The sweep folder receives ``sweep_summary.json`` (one record per run with exactly the keys
:data:`RECORD_KEYS`: ``id``, ``status``, ``message``, ``config_hash``, ``params`` (the grid or
drawn values), ``wall_time_s``, ``attempts``, ``resumed_from_s``, ``summary`` (the run's
summary.json)), ``sweep_summary.csv`` (the same as a table: the sweep columns, a
``params.<key>`` column per varied key, then every scalar of the run summaries, each column once)
and ``sweep_manifest.json`` (sweep file, its hash, overrides, engine, workers, worker thread
settings, package versions, wall time, the reused runs), written atomically in that order. Every
run folder also holds ``params.json`` (its id, params, config, overrides and config hash).
While runs go, a progress bar on stderr (:mod:`magsail_mj.sweep.progress`) counts the runs done,
running and failed and gives the Dask dashboard address; :mod:`magsail_mj.sweep.report` writes
the tables and plots of a finished sweep.
"""

from __future__ import annotations

import contextlib
import csv
import datetime as _dt
import hashlib
import io
import json
import logging
import os
import re
import shutil
import signal
import sys
import threading
import time
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Self

from dask.utils import parse_bytes
from distributed import Client, LocalCluster, Nanny, as_completed

from magsail_mj.config import ConfigError, apply_overrides, config_hash, load_config, read_toml
from magsail_mj.io import RunDirError, atomic_path, file_sha256, package_versions, to_jsonable, write_json
from magsail_mj.resources import memory_limit_bytes
from magsail_mj.run import deferred_interrupts
from magsail_mj.sweep.common import (
    _SUCCESS,
    FINISHED,
    LOCK_NAME,
    RUNS_LOCK,
    STATE_DIR,
    SweepRun,
    _folder_check,
    _record,
    runs_running,
)
from magsail_mj.sweep.design import design_points
from magsail_mj.sweep.batches import check_batch_size, plan_batches
from magsail_mj.sweep.progress import SweepProgress, dashboard_address, running_tasks
from magsail_mj.sweep.runner import IgnoreSigint, request_stop, run_one, supervise, supervise_batch

try:
    import fcntl
except ImportError:  # pragma: no cover - not on Linux/macOS
    fcntl = None  # type: ignore[assignment]

try:
    import bokeh  # noqa: F401 - only whether the Dask dashboard can be served
except ImportError:
    _DASHBOARD = False
else:
    _DASHBOARD = True

__all__ = [
    "FINISHED",
    "RECORD_KEYS",
    "LOCK_NAME",
    "RUNS_LOCK",
    "STATE_DIR",
    "Sweep",
    "SweepInterrupted",
    "SweepRun",
    "is_sweep_file",
    "load_sweep",
    "check_walltime",
    "make_cluster",
    "run_sweep",
    "sweep_exit_code",
]


_OUTPUTS = ("sweep_summary.json", "sweep_summary.csv", "sweep_manifest.json")
_RESERVED = (*_OUTPUTS, LOCK_NAME, STATE_DIR)
_run_one = run_one  # one attempt of a run in this process (tests, debugging)
_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
_SWEEP_COLUMNS = ("id", "status", "reused", "wall_time_s", "message")
_EXTRA_COLUMNS = ("attempts", "resumed_from_s", "config_hash")
_SUMMARY_DUPLICATES = ("status_message",)  # the run's own message: the sweep's "message" column says it
_SIGNALS = (signal.SIGINT, signal.SIGTERM)
_SWEEP_KEYS = ("name", "description", "set", "config", "run", "grid", "monte_carlo", "report", "plots")
RECORD_KEYS = (
    "id",
    "status",
    "message",
    "config_hash",
    "params",
    "wall_time_s",
    "attempts",
    "resumed_from_s",
    "summary",
)
"""The keys of a ``sweep_summary.json`` record, exactly (the returned records also hold ``reused``,
``selected`` and ``config``; the CSV and the manifest say which runs were reused)."""
_POLL_S = 0.5  # how often the progress bar asks the scheduler what runs


class SweepInterrupted(KeyboardInterrupt):
    """The sweep was stopped by SIGINT/SIGTERM after writing its summaries (the CLI exits 130).

    ``records`` holds the summary records written (empty when raised before the summaries).
    """

    def __init__(self, signum: int | None = None, records: list[dict[str, Any]] | None = None):
        name = signal.Signals(signum).name if signum else "interrupt"
        super().__init__(f"sweep interrupted by {name}")
        self.signum = signum
        self.records = list(records or [])


@dataclass(frozen=True)
class Sweep:
    """A parsed sweep file: every run it lists (``runs``) and the ``only`` filter."""

    name: str
    path: Path
    runs: tuple[SweepRun, ...]
    description: str = ""
    overrides: tuple[str, ...] = field(default_factory=tuple)
    only: tuple[str, ...] | None = None

    @property
    def selected(self) -> tuple[SweepRun, ...]:
        """The runs this call runs (all of them unless ``only`` was given)."""
        return tuple(r for r in self.runs if r.selected)


def is_sweep_file(path: str | Path) -> bool:
    """True for a sweep file (``[[run]]``, ``[grid]`` or ``[monte_carlo]`` tables and no ``concept``).

    Raises:
      ConfigError: the path is missing, a folder, unreadable or not TOML.
    """
    tree = read_toml(path)
    return any(k in tree for k in ("run", "grid", "monte_carlo")) and "concept" not in tree


# ---------------------------------------------------------------------------------------------
# Loading and validation


def _str_list(value: Any, where: str) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ConfigError([f"{where}: must be a list of 'key.path=value' strings, got {value!r}"])
    return tuple(value)


_NAME_MAX = 255  # bytes in one folder name (Linux, macOS)


def _normalise_id(raw: Any) -> str:
    """The run folder of an id, normalised (``a//b/`` → ``a/b``); ValueError says what is wrong."""
    if not isinstance(raw, str):
        raise TypeError("must be a string")
    if any(ord(c) < 32 or ord(c) == 127 or c == "\\" for c in raw):
        raise ValueError("must not contain control characters or backslashes")
    if raw.startswith("/"):
        raise ValueError("must be relative to the sweep folder, not absolute")
    parts = [p for p in raw.split("/") if p not in ("", ".")]
    if ".." in parts:
        raise ValueError("must not contain '..'")
    if not parts:
        raise ValueError("names the sweep folder itself; give each run its own folder")
    if parts[0] in _RESERVED:
        raise ValueError(f"is reserved for the sweep's own files ({', '.join(_RESERVED)})")
    long = [p for p in parts if len(p.encode()) > _NAME_MAX]
    if long:
        raise ValueError(f"has a folder name of {len(long[0].encode())} bytes; file systems allow {_NAME_MAX}")
    return "/".join(parts)


def _check_ids(entries: list[Any]) -> tuple[dict[int, str], list[str]]:
    """Normalised id per entry index, and the problems (bad, duplicate or nested ids)."""
    ids: dict[int, str] = {}
    problems: list[str] = []
    for n, entry in enumerate(entries):
        if (
            not isinstance(entry, dict)
            or set(entry) - {"id", "config", "set"}
            or "id" not in entry
            or "config" not in entry
        ):
            problems.append(f"run[{n}]: needs 'id' and 'config' (optional 'set'), got {entry!r}")
            continue
        try:
            ids[n] = _normalise_id(entry["id"])
        except (TypeError, ValueError) as err:
            problems.append(f"run[{n}].id: {entry['id']!r} {err}")
    first: dict[str, int] = {}
    for n, rid in ids.items():
        other = first.setdefault(rid.casefold(), n)
        if other != n:
            problems.append(
                f"run[{n}].id: {entries[n]['id']!r} names the same folder {rid!r} as "
                f"run[{other}].id {entries[other]['id']!r}"
            )
    for n, rid in ids.items():
        parts = rid.split("/")
        for k in range(1, len(parts)):
            outer = first.get("/".join(parts[:k]).casefold())
            if outer is not None:
                problems.append(
                    f"run[{n}].id: {entries[n]['id']!r} lies inside the folder of "
                    f"run[{outer}].id {entries[outer]['id']!r}"
                )
    return ids, problems


def _check_header(tree: dict[str, Any], path: Path) -> tuple[str, str]:
    """The sweep's name and description; ConfigError for unknown keys or a name unfit as a folder."""
    unknown = sorted(set(tree) - set(_SWEEP_KEYS))
    if unknown:
        raise ConfigError(
            [f"{k}: unknown sweep key (allowed: {', '.join(_SWEEP_KEYS)})" for k in unknown], source=str(path)
        )
    name = tree.get("name", path.stem)
    if (
        not isinstance(name, str)
        or not name.strip()
        or name in (".", "..")
        or "/" in name
        or "\\" in name
        or any(ord(c) < 32 for c in name)
    ):
        problem = f"name: must be a plain folder name (the default output folder runs/<name>), got {name!r}"
        raise ConfigError([problem], source=str(path))
    description = tree.get("description", "")
    if not isinstance(description, str):
        raise ConfigError([f"description: must be a string, got {description!r}"], source=str(path))
    if not isinstance(tree.get("plots", True), bool):
        raise ConfigError([f"plots: must be true or false, got {tree['plots']!r}"], source=str(path))
    report = tree.get("report", {})
    figures = report.get("figures", ["-"]) if isinstance(report, dict) else None
    shares = report.get("shares", ["-"]) if isinstance(report, dict) else None
    percentiles = report.get("percentiles", [50]) if isinstance(report, dict) else None
    if (
        set(report or {}) - {"figures", "percentiles", "shares"}
        or not all(isinstance(v, list) and v and all(isinstance(f, str) for f in v) for v in (figures, shares))
        or not isinstance(percentiles, list)
        or not percentiles
        or not all(not isinstance(q, bool) and isinstance(q, (int, float)) and 0 < q <= 100 for q in percentiles)
    ):
        raise ConfigError(
            [
                f"report: must be a table with 'figures' and 'shares', non-empty lists of summary keys, and "
                f"'percentiles', a non-empty list of numbers in (0, 100] (magsail report), got {report!r}"
            ],
            source=str(path),
        )
    return name, description


def _only_terms(only: str | list[str] | tuple[str, ...] | None) -> tuple[str, ...] | None:
    if only is None:
        return None
    terms = (only,) if isinstance(only, str) else tuple(only)
    if not terms or not all(isinstance(t, str) for t in terms):
        raise ConfigError([f"only: must be a string or a non-empty list of strings, got {only!r}"])
    return terms


def _load_run(
    rid: str, config: Path, overrides: tuple[str, ...], selected: bool, params: dict[str, Any]
) -> tuple[SweepRun, list[str]]:
    """The run with the hash of its config now; the config's problems (fatal only when selected)."""
    try:
        cfg = load_config(config, list(overrides))
        digest, concept, problems = config_hash(cfg), str(cfg.concept), []
    except ConfigError as err:
        digest, concept, problems = "", "", [f"{rid}: {p}" for p in err.problems]
    except OSError as err:
        digest, concept, problems = "", "", [f"{rid}: config {config}: {err}"]
    run = SweepRun(
        id=rid,
        config=config,
        overrides=overrides,
        config_hash=digest,
        selected=selected,
        problem="; ".join(problems),
        params=params,
        concept=concept,
    )
    return run, problems if selected else []


def _set_params(overrides: tuple[str, ...]) -> dict[str, Any]:
    """The keys and values of a run's own ``set`` overrides (its params in the summaries)."""
    tree = apply_overrides({}, list(overrides))
    return _flat_params(tree)


def _flat_params(tree: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in tree.items():
        if isinstance(value, dict):
            out.update(_flat_params(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = to_jsonable(value)
    return out


def _entries(tree: dict[str, Any], path: Path) -> list[dict[str, Any]]:
    """The ``[[run]]`` tables, then one entry per ``[grid]`` / ``[monte_carlo]`` point (with ``params``)."""
    entries = tree.get("run", [])
    designed = "grid" in tree or "monte_carlo" in tree
    if not isinstance(entries, list) or not (entries or designed):
        raise ConfigError(
            [
                f"run: must be a non-empty array of [[run]] tables (or give [grid] / [monte_carlo]), "
                f"got {tree.get('run')!r}"
            ],
            source=str(path),
        )
    if not designed:
        if "config" in tree:
            raise ConfigError(
                [
                    "config: the base config is used by [grid] / [monte_carlo] only; add one of them "
                    "or give each [[run]] its config"
                ],
                source=str(path),
            )
        return list(entries)
    base = tree.get("config")
    if not isinstance(base, str) or not base:
        raise ConfigError([f"config: [grid] / [monte_carlo] need the base config path, got {base!r}"], source=str(path))
    try:
        points = design_points(tree)
    except ConfigError as err:
        raise ConfigError(err.problems, source=str(path)) from None
    return [*entries, *({"id": p.id, "config": base, "set": list(p.overrides), "params": p.params} for p in points)]


def load_sweep(
    path: str | Path,
    *,
    extra_overrides: tuple[str, ...] = (),
    only: str | list[str] | tuple[str, ...] | None = None,
    plots: bool | None = None,
) -> Sweep:
    """Parse and validate a sweep file; every listed config is loaded and its hash computed.

    Runs come from the ``[[run]]`` tables (id, config, set) and from the ``[grid]`` /
    ``[monte_carlo]`` tables over the base ``config`` (:mod:`magsail_mj.sweep.design`). The
    overrides of a run apply in this order: the file's ``set``, the run's own ``set`` or its grid
    and Monte Carlo values, then ``extra_overrides``.

    Args:
      path: the sweep TOML.
      extra_overrides: ``key=value`` overrides applied to every run after the file's own.
      only: select the runs whose id contains this substring (or any of these substrings);
        the others stay in ``runs`` (for the merged summary) with ``selected=False``, and a
        config of theirs that does not load is not an error.
      plots: draw the scenarios' PNG plots in every run folder (None: the file's ``plots``, default
        true; false leaves records, series, summary and manifest — a Monte Carlo's runs then cost
        their simulation only, and ``magsail report sweep`` needs none of the plots).
    Raises:
      ConfigError: naming the sweep key, or the run index and id, with the problems.
    """
    path = Path(path)
    tree = read_toml(path)
    name, description = _check_header(tree, path)
    entries = _entries(tree, path)
    common = _str_list(tree.get("set", []), "set")
    extra = tuple(extra_overrides)
    wanted = _only_terms(only)
    draw = bool(tree.get("plots", True)) if plots is None else bool(plots)
    ids, problems = _check_ids(
        [{k: v for k, v in e.items() if k != "params"} if isinstance(e, dict) else e for e in entries]
    )
    runs = []
    for n, rid in ids.items():
        config = entries[n]["config"]
        if not isinstance(config, str) or not config:
            problems.append(f"run[{n}].config: must be a path string, got {config!r}")
            continue
        try:
            own = _str_list(entries[n].get("set", []), f"run[{n}].set")
            params = entries[n]["params"] if "params" in entries[n] else _set_params(own)
        except ConfigError as err:
            problems.extend(f"run[{n}].set: {p}" if p.startswith("--set") else p for p in err.problems)
            continue
        selected = wanted is None or any(w in rid for w in wanted)
        run, errors = _load_run(rid, (path.parent / config).resolve(), common + own + extra, selected, params)
        runs.append(replace(run, plots=draw))
        problems.extend(errors)
    if not any(r.selected for r in runs) and not problems:
        # nothing selected: the runs' own problems are the file's problems too, and are not hidden
        unselected = [r.problem for r in runs if r.problem]
        problems = [f"only: no run id contains any of {list(wanted or [])!r}", *unselected]
    if problems:
        raise ConfigError(problems, source=str(path))
    return Sweep(name=name, path=path, runs=tuple(runs), description=description, overrides=common + extra, only=wanted)


def _reused_record(run: SweepRun, run_dir: Path, manifest: dict[str, Any]) -> dict[str, Any] | None:
    """The record of a valid earlier run (None when its summary does not parse)."""
    try:
        summary = json.loads((run_dir / "summary.json").read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(summary, dict):
        return None
    return _record(
        run,
        status=str(manifest["status"]),
        message=str(manifest.get("status_message") or ""),
        wall_time_s=manifest.get("wall_time_s"),
        reused=True,
        summary=summary,
    )


def _plan(
    sweep: Sweep, out: Path, *, video: bool, overwrite: bool, log: Callable[[str], None] | None
) -> tuple[dict[str, dict[str, Any]], list[SweepRun]]:
    """Records of the runs not to run now (reused or not run), and the runs to run."""
    records: dict[str, dict[str, Any]] = {}
    todo: list[SweepRun] = []
    for run in sweep.runs:
        if run.selected and overwrite:
            todo.append(run)
            continue
        manifest, why = _folder_check(out / run.id, config_hash=run.config_hash, video=video and run.selected)
        rec = _reused_record(run, out / run.id, manifest) if manifest else None
        if rec is not None:
            records[run.id] = rec
        elif run.selected:
            todo.append(run)
            if log and (out / run.id / "manifest.json").exists():
                log(f"  {run.id}: rerun: {why}")
        else:
            records[run.id] = _record(run, status="not_run", message=f"not selected in this call; {run.problem or why}")
    return records, todo


# ---------------------------------------------------------------------------------------------
# Client side: lock, signals, the Dask cluster


@contextlib.contextmanager
def _sweep_lock(out: Path) -> Iterator[int]:
    """Hold ``out/.sweep.lock`` exclusively; RunDirError when another sweep holds it, or when run
    processes of an earlier sweep (e.g. one killed with -9) still run in this folder."""
    path = out / LOCK_NAME
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 100, 0).decode(errors="replace").strip() or "?"
                raise RunDirError(
                    f"--out {out}: another sweep is running in this folder (lock {path} held by "
                    f"pid {holder}); wait for it or choose another --out"
                ) from None
        if runs_running(out):
            raise RunDirError(
                f"--out {out}: another sweep is running in this folder (run processes of an "
                f"earlier sweep still hold {out / STATE_DIR / RUNS_LOCK}); wait for them to end "
                "or choose another --out"
            )
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield fd
    finally:
        os.close(fd)


class _Interrupts:
    """SIGINT/SIGTERM raise :class:`SweepInterrupted`, or are remembered inside :meth:`deferred`."""

    def __init__(self) -> None:
        self.pending: int | None = None
        self.received = 0  # signals seen while deferring (a second Ctrl-C hurries the stop)
        self._depth = 0
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> Self:
        if threading.current_thread() is threading.main_thread():
            for signum in _SIGNALS:
                if signal.getsignal(signum) is not signal.SIG_IGN:  # e.g. SIGINT of a background job
                    self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for signum, previous in self._previous.items():
            signal.signal(signum, signal.SIG_DFL if previous is None else previous)

    def _handle(self, signum: int, frame: Any) -> None:
        if self._depth:
            self.pending = self.pending or signum
            self.received += 1
            return
        raise SweepInterrupted(signum)

    def raise_pending(self) -> None:
        """Raise :class:`SweepInterrupted` for a signal remembered during a deferred block."""
        if self.pending:
            raise SweepInterrupted(self.pending)

    @contextlib.contextmanager
    def deferred(self) -> Iterator[None]:
        """Remember signals during the block instead of raising (nestable)."""
        self._depth += 1
        try:
            yield
        finally:
            self._depth -= 1


@contextlib.contextmanager
def _sigint_ignored_by_children() -> Iterator[None]:
    """Worker processes started in the block start with SIGINT ignored (a terminal's Ctrl-C
    reaches the whole process group; only the sweep client handles it). Dask's worker start-up
    installs a SIGINT handler of its own later; :class:`~magsail_mj.sweep.runner.IgnoreSigint`
    ignores it again once the worker runs."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)  # an ignored signal stays ignored across exec
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.SIG_DFL if previous is None else previous)


@contextlib.contextmanager
def _worker_env() -> Iterator[None]:
    """One BLAS thread per worker unless the user set one (environment seen by the worker processes)."""
    added = [v for v in _THREAD_VARS if v not in os.environ]
    for var in added:
        os.environ[var] = "1"
    try:
        yield
    finally:
        for var in added:
            os.environ.pop(var, None)


def _thread_settings() -> dict[str, str]:
    return {var: os.environ.get(var, "1") for var in _THREAD_VARS}


def _log_record(log: Callable[[str], None] | None, rec: dict[str, Any]) -> None:
    if log:
        wall = rec.get("wall_time_s")
        took = f" in {wall:.1f} s" if isinstance(wall, (int, float)) else ""
        extra = f" ({rec['message']})" if rec["status"] != "completed" and rec["message"] else ""
        again = f", attempt {rec['attempts']}" if (rec.get("attempts") or 0) > 1 else ""
        resumed = f", resumed from t = {rec['resumed_from_s']:g} s" if rec.get("resumed_from_s") is not None else ""
        log(f"  {rec['id']}: {rec['status']}{took}{again}{resumed}{extra}")


class _SchedulerUnreachable(RunDirError):
    """``--scheduler`` names no Dask scheduler that answers (no run has started)."""


@contextlib.contextmanager
def _dask_client(*, workers: int, scheduler: str | None, cluster: Any | None) -> Iterator[Any]:
    """A Dask client: on ``scheduler`` (an address), on ``cluster`` (e.g. a dask-jobqueue cluster),
    else on a LocalCluster of ``workers`` processes with one thread each (closed on exit).

    Raises:
      RunDirError: the scheduler cannot be reached (naming ``--scheduler`` and the address).
    """
    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=15, set_as_default=False)
        except (OSError, TimeoutError, ValueError) as err:
            raise _SchedulerUnreachable(
                f"--scheduler {scheduler!r}: cannot connect to a Dask scheduler there ({err})"
            ) from None
        with contextlib.closing(client):
            yield client
        return
    if cluster is not None:
        with Client(cluster, set_as_default=False) as client:
            yield client
        return
    # a signal while the cluster starts would leave it half-built (its finaliser then fails with a
    # traceback): it is held until the cluster exists and is delivered again inside the try below
    with _worker_env(), _sigint_ignored_by_children(), deferred_interrupts() as pending:
        local = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0" if _DASHBOARD else None,
            silence_logs=logging.CRITICAL,
            worker_class=Nanny,
        )
    try:
        if pending:
            signal.raise_signal(pending[0])
        with Client(local, set_as_default=False) as client:
            client.register_plugin(IgnoreSigint())
            yield client
    finally:
        try:
            local.close(timeout=10)
        except (TimeoutError, OSError, RuntimeError):  # its workers die with this process anyway (parent watch)
            pass


CLUSTER_KINDS = ("slurm", "pbs")
_WALLTIME = re.compile(r"^(?:(\d+)-)?(\d{1,3}):([0-5]\d)(?::([0-5]\d))?$")
_SUBMIT = {"slurm": "sbatch", "pbs": "qsub"}
"""The batch system's submit command that a cluster of each kind runs."""


def check_walltime(walltime: Any) -> str:
    """``walltime`` when it is ``[D-]HH:MM[:SS]`` with minutes and seconds below 60 (and hours
    below 24 after a day count); ValueError naming ``--walltime`` otherwise."""
    match = _WALLTIME.match(walltime) if isinstance(walltime, str) else None
    if match is None or (match.group(1) is not None and int(match.group(2)) >= 24):
        raise ValueError(
            f"--walltime: must be HH:MM:SS (or D-HH:MM:SS) with minutes and seconds below 60, got {walltime!r}"
        )
    return walltime


def make_cluster(
    kind: str,
    *,
    cores_per_job: int = 1,
    memory_per_job: str = "4GB",
    walltime: str = "01:00:00",
    queue: str | None = None,
    account: str | None = None,
    python: str | None = None,
    require_submit: bool = True,
) -> Any:
    """A dask-jobqueue cluster (``kind`` slurm or pbs) whose jobs each run ``cores_per_job`` worker
    processes with one thread (and one BLAS thread) each; no job is submitted yet (``cluster.scale(jobs=N)``
    or ``cluster.adapt(...)`` does that; ``cluster.job_script()`` shows the script).

    Raises:
      ValueError: naming the option (``--cluster``, ``--cores-per-job``, ``--memory-per-job``,
        ``--walltime``) and the value, saying that dask-jobqueue is not installed, or that the
        batch system's submit command (``sbatch``, ``qsub``) is not on ``PATH`` (with
        ``require_submit``; without it the cluster can still write its job script).
    """
    if kind not in CLUSTER_KINDS:
        raise ValueError(f"--cluster: must be one of {', '.join(CLUSTER_KINDS)}, got {kind!r}")
    # imported here, its single entry point: importing dask_jobqueue replaces the process's SIGINT
    # handler with one that exits with status 0, so it must not be imported at start-up (a Ctrl-C
    # while the command starts would end it "successfully"); the handlers are put back
    saved = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        import dask_jobqueue
    except ImportError:  # the optional extra "cluster"
        raise ValueError("--cluster: needs dask-jobqueue (pip install 'magsail_mj[cluster]')") from None
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)
    if isinstance(cores_per_job, bool) or not isinstance(cores_per_job, int) or cores_per_job < 1:
        raise ValueError(f"--cores-per-job: must be an integer >= 1, got {cores_per_job!r}")
    try:
        if parse_bytes(memory_per_job) <= 0:
            raise ValueError
    except (ValueError, TypeError):
        raise ValueError(f"--memory-per-job: must be a memory size such as 16GB, got {memory_per_job!r}") from None
    check_walltime(walltime)
    if (
        require_submit and shutil.which(_SUBMIT[kind]) is None
    ):  # dask-jobqueue would fail inside its event loop and hang
        raise ValueError(
            f"--cluster {kind}: the {kind.upper()} submit command {_SUBMIT[kind]!r} is not on PATH "
            "(run the sweep on a login node of the cluster, or use --workers / --scheduler)"
        )
    cls = dask_jobqueue.SLURMCluster if kind == "slurm" else dask_jobqueue.PBSCluster
    threads = [f"export {var}=1" for var in _THREAD_VARS]
    return cls(
        cores=cores_per_job,
        processes=cores_per_job,
        memory=memory_per_job,
        walltime=walltime,
        queue=queue,
        account=account,
        python=python or sys.executable,
        job_script_prologue=threads,
        job_name="magsail-sweep",
        silence_logs="error",
    )


@dataclass
class _Call:
    """One sweep call: what it runs, where, and the records so far."""

    sweep: Sweep
    out: Path
    token: str
    records: dict[str, dict[str, Any]]
    interrupts: _Interrupts
    log: Callable[[str], None] | None
    meta: dict[str, Any]
    progress: SweepProgress | None = None
    t0: float = field(default_factory=time.perf_counter)
    settled: bool = True  # False while tasks of this call may still run (their stop request must stay)

    def store(self, rec: dict[str, Any]) -> None:
        """Record a finished run and rewrite the summaries (a crash of the client loses nothing finished)."""
        with self.interrupts.deferred():
            self.records[rec["id"]] = rec
            self.write(finished=False)
            _log_record(self.log, rec)
            if self.progress is not None:
                self.progress.finished(rec["status"])

    def write(self, *, finished: bool, interrupted: bool = False) -> list[dict[str, Any]]:
        """Write the summaries and the manifest; runs without a record yet are ``not_run`` (pending)."""
        pending = "pending: the sweep was still running" if not finished else "not started"
        ordered = [self.records.get(r.id) or _record(r, status="not_run", message=pending) for r in self.sweep.runs]
        _write_outputs(
            self.out,
            self.sweep,
            ordered,
            {
                **self.meta,
                "finished": finished,
                "interrupted": interrupted,
                "wall_time_s": time.perf_counter() - self.t0,
            },
        )
        return ordered


def _future_records(future: Any, task: tuple[SweepRun, ...]) -> list[dict[str, Any]]:
    """The records a finished task returned (one per run of the task), or failed records saying
    why the task failed."""
    try:
        result = future.result()
    except Exception as err:  # noqa: BLE001 - KilledWorker (workers died again and again) or a lost task
        why = (
            "its workers died too often (Dask KilledWorker)"
            if type(err).__name__ == "KilledWorker"
            else f"{type(err).__name__}: {err}"
        )
        return [_record(run, status="failed", message=f"the task failed: {why}", attempts=0) for run in task]
    return list(result) if isinstance(result, list) else [result]


def _submit(
    client: Any,
    call: _Call,
    tasks: list[tuple[SweepRun, ...]],
    *,
    video: bool,
    overwrite: bool,
    retries: int,
    grace_s: float,
) -> dict[Any, tuple[SweepRun, ...]]:
    """One Dask task per task of runs: :func:`~magsail_mj.sweep.runner.supervise` for a single
    run, :func:`~magsail_mj.sweep.runner.supervise_batch` for a batch (its key ends ``-w<worlds>``,
    which the progress bar counts as that many runs)."""
    futures = {}
    for n, task in enumerate(tasks):
        common = {"fresh": overwrite, "token": call.token, "run_retries": retries, "grace_s": grace_s, "pure": False}
        if len(task) == 1:
            future = client.submit(
                supervise, task[0], str(call.out), video=video, key=f"magsail-run-{call.token}-{n}", **common
            )
        else:
            future = client.submit(
                supervise_batch, task, str(call.out), key=f"magsail-run-{call.token}-{n}-w{len(task)}", **common
            )
        futures[future] = task
    return futures


def _task_runs(key: str) -> int:
    """The runs of a task of this sweep from its key (``…-w<worlds>`` for a batch)."""
    head, _, worlds = str(key).rpartition("-w")
    return int(worlds) if head and worlds.isdigit() else 1


def _store_task(call: _Call, future: Any, task: tuple[SweepRun, ...]) -> None:
    """Store the record of every run of a finished task."""
    for rec in _future_records(future, task):
        call.store(rec)


def _execute(client: Any, futures: dict[Any, tuple[SweepRun, ...]], call: _Call) -> None:
    """Store each run's record as its task ends (the progress bar asks the scheduler meanwhile
    how many runs are being processed)."""
    progress = call.progress if call.progress is not None and call.progress.enabled else None
    if progress is None:
        for future in as_completed(list(futures), loop=client.loop):
            _store_task(call, future, futures[future])
            call.interrupts.raise_pending()
        return
    progress.set_dashboard(dashboard_address(client))
    prefix = f"magsail-run-{call.token}-"
    pending = as_completed(list(futures), loop=client.loop)
    while not pending.is_empty():
        if not pending.has_ready():
            progress.set_running(running_tasks(client, prefix, weight=_task_runs))
            time.sleep(_POLL_S)
            continue
        for future in pending.next_batch(block=False):
            _store_task(call, future, futures[future])
            call.interrupts.raise_pending()


def _stop(futures: dict[Any, tuple[SweepRun, ...]], call: _Call, *, grace_s: float) -> None:
    """After SIGINT/SIGTERM: ask the supervisors to stop, wait for their records (a further
    interrupt kills the runs at once), mark the rest ``interrupted``."""
    if call.log:
        call.log("sweep interrupted: stopping the running runs (interrupt again to kill them now)")
    request_stop(call.out, call.token)
    seen = call.interrupts.received
    killed = False
    deadline = time.monotonic() + grace_s + 5.0
    while time.monotonic() < deadline and not all(f.done() for f in futures):
        if call.interrupts.received != seen and not killed:
            request_stop(call.out, call.token, kill=True)
            killed, deadline = True, min(deadline, time.monotonic() + 3.0)
        time.sleep(0.1)
    call.settled = all(f.done() for f in futures)
    for future, task in futures.items():
        if all(run.id in call.records for run in task):
            continue
        recs = (
            _future_records(future, task)
            if future.done()
            else [
                _record(run, status="interrupted", message="stopped while running (no record from its worker)")
                for run in task
            ]
        )
        for rec in recs:
            if rec["id"] not in call.records:
                call.records[rec["id"]] = rec
                _log_record(call.log, rec)


def _engine_resources(client: Any, local_workers: int | None) -> tuple[int, float]:
    """``(cores, memory per core [bytes])`` the default batch size is chosen for: a LocalCluster's
    workers sharing the memory limit (:func:`~magsail_mj.resources.memory_limit_bytes`), else the
    scheduler's worker threads now and their workers' memory limits (the memory limit here when
    they state none)."""
    if local_workers is not None:
        return local_workers, memory_limit_bytes() / local_workers
    try:
        workers = list(client.scheduler_info().get("workers", {}).values())
    except (OSError, TimeoutError, RuntimeError, AttributeError):
        workers = []
    cores = max(1, sum(int(w.get("nthreads") or 0) for w in workers))
    stated = [float(w["memory_limit"]) / max(1, int(w.get("nthreads") or 1)) for w in workers if w.get("memory_limit")]
    return cores, min(stated) if stated else memory_limit_bytes() / cores


def _plan_tasks(
    todo: list[SweepRun],
    call: _Call,
    *,
    batch_size: int | None,
    resources: tuple[int, float],
    overwrite: bool,
) -> list[tuple[SweepRun, ...]]:
    """The tasks of ``todo`` (:func:`magsail_mj.sweep.batches.plan_batches`); the batch size used
    goes into the manifest."""
    cores, per_core = resources
    tasks, size = plan_batches(
        todo, call.out, batch_size=batch_size, cores=cores, memory_per_core_bytes=per_core, resume=not overwrite
    )
    batches = [t for t in tasks if len(t) > 1]
    call.meta.update(batch_size=size, batches=len(batches))
    if call.log:
        call.log(
            f"sweep {call.sweep.name}: batch size {size}: {sum(map(len, batches))} runs in {len(batches)} "
            f"batches, {len(tasks) - len(batches)} runs alone"
        )
    return tasks


def _run_dask(
    todo: list[SweepRun],
    call: _Call,
    *,
    workers: int,
    scheduler: str | None,
    cluster: Any | None,
    video: bool,
    overwrite: bool,
    retries: int,
    grace_s: float,
    batch_size: int | None,
    batch_resources: tuple[int, float] | None,
) -> SweepInterrupted | None:
    """Run ``todo`` on Dask, grouped into tasks (:func:`_plan_tasks`); on SIGINT/SIGTERM stop and
    return the interrupt."""
    futures: dict[Any, tuple[SweepRun, ...]] = {}
    stopped: SweepInterrupted | None = None
    try:
        with _dask_client(workers=workers, scheduler=scheduler, cluster=cluster) as client:
            try:
                call.interrupts.raise_pending()
                local = None if scheduler or cluster is not None else workers
                tasks = _plan_tasks(
                    todo,
                    call,
                    batch_size=1 if video else batch_size,
                    resources=batch_resources or _engine_resources(client, local),
                    overwrite=overwrite,
                )
                call.interrupts.raise_pending()
                futures = _submit(
                    client, call, tasks, video=video, overwrite=overwrite, retries=retries, grace_s=grace_s
                )
                _execute(client, futures, call)
            except KeyboardInterrupt as err:
                stopped = err if isinstance(err, SweepInterrupted) else SweepInterrupted(signal.SIGINT)
                with call.interrupts.deferred():
                    _stop(futures, call, grace_s=grace_s)
            except BaseException:
                request_stop(call.out, call.token, kill=True)  # no run outlives a sweep that fails itself
                call.settled = False
                raise
            finally:
                with call.interrupts.deferred():
                    client.cancel(list(futures), force=True)
    except KeyboardInterrupt as err:  # while the cluster started or closed
        stopped = stopped or (err if isinstance(err, SweepInterrupted) else SweepInterrupted(signal.SIGINT))
    for run in todo:
        call.records.setdefault(
            run.id, _record(run, status="not_run", message="not started: the sweep was interrupted")
        )
    return stopped


# ---------------------------------------------------------------------------------------------
# Outputs


def _cell(value: Any) -> Any:
    """A CSV cell: scalars as they are, vectors and tables as JSON, None as empty."""
    if value is None:
        return ""
    return value if isinstance(value, (int, float, str, bool)) else json.dumps(value)


def _table(records: list[dict[str, Any]]) -> str:
    """CSV text: the sweep columns, ``params.<key>`` per varied key, then every scalar of the run
    summaries not already a column."""
    skip = set(_SWEEP_COLUMNS) | set(_EXTRA_COLUMNS) | set(_SUMMARY_DUPLICATES)
    params: list[str] = []
    cols: list[str] = []
    for rec in records:
        params.extend(k for k in rec.get("params", {}) if k not in params)
        for key, value in rec.get("summary", {}).items():
            if key not in skip and key not in cols and (value is None or isinstance(value, (int, float, str, bool))):
                cols.append(key)
    buf = io.StringIO()
    writer = csv.writer(buf)
    writer.writerow([*_SWEEP_COLUMNS, *_EXTRA_COLUMNS, *(f"params.{k}" for k in params), *cols])
    for rec in records:
        s, p = rec.get("summary", {}), rec.get("params", {})
        wall = rec.get("wall_time_s")
        writer.writerow(
            [
                rec["id"],
                rec["status"],
                rec["reused"],
                f"{wall:.1f}" if isinstance(wall, (int, float)) else "",
                rec["message"],
                *[_cell(rec.get(c)) for c in _EXTRA_COLUMNS],
                *[_cell(p.get(k)) for k in params],
                *[_cell(s.get(c)) for c in cols],
            ]
        )
    return buf.getvalue()


def _write_outputs(out: Path, sweep: Sweep, ordered: list[dict[str, Any]], meta: dict[str, Any]) -> None:
    """Summaries, then the manifest (last), each atomically."""
    write_json(out / "sweep_summary.json", [_summary_record(r) for r in ordered])
    with atomic_path(out / "sweep_summary.csv") as tmp:
        tmp.write_text(_table(ordered))
    write_json(
        out / "sweep_manifest.json",
        {
            "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
            "sweep": str(sweep.path),
            "sweep_hash": hashlib.sha256(sweep.path.read_bytes()).hexdigest(),
            "name": sweep.name,
            "description": sweep.description,
            "overrides": list(sweep.overrides),
            "only": None if sweep.only is None else list(sweep.only),
            **meta,
            "runs": {r["id"]: r["status"] for r in ordered},
            "reused": [r["id"] for r in ordered if r.get("reused")],
            "versions": package_versions(),
            "files": {name: file_sha256(out / name) for name in _OUTPUTS[:2]},  # verified by the report
        },
    )


def _summary_record(rec: dict[str, Any]) -> dict[str, Any]:
    """The ``sweep_summary.json`` record of a run: exactly :data:`RECORD_KEYS` (params and summary
    default to empty tables)."""
    out = {key: rec.get(key) for key in RECORD_KEYS}
    out["params"] = rec.get("params") or {}
    out["summary"] = rec.get("summary") or {}
    return out


def _remove_stale_temporaries(out: Path) -> None:
    """Temporary files of sweep outputs left by a killed sweep (we hold the lock: none is ours)."""
    for name in _OUTPUTS:
        for tmp in out.glob(f".{name}.*"):
            tmp.unlink(missing_ok=True)


def sweep_exit_code(records: list[dict[str, Any]]) -> int:
    """Exit status of a sweep call from its records (runs selected in this call only).

    1 when a selected run failed or ended otherwise unfinished, else 3 when one diverged, else 0
    (completed and the studied failures such as structure_failed are successes).
    """
    statuses = [r["status"] for r in records if r.get("selected", True)]
    if any(s not in FINISHED for s in statuses):
        return 1
    return 0 if all(s in _SUCCESS for s in statuses) else 3


def _clear_state(out: Path) -> None:
    """Remove the per-call state folders (attempt counters, stop requests) of finished calls; the
    run lock file stays (an orphan run process may hold a lock on it)."""
    state = out / STATE_DIR
    if state.is_dir():
        for child in state.iterdir():
            if child.is_dir():
                shutil.rmtree(child, ignore_errors=True)
            elif child.name != RUNS_LOCK:
                child.unlink(missing_ok=True)


def run_sweep(
    sweep: Sweep,
    out_dir: str | Path,
    *,
    workers: int = 1,
    video: bool = False,
    overwrite: bool = False,
    log: Callable[[str], None] | None = print,
    grace_s: float = 10.0,
    scheduler: str | None = None,
    cluster: Any | None = None,
    retries: int = 2,
    progress: bool | None = None,
    batch_size: int | None = None,
    batch_resources: tuple[int, float] | None = None,
) -> list[dict[str, Any]]:
    """Run the selected entries of ``sweep`` into ``out_dir/<id>`` on Dask.

    By default on a LocalCluster of ``workers`` processes (one thread each); on a running Dask
    scheduler with ``scheduler`` (an address such as ``tcp://host:8786``); or on ``cluster`` (a
    Dask cluster object, e.g. from :func:`magsail_mj.sweep.make_cluster`). Each run runs in its
    own process below its worker; a run process killed by a signal is retried up to ``retries``
    times, and a task whose worker died is rescheduled by Dask; a retried run resumes from its
    checkpoint when it has one of the same config.

    Returns one record per run of the sweep file, in file order (``id``, ``status`` ∈ completed,
    structure_failed, diverged, stopped, failed, interrupted, not_run; ``message``,
    ``config_hash``, ``params``, ``wall_time_s``, ``attempts``, ``resumed_from_s``, ``reused``,
    ``selected``, ``summary``), also written to ``sweep_summary.json``/``.csv`` as runs finish.

    ``grace_s`` is how long stopped runs may take to write their outputs after an interrupt
    before they are killed (a second interrupt kills them at once). ``progress`` draws the
    sweep-level bar on stderr (runs done / running / failed, the Dask dashboard address;
    :class:`~magsail_mj.sweep.progress.SweepProgress`): None (default) when stderr is a terminal,
    False never (``--no-progress``).

    ``batch_size`` (``--batch-size``): runs of one compiled model run as the worlds of batches of
    at most this many runs, one task each (:mod:`magsail_mj.sweep.batches`; their folders and
    records have the single runs' form and numbers); 1 runs every run alone; None (default)
    chooses it from the cores and the memory estimate: ``batch_resources`` ``(cores, bytes per
    core)``, by default the LocalCluster's ``workers`` sharing the memory limit, or the
    scheduler's worker threads and their memory limits. With ``video`` every run goes alone.

    Raises:
      ValueError: ``workers``, ``retries`` or ``batch_size`` (named ``--batch-size``) is not an
        integer in range.
      RunDirError: ``out_dir`` is not a folder, another sweep runs in it, or ``scheduler`` is unreachable.
      SweepInterrupted: on SIGINT/SIGTERM, after writing the summaries (``.records``).
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers: must be an integer >= 1, got {workers!r}")
    if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
        raise ValueError(f"retries: must be an integer >= 0, got {retries!r}")
    check_batch_size(batch_size)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise RunDirError(f"--out {out}: exists and is not a folder")
    made = [d for d in (out.absolute(), *out.absolute().parents) if not d.exists()]
    lock_made = not (out / LOCK_NAME).exists()
    out.mkdir(parents=True, exist_ok=True)
    out = out.resolve()
    try:
        return _run_sweep_locked(
            sweep,
            out,
            workers=workers,
            video=video,
            overwrite=overwrite,
            log=log,
            grace_s=grace_s,
            scheduler=scheduler,
            cluster=cluster,
            retries=retries,
            progress=progress,
            batch_size=batch_size,
            batch_resources=batch_resources,
        )
    except _SchedulerUnreachable:  # nothing ran: leave nothing that was not there
        if lock_made:
            (out / LOCK_NAME).unlink(missing_ok=True)
        for folder in made:  # the folders made for --out, innermost first, when still empty
            with contextlib.suppress(OSError):
                folder.rmdir()
        raise


def _run_sweep_locked(
    sweep: Sweep,
    out: Path,
    *,
    workers: int,
    video: bool,
    overwrite: bool,
    log: Callable[[str], None] | None,
    grace_s: float,
    scheduler: str | None,
    cluster: Any | None,
    retries: int,
    progress: bool | None,
    batch_size: int | None,
    batch_resources: tuple[int, float] | None,
) -> list[dict[str, Any]]:
    """:func:`run_sweep` in the existing folder ``out`` (resolved), under the sweep lock."""
    with _sweep_lock(out), _Interrupts() as interrupts:
        _remove_stale_temporaries(out)
        _clear_state(out)
        records, todo = _plan(sweep, out, video=video, overwrite=overwrite, log=log)
        n_workers = min(workers, max(1, len(todo)))
        engine = scheduler or ("cluster" if cluster is not None else f"LocalCluster({n_workers} workers)")
        if log:
            log(
                f"sweep {sweep.name}: {len(todo)} runs to do, {len(records)} not run now "
                f"({sum(r['reused'] for r in records.values())} valid earlier) on {engine}"
            )
        call = _Call(
            sweep=sweep,
            out=out,
            token=uuid.uuid4().hex,
            records=records,
            interrupts=interrupts,
            log=log,
            meta={
                "selected": [r.id for r in sweep.selected],
                "workers": n_workers,
                "engine": engine,
                "video": video,
                "plots": all(r.plots for r in sweep.selected),
                "overwrite": overwrite,
                "retries": retries,
                "process_per_run": True,
                "batch_size": 1 if video else batch_size,
                "batches": 0,
                "worker_thread_env": _thread_settings(),
            },
        )
        stopped = None
        if todo:
            call.progress = SweepProgress(total=len(todo), enabled=progress)
            try:
                stopped = _run_dask(
                    todo,
                    call,
                    workers=n_workers,
                    scheduler=scheduler,
                    cluster=cluster,
                    video=video,
                    overwrite=overwrite,
                    retries=retries,
                    grace_s=grace_s,
                    batch_size=batch_size,
                    batch_resources=batch_resources,
                )
            finally:
                call.progress.close()
        with interrupts.deferred():  # the summaries are written whole, whatever arrives now
            ordered = call.write(finished=True, interrupted=stopped is not None)
            if call.settled or engine.startswith("LocalCluster"):  # a closed LocalCluster took its runs down
                _clear_state(out)
            wall = time.perf_counter() - call.t0
    if log:
        counts = {s: sum(r["status"] == s for r in ordered) for s in sorted({r["status"] for r in ordered})}
        log(f"sweep {sweep.name}: {counts} in {wall:.1f} s wall -> {out}")
    if stopped is not None:
        stopped.records = ordered
        raise stopped
    return ordered
