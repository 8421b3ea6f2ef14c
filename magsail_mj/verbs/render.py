"""``magsail render``: a run folder (or two side by side) as an MP4."""

from __future__ import annotations

import argparse

from magsail_mj.render.compose import render_run
from magsail_mj.verbs.common import non_empty

__all__ = ["render"]


def render(args: argparse.Namespace) -> int:
    """Render ``RUN_DIR`` (and ``--compare``) to ``--output``; print the video's path."""
    out = render_run(
        non_empty(args.run_dir, "RUN_DIR"),
        non_empty(args.output, "--output"),
        compare=non_empty(args.compare, "--compare") if args.compare is not None else None,
        labels=args.labels,
    )
    print(str(out))
    return 0
