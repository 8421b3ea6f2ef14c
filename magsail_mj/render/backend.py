"""Headless OpenGL backend selection for MuJoCo rendering (OSMesa or EGL).

MuJoCo's Python bindings read ``MUJOCO_GL`` **once, when** ``mujoco`` **is first imported**
(``mujoco/rendering/classic/gl_context.py`` binds ``GLContext`` to ``mujoco.osmesa``,
``mujoco.egl`` or ``mujoco.glfw`` at that moment), and PyOpenGL reads ``PYOPENGL_PLATFORM`` when
``OpenGL`` is first imported. :func:`ensure_gl_backend` therefore has to run before anything
imports ``mujoco``; ``magsail_mj/__init__.py`` calls it first thing. This module itself never
imports ``mujoco`` or ``OpenGL`` at module level.

Choice (only when ``MUJOCO_GL`` is unset or empty): ``"osmesa"`` when ``libOSMesa`` can be
loaded (software rendering, works everywhere, the CI default), else ``"egl"`` (GPU, or Mesa's
software EGL device). A user's explicit ``MUJOCO_GL`` is respected.

:func:`make_renderer` creates a :class:`mujoco.Renderer`. If that fails with the chosen backend
(and no GL context has been made yet in this process), it switches to the other one in-process
(re-importing PyOpenGL under the other ``PYOPENGL_PLATFORM``) and says so in a
:class:`RuntimeWarning`; if neither works it raises :class:`GLBackendError`, which tells how to
install OSMesa.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import importlib
import os
import sys
import warnings
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover - typing only
    import mujoco

__all__ = [
    "GLBackendError",
    "HEADLESS_BACKENDS",
    "INSTALL_HINT",
    "active_backend",
    "ensure_gl_backend",
    "make_renderer",
    "osmesa_available",
]

#: The headless backends this module chooses between, in fallback order.
HEADLESS_BACKENDS = ("osmesa", "egl")
#: the values MuJoCo's GL context accepts on Linux (it raises at import for any other)
_MUJOCO_GL_VALUES = (
    "enable",
    "enabled",
    "on",
    "true",
    "1",
    "glfw",
    "",
    "glx",
    "egl",
    "osmesa",
    "disable",
    "disabled",
    "off",
    "false",
    "0",
)

INSTALL_HINT = (
    "Install the OSMesa software renderer (works without a GPU or display): "
    "`apt-get install -y libosmesa6` (Debian/Ubuntu; `dnf install mesa-libOSMesa` on Fedora), "
    "then run again; or, on a machine with a GPU driver, set MUJOCO_GL=egl before Python starts."
)

# Backend of the first Renderer that was created successfully in this process. Once a GL
# context has existed, MuJoCo's GL function pointers are bound to that library, so the backend
# is not switched any more.
_ACTIVE: str | None = None


class GLBackendError(RuntimeError):
    """No headless OpenGL backend could create a MuJoCo renderer."""


def osmesa_available() -> bool:
    """True when the OSMesa shared library (``libOSMesa``) can be loaded with ``ctypes``."""
    names = []
    found = ctypes.util.find_library("OSMesa")
    if found:
        names.append(found)
    names += ["libOSMesa.so.8", "libOSMesa.so"]
    for name in names:
        try:
            ctypes.CDLL(name)
        except OSError:
            continue
        return True
    return False


def ensure_gl_backend() -> str:
    """Choose the headless GL backend and export it; call before ``mujoco`` is first imported.

    If ``MUJOCO_GL`` is unset (or empty) it is set to ``"osmesa"`` when ``libOSMesa`` is
    loadable, else to ``"egl"``; ``PYOPENGL_PLATFORM`` is set to the same value (MuJoCo's
    ``mujoco.osmesa``/``mujoco.egl`` modules refuse to load under a different one). A
    ``MUJOCO_GL`` that is already set is kept (``PYOPENGL_PLATFORM`` is filled in for
    ``osmesa``/``egl`` if unset), unless MuJoCo could not import under it (a value it does not
    accept, or ``osmesa`` without ``libOSMesa``): then it is replaced by the choice above, with a
    :class:`RuntimeWarning`. Idempotent and cheap (no ``mujoco``/``OpenGL`` import).

    If ``mujoco`` was already imported, the choice cannot take effect at import time any more;
    a :class:`RuntimeWarning` says so, and :func:`make_renderer` applies the choice when it
    creates the first renderer.

    Returns:
      the value of ``MUJOCO_GL`` now in effect (lower case).
    """
    current = os.environ.get("MUJOCO_GL", "").strip().lower()
    unusable = current and (current not in _MUJOCO_GL_VALUES or (current == "osmesa" and not osmesa_available()))
    if current and not unusable:
        if current in HEADLESS_BACKENDS and not os.environ.get("PYOPENGL_PLATFORM"):
            os.environ["PYOPENGL_PLATFORM"] = current
        return current
    choice = "osmesa" if osmesa_available() else "egl"
    if unusable:  # MuJoCo would refuse to import under it: every verb would fail, not only rendering
        warnings.warn(
            f"MUJOCO_GL={current!r} is not a backend MuJoCo can use here (one of "
            f"{', '.join(sorted(set(_MUJOCO_GL_VALUES) - {''}))}; osmesa needs libOSMesa); "
            f"using MUJOCO_GL={choice!r}",
            RuntimeWarning,
            stacklevel=2,
        )
        os.environ.pop("PYOPENGL_PLATFORM", None)
    platform = os.environ.get("PYOPENGL_PLATFORM", "").strip().lower()
    if platform and platform != choice:
        warnings.warn(
            f"PYOPENGL_PLATFORM={platform!r} conflicts with the chosen MUJOCO_GL={choice!r}; "
            f"setting PYOPENGL_PLATFORM={choice!r}",
            RuntimeWarning,
            stacklevel=2,
        )
    os.environ["MUJOCO_GL"] = choice
    os.environ["PYOPENGL_PLATFORM"] = choice
    if "mujoco" in sys.modules and _loaded_backend() != choice:
        warnings.warn(
            "mujoco was imported before magsail_mj chose its GL backend "
            f"(MUJOCO_GL is read at import time); {choice!r} will be switched to when the "
            "first renderer is created. Import magsail_mj before mujoco, or set MUJOCO_GL.",
            RuntimeWarning,
            stacklevel=2,
        )
    return choice


def active_backend() -> str | None:
    """Backend of the renderers made by :func:`make_renderer` so far (``None`` before the first)."""
    return _ACTIVE


def _loaded_backend() -> str | None:
    """Backend MuJoCo's ``GLContext`` is bound to now (``None`` if ``mujoco`` is not imported)."""
    gl_context = sys.modules.get("mujoco.rendering.classic.gl_context")
    if gl_context is None:
        return None
    cls = getattr(gl_context, "GLContext", None)
    if cls is None:
        return "none"
    module = getattr(cls, "__module__", "") or ""
    for name in ("osmesa", "egl", "glfw", "cgl"):
        if module == f"mujoco.{name}":
            return name
    return "missing"  # MuJoCo's placeholder: the backend's import failed


