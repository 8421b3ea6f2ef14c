"""WebM (VP9) copies of the documentation's MP4 (H.264) videos, so that browsers without H.264
play them too: every ``docs/_static/<name>.mp4`` gets ``docs/_static/<name>.webm`` beside it.

    .venv/bin/python scripts/docs_webm.py [--crf 50] [--force]

Uses the ffmpeg binary that imageio-ffmpeg ships (no system ffmpeg needed): VP9 at constant
quality ``--crf`` (``-b:v 0``, 0 best … 63 worst), no audio, same size and frame rate as the MP4.
A WebM newer than its MP4 is kept unless ``--force``. The pages embed both as ``<source>`` of one
``<video>`` (MP4 first); ``scripts/check_docs_site.py`` checks that both exist and load.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import imageio_ffmpeg

STATIC = Path(__file__).resolve().parents[1] / "docs" / "_static"


def to_webm(mp4: Path, *, crf: int) -> Path:
    """Encode ``mp4`` as VP9 WebM beside it (written under a temporary name, then renamed)."""
    out = mp4.with_suffix(".webm")
    tmp = mp4.with_suffix(".tmp.webm")
    cmd = [
        imageio_ffmpeg.get_ffmpeg_exe(),
        "-hide_banner",
        "-loglevel",
        "error",
        "-y",
        "-i",
        str(mp4),
        "-an",
        "-c:v",
        "libvpx-vp9",
        "-b:v",
        "0",
        "-crf",
        str(crf),
        "-row-mt",
        "1",
        "-deadline",
        "good",
        "-cpu-used",
        "4",
        "-pix_fmt",
        "yuv420p",
        str(tmp),
    ]
    subprocess.run(cmd, check=True)
    tmp.replace(out)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--crf",
        type=int,
        default=50,
        help="VP9 constant quality, 0 (best) to 63 (default 50: about the size of the MP4)",
    )
    ap.add_argument("--force", action="store_true", help="re-encode WebM files that are newer than their MP4")
    args = ap.parse_args(argv)
    if not 0 <= args.crf <= 63:
        print(f"error: --crf: must be 0 … 63, got {args.crf}", file=sys.stderr)
        return 2
    for mp4 in sorted(STATIC.glob("*.mp4")):
        webm = mp4.with_suffix(".webm")
        if webm.exists() and webm.stat().st_mtime >= mp4.stat().st_mtime and not args.force:
            continue
        out = to_webm(mp4, crf=args.crf)
        print(
            f"{out.relative_to(STATIC.parents[1])}: {out.stat().st_size / 1e3:.0f} kB "
            f"(MP4 {mp4.stat().st_size / 1e3:.0f} kB)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
