"""Sweeps: many independent runs from one sweep file, in parallel worker processes.

A sweep file is a TOML document listing scenario configs::

    name = "sweep36"
    description = "current-loops §5: geometries A–D × EI × N"
    set = ["sim.record_every=20"]          # optional overrides applied to every run

    [[run]]
    id = "sweep/a_n12_ei1e3"                # run folder below the sweep's output folder
    config = "sweep/a_n12_ei1e3.toml"       # relative to the sweep file
    set = []                                # optional per-run overrides

Every config is loaded and validated before anything is written (a bad one names its run id,
key, value and what is allowed); run ids must name distinct, non-nested folders below the sweep
folder (``""``, ``"."``, ``"a/.."``, ``"a"`` beside ``"a/"`` are refused with the run index).

Each run goes to its own fresh ``spawn`` process (at most ``workers`` at a time) and writes the
folder ``OUT/<id>`` through :func:`magsail_mj.run.run_scenario`. A run that raises, diverges or
whose video fails is recorded with its status and message; the others go on.

Guarantees:

* **Reuse only of what is valid now.** A run folder is reused (not rerun) only when its
  ``manifest.json`` has a finished status (:data:`FINISHED`: completed, a studied failure such as
  structure_failed, or diverged), the
  ``config_hash`` of the config the sweep would run now (same overrides), every file it lists with
  the recorded sha256, and ``video.mp4`` when a video is asked. Anything else is rerun into that
  folder. ``overwrite`` reruns every selected run.
* **Summaries merge.** ``sweep_summary.json``/``.csv`` always list every run of the sweep file:
  runs outside ``only`` keep their record when their folder is still valid, else ``not_run``.
* **Interrupts stop promptly.** SIGINT or SIGTERM cancels the runs not started, stops the running
  workers (SIGTERM; SIGKILL after a grace time or at a second interrupt), writes the summaries (stopped runs
  ``interrupted``, unstarted ones ``not_run``) and raises :class:`SweepInterrupted`.
* **No orphans, no concurrent sweeps.** Workers die with the sweep process (``PR_SET_PDEATHSIG``
  on Linux, a parent-pid watch elsewhere); the sweep folder is locked (``fcntl.flock`` on
  ``.sweep.lock``, shared with the workers, released by the kernel when the last one dies), and a
  second sweep into a locked folder raises :class:`~magsail_mj.io.RunDirError`.

* **Failed means failed.** A run whose video (or anything else) failed has status ``failed`` and
  a message saying why; so has a run whose folder does not verify right after it ran. Only
  :data:`FINISHED` folders are ever reused. :func:`sweep_exit_code` gives 1 when a run of this
  call failed or was stopped, else 3 when one diverged, else 0.

The sweep folder receives ``sweep_summary.json`` (one record per run), ``sweep_summary.csv``
(the same as a table, each column once) and ``sweep_manifest.json`` (sweep file, its hash,
overrides, workers, worker thread settings, package versions, wall time), written atomically in
that order.
"""

from __future__ import annotations

import contextlib
import csv
import ctypes
import datetime as _dt
import hashlib
import io
import json
import multiprocessing
import multiprocessing.connection
import os
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from multiprocessing import reduction, resource_tracker
from pathlib import Path
from typing import Any, Self

from magsail_mj.config import ConfigError, apply_overrides, config_hash, load_config, read_toml
from magsail_mj.io import (
    RunDirError,
    atomic_path,
    package_versions,
    to_jsonable,
    write_json,
)
from magsail_mj.sweep.design import design_points

try:
    import fcntl
except ImportError:  # pragma: no cover - not on Linux/macOS
    fcntl = None  # type: ignore[assignment]

__all__ = [
    "FINISHED",
    "Sweep",
    "SweepInterrupted",
    "SweepRun",
    "is_sweep_file",
    "load_sweep",
    "run_sweep",
    "sweep_exit_code",
]

FINISHED = ("completed", "structure_failed", "tracking_lost", "failed_condition", "diverged")
"""Run statuses whose folder is a final result (reused by a later sweep when still valid): completed,
the studied failures (:class:`magsail_mj.divergence.StudiedFailure` statuses) and diverged."""

