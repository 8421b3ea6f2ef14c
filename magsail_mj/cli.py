"""``magsail`` command line: build | validate | run | bench | render | export | sweep | report | scaling | torque.

``report`` has the actions collect | render | update (reproduction reports) and sweep (a sweep report).

Every verb checks its inputs where it uses them (paths, numbers, the memory the input needs) and
reports a problem as one line ``error: <what>`` on stderr, never a traceback; the exit status
follows :data:`EXIT_CODES`. ``MAGSAIL_DEBUG=1`` adds the traceback of an unexpected error.

Messages go through :mod:`logging` (logger ``magsail_mj`` and its children) to stderr: warnings
and errors by default, ``-v`` adds progress messages (INFO), ``-vv`` debugging detail (DEBUG).
Results (JSON, paths) go to stdout. ``python -m magsail_mj`` is the same command.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import json
import logging
import math
import os
import signal
import sys
import threading
import traceback
import warnings
from collections.abc import Callable, Iterator, Mapping
from importlib import metadata
from pathlib import Path
from typing import Any, NoReturn

from magsail_mj.analysis.coil_torque import coil_torque_report
from magsail_mj.analysis.loop_scaling import loop_sizing, scaling_table
from magsail_mj.analysis.scaling import scaling_report
from magsail_mj.bench import BenchRunError, bench
from magsail_mj.config import ConfigError, load_config
from magsail_mj.export import add_arguments as add_export_arguments
from magsail_mj.export import main as export_main
from magsail_mj.io import RunDirError, atomic_path, to_jsonable
from magsail_mj.render import render_run
from magsail_mj.render.backend import GLBackendError
from magsail_mj.report.commands import (
    add_collect_arguments,
    add_render_arguments,
    collect_main,
    render_main,
    update_main,
)
from magsail_mj.resources import (
    ENV_VAR,
    MemoryLimitError,
    check_memory,
    estimate_model_bytes,
    estimate_run_bytes,
    memory_limit,
    parse_memory_limit,
    render_bytes,
)
from magsail_mj.run import run_scenario
from magsail_mj.scenario import build_scenario
from magsail_mj.sweep import load_sweep, make_cluster, run_sweep, sweep_exit_code
from magsail_mj.sweep.report import add_arguments as add_report_arguments
from magsail_mj.sweep.report import main as report_main
from magsail_mj.sweep.report import ReportError, write_report

__all__ = ["EXIT_CODES", "CliInputError", "forget_handled_interrupt", "main"]

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
_SMALL_REPORT_BYTES = 1 << 20  # analytic reports of fixed size (loop sizing, the A–D × N scaling table)
_SCALING_ENTRY_BYTES = 200  # one entry of the λ_f(d, κ) table, see _cmd_scaling_magnetorquer


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


def _memory(text: str) -> int | None:
    try:
        return parse_memory_limit(text, what="--memory-limit")
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err).split(": ", 1)[-1]) from None


# --------------------------------------------------------------------------- path checks


def _non_empty(path: str | None, option: str) -> Path:
    if path is None or not str(path).strip():
        raise CliInputError(f"{option}: must be a path, got an empty string {path!r}")
    if "\x00" in str(path):
        raise CliInputError(f"{option}: must not contain a NUL character, got {path!r}")
    return Path(path)


def _input_file(path: str, option: str) -> Path:
    """An existing, readable regular file."""
    p = _non_empty(path, option)
    if not p.exists():
        raise CliInputError(f"{option}: no such file {str(p)!r}")
    if not p.is_file():
        raise CliInputError(f"{option}: {str(p)!r} is not a regular file")
    if not os.access(p, os.R_OK):
        raise CliInputError(f"{option}: {str(p)!r} is not readable (permission denied)")
    return p


def _writable_parent(p: Path, option: str) -> None:
    """The nearest existing ancestor of ``p`` is a writable folder (so ``p`` can be created)."""
    for parent in p.absolute().parents:
        if not parent.exists():
            continue
        if not parent.is_dir():
            raise CliInputError(f"{option}: {str(parent)!r} is a file, so {str(p)!r} cannot be created below it")
        if not os.access(parent, os.W_OK | os.X_OK):
            raise CliInputError(f"{option}: folder {str(parent)!r} is not writable (permission denied)")
        return


def _output_dir(path: str | None, option: str) -> Path:
    """A folder that exists and is writable, or can be created."""
    p = _non_empty(path, option)
    if p.exists():
        if not p.is_dir():
            raise CliInputError(f"{option}: {str(p)!r} exists and is not a folder")
        if not os.access(p, os.W_OK | os.X_OK):
            raise CliInputError(f"{option}: folder {str(p)!r} is not writable (permission denied)")
        return p
    _writable_parent(p, option)
    return p


def _output_file(path: str | None, option: str) -> Path:
    """A file path that is not a folder, below a writable (or creatable) folder."""
    p = _non_empty(path, option)
    if p.is_dir():
        raise CliInputError(f"{option}: {str(p)!r} is a folder; give a file path")
    _writable_parent(p, option)  # the file is replaced by a rename in its folder
    return p


def _load(args: argparse.Namespace) -> Any:
    """The validated config of ``args.config`` with ``--set`` overrides (ConfigError or CliInputError)."""
    path = _input_file(args.config, "config")
    try:
        return load_config(path, args.set)
    except UnicodeDecodeError:
        raise CliInputError(f"config: {str(path)!r} is not a UTF-8 text (TOML) file") from None


# --------------------------------------------------------------------------- verbs


def _print_json(obj: Any, *, what: str, indent: int | None = None) -> None:
    """Print ``obj`` as JSON; a non-finite number in it is an error naming ``what``."""
    bad = _non_finite(obj)
    if bad is not None:
        raise CliInputError(
            f"{what}: the result {bad[0]} is not finite ({bad[1]!r}); the inputs are outside "
            "the range where it can be computed"
        )
    print(json.dumps(to_jsonable(obj), indent=indent, allow_nan=False))


def _non_finite(obj: Any, key: str = "") -> tuple[str, float] | None:
    """``(key path, value)`` of the first non-finite float in a JSON-like tree, else None."""
    if isinstance(obj, Mapping):
        for k, v in obj.items():
            found = _non_finite(v, f"{key}.{k}" if key else str(k))
            if found:
                return found
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            found = _non_finite(v, f"{key}[{i}]")
            if found:
                return found
    elif isinstance(obj, float) and not math.isfinite(obj):
        return key, obj
    elif hasattr(obj, "dtype") and hasattr(obj, "tolist"):
        return _non_finite(obj.tolist(), key)
    return None


def _cmd_build(args: argparse.Namespace) -> int:
    out = _output_file(args.output, "--output") if args.output is not None else None
    cfg = _load(args)
    out = out or Path(args.config).with_suffix(".xml")
    check_memory(estimate_model_bytes(cfg), what=f"build {args.config}")
    scenario = build_scenario(cfg)
    with atomic_path(out) as tmp:
        tmp.write_text(scenario.spec.to_xml())
    size = scenario.manifest_extra().get("model_size", {})
    _print_json({"mjcf": str(out), **size}, what="build")
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    cfg = _load(args)
    estimate = check_memory(estimate_run_bytes(cfg), what=f"validate {args.config}: a run")
    _print_json(
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


def _video_bytes(cfg: Any) -> float:
    """Memory of rendering the run's video (the render table's frame count, 960 × 540 px)."""
    r = getattr(cfg, "render", None)
    frames = int(getattr(r, "max_frames", 600) or 600)
    return render_bytes(frames=frames, width=960, height=540, model_bytes=estimate_model_bytes(cfg))


_RUN_EXIT = {"diverged": 3, "failed": 1, "interrupted": 130}


def _cmd_run(args: argparse.Namespace) -> int:
    out = _output_dir(args.out, "--out")
    if args.resume and not out.is_dir():
        raise CliInputError(f"--resume: there is no run folder {str(out)!r} to resume")
    cfg = _load(args)
    estimate = estimate_run_bytes(cfg) + (_video_bytes(cfg) if args.video else 0.0)
    check_memory(estimate, what=f"run {args.config}{' with --video' if args.video else ''}")
    if args.stop_after_s is not None and args.stop_after_s >= cfg.sim.duration_s:
        raise CliInputError(
            f"--stop-after-s: must be below sim.duration_s = {cfg.sim.duration_s:g}, got {args.stop_after_s:g}"
        )
    outcome = run_scenario(
        cfg,
        out,
        video=args.video,
        resume=args.resume,
        overwrite=args.overwrite,
        progress=False if args.no_progress else None,
        stop_after_s=args.stop_after_s,
    )
    print(json.dumps(to_jsonable(dict(outcome)), indent=2))
    LOG.info("run folder: %s", outcome.run_dir)
    if args.video and (outcome.run_dir / "video.mp4").is_file():
        LOG.info("video: %s", outcome.run_dir / "video.mp4")
    status = getattr(outcome, "status", "completed")
    code = _RUN_EXIT.get(status, 0)
    if code:
        LOG.error("run %s: %s", status, outcome.get("status_message", ""))
    return code


def _cmd_bench(args: argparse.Namespace) -> int:
    """``magsail bench``: :func:`magsail_mj.bench.bench`, one JSON object on stdout; a pass that
    diverged exits 3, one that failed otherwise 1."""
    if args.duration_s is not None:
        args.set = [*args.set, f"sim.duration_s={args.duration_s!r}"]
    cfg = _load(args)
    check_memory(estimate_run_bytes(cfg), what=f"bench {args.config}: a run")
    try:
        result = bench(cfg, repeat=args.repeat)
    except BenchRunError as err:
        return _error(str(err), 3 if err.status == "diverged" else 1)
    _print_json({"config": args.config, **result}, what="bench")
    return 0


def _cmd_render(args: argparse.Namespace) -> int:
    out = render_run(
        _non_empty(args.run_dir, "RUN_DIR"),
        _non_empty(args.output, "--output"),
        compare=_non_empty(args.compare, "--compare") if args.compare is not None else None,
        labels=args.labels,
    )
    print(str(out))
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    """``magsail export``: :func:`magsail_mj.export.main`."""
    return export_main(args)


def _cmd_report(args: argparse.Namespace) -> int:
    """``magsail report sweep``: :func:`magsail_mj.sweep.report.main`."""
    return report_main(args)


def _cmd_report_collect(args: argparse.Namespace) -> int:
    """``magsail report collect``: :func:`magsail_mj.report.commands.collect_main`."""
    return collect_main(args)


def _cmd_report_render(args: argparse.Namespace) -> int:
    """``magsail report render``: :func:`magsail_mj.report.commands.render_main`."""
    return render_main(args)


def _cmd_report_update(args: argparse.Namespace) -> int:
    """``magsail report update``: :func:`magsail_mj.report.commands.update_main`."""
    return update_main(args)


def _sweep_engine(args: argparse.Namespace) -> Any:
    """The Dask cluster of ``--cluster`` (jobs not yet submitted), else None; CliInputError for
    options that do not fit together."""
    queue_opts = {
        "--jobs": args.jobs,
        "--cores-per-job": args.cores_per_job,
        "--memory-per-job": args.memory_per_job,
        "--walltime": args.walltime,
        "--queue": args.queue,
        "--account": args.account,
    }
    given = [opt for opt, value in queue_opts.items() if value is not None]
    if args.scheduler is not None and args.cluster is not None:
        raise CliInputError(f"--scheduler {args.scheduler!r} and --cluster {args.cluster!r}: choose one")
    if args.cluster is None:
        if given:
            raise CliInputError(f"{given[0]}: only with --cluster slurm|pbs")
        return None
    if args.workers != 1:
        raise CliInputError(f"--workers {args.workers}: not with --cluster (use --jobs and --cores-per-job)")
    return make_cluster(
        args.cluster,
        cores_per_job=args.cores_per_job or 1,
        memory_per_job=args.memory_per_job or "4GB",
        walltime=args.walltime or "01:00:00",
        queue=args.queue,
        account=args.account,
    )


def _cmd_sweep(args: argparse.Namespace) -> int:
    path = _input_file(args.sweep, "SWEEP")
    out = _output_dir(args.out, "--out") if args.out is not None else None
    if args.scheduler is not None and not args.scheduler.strip():
        raise CliInputError(
            f"--scheduler: must be a scheduler address such as tcp://127.0.0.1:8786, got {args.scheduler!r}"
        )
    try:
        sweep = load_sweep(path, extra_overrides=tuple(args.set), only=args.only)
    except UnicodeDecodeError:
        raise CliInputError(f"SWEEP: {str(path)!r} is not a UTF-8 text (TOML) file") from None
    out = out or _output_dir(str(Path("runs") / sweep.name), "--out")
    cluster = _sweep_engine(args)
    if args.scheduler is None and cluster is None:  # runs on this machine: they must fit its memory
        biggest = 0.0
        for run in sweep.selected:
            biggest = max(biggest, estimate_run_bytes(load_config(run.config, list(run.overrides))))
        workers = min(args.workers, max(1, len(sweep.selected)))
        check_memory(workers * biggest, what=f"sweep {args.sweep} ({workers} worker(s), largest run)")
    try:
        if cluster is not None:
            cluster.adapt(minimum_jobs=args.jobs or 1, maximum_jobs=args.jobs or 1)  # jobs that end are replaced
        records = run_sweep(
            sweep,
            out,
            workers=args.workers,
            video=args.video,
            overwrite=args.overwrite,
            scheduler=args.scheduler,
            cluster=cluster,
            retries=args.retries,
            log=LOG.info,
            progress=False if args.no_progress else None,
        )
    finally:
        if cluster is not None:
            cluster.close()
    result: dict[str, Any] = {"sweep": sweep.name, "out": str(out), "status": {r["id"]: r["status"] for r in records}}
    code = sweep_exit_code(records)
    if args.report:
        try:
            result["report"] = [str(p) for p in write_report(out)]
        except ReportError as err:  # e.g. no run finished with a figure to report: the runs stay as they are
            LOG.error("report: %s", err)
            result["report_error"] = str(err)
            code = code or 1
    print(json.dumps(result, indent=2))
    return code


def _cmd_scaling_magnetorquer(args: argparse.Namespace) -> int:
    # the report is a len(side) × len(kappa) table of λ_f, built as floats, Python objects and JSON
    # text: 172–178 bytes per entry measured (max RSS over the base process, 1e6 and 9e6 entries)
    check_memory(
        _SCALING_ENTRY_BYTES * len(args.side_m) * len(args.kappa) + _SMALL_REPORT_BYTES,
        what=f"scaling magnetorquer ({len(args.side_m)} × {len(args.kappa)} table)",
    )
    side = args.side_m[0] if len(args.side_m) == 1 else args.side_m
    kappa = args.kappa[0] if len(args.kappa) == 1 else args.kappa
    report = scaling_report(
        side, kappa, altitude_km=args.altitude_km, total_kg=args.total_kg, rod_mass_kg=args.rod_mass_kg
    )
    _print_json(report, what="--side-m, --kappa, --altitude-km, --total-kg, --rod-mass-kg")
    return 0


def _cmd_scaling_loops(args: argparse.Namespace) -> int:
    check_memory(_SMALL_REPORT_BYTES, what="scaling loops")
    if args.table:
        report = scaling_table(side_m=args.side_m, areal_density_kg_m2=args.areal_density, kappa=args.kappa)
    elif args.geometry is None:
        raise CliInputError("--geometry: required unless --table is given (one of A, B, C, D)")
    else:
        report = loop_sizing(
            args.geometry,
            units=args.units,
            side_m=args.side_m,
            areal_density_kg_m2=args.areal_density,
            kappa=args.kappa,
        )
    _print_json(report, what="--geometry, --units, --side-m, --areal-density, --kappa")
    return 0


def _cmd_torque_coil(args: argparse.Namespace) -> int:
    report = coil_torque_report(
        side_m=args.side_m,
        segment_m=args.segment_m,
        depth_m=args.depth_m,
        current_A=args.current_a,
        field_T=args.field_t,
        pitch_cells=args.pitch_cells,
        rows=args.rows,
    )
    _print_json(report, what="--side-m, --segment-m, --depth-m, --current-a, --field-t, --pitch-cells, --rows")
    return 0


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
        help=f"refuse inputs needing more memory (default: ${ENV_VAR}, else the available memory)",
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


def _add_run_verbs(sub: Any) -> None:
    b = _verb(sub, "build", "write the MJCF of a config and print the model size", _cmd_build)
    b.add_argument("config", help=_CONFIG_HELP)
    b.add_argument("-o", "--output", help="MJCF path (default: next to the config, same stem)")
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
        {"duration_s": "--duration-s", "repeat": "--repeat"},
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
        {"workers": "--workers", "only": "--only", "retries": "--retries", "scheduler": "--scheduler"},
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
  magsail report SWEEP_DIR [--figure KEY]     the same as sweep (one folder, not a run folder, no --bundle/--out)"""


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
        "--out", default="docs/reproduction", metavar="DIR", help="folder of the MyST pages (default docs/reproduction)"
    )
    sw = _verb(
        actions,
        "sweep",
        "summarise a finished sweep folder: tables and figures of its runs' summaries",
        _cmd_report,
        {"sweep_dir": "SWEEP_DIR", "figures": "--figure"},
    )
    add_report_arguments(sw)


