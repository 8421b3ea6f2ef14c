"""Companion data files of a structure file: named arrays in ``.npz`` and numeric columns in ``.csv``.

A companion file is data only. Its path is relative to the structure file's folder and must stay
inside that folder (no absolute path, no ``..`` step, no link leading out); ``.npz`` arrays are
read with ``allow_pickle=False`` and an object array is refused by its header before any byte of
it is read; every array's size is checked against :data:`MAX_ELEMENTS` from its header (``.npz``)
or its line count (``.csv``) before it is allocated. Each file is read once, as bytes, and the
SHA-256 of exactly those bytes is recorded (:attr:`CompanionFiles.sha256`) so that a run manifest
can store what was read.
"""

from __future__ import annotations

import hashlib
import io
import os
import zipfile
from pathlib import Path, PurePosixPath

import numpy as np

from magsail_mj.structure.model import StructureError

__all__ = ["COMPANION_SUFFIXES", "MAX_COMPANION_BYTES", "MAX_ELEMENTS", "CompanionFiles", "CsvTable"]

#: File kinds a companion reference may name.
COMPANION_SUFFIXES = (".npz", ".csv")
#: Largest companion file read [bytes].
MAX_COMPANION_BYTES = 4 * 1024**3
#: Largest number of numbers one companion array may hold (10 million rows of 9 columns).
MAX_ELEMENTS = 90_000_000


class CsvTable:
    """A ``.csv`` companion: a header of column names and a (rows, columns) float array."""

    def __init__(self, names: tuple[str, ...], values: np.ndarray):
        self.names = names
        self.values = values

    def columns(self, wanted: list[str] | None, where: str) -> np.ndarray:
        """The columns ``wanted`` (all when ``None``) as a (rows, k) array, or (rows,) for one
        name given as a list of one."""
        if wanted is None:
            return self.values
        missing = [name for name in wanted if name not in self.names]
        if missing:
            raise StructureError(f"{where}: no column {missing[0]!r} (the header has {', '.join(self.names)})")
        return self.values[:, [self.names.index(name) for name in wanted]]


class CompanionFiles:
    """The companion files of one structure, read on demand below ``base_dir``.

    Attributes:
      base_dir: the folder of the structure file (or of the config holding ``[structure]``).
      sha256: relative path (POSIX spelling, as written in the file) -> SHA-256 hex digest of the
        bytes read.
    """

    def __init__(self, base_dir: str | Path):
        self.base_dir = Path(base_dir)
        self.sha256: dict[str, str] = {}
        self._opened: dict[str, np.lib.npyio.NpzFile | CsvTable] = {}

    def resolve(self, name: object, where: str) -> tuple[str, Path]:
        """The normalised relative name and the path of companion ``name``; :class:`StructureError`
        for a name that is not a relative path to an ``.npz`` or ``.csv`` file inside ``base_dir``."""
        if not isinstance(name, str) or not name.strip():
            raise StructureError(f"{where}: a companion file is a relative path string, got {name!r}")
        pure = PurePosixPath(name.replace("\\", "/"))
        if pure.is_absolute() or name.startswith(("/", "\\")) or (len(name) > 1 and name[1] == ":"):
            raise StructureError(f"{where}: {name!r} is an absolute path; companion files are relative to the folder")
        if ".." in pure.parts:
            raise StructureError(f"{where}: {name!r} leaves the structure file's folder ('..' is refused)")
        if pure.suffix.lower() not in COMPANION_SUFFIXES:
            raise StructureError(f"{where}: {name!r} is neither an .npz nor a .csv file")
        root = self.base_dir.resolve()
        path = (root / pure).resolve()
        if not path.is_relative_to(root):
            raise StructureError(f"{where}: {name!r} leads out of the structure file's folder (through a link)")
        return pure.as_posix(), path

    def _read_bytes(self, key: str, path: Path, where: str) -> bytes:
        if not path.is_file():
            what = "is not a file" if path.exists() else "does not exist"
            raise StructureError(f"{where}: companion file {key!r} {what} (in {self.base_dir})")
        try:
            size = os.path.getsize(path)
            if size > MAX_COMPANION_BYTES:
                raise StructureError(
                    f"{where}: companion file {key!r} has {size} bytes, more than {MAX_COMPANION_BYTES}"
                )
            data = path.read_bytes()
        except OSError as err:
            raise StructureError(f"{where}: companion file {key!r} cannot be read: {err.strerror or err}") from None
        self.sha256[key] = hashlib.sha256(data).hexdigest()
        return data

    def _open(self, name: object, where: str) -> tuple[str, np.lib.npyio.NpzFile | CsvTable]:
        key, path = self.resolve(name, where)
        if key not in self._opened:
            data = self._read_bytes(key, path, where)
            self._opened[key] = (
                _open_npz(data, key, where) if key.lower().endswith(".npz") else _parse_csv(data, key, where)
            )
        return key, self._opened[key]

    def npz_array(self, name: object, array: object, where: str) -> np.ndarray:
        """Array ``array`` of the ``.npz`` companion ``name`` (checked from its header first)."""
        key, npz = self._open(name, where)
        if not isinstance(npz, np.lib.npyio.NpzFile):
            raise StructureError(f"{where}: {key!r} is a .csv file: name its columns with 'columns', not 'array'")
        if not isinstance(array, str):
            raise StructureError(f"{where}.array: the name of an array in {key!r}, got {array!r}")
        if array not in npz.files:
            raise StructureError(
                f"{where}.array: {key!r} has no array {array!r} (it has {', '.join(npz.files) or 'none'})"
            )
        _check_npy_header(npz, array, f"{where}: {key}[{array!r}]")
        try:
            return npz[array]
        except (ValueError, OSError, EOFError, zipfile.BadZipFile) as err:
            raise StructureError(f"{where}: {key}[{array!r}] cannot be read: {err}") from None

    def npz_arrays(self, name: object, where: str) -> tuple[str, dict[str, np.ndarray]]:
        """Every array of the ``.npz`` companion ``name``, by name."""
        key, npz = self._open(name, where)
        if not isinstance(npz, np.lib.npyio.NpzFile):
            raise StructureError(f"{where}: {key!r} is not an .npz file")
        return key, {array: self.npz_array(name, array, where) for array in npz.files}

    def csv_table(self, name: object, where: str) -> CsvTable:
        """The ``.csv`` companion ``name``."""
        key, table = self._open(name, where)
        if not isinstance(table, CsvTable):
            raise StructureError(f"{where}: {key!r} is an .npz file: name an array with 'array', not 'columns'")
        return table


