"""What the sweep client and its run processes share: run entries, records, folder checks, locks."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from magsail_mj.io import RunDirError, file_sha256

try:
    import fcntl
except ImportError:  # pragma: no cover - not on Linux/macOS
    fcntl = None  # type: ignore[assignment]

FINISHED = ("completed", "structure_failed", "tracking_lost", "failed_condition", "diverged")
"""Run statuses whose folder is a final result (reused by a later sweep when still valid): completed,
the studied failures (:class:`magsail_mj.divergence.StudiedFailure` statuses) and diverged."""

_SUCCESS = ("completed", "structure_failed", "tracking_lost", "failed_condition")

LOCK_NAME = ".sweep.lock"
STATE_DIR = ".sweep.state"
"""Folder of the sweep's shared state: ``runs.lock`` (one byte-range lock per running run, held by
its run process) and, per sweep call, the attempt counters and the stop request."""
RUNS_LOCK = "runs.lock"


@dataclass(frozen=True)
class SweepRun:
    """One entry of a sweep: its id (run folder, normalised), config path and overrides.

    ``config_hash`` is the hash of the config as it would run now (empty when it does not load);
    ``selected`` is False for runs outside ``only``; ``problem`` says why an unselected config
    does not load; ``params`` holds the values this run varies (grid or Monte Carlo values, or
    the keys of its own ``set``); ``concept`` is its config's concept (empty when it does not load);
    ``plots`` says whether its folder gets the scenario's PNG plots (the sweep file's ``plots``).
    """

    id: str
    config: Path
    overrides: tuple[str, ...] = ()
    config_hash: str = ""
    selected: bool = True
    problem: str = ""
    params: dict[str, Any] = field(default_factory=dict, hash=False)
    concept: str = ""
    plots: bool = True


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
            actual = file_sha256(run_dir / rel)
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


def _record(
    run: SweepRun,
    *,
    status: str,
    message: str,
    wall_time_s: float | None = None,
    reused: bool = False,
    summary: dict[str, Any] | None = None,
    attempts: int = 0,
    resumed_from_s: float | None = None,
) -> dict[str, Any]:
    """A sweep summary record (one per run of the sweep file)."""
    return {
        "id": run.id,
        "status": status,
        "message": message,
        "config_hash": run.config_hash,
        "params": dict(run.params),
        "wall_time_s": wall_time_s,
        "attempts": attempts,
        "resumed_from_s": resumed_from_s,
        "reused": reused,
        "selected": run.selected,
        "config": str(run.config),
        "summary": summary or {},
    }


def _run_offset(run_id: str) -> int:
    """The byte of ``runs.lock`` whose lock stands for the run ``run_id``."""
    return int.from_bytes(hashlib.sha256(run_id.encode()).digest()[:6], "little")


@contextlib.contextmanager
def run_lock(out: Path, run_id: str, *, wait_s: float) -> Iterator[None]:
    """Hold the lock of one run (a POSIX byte-range lock on ``STATE_DIR/runs.lock``, released by
    the kernel when the process dies); waits up to ``wait_s`` for an earlier process of this run.

    Raises:
      RunDirError: another process still runs ``run_id`` after ``wait_s``.
    """
    state = out / STATE_DIR
    state.mkdir(exist_ok=True)
    fd = os.open(state / RUNS_LOCK, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        deadline = time.monotonic() + wait_s
        while fcntl is not None:
            try:
                fcntl.lockf(fd, fcntl.LOCK_EX | fcntl.LOCK_NB, 1, _run_offset(run_id))
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise RunDirError(
                        f"run {run_id!r}: still running in another process after {wait_s:g} s "
                        f"(lock {state / RUNS_LOCK})"
                    ) from None
                time.sleep(0.1)
        yield
    finally:
        os.close(fd)


def runs_running(out: Path) -> bool:
    """True while a run process (of this sweep or an earlier, killed one) holds a run lock in ``out``."""
    path = out / STATE_DIR / RUNS_LOCK
    if fcntl is None or not path.exists():
        return False
    fd = os.open(path, os.O_RDWR)
    try:
        fcntl.lockf(fd, fcntl.LOCK_EX | fcntl.LOCK_NB, 0, 0)
    except OSError:
        return True
    else:
        fcntl.lockf(fd, fcntl.LOCK_UN, 0, 0)
        return False
    finally:
        os.close(fd)
