"""Render a run folder (or two, side by side) into an MP4.

A run folder holds ``model.xml``, ``timeseries.zarr`` (or, from earlier versions and scripts,
``timeseries.npz``) with ``t`` (T,), ``qpos`` (T, nq), optional ``strut_activity`` (T, ntendon)
int8 in {-1, 0, +1} and optional scalar series, and
``manifest.json`` whose ``render`` table gives ``title``, ``top_nodes``, ``overlay``, ``inset``
(one scalar series drawn as a small plot of its history up to the frame's time), ``camera``,
``exaggeration``, and what the legend and the overlay lines say: ``markers`` (model object name
pattern → meaning), ``overlay_names`` (series → readable name), ``overlay_units`` (series →
unit, where the name's suffix has none), ``overlay_labels`` (series → {integer value → meaning},
for enumerations such as a controller mode), ``activity_labels`` (``"1"``/``"-1"`` → meaning of
the strut activity colours) and ``strut_colours`` (all optional). The manifest's (or else the
record store's) ``scenario`` and ``config_hash`` are printed in the lower right corner. See
``docs/rendering.md``.

The frames of ``qpos`` and ``strut_activity`` are read from the store when drawn (a chunk at a
time, :class:`Frames`), so the memory of a render does not grow with the run's length; the checks
of the whole series (finite, values in {-1, 0, +1}) read them chunk by chunk.

Per frame: the recorded ``qpos`` is set, positions are computed (``mj_kinematics``,
``mj_comPos``, ``mj_camlight``, ``mj_tendon``; no dynamics), struts (tendons) are coloured
from ``strut_activity`` through ``model.tendon_rgba``, top-layer nodes are coloured by their
height above the top layer's total-least-squares plane through ``model.geom_rgba``, and the
image from :class:`mujoco.Renderer` gets the overlay of :mod:`magsail_mj.render.overlay` (title,
time, values with units, legend of every colour shown, colour bar, inset, run identity).

Camera: a free camera whose ``lookat`` follows the centroid of the body positions, with a fixed
azimuth/elevation in the world (inertial-axes) frame and a fixed distance, so rotations of the
structure are seen as rotations. The distance is the least at which every body (with its geoms
and sites, exaggeration included) of every frame projects inside the largest rectangle the
overlay leaves free (:func:`magsail_mj.render.overlay.free_rectangles`), the centroid drawn at
that rectangle's centre: a structure of any size stays clear of the title, the values, the
legend, the colour bar and the inset. A ``camera`` option's ``distance_m`` is used as given; a
manifest's ``render.camera.distance_m`` only when it is farther than the fit.

Why a run ended (``summary.json``: structure failed with the strut and its strain, diverged with
the time, stopped, interrupted; :mod:`magsail_mj.render.ending`) is printed under the values
from the run's last record on.

Thin struts and small nodes of a 100 m truss are far below one pixel; their rendered radii are
raised to a minimum on-screen size (tendon 1 px wide, actuated tendon 2.5 px, top node 8 px),
which changes the picture only, never the recorded motion.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import tempfile
import warnings
import zipfile
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Self

import mujoco
import numpy as np
from tqdm import tqdm

from magsail_mj.analysis.flatness import average_plane, surface_heights
from magsail_mj.integrity import IntegrityError, verify_run_folder
from magsail_mj.records import STORE_NAME, RecordStoreError, chunk_block_bytes, lazy_arrays, open_records
from magsail_mj.render.backend import ensure_gl_backend, make_renderer
from magsail_mj.render.ending import end_reason, end_status
from magsail_mj.render.overlay import (
    ColourBar,
    Inset,
    LegendEntry,
    OverlayError,
    colormap,
    draw_overlay,
    format_time,
    format_value,
    free_rectangles,
    PanelText,
    overlay_boxes,
)
from magsail_mj.render.video import Mp4Writer
from magsail_mj.resources import (
    check_memory,
    mjcf_model_bytes,
    npz_array_bytes,
    render_bytes,
)

__all__ = [
    "ACTIVE_NEG_RGBA",
    "FrameOptions",
    "ACTIVE_POS_RGBA",
    "DEFAULT_AZIMUTH_DEG",
    "DEFAULT_ELEVATION_DEG",
    "CameraView",
    "RenderError",
    "RunData",
    "RunScene",
    "camera_basis",
    "frame_plan",
    "load_run",
    "project_points",
    "render_frames",
    "render_run",
]

#: Strut colour for ``strut_activity == +1`` (red) and ``-1`` (blue).
ACTIVE_POS_RGBA = (0.95, 0.12, 0.10, 1.0)
ACTIVE_NEG_RGBA = (0.10, 0.35, 1.00, 1.0)
#: Default free-camera view, MuJoCo convention: azimuth 180° looks along −x, elevation −30°
#: looks down at 30° from above.
DEFAULT_AZIMUTH_DEG = 180.0
DEFAULT_ELEVATION_DEG = -30.0
#: Diverging colormap of node heights (purple below the plane, orange above); chosen to be
#: distinct from the red/blue strut activity colours.
DEFAULT_HEIGHT_CMAP = "PuOr_r"

_CAMERA_KEYS = ("azimuth_deg", "elevation_deg", "distance_m")
_MIN_PX = {"tendon": 0.5, "active": 1.25, "top_node": 4.0}  # minimum radii [px]
# Scenes with more objects than this are drawn with coarser tessellation (6 slices, 4 stacks
# instead of MuJoCo's 28 x 16): 14x faster in software rendering (800-node truss, OSMesa),
# and struts a few pixels wide look the same.
_LOD_MIN_OBJECTS = 500
_LOD_SLICES, _LOD_STACKS = 6, 4
# Smallest height range of the node colour scale, relative to the structure's radius: below it the
# heights are rounding noise of a rigid motion, not a shape.
_HEIGHT_FLOOR = 1e-9
_NODE_NAME = re.compile(r"n(\d+)\Z")
#: default meaning of the strut activity colours (``render.activity_labels`` replaces them)
_ACTIVITY_TEXT = {"1": "actuated strut, + sign", "-1": "actuated strut, − sign"}
_AXES = "xyz"
#: digits of the config hash printed in the corner
_HASH_DIGITS = 12


# --------------------------------------------------------------------------- run loading


class RenderError(ValueError):
    """A render input is invalid: an argument, a run folder or one of its files (the message
    starts with the argument's name, e.g. ``run_dir: ...``, ``out_path: ...``)."""


@dataclass(frozen=True)
class RunData:
    """The contents of a run folder that rendering needs.

    Attributes:
      run_dir: the folder.
      model_xml: path of ``model.xml``.
      t: (T,) record times [s], non-decreasing.
      qpos: (T, nq) MuJoCo ``qpos`` at each record (an array, or :class:`Frames` reading a store).
      strut_activity: (T, ntendon) int8 in {-1, 0, +1} (array or :class:`Frames`), or ``None``.
      series: overlay series named in ``manifest.render.overlay``, each (T,) or (T, k).
      inset: ``(name, values (T,))`` of ``manifest.render.inset``, or ``None``.
      title: ``manifest.render.title`` (default: the folder name).
      top_nodes: node indices of the top layer (body = node + 1), or ``None``.
      camera: ``manifest.render.camera`` (keys from ``azimuth_deg``, ``elevation_deg``,
        ``distance_m``).
      exaggeration: ``manifest.render.exaggeration`` or ``None``.
      manifest: the whole manifest (``{}`` when the render table was given instead).
      strut_colours: ``render.strut_colours`` entries ``{"struts": [...], "rgba": [r, g, b, a]}``
        (optional ``label``, or ``axis`` 0/1/2 of a current loop, for the legend).
      names: ``render.overlay_names``: series → readable name.
      units: ``render.overlay_units``: series → printed unit.
      labels: ``render.overlay_labels``: series → {integer value as a string → meaning}.
      markers: ``render.markers``: model object name pattern → meaning (legend rows).
      activity_labels: ``render.activity_labels``: ``"1"``/``"-1"`` → meaning of the strut
        activity colours.
      identity: ``scenario <name> · config <hash[:12]>`` (empty when neither is known).
      end: how the run ended, from ``summary.json`` (else the manifest): ``status``,
        ``status_message``, ``t_end_s`` and, where written, ``strut_strain_max``, ``t_failed_s``
        (``{}`` when unknown).
      end_line: why the run ended, one line (:func:`magsail_mj.render.ending.end_reason`), shown
        once the video is past the run's last record.
    """

    run_dir: Path
    model_xml: Path
    t: np.ndarray
    qpos: Any
    strut_activity: Any
    series: dict[str, np.ndarray]
    title: str
    top_nodes: np.ndarray | None
    camera: dict[str, float]
    exaggeration: float | None
    manifest: dict = field(repr=False)
    inset: tuple[str, np.ndarray] | None = None
    strut_colours: tuple = ()
    names: dict[str, str] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    labels: dict[str, dict[str, str]] = field(default_factory=dict)
    markers: dict[str, str] = field(default_factory=dict)
    activity_labels: dict[str, str] = field(default_factory=dict)
    identity: str = ""
    end: dict[str, Any] = field(default_factory=dict)
    end_line: str = ""

    @property
    def ended_early(self) -> bool:
        """The run is known to have ended before its planned end (a status other than
        ``completed``: structure failed, diverged, stopped, interrupted, ...)."""
        return self.end.get("status") not in (None, "", "completed")


def _check_camera(camera: object, what: str) -> dict[str, float]:
    if camera is None:
        return {}
    if not isinstance(camera, Mapping):
        raise RenderError(f"{what}: expected a mapping with keys {_CAMERA_KEYS}, got {camera!r}")
    out: dict[str, float] = {}
    for key, value in camera.items():
        if key not in _CAMERA_KEYS:
            raise RenderError(f"{what}: unknown key {key!r}; allowed: {_CAMERA_KEYS}")
        if value is None:
            continue
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise RenderError(f"{what}.{key}: expected a number, got {value!r}") from None
        if not math.isfinite(v) or (key == "distance_m" and v <= 0):
            raise RenderError(f"{what}.{key}: must be finite{' and > 0' if key == 'distance_m' else ''}, got {value!r}")
        out[key] = v
    return out


def _read_manifest(path: Path, *, name: str, required: bool) -> dict:
    """The run's ``manifest.json`` as a dict (``{}`` when absent and not ``required``)."""
    if not path.is_file():
        if required:
            raise RenderError(f"{name}: {str(path)!r} is missing (not a run folder?)")
        return {}
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise RenderError(f"{name}: {str(path)!r} is not valid JSON ({exc})") from None
    except OSError as exc:
        raise RenderError(f"{name}: cannot read {str(path)!r} ({exc.strerror or exc})") from None
    if not isinstance(manifest, dict):
        raise RenderError(f"{name}: {str(path)!r} must hold a JSON object, got {type(manifest).__name__}")
    return manifest


def _read_series(path: Path, *, name: str) -> dict[str, np.ndarray]:
    """All arrays of the run's ``timeseries.npz`` (no pickles); a file that is not a readable
    ``.npz`` is a :class:`RenderError`."""
    try:
        with np.load(path, allow_pickle=False) as npz:
            if not hasattr(npz, "files"):
                raise RenderError(f"{name}: {str(path)!r} is a single array, not an .npz archive")
            return {key: npz[key] for key in npz.files}
    except RenderError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as exc:
        raise RenderError(
            f"{name}: cannot read {str(path)!r} as an .npz archive ({type(exc).__name__}: {exc})"
        ) from None


class Frames:
    """Rows of a stored (T, n) series read on demand: ``frames[i]`` reads the chunk holding row
    ``i`` (kept until a row of another chunk is asked), ``blocks()`` yields the rows chunk by
    chunk; ``T`` may be cut below the stored length (:meth:`head`)."""

    def __init__(self, array: Any, *, dtype: Any, rows: int | None = None):
        self.array = array
        self.dtype = np.dtype(dtype)
        self.step = int(array.chunks[0]) if getattr(array, "chunks", None) else max(1, int(array.shape[0]))
        self.shape = (int(array.shape[0]) if rows is None else int(rows), *(int(s) for s in array.shape[1:]))
        self.ndim = len(self.shape)
        self._cached: tuple[int, np.ndarray] | None = None

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, i: int) -> np.ndarray:
        i = int(i)
        if not 0 <= i < self.shape[0]:
            raise IndexError(f"row {i} outside 0 … {self.shape[0] - 1}")
        a = i // self.step * self.step
        if self._cached is None or self._cached[0] != a:
            self._cached = (a, np.asarray(self.array[a : min(a + self.step, self.shape[0])], dtype=self.dtype))
        return self._cached[1][i - a]

    def blocks(self) -> Iterator[tuple[int, np.ndarray]]:
        """``(first row, rows)`` of each chunk, in order."""
        for a in range(0, self.shape[0], self.step):
            yield a, np.asarray(self.array[a : min(a + self.step, self.shape[0])], dtype=self.dtype)

    def head(self, rows: int) -> "Frames":
        """The first ``rows`` rows."""
        return Frames(self.array, dtype=self.dtype, rows=rows)