def _report_argv(argv: list[str]) -> list[str]:
    """``magsail report X...`` without an action becomes ``report sweep X`` when X is one folder
    that is not a run folder (no manifest.json) and neither --bundle nor --out is given, else
    ``report update X...``."""
    i = 0
    while i < len(argv) and argv[i].startswith("-"):
        i += 2 if argv[i] == "--memory-limit" else 1
    if i >= len(argv) - 1 or argv[i] != "report" or argv[i + 1] in _REPORT_ACTIONS or argv[i + 1].startswith("-"):
        return argv
    rest = argv[i + 1 :]
    positional = [a for a in rest if not a.startswith("-")]
    reproduction = any(a.split("=", 1)[0] in ("--bundle", "--out") for a in rest)
    sweep = len(positional) == 1 and not reproduction and not (Path(positional[0]) / "manifest.json").is_file()
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


def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="magsail", description=DESCRIPTION, epilog=EXIT_CODES, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument(
        "--memory-limit",
        type=_memory,
        default=None,
        metavar="BYTES|auto",
        help=f"refuse inputs needing more memory than this (suffix K, M, G, T; default: ${ENV_VAR}, "
        "else the machine's available memory)",
    )
    p.add_argument(
        "--version",
        action="version",
        version=version_text(),
        help="print the versions of magsail_mj, MuJoCo, NumPy and Python and exit",
    )
    _verbose_option(p, default=0)
    sub = p.add_subparsers(dest="command", required=True, metavar="VERB", help="what to do (VERB --help for more)")
    _add_run_verbs(sub)
    _add_analytic_verbs(sub)
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
    names = ("config", "output", "out", "run_dir", "compare", "sweep", "sweep_dir")
    return [Path(v).absolute() for n in names if isinstance(v := getattr(args, n, None), str) and v.strip()]


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
    """Run the verb, mapping its exceptions to exit statuses (see :data:`EXIT_CODES`)."""
    options = getattr(args, "options", {})
    try:
        return args.fn(args)
    except (ConfigError, RunDirError, MemoryLimitError, CliInputError) as err:
        return _error(_named(str(err), options), 2)
    except GLBackendError as err:
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
        with memory_limit(args.memory_limit), _sigterm_interrupts(), _plain_warnings():
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
