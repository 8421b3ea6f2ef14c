"""Reproduction reports: paper claims against our runs, rendered from a committed results bundle.

* :mod:`magsail_mj.report.registry`: the claims of each paper (``claims/<paper>.toml``);
* :mod:`magsail_mj.report.verdict`: agrees / differs / failed / not run, computed from the bundled runs;
* :mod:`magsail_mj.report.bundle`: ``collect`` copies summaries, run identities and downscaled
  figures from finished run folders into ``results/<paper>/<run id>/``;
* :mod:`magsail_mj.report.render`: one MyST page per paper and an index (``docs/reproduction/``);
* :mod:`magsail_mj.report.commands`: ``magsail report collect | render | update``.
"""

from magsail_mj.report.bundle import BundleError, collect, read_bundle
from magsail_mj.report.registry import Claim, Paper, RegistryError, load_registry
from magsail_mj.report.render import render, render_pages
from magsail_mj.report.verdict import VERDICTS, Verdict, judge

__all__ = [
    "VERDICTS",
    "BundleError",
    "Claim",
    "Paper",
    "RegistryError",
    "Verdict",
    "collect",
    "judge",
    "load_registry",
    "read_bundle",
    "render",
    "render_pages",
]