def _read_store(run_dir: Path, *, name: str) -> dict[str, Any]:
    """name → lazy Zarr array of the run's ``timeseries.zarr`` (records, then derived series)."""
    try:
        return lazy_arrays(run_dir)
    except RecordStoreError as exc:
        raise RenderError(f"{name}: {exc}") from None


def _finite_rows(qpos: Any) -> tuple[int, int]:
    """``(T, first non-finite row or T)`` of an array or :class:`Frames`, chunk by chunk."""
    if isinstance(qpos, Frames):
        for a, rows in qpos.blocks():
            ok = np.isfinite(rows).all(axis=1)
            if not ok.all():
                return qpos.shape[0], a + int(np.argmin(ok))
        return qpos.shape[0], qpos.shape[0]
    ok = np.isfinite(qpos).all(axis=1)
    return ok.size, ok.size if ok.all() else int(np.argmin(ok))


def _activity_values_ok(activity: Any) -> bool:
    blocks = activity.blocks() if isinstance(activity, Frames) else [(0, activity)]
    return all(not rows.size or np.all(np.isin(rows, (-1, 0, 1))) for _, rows in blocks)


def _overlay_names(overlay: object, arrays: Mapping[str, np.ndarray], *, where: str, where_ts: str) -> list[str]:
    """The overlay series to draw: names absent from the time series are skipped with a warning
    (a scenario may list a series that its kind does not record); a non-list is an error."""
    if overlay is None:
        return []
    if isinstance(overlay, str) or not isinstance(overlay, Sequence):
        raise RenderError(f"{where}.overlay: expected a list of series names, got {overlay!r}")
    present = [str(n) for n in overlay if isinstance(n, str) and n in arrays]
    missing = [n for n in overlay if not (isinstance(n, str) and n in arrays)]
    if missing:
        warnings.warn(
            f"{where}.overlay: series {missing} not in {where_ts} (has {sorted(arrays)}); drawn without them",
            RuntimeWarning,
            stacklevel=3,
        )
    return present


