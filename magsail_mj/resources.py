"""Memory bounds: estimate what an input needs before allocating it, refuse it above a limit.

Every ``magsail`` verb estimates, from its validated inputs and without building anything, the
memory the work will allocate, and calls :func:`check_memory`, which raises
:class:`MemoryLimitError` (a ``ValueError``; the CLI exits 2) when the estimate is above the
limit. The limit is, in order: the ``limit`` argument; the value set by :func:`memory_limit`
(the CLI's ``--memory-limit``); the environment variable ``MAGSAIL_MEMORY_LIMIT``; the memory
the machine has available now (``MemAvailable`` of ``/proc/meminfo``). A limit is a number of
bytes (suffixes ``K``, ``M``, ``G``, ``T`` in powers of 1024 accepted) or ``auto`` (available
memory).

Estimates:

* :func:`estimate_model_bytes` — the model of a config. Lattices (truss and current loops,
  :func:`lattice_model_bytes`): MuJoCo's model and data buffers (fitted to ``MjModel.nbuffer +
  MjData.nbuffer`` for N = 3 … 24, both diagonal patterns: within 1 %), the arena the lattice
  builder sets (:func:`magsail_mj.lattice.mjcf.lattice_arena_bytes`, linear in ``nv``), the model
  building and the loads (16 kB per dof: the resident memory grows by 15 kB per dof from
  nv = 732 to 39 372) and, for the current loops, the dense modal matrices of the Caughey damping
  (62 B·nv²: the traced peak grows by 40 B·nv² from N = 12 to 27). Any structure's model
  (:func:`structure_model_bytes`, from its node and member counts or its model's counts): the
  same arena and build terms, buffers fitted with a body and a mass-matrix term (beam chains).
  The rigid reflector, CNUSAIL and MSAC models keep MuJoCo's default arena, which grows with
  ``nv²``: :func:`mujoco_bytes`, fitted to ``MjModel.nbuffer + MjData.nbuffer + MjData.narena``
  of default-arena builds (≈ 14.7 MB for these). Lattice node and strut counts come from ``lattice.units`` by formula
  (:func:`lattice_counts`), the reflector's coil paths from ``plate.side_m / plate.cell_m``
  (:func:`coil_report_bytes`). A config with a ``model_counts()`` method (the structure concept,
  which reads its structure at validation) gives its ``(nv, nbody, ntendon)`` itself and is
  estimated as a lattice (the same builder's explicit arena).
* :func:`estimate_run_bytes` — the model plus the records of a run, ``duration / timestep /
  record_every`` records of :func:`record_bytes` each (kept as per-record arrays, then stacked),
  plus the larger of its post-processing (:func:`postprocess_bytes`) and the export of its
  records (:func:`export_bytes`): every allocation that grows with the records or the structure.
* :func:`postprocess_bytes` — summary, series and plots of a finished (or failed) run: the
  per-record series and loaded probes (:data:`POSTPROCESS_PER_RECORD`: 5.4 kB measured for the
  truss detumble; a rigid model's ``qpos`` and ``qvel`` too), one block of the recorded positions with its
  temporaries (:func:`records_block_bytes` times :data:`POSTPROCESS_BLOCK_FACTOR`), the lattice's
  low modes (:data:`POSTPROCESS_PER_DOF`), the truss's surface-angle grid (at most
  :data:`SURFACE_ANGLE_MAX_BYTES` whatever the positions: a structure that blew up to 10¹⁰ m is
  evaluated on the same bounded grid) and the figures (:data:`POSTPROCESS_BASE_BYTES`).
  Fine time grids that grow with the duration (the truss's rigid reference at 0.01 s, the
  commanded impulse per step) are walked in fixed blocks and are not counted.
* :func:`export_bytes` — ``magsail export``: the records are streamed one chunk at a time (npz)
  or by Dask chunks (netCDF), :data:`EXPORT_CHUNKS_IN_FLIGHT` chunks of
  :func:`records_block_bytes` at once.
* :func:`coil_report_bytes` — the coil paths of ``magsail torque coil`` (their node counts by
  :func:`magsail_mj.geometry.reflector_coil.coil_node_count`).
* :func:`render_bytes` — a video render: the per-frame position arrays, the frames in flight,
  the run's time series and the model.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from magsail_mj.geometry.reflector_coil import coil_node_count
from magsail_mj.lattice.mjcf import lattice_arena_bytes

__all__ = [
    "ENV_VAR",
    "MemoryLimitError",
    "available_memory_bytes",
    "msac_drive_bytes",
    "check_memory",
    "coil_report_bytes",
    "estimate_model_bytes",
    "estimate_run_bytes",
    "export_bytes",
    "export_store_bytes",
    "explicit_arena_mujoco_bytes",
    "format_bytes",
    "lattice_counts",
    "lattice_model_bytes",
    "structure_model_bytes",
    "memory_limit",
    "memory_limit_bytes",
    "mjcf_arena_bytes",
    "mjcf_counts",
    "mjcf_model_bytes",
    "mujoco_bytes",
    "npz_array_bytes",
    "parse_memory_limit",
    "postprocess_bytes",
    "record_bytes",
    "records_block_bytes",
    "render_bytes",
]

#: Environment variable holding the default limit (bytes, with optional K/M/G/T suffix, or "auto").
ENV_VAR = "MAGSAIL_MEMORY_LIMIT"

# MjModel + MjData + default arena [bytes] ≈ BASE + PER_DOF nv + PER_DOF2 nv² (+ PER_TENDON, PER_BODY
# for the buffers), least-squares fit of 12 real builds (MuJoCo 4.0; see the module docstring).
_BASE_BYTES = 13.7e6
_PER_DOF = 53.3e3
_PER_DOF2 = 40.0
_PER_BODY = 4.0e3
_PER_TENDON = 0.4e3
# Lattice models (explicit arena): buffers ≈ 8.1 kB + 1 455 B nv + 588 B ntendon (least squares,
# N = 3 … 24, parity and X diagonals), rounded up; the build and loads per dof; the current loops'
# dense modal matrices per nv² (see the module docstring).
_LATTICE_BUFFER_BASE = 16e3
_LATTICE_BUFFER_PER_DOF = 1.5e3
_LATTICE_BUFFER_PER_TENDON = 0.6e3
_LATTICE_BUILD_PER_DOF = 16e3
_LOOPS_DENSE_PER_DOF2 = 62.0
# Structure models (build_structure_spec): buffers ≈ 16 kB + 1.2 kB nv + 0.4 kB nbody + 0.6 kB ntendon
# + 96 B nM, nM the non-zeros of MuJoCo's mass matrix (a kinematic chain of d dofs has d (d + 1) / 2):
# 1.04–1.19 times MjModel.nbuffer + MjData.nbuffer of strut plates (32–4 232 nodes), beam
# cantilevers (20–200 beams), a rigid hub with two booms (5–100 beams each) and the four-boom sail.
_STRUCTURE_BUFFER_BASE = 16e3
_STRUCTURE_BUFFER_PER_DOF = 1.2e3
_STRUCTURE_BUFFER_PER_BODY = 0.4e3
_STRUCTURE_BUFFER_PER_TENDON = 0.6e3
_STRUCTURE_BUFFER_PER_MASS_NNZ = 96.0
# Python-side bytes per coil-path node (fitted with tracemalloc: the estimate is 1.14 × the measured
# peak at d/L = 100 … 200): the tuples of coil_y's list, and the float arrays of the paths.
_COIL_LIST_NODE = 96
_COIL_ARRAY_NODE = 48
_SUFFIX = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
_LIMIT_RE = re.compile(r"\s*(\d+(?:\.\d*)?(?:[eE]\d+)?)\s*([KMGT]?)(?:i?B)?\s*\Z", re.IGNORECASE)
_override: int | None = None


class MemoryLimitError(ValueError):
    """The memory an input needs (estimated before allocating it) is above the limit."""


# --------------------------------------------------------------------------- the limit


def available_memory_bytes() -> int:
    """Memory available for new allocations now [bytes]: ``MemAvailable`` of ``/proc/meminfo``,
    else free physical pages (``os.sysconf``), else 4 GiB when neither can be read."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (OSError, ValueError, AttributeError):
        return 4 << 30


