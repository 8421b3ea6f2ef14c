"""Store short-duration summaries of every shipped config, the reference of regression tests.

Before a restructuring, run this script on the code before the change; the tests in
``tests/test_regression_summaries.py`` then compare every config's summary of the same short run
with the stored one (floats to 1e-9 relative). Each config runs ``STEPS`` time steps (MSAC:
``MSAC_CYCLES`` cycles), keeping its own lattice size and every other key.

    .venv/bin/python scripts/store_regression_summaries.py [--only TEXT ...] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from magsail_mj.config import load_config
from magsail_mj.io import to_jsonable, write_json
from magsail_mj.run import run_scenario
from magsail_mj.structure.fileformat import is_structure_file
from magsail_mj.sweep import is_sweep_file

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "tests" / "data" / "regression_summaries.json"
STEPS = 30
MSAC_CYCLES = 6
#: keys that measure the machine, not the physics
TIMING_KEYS = ("wall_time_s", "step_cost_us", "wall_time_per_step_s", "steps_per_s", "wall_s")


def shipped_configs() -> list[Path]:
    """Every scenario config under ``models/`` (sweep and structure files excluded), sorted."""
    paths = (REPO / "magsail_mj" / "concepts").rglob("*.toml")
    return sorted(p for p in paths if not is_sweep_file(p) and not is_structure_file(p))


def short_overrides(path: Path) -> list[str]:
    """The overrides of the short run of ``path``: ``STEPS`` time steps (MSAC: whole cycles)."""
    cfg = load_config(path)
    dt = cfg.sim.timestep_s
    if getattr(cfg, "kind", None) == "lifetime":  # an orbit-decay analysis: its duration is a cap
        duration = cfg.sim.duration_s
    elif cfg.concept == "msac":
        duration = MSAC_CYCLES / cfg.cycle.frequency_Hz
    else:
        duration = STEPS * dt
    duration = min(duration, cfg.sim.duration_s)
    return [f"sim.duration_s={duration!r}", "sim.progress=false", "sim.checkpoint_every_s=0.0"]


def physics_summary(summary: dict[str, Any]) -> dict[str, Any]:
    """The summary without timing keys, JSON-ready."""
    return {k: v for k, v in to_jsonable(summary).items() if not any(k.endswith(t) or k == t for t in TIMING_KEYS)}


def short_summary(path: Path) -> dict[str, Any]:
    """The summary of the short run of ``path`` (run in a temporary folder)."""
    cfg = load_config(path, short_overrides(path))
    with tempfile.TemporaryDirectory() as tmp:
        return physics_summary(dict(run_scenario(cfg, Path(tmp) / "run")))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--only", action="append", default=[], metavar="TEXT", help="configs whose path contains TEXT")
    p.add_argument("--out", default=str(OUT))
    args = p.parse_args(argv)
    out = Path(args.out)
    stored = json.loads(out.read_text()) if out.exists() else {}
    for path in shipped_configs():
        key = str(path.relative_to(REPO))
        if args.only and not any(t in key for t in args.only):
            continue
        t0 = time.perf_counter()
        stored[key] = short_summary(path)
        print(f"{key}: {stored[key].get('status')} ({time.perf_counter() - t0:.1f} s)", file=sys.stderr, flush=True)
        write_json(out, dict(sorted(stored.items())))
    return 0


def differences(
    expected: dict[str, Any], actual: dict[str, Any], *, rel: float = 1e-9, abs_tol: float = 1e-300
) -> list[str]:
    """Stored keys whose values differ now (floats beyond ``rel`` relative, anything else not
    equal) or that are gone; keys added since the summaries were stored are allowed."""
    out = []
    for key in sorted(expected):
        a, b = expected.get(key, "<missing>"), actual.get(key, "<missing>")
        if not _close(a, b, rel, abs_tol):
            out.append(f"{key}: stored {a!r}, now {b!r}")
    return out


def _close(a: Any, b: Any, rel: float, abs_tol: float) -> bool:
    if isinstance(a, bool) or isinstance(b, bool) or a is None or b is None:
        return a == b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return math.isclose(a, b, rel_tol=rel, abs_tol=abs_tol)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y, rel, abs_tol) for x, y in zip(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k], rel, abs_tol) for k in a)
    return a == b


if __name__ == "__main__":
    sys.exit(main())