def load_run(run_dir: str | os.PathLike, *, name: str = "run_dir", render_info: Mapping | None = None) -> RunData:
    """Read and validate a run folder (``model.xml``, ``timeseries.zarr`` or ``timeseries.npz``,
    ``manifest.json``, and ``summary.json`` for how the run ended); ``qpos`` and
    ``strut_activity`` are read lazily from a store. Everything rendering reads from the folder
    is read here.

    Args:
      run_dir: the folder.
      name: the argument name used in error messages (e.g. ``"compare"``).
      render_info: the render table to use instead of the manifest's ``render`` entry; then
        ``manifest.json`` is optional (a run renders its video before it writes its manifest).

    Raises:
      RenderError: the folder or a file is missing or unreadable, or a series or render entry has
        the wrong shape or value (the message names the argument, the file and the entry).
    """
    if not str(os.fspath(run_dir)).strip():
        raise RenderError(f"{name}: must be a run folder, got an empty path")
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        what = "is a file, not a run folder" if run_dir.exists() else "no such folder"
        raise RenderError(f"{name}: {what}: {str(run_dir)!r}")
    paths = {key: run_dir / key for key in ("model.xml", "timeseries.npz", "manifest.json")}
    stored = (run_dir / STORE_NAME).is_dir()
    if stored:
        paths["timeseries.npz"] = run_dir / STORE_NAME
    for key in ("model.xml", "timeseries.npz"):
        if not (paths[key].is_dir() if key == "timeseries.npz" and stored else paths[key].is_file()):
            raise RenderError(f"{name}: {str(paths[key])!r} is missing (not a run folder?)")
    manifest = _read_manifest(paths["manifest.json"], name=name, required=render_info is None)
    # how the run ended: summary.json is written before the video is rendered; the manifest after
    summary = _read_manifest(run_dir / "summary.json", name=name, required=False)
    end = end_status(summary) if summary.get("status") else end_status(manifest)
    render = manifest.get("render") if render_info is None else render_info
    render = render or {}
    if not isinstance(render, Mapping):
        raise RenderError(f"{name}: {paths['manifest.json']}: 'render' must be an object, got {render!r}")
    where = f"{name}: {paths['manifest.json']}: render"

    arrays = _read_store(run_dir, name=name) if stored else _read_series(paths["timeseries.npz"], name=name)
    where_ts = f"{name}: {paths['timeseries.npz']}"
    for key in ("t", "qpos"):
        if key not in arrays:
            raise RenderError(
                f"{where_ts}: series {key!r} is missing (has {sorted(arrays)[:20]}); "
                "a run without recorded positions (qpos) has no motion to render"
            )
    try:
        t = np.asarray(arrays["t"][...], dtype=float)
        if stored:
            if arrays["qpos"].dtype.kind not in "biuf":
                raise TypeError("qpos")
            qpos = Frames(arrays["qpos"], dtype=float)
        else:
            qpos = np.asarray(arrays["qpos"], dtype=float)
    except (TypeError, ValueError):
        raise RenderError(f"{where_ts}: 't' and 'qpos' must be numeric") from None
    if t.ndim != 1 or t.size == 0:
        raise RenderError(f"{where_ts}: 't' must have shape (T,) with T >= 1, got {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0):
        raise RenderError(f"{where_ts}: 't' must be finite and non-decreasing")
    T = t.size
    if qpos.ndim != 2 or qpos.shape[0] != T:
        raise RenderError(f"{where_ts}: 'qpos' must have shape ({T}, nq), got {qpos.shape}")

    n_rows, first = _finite_rows(qpos)
    if first < n_rows:  # a diverged run keeps what was recorded: render up to the blow-up
        if first == 0:
            raise RenderError(f"{where_ts}: 'qpos' is non-finite from the first record on")
        warnings.warn(
            f"{where_ts}: 'qpos' is non-finite from record {first} "
            f"(t = {t[first]:g} s); rendering the {first} records before it",
            RuntimeWarning,
            stacklevel=2,
        )
        T = first
        t = t[:T]
        qpos = qpos.head(T) if isinstance(qpos, Frames) else qpos[:T]
        arrays = {k: (v[:T] if np.ndim(v) >= 1 and np.shape(v)[0] == n_rows else v) for k, v in arrays.items()}

    activity = arrays.get("strut_activity")
    if activity is not None:
        if not stored:
            activity = np.asarray(activity)
        if activity.ndim != 2 or activity.shape[0] != T:
            raise RenderError(f"{where_ts}: 'strut_activity' must have shape ({T}, ntendon), got {activity.shape}")
        activity = Frames(activity, dtype=np.int8, rows=T) if stored else activity
        if not _activity_values_ok(activity):
            raise RenderError(f"{where_ts}: 'strut_activity' values must be -1, 0 or +1")
        activity = activity if stored else activity.astype(np.int8)

    series: dict[str, np.ndarray] = {}
    for key in _overlay_names(render.get("overlay"), arrays, where=where, where_ts=where_ts):
        s = np.asarray(arrays[key])
        if s.ndim not in (1, 2) or s.shape[0] != T or not np.issubdtype(s.dtype, np.number):
            raise RenderError(
                f"{where}.overlay: series {key!r} must be numeric with shape ({T},) "
                f"or ({T}, k), got {s.shape} {s.dtype}"
            )
        series[key] = s

    inset = render.get("inset")
    if isinstance(inset, str) and inset not in arrays:
        warnings.warn(
            f"{where}.inset: series {inset!r} not in {where_ts}; drawn without the inset", RuntimeWarning, stacklevel=2
        )
        inset = None
    if inset is not None:
        values = np.asarray(arrays[inset]) if isinstance(inset, str) and inset in arrays else None
        if values is None or values.shape != (T,) or not np.issubdtype(values.dtype, np.number):
            raise RenderError(
                f"{where}.inset: expected the name of a numeric ({T},) series in {where_ts}, got {inset!r}"
            )
        inset = (inset, values.astype(float))

    top = render.get("top_nodes")
    if top is not None:
        try:
            top = np.asarray(top)
        except (TypeError, ValueError):
            top = np.zeros((0,))
        if (
            top.ndim != 1
            or top.size < 3
            or not np.issubdtype(top.dtype, np.integer)
            or np.any(top < 0)
            or np.unique(top).size != top.size
        ):
            raise RenderError(
                f"{where}.top_nodes: expected >= 3 distinct node indices >= 0, got {render.get('top_nodes')!r:.200}"
            )
        top = top.astype(np.int64)

    exaggeration = render.get("exaggeration")
    if exaggeration is not None:
        try:
            exaggeration = float(exaggeration)
        except (TypeError, ValueError):
            raise RenderError(f"{where}.exaggeration: expected a number, got {exaggeration!r}") from None
        if not (math.isfinite(exaggeration) and exaggeration > 0):
            raise RenderError(f"{where}.exaggeration: must be > 0, got {exaggeration!r}")

    title = render.get("title") or run_dir.resolve().name
    colours = render.get("strut_colours") or ()
    if isinstance(colours, (str, Mapping)) or not isinstance(colours, Sequence):
        raise RenderError(f"{where}.strut_colours: expected a list of {{struts, rgba}} tables, got {colours!r:.200}")
    labels = _text_table(render.get("overlay_labels"), f"{where}.overlay_labels", nested=True)
    return RunData(
        run_dir=run_dir,
        model_xml=paths["model.xml"],
        t=t,
        qpos=qpos,
        strut_activity=activity,
        series=series,
        title=str(title),
        top_nodes=top,
        camera=_check_camera(render.get("camera"), f"{where}.camera"),
        exaggeration=exaggeration,
        manifest=manifest,
        inset=inset,
        strut_colours=tuple(colours),
        names=_text_table(render.get("overlay_names"), f"{where}.overlay_names"),
        units=_text_table(render.get("overlay_units"), f"{where}.overlay_units"),
        labels=labels,
        markers=_text_table(render.get("markers"), f"{where}.markers"),
        activity_labels=_text_table(render.get("activity_labels"), f"{where}.activity_labels"),
        identity=_identity(manifest, run_dir if stored else None),
        end=end,
        end_line=end_reason(end, t_last_s=float(t[-1])),
    )


def _text_table(table: object, where: str, *, nested: bool = False) -> dict:
    """A render table of texts (``{key: text}``; ``nested``: ``{key: {value: text}}``) with string
    keys and values; ``None`` is empty; anything else is a :class:`RenderError` naming ``where``."""
    if table is None:
        return {}
    if not isinstance(table, Mapping):
        raise RenderError(f"{where}: expected a table, got {table!r:.200}")
    out: dict = {}
    for key, value in table.items():
        if nested:
            out[str(key)] = _text_table(value, f"{where}.{key}")
        elif isinstance(value, (str, int, float)) and not isinstance(value, bool):
            out[str(key)] = str(value)
        else:
            raise RenderError(f"{where}.{key}: expected a text, got {value!r:.200}")
    return out


def _identity(manifest: Mapping, run_dir: Path | None) -> str:
    """``scenario <name> · config <first 12 hex digits>`` from the manifest, else from the record
    store's attributes (a run renders its video before it writes its manifest); ``""`` if unknown."""
    scenario, digest = manifest.get("scenario"), manifest.get("config_hash")
    if (scenario is None or digest is None) and run_dir is not None:
        try:
            attrs = open_records(run_dir).attrs
        except (RecordStoreError, KeyError):
            attrs = {}
        scenario = scenario if scenario is not None else attrs.get("scenario")
        digest = digest if digest is not None else attrs.get("config_hash")
    parts = [f"scenario {scenario}"] if scenario else []
    return " · ".join(parts + ([f"config {str(digest)[:_HASH_DIGITS]}"] if digest else []))


def _strut_colours(entries: Sequence, *, where: str, ntendon: int) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """``(strut indices, rgba)`` of each ``render.strut_colours`` entry, checked against the model."""
    for k, entry in enumerate(entries):
        try:
            idx = np.asarray(entry.get("struts", []), dtype=np.int64).reshape(-1)
            rgba = np.asarray(entry["rgba"], dtype=float)
        except (AttributeError, KeyError, TypeError, ValueError):
            raise RenderError(
                f"{where}[{k}]: expected {{struts: [indices], rgba: [r, g, b, a]}}, got {entry!r:.200}"
            ) from None
        if rgba.shape != (4,) or not np.all(np.isfinite(rgba)):
            raise RenderError(f"{where}[{k}].rgba: expected 4 finite numbers, got {entry['rgba']!r:.100}")
        if idx.size and (idx.min() < 0 or idx.max() >= ntendon):
            raise RenderError(f"{where}[{k}]: strut index out of range (model has {ntendon} tendons)")
        yield idx, rgba


# --------------------------------------------------------------------------- timeline


def frame_plan(
    times: Sequence[np.ndarray], *, max_frames: int
) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray]]:
    """Common frame times for one or more runs.

    The run with the longest time span sets the frame times: its records, subsampled uniformly
    to at most ``max_frames``. Every run shows, at each frame time, its nearest record (a run
    that ended earlier holds its last record).

    Args:
      times: each run's (T,) record times [s].
      max_frames: most frames, >= 1.

    Returns:
      ``(frame_t, indices, ended)``: (F,) frame times [s]; per run, (F,) record indices; per
      run, (F,) bool, True where the frame time lies after the run's last record.
    """
    if int(max_frames) != max_frames or max_frames < 1:
        raise RenderError(f"max_frames: must be an integer >= 1, got {max_frames!r}")
    spans = [float(t[-1] - t[0]) for t in times]
    base = int(np.argmax(spans))
    n = len(times[base])
    F = min(n, int(max_frames))
    idx = np.unique(np.round(np.linspace(0, n - 1, F)).astype(np.int64))
    frame_t = np.asarray(times[base], dtype=float)[idx]
    indices, ended = [], []
    for k, t in enumerate(times):
        t = np.asarray(t, dtype=float)
        if k == base:
            indices.append(idx)
        else:
            j = np.clip(np.searchsorted(t, frame_t), 1, max(t.size - 1, 1))
            if t.size == 1:
                j = np.zeros_like(j)
            else:
                j = np.where(np.abs(frame_t - t[j - 1]) <= np.abs(t[j] - frame_t), j - 1, j)
            indices.append(j.astype(np.int64))
        tol = 1e-9 * max(1.0, abs(float(t[-1])))
        ended.append(frame_t > t[-1] + tol)
    return frame_t, indices, ended


