"""``magsail`` command line: build | validate | run | bench | render | export | sweep | report | scaling | torque |
modes.

``report`` has the actions collect | render | update (reproduction reports) and sweep (a sweep report).

Every verb checks its inputs where it uses them (paths, numbers, the memory the input needs) and
reports a problem as one line ``error: <what>`` on stderr, never a traceback; the exit status
follows :data:`EXIT_CODES`. ``MAGSAIL_DEBUG=1`` adds the traceback of an unexpected error.

Messages go through :mod:`logging` (logger ``magsail_mj`` and its children) to stderr: warnings
and errors by default, ``-v`` adds progress messages (INFO), ``-vv`` debugging detail (DEBUG).
Results (JSON, paths) go to stdout. ``python -m magsail_mj`` is the same command.

Start-up: this module imports the standard library only, so the parser (``--help``, ``--version``,
a usage error) is built and answered at once. The dispatcher (:func:`_dispatch`) is the one place
that imports late: when a verb runs, it loads :mod:`magsail_mj.verbs.common` and the verb's own
module (:class:`_Handler`, e.g. :mod:`magsail_mj.verbs.model` for ``validate``), so a verb loads
what it needs and no more (``validate`` imports neither Dask nor Matplotlib nor mediapy).
``scripts/bench_startup.py`` prints the start-up times and the heavy modules each verb imports.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import importlib
import logging
import math
import os
import signal
import sys
import threading
import traceback
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any, NoReturn

__all__ = ["EXIT_CODES", "RUN_EXIT", "CliInputError", "forget_handled_interrupt", "main", "version_text"]

EXIT_CODES = """\
exit status:
  0    success
  1    a run or an output failed for another reason (e.g. the video could not be
       rendered, a sweep run failed)
  2    invalid input, or a refused resume or output folder ('error: ...' on stderr,
       naming the option or key and the value)
  3    the simulation diverged (its outputs up to the divergence are written)
  130  interrupted (Ctrl-C / SIGINT or SIGTERM); the run folder is left consistent
  sweep: non-zero when any run failed, was interrupted or stopped (1), else when any diverged (3)
  export, report: 2 when the folder is not a run folder / a finished sweep folder, or a
       run folder matches no registry run (report collect/update)