def _switch_backend(name: str) -> None:
    """Rebind MuJoCo's ``GLContext`` to backend ``name`` in-process.

    Only safe before any GL context has been created: PyOpenGL is purged from ``sys.modules``
    and re-imported under ``PYOPENGL_PLATFORM=name``.
    """
    for key in list(sys.modules):
        if (
            key == "OpenGL"
            or key.startswith("OpenGL.")
            or key.split(".")[:2] in (["mujoco", "osmesa"], ["mujoco", "egl"])
        ):
            del sys.modules[key]
    os.environ["MUJOCO_GL"] = name
    os.environ["PYOPENGL_PLATFORM"] = name
    module = importlib.import_module(f"mujoco.{name}")
    gl_context = importlib.import_module("mujoco.rendering.classic.gl_context")
    gl_context.GLContext = module.GLContext


def _try_renderer(model: "mujoco.MjModel", width: int, height: int, max_geom: int, backend: str) -> "mujoco.Renderer":
    import mujoco

    if _loaded_backend() != backend:
        _switch_backend(backend)
    return mujoco.Renderer(model, height=height, width=width, max_geom=max_geom)


def make_renderer(model: "mujoco.MjModel", *, width: int, height: int, max_geom: int = 10000) -> "mujoco.Renderer":
    """Create a :class:`mujoco.Renderer`, falling back between OSMesa and EGL.

    The model's offscreen framebuffer (``model.vis.global_.offwidth/offheight``) is enlarged in
    place when it is smaller than the requested image.

    Args:
      model: the model to render (modified in place as above).
      width: image width [px], >= 1.
      height: image height [px], >= 1.
      max_geom: scene capacity (geoms + tendon segments + decorations).

    Returns:
      an open renderer; close it (``with`` block or ``.close()``) when done.

    Raises:
      GLBackendError: no backend could create a renderer; the message lists each backend's
        error and how to install ``libosmesa6``.
    """
    global _ACTIVE
    for name, value in (("width", width), ("height", height), ("max_geom", max_geom)):
        if int(value) != value or value < 1:
            raise ValueError(f"{name}: must be a positive integer, got {value!r}")
    width, height = int(width), int(height)
    model.vis.global_.offwidth = max(int(model.vis.global_.offwidth), width)
    model.vis.global_.offheight = max(int(model.vis.global_.offheight), height)

    if _ACTIVE is not None:  # a context exists: no more switching
        return _try_renderer(model, width, height, max_geom, _ACTIVE)

    wanted = ensure_gl_backend()
    order = [wanted] + [b for b in HEADLESS_BACKENDS if b != wanted]
    errors: list[str] = []
    for backend in order:
        try:
            renderer = _try_renderer(model, width, height, max_geom, backend)
        except Exception as exc:  # noqa: BLE001 - any failure means: try the next backend
            errors.append(f"  MUJOCO_GL={backend}: {type(exc).__name__}: {exc}")
            continue
        _ACTIVE = backend
        if backend != wanted:
            warnings.warn(
                f"could not create a MuJoCo renderer with MUJOCO_GL={wanted!r} "
                f"({errors[0].split(': ', 1)[1]}); fell back to MUJOCO_GL={backend!r}",
                RuntimeWarning,
                stacklevel=2,
            )
        return renderer
    raise GLBackendError(
        "no OpenGL backend could create a MuJoCo renderer:\n" + "\n".join(errors) + "\n" + INSTALL_HINT
    )