# --------------------------------------------------------------------------- the 3-D scene


@dataclass(frozen=True)
class CameraView:
    """Free-camera view in MuJoCo's convention.

    Attributes:
      azimuth_deg: direction of view about world z; 0 looks along +x, 180 along −x.
      elevation_deg: negative looks down from above.
      distance_m: camera distance from the look-at point (the body centroid) [m].
    """

    azimuth_deg: float = DEFAULT_AZIMUTH_DEG
    elevation_deg: float = DEFAULT_ELEVATION_DEG
    distance_m: float = 1.0


def camera_basis(view: CameraView) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(forward, up, right)`` unit vectors of a MuJoCo free camera at ``view``'s azimuth and
    elevation (as ``mjv_updateCamera`` computes them): the image's x axis is ``right``, its y
    axis ``up``, and the camera looks along ``forward``."""
    az, el = math.radians(view.azimuth_deg), math.radians(view.elevation_deg)
    forward = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    up = np.array([-math.sin(el) * math.cos(az), -math.sin(el) * math.sin(az), math.cos(el)])
    return forward, up, np.cross(forward, up)


def project_points(
    points: np.ndarray, *, view: CameraView, lookat: np.ndarray, fovy_deg: float, width: int, height: int
) -> np.ndarray:
    """Pixel coordinates (n, 2) — x to the right, y downwards, from the image's top-left corner —
    of world points (n, 3) seen by a MuJoCo free camera looking at ``lookat`` from
    ``view.distance_m`` with vertical field of view ``fovy_deg`` on a ``width`` x ``height`` image."""
    forward, up, right = camera_basis(view)
    rel = np.asarray(points, float).reshape(-1, 3) - np.asarray(lookat, float)
    depth = view.distance_m + rel @ forward
    ty = math.tan(math.radians(fovy_deg) / 2)
    tx = ty * width / height
    x_ndc = (rel @ right) / (depth * tx)
    y_ndc = (rel @ up) / (depth * ty)
    return np.stack([(x_ndc + 1) * width / 2, (1 - y_ndc) * height / 2], axis=1)


def _ndc(rect: tuple[float, float, float, float], width: int, height: int) -> tuple[float, float, float, float]:
    """A pixel rectangle (x0, y0, x1, y1; y downwards) as (x_lo, x_hi, y_lo, y_hi) in normalised
    device coordinates (−1 … 1, y upwards)."""
    x0, y0, x1, y1 = rect
    return 2 * x0 / width - 1, 2 * x1 / width - 1, 1 - 2 * y1 / height, 1 - 2 * y0 / height


class RunScene:
    """Renders the frames of one run: kinematics, colouring, camera, MuJoCo image.

    Use as a context manager (it owns an OpenGL context)::

        with RunScene(run, width=960, height=540) as scene:
            scene.prepare(indices, exaggeration=1.0)
            view = CameraView(distance_m=scene.auto_distance_m)
            image = scene.render(0, view=view)

    Args:
      run: the loaded run.
      width: image width [px].
      height: image height [px].
      antialias: 4x multisampling (MuJoCo's ``offsamples``); off is about twice as fast in
        software rendering, with jagged thin struts.
    """

    def __init__(self, run: RunData, *, width: int, height: int, antialias: bool = True) -> None:
        self.run = run
        self.width, self.height = int(width), int(height)
        try:
            self.model = mujoco.MjModel.from_xml_path(str(run.model_xml))
        except Exception as exc:
            raise RenderError(f"{run.model_xml}: cannot load the model ({exc})") from exc
        m = self.model
        self.data = mujoco.MjData(m)
        q = m.vis.quality
        if m.ngeom + m.ntendon > _LOD_MIN_OBJECTS:
            q.numslices = min(int(q.numslices), _LOD_SLICES)
            q.numstacks = min(int(q.numstacks), _LOD_STACKS)
        if not antialias:
            q.offsamples = 0
        if run.qpos.shape[1] != m.nq:
            raise RenderError(
                f"{run.run_dir / 'timeseries.npz'}: 'qpos' has {run.qpos.shape[1]} columns, the model has nq = {m.nq}"
            )
        if run.strut_activity is not None and run.strut_activity.shape[1] != m.ntendon:
            raise RenderError(
                f"{run.run_dir / 'timeseries.npz'}: 'strut_activity' has "
                f"{run.strut_activity.shape[1]} columns, the model has "
                f"{m.ntendon} tendons"
            )

        # Truss nodes: bodies named "n<i>" that are body i + 1 (build_truss_spec).
        names = [m.body(b).name for b in range(m.nbody)]
        self.node_bodies = np.array(
            [b for b in range(1, m.nbody) if (mt := _NODE_NAME.match(names[b])) and int(mt.group(1)) == b - 1],
            dtype=np.int64,
        )
        self.top_bodies: np.ndarray | None = None
        self.top_geoms: np.ndarray | None = None
        if run.top_nodes is not None:
            bodies = run.top_nodes + 1
            bad = bodies[bodies >= m.nbody]
            if bad.size:
                raise RenderError(
                    f"{run.run_dir / 'manifest.json'}: render.top_nodes: node "
                    f"{int(bad[0]) - 1} does not exist (model has {m.nbody - 1} bodies)"
                )
            nogeom = bodies[m.body_geomnum[bodies] < 1]
            if nogeom.size:
                raise RenderError(
                    f"{run.run_dir / 'manifest.json'}: render.top_nodes: node "
                    f"{int(nogeom[0]) - 1} has no geom to colour"
                )
            self.top_bodies = bodies
            self.top_geoms = m.body_geomadr[bodies].astype(np.int64)

        # Static strut colours (e.g. current loops coloured by axis): manifest render.strut_colours
        # = [{"struts": [...], "rgba": [r, g, b, a]}, ...], drawn 2.5× wider.
        widen = np.zeros(m.ntendon, bool)
        for idx, rgba in _strut_colours(
            run.strut_colours, where=f"{run.run_dir / 'manifest.json'}: render.strut_colours", ntendon=m.ntendon
        ):
            m.tendon_rgba[idx] = rgba
            widen[idx] = True
        m.tendon_width[widen] *= 2.5
        self._widened = widen
        # Render-only size floors, based on the original sizes.
        self._tendon_rgba0 = m.tendon_rgba.copy()
        self._tendon_width0 = m.tendon_width.copy()
        self._geom_size0 = m.geom_size.copy()
        node_set = np.zeros(m.nbody, bool)
        node_set[self.node_bodies] = True
        self._node_sphere_geoms = np.flatnonzero(
            node_set[m.geom_bodyid] & (m.geom_type == int(mujoco.mjtGeom.mjGEOM_SPHERE))
        )

        self._indices: np.ndarray | None = None
        self._centroid: np.ndarray | None = None
        self._offsets: np.ndarray = np.zeros((0, 0, 3))
        self._frame_centre = (0.0, 0.0)
        self._heights: np.ndarray | None = None
        self._shift: np.ndarray | None = None
        self.radius_m = float(m.stat.extent)
        self.height_limit_m = 0.0
        self.exaggeration = 1.0
        self._renderer = None
        self._option = mujoco.MjvOption()
        self._camera = mujoco.MjvCamera()
        self._camera.type = int(mujoco.mjtCamera.mjCAMERA_FREE)
        self._configured_distance: float | None = None

    # -- legend

    def legend(self) -> list[LegendEntry]:
        """The legend rows of this run: each ``render.markers`` entry that names objects of the
        model (with their colours), the ``render.strut_colours`` colours, and the strut activity
        colours (``render.activity_labels``, else "actuated strut, ± sign") with the idle strut
        colour."""
        run, m = self.run, self.model
        colours = _ModelColours(m)
        rows = [e for key, text in run.markers.items() if (e := colours.entry(key, text)) is not None]
        rows += _strut_colour_entries(run.strut_colours)
        if run.strut_activity is not None:
            text = {**_ACTIVITY_TEXT, **run.activity_labels}
            rows += [
                LegendEntry((tuple(ACTIVE_POS_RGBA[:3]),), text["1"]),
                LegendEntry((tuple(ACTIVE_NEG_RGBA[:3]),), text["-1"]),
            ]
            idle = _unique_rgb(self._tendon_rgba0[~self._widened], most=1)
            if idle:
                rows.append(LegendEntry(idle, "strut, not actuated"))
        return rows

    # -- lifecycle

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Free the OpenGL context."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # -- kinematics

    def _positions(self, qpos: np.ndarray) -> None:
        m, d = self.model, self.data
        d.qpos[:] = qpos
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)

    def _finish_positions(self) -> None:
        m, d = self.model, self.data
        mujoco.mj_camlight(m, d)
        if m.nflex:
            mujoco.mj_flex(m, d)
        mujoco.mj_tendon(m, d)

    def prepare(self, indices: np.ndarray, *, exaggeration: float = 1.0) -> None:
        """Pre-pass over the frames to render: centroids, size, node heights, exaggeration.

        Args:
          indices: (F,) record indices of the frames, in frame order.
          exaggeration: factor k on each node's out-of-plane deviation (see module docs);
            needs at least 3 truss nodes when k != 1.
        """
        indices = np.asarray(indices, dtype=np.int64)
        if indices.ndim != 1 or indices.size == 0 or indices.min() < 0 or indices.max() >= self.run.t.size:
            raise RenderError(f"indices: expected (F,) record indices in [0, {self.run.t.size})")
        if not (math.isfinite(exaggeration) and exaggeration > 0):
            raise RenderError(f"exaggeration: must be > 0, got {exaggeration!r}")
        if exaggeration != 1.0 and self.node_bodies.size < 3:
            raise RenderError(
                "exaggeration: needs a flexible structure (>= 3 node bodies named "
                "n0, n1, ... as build_truss_spec makes them); this model has "
                f"{self.node_bodies.size}"
            )
        m, d = self.model, self.data
        F = indices.size
        xpos = np.empty((F, m.nbody, 3))
        for f, i in enumerate(indices):
            self._positions(self.run.qpos[i])
            xpos[f] = d.xpos
            if f == 0:
                c0 = d.xpos[1:].mean(axis=0) if m.nbody > 1 else np.zeros(3)
                if m.ngeom:
                    r = np.linalg.norm(d.geom_xpos - c0, axis=1) + m.geom_rbound
                    self.radius_m = float(r.max())
                elif m.nbody > 1:
                    self.radius_m = float(np.linalg.norm(d.xpos[1:] - c0, axis=1).max())
                if not self.radius_m > 0:
                    self.radius_m = float(m.stat.extent) or 1.0
        if not np.all(np.isfinite(xpos)):
            bad = indices[np.flatnonzero(~np.isfinite(xpos).all(axis=(1, 2)))[0]]
            raise RenderError(
                f"{self.run.run_dir / 'timeseries.npz'}: non-finite positions at "
                f"record {int(bad)} (t = {self.run.t[bad]:g} s)"
            )
        self._indices = indices
        self._centroid = xpos[:, 1:].mean(axis=1) if m.nbody > 1 else np.zeros((F, 3))
        self.exaggeration = float(exaggeration)
        self._frame_centre = (0.0, 0.0)

        nodes = xpos[:, self.node_bodies] if self.node_bodies.size else None
        top = xpos[:, self.top_bodies] if self.top_bodies is not None else None
        if top is not None:
            if nodes is not None and self.node_bodies.size > top.shape[1]:
                orient = top.mean(axis=1) - nodes.mean(axis=1)  # from mid-plane towards the top
            else:
                _, orient = average_plane(top)
                for f in range(1, F):  # keep the normal's sign continuous
                    if orient[f] @ orient[f - 1] < 0:
                        orient[f] = -orient[f]
            self._heights = surface_heights(top, orient=orient)
            # Heights at rounding-noise level (a rigid motion) map to the neutral middle colour.
            self.height_limit_m = max(float(np.max(np.abs(self._heights))), _HEIGHT_FLOOR * self.radius_m)
        else:
            self._heights = None
            self.height_limit_m = 0.0

        self._shift = None
        if exaggeration != 1.0 and nodes is not None:
            c, nrm = average_plane(nodes)
            s = np.einsum("fij,fj->fi", nodes - c[:, None, :], nrm)  # (F, n) [m]
            layers = np.zeros(self.node_bodies.size, np.int64)
            if self.top_bodies is not None:
                layers[np.isin(self.node_bodies, self.top_bodies)] = 1
            dev = s.copy()
            for layer in np.unique(layers):
                sel = layers == layer
                dev[:, sel] -= s[:, sel].mean(axis=1, keepdims=True)
            self._shift = (exaggeration - 1.0) * dev[:, :, None] * nrm[:, None, :]  # (F, n, 3)
            node_of_body = np.full(m.nbody, -1, np.int64)
            node_of_body[self.node_bodies] = np.arange(self.node_bodies.size)
            self._geom_nodes = node_of_body[m.geom_bodyid]
            self._site_nodes = node_of_body[m.site_bodyid]
            xpos[:, self.node_bodies] += self._shift
        # where the structure is drawn, about each frame's look-at point (the body centroid), for
        # the framing (fit_distance); kept in the prepare pass's own array, no copy
        xpos -= self._centroid[:, None, :]
        self._offsets = xpos[:, 1:]

    def _body_reach(self) -> np.ndarray:
        """(nbody − 1,) radius [m] about each body's origin that holds its geoms and sites."""
        m = self.model
        reach = np.zeros(m.nbody)
        if m.ngeom:
            np.maximum.at(reach, m.geom_bodyid, np.linalg.norm(m.geom_pos, axis=1) + m.geom_rbound)
        if m.nsite:
            np.maximum.at(reach, m.site_bodyid, np.linalg.norm(m.site_pos, axis=1) + m.site_size[:, 0])
        return reach[1:]

    def fit_distance(self, view: CameraView, rects: Sequence[tuple[float, float, float, float]]) -> list[float]:
        """The least camera distance [m] at which every body of every prepared frame (with its
        geoms and sites, the exaggeration included) projects inside each rectangle ``rects``
        (x_lo, x_hi, y_lo, y_hi in normalised device coordinates), the frame's centroid being put
        at the rectangle's centre (:meth:`set_frame_centre`).

        A point at ``p`` from the centroid, ``a, b, c`` its components along the camera's right,
        forward and up axes, is inside ``[cx − hx, cx + hx]`` when
        ``|a − cx·tx·b| ≤ hx·tx·(D + b)`` (``tx``: the half-width's tangent), so
        ``D ≥ |a − cx·tx·b| / (hx·tx) − b``, and likewise along y; a body's reach ``ρ`` adds
        ``ρ (1 + |cx|·tx) / (hx·tx) + ρ``.
        """
        if self._indices is None:
            raise RuntimeError("RunScene.fit_distance: call prepare() first")
        forward, up, right = camera_basis(view)
        ty = math.tan(math.radians(float(self.model.vis.global_.fovy)) / 2)
        tx = ty * self.width / self.height
        rho = self._body_reach()
        need = np.full(len(rects), 1e-9)
        offsets = self._offsets
        for a0 in range(0, offsets.shape[0], 64):
            block = offsets[a0 : a0 + 64]
            a, b, c = block @ right, block @ forward, block @ up
            for k, (x_lo, x_hi, y_lo, y_hi) in enumerate(rects):
                for along, t, lo, hi in ((a, tx, x_lo, x_hi), (c, ty, y_lo, y_hi)):
                    centre, half = (lo + hi) / 2, (hi - lo) / 2
                    if half <= 0:
                        need[k] = math.inf
                        continue
                    d = (np.abs(along - centre * t * b) + rho * (1 + abs(centre) * t)) / (half * t) - b + rho
                    need[k] = max(need[k], float(d.max(initial=0.0)))
        return need.tolist()

    def release_fit_points(self) -> None:
        """Free the positions kept for :meth:`fit_distance` (the framing is decided)."""
        self._offsets = np.zeros((0, 0, 3))

    def set_frame_centre(self, centre: tuple[float, float]) -> None:
        """Draw each frame's centroid at ``centre`` (x, y in normalised device coordinates, −1 …
        1, y upwards) instead of the image's centre."""
        self._frame_centre = (float(centre[0]), float(centre[1]))

    def lookat(self, frame: int, view: CameraView) -> np.ndarray:
        """The camera's look-at point [m] of frame number ``frame``: the centroid, moved so that
        it is drawn at the frame centre (:meth:`set_frame_centre`)."""
        _, up, right = camera_basis(view)
        ty = math.tan(math.radians(float(self.model.vis.global_.fovy)) / 2)
        tx = ty * self.width / self.height
        cx, cy = self._frame_centre
        return self._centroid[frame] - view.distance_m * (cx * tx * right + cy * ty * up)

    @property
    def auto_distance_m(self) -> float:
        """Camera distance [m] at which the structure's bounding sphere (radius from
        :meth:`prepare`) spans 80 % of the image height, leaving room for the overlay."""
        fovy = math.radians(float(self.model.vis.global_.fovy))
        return 1.25 * self.radius_m / math.sin(fovy / 2)

    # -- rendering

    def _configure(self, distance: float) -> None:
        """Clipping planes and render-only size floors for a camera ``distance`` [m]."""
        if self._configured_distance == distance:
            return
        m = self.model
        extent = float(m.stat.extent) if m.stat.extent > 0 else 1.0
        reach = self.radius_m * max(1.0, self.exaggeration)
        m.vis.map.znear = max(1e-3 * distance, 0.02 * max(distance - 2 * reach, 0.0)) / extent
        m.vis.map.zfar = (distance + 4 * reach) / extent
        px = 2 * distance * math.tan(math.radians(float(m.vis.global_.fovy)) / 2) / self.height
        m.tendon_width[:] = np.maximum(self._tendon_width0, _MIN_PX["tendon"] * px)
        self._active_width = np.maximum(self._tendon_width0, _MIN_PX["active"] * px)
        self._base_width = m.tendon_width.copy()
        if self.top_geoms is not None:
            g = self._node_sphere_geoms
            m.geom_size[g, 0] = self._geom_size0[g, 0]
            tg = self.top_geoms[m.geom_type[self.top_geoms] == int(mujoco.mjtGeom.mjGEOM_SPHERE)]
            m.geom_size[tg, 0] = np.maximum(self._geom_size0[tg, 0], _MIN_PX["top_node"] * px)
        self._configured_distance = distance

    def render(
        self, frame: int, *, view: CameraView, height_limit_m: float | None = None, cmap: str = DEFAULT_HEIGHT_CMAP
    ) -> np.ndarray:
        """Render frame number ``frame`` (position in the prepared ``indices``) without overlay.

        Args:
          frame: 0-based frame number.
          view: camera azimuth/elevation/distance.
          height_limit_m: node height [m] mapped to the colormap ends (default: the largest
            |height| over the prepared frames).
          cmap: matplotlib colormap name for node heights.

        Returns:
          (height, width, 3) uint8 image.
        """
        if self._indices is None:
            raise RuntimeError("RunScene.render: call prepare() first")
        if not 0 <= frame < self._indices.size:
            raise RenderError(f"frame: must be in [0, {self._indices.size}), got {frame!r}")
        m, d = self.model, self.data
        if self._renderer is None:
            max_geom = max(10000, 2 * (m.ngeom + m.nwrap + m.ntendon) + 1000)
            self._renderer = make_renderer(m, width=self.width, height=self.height, max_geom=max_geom)
            flags = self._renderer.scene.flags
            flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
            flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        self._configure(float(view.distance_m))
        i = int(self._indices[frame])

        self._positions(self.run.qpos[i])
        if self._shift is not None:
            shift = self._shift[frame]
            d.xpos[self.node_bodies] += shift
            d.xipos[self.node_bodies] += shift
            g = self._geom_nodes >= 0
            d.geom_xpos[g] += shift[self._geom_nodes[g]]
            s = self._site_nodes >= 0
            d.site_xpos[s] += shift[self._site_nodes[s]]
        self._finish_positions()

        if self.run.strut_activity is not None:
            act = self.run.strut_activity[i]
            rgba = self._tendon_rgba0.copy()
            rgba[act > 0] = ACTIVE_POS_RGBA
            rgba[act < 0] = ACTIVE_NEG_RGBA
            m.tendon_rgba[:] = rgba
            m.tendon_width[:] = np.where(act != 0, self._active_width, self._base_width)
        if self._heights is not None:
            lim = self.height_limit_m if height_limit_m is None else float(height_limit_m)
            h = self._heights[frame]
            u = 0.5 + 0.5 * h / lim if lim > 0 else np.full(h.shape, 0.5)
            m.geom_rgba[self.top_geoms] = _colormap(cmap)(np.clip(u, 0.0, 1.0))

        cam = self._camera
        cam.lookat[:] = self.lookat(frame, view)
        cam.distance = float(view.distance_m)
        cam.azimuth = float(view.azimuth_deg)
        cam.elevation = float(view.elevation_deg)
        self._renderer.update_scene(d, camera=cam, scene_option=self._option)
        return self._renderer.render()


# --------------------------------------------------------------------------- legend


def _colormap(name: str):
    """The matplotlib colormap ``name`` (a :class:`RenderError` naming ``height_cmap`` if unknown)."""
    try:
        return colormap(name)
    except OverlayError as exc:
        raise RenderError(str(exc)) from None


def _unique_rgb(rgba: np.ndarray, *, most: int = 3) -> tuple[tuple[float, float, float], ...]:
    """The distinct visible colours (alpha > 0) of the rows of ``rgba`` (n, 4), in order, at most ``most``."""
    out: list[tuple[float, float, float]] = []
    for row in np.asarray(rgba, dtype=float).reshape(-1, 4):
        colour = tuple(round(float(c), 3) for c in row[:3])
        if row[3] > 0 and colour not in out:
            out.append(colour)  # type: ignore[arg-type]
    return tuple(out[:most])  # type: ignore[return-value]


def _marker_parts(key: str, exists) -> list[str]:
    """The object names of a ``render.markers`` key: ``"ycoil/xcoil"`` → ``ycoil``, ``xcoil``;
    a later part that names nothing by itself replaces the tail of the first
    (``"axis_x/y/z"`` → ``axis_x``, ``axis_y``, ``axis_z``)."""
    first, *rest = key.split("/")
    parts = [first]
    for part in rest:
        parts.append(part if exists(part) or len(part) >= len(first) else first[: len(first) - len(part)] + part)
    return parts


class _ModelColours:
    """The colours of a model's named objects, for the legend: geoms, sites and tendons named
    ``name`` or ``name_<anything>``, and the geoms of a body named ``name``."""

    _KINDS = (
        ("geom", mujoco.mjtObj.mjOBJ_GEOM, "ngeom", "geom_rgba"),
        ("site", mujoco.mjtObj.mjOBJ_SITE, "nsite", "site_rgba"),
        ("tendon", mujoco.mjtObj.mjOBJ_TENDON, "ntendon", "tendon_rgba"),
    )

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        self.names = {
            kind: [mujoco.mj_id2name(model, obj, i) or "" for i in range(getattr(model, n))]
            for kind, obj, n, _ in self._KINDS
        }
        self.bodies = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or "": b for b in range(model.nbody)}

    def rgba(self, name: str) -> np.ndarray:
        """(n, 4) colours of the objects that ``name`` names (none: shape (0, 4))."""
        rows = []
        for kind, _, _, attr in self._KINDS:
            colours = getattr(self.model, attr)
            rows += [colours[i] for i, n in enumerate(self.names[kind]) if n == name or n.startswith(name + "_")]
        body = self.bodies.get(name)
        if body is not None and body > 0:
            rows += list(self.model.geom_rgba[self.model.geom_bodyid == body])
        return np.asarray(rows, dtype=float).reshape(-1, 4)

    def entry(self, key: str, text: str) -> LegendEntry | None:
        """The legend row of a ``render.markers`` entry (``None``: no object of the model matches)."""
        parts = _marker_parts(key, lambda n: self.rgba(n).size > 0)
        colours = _unique_rgb(np.concatenate([self.rgba(p) for p in parts]))
        return LegendEntry(colours, text) if colours else None