memory: every verb estimates the memory its input needs before allocating it and refuses
  (exit 2) above --memory-limit BYTES|auto (or $MAGSAIL_MEMORY_LIMIT; default: the
  machine's available memory)."""

DESCRIPTION = (
    "magsail: spacecraft geometry configs (TOML) to MuJoCo models and attitude-control runs "
    "in orbit. 'python -m magsail_mj' is the same command."
)
DEBUG_ENV = "MAGSAIL_DEBUG"
LOG = logging.getLogger("magsail_mj")
# -v count → level of the ``magsail_mj`` logger (quiet by default: warnings and errors only)
_LEVELS = (logging.WARNING, logging.INFO, logging.DEBUG)
# the packages whose versions ``--version`` prints
_VERSION_PACKAGES = ("magsail_mj", "mujoco", "numpy")
# errno values of an OSError that mean: this path cannot be used as given (exit 2).
_PATH_ERRNOS = {
    errno.ENOENT,
    errno.ENOTDIR,
    errno.EISDIR,
    errno.EACCES,
    errno.EPERM,
    errno.EROFS,
    errno.EEXIST,
    errno.ENAMETOOLONG,
    errno.ELOOP,
    errno.EINVAL,
}
MEMORY_ENV_VAR = "MAGSAIL_MEMORY_LIMIT"
"""The environment variable of the default memory limit (:data:`magsail_mj.resources.ENV_VAR`)."""
RUN_EXIT = {"diverged": 3, "failed": 1, "interrupted": 130}
"""Exit status of ``magsail run`` by the run's final status (any other status: 0)."""
_RUN_EXIT = RUN_EXIT


class CliInputError(ValueError):
    """A command-line input is invalid (the message names the option or argument)."""


class _UsageError(CliInputError):
    """argparse refused the command line."""


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are raised (``error: ...``, exit 2 in :func:`main`) rather than
    printed by argparse with the program name in front."""

    def error(self, message: str) -> NoReturn:
        """``argument --x: msg`` becomes ``--x: msg``; other messages are prefixed by the program."""
        if message.startswith("argument ") and ": " in message:
            name, rest = message[len("argument ") :].split(": ", 1)
            raise _UsageError(f"{name.split('/')[-1]}: {rest} (see {self.prog} --help)")
        raise _UsageError(f"{self.prog}: {message} (see {self.prog} --help)")


# --------------------------------------------------------------------------- logging, version


class _StderrHandler(logging.StreamHandler):
    """A handler that writes to the ``sys.stderr`` of the moment (so a replaced stderr, as under
    pytest's ``capsys``, receives the messages)."""

    def __init__(self) -> None:
        super().__init__(sys.stderr)

    @property
    def stream(self) -> Any:
        """The current ``sys.stderr``."""
        return sys.stderr

    @stream.setter
    def stream(self, value: Any) -> None:
        """Ignored: the stream is always the current ``sys.stderr``."""


class _Formatter(logging.Formatter):
    """``error: <msg>`` / ``warning: <msg>`` for WARNING and above, the bare message below."""

    def format(self, record: logging.LogRecord) -> str:
        """One line per record; the level name in lower case in front of warnings and errors."""
        text = record.getMessage()
        if record.exc_info:
            text = f"{text}\n{self.formatException(record.exc_info)}"
        if record.levelno >= logging.WARNING:
            return f"{record.levelname.lower()}: {text}"
        return text


@contextlib.contextmanager
def _logging_to_stderr(*, verbosity: int) -> Iterator[None]:
    """Within the block, the ``magsail_mj`` logger writes to stderr at the level of ``verbosity``
    (0: WARNING, 1: INFO, 2 or more: DEBUG); its earlier level, handlers and propagation are
    restored afterwards."""
    handler = _StderrHandler()
    handler.setFormatter(_Formatter())
    saved = (LOG.level, LOG.propagate)
    LOG.setLevel(_LEVELS[min(max(verbosity, 0), len(_LEVELS) - 1)])
    LOG.propagate = False
    LOG.addHandler(handler)
    try:
        yield
    finally:
        LOG.removeHandler(handler)
        LOG.setLevel(saved[0])
        LOG.propagate = saved[1]


def version_text() -> str:
    """``magsail <version> (mujoco <v>, numpy <v>, Python <v>)``: the installed distributions'
    versions (``not installed`` for a missing one)."""
    found = {}
    for name in _VERSION_PACKAGES:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = "not installed"
    others = ", ".join(f"{name} {found[name]}" for name in _VERSION_PACKAGES[1:])
    return f"magsail {found['magsail_mj']} ({others}, Python {sys.version.split()[0]})"


# --------------------------------------------------------------------------- argument types


def _number(text: str, *, what: str) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r} (not finite)")
    return value


def _positive(text: str) -> float:
    """A finite number > 0 (a physical size, mass, current, field)."""
    value = _number(text, what="a finite number > 0")
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
    return value


def _non_negative(text: str) -> float:
    """A finite number >= 0."""
    value = _number(text, what="a finite number >= 0")
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text!r}")
    return value


def _integer_at_least(text: str, low: int) -> int:
    """An integer >= ``low``; argparse's type error otherwise."""
    try:
        value = int(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"expected an integer >= {low}, got {text!r}") from None
    if value < low:
        raise argparse.ArgumentTypeError(f"must be an integer >= {low}, got {text!r}")
    return value


def _count(text: str) -> int:
    """An integer >= 1 (a count)."""
    return _integer_at_least(text, 1)


def _count_or_zero(text: str) -> int:
    """An integer >= 0."""
    return _integer_at_least(text, 0)


SWEEP_MAX_BATCH_SIZE = 1024
"""The largest ``magsail sweep --batch-size`` (:data:`magsail_mj.sweep.batches.MAX_BATCH_SIZE`,
mirrored so that the parser imports no Dask; tests/test_sweep_batch.py checks they agree)."""


def _batch_size(text: str) -> int:
    """An integer from 1 to :data:`SWEEP_MAX_BATCH_SIZE` (the worlds of a sweep's batch)."""
    value = _integer_at_least(text, 1)
    if value > SWEEP_MAX_BATCH_SIZE:
        raise argparse.ArgumentTypeError(f"must be an integer from 1 to {SWEEP_MAX_BATCH_SIZE}, got {text!r}")
    return value


def _memory(text: str) -> str:
    """The text of ``--memory-limit`` (parsed by the dispatcher, which names the option in an error)."""
    if not str(text).strip():
        raise argparse.ArgumentTypeError(
            f"expected a number of bytes (suffix K, M, G or T allowed) or 'auto', got {text!r}"
        )
    return text


