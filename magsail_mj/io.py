"""Atomic output writing and run manifests.

Every file of a run folder is written to a temporary file in the same folder and moved into
place with ``os.replace``, so a reader never sees a half-written file and a crash leaves the
previous version intact.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import math
import os
import platform
import shutil
import sys
import tempfile
from importlib import metadata
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np

__all__ = [
    "atomic_path",
    "write_json",
    "write_npz",
    "file_sha256",
    "print_report",
    "package_versions",
    "prepare_run_dir",
    "RunDirError",
    "OutputPathError",
    "RUN_FILE_PATTERNS",
    "check_output_folder",
    "remove_earlier_run",
    "run_dir_lock",
    "to_jsonable",
]

_VERSIONED = (
    "magsail_mj",
    "mujoco",
    "dm-control",
    "numpy",
    "scipy",
    "ppigrf",
    "mediapy",
    "imageio-ffmpeg",
    "matplotlib",
    "pydantic",
)


class RunDirError(RuntimeError):
    """The output folder cannot be used (it holds another run and overwriting was not asked)."""


class OutputPathError(RunDirError):
    """An output path names something that is not a regular file (a folder, a device, a pipe)."""


@contextlib.contextmanager
def run_dir_lock(folder: str | Path) -> Iterator[None]:
    """Hold an exclusive lock on a run folder (``flock`` on the folder itself: no file is made)
    while a run writes into it; another run into the same folder (a sweep worker, a second
    ``magsail run``) is refused with :class:`RunDirError`. The kernel drops the lock when the
    process ends, so none is ever stale."""
    fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise RunDirError(f"--out {folder}: another run is writing into this folder now") from None
        yield
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_path(path: str | Path, suffix: str = "") -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it replaces ``path`` atomically."""
    path = Path(path)
    if path.exists() and not path.is_file():  # a folder, a device, a pipe: never replaced by a file
        raise OutputPathError(f"{path}: exists and is not a regular file")
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix or path.suffix, dir=path.parent)
    except OSError as err:  # name the path asked for, not the temporary name beside it
        raise type(err)(err.errno, err.strerror, str(path)) from None
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the final file the usual mode
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        os.replace(tmp_path, path)
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


def to_jsonable(value: Any) -> Any:
    """Convert NumPy scalars/arrays and non-finite floats to JSON-safe values (NaN → null)."""
    if isinstance(value, dict):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, Path):
        return str(value)
    return value


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file's bytes (read in 1 MiB blocks), hex. Of a folder (a Zarr store): of its
    files in sorted order of their relative paths, each as ``path\0size\0bytes``."""
    h = hashlib.sha256()
    path = Path(path)
    if path.is_dir():
        for item in sorted(p for p in path.rglob("*") if p.is_file()):
            rel = item.relative_to(path).as_posix()
            h.update(f"{rel}\0{item.stat().st_size}\0".encode())
            _hash_bytes(h, item)
        return h.hexdigest()
    _hash_bytes(h, path)
    return h.hexdigest()


def _hash_bytes(h: Any, path: Path) -> None:
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)


def write_json(path: str | Path, obj: Any) -> Path:
    """Write ``obj`` as indented JSON, atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(to_jsonable(obj), indent=2, sort_keys=False) + "\n")
    return Path(path)


def print_report(text: str, out: str | Path | None = None) -> None:
    """Print a report (a benchmark table) and, when ``out`` is given, also write it there atomically."""
    print(text)
    if out is not None:
        with atomic_path(out) as tmp:
            Path(tmp).write_text(text + "\n")


def write_npz(path: str | Path, **arrays: np.ndarray) -> Path:
    """Write arrays to a compressed ``.npz``, atomically."""
    with atomic_path(path, suffix=".npz") as tmp:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)
    return Path(path)