def _strut_colour_entries(entries: Sequence[Mapping]) -> list[LegendEntry]:
    """One legend row per colour of ``render.strut_colours``: its ``label``, else the current-loop
    axis (``x-loop circuits (4)``), else its ``name``."""
    groups: dict[tuple, list[Mapping]] = {}
    for entry in entries:
        groups.setdefault(tuple(np.round(np.asarray(entry["rgba"], float)[:3], 3)), []).append(entry)
    rows = []
    for colour, members in groups.items():
        first = members[0]
        if first.get("label"):
            text = str(first["label"])
        elif first.get("axis") in (0, 1, 2):
            text = f"{_AXES[int(first['axis'])]}-loop circuit" + (f"s ({len(members)})" if len(members) > 1 else "")
        else:
            text = ", ".join(str(m.get("name", "?")) for m in members[:3]) + (" …" if len(members) > 3 else "")
        rows.append(LegendEntry((colour,), text))
    return rows


# --------------------------------------------------------------------------- argument checks


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)


def _check_int(name: str, value: object, *, minimum: int, even: bool = False) -> int:
    """``value`` as an int >= ``minimum`` (even when ``even``), else a :class:`RenderError` naming it."""
    ok = _is_number(value) and math.isfinite(float(value)) and float(value) == int(value)
    if not ok or int(value) < minimum or (even and int(value) % 2):
        kind = "an even integer" if even else "an integer"
        raise RenderError(f"{name}: must be {kind} >= {minimum}{' (H.264 yuv420p)' if even else ''}, got {value!r}")
    return int(value)