def _open_npz(data: bytes, key: str, where: str) -> np.lib.npyio.NpzFile:
    try:
        npz = np.load(io.BytesIO(data), allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as err:
        raise StructureError(f"{where}: companion file {key!r} is not a readable .npz archive ({err})") from None
    if not isinstance(npz, np.lib.npyio.NpzFile):
        raise StructureError(f"{where}: companion file {key!r} is a single .npy array, not an .npz archive")
    return npz


def _check_npy_header(npz: np.lib.npyio.NpzFile, array: str, where: str) -> None:
    """Refuse an object (pickled) array or one of more than :data:`MAX_ELEMENTS` numbers from the
    ``.npy`` header alone."""
    try:
        with npz.zip.open(f"{array}.npy") as stream:
            version = np.lib.format.read_magic(stream)
            if version == (1, 0):
                shape, _, dtype = np.lib.format.read_array_header_1_0(stream)
            else:
                shape, _, dtype = np.lib.format.read_array_header_2_0(stream)
    except (ValueError, OSError, EOFError, KeyError, zipfile.BadZipFile) as err:
        raise StructureError(f"{where}: not a readable array ({err})") from None
    if dtype.hasobject:
        raise StructureError(f"{where}: holds Python objects (pickled data is never loaded); store numbers")
    if dtype.kind not in "biuf":
        raise StructureError(f"{where}: dtype {dtype} is not numeric")
    count = int(np.prod(shape, dtype=object))
    if count > MAX_ELEMENTS:
        raise StructureError(f"{where}: {count} numbers (shape {shape}), more than {MAX_ELEMENTS}")


def _parse_csv(data: bytes, key: str, where: str) -> CsvTable:
    """A header line of unique column names, then rows of as many numbers, comma-separated."""
    try:
        text = data.decode("utf-8-sig")  # a byte-order mark, as spreadsheets write, is dropped
    except UnicodeDecodeError as err:
        raise StructureError(f"{where}: companion file {key!r} is not UTF-8 text (byte {err.start})") from None
    header, _, body = text.partition("\n")
    names = tuple(name.strip() for name in header.strip().split(","))
    if not all(names):
        raise StructureError(f"{where}: {key!r} line 1: a header of column names is needed, got {header.strip()!r}")
    if len(set(names)) != len(names):
        raise StructureError(f"{where}: {key!r} line 1: column names repeat ({header.strip()!r})")
    rows = sum(1 for line in body.splitlines() if line.strip())
    if rows * len(names) > MAX_ELEMENTS:
        raise StructureError(
            f"{where}: {key!r} has {rows} rows of {len(names)} columns, more than {MAX_ELEMENTS} numbers"
        )
    if rows == 0:
        return CsvTable(names, np.zeros((0, len(names))))
    try:
        values = np.loadtxt(io.StringIO(body), delimiter=",", dtype=float, ndmin=2, comments=None)
    except ValueError as err:
        reason = str(err).split(";")[0]  # NumPy's own advice on usecols does not apply here
        raise StructureError(f"{where}: {key!r}, data rows counted from 0 after the header: {reason}") from None
    if values.shape[1] != len(names):
        raise StructureError(f"{where}: {key!r} rows have {values.shape[1]} numbers, the header {len(names)} names")
    return CsvTable(names, values)