def package_versions() -> dict[str, str]:
    """Versions of Python and the packages that determine a run's numbers."""
    out = {"python": sys.version.split()[0], "platform": platform.platform()}
    for name in _VERSIONED:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def prepare_run_dir(
    out_dir: str | Path, *, overwrite: bool = False, resume: bool = False, check: Callable[[Path], None] | None = None
) -> Path:
    """Create ``out_dir`` or check it may be reused; nothing is written before every check passed.

    A folder that already holds a ``manifest.json`` or a checkpoint belongs to an earlier run: it
    is reused only with ``overwrite=True`` (the caller then removes the earlier run's files with
    :func:`remove_earlier_run` once it holds the folder's :func:`run_dir_lock`) or
    ``resume=True``; otherwise :class:`RunDirError` names it, so nothing the user had is
    overwritten silently. A folder that holds anything else (files that no run writes: ``/``,
    ``/dev``, a project folder) is refused, and so is a system location or a folder inside another
    run folder or a record store (:func:`check_output_folder`). ``check(folder)`` runs after these
    checks and before anything is created (the resume check).
    """
    if str(out_dir).strip() == "":
        raise RunDirError("--out: must name a folder, got an empty path")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise RunDirError(f"--out {out}: exists and is not a folder")
    for parent in out.parents:
        if parent.exists():
            if not parent.is_dir():
                raise RunDirError(f"--out {out}: {parent} is a file, not a folder")
            break
    check_output_folder(out)
    earlier = _is_run_folder(out)
    foreign = _foreign_entries(out) if out.is_dir() and not earlier else []
    if foreign:
        raise RunDirError(
            f"--out {out}: is a folder with other files ({', '.join(foreign[:3])}"
            f"{', ...' if len(foreign) > 3 else ''}), not a run folder; give a new or empty folder"
        )
    if resume and overwrite:
        raise RunDirError("--resume and --overwrite: choose one")
    if earlier and not (overwrite or resume):
        raise RunDirError(
            f"--out {out}: holds an earlier run (manifest.json or checkpoint); pass --overwrite to replace it "
            "or --resume to continue it"
        )
    if resume and not out.is_dir():
        raise RunDirError(f"--resume: {out} does not exist")
    if check is not None:
        check(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".write-test-{os.getpid()}"
        probe.touch()
        probe.unlink()
    except OSError as err:
        raise RunDirError(f"--out {out}: cannot write there ({err.strerror or err})") from None
    return out


_SYSTEM_TREES = ("/dev", "/proc", "/sys", "/etc", "/boot", "/bin", "/sbin", "/usr", "/lib", "/lib32", "/lib64")
"""System trees (pseudo file systems, the installed system): no output is ever written below them."""
_SYSTEM_FOLDERS = ("/var", "/run", "/opt", "/srv", "/root", "/home", "/mnt", "/media", "/tmp", "/snap")
"""Top-level system folders: outputs go into folders below them, never into them directly."""


def _is_run_folder(folder: Path) -> bool:
    """True when ``folder`` holds a run: its ``manifest.json`` or a checkpoint."""
    return folder.is_dir() and ((folder / "manifest.json").exists() or any(folder.glob("checkpoint*.npz")))


def _is_record_store(folder: Path) -> bool:
    """True when ``folder`` is a Zarr store (a ``.zarr`` folder, or one with Zarr metadata)."""
    return folder.is_dir() and (
        folder.suffix == ".zarr" or any((folder / name).exists() for name in (".zgroup", ".zarray", "zarr.json"))
    )


def _foreign_entries(folder: Path) -> list[str]:
    """The entries of ``folder`` that no run writes (hidden temporaries and lock files aside), sorted."""
    try:
        names = sorted(entry.name for entry in os.scandir(folder))
    except OSError:
        return []
    return [n for n in names if not n.startswith(".") and not any(Path(n).match(p) for p in RUN_FILE_PATTERNS)]


def check_output_folder(out: str | Path, *, option: str = "--out") -> None:
    """RunDirError naming ``option`` when the folder ``out`` is no place for outputs: the root, a
    top-level system folder, anything below ``/dev``, ``/proc`` or ``/sys``, or a folder inside
    another run folder or a record store (``RUN/timeseries.zarr``, ``RUN/sub``)."""
    path = Path(out).absolute()
    try:
        resolved = path.resolve()
    except (OSError, RuntimeError):
        resolved = path
    for p in (path, resolved):
        text = p.as_posix()
        if (
            p == Path(p.anchor)
            or text in _SYSTEM_FOLDERS
            or any(text == t or text.startswith(t + "/") for t in _SYSTEM_TREES)
        ):
            raise RunDirError(f"{option} {out}: is a system location; give a folder of your own")
    for parent in [resolved, *resolved.parents]:
        if parent != resolved and _is_run_folder(parent):
            raise RunDirError(f"{option} {out}: is inside the run folder {parent}; give a folder outside it")
        if _is_record_store(parent):
            where = "is" if parent == resolved else "is inside"
            raise RunDirError(f"{option} {out}: {where} the record store {parent}; give a folder outside it")


RUN_FILE_PATTERNS = (
    "manifest.json",
    "params.json",
    "summary.json",
    "timeseries.npz",
    "timeseries.zarr",
    "timeseries.nc",
    "model.xml",
    "video.mp4",
    "*.png",
    "checkpoint*.npz",
    "checkpoint*.pkl",
    "checkpoint*.zarr",
)
"""The names of the files a run (or a sweep, ``params.json``) writes into its run folder."""
_RUN_FILE_PATTERNS = RUN_FILE_PATTERNS


def remove_earlier_run(out: Path) -> None:
    """Delete the files of the run in ``out`` (its manifest's list and the run file patterns; a
    record store, a folder, is removed whole)."""
    names: set[str] = set()
    try:
        listed = json.loads((out / "manifest.json").read_text()).get("files", {})
        names.update(n for n in listed if isinstance(n, str) and "/" not in n and not n.startswith("."))
    except (OSError, ValueError, AttributeError):
        pass
    for pattern in RUN_FILE_PATTERNS:
        names.update(p.name for p in out.glob(pattern))
    for name in sorted(names, key=lambda n: n == "manifest.json"):  # the manifest goes last
        path = out / name
        if path.is_file():
            path.unlink()
        elif path.is_dir() and name.endswith(".zarr"):
            shutil.rmtree(path)