def _run_dirs(run_dir: str | os.PathLike, compare: str | os.PathLike | None) -> list[Path]:
    """``[run_dir]`` or ``[run_dir, compare]`` as paths; an empty path is a :class:`RenderError`
    (``Path("")`` would silently mean the current folder)."""
    for name, value in (("run_dir", run_dir), ("compare", compare)):
        if value is not None and not str(os.fspath(value)).strip():
            raise RenderError(f"{name}: must be a run folder, got an empty path")
    return [Path(run_dir)] + ([Path(compare)] if compare is not None else [])


def _check_out_path(out_path: str | os.PathLike) -> Path:
    """The output video path: non-empty, ``.mp4``, not a folder, below a writable folder (or one
    that can be created: its nearest existing ancestor is a writable folder)."""
    text = os.fspath(out_path)
    if not str(text).strip():
        raise RenderError("out_path: must be a file path ending in '.mp4', got an empty path")
    out = Path(out_path)
    if out.suffix.lower() != ".mp4":
        raise RenderError(f"out_path: only MP4 video (H.264) is written; the path must end in '.mp4', got {str(out)!r}")
    if out.is_dir():
        raise RenderError(f"out_path: {str(out)!r} is a folder; give a file path ending in '.mp4'")
    for parent in out.absolute().parents:
        if not parent.exists():
            continue
        if not parent.is_dir():
            raise RenderError(f"out_path: {str(parent)!r} is a file, so {str(out)!r} cannot be written below it")
        if not os.access(parent, os.W_OK | os.X_OK):
            raise RenderError(f"out_path: folder {str(parent)!r} is not writable")
        try:  # access() says yes to root everywhere, also where no file can be made (/proc)
            with tempfile.TemporaryFile(dir=parent):
                pass
        except OSError as err:
            raise RenderError(f"out_path: folder {str(parent)!r} is not writable ({err.strerror})") from None
        break
    return out