def parse_memory_limit(text: str, *, what: str = "--memory-limit") -> int | None:
    """Parse a limit: ``auto`` → ``None`` (available memory), else bytes (``2G``, ``512M``,
    ``1e9``) → int >= 1. ``what`` names the option in the error."""
    text = str(text)
    if text.strip().lower() == "auto":
        return None
    match = _LIMIT_RE.match(text)
    if match is None:
        raise ValueError(f"{what}: expected a number of bytes (suffix K, M, G or T allowed) or 'auto', got {text!r}")
    value = float(match.group(1)) * _SUFFIX[match.group(2).upper()]
    if not (math.isfinite(value) and 1 <= value < 2**63):
        raise ValueError(f"{what}: must be between 1 byte and 8 EiB, got {text!r}")
    return int(value)


@contextlib.contextmanager
def memory_limit(limit: int | None) -> Iterator[None]:
    """Within the block, :func:`check_memory` uses ``limit`` [bytes] (``None``: no override)."""
    global _override
    if limit is not None and (int(limit) != limit or limit < 1):
        raise ValueError(f"limit: must be an integer >= 1 byte or None, got {limit!r}")
    previous, _override = _override, (None if limit is None else int(limit))
    try:
        yield
    finally:
        _override = previous


def memory_limit_bytes(limit: int | None = None) -> int:
    """The limit in force [bytes]: ``limit``, else :func:`memory_limit`'s, else ``$MAGSAIL_MEMORY_LIMIT``,
    else :func:`available_memory_bytes`."""
    if limit is not None:
        if int(limit) != limit or limit < 1:
            raise ValueError(f"limit: must be an integer >= 1 byte, got {limit!r}")
        return int(limit)
    if _override is not None:
        return _override
    env = os.environ.get(ENV_VAR, "").strip()
    parsed = parse_memory_limit(env, what=ENV_VAR) if env else None
    return available_memory_bytes() if parsed is None else parsed


