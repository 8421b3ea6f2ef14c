"""``magsail build`` and ``magsail validate``: a config's model and its check (no run, so no Dask,
Matplotlib or mediapy is loaded)."""

from __future__ import annotations

import argparse
from pathlib import Path

from magsail_mj.cli import CliInputError
from magsail_mj.io import atomic_path
from magsail_mj.resources import check_memory, estimate_model_bytes, estimate_run_bytes
from magsail_mj.scenario import build_scenario
from magsail_mj.verbs.common import load, output_file, print_json

__all__ = ["build", "default_mjcf_path", "validate"]


def default_mjcf_path(config: str | Path) -> Path:
    """Where ``magsail build CONFIG`` writes without ``-o``: beside the config, same stem, ``.xml``."""
    return Path(config).with_suffix(".xml")


def build(args: argparse.Namespace) -> int:
    """Write the MJCF of the config and print the model size (one JSON object).

    Without ``-o`` the MJCF goes beside the config (:func:`default_mjcf_path`): that file is the
    model of the config as written, so it is written only without ``--set``; with overrides the
    output must be named with ``-o`` (a committed model beside its config is never replaced by
    the model of other values).
    """
    out = output_file(args.output, "--output") if args.output is not None else None
    cfg = load(args)
    check_memory(estimate_model_bytes(cfg), what=f"build {args.config}")
    if out is None and args.set:  # the config's own problems are reported first
        raise CliInputError(
            f"--output: required with --set (without -o, build writes the model of the config as written to "
            f"{str(default_mjcf_path(args.config))!r}; name the model of the overridden config with -o OUT.xml)"
        )
    out = out or default_mjcf_path(args.config)
    scenario = build_scenario(cfg)
    with atomic_path(out) as tmp:
        tmp.write_text(scenario.spec.to_xml())
    size = scenario.manifest_extra().get("model_size", {})
    print_json({"mjcf": str(out), **size}, what="build")
    return 0


def validate(args: argparse.Namespace) -> int:
    """Check the config (every problem with its key path) and the memory a run of it needs."""
    cfg = load(args)
    estimate = check_memory(estimate_run_bytes(cfg), what=f"validate {args.config}: a run")
    print_json(
        {
            "config": args.config,
            "concept": cfg.concept,
            "scenario": cfg.scenario,
            "valid": True,
            "memory_estimate_bytes": estimate,
        },
        what="validate",
    )
    return 0