def _check_render_memory(run_dirs: Sequence[Path], *, max_frames: int, width: int, height: int) -> None:
    """Refuse a render whose estimated memory (:func:`magsail_mj.resources.render_bytes`) is above
    the limit, before anything is loaded. Files that cannot be sized are left to :func:`load_run`."""
    series = model = block = 0.0
    nbody = 1
    for folder in run_dirs:
        npz, xml = folder / "timeseries.npz", folder / "model.xml"
        if (folder / STORE_NAME).is_dir():
            with contextlib.suppress(RecordStoreError):  # an unreadable store is load_run's to name
                block += chunk_block_bytes(lazy_arrays(folder))
        try:
            series += npz_array_bytes(npz) if npz.is_file() else 0.0
            if xml.is_file():
                m_bytes, m_body = mjcf_model_bytes(xml)
                model, nbody = model + m_bytes, max(nbody, m_body)
        except (OSError, ValueError, EOFError, zipfile.BadZipFile):
            continue
    estimate = render_bytes(
        frames=max_frames,
        width=width,
        height=height,
        panels=len(run_dirs),
        nbody=nbody,
        series_bytes=series,
        model_bytes=model,
        records_block_bytes=block,
    )
    check_memory(
        estimate, what=f"render {', '.join(str(p) for p in run_dirs)} ({max_frames} frames of {width} x {height} px)"
    )


# --------------------------------------------------------------------------- public API


@dataclass(frozen=True, kw_only=True)
class FrameOptions:
    """What the frames of a render show: the options of :func:`render_frames` and
    :func:`render_run` (besides the output ones).

    Attributes:
      compare: a second run folder, rendered beside the first with the same camera and frame
        times; the frames are then ``2 * width`` wide.
      labels: one label per panel (default with ``compare``: the run folder names; without:
        none).
      width: width of one panel [px] (even for a video).
      height: height [px] (even for a video).
      max_frames: the recorded frames are subsampled uniformly to at most this many.
      exaggeration: out-of-plane exaggeration factor k (default: manifest
        ``render.exaggeration``, else 1). Each truss node's deviation from the best-fit plane
        of all nodes, less its layer's mean (so the layer spacing is kept), is multiplied by k.
      camera: ``{"azimuth_deg", "elevation_deg", "distance_m"}`` (any subset) overriding the
        manifest's ``render.camera`` and the defaults (azimuth 180°, elevation −30°, distance
        at which the structure fits the area the overlay leaves free over the whole run),
        MuJoCo free-camera convention.
      height_cmap: matplotlib diverging colormap for top-node heights.
      antialias: 4x multisampling; ``False`` renders about twice as fast in software.
      render_info: the render table of the run (title, overlay, camera, ...) to use instead of
        its manifest's ``render`` entry; ``manifest.json`` is then optional (``run_scenario``
        renders the video before it writes the manifest).
    """

    compare: str | os.PathLike | None = None
    labels: Sequence[str] | None = None
    width: int = 960
    height: int = 540
    max_frames: int = 600
    exaggeration: float | None = None
    camera: Mapping[str, float] | None = None
    height_cmap: str = DEFAULT_HEIGHT_CMAP
    antialias: bool = True
    render_info: Mapping | None = None


def _frame_options(options: Mapping[str, Any]) -> FrameOptions:
    """``options`` as :class:`FrameOptions`; an unknown name is a :class:`RenderError` naming it."""
    allowed = FrameOptions.__dataclass_fields__
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise RenderError(f"{unknown[0]}: unknown render option; allowed: {', '.join(allowed)}")
    return FrameOptions(**options)


def _widest_lines(run: RunData, frame_t: np.ndarray) -> list[str]:
    """The time line and each overlay series' line at its longest over the run (sampled at up to
    nine records and the last frame time), for the overlay's reserved area."""
    picks = np.unique(np.linspace(0, run.t.size - 1, min(run.t.size, 9)).round().astype(np.int64))
    times = [format_time(float(t)) for t in (*run.t[picks], frame_t[-1])]
    lines = [max(times, key=len)]
    for name, values in run.series.items():
        texts = [format_value(name, values[i], names=run.names, units=run.units, labels=run.labels) for i in picks]
        lines.append(max(texts, key=len))
    return lines


def _frame_scenes(
    runs: Sequence[RunData],
    scenes: Sequence[RunScene],
    *,
    camera: Mapping | None,
    ended: Sequence[np.ndarray],
    frame_t: np.ndarray,
    legends: Sequence[list[LegendEntry]],
    labels: Sequence[str | None],
    ks: Sequence[float],
    bar: ColourBar | None,
) -> CameraView:
    """The common camera view of the panels, each structure framed in its panel's free area.

    Each panel's overlay (:func:`magsail_mj.render.overlay.overlay_boxes`, with its longest
    lines) leaves free rectangles; each scene takes the one in which its structure, over all its
    frames, is drawn largest (:meth:`RunScene.fit_distance`) and centres its frames there. The
    camera distance is the largest the panels need, or the ``camera`` argument's ``distance_m``
    when given; a manifest's ``render.camera.distance_m`` is kept when it is farther (the
    scenario's chosen view), never closer than the structure fits."""
    explicit = _check_camera(camera, "camera")
    settings = {**runs[0].camera, **explicit}
    view = CameraView(
        azimuth_deg=settings.get("azimuth_deg", DEFAULT_AZIMUTH_DEG),
        elevation_deg=settings.get("elevation_deg", DEFAULT_ELEVATION_DEG),
    )
    needed = []
    for run, scene, end, legend, label, k in zip(runs, scenes, ended, legends, labels, ks):
        w, h = scene.width, scene.height
        shows_end = bool(end.any()) or run.ended_early
        text = _panel_text(
            run, legend=legend, exaggeration=k, label=label, bar=bar if scene.top_bodies is not None else None
        )
        boxes = overlay_boxes(w, h, text, lines=_widest_lines(run, frame_t), ended=shows_end)
        # clear of the overlay by a small gap and by the largest drawn node radius (render-only floor)
        margin = max(2.0, h / 60) + _MIN_PX["top_node"]
        rects = free_rectangles(w, h, boxes, margin=margin) or [(margin, margin, w - margin, h - margin)]
        ndc = [_ndc(r, w, h) for r in rects]
        distances = scene.fit_distance(view, ndc)
        scene.release_fit_points()
        best = int(np.argmin(distances))
        x_lo, x_hi, y_lo, y_hi = ndc[best]
        scene.set_frame_centre(((x_lo + x_hi) / 2, (y_lo + y_hi) / 2))
        needed.append(distances[best])
    distance = explicit.get("distance_m") or max(max(needed), runs[0].camera.get("distance_m", 0.0))
    if not math.isfinite(distance):
        distance = max(s.auto_distance_m for s in scenes)
    return CameraView(azimuth_deg=view.azimuth_deg, elevation_deg=view.elevation_deg, distance_m=float(distance))


