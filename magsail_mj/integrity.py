"""Verification of a run folder before it is read: nothing edited, missing or truncated.

A finished run's ``manifest.json`` lists the SHA-256 of every file it wrote (of the record store
``timeseries.zarr``: of its files' names and bytes) and ``records_digests``, the BLAKE2b digest of
every chunk of every stored variable taken as the chunk was written
(:meth:`magsail_mj.records.Recorder.digest_table`, :func:`magsail_mj.records.write_group`), and,
when the run checkpointed, the checkpoint's ``state_digest``
(:func:`magsail_mj.checkpoint.state_digest`). :func:`verify_run_folder` checks them all before
``render``, ``export`` or ``report`` read the folder; a resume checks the checkpoint's own digests
instead (the checkpoint's state digest, then every record chunk the checkpoint counts).

A failed check is an :class:`IntegrityError` (exit status 2) naming the piece: the file, or the
variable and the records of the chunk (a deleted Zarr chunk would otherwise read as zeros).
The digests are not signatures: they find damage and edits made without rewriting the manifest,
and with the restore's state slots (:mod:`magsail_mj.checkpoint`) a folder from elsewhere still
cannot run code; they do not prove who wrote a folder.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from magsail_mj.io import RunDirError, file_sha256
from magsail_mj.records import STORE_NAME, RecordStoreError, verify_digests

__all__ = ["IntegrityError", "MANIFEST_NAME", "read_manifest", "verify_run_folder"]

#: the manifest of a run folder (written last)
MANIFEST_NAME = "manifest.json"


class IntegrityError(RunDirError):
    """A piece of a run folder is missing, truncated, or differs from its digest."""


def read_manifest(run_dir: str | Path) -> dict[str, Any]:
    """The run's ``manifest.json`` as a mapping.

    Raises:
      IntegrityError: the folder has no manifest (not a run folder, or a run that has not finished:
        ``--resume`` it) or the manifest is not a JSON object.
    """
    path = Path(run_dir) / MANIFEST_NAME
    if not path.is_file():
        raise IntegrityError(
            f"{run_dir}: no {MANIFEST_NAME} (not a run folder, or a run that did not finish: continue it with --resume)"
        )
    try:
        manifest = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as err:
        raise IntegrityError(f"{path}: unreadable ({type(err).__name__}: {err})") from None
    if not isinstance(manifest, dict):
        raise IntegrityError(f"{path}: not a JSON object")
    return manifest


def verify_run_folder(run_dir: str | Path, *, records: bool = True) -> dict[str, Any]:
    """Check every file ``manifest.json`` lists against its SHA-256 (the record store too unless
    ``records`` is false) and return the manifest.

    A record store that differs is read back against ``records_digests`` to name the variable and
    the records of the first chunk that differs; when every chunk matches, its metadata or
    attributes were changed.

    Raises:
      IntegrityError: the manifest is missing or malformed, or a file it lists is missing or differs.
    """
    run_dir = Path(run_dir)
    manifest = read_manifest(run_dir)
    files = manifest.get("files")
    if not isinstance(files, dict) or not all(isinstance(v, str) for v in files.values()):
        raise IntegrityError(f"{run_dir / MANIFEST_NAME}: no valid 'files' table")
    for name, sha in sorted(files.items()):
        if not isinstance(name, str) or "/" in name or "\\" in name or name in ("", ".", ".."):
            raise IntegrityError(f"{run_dir / MANIFEST_NAME}: {name!r} is not a file name of the run folder")
        if name == STORE_NAME and not records:
            continue
        path = run_dir / name
        if not path.exists():
            raise IntegrityError(f"{path} is missing ({MANIFEST_NAME} lists it)")
        if file_sha256(path) == sha:
            continue
        if name == STORE_NAME and isinstance(manifest.get("records_digests"), dict):
            try:
                verify_digests(path, manifest["records_digests"])
            except RecordStoreError as err:
                raise IntegrityError(f"{err} (run folder {run_dir})") from None
            raise IntegrityError(f"{path}: its metadata or attributes differ from {MANIFEST_NAME} (edited)")
        raise IntegrityError(f"{path} differs from its SHA-256 in {MANIFEST_NAME} (edited or truncated)")
    return manifest