def format_bytes(n: float) -> str:
    """``1.5 GiB``-style text of a byte count."""
    n = float(n)
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(n) < 1024 or unit == "PiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} EiB"  # pragma: no cover - unreachable


def check_memory(estimate_bytes: float, *, what: str, limit: int | None = None) -> int:
    """Refuse work whose estimated memory is above the limit.

    Args:
      estimate_bytes: the estimate [bytes] (may be huge or ``inf``; never allocated).
      what: what needs it, named in the message (e.g. ``"torque coil --side-m 1e6 --segment-m 0.001"``).
      limit: limit [bytes] (default: :func:`memory_limit_bytes`).

    Returns:
      the estimate, as an int (``estimate_bytes`` rounded up).

    Raises:
      MemoryLimitError: the estimate is above the limit (message: the estimate, the limit, and how
        to change the limit).
    """
    lim = memory_limit_bytes(limit)
    est = float(estimate_bytes)
    if math.isnan(est) or est < 0:
        raise ValueError(f"estimate_bytes: must be >= 0, got {estimate_bytes!r}")
    if est > lim:
        raise MemoryLimitError(
            f"{what}: needs about {format_bytes(est)} of memory (estimated before allocating), above the "
            f"limit of {format_bytes(lim)}; make the input smaller, or raise the limit with "
            f"--memory-limit BYTES or {ENV_VAR}"
        )
    return math.ceil(est)


# --------------------------------------------------------------------------- estimates


def lattice_counts(units: int, *, diagonals: str = "parity") -> tuple[int, int]:
    """``(nodes, struts)`` of the two-layer lattice of ``units`` × ``units`` cubes
    (:func:`magsail_mj.lattice.geometry.make_lattice`), by formula, without building it.

    With ``n = units``, ``N = n + 1``: nodes ``2 N²``; struts ``4 n N`` cube edges in x and y,
    ``N²`` verticals and one diagonal per face (``2 n²`` top/bottom, ``2 n N`` vertical faces),
    two per face with ``diagonals = "X"``.
    """
    n = int(units)
    if n != units or n < 1:
        raise ValueError(f"units: must be an integer >= 1, got {units!r}")
    N = n + 1
    faces = 2 * n * n + 2 * n * N
    return 2 * N * N, 4 * n * N + N * N + faces * (2 if diagonals == "X" else 1)


def mujoco_bytes(*, nv: int, nbody: int, ntendon: int = 0) -> float:
    """MjModel + MjData (with MuJoCo's default arena) of a model with ``nv`` degrees of freedom,
    ``nbody`` bodies and ``ntendon`` tendons [bytes] (fit; see the module docstring)."""
    nv, nbody, ntendon = float(nv), float(nbody), float(ntendon)
    return _BASE_BYTES + _PER_DOF * nv + _PER_DOF2 * nv * nv + _PER_BODY * nbody + _PER_TENDON * ntendon


def explicit_arena_mujoco_bytes(*, nv: int, ntendon: int, arena_bytes: float) -> float:
    """MjModel + MjData of a model whose arena is set explicitly (``<size memory>``) [bytes]: the
    buffers (fit; see the module docstring) plus ``arena_bytes``."""
    buffers = _LATTICE_BUFFER_BASE + _LATTICE_BUFFER_PER_DOF * float(nv) + _LATTICE_BUFFER_PER_TENDON * float(ntendon)
    return buffers + float(arena_bytes)