def _panel_labels(runs: Sequence[RunData], labels: Sequence[str] | None) -> list[str | None]:
    if labels is None:
        return [r.run_dir.resolve().name for r in runs] if len(runs) > 1 else [None]
    if isinstance(labels, str) or len(labels) != len(runs):
        raise RenderError(f"labels: expected {len(runs)} label(s), one per run, got {labels!r}")
    return [str(x) for x in labels]


def _compose(
    run: RunData,
    scene: RunScene,
    image: np.ndarray,
    *,
    record: int,
    ended: bool,
    legend: list[LegendEntry],
    exaggeration: float,
    label: str | None,
    bar: ColourBar | None,
) -> np.ndarray:
    """One panel: the rendered ``image`` of record ``record`` with its overlay."""
    last = record == run.t.size - 1 and run.ended_early  # a run that failed, diverged or stopped
    text = _panel_text(
        run,
        legend=legend,
        exaggeration=exaggeration,
        label=label,
        bar=bar if scene.top_bodies is not None else None,
        inset_upto=record,
    )
    values = [
        format_value(n, s[record], names=run.names, units=run.units, labels=run.labels) for n, s in run.series.items()
    ]
    return draw_overlay(image, text, time_s=float(run.t[record]), ended=ended or last, values=values)


def _panel_text(
    run: RunData,
    *,
    legend: list[LegendEntry],
    exaggeration: float,
    label: str | None,
    bar: ColourBar | None,
    inset_upto: int = 0,
) -> PanelText:
    """The overlay text of a run's panel (its inset drawn up to record ``inset_upto``)."""
    return PanelText(
        title=run.title,
        end_line=run.end_line,
        legend=legend,
        identity=run.identity,
        exaggeration=exaggeration,
        label=label,
        colour_bar=bar,
        inset=Inset(run.inset[0], run.t, run.inset[1], inset_upto) if run.inset is not None else None,
        names=run.names,
        units=run.units,
    )


def render_frames(run_dir: str | os.PathLike, **options: Any) -> Iterator[np.ndarray]:
    """Yield the finished video frames of a run (or of two runs side by side).

    ``options``: the fields of :class:`FrameOptions` (``compare``, ``labels``, ``width``,
    ``height``, ``max_frames``, ``exaggeration``, ``camera``, ``height_cmap``, ``antialias``,
    ``render_info``). Each frame is ``(height, width * n_runs, 3)`` uint8. The OpenGL contexts
    are released when the generator is exhausted or closed.
    """
    opt = _frame_options(options)
    for name, value in (("width", opt.width), ("height", opt.height)):
        _check_int(name, value, minimum=16)
    exaggeration = opt.exaggeration
    if exaggeration is not None and not (_is_number(exaggeration) and math.isfinite(exaggeration) and exaggeration > 0):
        raise RenderError(f"exaggeration: must be > 0, got {exaggeration!r}")
    _colormap(opt.height_cmap)
    ensure_gl_backend()
    run_dirs = _run_dirs(run_dir, opt.compare)
    runs = [
        load_run(p, name=n, render_info=info)
        for p, n, info in zip(run_dirs, ("run_dir", "compare"), (opt.render_info, None))
    ]
    labels = _panel_labels(runs, opt.labels)
    frame_t, indices, ended = frame_plan([r.t for r in runs], max_frames=opt.max_frames)

    with contextlib.ExitStack() as stack:
        scenes = [
            stack.enter_context(RunScene(r, width=int(opt.width), height=int(opt.height), antialias=opt.antialias))
            for r in runs
        ]
        ks = []
        for run, scene, idx in zip(runs, scenes, indices):
            k = exaggeration if exaggeration is not None else (runs[0].exaggeration or 1.0)
            if k != 1.0 and scene.node_bodies.size < 3 and exaggeration is None:
                warnings.warn(
                    f"{run.run_dir}: manifest exaggeration {k:g} ignored: the model has no flexible structure",
                    RuntimeWarning,
                    stacklevel=2,
                )
                k = 1.0
            scene.prepare(idx, exaggeration=k)
            ks.append(k)
        limits = [s.height_limit_m for s in scenes if s.top_bodies is not None]
        bar = ColourBar(opt.height_cmap, max(limits)) if limits else None
        legends = [scene.legend() for scene in scenes]
        view = _frame_scenes(
            runs,
            scenes,
            camera=opt.camera,
            ended=ended,
            frame_t=frame_t,
            legends=legends,
            labels=labels,
            ks=ks,
            bar=bar,
        )
        for f in range(frame_t.size):
            panels = [
                _compose(
                    run,
                    scene,
                    scene.render(f, view=view, height_limit_m=bar and bar.limit_m, cmap=opt.height_cmap),
                    record=int(idx[f]),
                    ended=bool(end[f]),
                    legend=legend,
                    exaggeration=k,
                    label=label,
                    bar=bar,
                )
                for run, scene, idx, end, k, label, legend in zip(runs, scenes, indices, ended, ks, labels, legends)
            ]
            yield panels[0] if len(panels) == 1 else np.concatenate(panels, axis=1)


def render_run(
    run_dir: str | os.PathLike,
    out_path: str | os.PathLike,
    *,
    fps: float = 30,
    crf: float = 20.0,
    progress: bool = False,
    verify: bool = True,
    **options: Any,
) -> Path:
    """Render a run folder to a browser-playable MP4 (H.264, yuv420p), written atomically.

    Args:
      run_dir: run folder (``model.xml``, ``timeseries.zarr`` or ``timeseries.npz``,
        ``manifest.json``).
      out_path: output ``.mp4`` path (folder created if missing; replaced atomically).
      fps: playback frames per second.
      crf: x264 quality (lower is better and larger).
      progress: show a tqdm progress bar.
      verify: check every folder against its ``manifest.json`` first
        (:func:`magsail_mj.integrity.verify_run_folder`: no file edited, missing or truncated, no
        record chunk deleted); ``False`` only for the run that is writing the folder now.
      options: what the frames show, the fields of :class:`FrameOptions`: ``compare``,
        ``labels``, ``width`` (960, even), ``height`` (540, even), ``max_frames`` (600),
        ``exaggeration``, ``camera``, ``height_cmap`` (``"PuOr_r"``), ``antialias`` (True),
        ``render_info``.

    Returns:
      the path of the written video.

    Raises:
      RenderError: an argument, a run folder or one of its files is missing or invalid (the
        message starts with the argument's name), or the render needs more memory than
        :func:`magsail_mj.resources.check_memory` allows
        (:class:`magsail_mj.resources.MemoryLimitError`, also a ``ValueError``).
      magsail_mj.render.backend.GLBackendError: no OpenGL backend works.
    """
    out_path = _check_out_path(out_path)
    opt = _frame_options(options)
    n_panels = 1 if opt.compare is None else 2
    for name, value in (("width", opt.width), ("height", opt.height)):
        _check_int(name, value, minimum=16, even=True)
    _check_int("max_frames", opt.max_frames, minimum=1)
    if not (_is_number(fps) and math.isfinite(fps) and fps > 0):
        raise RenderError(f"fps: must be a finite number > 0, got {fps!r}")
    run_dirs = _run_dirs(run_dir, opt.compare)
    if verify:  # a folder that is missing is named as such below
        for name, folder in [(n, f) for n, f in zip(("run_dir", "compare"), run_dirs) if f.is_dir()]:
            try:
                verify_run_folder(folder)
            except IntegrityError as err:
                raise RenderError(f"{name}: {err}") from None
    _check_render_memory(run_dirs, max_frames=int(opt.max_frames), width=int(opt.width), height=int(opt.height))
    frames = render_frames(run_dir, **options)
    with contextlib.closing(frames):
        iterator: Iterator[np.ndarray] = frames
        if progress:
            iterator = tqdm(frames, desc=f"render {Path(run_dir).name}", unit="frame")
        with Mp4Writer(out_path, width=int(opt.width) * n_panels, height=int(opt.height), fps=fps, crf=crf) as writer:
            for frame in iterator:
                writer.add(frame)
    return out_path
