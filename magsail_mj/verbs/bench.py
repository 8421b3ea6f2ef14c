"""``magsail bench``: the cost per step of a config (:func:`magsail_mj.bench.bench`)."""

from __future__ import annotations

import argparse
import logging

from magsail_mj.batch.groups import batch_bytes
from magsail_mj.bench import BenchRunError, bench
from magsail_mj.resources import check_memory, estimate_run_bytes
from magsail_mj.verbs.common import load, print_json

__all__ = ["run_bench"]

LOG = logging.getLogger("magsail_mj")


def run_bench(args: argparse.Namespace) -> int:
    """One JSON object on stdout; a pass that diverged exits 3, one that failed otherwise 1."""
    if args.duration_s is not None:
        args.set = [*args.set, f"sim.duration_s={args.duration_s!r}"]
    cfg = load(args)
    worlds = getattr(args, "worlds", None)  # a batch of identical worlds (bench_worlds)
    # a batch holds one world's records at a time in memory (each world streams to its store)
    need = batch_bytes(cfg, worlds) if worlds else estimate_run_bytes(cfg)
    check_memory(need, what=f"bench {args.config}: a run")
    try:
        result = bench(cfg, repeat=args.repeat, worlds=worlds, nthread=getattr(args, "nthread", 1))
    except BenchRunError as err:
        LOG.error("%s", err)
        return 3 if err.status == "diverged" else 1
    print_json({"config": args.config, **result}, what="bench")
    return 0
