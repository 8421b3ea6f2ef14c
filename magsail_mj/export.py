"""``magsail export RUN_DIR --format npz|netcdf [--out PATH]``: a run's record store in other formats.

A run folder keeps its records and derived series in ``timeseries.zarr``
(:mod:`magsail_mj.records`: the records in the root group, the derived series of
post-processing in the group ``series``). Export writes

* ``npz``: one NumPy ``.npz`` archive holding every root variable and every series (a series
  replaces a record of the same name, as :func:`read_timeseries` does), each
  array streamed chunk by chunk from the store into its archive member, so the memory used is one
  chunk whatever the run's length; read it with ``numpy.load(path, allow_pickle=False)``;
* ``netcdf``: one netCDF-4 file with the root group's variables, dimensions and attributes, and the
  series in the netCDF group ``series`` (written by :mod:`xarray` through dask, chunk by chunk).

Arrays are written bit for bit (float64 stays float64). Errors name the argument and exit with
status 2; the output is written to a temporary file and moved into place.
"""

from __future__ import annotations

import argparse
import os
import sys
import zipfile
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np
import xarray as xr

from magsail_mj.cli import EXPORT_FORMATS
from magsail_mj.cli import add_export_arguments as add_arguments
from magsail_mj.io import RUN_FILE_PATTERNS, atomic_path
from magsail_mj.integrity import IntegrityError, verify_run_folder
from magsail_mj.records import (
    SERIES_GROUP,
    STORE_NAME,
    RecordStoreError,
    StoreRecords,
    chunk_block_bytes,
    lazy_arrays,
    open_records,
)
from magsail_mj.resources import MemoryLimitError, check_memory, export_store_bytes

__all__ = ["add_arguments", "main", "export_run", "write_npz_streamed", "read_timeseries", "EXTENSIONS", "FORMATS"]

#: output formats and their file suffixes
FORMATS = EXPORT_FORMATS
#: file extensions that name a format (``--out`` with one of them decides the format, or must agree with ``--format``)
EXTENSIONS = {".npz": "npz", ".nc": "netcdf", ".nc4": "netcdf", ".netcdf": "netcdf"}


class ExportError(ValueError):
    """An export argument is unusable (the message names it)."""