def lattice_model_bytes(*, nv: int, ntendon: int, dense_modes: bool = False) -> float:
    """Memory of a lattice model with ``nv`` degrees of freedom and ``ntendon`` struts [bytes]:
    MuJoCo's model and data with the arena the lattice builder sets, the build and loads, and with
    ``dense_modes`` (current loops) the dense modal matrices (see the module docstring)."""
    nv_f = float(nv)
    mujoco_part = explicit_arena_mujoco_bytes(nv=nv, ntendon=ntendon, arena_bytes=lattice_arena_bytes(int(nv)))
    modes = _LOOPS_DENSE_PER_DOF2 * nv_f * nv_f if dense_modes else 0.0
    return mujoco_part + _LATTICE_BUILD_PER_DOF * nv_f + modes


def structure_model_bytes(
    *,
    n_nodes: int,
    n_members: int,
    nv: int | None = None,
    nbody: int | None = None,
    ntendon: int | None = None,
    mass_nnz: int | None = None,
    arena_bytes: int | None = None,
) -> float:
    """Memory of the model :func:`magsail_mj.structure.mjcf.build_structure_spec` builds [bytes]:
    MuJoCo's model and data buffers (``16 kB + 1.2 kB nv + 0.4 kB nbody + 0.6 kB ntendon + 96 B
    mass_nnz``, fitted as the comment above says), the arena the builder sets
    (:func:`~magsail_mj.lattice.mjcf.lattice_arena_bytes` of ``nv``: linear in ``nv``, where
    MuJoCo's default grows with ``nv²``) and the build (the MjSpec and the structure's arrays, 16 kB
    per dof as for the lattices).

    The counts default to a structure of free particles joined by struts and cables: ``nv = 3
    n_nodes``, ``nbody = n_nodes + 1``, ``ntendon = n_members`` and ``mass_nnz = 2 nv`` (a node's
    three slide dofs are chained: 6 non-zeros). Beams make chains: give the counts of the model
    (``mass_nnz`` is MuJoCo's ``nM``, ``d (d + 1) / 2`` for a chain of ``d`` dofs), and
    ``arena_bytes``, the arena the builder set (``MjModel.narena``: more than the struts' when
    beam cycles are welded), when known.

    Raises:
      ValueError: a count that is not an integer >= 0 (named).
    """
    counts = {"n_nodes": n_nodes, "n_members": n_members, "nv": nv, "nbody": nbody, "ntendon": ntendon}
    counts["mass_nnz"] = mass_nnz
    counts["arena_bytes"] = arena_bytes
    for label, value in counts.items():
        if value is not None and (isinstance(value, bool) or int(value) != value or value < 0):
            raise ValueError(f"{label}: must be an integer >= 0, got {value!r}")
    dofs = 3 * int(n_nodes) if nv is None else int(nv)
    bodies = int(n_nodes) + 1 if nbody is None else int(nbody)
    tendons = int(n_members) if ntendon is None else int(ntendon)
    nnz = 2 * dofs if mass_nnz is None else int(mass_nnz)
    buffers = (
        _STRUCTURE_BUFFER_BASE
        + _STRUCTURE_BUFFER_PER_DOF * dofs
        + _STRUCTURE_BUFFER_PER_BODY * bodies
        + _STRUCTURE_BUFFER_PER_TENDON * tendons
        + _STRUCTURE_BUFFER_PER_MASS_NNZ * nnz
    )
    arena = lattice_arena_bytes(dofs) if arena_bytes is None else int(arena_bytes)
    return buffers + float(arena) + _LATTICE_BUILD_PER_DOF * dofs


def coil_report_bytes(*, side_m: float, segment_m: float, pitch_cells: int = 2, rows: int | None = None) -> float:
    """Peak memory of the coil paths of :func:`magsail_mj.analysis.coil_torque.coil_torque_report`
    [bytes]: y-, x-coil, the p = 1 and rows + 1 variants and two square loops, estimated from their
    node counts. ``inf`` when ``side_m / segment_m`` overflows."""
    ratio = float(side_m) / float(segment_m)
    if not math.isfinite(ratio) or ratio > 1e15:
        return math.inf
    n = max(1, round(ratio))
    p = max(1, int(pitch_cells))
    n_row = n if rows is None else max(1, int(rows))
    counts = [
        coil_node_count(n, p=p, n_row=n_row),
        coil_node_count(n, p=p, n_row=n_row),
        coil_node_count(n, p=1, n_row=n_row),
        coil_node_count(n, p=p, n_row=n + 1),
        4 * n + 1,
        4 * n + 1,
    ]
    counts = [max(c, 1) for c in counts]
    return float(_COIL_ARRAY_NODE * sum(counts) + _COIL_LIST_NODE * max(counts))