_SUCCESS = ("completed", "structure_failed", "tracking_lost", "failed_condition")

LOCK_NAME = ".sweep.lock"
_OUTPUTS = ("sweep_summary.json", "sweep_summary.csv", "sweep_manifest.json")
_RESERVED = (*_OUTPUTS, LOCK_NAME)
_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
_SWEEP_COLUMNS = ("id", "status", "reused", "wall_time_s", "message")
_EXTRA_COLUMNS = ("attempts", "resumed_from_s", "config_hash")
_SUMMARY_DUPLICATES = ("status_message",)  # the run's own message: the sweep's "message" column says it
_PR_SET_PDEATHSIG = 1
_SIGNALS = (signal.SIGINT, signal.SIGTERM)
_SWEEP_KEYS = ("name", "description", "set", "config", "run", "grid", "monte_carlo")


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
class SweepRun:
    """One entry of a sweep: its id (run folder, normalised), config path and overrides.

    ``config_hash`` is the hash of the config as it would run now (empty when it does not load);
    ``selected`` is False for runs outside ``only``; ``problem`` says why an unselected config
    does not load; ``params`` holds the values this run varies (grid or Monte Carlo values, or
    the keys of its own ``set``).
    """

    id: str
    config: Path
    overrides: tuple[str, ...] = ()
    config_hash: str = ""
    selected: bool = True
    problem: str = ""
    params: dict[str, Any] = field(default_factory=dict, hash=False)


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
    return "/".join(parts)


def _check_ids(entries: list[Any]) -> tuple[dict[int, str], list[str]]:
    """Normalised id per entry index, and the problems (bad, duplicate or nested ids)."""
    ids: dict[int, str] = {}
    problems: list[str] = []
    for n, entry in enumerate(entries):
        if not isinstance(entry, dict) or set(entry) - {"id", "config", "set"} or "id" not in entry \
                or "config" not in entry:
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
            problems.append(f"run[{n}].id: {entries[n]['id']!r} names the same folder {rid!r} as "
                            f"run[{other}].id {entries[other]['id']!r}")
    for n, rid in ids.items():
        parts = rid.split("/")
        for k in range(1, len(parts)):
            outer = first.get("/".join(parts[:k]).casefold())
            if outer is not None:
                problems.append(f"run[{n}].id: {entries[n]['id']!r} lies inside the folder of "
                                f"run[{outer}].id {entries[outer]['id']!r}")
    return ids, problems


def _check_header(tree: dict[str, Any], path: Path) -> tuple[str, str]:
    """The sweep's name and description; ConfigError for unknown keys or a name unfit as a folder."""
    unknown = sorted(set(tree) - set(_SWEEP_KEYS))
    if unknown:
        raise ConfigError([f"{k}: unknown sweep key (allowed: {', '.join(_SWEEP_KEYS)})" for k in unknown],
                          source=str(path))
    name = tree.get("name", path.stem)
    if not isinstance(name, str) or not name.strip() or name in (".", "..") or "/" in name or "\\" in name \
            or any(ord(c) < 32 for c in name):
        problem = f"name: must be a plain folder name (the default output folder runs/<name>), got {name!r}"
        raise ConfigError([problem], source=str(path))
    description = tree.get("description", "")
    if not isinstance(description, str):
        raise ConfigError([f"description: must be a string, got {description!r}"], source=str(path))
    return name, description


def _only_terms(only: str | list[str] | tuple[str, ...] | None) -> tuple[str, ...] | None:
    if only is None:
        return None
    terms = (only,) if isinstance(only, str) else tuple(only)
    if not terms or not all(isinstance(t, str) for t in terms):
        raise ConfigError([f"only: must be a string or a non-empty list of strings, got {only!r}"])
    return terms


