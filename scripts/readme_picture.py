"""Write the README's picture: one frame of the main job's side-by-side video of Case C.

The main job (``scripts/main_job.sh``) runs Case C centralised and distributed and renders
``runs/dist_vs_central/case_c_bangbang_side_by_side.mp4`` (centralised | distributed); this
script takes the frame of that video at ``--time-s`` (default: the moment the centralised run
ended, read from its ``summary.json``: its largest bending and, when the structure failed, the
overlay's line saying why) and writes it as PNG (default ``docs/_static/case_c_side_by_side.png``,
the picture at the top of README.md), scaled to ``--width`` (1280 px) with a 256-colour palette so
that it stays small.

The frame's time is found by the renderer's own frame plan
(:func:`magsail_mj.render.frame_plan`) over both runs' record times, with the video's frame count
(counted by ffmpeg), so no frame is guessed from the frame rate.

    python scripts/readme_picture.py                      # after the main job
    python scripts/readme_picture.py --time-s 600 --out /tmp/frame.png
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import imageio_ffmpeg
import numpy as np
from PIL import Image

from magsail_mj.io import atomic_path
from magsail_mj.render import frame_plan, load_run
from magsail_mj.render.ending import read_end_status

REPO = Path(__file__).resolve().parents[1]

RUNS = REPO / "runs" / "dist_vs_central"
OUT = REPO / "docs" / "_static" / "case_c_side_by_side.png"
#: width of the README picture [px] (the video's two 960 px panels, scaled)
WIDTH = 1280


def frame_index(run_dirs: list[Path], *, time_s: float | None, max_frames: int) -> tuple[int, float]:
    """``(frame number, frame time [s])`` of the side-by-side video of ``run_dirs`` (left, right)
    whose frame time is the first at or after ``time_s`` (default: the left run's end)."""
    times = [load_run(run, name=f"run {run}").t for run in run_dirs]  # as the renderer reads them
    frame_t, _, _ = frame_plan(times, max_frames=max_frames)
    if time_s is None:
        end = read_end_status(run_dirs[0]).get("t_end_s")
        time_s = float(end) if end is not None else float(times[0][-1])
    k = min(int(np.searchsorted(frame_t, time_s - 1e-9)), frame_t.size - 1)
    return k, float(frame_t[k])


def read_frame(video: Path, index: int) -> np.ndarray:
    """Frame ``index`` (0-based) of ``video`` as (H, W, 3) uint8, decoding no frame after it."""
    gen = imageio_ffmpeg.read_frames(str(video), pix_fmt="rgb24")
    try:
        meta = next(gen)
        width, height = meta["size"]
        for k, buf in enumerate(gen):
            if k == index:
                return np.frombuffer(buf, np.uint8).reshape(height, width, 3).copy()
    finally:
        gen.close()
    raise ValueError(f"{video}: has no frame {index}")


def small_png(frame: np.ndarray, *, width: int) -> Image.Image:
    """``frame`` scaled to ``width`` px (Lanczos; ``0`` or a larger width keeps it) with a
    256-colour palette: the README picture stays small (tests/test_docs.py: below 300 kB)."""
    image = Image.fromarray(frame)
    if 0 < width < image.width:
        image = image.resize((width, round(image.height * width / image.width)), Image.Resampling.LANCZOS)
    return image.quantize(colors=256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=Path, default=RUNS, help="the main job's output folder")
    ap.add_argument("--case", default="c", help="case letter (default: c)")
    ap.add_argument("--profile", default="bangbang", help="torque profile (default: bangbang)")
    ap.add_argument("--time-s", type=float, default=None, help="frame time [s] (default: the centralised run's end)")
    ap.add_argument("--out", type=Path, default=OUT, help="PNG to write")
    ap.add_argument("--width", type=int, default=WIDTH, help=f"picture width [px] (default {WIDTH}; 0: the video's)")
    args = ap.parse_args(argv)
    runs = [args.runs / f"case_{args.case}_{place}_{args.profile}" for place in ("central", "distributed")]
    video = args.runs / f"case_{args.case}_{args.profile}_side_by_side.mp4"
    for path in (*runs, video):
        if not path.exists():
            print(f"readme_picture: {path} is missing: run the main job first (scripts/main_job.sh)", file=sys.stderr)
            return 2
    n_frames, _ = imageio_ffmpeg.count_frames_and_secs(str(video))
    index, t = frame_index(runs, time_s=args.time_s, max_frames=n_frames)
    picture = small_png(read_frame(video, index), width=args.width)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(args.out, suffix=".png") as tmp:
        picture.save(tmp, format="PNG", optimize=True)
    print(json.dumps({"picture": str(args.out), "video": str(video), "frame": index, "t_s": t}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
