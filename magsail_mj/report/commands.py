"""``magsail report collect | render | update``: the command-line side of the reproduction reports.

``collect RUN_DIR... [--bundle results]`` copies what the reports need from finished run folders
into the bundle; ``render [--bundle results] [--out docs/reproduction]`` writes the pages;
``update RUN_DIR...`` (also ``magsail report RUN_DIR...``) does both. Each prints one JSON object
on stdout (the files written) and returns 0, or 2 with ``error: <what>`` on stderr naming the
folder, file or claim when an input is refused.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from magsail_mj.cli import DEFAULT_BUNDLE, add_collect_arguments, add_render_arguments
from magsail_mj.cli import DEFAULT_PAGES as DEFAULT_OUT
from magsail_mj.report.bundle import BundleError, bundle_bytes, collect
from magsail_mj.report.registry import RegistryError, load_registry
from magsail_mj.report.render import render
from magsail_mj.report.verdict import MissingExplanation, MissingKey

__all__ = [
    "DEFAULT_BUNDLE",
    "DEFAULT_OUT",
    "add_collect_arguments",
    "add_render_arguments",
    "collect_main",
    "render_main",
    "update_main",
]

_REFUSED = (BundleError, RegistryError, MissingExplanation, MissingKey)


def _fail(err: Exception) -> int:
    text = err.args[0] if isinstance(err, KeyError) and err.args else str(err)
    print(f"error: {text}", file=sys.stderr)
    return 2


def _collect(args: argparse.Namespace) -> dict[str, object]:
    written = collect(args.run_dirs, args.bundle, load_registry())
    return {"bundle": str(args.bundle), "runs": [str(p) for p in written], "bundle_bytes": bundle_bytes(args.bundle)}


def _render(args: argparse.Namespace) -> dict[str, object]:
    if not Path(args.bundle).is_dir():
        raise BundleError(f"--bundle {args.bundle}: not a folder")
    return {"pages": [str(p) for p in render(load_registry(), args.bundle, args.out)]}


def collect_main(args: argparse.Namespace) -> int:
    """``magsail report collect``."""
    try:
        result = _collect(args)
    except _REFUSED as err:
        return _fail(err)
    print(json.dumps(result, indent=2))
    return 0


def render_main(args: argparse.Namespace) -> int:
    """``magsail report render``."""
    try:
        result = _render(args)
    except _REFUSED as err:
        return _fail(err)
    print(json.dumps(result, indent=2))
    return 0


def update_main(args: argparse.Namespace) -> int:
    """``magsail report update`` (= ``magsail report RUN_DIR...``): collect, then render."""
    try:
        result = _collect(args) | _render(args)
    except _REFUSED as err:
        return _fail(err)
    print(json.dumps(result, indent=2))
    return 0