def _load_run(rid: str, config: Path, overrides: tuple[str, ...], selected: bool,
              params: dict[str, Any]) -> tuple[SweepRun, list[str]]:
    """The run with the hash of its config now; the config's problems (fatal only when selected)."""
    try:
        digest, problems = config_hash(load_config(config, list(overrides))), []
    except ConfigError as err:
        digest, problems = "", [f"{rid}: {p}" for p in err.problems]
    except OSError as err:
        digest, problems = "", [f"{rid}: config {config}: {err}"]
    run = SweepRun(id=rid, config=config, overrides=overrides, config_hash=digest, selected=selected,
                   problem="; ".join(problems), params=params)
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
        raise ConfigError([f"run: must be a non-empty array of [[run]] tables (or give [grid] / [monte_carlo]), "
                           f"got {tree.get('run')!r}"], source=str(path))
    if not designed:
        if "config" in tree:
            raise ConfigError(["config: the base config is used by [grid] / [monte_carlo] only; add one of them "
                               "or give each [[run]] its config"], source=str(path))
        return list(entries)
    base = tree.get("config")
    if not isinstance(base, str) or not base:
        raise ConfigError([f"config: [grid] / [monte_carlo] need the base config path, got {base!r}"],
                          source=str(path))
    try:
        points = design_points(tree)
    except ConfigError as err:
        raise ConfigError(err.problems, source=str(path)) from None
    return [*entries, *({"id": p.id, "config": base, "set": list(p.overrides), "params": p.params} for p in points)]


def load_sweep(path: str | Path, *, extra_overrides: tuple[str, ...] = (),
               only: str | list[str] | tuple[str, ...] | None = None) -> Sweep:
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
    ids, problems = _check_ids([{k: v for k, v in e.items() if k != "params"} if isinstance(e, dict) else e
                                for e in entries])
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
        runs.append(run)
        problems.extend(errors)
    if problems:
        raise ConfigError(problems, source=str(path))
    if not any(r.selected for r in runs):
        raise ConfigError([f"only: no run id contains any of {list(wanted or [])!r}"], source=str(path))
    return Sweep(name=name, path=path, runs=tuple(runs), description=description, overrides=common + extra,
                 only=wanted)


# ---------------------------------------------------------------------------------------------
# Which run folders are still valid


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _check_files(run_dir: Path, files: Any, *, video: bool) -> str:
    """Why the files listed in a manifest do not match the folder ("" when they all do)."""
    if not isinstance(files, dict) or "summary.json" not in files:
        return "manifest.json lists no files (summary.json missing from its file list)"
    if video and "video.mp4" not in files:
        return "no video.mp4 in the run (a video is asked)"
    for name, digest in files.items():
        rel = Path(str(name))
        if rel.is_absolute() or ".." in rel.parts:
            return f"manifest.json lists a file outside the run folder: {name!r}"
        try:
            actual = _sha256(run_dir / rel)
        except OSError:
            return f"{name} is missing"
        if actual != digest:
            return f"{name} changed since the run (sha256 differs from manifest.json)"
    return ""


def _folder_check(run_dir: Path, *, config_hash: str, video: bool) -> tuple[dict[str, Any] | None, str]:
    """``(manifest, "")`` when ``run_dir`` holds a finished, intact run of this config; else ``(None, why)``."""
    try:
        manifest = json.loads((run_dir / "manifest.json").read_text())
    except FileNotFoundError:
        return None, "no finished run in its folder (no manifest.json)"
    except (OSError, ValueError) as err:
        return None, f"manifest.json unreadable ({type(err).__name__})"
    if not isinstance(manifest, dict):
        return None, "manifest.json is not an object"
    if not config_hash:
        return None, "its config does not load now"
    if manifest.get("config_hash") != config_hash:
        return None, "its config changed since (config_hash differs: other file contents or --set)"
    if manifest.get("status") not in FINISHED:
        return None, f"its status {manifest.get('status')!r} is not a finished one {FINISHED}"
    why = _check_files(run_dir, manifest.get("files"), video=video)
    return (None, why) if why else (manifest, "")


def _record(run: SweepRun, *, status: str, message: str, wall_time_s: float | None = None,
            reused: bool = False, summary: dict[str, Any] | None = None, attempts: int = 0,
            resumed_from_s: float | None = None) -> dict[str, Any]:
    """A sweep summary record (one per run of the sweep file)."""
    return {"id": run.id, "status": status, "message": message, "config_hash": run.config_hash,
            "params": dict(run.params), "wall_time_s": wall_time_s, "attempts": attempts,
            "resumed_from_s": resumed_from_s, "reused": reused, "selected": run.selected, "config": str(run.config),
            "summary": summary or {}}