def _is_lattice(cfg: Any) -> bool:
    """Whether a validated config builds a spring lattice (truss, flexible current-loop plate) or
    another model with the lattice builder's explicit arena, whose config counts its own model
    (``model_counts()``: the structure concept's)."""
    if callable(getattr(cfg, "model_counts", None)):
        return True
    concept = getattr(cfg, "concept", "")
    rigid = concept == "current_loops" and getattr(cfg, "scenario", "") == "slew_rigid"
    return (
        concept in ("truss_magnetorquer", "current_loops") and getattr(cfg, "lattice", None) is not None and not rigid
    )


def _model_counts(cfg: Any) -> tuple[int, int, int]:
    """``(nv, nbody, ntendon)`` a validated config implies, from its size keys only (or from its
    own ``model_counts()``, counted from the structure it read without building the model)."""
    counts = getattr(cfg, "model_counts", None)
    if callable(counts):
        return counts()
    if _is_lattice(cfg):
        lattice = cfg.lattice
        nodes, struts = lattice_counts(lattice.units, diagonals=getattr(lattice, "diagonals", "parity"))
        return 3 * nodes + 6, nodes + 1, struts
    return 24, 10, 0  # the rigid models: a bus with a few bodies (reflector, CNUSAIL, MSAC)


def estimate_model_bytes(cfg: Any) -> float:
    """Memory the model of a validated config needs [bytes], without building it: a lattice's
    :func:`lattice_model_bytes`, else MuJoCo's model, data and default arena (:func:`mujoco_bytes`)
    from the implied counts; plus the reflector's coil paths and the environment grid."""
    nv, nbody, ntendon = _model_counts(cfg)
    own = getattr(cfg, "model_bytes", None)
    if callable(own):  # a config that compiled its own model in validation (the structure concept)
        total = float(own())
    elif _is_lattice(cfg):
        dense = getattr(cfg, "concept", "") == "current_loops"
        total = lattice_model_bytes(nv=nv, ntendon=ntendon, dense_modes=dense)
    else:
        total = mujoco_bytes(nv=nv, nbody=nbody, ntendon=ntendon)
    plate, coil = getattr(cfg, "plate", None), getattr(cfg, "coil", None)
    if getattr(cfg, "concept", "") == "reflector" and plate is not None and coil is not None:
        total += coil_report_bytes(
            side_m=plate.side_m, segment_m=plate.cell_m, pitch_cells=coil.pitch_cells, rows=coil.rows
        )
    return total + environment_bytes(cfg) + msac_drive_bytes(cfg)


#: bytes per step of the MSAC drive's rollout chunk: its controls, states and sensor data (8 + 26 +
#: 10 doubles for the two-wing model, rounded up to 64 doubles)
MSAC_CHUNK_STEP_BYTES = 64 * 8.0
#: bytes per step of the MSAC drive's computed-torque calibration: the four joint torques (4
#: doubles, counted twice for the held-torque table's copies)
MSAC_CALIBRATION_STEP_BYTES = 8 * 8.0


def msac_drive_bytes(cfg: Any) -> float:
    """Memory of the MSAC drive's buffers [bytes]: ``drive.chunk_cycles`` cycles of
    :data:`MSAC_CHUNK_STEP_BYTES` and ``drive.calibration_cycles`` cycles of
    :data:`MSAC_CALIBRATION_STEP_BYTES`, at ``N = 1 / (cycle.frequency_Hz · sim.timestep_s)`` steps a
    cycle; 0 for the other concepts. Both are allocated whole, however short the run."""
    drive, cycle, sim = getattr(cfg, "drive", None), getattr(cfg, "cycle", None), getattr(cfg, "sim", None)
    if getattr(cfg, "concept", "") != "msac" or drive is None or cycle is None or sim is None:
        return 0.0
    period_steps = float(cycle.frequency_Hz) * float(sim.timestep_s)  # the inverse of N
    steps = max(1.0, 1.0 / period_steps) if period_steps > 0 else math.inf
    chunk = float(drive.chunk_cycles) * steps * MSAC_CHUNK_STEP_BYTES
    return chunk + float(drive.calibration_cycles) * steps * MSAC_CALIBRATION_STEP_BYTES