class _VersionAction(argparse.Action):
    """``--version``: print :func:`version_text` and exit (the versions are read only when asked)."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS, **kwargs: Any) -> None:
        super().__init__(option_strings, dest=dest, default=argparse.SUPPRESS, nargs=0, **kwargs)

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        print(version_text())
        parser.exit()


# --------------------------------------------------------------------------- verbs


class _Handler:
    """A verb's handler named by its module and function: the module is imported when the verb
    runs (by :func:`_dispatch`, through this call), never when the parser is built."""

    def __init__(self, module: str, function: str) -> None:
        self.module, self.function = module, function

    def __call__(self, args: argparse.Namespace) -> int:
        """Import the module and run the handler with ``args``; its exit status."""
        return getattr(importlib.import_module(self.module), self.function)(args)

    def __repr__(self) -> str:
        return f"_Handler({self.module}:{self.function})"


_cmd_build = _Handler("magsail_mj.verbs.model", "build")
_cmd_validate = _Handler("magsail_mj.verbs.model", "validate")
_cmd_run = _Handler("magsail_mj.verbs.run", "run")
_cmd_bench = _Handler("magsail_mj.verbs.bench", "run_bench")
_cmd_render = _Handler("magsail_mj.verbs.render", "render")
_cmd_export = _Handler("magsail_mj.export", "main")
_cmd_sweep = _Handler("magsail_mj.verbs.sweep", "sweep")
_cmd_report = _Handler("magsail_mj.sweep.report", "main")
_cmd_report_collect = _Handler("magsail_mj.report.commands", "collect_main")
_cmd_report_render = _Handler("magsail_mj.report.commands", "render_main")
_cmd_report_update = _Handler("magsail_mj.report.commands", "update_main")
_cmd_scaling_magnetorquer = _Handler("magsail_mj.verbs.analytic", "scaling_magnetorquer")
_cmd_scaling_loops = _Handler("magsail_mj.verbs.analytic", "scaling_loops")
_cmd_torque_coil = _Handler("magsail_mj.verbs.analytic", "torque_coil")
_cmd_modes = _Handler("magsail_mj.verbs.modes", "modes")


# --------------------------------------------------------------------------- parser


def _verb(
    sub: Any,
    name: str,
    help_text: str,
    fn: Callable[[argparse.Namespace], int],
    options: Mapping[str, str] | None = None,
) -> argparse.ArgumentParser:
    """A sub-command with the exit-status epilog, the ``--memory-limit`` option, its function and
    the map from library argument names to its options (used to name options in errors)."""
    p = sub.add_parser(
        name,
        help=help_text,
        description=help_text,
        epilog=EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--memory-limit",
        type=_memory,
        default=argparse.SUPPRESS,
        metavar="BYTES|auto",
        help=f"refuse inputs needing more memory (default: ${MEMORY_ENV_VAR}, else the available memory)",
    )
    _verbose_option(p, default=argparse.SUPPRESS)
    p.set_defaults(fn=fn, options=dict(options or {}))
    return p


def _verbose_option(p: argparse.ArgumentParser, *, default: Any) -> None:
    """``-v/--verbose`` (repeatable): more messages on stderr."""
    p.add_argument(
        "-v",
        "--verbose",
        action="count",
        default=default,
        help="more messages on stderr: -v progress (INFO), -vv debugging detail (DEBUG); "
        "default: warnings and errors only",
    )


_CONFIG_HELP = "config TOML file (see the config reference: docs/reference/config.md)"


def _set_option(
    p: argparse.ArgumentParser, help_text: str = "override a config key, e.g. --set sim.duration_s=60"
) -> None:
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=help_text)


# --------------------------------------------------------------------------- arguments of the library verbs

EXPORT_FORMATS = {"npz": ".npz", "netcdf": ".nc"}
"""``magsail export`` formats and their file suffixes (:data:`magsail_mj.export.FORMATS`)."""
DEFAULT_BUNDLE = "results"
"""The results bundle of ``magsail report collect | render | update``."""
DEFAULT_PAGES = "docs/reproduction"
"""The folder of the reproduction pages of ``magsail report render | update``."""


def add_export_arguments(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """The ``export`` verb's arguments: ``RUN_DIR``, ``--format``, ``--out``."""
    parser.add_argument("run_dir", metavar="RUN_DIR", help="run folder holding timeseries.zarr")
    parser.add_argument(
        "--format",
        dest="format",
        default=None,
        metavar="npz|netcdf",
        help="output format (default: the one of the --out extension, .npz or .nc; else npz); "
        "a --out extension of the other format is refused",
    )
    parser.add_argument(
        "--out",
        default=None,
        help="output file, outside the run's own files (default RUN_DIR/timeseries.npz or RUN_DIR/timeseries.nc)",
    )
    return parser