def _reused_record(run: SweepRun, run_dir: Path, manifest: dict[str, Any]) -> dict[str, Any] | None:
    """The record of a valid earlier run (None when its summary does not parse)."""
    try:
        summary = json.loads((run_dir / "summary.json").read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(summary, dict):
        return None
    return _record(run, status=str(manifest["status"]), message=str(manifest.get("status_message") or ""),
                   wall_time_s=manifest.get("wall_time_s"), reused=True, summary=summary)


def _plan(sweep: Sweep, out: Path, *, video: bool, overwrite: bool,
          log: Callable[[str], None] | None) -> tuple[dict[str, dict[str, Any]], list[SweepRun]]:
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
            records[run.id] = _record(run, status="not_run",
                                      message=f"not selected in this call; {run.problem or why}")
    return records, todo


# ---------------------------------------------------------------------------------------------
# Worker process


def _run_one(run: SweepRun, out_dir: str | Path, *, video: bool) -> dict[str, Any]:
    """One run into ``out_dir/<id>`` (replacing what is there); never raises an ``Exception``.

    The record says ``failed`` with the reason when the run raises (the video included) or when
    its folder does not verify afterwards; a KeyboardInterrupt propagates.
    """
    t0 = time.perf_counter()
    run_dir = Path(out_dir) / run.id
    record = _record(run, status="failed", message="", attempts=1)
    try:
        # the simulation stack is imported in the worker only (an import failure is this run's failure)
        from magsail_mj.run import run_scenario

        cfg = load_config(run.config, list(run.overrides))
        record["config_hash"] = config_hash(cfg)
        # overwrite: the earlier run's files go first (its manifest last), so a stopped rerun never looks finished
        outcome = run_scenario(cfg, run_dir, video=video, overwrite=True, progress=False)
        record.update(status=str(outcome.status), message=str(outcome.get("status_message") or ""),
                      summary=to_jsonable(dict(outcome)))
        if outcome.status in FINISHED:
            _, why = _folder_check(run_dir, config_hash=record["config_hash"], video=video)
            if why:
                record.update(status="failed", message=f"run folder does not verify after the run: {why}")
    except Exception as err:  # noqa: BLE001 - one failing run must not lose the others
        record.update(status="failed", message=f"{type(err).__name__}: {err}",
                      traceback=traceback.format_exc(limit=-8))
    record["wall_time_s"] = time.perf_counter() - t0
    return record


def _adopt_fd(dup: Any) -> int:
    """Unpickle side of :class:`_SharedFd`: the inherited descriptor number."""
    return dup.detach()


class _SharedFd:
    """A descriptor handed to a spawned worker (same open file, so the worker shares its flock)."""

    def __init__(self, fd: int):
        self.fd = fd

    def __reduce__(self):
        return (_adopt_fd, (reduction.DupFd(self.fd),))


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
    """Worker thread: once the parent is gone, stop this worker (SIGTERM), then exit hard."""
    while os.getppid() == parent_pid:
        time.sleep(period_s)
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(grace_s)
    os._exit(1)


_STOP = threading.Event()
"""Set in a worker once it was asked to stop (SIGTERM from the sweep, or its parent died)."""


def _on_sigterm(signum: int, frame: Any) -> None:
    """Worker SIGTERM handler: stop the run (once) as a Ctrl-C would."""
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    _STOP.set()
    raise KeyboardInterrupt(f"worker stopped by {signal.Signals(signum).name}")


def _guard_worker(parent_pid: int) -> None:
    """Worker set-up: the sweep process handles Ctrl-C; SIGTERM or the parent's death stops the run."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the terminal's Ctrl-C: the parent decides
    signal.signal(signal.SIGTERM, _on_sigterm)
    _set_parent_death_signal(signal.SIGTERM)
    threading.Thread(target=_watch_parent, args=(parent_pid,), name="parent-watch", daemon=True).start()
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _SIGNALS)  # should a start method pass on the parent's mask


def _stopped_record(run: SweepRun, err: BaseException, *, wall_time_s: float) -> dict[str, Any]:
    """The record of a run that raised past :func:`_run_one` (an interrupt, or an exit)."""
    if isinstance(err, KeyboardInterrupt):
        outcome = getattr(err, "outcome", None)  # RunInterrupted: the outputs up to then are written
        return _record(run, status="interrupted", message=f"stopped while running ({err})", wall_time_s=wall_time_s,
                       summary=to_jsonable(dict(outcome)) if isinstance(outcome, dict) else None)
    return _record(run, status="failed", message=f"{type(err).__name__}: {err}", wall_time_s=wall_time_s)


def _worker_main(run: SweepRun, out_dir: str, video: bool, conn: Any, lock_fd: int, parent_pid: int) -> None:
    """Process target: run one entry and send its record to the parent (keeps ``lock_fd`` open)."""
    t0 = time.perf_counter()
    try:
        _guard_worker(parent_pid)
        record = _run_one(run, out_dir, video=video)
    except BaseException as err:  # noqa: BLE001 - a worker reports what stopped it, never a traceback
        record = _stopped_record(run, err, wall_time_s=time.perf_counter() - t0)
    if _STOP.is_set() and record["status"] not in (*FINISHED, "interrupted"):  # e.g. an interrupt turned error
        record.update(status="interrupted", message=f"stopped while running ({record['message']})")
    try:
        conn.send(record)
    except (OSError, KeyboardInterrupt):  # the parent is gone or stopping us: nothing to report to
        pass


# ---------------------------------------------------------------------------------------------
# Parent side: lock, signals, scheduling


@contextlib.contextmanager
def _sweep_lock(out: Path) -> Iterator[int]:
    """Hold ``out/.sweep.lock`` exclusively; RunDirError when another sweep (or its workers) holds it."""
    path = out / LOCK_NAME
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 100, 0).decode(errors="replace").strip() or "?"
                raise RunDirError(f"--out {out}: another sweep is running in this folder (lock {path} held by "
                                  f"pid {holder} or its worker processes); wait for it or choose another --out")
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
    def deferred(self, *, block: bool = False) -> Iterator[None]:
        """Remember signals during the block instead of raising (nestable).

        ``block`` also holds them back in the kernel (pending, delivered after the block), for
        a block that changes their dispositions (:func:`_sigint_ignored_by_child`).
        """
        self._depth += 1
        if block:
            signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
        try:
            yield
        finally:
            if block:
                signal.pthread_sigmask(signal.SIG_UNBLOCK, _SIGNALS)  # runs the handler of a held-back signal
            self._depth -= 1


@dataclass
class _Job:
    run: SweepRun
    process: Any
    conn: Any
    t0: float
    record: dict[str, Any] | None = None


class _Workers:
    """At most ``workers`` runs at a time, each in a fresh spawn process; ended runs go to ``records``."""

    def __init__(self, *, workers: int, out: Path, video: bool, lock_fd: int, interrupts: _Interrupts,
                 records: dict[str, dict[str, Any]], log: Callable[[str], None] | None):
        self.workers, self.out, self.video = workers, out, video
        self.lock_fd, self.interrupts = lock_fd, interrupts
        self.records, self.log = records, log
        self.ctx = multiprocessing.get_context("spawn")
        self.active: list[_Job] = []
        self.stopping = False

    def start(self, run: SweepRun) -> None:
        """Start ``run`` in a new worker (signals held back until it is registered)."""
        if threading.current_thread() is threading.main_thread():
            resource_tracker.ensure_running()  # its first start unblocks SIGINT/SIGTERM: not in the block below
        with self.interrupts.deferred(block=True):
            reader, writer = self.ctx.Pipe(duplex=False)
            proc = self.ctx.Process(target=_worker_main, name=f"sweep:{run.id}", daemon=False,
                                    args=(run, str(self.out), self.video, writer, _SharedFd(self.lock_fd),
                                          os.getpid()))
            with _worker_env(), _sigint_ignored_by_child():
                proc.start()
            writer.close()
            self.active.append(_Job(run=run, process=proc, conn=reader, t0=time.perf_counter()))

    def collect(self, timeout: float | None = None) -> None:
        """Block until a worker reports or ends (or ``timeout``); record the runs that ended."""
        handles = [j.process.sentinel for j in self.active] + [j.conn for j in self.active if j.record is None]
        if handles:
            multiprocessing.connection.wait(handles, timeout)
        with self.interrupts.deferred():  # a record is never half stored
            for job in list(self.active):
                self._receive(job)
                if not job.process.is_alive():
                    self._finish(job)

    @staticmethod
    def _receive(job: _Job) -> None:
        try:
            if job.record is None and job.conn.poll():
                job.record = job.conn.recv()
        except Exception:  # noqa: BLE001 - a cut or garbled message: the run ended without a result
            job.record = None

    def _finish(self, job: _Job) -> None:
        job.process.join()
        self._receive(job)
        job.conn.close()
        self.active.remove(job)
        rec = job.record
        if rec is None:
            code = job.process.exitcode
            how = f"signal {signal.Signals(-code).name}" if code and code < 0 else f"exit code {code}"
            rec = _record(job.run, status="failed", message=f"worker process ended without a result ({how})",
                          wall_time_s=time.perf_counter() - job.t0)
        if self.stopping and rec["status"] not in FINISHED:
            rec = {**rec, "status": "interrupted", "message": rec["message"] or "stopped while running"}
        self.records[rec["id"]] = rec
        _log_record(self.log, rec)

    def stop(self, *, grace_s: float) -> None:
        """Stop every running worker: SIGTERM, then SIGKILL after ``grace_s`` or at a further
        SIGINT/SIGTERM; record them (``interrupted`` unless they had just finished)."""
        self.stopping = True
        with self.interrupts.deferred():
            for job in self.active:
                if job.process.is_alive():
                    job.process.terminate()
            deadline = time.monotonic() + grace_s
            seen = self.interrupts.received
            while self.active and time.monotonic() < deadline and self.interrupts.received == seen:
                self.collect(timeout=min(0.2, max(0.0, deadline - time.monotonic())))
            for job in list(self.active):
                job.process.kill()
                self._finish(job)


@contextlib.contextmanager
def _sigint_ignored_by_child() -> Iterator[None]:
    """Start a child that ignores SIGINT from its first instruction (a terminal's Ctrl-C reaches
    the whole process group; only the sweep process handles it, never a worker still importing).

    The caller holds SIGINT blocked meanwhile (:meth:`_Interrupts.deferred`), so a Ctrl-C in this
    window stays pending for the sweep process instead of being lost.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    resource_tracker.ensure_running()  # its start unblocks SIGINT: do it before ignoring
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)  # an ignored signal stays ignored across exec
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.SIG_DFL if previous is None else previous)


