"""Poster pictures of the documentation's videos: every ``docs/_static/<name>.mp4`` gets
``docs/_static/<name>_poster.jpg``, its first meaningful frame (the first that is not blank), so a
page shows the video's picture, not a black box, before it plays.

    .venv/bin/python scripts/docs_posters.py [--force]

The pages name it in the ``<video poster=...>`` attribute; ``scripts/check_docs_site.py`` checks
that every video has a poster that exists, and ``tests/test_docs_site.py`` that it is a frame of
the video's size. A poster newer than its MP4 is kept unless ``--force``. JPEG (quality 88): a
frame as PNG would be larger than the whole video.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import imageio_ffmpeg
import numpy as np
from PIL import Image

from magsail_mj.io import atomic_path

STATIC = Path(__file__).resolve().parents[1] / "docs" / "_static"
#: a frame whose pixels vary less than this (standard deviation, 0-255) is blank
BLANK_STD = 8.0


def poster_path(mp4: Path) -> Path:
    """``<name>_poster.jpg`` beside ``<name>.mp4``."""
    return mp4.with_name(f"{mp4.stem}_poster.jpg")


def first_meaningful_frame(mp4: Path) -> np.ndarray:
    """The first frame of ``mp4`` that is not blank (else the first), (H, W, 3) uint8."""
    gen = imageio_ffmpeg.read_frames(str(mp4), pix_fmt="rgb24")
    first = None
    try:
        meta = next(gen)
        width, height = meta["size"]
        for buf in gen:
            frame = np.frombuffer(buf, np.uint8).reshape(height, width, 3)
            if first is None:
                first = frame.copy()
            if frame.std() > BLANK_STD:
                return frame.copy()
    finally:
        gen.close()
    if first is None:
        raise ValueError(f"{mp4}: no frame")
    return first


def write_poster(mp4: Path) -> Path:
    """Write the poster of ``mp4`` (atomically) and return its path."""
    out = poster_path(mp4)
    with atomic_path(out, suffix=".jpg") as tmp:
        Image.fromarray(first_meaningful_frame(mp4)).save(tmp, format="JPEG", quality=88, optimize=True)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--force", action="store_true", help="rewrite posters newer than their video")
    args = ap.parse_args(argv)
    for mp4 in sorted(STATIC.glob("*.mp4")):
        out = poster_path(mp4)
        if not args.force and out.is_file() and out.stat().st_mtime >= mp4.stat().st_mtime:
            continue
        print(write_poster(mp4))
    return 0


if __name__ == "__main__":
    sys.exit(main())
