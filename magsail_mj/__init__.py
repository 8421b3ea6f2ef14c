"""magsail_mj: spacecraft geometry configs → MuJoCo models → attitude-control rollouts in orbit."""

# Must run before anything imports mujoco: MuJoCo reads MUJOCO_GL when it is first imported.
from magsail_mj.render.backend import ensure_gl_backend as _ensure_gl_backend

_ensure_gl_backend()

from magsail_mj.api import load  # noqa: E402  (after the GL choice above, which must come first)

__all__ = ["load"]
__version__ = "0.1.0"