@contextlib.contextmanager
def _worker_env() -> Iterator[None]:
    """One BLAS thread per worker unless the user set one (environment seen by a spawned worker)."""
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
        log(f"  {rec['id']}: {rec['status']}{took}{extra}")


def _execute(todo: list[SweepRun], pool: _Workers) -> None:
    """Run ``todo`` on ``pool`` (its records fill as runs end)."""
    queue = list(todo)
    while queue or pool.active:
        while queue and len(pool.active) < pool.workers:
            pool.start(queue.pop(0))
            pool.interrupts.raise_pending()
        pool.collect()
        pool.interrupts.raise_pending()


def _interrupted(todo: list[SweepRun], pool: _Workers, *, grace_s: float) -> None:
    """After SIGINT/SIGTERM: stop the workers, mark the stopped runs and those never started."""
    if pool.log:
        pool.log(f"sweep interrupted: stopping {len(pool.active)} running runs (interrupt again to kill them now)")
    pool.stop(grace_s=grace_s)
    for run in todo:
        pool.records.setdefault(run.id, _record(run, status="not_run",
                                                message="not started: the sweep was interrupted"))


def _run_pool(todo: list[SweepRun], pool: _Workers, *, grace_s: float) -> SweepInterrupted | None:
    """Run ``todo``; on SIGINT/SIGTERM stop and return the interrupt (other errors: stop, re-raise)."""
    try:
        _execute(todo, pool)
    except KeyboardInterrupt as err:
        stopped = err if isinstance(err, SweepInterrupted) else SweepInterrupted(signal.SIGINT)
    except BaseException:
        pool.stop(grace_s=grace_s)  # no worker outlives a sweep that fails itself
        raise
    else:
        return None
    with pool.interrupts.deferred():
        _interrupted(todo, pool, grace_s=grace_s)
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
        writer.writerow([rec["id"], rec["status"], rec["reused"],
                         f"{wall:.1f}" if isinstance(wall, (int, float)) else "", rec["message"],
                         *[_cell(rec.get(c)) for c in _EXTRA_COLUMNS],
                         *[_cell(p.get(k)) for k in params], *[_cell(s.get(c)) for c in cols]])
    return buf.getvalue()