#: peak memory per row of the environment's precompute grid (orbit, IGRF field, Sun, density and
#: their splines): 10.4–10.5 kB measured with tracemalloc for 2 000–8 000 rows, rounded up
ENVIRONMENT_ROW_BYTES = 12_000.0


def environment_bytes(cfg: Any) -> float:
    """Memory of the environment grid of an orbital config [bytes]: ``(duration + 2h) / h`` rows of
    :data:`ENVIRONMENT_ROW_BYTES` (``h = field.sample_step_s``); 0 for configs without one."""
    field, sim = getattr(cfg, "field", None), getattr(cfg, "sim", None)
    step = getattr(field, "sample_step_s", None)
    if getattr(cfg, "kind", None) == "lifetime":
        return 0.0  # the lifetime analysis propagates orbit elements; it samples no environment grid
    if not hasattr(cfg, "environment_config") or step is None or sim is None:
        return 0.0
    return (float(sim.duration_s) + 2.0 * float(step)) / float(step) * ENVIRONMENT_ROW_BYTES


def record_bytes(cfg: Any) -> float:
    """Bytes per record of a run: ``qpos``, ``qvel`` and one value per tendon (8 bytes each) and the
    per-record overhead of the probe arrays (2 KiB), counted twice (lists, then stacked)."""
    nv, _, ntendon = _model_counts(cfg)
    return 2.0 * (8.0 * (2 * nv + 1 + ntendon) + 2048.0)


def _record_count(cfg: Any) -> float:
    sim = getattr(cfg, "sim", None)
    if sim is None or getattr(cfg, "kind", None) == "lifetime":  # no MuJoCo records
        return 0.0
    every = float(getattr(sim, "record_every", 1) or 1)
    duration, step = float(sim.duration_s), float(sim.timestep_s)
    if not (step > 0 and every > 0) or math.isnan(duration):
        return math.inf
    return max(duration, 0.0) / step / every + 1.0


#: the most bytes of records post-processing reads at once (``magsail_mj.records.BLOCK_BYTES``,
#: mirrored so that estimating imports no Zarr; tests/test_memory_bounds.py checks they agree)
RECORDS_BLOCK_BYTES = 8 * 2**20
#: a record store's chunk of the widest variable: 4 MiB, at least 16 records
#: (``magsail_mj.records.Recorder``: ``chunk_bytes = 1 << 22``, ``min_chunk = 16``)
RECORDS_CHUNK_BYTES = 4 * 2**20
RECORDS_MIN_CHUNK = 16
#: bytes per record of the loaded probes (attitude, rates, field, torques, counts: about a hundred
#: numbers) and the derived series and their figures' copies (5.4 kB measured for the truss
#: detumble, 401 → 1 601 records), rounded up
POSTPROCESS_PER_RECORD = 8192.0
#: bytes of post-processing temporaries per byte of the block of recorded qpos read at once: the
#: node positions, strut lengths and strains, the failure check's tetrahedra, the best-fit rotation
#: of one block (traced 8.5 for the 10-unit truss, whose 401 records are one block), doubled
POSTPROCESS_BLOCK_FACTOR = 16.0
#: the lattice's low modes per degree of freedom (shift-invert Lanczos: SuperLU's factor, outside
#: tracemalloc, and the mode shapes; traced 3.7 kB, resident growth 5–15 kB per dof for
#: nv = 726 … 5 766), rounded up
POSTPROCESS_PER_DOF = 16e3
#: the figures, Matplotlib's own buffers and the fixed part of the summary (traced 14–20 MB for
#: the truss plots), rounded up
POSTPROCESS_BASE_BYTES = 64.0 * 2**20
#: the most the truss's surface-angle map allocates, whatever the node positions:
#: ``magsail_mj.concepts.truss_magnetorquer.surface_angle.surface_angle_bytes`` without the
#: per-node part (512² samples of 400 B and an 8 MiB hull block; mirrored so that estimating
#: imports no SciPy; tests/test_memory_bounds.py checks they agree)
SURFACE_ANGLE_MAX_BYTES = 512.0**2 * 400.0 + 8 * 2**20
_SURFACE_ANGLE_PER_NODE = 1024.0
#: record-store chunks in flight while exporting (npz: the chunk, its contiguous copy and its
#: bytes; netCDF: Dask reads and writes a few chunks at once), counted generously
EXPORT_CHUNKS_IN_FLIGHT = 8.0
#: xarray's and the zip writer's fixed part of an export
EXPORT_BASE_BYTES = 16.0 * 2**20


