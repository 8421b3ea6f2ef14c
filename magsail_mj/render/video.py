"""Browser-playable MP4 writing (H.264/libx264, yuv420p), atomic, streamed frame by frame.

Encoding goes through :mod:`mediapy` with the ``ffmpeg`` binary shipped in the
``imageio-ffmpeg`` wheel, so no system ffmpeg is needed. Frames are piped to ffmpeg as they are
rendered (memory stays flat in video length); the file is written to a temporary name in the
destination folder and moved into place with :func:`os.replace`, so a reader never sees a
half-written video and a failed render leaves no file behind.
"""

from __future__ import annotations

import os
import re
import subprocess
import uuid
from collections.abc import Iterable
from pathlib import Path
from types import TracebackType

import imageio_ffmpeg
import mediapy
import numpy as np

__all__ = ["Mp4Writer", "ffmpeg_exe", "read_mp4", "video_codec", "write_mp4"]

_CONFIGURED = False


def ffmpeg_exe() -> str:
    """Path of the ``imageio-ffmpeg`` ffmpeg binary, also registered with :mod:`mediapy`."""
    global _CONFIGURED
    exe = imageio_ffmpeg.get_ffmpeg_exe()
    if not _CONFIGURED:
        mediapy.set_ffmpeg(exe)
        _CONFIGURED = True
    return exe


class Mp4Writer:
    """Context manager that streams RGB frames into an H.264 MP4, atomically.

    Example::

        with Mp4Writer("out.mp4", width=960, height=540, fps=30) as w:
            for frame in frames:          # (540, 960, 3) uint8
                w.add(frame)

    On a clean exit the temporary file replaces ``path``; on an exception it is deleted and
    ``path`` is left untouched.

    Args:
      path: destination, must end in ``.mp4``; its folder is created if missing.
      width: frame width [px], even (yuv420p halves the chroma resolution).
      height: frame height [px], even.
      fps: frames per second of playback, > 0.
      crf: x264 constant rate factor (0 lossless … 51 worst; 18–23 is visually good).
    """

    def __init__(
        self, path: str | os.PathLike, *, width: int, height: int, fps: float = 30.0, crf: float = 20.0
    ) -> None:
        self.path = Path(path)
        if self.path.suffix.lower() != ".mp4":
            raise ValueError(f"path: must end in '.mp4', got {str(path)!r}")
        for name, value in (("width", width), ("height", height)):
            if int(value) != value or value < 2 or int(value) % 2:
                raise ValueError(f"{name}: must be an even integer >= 2 (H.264 yuv420p), got {value!r}")
        if not fps > 0:
            raise ValueError(f"fps: must be > 0, got {fps!r}")
        if not 0 <= crf <= 51:
            raise ValueError(f"crf: must be in [0, 51], got {crf!r}")
        self.width, self.height, self.fps, self.crf = int(width), int(height), float(fps), crf
        self.frames_written = 0
        self._tmp: Path | None = None
        self._writer = None

    def __enter__(self) -> "Mp4Writer":
        ffmpeg_exe()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._tmp = self.path.with_name(f".{self.path.stem}.{uuid.uuid4().hex[:8]}.tmp.mp4")
        self._writer = mediapy.VideoWriter(
            self._tmp,
            shape=(self.height, self.width),
            fps=self.fps,
            codec="libx264",
            encoded_format="yuv420p",
            crf=self.crf,
            ffmpeg_args=["-profile:v", "high", "-movflags", "+faststart"],
        )
        try:
            self._writer.__enter__()
        except BaseException:
            self._cleanup()
            raise
        return self

    def add(self, frame: np.ndarray) -> None:
        """Append one ``(height, width, 3)`` uint8 RGB frame."""
        if self._writer is None:
            raise RuntimeError("Mp4Writer.add: use the writer inside a 'with' block")
        frame = np.asarray(frame)
        if frame.shape != (self.height, self.width, 3) or frame.dtype != np.uint8:
            raise ValueError(f"frame: expected ({self.height}, {self.width}, 3) uint8, got {frame.shape} {frame.dtype}")
        self._writer.add_image(frame)
        self.frames_written += 1

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        writer, self._writer = self._writer, None
        try:
            if writer is not None:
                writer.__exit__(exc_type, exc, tb)
        except BaseException:
            self._cleanup()
            raise
        if exc_type is not None or self.frames_written == 0:
            self._cleanup()
            if exc_type is None:
                raise ValueError(f"no frames were written to {self.path}")
            return
        os.replace(self._tmp, self.path)
        self._tmp = None

    def _cleanup(self) -> None:
        if self._tmp is not None:
            try:
                self._tmp.unlink()
            except FileNotFoundError:
                pass
            self._tmp = None


def write_mp4(frames: Iterable[np.ndarray], path: str | os.PathLike, *, fps: float = 30.0, crf: float = 20.0) -> Path:
    """Write an iterable of equal-size RGB uint8 frames to an H.264 MP4 (atomically).

    The size is taken from the first frame (width and height must be even).

    Returns:
      the path written.
    """
    it = iter(frames)
    try:
        first = np.asarray(next(it))
    except StopIteration:
        raise ValueError("frames: is empty") from None
    if first.ndim != 3 or first.shape[2] != 3:
        raise ValueError(f"frames: expected (H, W, 3) images, got shape {first.shape}")
    with Mp4Writer(path, width=first.shape[1], height=first.shape[0], fps=fps, crf=crf) as w:
        w.add(first)
        for frame in it:
            w.add(frame)
    return Path(path)


def read_mp4(path: str | os.PathLike) -> np.ndarray:
    """Decode a video into a ``(frames, height, width, 3)`` uint8 RGB array.

    Uses ``imageio_ffmpeg.read_frames``: ``mediapy.read_video`` 1.2.7 passes ``-vsync``, which
    the ffmpeg 9 binary of ``imageio-ffmpeg`` 0.8 no longer accepts.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"path: no such file {str(path)!r}")
    gen = imageio_ffmpeg.read_frames(str(path), pix_fmt="rgb24")
    try:
        meta = next(gen)
        width, height = meta["size"]
        frames = [np.frombuffer(buf, np.uint8).reshape(height, width, 3) for buf in gen]
    finally:
        gen.close()
    if not frames:
        return np.zeros((0, height, width, 3), np.uint8)
    return np.stack(frames)


def video_codec(path: str | os.PathLike) -> str:
    """Codec name of the first video stream (e.g. ``"h264"``) and its pixel format.

    Parses the stream line that ``ffmpeg -i`` prints (no ffprobe needed), e.g.
    ``Stream #0:0: Video: h264 (High) (avc1 / 0x31637661), yuv420p(...), 960x540`` →
    ``"h264 yuv420p"``.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"path: no such file {str(path)!r}")
    proc = subprocess.run([ffmpeg_exe(), "-hide_banner", "-i", str(path)], capture_output=True, text=True, check=False)
    match = re.search(r"Stream #\d+:\d+.*?: Video: (\w+)[^,]*, (\w+)", proc.stderr)
    if match is None:
        raise ValueError(f"path: no video stream found in {str(path)!r}:\n{proc.stderr[-2000:]}")
    return f"{match.group(1)} {match.group(2)}"