def main(args: argparse.Namespace) -> int:
    """Run the ``export`` verb; 0 on success, 2 on an unusable argument (``error: …`` on stderr)."""
    try:
        out = export_run(args.run_dir, fmt=args.format, out=args.out)
    except (ExportError, RecordStoreError, MemoryLimitError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print(out)
    return 0


def export_run(run_dir: str | Path, *, fmt: str | None = None, out: str | Path | None = None) -> Path:
    """Write the store of ``run_dir`` as ``fmt`` (``npz`` or ``netcdf``) to ``out`` and return it.

    ``fmt`` None: the format that the extension of ``out`` names (``.npz``; ``.nc``, ``.nc4``,
    ``.netcdf``), else ``npz``. An extension of the other format is refused, and so is an ``out``
    that is one of the run folder's own files (its manifest, summary, model, record store, ...;
    only ``timeseries.npz`` / ``timeseries.nc``, the export's own names, may be replaced there) or
    lies in an unwritable folder. The folder is then checked against its ``manifest.json``
    (:func:`magsail_mj.integrity.verify_run_folder`). Every refusal is an :class:`ExportError`
    naming the argument.
    """
    if fmt is not None and fmt not in FORMATS:
        raise ExportError(f"--format: must be one of {', '.join(FORMATS)}, got {fmt!r}")
    if not str(run_dir).strip():
        raise ExportError("RUN_DIR: must name a run folder, got an empty path")
    folder = Path(run_dir)
    if not folder.is_dir():
        raise ExportError(f"RUN_DIR: {folder} is {'a file, not a folder' if folder.exists() else 'missing'}")
    if not (folder / STORE_NAME).is_dir():
        raise ExportError(f"RUN_DIR: {folder} holds no {STORE_NAME} (not a run folder, or a run of an older version)")
    if out is not None and (not str(out).strip() or Path(out).is_dir()):
        raise ExportError(f"--out: must name a file, got {str(out)!r}")
    fmt = _format(fmt, out)
    target = Path(out) if out is not None else folder / f"timeseries{FORMATS[fmt]}"
    _check_target(target, folder)
    try:  # nothing edited, missing or truncated since the run wrote its manifest
        verify_run_folder(folder)
    except IntegrityError as err:
        raise ExportError(f"RUN_DIR: {err}") from None
    # the store is streamed a chunk's rows at a time: refused when its chunks exceed the limit
    check_memory(export_store_bytes(chunk_block_bytes(lazy_arrays(folder))), what=f"export {folder}")
    try:
        if fmt == "npz":
            write_npz_streamed(target, lazy_arrays(folder))
        else:
            open_records(folder)  # an unreadable store is refused before anything is written
            _write_netcdf(folder / STORE_NAME, target, has_series=_series(folder) is not None)
    except OSError as err:  # the temporary file beside --out is ours: the error names the option
        raise ExportError(f"--out: cannot write {str(target)!r} ({err.strerror or err})") from None
    return target


def _format(fmt: str | None, out: str | Path | None) -> str:
    """The format: ``fmt``, else the one the extension of ``out`` names, else npz; ExportError when
    ``fmt`` and the extension disagree."""
    named = EXTENSIONS.get(Path(out).suffix.lower()) if out is not None else None
    if fmt is None:
        return named or "npz"
    if named is not None and named != fmt:
        raise ExportError(
            f"--out: {str(out)!r} has the extension of {named} files, not of --format {fmt} ({FORMATS[fmt]}); "
            f"name the file {Path(out).stem}{FORMATS[fmt]} or leave out --format"
        )
    return fmt


def _check_target(target: Path, folder: Path) -> None:
    """ExportError naming ``--out`` when ``target`` is a file of the run folder ``folder`` (other
    than the export's own names) or inside its record store, or its folder cannot be written."""
    where = target.absolute().resolve()
    run = folder.absolute().resolve()
    if run in where.parents:
        own = {f"timeseries{suffix}" for suffix in FORMATS.values()}
        inside = where.parent != run
        ours = where.name in own
        if inside or (not ours and (where.exists() or any(where.match(p) for p in RUN_FILE_PATTERNS))):
            raise ExportError(
                f"--out: {str(target)!r} is {'inside' if inside else 'a file of'} the run folder {str(folder)!r}; "
                "write the export elsewhere (or leave out --out for RUN_DIR/timeseries.npz|.nc)"
            )
    if not target.parent.is_dir():
        raise ExportError(f"--out: folder {target.parent} does not exist")
    if not os.access(target.parent, os.W_OK | os.X_OK):
        raise ExportError(f"--out: folder {str(target.parent)!r} is not writable (permission denied)")


def _series(folder: Path) -> StoreRecords | None:
    try:
        return open_records(folder, group=SERIES_GROUP)
    except (RecordStoreError, KeyError):
        return None


def _blocks(array: Any) -> Iterable[np.ndarray]:
    """The rows of a (lazy) array in blocks of its chunk length along the first axis."""
    if array.ndim == 0:
        yield np.asarray(array[...])
        return
    step = int(array.chunks[0]) if getattr(array, "chunks", None) else max(1, len(array))
    for a in range(0, array.shape[0], max(1, step)):
        yield np.asarray(array[a : a + step])


def write_npz_streamed(path: str | Path, arrays: Mapping[str, Any]) -> Path:
    """Write ``arrays`` (NumPy or Zarr arrays) to a compressed ``.npz`` atomically, each member
    streamed block by block along its first axis (memory: one block).

    Each member is a ``.npy`` (format 1.0 or 2.0 header, C order) inside a ZIP64 archive, exactly
    what :func:`numpy.savez_compressed` writes, so :func:`numpy.load` reads it."""
    with atomic_path(path, suffix=".npz") as tmp:
        with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED, allowZip64=True) as zf:
            for name, array in arrays.items():
                dtype = np.dtype(array.dtype)
                header = {
                    "descr": np.lib.format.dtype_to_descr(dtype),
                    "fortran_order": False,
                    "shape": tuple(int(s) for s in array.shape),
                }
                with zf.open(f"{name}.npy", "w", force_zip64=True) as fh:
                    np.lib.format.write_array_header_2_0(fh, header)
                    for block in _blocks(array):
                        fh.write(np.ascontiguousarray(block, dtype=dtype).tobytes())
    return Path(path)


def _write_netcdf(store: Path, target: Path, *, has_series: bool) -> None:
    """The root group and the ``series`` group as one netCDF-4 file (dask streams the chunks)."""
    with atomic_path(target, suffix=".nc") as tmp:
        with xr.open_zarr(store, consolidated=True) as ds:
            ds.to_netcdf(tmp, mode="w")
        if has_series:
            with xr.open_zarr(store, group=SERIES_GROUP, consolidated=True) as ds:
                ds.to_netcdf(tmp, mode="a", group=SERIES_GROUP)


def read_timeseries(run_dir: str | Path) -> dict[str, np.ndarray]:
    """Every record and series of a run folder as NumPy arrays (the series replacing records of
    the same name): the arrays of ``magsail export --format npz``, read from the store without a
    copy. Loads everything; a script that needs a few arrays of a long run reads them lazily
    (:func:`magsail_mj.records.lazy_arrays`)."""
    return {name: np.asarray(array[...]) for name, array in lazy_arrays(run_dir).items()}
