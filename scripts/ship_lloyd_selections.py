"""Compute the Lloyd rod selections of every shipped truss config into the package's data folder.

The orbital truss runs pick which rods of each family to switch on by centroidal Voronoi
(Lloyd) selections, one per rod count; a fresh checkout would spend minutes computing them on the
first run. This script computes every count of every distinct selection the shipped configs use
(region, seed, tolerance, iteration cap) into ``magsail_mj/data/lloyd/`` (read by
:class:`magsail_mj.control.lloyd.LloydSelector` after its own cache; installed with the package),
and prints one line per selection. Rerun it when a shipped config changes its rods or Lloyd keys.

    python scripts/ship_lloyd_selections.py [--workers 2]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from magsail_mj.concepts import build_task
from magsail_mj.concepts.truss_magnetorquer.orbital import lloyd_seed
from magsail_mj.config import load_config
from magsail_mj.control.lloyd import SHIPPED_DIR, LloydSelector
from magsail_mj.sweep import is_sweep_file

ORBITAL_KINDS = ("detumble", "slew")  # the kinds that allocate torque over Lloyd selections
CONFIGS = Path(__file__).resolve().parent.parent / "magsail_mj" / "concepts" / "truss_magnetorquer" / "configs"


def selectors() -> dict[str, tuple[LloydSelector, list[str]]]:
    """cache key → (a selector writing into :data:`SHIPPED_DIR`, the configs that use it)."""
    found: dict[str, tuple[LloydSelector, list[str]]] = {}
    for path in sorted(p for p in CONFIGS.rglob("*.toml") if not is_sweep_file(p)):
        cfg = load_config(path)
        if cfg.scenario not in ORBITAL_KINDS or getattr(cfg.actuators, "kind", None) != "magnetorquer":
            continue
        rods = build_task(cfg).rods().rods
        c = cfg.control
        sel = LloydSelector(
            [rods.family_sites(0), rods.family_sites(1)],
            region=rods.region,
            seed=lloyd_seed(c, cfg.sim.seed),
            tol_rel=c.lloyd.tol_rel,
            max_iter=c.lloyd.max_iter,
            cache_dir=SHIPPED_DIR,
            shipped_dir=None,
        )
        key = f"{sel.cache_key()}/{'/'.join(sel._sites_key)}"
        found.setdefault(key, (sel, []))[1].append(str(path.relative_to(CONFIGS)))
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--workers", type=int, default=2, help="processes for the Lloyd iterations (default 2)")
    args = parser.parse_args(argv)
    if args.workers < 1:
        parser.error("--workers: must be >= 1")
    for key, (sel, users) in selectors().items():
        t0 = time.perf_counter()
        sel.precompute(workers=args.workers)
        print(
            json.dumps(
                {
                    "key": key,
                    "counts": max(sel.n_sites) + 1,
                    "configs": len(users),
                    "lloyd_runs": sel.stats["lloyd_runs"],
                    "wall_s": round(time.perf_counter() - t0, 1),
                }
            ),
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
