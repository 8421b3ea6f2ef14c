"""Helper of the concept task tests (tests/test_truss_tasks.py, tests/test_current_loops_tasks.py)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from magsail_mj.config import load_config
from magsail_mj.scenario import build_scenario

SMALL_SHORT = ["lattice.units=3", "sim.duration_s=2"]
"""A 3-unit lattice run for 2 s: builds in well under a second."""


def built_kind(path: str | Path, *, kind: str, cls: type, base: type) -> Any:
    """The scenario built from the config at ``path`` (:data:`SMALL_SHORT`), after checking that
    the config is of scenario kind ``kind``, that it builds exactly ``cls`` (a ``base``) and that
    the video overlay is the class's ``OVERLAY``."""
    cfg = load_config(path, SMALL_SHORT)
    assert cfg.scenario == kind
    sc = build_scenario(cfg)
    assert type(sc) is cls and isinstance(sc, base)
    assert sc.render_info()["overlay"] == list(cls.OVERLAY)
    return sc