def add_sweep_report_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``magsail report sweep``: ``SWEEP_DIR`` and ``--figure KEY`` (repeatable)."""
    parser.add_argument("sweep_dir", metavar="SWEEP_DIR", help="folder of a finished sweep (sweep_summary.json)")
    parser.add_argument(
        "--figure",
        action="append",
        default=None,
        metavar="KEY",
        help="summary key to report (repeatable; default: the sweep file's [report] figures)",
    )


def _bundle_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--bundle",
        default=DEFAULT_BUNDLE,
        metavar="DIR",
        help=f"results bundle folder: <bundle>/<paper>/<run id>/ and index.json (default {DEFAULT_BUNDLE})",
    )


def add_collect_arguments(p: argparse.ArgumentParser) -> None:
    """``RUN_DIR...`` and ``--bundle`` (``magsail report collect | update``)."""
    p.add_argument(
        "run_dirs",
        nargs="+",
        metavar="RUN_DIR",
        help="finished run folders (summary.json, manifest.json), or sweep folders standing for their "
        "runs; each run must match one registry run (magsail_mj/report/claims/*.toml) by concept, "
        "scenario and config",
    )
    _bundle_option(p)


def add_render_arguments(p: argparse.ArgumentParser) -> None:
    """``--bundle`` and ``--out`` (``magsail report render``)."""
    _bundle_option(p)
    p.add_argument(
        "--out",
        default=DEFAULT_PAGES,
        metavar="DIR",
        help=f"folder of the MyST pages: one <paper>.md per paper and index.md (default {DEFAULT_PAGES})",
    )


def _add_run_verbs(sub: Any) -> None:
    b = _verb(sub, "build", "write the MJCF of a config and print the model size", _cmd_build)
    b.add_argument("config", help=_CONFIG_HELP)
    b.add_argument(
        "-o",
        "--output",
        help="MJCF path (default: next to the config, same stem, .xml: the model of the config as written, "
        "so -o is required with --set)",
    )
    _set_option(b)

    v = _verb(sub, "validate", "check a config (and the memory a run of it needs) and exit", _cmd_validate)
    v.add_argument("config", help=_CONFIG_HELP)
    _set_option(v)

    r = _verb(sub, "run", "simulate a config into a run folder", _cmd_run)
    r.add_argument("config", help=_CONFIG_HELP)
    r.add_argument("--out", required=True, help="run folder")
    r.add_argument("--video", action="store_true", help="also render video.mp4")
    _set_option(r)
    r.add_argument("--resume", action="store_true", help="continue from the folder's checkpoint")
    r.add_argument("--overwrite", action="store_true", help="replace an earlier run in --out")
    r.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    r.add_argument(
        "--stop-after-s",
        type=_positive,
        default=None,
        metavar="T",
        help="stop at simulated time T with a checkpoint (status 'stopped', exit 0); continue later with --resume",
    )

    bn = _verb(
        sub,
        "bench",
        "time a config's step loop against MuJoCo's bare mj_step (one JSON object on stdout)",
        _cmd_bench,
        {"duration_s": "--duration-s", "repeat": "--repeat", "worlds": "--worlds", "nthread": "--threads"},
    )
    bn.add_argument("config", help=_CONFIG_HELP)
    bn.add_argument(
        "--duration-s",
        type=_positive,
        default=None,
        metavar="T",
        help="simulated seconds per timed pass (default: the config's sim.duration_s)",
    )
    bn.add_argument(
        "--repeat",
        type=_count,
        default=1,
        metavar="N",
        help="timed all-in and bare passes; the medians are reported (default 1)",
    )
    bn.add_argument(
        "--worlds",
        type=_count,
        default=None,
        metavar="N",
        help="time a batch of N identical worlds (the CNUSAIL B-dot detumble): adds worlds, us_per_world_step "
        "and ratio_to_mj_step per world-step, and for a config on the Python path the same batch with compiled "
        "loads (us_per_world_step_compiled, ratio_to_mj_step_compiled)",
    )
    bn.add_argument(
        "--threads",
        dest="nthread",
        type=_count,
        default=1,
        metavar="N",
        help="threads stepping the batch (with --worlds; default 1)",
    )
    _set_option(bn)

    rr = _verb(
        sub,
        "render",
        "render a run folder to MP4 (optionally side by side)",
        _cmd_render,
        {"run_dir": "RUN_DIR", "out_path": "--output", "compare": "--compare", "labels": "--labels"},
    )
    rr.add_argument("run_dir", help="run folder written by 'magsail run' (left side when comparing)")
    rr.add_argument("-o", "--output", required=True, help="video path; only .mp4 (H.264) is written")
    rr.add_argument("--compare", help="second run folder, shown on the right")
    rr.add_argument(
        "--labels",
        nargs=2,
        metavar=("LEFT", "RIGHT"),
        help="captions of the left and right run (default: the run folders' names)",
    )

    ex = _verb(
        sub,
        "export",
        "write a run folder's records (timeseries.zarr) as .npz or netCDF",
        _cmd_export,
        {"run_dir": "RUN_DIR", "fmt": "--format", "out": "--out"},
    )
    add_export_arguments(ex)

    sw = _verb(
        sub,
        "sweep",
        "run every run of a sweep file ([[run]], [grid], [monte_carlo]) on Dask",
        _cmd_sweep,
        {
            "workers": "--workers",
            "only": "--only",
            "retries": "--retries",
            "scheduler": "--scheduler",
            "batch_size": "--batch-size",
        },
    )
    sw.add_argument("sweep", help="sweep TOML ([[run]] tables with id and config, or [grid] / [monte_carlo])")
    sw.add_argument("--out", help="sweep folder (default: runs/<sweep name>)")
    sw.add_argument(
        "--workers",
        type=_count,
        default=1,
        help="worker processes of the local Dask cluster, one thread each (default 1)",
    )
    sw.add_argument(
        "--only",
        action="append",
        metavar="TEXT",
        help="run only the ids containing this text (repeatable: any of them)",
    )
    sw.add_argument("--video", action="store_true", help="render video.mp4 in every run folder")
    sw.add_argument(
        "--no-plots",
        action="store_true",
        help="no PNG plots in the run folders (records, summary and manifest only; as the sweep file's plots = false)",
    )
    _set_option(sw, "override a key in every run, e.g. --set sim.duration_s=60")
    sw.add_argument("--overwrite", action="store_true", help="rerun runs that already finished")
    sw.add_argument(
        "--no-progress",
        action="store_true",
        help="no sweep progress bar on stderr (it shows only on a terminal anyway)",
    )
    sw.add_argument(
        "--report",
        action="store_true",
        help="after the runs, write the sweep report (tables and figures) into OUT/report",
    )
    sw.add_argument(
        "--retries",
        type=_count_or_zero,
        default=2,
        help="retries of a run whose process was killed (default 2; a retry resumes from its checkpoint)",
    )
    sw.add_argument(
        "--batch-size",
        type=_batch_size,
        metavar="N",
        help=(
            "runs of one compiled model (CNUSAIL B-dot) run as the worlds of batches of up to N runs, one "
            f"task each; 1: every run alone (default: from the cores and the memory estimate, at most 64; "
            f"at most {SWEEP_MAX_BATCH_SIZE})"
        ),
    )
    sw.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on a running Dask scheduler, e.g. tcp://127.0.0.1:8786 (see docs/sweeps.md)",
    )
    sw.add_argument(
        "--cluster",
        choices=("slurm", "pbs"),
        help="start Dask workers as batch jobs through dask-jobqueue (extra 'cluster')",
    )
    sw.add_argument("--jobs", type=_count, help="--cluster: number of batch jobs (default 1)")
    sw.add_argument("--cores-per-job", type=_count, help="--cluster: worker processes (cores) per job (default 1)")
    sw.add_argument("--memory-per-job", metavar="SIZE", help="--cluster: memory per job, e.g. 16GB (default 4GB)")
    sw.add_argument("--walltime", metavar="HH:MM:SS", help="--cluster: wall time per job (default 01:00:00)")
    sw.add_argument("--queue", help="--cluster: partition (SLURM) or queue (PBS)")
    sw.add_argument("--account", help="--cluster: account to charge")

    _add_report_verb(sub)


_REPORT_ACTIONS = ("collect", "render", "update", "sweep")
_REPORT_HELP = """\
reproduction reports and sweep reports:
  magsail report collect RUN_DIR... [--bundle results]      copy finished runs into the results bundle
  magsail report render [--bundle results] [--out docs/reproduction]   write one MyST page per paper
  magsail report update RUN_DIR... [--bundle ...] [--out ...]          collect, then render
  magsail report RUN_DIR... [--bundle ...] [--out ...]                 the same as update
  (a sweep folder given to collect/update stands for its run folders)
  magsail report sweep SWEEP_DIR [--figure KEY]             tables and figures of a finished sweep
  magsail report SWEEP_DIR [--figure KEY]                   the same as sweep (one folder that is not a
                                                            run folder, or --figure given; no --bundle/--out)"""


def _add_report_verb(sub: Any) -> None:
    """``magsail report collect | render | update | sweep`` (see :func:`_report_argv`)."""
    rp = sub.add_parser(
        "report",
        help="reproduction reports from finished runs (collect, render, update) or a sweep report (sweep)",
        description=_REPORT_HELP,
        epilog=EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    actions = rp.add_subparsers(dest="report_action", required=True, metavar="ACTION", help="what to report")
    co = _verb(
        actions,
        "collect",
        "copy what the reproduction reports need from run folders into the bundle",
        _cmd_report_collect,
    )
    add_collect_arguments(co)
    rn = _verb(
        actions, "render", "write the reproduction pages (MyST) from the registry and the bundle", _cmd_report_render
    )
    add_render_arguments(rn)
    up = _verb(actions, "update", "collect the run folders, then render the pages", _cmd_report_update)
    add_collect_arguments(up)
    up.add_argument(
        "--out", default=DEFAULT_PAGES, metavar="DIR", help=f"folder of the MyST pages (default {DEFAULT_PAGES})"
    )
    sw = _verb(
        actions,
        "sweep",
        "summarise a finished sweep folder: tables and figures of its runs' summaries",
        _cmd_report,
        {"sweep_dir": "SWEEP_DIR", "figures": "--figure"},
    )
    add_sweep_report_arguments(sw)


_REPORT_VALUE_OPTIONS = ("--figure", "--bundle", "--out", "--memory-limit")
"""Options of ``magsail report`` that take a value (a value is no folder argument)."""


def _report_argv(argv: list[str]) -> list[str]:
    """``magsail report X...`` without an action becomes ``report sweep X`` when ``--figure`` is
    given, or when X is one folder that is not a run folder (no manifest.json) and neither
    ``--bundle`` nor ``--out`` is given; else ``report update X...``."""
    i = 0
    while i < len(argv) and argv[i].startswith("-"):
        i += 2 if argv[i] == "--memory-limit" else 1
    if i >= len(argv) - 1 or argv[i] != "report" or argv[i + 1] in _REPORT_ACTIONS or argv[i + 1].startswith("-"):
        return argv
    rest = argv[i + 1 :]
    positional, options = [], []
    j = 0
    while j < len(rest):
        arg = rest[j]
        if arg.startswith("-"):
            options.append(arg.split("=", 1)[0])
            j += 2 if arg in _REPORT_VALUE_OPTIONS else 1
            continue
        positional.append(arg)
        j += 1
    reproduction = any(o in ("--bundle", "--out") for o in options)
    sweep = "--figure" in options or (
        len(positional) == 1 and not reproduction and not (Path(positional[0]) / "manifest.json").is_file()
    )
    return [*argv[: i + 1], "sweep" if sweep else "update", *rest]


def _add_analytic_verbs(sub: Any) -> None:
    sc = sub.add_parser(
        "scaling",
        help="analytic scaling laws (one JSON object on stdout)",
        epilog=EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _verbose_option(sc, default=argparse.SUPPRESS)
    scs = sc.add_subparsers(dest="law", required=True, metavar="LAW", help="the scaling law")
    mt = _verb(
        scs,
        "magnetorquer",
        "rod mass fraction λ_f(d, κ_τ) (Robb et al. 2022a, Sec. 4.1)",
        _cmd_scaling_magnetorquer,
        {
            "side_m": "--side-m",
            "kappa": "--kappa",
            "altitude_km": "--altitude-km",
            "total_kg": "--total-kg",
            "rod_mass_kg": "--rod-mass-kg",
        },
    )
    mt.add_argument("--side-m", type=_positive, nargs="+", required=True, help="plate side(s) d [m]")
    mt.add_argument("--kappa", type=_positive, nargs="+", required=True, help="dipole per rod mass κ_τ [A m²/kg]")
    mt.add_argument(
        "--altitude-km",
        type=_non_negative,
        default=800.0,
        help="circular orbit altitude [km], sets the field strength (default 800)",
    )
    mt.add_argument("--total-kg", type=_positive, default=200.0, help="spacecraft total mass [kg] (default 200)")
    mt.add_argument(
        "--rod-mass-kg", type=_non_negative, default=100.0, help="mass of all magnetorquer rods [kg] (default 100)"
    )

    lo = _verb(
        scs,
        "loops",
        "current-loop sizing: Eq.-9 current, wire, λ_f, power (Robb et al. 2022b, Eqs. 2–11)",
        _cmd_scaling_loops,
        {
            "geometry": "--geometry",
            "units": "--units",
            "side_m": "--side-m",
            "areal_density_kg_m2": "--areal-density",
            "kappa": "--kappa",
        },
    )
    lo.add_argument("--geometry", help="loop geometry A, B, C or D (Cx/Cy/Dx/Dy accepted)")
    lo.add_argument("--units", type=_count, default=19, help="cubic units per side N (default 19)")
    lo.add_argument("--side-m", type=_positive, default=250.0, help="plate side D [m] (default 250)")
    lo.add_argument(
        "--areal-density", type=_positive, default=0.1, metavar="KG_M2", help="areal density σ_A [kg/m²] (default 0.1)"
    )
    lo.add_argument(
        "--kappa",
        type=_non_negative,
        default=15.0,
        help="geometry A rim-inertia factor κ = 12 k_c − 1 (paper 15, physical 1)",
    )
    lo.add_argument(
        "--table",
        action="store_true",
        help="print the scaling object (A–D × N = 12, 19, 27) instead of one sizing",
    )

    tq = sub.add_parser(
        "torque",
        help="analytic actuator torques (one JSON object on stdout)",
        epilog=EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _verbose_option(tq, default=argparse.SUPPRESS)
    tqs = tq.add_subparsers(dest="actuator", required=True, metavar="ACTUATOR", help="the actuator")
    tc = _verb(
        tqs,
        "coil",
        "reflector coil paths: capability T_max, torque vectors (Robb et al. 2020, Eqs. 1–4)",
        _cmd_torque_coil,
        {
            "side_m": "--side-m",
            "segment_m": "--segment-m",
            "depth_m": "--depth-m",
            "current_A": "--current-a",
            "field_T": "--field-t",
            "pitch_cells": "--pitch-cells",
            "rows": "--rows",
        },
    )
    tc.add_argument("--side-m", type=_positive, default=100.0, help="structure side d [m] (default 100)")
    tc.add_argument("--segment-m", type=_positive, default=1.0, help="segment length = cell edge L [m] (default 1)")
    tc.add_argument("--depth-m", type=_positive, default=None, help="lattice depth h [m] (default L, A1)")
    tc.add_argument("--current-a", type=_positive, default=10.0, help="maximum current I_max [A] (default 10)")
    tc.add_argument("--field-t", type=_positive, default=30e-6, help="reference field B_ref [T] (default 30e-6)")
    tc.add_argument("--pitch-cells", type=_count, default=2, help="coil column pitch p [cells] (default 2, A2)")
    tc.add_argument("--rows", type=_count, default=None, help="3/4 turns per column N_row (default d/L)")


def _add_modes_verb(sub: Any) -> None:
    md = _verb(
        sub,
        "modes",
        "the lowest modes of a structure: frequencies, rigid-body participation, in-plane/bending/twist "
        "shares (one JSON object on stdout)",
        _cmd_modes,
        {"source": "SOURCE", "count": "--count", "k": "--count", "plot": "--plot", "set": "--set"},
    )
    md.add_argument(
        "source",
        metavar="SOURCE",
        help="a structure file (.toml), a lattice config (.toml), a mesh (.msh) or a Nastran deck (.bdf/.dat/.nas)",
    )
    md.add_argument("--count", type=_count, default=20, metavar="K", help="modes to compute, lowest first (default 20)")
    md.add_argument("--plot", default=None, metavar="DIR", help="also draw the elastic mode shapes as PNGs in DIR")
    _set_option(md, "override a key of a config SOURCE, e.g. --set lattice.units=5 (refused for other sources)")


def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="magsail", description=DESCRIPTION, epilog=EXIT_CODES, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument(
        "--memory-limit",
        type=_memory,
        default=None,
        metavar="BYTES|auto",
        help=f"refuse inputs needing more memory than this (suffix K, M, G, T; default: ${MEMORY_ENV_VAR}, "
        "else the machine's available memory)",
    )
    p.add_argument(
        "--version",
        action=_VersionAction,
        help="print the versions of magsail_mj, MuJoCo, NumPy and Python and exit",
    )
    _verbose_option(p, default=0)
    sub = p.add_subparsers(dest="command", required=True, metavar="VERB", help="what to do (VERB --help for more)")
    _add_run_verbs(sub)
    _add_analytic_verbs(sub)
    _add_modes_verb(sub)
    return p


# --------------------------------------------------------------------------- main


_SIGNALLED: list[int] = []


@contextlib.contextmanager
def _sigterm_interrupts() -> Iterator[None]:
    """Within the block, SIGINT and SIGTERM raise KeyboardInterrupt, in the main thread only, and
    are remembered in ``_SIGNALLED``: an interrupt that Python swallows (raised inside a weakref
    callback or a ``__del__``) still ends the verb with exit 130."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def _raise(signum: int, frame: Any) -> None:
        _SIGNALLED.append(signum)
        # the record store's input/output futures that the interrupt abandons report their
        # errors (a file not yet written) when collected; the command's one line says it all
        logging.getLogger("asyncio").disabled = True
        raise KeyboardInterrupt(signal.Signals(signum).name)

    previous = {sig: signal.signal(sig, _raise) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


@contextlib.contextmanager
def _plain_warnings() -> Iterator[None]:
    """Within the block, a warning is logged as one line ``warning: <message>`` (no source line)."""

    def show(
        message: Warning | str,
        category: type[Warning],
        filename: str,
        lineno: int,
        file: Any = None,
        line: str | None = None,
    ) -> None:
        LOG.warning("%s", message)

    with warnings.catch_warnings():
        warnings.showwarning = show
        yield


def _error(message: str, code: int) -> int:
    """Log ``error: <message>`` and return the exit status ``code``."""
    LOG.error("%s", message)
    return code


def _named(message: str, options: Mapping[str, str]) -> str:
    """``message`` with its leading library argument name (``side_m: ...``) renamed to the option."""
    name = message.split(":", 1)[0]
    return f"{options[name]}{message[len(name) :]}" if name in options else message


def _user_paths(args: argparse.Namespace) -> list[Path]:
    names = ("config", "output", "out", "run_dir", "run_dirs", "compare", "sweep", "sweep_dir", "bundle")
    values = [getattr(args, n, None) for n in names]
    texts = [t for v in values for t in (v if isinstance(v, list) else [v])]
    return [Path(t).absolute() for t in texts if isinstance(t, str) and t.strip()]


def _is_user_path_error(err: OSError, args: argparse.Namespace) -> bool:
    """True when ``err`` is about a path the user gave (or one below or beside it) and says the path
    cannot be used as given (missing, not a folder, permission, read-only, ...)."""
    if err.errno not in _PATH_ERRNOS or not err.filename:
        return False
    try:
        failed = Path(os.fsdecode(err.filename)).absolute()
    except (TypeError, ValueError):
        return False
    for user in _user_paths(args):
        if failed == user or user in failed.parents or failed in user.parents or failed.parent == user.parent:
            return True
    return False


def _dispatch(args: argparse.Namespace) -> int:
    """Run the verb, mapping its exceptions to exit statuses (see :data:`EXIT_CODES`).

    The one place of the command that imports late: :mod:`magsail_mj.verbs.common` (the config
    schema, the memory limit, the exceptions of a refused input) here, the verb's own module when
    its :class:`_Handler` is called."""
    options = getattr(args, "options", {})
    common = importlib.import_module("magsail_mj.verbs.common")
    try:
        limit = args.memory_limit
        with common.memory_limit(None if limit is None else common.parse_memory_limit(limit, what="--memory-limit")):
            return args.fn(args)
    except common.REFUSED as err:
        return _error(_named(str(err), options), 2)
    except common.GLBackendError as err:
        return _error(f"the video could not be rendered: {err}", 1)
    except OSError as err:
        text = f"{err.filename!s}: {err.strerror}" if err.filename and err.strerror else str(err)
        if _is_user_path_error(err, args):
            return _error(text, 2)
        return _error(f"output failed: {type(err).__name__}: {text}", 1)
    except ValueError as err:
        return _error(_named(str(err), options), 2)


def main(argv: list[str] | None = None) -> int:
    """Run ``magsail`` with ``argv`` (default ``sys.argv[1:]``) and return the exit status."""
    try:
        with _logging_to_stderr(verbosity=0):
            return _main(argv)
    finally:
        forget_handled_interrupt()


def forget_handled_interrupt() -> None:
    """Let the exit status stand after an interrupt that was handled.

    CPython marks a ``KeyboardInterrupt`` that leaves code run from a string (``exec``/``eval`` of
    source text: the code behind dataclasses and named tuples, ``.pth`` lines) as unhandled, even
    when an outer ``except`` catches it, and a ``python -m`` process then ends by killing itself
    with SIGINT (status -2) instead of exiting 130. Running a string that completes clears the mark.
    """
    exec("pass")  # noqa: S102 - a constant string; its evaluation resets the interpreter's mark


def _main(argv: list[str] | None) -> int:
    """:func:`main` with the logging to stderr set up (WARNING until ``-v`` is parsed)."""
    try:
        args = _parser().parse_args(_report_argv(list(sys.argv[1:] if argv is None else argv)))
    except _UsageError as err:
        return _error(str(err), 2)
    except SystemExit as exit_:  # --help, --version
        return exit_.code if isinstance(exit_.code, int) else 0
    verbosity = getattr(args, "verbose", 0)
    LOG.setLevel(_LEVELS[min(verbosity, len(_LEVELS) - 1)])
    try:
        with _sigterm_interrupts(), _plain_warnings():
            code = _dispatch(args)
        if _SIGNALLED:
            raise KeyboardInterrupt
        return code
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except Exception as err:  # noqa: BLE001 - the last line of defence: no traceback unless asked
        if _SIGNALLED:  # an interrupt turned into another error (e.g. inside an extension's import)
            print("interrupted", file=sys.stderr)
            return 130
        if os.environ.get(DEBUG_ENV, "").strip() not in ("", "0") or verbosity >= 2:
            traceback.print_exc()
        return _error(f"internal error: {type(err).__name__}: {err}", 1)


if __name__ == "__main__":
    sys.exit(main())
