"""Compute the Lloyd rod selections of every shipped truss config into the package's data folder.

The orbital truss runs pick which rods of each family to switch on by centroidal Voronoi
(Lloyd) selections, one per rod count; a fresh checkout would spend minutes computing them on the
first run. This script computes every count of every distinct selection the shipped configs use
(region, seed, tolerance, iteration cap, symmetry) into ``magsail_mj/data/lloyd/`` (read by
:class:`magsail_mj.control.lloyd.LloydSelector` after its own cache; installed with the package),
and prints one line per selection. Rerun it when a shipped config changes its rods or Lloyd keys.

The runs of the reproduction registry (``magsail_mj/report/claims/``) that vary a shipped config's
Lloyd keys by ``set`` overrides (the detumble read with other seeds and mirror-symmetric selections)
get their snapped selections only (``sites_<hash>/nNNNNN.npy``, a few hundred kB in git, not the
generators): a selector reads a shipped selection before it looks for generators, so their runs
compute no Lloyd iteration either. Their generators are computed in ``--cache-dir`` (default the
configs' ``runs/lloyd_cache``, where earlier runs left theirs).

    python scripts/ship_lloyd_selections.py [--workers 2] [--cache-dir runs/lloyd_cache]
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from magsail_mj.concepts import build_task
from magsail_mj.concepts.truss_magnetorquer.orbital import lloyd_seed
from magsail_mj.config import load_config
from magsail_mj.control.lloyd import SHIPPED_DIR, LloydSelector
from magsail_mj.report.registry import REPO_ROOT, load_registry
from magsail_mj.sweep import is_sweep_file

ORBITAL_KINDS = ("detumble", "slew")  # the kinds that allocate torque over Lloyd selections
CONFIGS = Path(__file__).resolve().parent.parent / "magsail_mj" / "concepts" / "truss_magnetorquer" / "configs"


@dataclass
class Shipped:
    """One distinct selection: its selector, whether only its snapped selections are shipped, and
    the configs (or registry runs) that use it."""

    selector: LloydSelector
    selections_only: bool
    users: list[str] = field(default_factory=list)


def _selector(path: Path, overrides: list[str], *, cache_dir: Path | None) -> LloydSelector | None:
    """The Lloyd selector of an orbital magnetorquer config with ``overrides`` (None for other configs)."""
    cfg = load_config(path, overrides)
    if cfg.scenario not in ORBITAL_KINDS or getattr(cfg.actuators, "kind", None) != "magnetorquer":
        return None
    rods = build_task(cfg).rods().rods
    c = cfg.control
    return LloydSelector(
        [rods.family_sites(0), rods.family_sites(1)],
        region=rods.region,
        seed=lloyd_seed(c, cfg.sim.seed),
        tol_rel=c.lloyd.tol_rel,
        max_iter=c.lloyd.max_iter,
        cache_dir=cache_dir,
        shipped_dir=None,
        symmetry=c.lloyd.symmetry,
    )


def _key(sel: LloydSelector) -> str:
    return f"{sel.cache_key()}/{'/'.join(sel._sites_key)}"


def selectors(*, cache_dir: Path) -> dict[str, Shipped]:
    """cache key → what to ship: every shipped config (writing into :data:`SHIPPED_DIR`), then the
    registry runs with overrides whose selection no config has (generators in ``cache_dir``)."""
    found: dict[str, Shipped] = {}
    for path in sorted(p for p in CONFIGS.rglob("*.toml") if not is_sweep_file(p)):
        sel = _selector(path, [], cache_dir=SHIPPED_DIR)
        if sel is not None:
            found.setdefault(_key(sel), Shipped(sel, False)).users.append(str(path.relative_to(CONFIGS)))
    for paper in load_registry().values():
        for spec in paper.run:
            path = REPO_ROOT / spec.config
            if not spec.set or not path.is_relative_to(CONFIGS):
                continue
            sel = _selector(path, list(spec.set), cache_dir=cache_dir)
            if sel is not None:
                found.setdefault(_key(sel), Shipped(sel, True)).users.append(f"{paper.paper}/{spec.id}")
    return found


def ship_selections(sel: LloydSelector) -> int:
    """Copy the snapped selections of ``sel`` (from its cache) into :data:`SHIPPED_DIR`; returns the count."""
    dest = SHIPPED_DIR / sel.cache_dir.name
    copied = 0
    for family in range(len(sel.sites)):
        for count in range(sel.n_sites[family]):  # the full count needs no file
            src = sel._snap_path(family, count)
            target = dest / src.parent.name / src.name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src, target)
            copied += 1
    return copied


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--workers", type=int, default=2, help="processes for the Lloyd iterations (default 2)")
    parser.add_argument(
        "--cache-dir",
        type=Path,
        default=Path("runs/lloyd_cache"),
        help="where the registry runs' generators are computed or found (default runs/lloyd_cache)",
    )
    args = parser.parse_args(argv)
    if args.workers < 1:
        parser.error("--workers: must be >= 1")
    for key, item in selectors(cache_dir=args.cache_dir).items():
        sel = item.selector
        t0 = time.perf_counter()
        sel.precompute(workers=args.workers)
        files = ship_selections(sel) if item.selections_only else None
        print(
            json.dumps(
                {
                    "key": key,
                    "counts": max(sel.n_sites) + 1,
                    "users": len(item.users),
                    "selections_only": item.selections_only,
                    "selection_files": files,
                    "lloyd_runs": sel.stats["lloyd_runs"],
                    "wall_s": round(time.perf_counter() - t0, 1),
                }
            ),
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