def _write_outputs(out: Path, sweep: Sweep, ordered: list[dict[str, Any]], meta: dict[str, Any]) -> None:
    """Summaries, then the manifest (last), each atomically."""
    write_json(out / "sweep_summary.json", ordered)
    with atomic_path(out / "sweep_summary.csv") as tmp:
        tmp.write_text(_table(ordered))
    write_json(out / "sweep_manifest.json", {
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "sweep": str(sweep.path), "sweep_hash": hashlib.sha256(sweep.path.read_bytes()).hexdigest(),
        "name": sweep.name, "description": sweep.description, "overrides": list(sweep.overrides),
        "only": None if sweep.only is None else list(sweep.only), **meta,
        "runs": {r["id"]: r["status"] for r in ordered}, "versions": package_versions(),
    })


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


def run_sweep(
    sweep: Sweep,
    out_dir: str | Path,
    *,
    workers: int = 1,
    video: bool = False,
    overwrite: bool = False,
    log: Callable[[str], None] | None = print,
    grace_s: float = 10.0,
) -> list[dict[str, Any]]:
    """Run the selected entries of ``sweep`` into ``out_dir/<id>`` with up to ``workers`` processes.

    Returns one record per run of the sweep file, in file order (``id``, ``status`` ∈ completed,
    structure_failed, diverged, stopped, failed, interrupted, not_run; ``message``, ``reused``,
    ``selected``, ``config_hash``, ``wall_time_s``, ``summary``), also written to
    ``sweep_summary.json``/``.csv``.

    ``grace_s`` is how long stopped workers may take to write their outputs after an interrupt
    before they are killed (a second interrupt kills them at once).

    Raises:
      ValueError: ``workers`` is not an integer >= 1.
      RunDirError: ``out_dir`` is not a folder, or another sweep runs in it.
      SweepInterrupted: on SIGINT/SIGTERM, after writing the summaries (``.records``).
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers: must be an integer >= 1, got {workers!r}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise RunDirError(f"--out {out}: exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    with _sweep_lock(out) as lock_fd, _Interrupts() as interrupts:
        _remove_stale_temporaries(out)
        records, todo = _plan(sweep, out, video=video, overwrite=overwrite, log=log)
        if log:
            log(f"sweep {sweep.name}: {len(todo)} runs to do, {len(records)} not run now "
                f"({sum(r['reused'] for r in records.values())} valid earlier), {workers} workers")
        pool = _Workers(workers=workers, out=out, video=video, lock_fd=lock_fd, interrupts=interrupts,
                        records=records, log=log)
        stopped = _run_pool(todo, pool, grace_s=grace_s)
        with interrupts.deferred():  # the summaries are written whole, whatever arrives now
            ordered = [records[r.id] for r in sweep.runs]
            wall = time.perf_counter() - t0
            _write_outputs(out, sweep, ordered, {
                "selected": [r.id for r in sweep.selected], "workers": workers, "video": video,
                "overwrite": overwrite, "start_method": "spawn", "process_per_run": True,
                "worker_thread_env": _thread_settings(), "interrupted": stopped is not None, "wall_time_s": wall,
            })
    if log:
        counts = {s: sum(r["status"] == s for r in ordered) for s in sorted({r["status"] for r in ordered})}
        log(f"sweep {sweep.name}: {counts} in {wall:.1f} s wall -> {out}")
    if stopped is not None:
        stopped.records = ordered
        raise stopped
    return ordered
