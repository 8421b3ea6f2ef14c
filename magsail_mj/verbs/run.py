"""``magsail run``: simulate a config into a run folder (and its video)."""

from __future__ import annotations

import argparse
import json
import logging
from typing import Any

from magsail_mj.cli import RUN_EXIT, CliInputError
from magsail_mj.io import to_jsonable
from magsail_mj.resources import check_memory, estimate_model_bytes, estimate_run_bytes, render_bytes
from magsail_mj.run import run_scenario
from magsail_mj.verbs.common import load, output_dir

__all__ = ["run"]

LOG = logging.getLogger("magsail_mj")


def _video_bytes(cfg: Any) -> float:
    """Memory of rendering the run's video (the render table's frame count, 960 × 540 px)."""
    r = getattr(cfg, "render", None)
    frames = int(getattr(r, "max_frames", 600) or 600)
    return render_bytes(frames=frames, width=960, height=540, model_bytes=estimate_model_bytes(cfg))


def run(args: argparse.Namespace) -> int:
    """Run the scenario into ``--out``; the exit status of its outcome (:data:`magsail_mj.cli.RUN_EXIT`)."""
    out = output_dir(args.out, "--out")
    if args.resume and not out.is_dir():
        raise CliInputError(f"--resume: there is no run folder {str(out)!r} to resume")
    cfg = load(args)
    estimate = estimate_run_bytes(cfg) + (_video_bytes(cfg) if args.video else 0.0)
    check_memory(estimate, what=f"run {args.config}{' with --video' if args.video else ''}")
    if args.stop_after_s is not None and args.stop_after_s >= cfg.sim.duration_s:
        raise CliInputError(
            f"--stop-after-s: must be below sim.duration_s = {cfg.sim.duration_s:g}, got {args.stop_after_s:g}"
        )
    outcome = run_scenario(
        cfg,
        out,
        video=args.video,
        resume=args.resume,
        overwrite=args.overwrite,
        progress=False if args.no_progress else None,
        stop_after_s=args.stop_after_s,
    )
    print(json.dumps(to_jsonable(dict(outcome)), indent=2))
    LOG.info("run folder: %s", outcome.run_dir)
    if args.video and (outcome.run_dir / "video.mp4").is_file():
        LOG.info("video: %s", outcome.run_dir / "video.mp4")
    status = getattr(outcome, "status", "completed")
    code = RUN_EXIT.get(status, 0)
    if code:
        LOG.error("run %s: %s", status, outcome.get("status_message", ""))
    return code