def _qpos_row_bytes(cfg: Any) -> float:
    """Bytes of one record of ``qpos`` (``nq = nv + 1``: a free joint's quaternion has 4 numbers)."""
    nv, _, _ = _model_counts(cfg)
    return 8.0 * (nv + 1)


def records_block_bytes(cfg: Any) -> float:
    """The most bytes of recorded ``qpos`` post-processing, rendering or export hold at once
    [bytes]: a block of rows of at most :data:`RECORDS_BLOCK_BYTES` (at least one row; all of them
    when the run is shorter) plus the store chunk decompressed to read it (4 MiB, at least 16
    rows): :func:`magsail_mj.records.row_blocks`."""
    row = _qpos_row_bytes(cfg)
    records = _record_count(cfg)
    block = min(records * row, max(float(RECORDS_BLOCK_BYTES), row))
    return block + max(float(RECORDS_CHUNK_BYTES), RECORDS_MIN_CHUNK * row)


def postprocess_bytes(cfg: Any) -> float:
    """Memory of the post-processing of a run of a validated config [bytes]: its summary, series
    and plots, for a completed or a failed run alike (see the module docstring): per record
    :data:`POSTPROCESS_PER_RECORD` (and a rigid model's ``qpos`` and ``qvel``, loaded whole, twice;
    a lattice's are read in blocks); one block of records (:func:`records_block_bytes`) times
    :data:`POSTPROCESS_BLOCK_FACTOR`; a lattice's modes (:data:`POSTPROCESS_PER_DOF`); the truss's
    surface-angle map (:data:`SURFACE_ANGLE_MAX_BYTES`, bounded whatever the positions); and
    :data:`POSTPROCESS_BASE_BYTES`. ``inf`` when the record count is."""
    records = _record_count(cfg)
    if records == 0.0:
        return 0.0  # no MuJoCo records: the lifetime analysis
    nv, nbody, _ = _model_counts(cfg)
    per_record = POSTPROCESS_PER_RECORD + (0.0 if _is_lattice(cfg) else 2.0 * 8.0 * (2 * nv + 1))
    total = POSTPROCESS_BASE_BYTES + records * per_record
    total += POSTPROCESS_BLOCK_FACTOR * records_block_bytes(cfg)
    if _is_lattice(cfg):
        total += POSTPROCESS_PER_DOF * nv
        if getattr(cfg, "concept", "") == "truss_magnetorquer":
            total += SURFACE_ANGLE_MAX_BYTES + _SURFACE_ANGLE_PER_NODE * (nbody - 1) / 2
    return total


def export_bytes(cfg: Any) -> float:
    """Memory of exporting a run's records (``magsail export``, npz or netCDF) [bytes]: they are
    streamed chunk by chunk, :data:`EXPORT_CHUNKS_IN_FLIGHT` blocks of
    :func:`records_block_bytes` at once, plus :data:`EXPORT_BASE_BYTES`; 0 for configs without
    records."""
    if _record_count(cfg) == 0.0:
        return 0.0
    return export_store_bytes(records_block_bytes(cfg))


def export_store_bytes(block_bytes: float) -> float:
    """Memory of exporting a store whose largest read is ``block_bytes`` (a chunk's rows of its
    widest variable: :func:`magsail_mj.records.chunk_block_bytes`) [bytes]:
    :data:`EXPORT_BASE_BYTES` plus :data:`EXPORT_CHUNKS_IN_FLIGHT` such blocks."""
    return EXPORT_BASE_BYTES + EXPORT_CHUNKS_IN_FLIGHT * float(block_bytes)


def estimate_run_bytes(cfg: Any) -> float:
    """Memory a run of a validated config needs [bytes]: :func:`estimate_model_bytes`, the records
    (``duration_s / timestep_s / record_every`` records of :func:`record_bytes`) and the larger of
    their post-processing (:func:`postprocess_bytes`, counted on top of the run's records, as if
    they were still held) and their export (:func:`export_bytes`, a later process)."""
    records = _record_count(cfg) * record_bytes(cfg)
    return estimate_model_bytes(cfg) + records + max(postprocess_bytes(cfg), export_bytes(cfg))


