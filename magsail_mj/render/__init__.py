"""Headless rendering of runs: GL backend choice (OSMesa/EGL), frame rendering, MP4 output.

The public names are imported lazily (PEP 562), so that ``import magsail_mj.render.backend``
(done by ``magsail_mj/__init__.py`` to choose ``MUJOCO_GL``) does not import ``mujoco`` before
the backend is chosen.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "GLBackendError": "backend",
    "active_backend": "backend",
    "ensure_gl_backend": "backend",
    "make_renderer": "backend",
    "osmesa_available": "backend",
    "Mp4Writer": "video",
    "read_mp4": "video",
    "video_codec": "video",
    "write_mp4": "video",
    "CameraView": "compose",
    "FrameOptions": "compose",
    "RenderError": "compose",
    "RunData": "compose",
    "RunScene": "compose",
    "frame_plan": "compose",
    "load_run": "compose",
    "render_frames": "compose",
    "render_run": "compose",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
