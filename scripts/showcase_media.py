"""The videos of the showcase page (``docs/showcases.md``) from finished structure-concept runs.

    .venv/bin/python scripts/showcase_media.py RUN_DIR NAME [--exaggeration K] [--top-set top]
    .venv/bin/python scripts/docs_webm.py && .venv/bin/python scripts/docs_posters.py

Writes ``docs/_static/structure_<NAME>.mp4`` at the size of the other documentation videos
(640 × 360 px, 15 frames/s, at most 300 frames subsampled uniformly from the records, x264
``--crf``), so a five-hour run plays in 20 s and stays well under 2 MB.

The run's own ``render`` table (its manifest) is used with two additions: ``top_nodes``, the
structure's node set ``--top-set`` when it has one (the renderer then colours those nodes by their
height above their total-least-squares plane and, with an exaggeration, keeps each layer's mean
offset from the plane, so a two-layer plate keeps its depth instead of being stretched ``k``
times), and the exaggeration ``--exaggeration`` when given. The renderer addresses node ``i`` as
body ``i + 1``; a structure whose nodes are not laid out so (rigid parts, beam trees) is refused
with ``--top-set``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from magsail_mj.concepts.structure.model import make_structure_model
from magsail_mj.config import parse_config
from magsail_mj.render import render_run

STATIC = Path(__file__).resolve().parents[1] / "docs" / "_static"
WIDTH_PX, HEIGHT_PX, FPS, MAX_FRAMES = 640, 360, 15, 300


def top_nodes(run_dir: Path, top_set: str) -> list[int] | None:
    """The node indices of ``top_set`` (``None`` when the structure has no such set); refuses a
    structure whose node ``i`` is not body ``i + 1``."""
    manifest = json.loads((run_dir / "manifest.json").read_text(encoding="utf-8"))
    sm = make_structure_model(parse_config(manifest["config"], source=str(run_dir / "manifest.json")))
    sets = sm.structure.node_sets
    if top_set not in sets:
        return None
    body = np.asarray(sm.index.node_body, dtype=np.int64)
    if not np.array_equal(body, np.arange(body.size) + 1):
        raise ValueError(f"--top-set: the nodes of {run_dir} are not bodies 1 … n (rigid parts or beam trees)")
    return [int(i) for i in sets[top_set]]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path, help="finished run folder of a structure-concept config")
    ap.add_argument("name", help="the video is docs/_static/structure_<name>.mp4")
    ap.add_argument("--exaggeration", type=float, default=None, help="out-of-plane factor (default: the run's)")
    ap.add_argument("--top-set", default="top", help="node set drawn as the top layer (default: top)")
    ap.add_argument("--crf", type=float, default=28.0, help="x264 constant quality (default 28)")
    args = ap.parse_args(argv)
    manifest_path = args.run_dir / "manifest.json"
    if not manifest_path.is_file():
        print(f"error: RUN_DIR: {args.run_dir} is not a finished run folder (no manifest.json)", file=sys.stderr)
        return 2
    info = dict(json.loads(manifest_path.read_text(encoding="utf-8"))["render"])
    top = top_nodes(args.run_dir, args.top_set)
    if top is not None:
        info["top_nodes"] = top
    if args.exaggeration is not None:
        info["exaggeration"] = args.exaggeration
    out = STATIC / f"structure_{args.name}.mp4"
    render_run(
        args.run_dir,
        out,
        fps=FPS,
        crf=args.crf,
        width=WIDTH_PX,
        height=HEIGHT_PX,
        max_frames=MAX_FRAMES,
        render_info=info,
    )
    print(f"{out.relative_to(STATIC.parents[1])}: {out.stat().st_size / 1e3:.0f} kB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
