"""Config → run folder: build, simulate, post-process, write outputs atomically.

A run folder holds ``model.xml`` (the MJCF of the run), ``timeseries.npz`` (the records and
derived series), ``summary.json`` (flat key figures, SI units in the names), ``manifest.json``
(config, its hash, seed, package versions, status, file list; written last), the plots
(``*.png``), ``checkpoint.pkl`` with its record segments ``checkpoint.records*.pkl`` when
checkpointing, and ``video.mp4`` when asked.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
from pathlib import Path
from typing import Any

import numpy as np

from magsail_mj.config import config_hash
from magsail_mj.io import package_versions, prepare_run_dir, write_json, write_npz, atomic_path
from magsail_mj.scenarios import build_scenario

__all__ = ["run_scenario", "RunOutcome"]


class RunOutcome(dict):
    """The summary dict of a run, with ``run_dir`` and ``status`` attributes."""

    run_dir: Path
    status: str


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def run_scenario(
    cfg: Any,
    out_dir: str | Path,
    *,
    video: bool = False,
    resume: bool = False,
    overwrite: bool = False,
    progress: bool | None = None,
    stop_after_s: float | None = None,
) -> RunOutcome:
    """Run a validated config into ``out_dir`` and return its summary.

    Args:
      cfg: validated config (see :func:`magsail_mj.config.load_config`).
      out_dir: run folder; an earlier run there is replaced only with ``overwrite`` or continued
        with ``resume`` (from ``checkpoint.pkl``).
      video: also render ``video.mp4``.
      progress: show a progress bar (default: ``cfg.sim.progress``).
      stop_after_s: stop early at this simulated time, leaving a checkpoint (used to test resume).
    """
    run_dir = prepare_run_dir(out_dir, overwrite=overwrite, resume=resume)
    scenario = build_scenario(cfg)
    with atomic_path(run_dir / "model.xml") as tmp:
        tmp.write_text(scenario.spec.to_xml())
    sim = scenario.simulation()
    ckpt = run_dir / "checkpoint.pkl" if (cfg.sim.checkpoint_every_s > 0 or stop_after_s is not None or resume) else None
    result = sim.run(progress=cfg.sim.progress if progress is None else progress,
                     checkpoint_path=ckpt, resume=resume, stop_after_s=stop_after_s)
    summary, series = scenario.postprocess(result)
    series = {"t": result.records["t"], **series}
    write_npz(run_dir / "timeseries.npz", **{**result.records, **series})
    summary = {"scenario": cfg.scenario, **summary}
    write_json(run_dir / "summary.json", summary)
    plots = scenario.plots(run_dir, result, series)
    files = ["model.xml", "timeseries.npz", "summary.json", *[p.name for p in plots]]
    manifest = {
        "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "concept": cfg.concept,
        "scenario": cfg.scenario,
        "config": cfg.model_dump(mode="json"),
        "config_hash": config_hash(cfg),
        "seed": cfg.sim.seed,
        "versions": package_versions(),
        "status": result.status,
        "status_message": result.message,
        "steps": result.steps,
        "wall_time_s": result.wall_time_s,
        "render": scenario.render_info(),
        **scenario.manifest_extra(),
    }
    manifest["files"] = {name: _sha256(run_dir / name) for name in files}
    write_json(run_dir / "manifest.json", manifest)
    if video:
        from magsail_mj.render import render_run

        info = manifest["render"]
        render_run(run_dir, run_dir / "video.mp4", fps=info.get("fps", 30), max_frames=info.get("max_frames", 600))
        manifest["files"]["video.mp4"] = _sha256(run_dir / "video.mp4")
        write_json(run_dir / "manifest.json", manifest)
    out = RunOutcome(summary)
    out.run_dir = run_dir
    out.status = result.status
    return out
