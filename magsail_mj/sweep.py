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
key, value and what is allowed). Runs then go to a :class:`~concurrent.futures.ProcessPoolExecutor`
with ``workers`` processes, each run into its own folder ``OUT/<id>`` through
:func:`magsail_mj.run.run_scenario`. A run that raises or diverges is recorded with its
message; the others go on. A run whose folder already holds a finished manifest is skipped
unless ``overwrite`` (so an interrupted sweep continues where it stopped).

The sweep folder receives ``sweep_summary.json`` (one record per run: id, status, wall time
and every scalar of its ``summary.json``), ``sweep_summary.csv`` (the same as a table) and
``sweep_manifest.json`` (sweep file, its hash, overrides, package versions, total wall time),
all written atomically.
"""

from __future__ import annotations

import csv
import datetime as _dt
import hashlib
import io
import json
import multiprocessing
import os
import time
import tomllib
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from magsail_mj.config import ConfigError, load_config
from magsail_mj.io import atomic_path, package_versions, to_jsonable, write_json

__all__ = ["SweepRun", "Sweep", "is_sweep_file", "load_sweep", "run_sweep"]


@dataclass(frozen=True)
class SweepRun:
    """One entry of a sweep: its id (run folder name), config path and overrides."""

    id: str
    config: Path
    overrides: tuple[str, ...] = ()


@dataclass(frozen=True)
class Sweep:
    """A parsed sweep file."""

    name: str
    path: Path
    runs: tuple[SweepRun, ...]
    description: str = ""
    overrides: tuple[str, ...] = field(default_factory=tuple)


def is_sweep_file(path: str | Path) -> bool:
    """True for a sweep file (``[[run]]`` tables and no ``concept``), which lists configs."""
    tree = tomllib.loads(Path(path).read_text())
    return "run" in tree and "concept" not in tree


def _str_list(value: Any, where: str) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ConfigError([f"{where}: must be a list of 'key.path=value' strings, got {value!r}"])
    return tuple(value)


def load_sweep(path: str | Path, *, extra_overrides: tuple[str, ...] = (),
               only: str | list[str] | tuple[str, ...] | None = None) -> Sweep:
    """Parse and validate a sweep file; every listed config is loaded and validated.

    Args:
      path: the sweep TOML.
      extra_overrides: ``key=value`` overrides applied to every run after the file's own.
      only: keep the runs whose id contains this substring (or any of these substrings).
    Raises:
      ConfigError: naming the sweep key or the run id with the config's problems.
    """
    path = Path(path)
    try:
        tree = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise ConfigError([f"{path}: {err}"]) from None
    unknown = sorted(set(tree) - {"name", "description", "set", "run"})
    if unknown:
        raise ConfigError([f"{k}: unknown sweep key (allowed: name, description, set, run)" for k in unknown],
                          source=str(path))
    entries = tree.get("run")
    if not isinstance(entries, list) or not entries:
        raise ConfigError([f"run: must be a non-empty array of [[run]] tables, got {entries!r}"], source=str(path))
    common = _str_list(tree.get("set", []), "set") + tuple(extra_overrides)
    wanted = None if only is None else ((only,) if isinstance(only, str) else tuple(only))
    runs, problems, seen = [], [], set()
    for n, entry in enumerate(entries):
        where = f"run[{n}]"
        if not isinstance(entry, dict) or set(entry) - {"id", "config", "set"} or "id" not in entry \
                or "config" not in entry:
            problems.append(f"{where}: needs 'id' and 'config' (optional 'set'), got {entry!r}")
            continue
        rid = str(entry["id"])
        if rid in seen or ".." in Path(rid).parts or Path(rid).is_absolute():
            problems.append(f"{where}.id: must be a unique relative folder name, got {rid!r}")
            continue
        seen.add(rid)
        if wanted and not any(w in rid for w in wanted):
            continue
        runs.append(SweepRun(id=rid, config=(path.parent / entry["config"]).resolve(),
                             overrides=common + _str_list(entry.get("set", []), f"{where}.set")))
    for run in runs:
        try:
            load_config(run.config, list(run.overrides))
        except ConfigError as err:
            problems.extend(f"{run.id}: {p}" for p in err.problems)
        except OSError as err:
            problems.append(f"{run.id}: config {run.config}: {err}")
    if problems:
        raise ConfigError(problems, source=str(path))
    if not runs:
        raise ConfigError([f"only: no run id contains any of {list(wanted or [])!r}"], source=str(path))
    return Sweep(name=str(tree.get("name", path.stem)), path=path, runs=tuple(runs),
                 description=str(tree.get("description", "")), overrides=common)


def _finished(run_dir: Path) -> bool:
    try:
        manifest = json.loads((run_dir / "manifest.json").read_text())
    except (OSError, ValueError):
        return False
    return manifest.get("status") in ("completed", "diverged")


def _run_one(run: SweepRun, out_dir: str, video: bool, overwrite: bool) -> dict[str, Any]:
    """Worker body: one run into its folder; never raises (failures become records)."""
    from magsail_mj.run import run_scenario

    t0 = time.perf_counter()
    record: dict[str, Any] = {"id": run.id, "config": str(run.config)}
    try:
        cfg = load_config(run.config, list(run.overrides))
        outcome = run_scenario(cfg, Path(out_dir) / run.id, video=video, overwrite=overwrite, progress=False)
        record.update(status=outcome.status, message=outcome.get("status_message", ""))
        record["summary"] = to_jsonable(dict(outcome))
    except Exception as err:  # noqa: BLE001 - one failing run must not lose the others
        record.update(status="failed", message=f"{type(err).__name__}: {err}")
    record["wall_time_s"] = time.perf_counter() - t0
    return record


def _scalar_columns(records: list[dict[str, Any]]) -> list[str]:
    cols: list[str] = []
    for rec in records:
        for key, value in rec.get("summary", {}).items():
            if key not in cols and (value is None or isinstance(value, (int, float, str, bool))):
                cols.append(key)
    return cols


def _write_table(path: Path, records: list[dict[str, Any]]) -> None:
    cols = _scalar_columns(records)
    buf = io.StringIO()
    writer = csv.writer(buf)
    writer.writerow(["id", "status", "wall_time_s", *cols])
    for rec in records:
        s = rec.get("summary", {})
        writer.writerow([rec["id"], rec["status"], f"{rec['wall_time_s']:.1f}", *[s.get(c, "") for c in cols]])
    with atomic_path(path) as tmp:
        tmp.write_text(buf.getvalue())


def run_sweep(
    sweep: Sweep,
    out_dir: str | Path,
    *,
    workers: int = 1,
    video: bool = False,
    overwrite: bool = False,
    log: Callable[[str], None] | None = print,
) -> list[dict[str, Any]]:
    """Run every entry of ``sweep`` into ``out_dir/<id>`` with ``workers`` processes.

    Returns one record per run (``id``, ``status`` ∈ completed/diverged/stopped/failed/skipped,
    ``message``, ``wall_time_s``, ``summary``), also written to ``sweep_summary.json``/``.csv``.
    """
    if int(workers) != workers or workers < 1:
        raise ValueError(f"workers: must be an integer >= 1, got {workers!r}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    records: dict[str, dict[str, Any]] = {}
    todo = []
    for run in sweep.runs:
        if not overwrite and _finished(out / run.id):
            summary = json.loads((out / run.id / "summary.json").read_text())
            records[run.id] = {"id": run.id, "config": str(run.config), "status": "skipped",
                               "message": "finished earlier (use overwrite to rerun)", "wall_time_s": 0.0,
                               "summary": summary}
        else:
            todo.append(run)
    if log:
        log(f"sweep {sweep.name}: {len(todo)} runs to do, {len(records)} already finished, {workers} workers")
    # Fresh interpreters ("spawn") with one BLAS thread each: the workers already share the cores,
    # and extra BLAS threads made the damping mat-vec 2–5× slower on a loaded machine.
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    with ProcessPoolExecutor(max_workers=int(workers), mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = {pool.submit(_run_one, run, str(out), video, overwrite): run for run in todo}
        for fut in as_completed(futures):
            rec = fut.result()
            records[rec["id"]] = rec
            if log:
                log(f"  {rec['id']}: {rec['status']} in {rec['wall_time_s']:.1f} s"
                    + (f" ({rec['message']})" if rec["status"] not in ("completed", "skipped") else ""))
    ordered = [records[r.id] for r in sweep.runs]
    wall = time.perf_counter() - t0
    write_json(out / "sweep_summary.json", ordered)
    _write_table(out / "sweep_summary.csv", ordered)
    digest = hashlib.sha256(sweep.path.read_bytes()).hexdigest()
    write_json(out / "sweep_manifest.json", {
        "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "sweep": str(sweep.path), "sweep_hash": digest, "name": sweep.name, "description": sweep.description,
        "overrides": list(sweep.overrides), "workers": int(workers), "wall_time_s": wall,
        "runs": {r["id"]: r["status"] for r in ordered}, "versions": package_versions(),
    })
    if log:
        counts = {s: sum(r["status"] == s for r in ordered) for s in {r["status"] for r in ordered}}
        log(f"sweep {sweep.name}: {counts} in {wall:.1f} s wall -> {out}")
    return ordered
