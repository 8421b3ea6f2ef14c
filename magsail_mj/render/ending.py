"""Why a run ended, in one short line for pictures (video overlays, plots).

A run folder's ``summary.json`` (or, without it, its ``manifest.json``) holds ``status``,
``status_message`` and ``t_end_s``; the truss scenarios add ``strut_strain_max`` and
``t_failed_s``. :func:`end_reason` turns them into the line a picture prints where a run's
curve or motion stops, e.g. ``structure failed at 646 s: strut 1330 strain 0.501 > 0.5`` or
``diverged at 12.3 s: MuJoCo BADQACC: an acceleration is not finite or huge``.

No heavy imports here: plot scripts use it without the renderer.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

__all__ = ["end_reason", "end_status", "read_end_status"]

_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
#: the simulator's structural-failure message (magsail_mj.sim)
_STRAIN = re.compile(
    rf"strut (?P<strut>\d+) strain (?P<strain>{_NUMBER}) exceeds sim\.max_strain (?P<limit>{_NUMBER})"
    rf"(?: at t = (?P<t>{_NUMBER}) s)?"
)
_AT_TIME = re.compile(rf"\s*\bat t = (?P<t>{_NUMBER}) s\b")
#: the readable name of each status
_STATUS_TEXT = {
    "structure_failed": "structure failed",
    "diverged": "diverged",
    "stopped": "stopped",
    "interrupted": "interrupted",
    "tracking_lost": "tracking lost",
    "failed_condition": "failure condition reached",
    "failed": "failed",
    "completed": "completed",
}


def _time(value: Any) -> float | None:
    try:
        t = float(value)
    except (TypeError, ValueError):
        return None
    return t if math.isfinite(t) else None


def _seconds(t: float) -> str:
    return f"{t:.6g} s"


def end_reason(summary: Mapping[str, Any] | None, *, t_last_s: float | None = None) -> str:
    """One line saying why a run ended, from its summary (``status``, ``status_message``,
    ``t_end_s`` and, for a structure, ``strut_strain_max`` / ``t_failed_s``).

    Args:
      summary: the run's ``summary.json`` (or manifest) as a mapping; ``None`` or ``{}`` when
        unknown.
      t_last_s: the time of the run's last record [s], used when the summary gives none.

    Returns:
      e.g. ``structure failed at 646 s: strut 1330 strain 0.501 > 0.5``, ``diverged at 12.3 s:
      state is not finite``, ``stopped at 300 s``, ``interrupted at 41 s``, ``completed at
      600 s``; ``run ended at 40 s`` when the status is unknown.
    """
    summary = summary or {}
    status = str(summary.get("status") or "")
    message = str(summary.get("status_message") or "").strip()
    t_end = _time(summary.get("t_end_s"))
    if t_end is None:
        t_end = _time(t_last_s)
    if status == "structure_failed":
        found = _STRAIN.search(message)
        if found:
            t = _time(found["t"]) if found["t"] else t_end
            when = f" at {_seconds(t)}" if t is not None else ""
            return f"structure failed{when}: strut {found['strut']} strain {found['strain']} > {found['limit']}"
        at = _AT_TIME.search(message)
        t = _time(at["t"]) if at else _time(summary.get("t_failed_s"))
        t = t if t is not None else t_end
        strain = _time(summary.get("strut_strain_max"))
        detail = f": largest strut strain {strain:.3g}" if strain is not None else ""
        return f"structure failed{' at ' + _seconds(t) if t is not None else ''}{detail}"
    if not status:
        return f"run ended at {_seconds(t_end)}" if t_end is not None else "run ended"
    text = _STATUS_TEXT.get(status, status.replace("_", " "))
    at = _AT_TIME.search(message)
    t = _time(at["t"]) if at else t_end
    cause = _AT_TIME.sub("", message, count=1).strip() if at else message
    cause = re.sub(r"\s*\([^()]*\)\s*$", "", cause).strip(" :;,")  # a trailing remark in parentheses
    if status in ("stopped", "interrupted", "completed") or cause.lower().startswith(text):
        cause = ""
    when = f" at {_seconds(t)}" if t is not None else ""
    return f"{text}{when}" + (f": {cause}" if cause else "")


def read_end_status(run_dir: str | Path) -> dict[str, Any]:
    """``status``, ``status_message``, ``t_end_s``, ``strut_strain_max`` and ``t_failed_s`` of a
    run folder: from ``summary.json``, else ``manifest.json``; ``{}`` when neither is readable.

    For plots that read a run folder without the renderer (the renderer reads the same files in
    :func:`magsail_mj.render.compose.load_run`)."""
    folder = Path(run_dir)
    for name in ("summary.json", "manifest.json"):
        try:
            data = json.loads((folder / name).read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError):
            continue
        if isinstance(data, dict) and data.get("status"):
            return end_status(data)
    return {}


def end_status(data: Mapping[str, Any]) -> dict[str, Any]:
    """The entries of a summary or manifest that :func:`end_reason` reads."""
    keys = ("status", "status_message", "t_end_s", "strut_strain_max", "t_failed_s")
    return {k: data[k] for k in keys if k in data}