def render_bytes(
    *,
    frames: int,
    width: int,
    height: int,
    panels: int = 1,
    nbody: int = 1,
    series_bytes: float = 0.0,
    model_bytes: float = 0.0,
    records_block_bytes: float = 0.0,
) -> float:
    """Memory of a video render [bytes]: per frame the body positions, centroids and node shifts
    (``3 × nbody × 3 × 8`` bytes per panel), four RGB frames of ``width × height × panels`` in
    flight (render, overlay, side-by-side, encoder pipe), the run's time series, the model(s), and
    the records read from the stores: ``records_block_bytes`` is the sum over the runs of their
    largest chunk's rows (:func:`magsail_mj.records.chunk_block_bytes`), each held twice (the
    chunk kept for the next frame and the one being read)."""
    frame = 3.0 * width * height * panels
    per_frame = 3.0 * nbody * 3 * 8 * panels
    stored = float(series_bytes) + float(model_bytes) + 2.0 * float(records_block_bytes)
    return float(frames) * per_frame + 4.0 * frame + stored


_MJCF_TOKENS = ("<body", "<joint", "<freejoint", 'type="ball"', 'type="free"', "<spatial", "<fixed")


def mjcf_counts(path: str | os.PathLike, *, chunk: int = 1 << 24) -> dict[str, int]:
    """Counts of the MJCF tokens that size a model (``<body``, ``<joint``, ``<freejoint``, ball and free
    joint types, ``<spatial``, ``<fixed``) in the file at ``path``, read in chunks (memory stays flat)."""
    counts = dict.fromkeys(_MJCF_TOKENS, 0)
    keep = max(len(t) for t in _MJCF_TOKENS) - 1
    tail = ""
    with open(path, encoding="utf-8", errors="replace") as fh:
        while block := fh.read(chunk):
            text = tail + block
            for token in _MJCF_TOKENS:  # a token straddling the boundary is counted in the next block
                counts[token] += text.count(token) - tail.count(token)
            tail = text[-keep:]
    return counts


_SIZE_MEMORY_RE = re.compile(r'<size\b[^>]*\bmemory="\s*(\d+)\s*([KMGT]?)\s*"', re.IGNORECASE)


def mjcf_arena_bytes(path: str | os.PathLike, *, head: int = 1 << 20) -> int | None:
    """The arena an MJCF file sets (``<size memory="…">``, suffixes K, M, G, T) [bytes], read from
    its first ``head`` characters (the element comes before the bodies); ``None`` when it sets none
    (MuJoCo's default arena)."""
    with open(path, encoding="utf-8", errors="replace") as fh:
        match = _SIZE_MEMORY_RE.search(fh.read(head))
    return None if match is None else int(match.group(1)) * _SUFFIX[match.group(2).upper()]


def mjcf_model_bytes(path: str | os.PathLike) -> tuple[float, int]:
    """``(bytes, nbody)`` of the MJCF file at ``path`` from :func:`mjcf_counts` (``nv`` = 6 per free
    joint, 3 per ball joint, 1 per other joint): MuJoCo's buffers plus the arena the file sets
    (:func:`mjcf_arena_bytes`), or :func:`mujoco_bytes` (default arena) when it sets none."""
    c = mjcf_counts(path)
    free = c["<freejoint"] + c['type="free"']
    nv = 6 * free + 2 * c['type="ball"'] + c["<joint"]
    nbody = c["<body"] + 1
    ntendon = c["<spatial"] + c["<fixed"]
    arena = mjcf_arena_bytes(path)
    if arena is None:
        return mujoco_bytes(nv=nv, nbody=nbody, ntendon=ntendon), nbody
    return explicit_arena_mujoco_bytes(nv=nv, ntendon=ntendon, arena_bytes=arena), nbody


def npz_array_bytes(path: str | os.PathLike) -> float:
    """Sum of the array sizes in a ``.npz`` file [bytes], from the headers (nothing is loaded).
    A member whose header cannot be read counts as its compressed size."""
    total = 0.0
    with zipfile.ZipFile(Path(path)) as zf:
        for info in zf.infolist():
            try:
                with zf.open(info) as fh:
                    major, _ = np.lib.format.read_magic(fh)
                    read = np.lib.format.read_array_header_1_0 if major == 1 else np.lib.format.read_array_header_2_0
                    shape, _, dtype = read(fh)
                total += float(np.prod(shape, dtype=float)) * np.dtype(dtype).itemsize
            except (ValueError, OSError, EOFError, TypeError):
                total += float(info.compress_size)
    return total
