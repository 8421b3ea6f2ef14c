"""The hostile campaign of issue 30, kept in the default test run: a property-based fuzz of every
verb's options, and the issue's one-command reproducers that no other test runs through the CLI.

**Fuzz.** The verbs come from the parser itself (:func:`magsail_mj.cli._parser`, walked through
its sub-parsers), so a new verb or option is fuzzed without touching this file. For each leaf
command (``run``, ``report sweep``, ``scaling loops``, ...) and for each command that takes an
action (``report``, ``scaling``, ``torque``: the action left out, or ``report``'s short form),
hypothesis draws command lines that mix valid and hostile values: empty strings, huge, negative,
NaN and infinite numbers, 1e308, ``/``, ``/dev``, ``/dev/null``, ``/proc``, ``/dev/zero``, a file
where a folder is expected and a folder where a file is expected, unicode, options given twice,
``--opt=value`` and ``--opt value``, unknown options, a missing positional argument, ``--help``.
Every command line runs in-process through :func:`magsail_mj.cli.main` in a scratch folder
(``monkeypatch.chdir(tmp_path)``) and must:

* exit with one of the statuses of :data:`magsail_mj.cli.EXIT_CODES` (0, 1, 2, 3, 130);
* never print a traceback nor ``internal error``;
* refuse (exit 2) with exactly one line ``error: ...`` on stderr (indented detail lines below it,
  such as the config problems, and ``warning:`` lines aside);
* print strict JSON (finite numbers only) when it succeeds with a JSON object on stdout;
* write nothing outside ``tmp_path``: the listings of ``/``, the home folder, the pytest base
  folder, the repository root, its ``results``, ``runs`` and ``docs/reproduction`` folders and the
  folders of the configs the fuzz uses (the MJCF files committed beside them) do not change, and
  ``git status`` of those config folders is the same after the test as before.

Every run is tiny: the config's own overrides are followed by ``sim.duration_s`` = 3 time steps,
``sim.timestep_s`` = the config's, ``sim.record_every=1`` and ``lattice.units=3`` where the config
has a lattice (a later ``--set`` of a key wins), a ``--memory-limit`` of 1 GiB comes first, and
the options whose valid values set the work (``bench --repeat``, ``--duration-s``) draw small
valid values beside their hostile ones. The default run keeps a fixed, reproducible budget
(``derandomize=True``) and, to stay fast, skips the runs' figures (a proxy of the scenario whose
``plots`` returns nothing; the figures have their own tests), ``--video``, and the sweep inputs
that would start a Dask cluster (a fresh ``--out``, ``--overwrite``, a valid ``--set``): a sweep
there reuses the finished run of a prepared sweep folder. The campaign marked ``slow`` draws all of
these, with figures, on a larger budget (``MAGSAIL_CAMPAIGN_EXAMPLES`` command lines per command;
``CAMPAIGN_LOG=FILE`` appends each command line, its exit status and the start of its stderr to
``FILE`` as JSON lines, to review what a campaign tried).

**Reproducers.** Each bullet of the issue's "Found" list that is one command, and where its test
lives (those marked *here* are in this file; the others already run elsewhere and are not
repeated):

- ``run --out /``, ``--out /dev`` (exit 2, "system location"):
  test_cli_outputs.py::test_run_refuses_system_folders
- ``run --out RUN/timeseries.zarr`` (exit 2, "record store"):
  test_cli_outputs.py::test_run_refuses_a_folder_of_other_files_and_folders_inside_runs
- ``build CONFIG --set ...`` without ``-o`` (exit 2, "--output: required with --set"):
  test_cli_outputs.py::test_build_without_output_keeps_the_model_beside_the_config
- ``report SWEEP_DIR --figure KEY`` (the sweep report): test_cli_outputs.py::test_report_help_forms_are_accepted
- ``export --out RUN/manifest.json`` (exit 2, "--out", the file kept): the library in
  test_cli_outputs.py::test_export_refuses_the_run_folders_own_files; the CLI *here*
- a netCDF file under a ``.npz`` name (exit 2, "--out ... --format netcdf"): the library in
  test_cli_outputs.py::test_export_format_and_extension_must_agree; the CLI *here*
- ``sweep --walltime 25:99:00`` (exit 2, "--walltime"):
  test_cli_outputs.py::test_sweep_cli_refuses_walltime_before_loading
- ``sweep --cluster slurm|pbs`` without ``sbatch``/``qsub`` (exit 2 at once, "is not on PATH"): the
  library in test_cli_outputs.py::test_cluster_without_the_submit_command_fails_at_once; the CLI *here*
- ``run --stop-after-s 0.01`` (exit 2, "--stop-after-s"): test_stop_after.py::test_the_cli_exits_2_naming_the_option
- ``validate`` with ``coil.I_max_A=1e300`` agrees with ``run`` (refused, naming the key), and
  ``actuators.kappa_Am2_kg=1e300`` validates and runs:
  test_hostile_config.py::test_the_issue_reproducers_are_refused_by_validation
- ``magsail_mj.envs.list()``: test_cli_startup.py::test_subpackages_are_attributes_of_the_package
- ``Simulation.reset(seed=...)``: test_reset_seed.py::test_reset_seed_reseeds_the_noise
- ``env.step(np.full(3, 1e200))`` (bounded, no overflow, every task):
  test_envs_actions.py::test_any_finite_action_is_bounded_and_steps
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import tomllib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import magsail_mj.run as run_module
import magsail_mj.sweep as sweep_module
from magsail_mj import cli
from magsail_mj.cli import EXIT_CODES, main

REPO = Path(__file__).resolve().parents[1]
CONCEPTS = REPO / "magsail_mj" / "concepts"
LATTICE_CONFIG = CONCEPTS / "truss_magnetorquer/configs/dist_vs_central/case_a_central_bangbang.toml"
RIGID_CONFIG = CONCEPTS / "cnusail/configs/detumble_pre.toml"
CONFIGS = (LATTICE_CONFIG, RIGID_CONFIG)

DOCUMENTED_EXITS = frozenset(int(code) for code in re.findall(r"^  (\d+) +\S", EXIT_CODES, flags=re.M))
"""The exit statuses the CLI documents (0, 1, 2, 3, 130), read from its own table."""

_REAL_OUTPUTS = run_module._outputs
"""The runs' outputs with figures (the default tests replace them, the slow campaign restores them)."""

DEFAULT_EXAMPLES = 5
"""Command lines per command in the default run (the file stays well under 40 s on 2 loaded cores)."""
SLOW_EXAMPLES = int(os.environ.get("MAGSAIL_CAMPAIGN_EXAMPLES", "60"))
"""Command lines per command in the campaign marked slow (``$MAGSAIL_CAMPAIGN_EXAMPLES``, default 60)."""
MEMORY_LIMIT = "1G"
"""The ``--memory-limit`` in front of every fuzzed command line (a fuzzed one after the verb wins)."""


# --------------------------------------------------------------------------- the parser's commands


@dataclass(frozen=True)
class Command:
    """A command of the parser: its words (``("report", "sweep")``), its arguments, and, for a
    command that takes an action, the arguments of every action (its own ``actions`` then hold
    the union, drawn without the action word)."""

    words: tuple[str, ...]
    actions: tuple[argparse.Action, ...]
    takes_action: bool = False

    @property
    def id(self) -> str:
        """The test id: the words joined by a space, ``<action left out>`` for an action command."""
        return " ".join(self.words) + (" <action left out>" if self.takes_action else "")

    @property
    def positionals(self) -> tuple[argparse.Action, ...]:
        """The positional arguments, in order."""
        return tuple(a for a in self.actions if not a.option_strings)

    @property
    def optionals(self) -> tuple[argparse.Action, ...]:
        """The options (``--help`` aside: it is drawn on its own)."""
        return tuple(a for a in self.actions if a.option_strings and not isinstance(a, argparse._HelpAction))


def _subparsers(parser: argparse.ArgumentParser) -> argparse._SubParsersAction | None:
    return next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)


def commands(parser: argparse.ArgumentParser | None = None, words: tuple[str, ...] = ()) -> list[Command]:
    """Every leaf command of ``parser`` (default: the ``magsail`` parser) and every command that
    takes an action, found by walking its sub-parsers."""
    parser = parser or cli._parser()
    sub = _subparsers(parser)
    if sub is None:
        return [Command(words, tuple(parser._actions))]
    found: list[Command] = []
    for name, child in sub.choices.items():
        found += commands(child, (*words, name))
    if words:  # the action left out: the union of its actions' arguments, without the action word
        leaves = [c for c in found if c.words[: len(words)] == words and not c.takes_action]
        union: dict[str, argparse.Action] = {}
        for leaf in leaves:
            for action in leaf.actions:
                union.setdefault(action.dest + "|" + ",".join(action.option_strings), action)
        found.append(Command(words, tuple(union.values()), takes_action=True))
    return found


COMMANDS = commands()
TOP_LEVEL = cli._parser()


# --------------------------------------------------------------------------- the arena


@dataclass
class Arena:
    """What the fuzz draws from: the repository's configs, a finished tiny run and a finished
    sweep (copied into each test's ``tmp_path``), and hostile files and folders."""

    root: Path
    sweep_file: Path
    plain: Path
    binary: Path
    empty: Path
    folder: Path
    config_copy: Path
    set_keys: dict[Path, list[str]] = field(default_factory=dict)


def forced_overrides(config: Path) -> list[str]:
    """``--set`` arguments that keep a run of ``config`` tiny: 3 time steps of the config's own
    step, every step recorded, a 3-unit lattice where the config has one."""
    tree = tomllib.loads(config.read_text())
    step = tree["sim"]["timestep_s"]
    sets = [f"sim.duration_s={3 * step!r}", f"sim.timestep_s={step!r}", "sim.record_every=1"]
    if "lattice" in tree:
        sets.append("lattice.units=3")
    return [arg for s in sets for arg in ("--set", s)]


def tiny_sweep_text() -> str:
    """A sweep file of one tiny run of the lattice config (id ``a``)."""
    sets = forced_overrides(LATTICE_CONFIG)[1::2]
    return f'name = "tiny"\n[[run]]\nid = "a"\nconfig = {json.dumps(str(LATTICE_CONFIG))}\nset = {json.dumps(sets)}\n'


def _numeric_keys(tree: dict[str, Any], prefix: str = "") -> list[str]:
    keys = []
    for name, value in tree.items():
        if isinstance(value, dict):
            keys += _numeric_keys(value, f"{prefix}{name}.")
        elif isinstance(value, int | float) and not isinstance(value, bool):
            keys.append(prefix + name)
    return keys


@pytest.fixture(scope="module")
def no_plots() -> Iterator[None]:
    """Within the module's default tests, runs write no figures (the fuzz is about the options;
    figures cost seconds a run and have their own tests)."""
    real = run_module._outputs

    def outputs(scenario: Any, result: Any, run_dir: Path, *, plots: bool = True) -> Any:
        return real(scenario, result, run_dir, plots=False)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(run_module, "_outputs", outputs)
        yield


@pytest.fixture(scope="module")
def arena(tmp_path_factory: pytest.TempPathFactory, no_plots: None) -> Arena:
    """A tiny finished run, a sweep file of one tiny run and its finished sweep folder (its run
    made directly, so the sweep reuses it without starting Dask), hostile files and folders."""
    root = tmp_path_factory.mktemp("campaign")
    forced = forced_overrides(LATTICE_CONFIG)
    assert main(["run", str(LATTICE_CONFIG), "--out", str(root / "run"), "--no-progress", *forced]) == 0
    sweep_file = root / "sweep.toml"
    sweep_file.write_text(tiny_sweep_text())
    shutil.copytree(root / "run", root / "sweep" / "a")  # the same config and overrides as the sweep's run
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sweep_module, "_run_dask", _no_dask)
        assert main(["sweep", str(sweep_file), "--out", str(root / "sweep"), "--no-progress"]) == 0
    assert (root / "sweep" / "sweep_summary.json").is_file()
    plain = root / "plain.txt"
    plain.write_text("not a folder\n")
    binary = root / "binary.toml"
    binary.write_bytes(bytes(range(256)) * 4)
    empty = root / "empty.toml"
    empty.write_text("")
    folder = root / "folder"
    folder.mkdir()
    config_copy = root / "copy" / LATTICE_CONFIG.name
    config_copy.parent.mkdir()
    shutil.copy(LATTICE_CONFIG, config_copy)
    keys = {c: _numeric_keys(tomllib.loads(c.read_text())) for c in (*CONFIGS, config_copy)}
    return Arena(root, sweep_file, plain, binary, empty, folder, config_copy, keys)


def _no_dask(*args: Any, **kwargs: Any) -> Any:
    """In place of the sweep's Dask engine where a test must not start one: fail the test."""
    pytest.fail("this sweep would start a Dask cluster (the default fuzz keeps to reused runs)")


# --------------------------------------------------------------------------- strategies

_VALID_NUMBERS = st.sampled_from(["1", "2", "3", "0.5", "19", "75", "100"])
NUMBERS = st.one_of(
    _VALID_NUMBERS,
    _VALID_NUMBERS,
    _VALID_NUMBERS,
    st.sampled_from(["", " ", "0", "-0", "-1", "nan", "NaN", "inf", "-inf", "1e308", "-1e308", "1e-308", "1e400"]),
    st.sampled_from(["abc", "0x10", "1_000", "1e6", " 5", "²", "٣", "1,5", "99999999999999999999"]),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(min_value=-(10**12), max_value=10**12).map(str),
)
"""Numbers of the options typed as positive or non-negative numbers or counts."""

SMALL_WORK = st.one_of(
    st.sampled_from(["1", "2", "1e-5", "0.1", "0.3"]),
    st.sampled_from(["", "0", "-1", "nan", "inf", "1e308", "1e-308", "abc", "1e400", "-0"]),
)
"""Values of options whose valid values set the work (repeats, a simulated duration): small ones only."""
WORK_OPTIONS = ("--repeat", "--duration-s")

MEMORY = st.one_of(
    st.sampled_from(["1G", "512m", "1e9", "64M"]),
    st.sampled_from(["0", "-1", "", " ", "nan", "inf", "1e400", "lots", "2 GB GB", "1K", "-", "1G1"]),
)
"""Values of ``--memory-limit`` (never ``auto``: the cap stays)."""

TEXT = st.text(
    alphabet=st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), min_size=0, max_size=12
)
"""Any text an argv can hold (no NUL)."""

WORDS = st.sampled_from(
    ["", " ", "A", "B", "Cx", "Dy", "E", "slurm", "pbs", "npz", "netcdf", "nc", "t_end_s", "a", "zzz", "ü", "日本"]
)
"""Words that some text options accept and others refuse."""

HOSTILE_PATHS = [
    "",
    " ",
    "\t",
    "/",
    "/dev",
    "/dev/null",
    "/proc",
    "/proc/self",
    "/usr",
    "/tmp",
    "/nonexistent/never/made",
    "ünïcødé/日本",
    "x" * 300,
    "-",
    "~",
]
"""Paths that name the root, system folders, device files, nothing, or are not paths at all; a
write to any of them must be refused or fail (no new file appears in a system folder)."""
HOSTILE_INPUTS = [*HOSTILE_PATHS, "..", "/dev/zero", "/proc/self/status", "/etc/passwd"]
"""Paths to read from (``..`` and the pseudo files are no run, sweep nor config)."""


@dataclass
class Pools:
    """What each kind of argument draws from in one test (paths relative to its ``tmp_path``)."""

    arena: Arena
    tmp: Path
    slow: bool

    def files(self) -> list[str]:
        """Hostile files and folders of the arena (a file where a folder is expected and back)."""
        a = self.arena
        return [str(a.plain), str(a.binary), str(a.empty), str(a.folder), str(a.plain / "below" / "x"), "run/model.xml"]

    def config(self) -> st.SearchStrategy[str]:
        """Configs: the repository's, a copy, and hostile paths."""
        good = [str(c) for c in CONFIGS] + [str(self.arena.config_copy)]
        return st.one_of(st.sampled_from(good), st.sampled_from(good), st.sampled_from(HOSTILE_INPUTS + self.files()))

    def sweep_file(self) -> st.SearchStrategy[str]:
        """Sweep files: the tiny sweep, a config (not a sweep file), hostile paths."""
        good = [str(self.arena.sweep_file)]
        return st.one_of(
            st.sampled_from(good),
            st.sampled_from(good),
            st.sampled_from(HOSTILE_INPUTS + self.files() + [str(RIGID_CONFIG)]),
        )

    def folder_in(self, *, sweep: bool) -> st.SearchStrategy[str]:
        """Folders to read: the run and the sweep (copies in ``tmp_path``; the sweep first where a
        sweep folder is expected), hostile paths."""
        good = ["run", "sweep/a", str(self.tmp / "run"), "sweep"]
        if sweep:
            good = ["sweep", "runs/tiny", "run"]
        return st.one_of(st.sampled_from(good), st.sampled_from(good), st.sampled_from(HOSTILE_INPUTS + self.files()))

    def output(self, *, sweep: bool, help_text: str) -> st.SearchStrategy[str]:
        """Outputs (files or folders): fresh names in ``tmp_path`` (first the one of a file type
        the option's help names), the run's own files and store, the run and sweep folders,
        hostile paths; for a sweep in the default run, no fresh folder (it would start Dask)."""
        fresh = ["out", "o.xml", "v.mp4", "e.npz", "e.nc", "bundle", "new/sub/dir", "ü.mp4", "x.avi", "."]
        fresh.sort(key=lambda name: Path(name).suffix not in help_text or not Path(name).suffix)
        own = [
            "run",
            "run/timeseries.zarr",
            "run/timeseries.zarr/qpos",
            "run/manifest.json",
            "run/summary.json",
            "run/model.xml",
            "run/sub",
            "sweep",
            "sweep/a",
        ]
        hostile = HOSTILE_PATHS + self.files()
        if sweep and not self.slow:
            return st.one_of(st.just("sweep"), st.sampled_from(hostile + own[:-2]))
        return st.one_of(st.sampled_from(fresh), st.sampled_from(fresh), st.sampled_from(own), st.sampled_from(hostile))

    def settings_(self, config: str | None, *, sweep: bool) -> st.SearchStrategy[str]:
        """``--set KEY=VALUE``: keys of the config with hostile numbers, unknown keys, malformed
        overrides; for a sweep in the default run, only overrides the sweep refuses."""
        keys = self.arena.set_keys.get(Path(config), []) if config else []
        keys = keys or self.arena.set_keys[LATTICE_CONFIG]
        refused_values = st.sampled_from(["nan", "inf", "-inf", "1e400", "[nan]"])
        unknown = st.sampled_from(["nope", "", "sim", "sim.duration_s.x", "a..b", "ünï.cødé", "sim.nope"])
        malformed = st.sampled_from(["=", "=5", "noequals", "sim.duration_s", "sim.duration_s=", "==", " = "])
        if sweep and not self.slow:
            return st.one_of(
                st.tuples(st.sampled_from(keys), refused_values).map("=".join),
                st.tuples(unknown, NUMBERS).map("=".join),
                malformed,
            )
        return st.one_of(
            st.tuples(st.sampled_from(keys), NUMBERS).map("=".join),
            st.tuples(unknown, NUMBERS).map("=".join),
            malformed,
            TEXT,
        )


EXCLUDED_BY_DEFAULT = {"--video", "--overwrite"}
"""Options the default run leaves out of ``run`` and ``sweep``: a video costs seconds, an
overwritten sweep run starts Dask; the slow campaign draws them."""


def _values(action: argparse.Action, command: Command, pools: Pools, config: str | None) -> st.SearchStrategy[str]:
    """The strategy of one value of ``action`` (by its type, choices, destination)."""
    dest, opts = action.dest, action.option_strings
    sweep = command.words[:1] == ("sweep",)
    if dest == "memory_limit":
        return MEMORY
    if dest == "set":
        return pools.settings_(config, sweep=sweep)
    if action.type in (cli._count, cli._count_or_zero, cli._positive, cli._non_negative):
        if any(o in WORK_OPTIONS for o in opts) and not pools.slow:
            return SMALL_WORK
        return NUMBERS
    if action.choices is not None:
        return st.one_of(st.sampled_from(sorted(map(str, action.choices))), WORDS, TEXT)
    if dest == "config":
        return pools.config()
    if dest == "sweep":
        return pools.sweep_file()
    if dest in ("run_dir", "run_dirs", "compare", "sweep_dir"):
        return pools.folder_in(sweep=dest == "sweep_dir")
    if dest in ("out", "output", "bundle"):
        return pools.output(sweep=sweep, help_text=str(action.help))
    if dest == "scheduler":  # an address that answers nothing waits 15 s: only malformed ones
        return st.sampled_from(["", " ", "not an address", "tcp://", "ü"])
    if dest == "walltime":
        return st.sampled_from(["01:00:00", "25:99:00", "1h", "", "-1:00:00", "99999:00:00", "00:00:00"])
    return st.one_of(WORDS, TEXT, st.sampled_from(HOSTILE_INPUTS))


def _option_args(action: argparse.Action, values: list[str], draw: Callable[[Any], Any]) -> list[str]:
    """The words of one use of an option: ``--opt v...`` or ``--opt=v``."""
    name = draw(st.sampled_from(action.option_strings))
    if not values:
        return [name]
    if len(values) == 1 and name.startswith("--") and draw(st.booleans()):
        return [f"{name}={values[0]}"]
    return [name, *values]


def _arity(action: argparse.Action, draw: Callable[[Any], Any]) -> int:
    """How many values to draw for ``action``: its own arity mostly, sometimes one fewer or more."""
    nargs = action.nargs
    if nargs == 0 or isinstance(action, argparse._StoreTrueAction | argparse._CountAction):
        return 0
    if nargs in (None, "?"):
        base = 1
    elif nargs in ("+", "*"):
        base = draw(st.integers(1, 3))
    else:
        base = int(nargs)
    return max(0, base + draw(st.sampled_from([0, 0, 0, 0, 0, -1, 1])))


def rarely(draw: Callable[[Any], Any], one_in: int) -> bool:
    """True once in ``one_in`` draws; False is hypothesis's simplest choice, so the first and the
    shrunk examples are the common case."""
    return bool(draw(st.sampled_from([False] * (one_in - 1) + [True])))


UNKNOWN = st.sampled_from(["--bogus", "--out-of", "-Z", "--", "---", "-", "--set", "--=x", "-vvvvv", "--memory"])
"""Words no command knows (or a dangling option)."""


@st.composite
def command_lines(draw: Callable[[Any], Any], command: Command, pools: Pools) -> list[str]:
    """One command line for ``command``: a top-level prefix, the command's words, its positional
    arguments (sometimes one missing), options (some twice), unknown words, rarely ``--help``."""
    config = None
    positional: list[str] = []
    for action in command.positionals:
        n = _arity(action, draw)
        values = [draw(_values(action, command, pools, config)) for _ in range(n)]
        if action.dest == "config" and values:
            config = values[0]
        positional += values
    if positional and rarely(draw, 6):  # a missing positional argument
        del positional[draw(st.integers(0, len(positional) - 1))]
    excluded = set() if pools.slow else EXCLUDED_BY_DEFAULT
    optionals = [a for a in command.optionals if not excluded & set(a.option_strings)]
    if _submit_commands():  # --cluster would really submit batch jobs here
        optionals = [a for a in optionals if a.dest != "cluster"]
    chosen = draw(st.lists(st.sampled_from(optionals), max_size=4)) if optionals else []  # repeats allowed
    required = [a for a in optionals if a.required and not rarely(draw, 8)]  # rarely one left out
    chosen = draw(st.permutations(required + chosen)) if required else chosen
    options: list[str] = []
    for action in chosen:
        values = [draw(_values(action, command, pools, config)) for _ in range(_arity(action, draw))]
        options += _option_args(action, values, draw)
    words = positional + options
    if rarely(draw, 6):  # an unknown option somewhere
        words.insert(draw(st.integers(0, len(words))), draw(UNKNOWN))
    if rarely(draw, 30):
        words.insert(draw(st.integers(0, len(words))), "--help")
    prefix = ["--memory-limit", MEMORY_LIMIT]
    if rarely(draw, 5):
        prefix += draw(st.sampled_from([["-v"], ["-vv"], ["--memory-limit=-1"], ["--version"]]))
    tiny = forced_overrides(Path(config)) if config and Path(config) in pools.arena.set_keys else []
    if command.words[:1] in (("run",), ("bench",), ("build",), ("validate",)) and not tiny:
        tiny = forced_overrides(LATTICE_CONFIG)  # harmless on a hostile config path
    return [*prefix, *command.words, *words, *tiny]


def _submit_commands() -> bool:
    """True when this machine can submit batch jobs (then ``--cluster`` would really submit)."""
    return bool(shutil.which("sbatch") or shutil.which("qsub"))


# --------------------------------------------------------------------------- the invariants


def _refuse_non_finite(token: str) -> Any:
    raise AssertionError(f"non-finite number {token} in the JSON output")


def check_outcome(argv: list[str], rc: int, out: str, err: str) -> None:
    """The invariants every command line keeps (see the module docstring)."""
    assert rc in DOCUMENTED_EXITS, (argv, rc, err)
    assert "Traceback" not in err and "Traceback" not in out, (argv, err)
    assert "internal error" not in err, (argv, err)
    if rc == 2:
        lines = [line for line in err.split("\n") if line.strip()]  # not splitlines(): \x1e is no line end
        errors = [line for line in lines if line.startswith("error:")]
        assert len(errors) == 1, (argv, err)
        others = [line for line in lines if not line.startswith(("error:", "warning:", " ", "\t"))]
        assert not others, (argv, err)
    if rc == 0 and out.lstrip().startswith("{"):
        json.loads(out, parse_constant=_refuse_non_finite)


def _listing(folder: Path) -> dict[str, tuple[int, int]]:
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return {}
    found = {}
    for entry in entries:
        try:
            st_ = entry.stat(follow_symlinks=False)
        except OSError:
            continue
        found[entry.name] = (st_.st_size, st_.st_mtime_ns if entry.is_file(follow_symlinks=False) else 0)
    return found


def watched_folders(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """The folders whose listing no fuzzed command may change (see the module docstring)."""
    repo_dirs = [REPO, REPO / "results", REPO / "runs", REPO / "docs" / "reproduction"]
    return [Path("/"), Path.home(), tmp_path_factory.getbasetemp(), *repo_dirs, *{c.parent for c in CONFIGS}]


def snapshot(folders: list[Path]) -> dict[str, dict[str, tuple[int, int]]]:
    """The listing (name: size, mtime of files) of each folder."""
    return {str(f): _listing(f) for f in folders}


def changed(before: dict[str, dict[str, tuple[int, int]]], after: dict[str, dict[str, tuple[int, int]]]) -> list[str]:
    """The entries that appeared, vanished or changed between two snapshots."""
    out = []
    for folder, entries in before.items():
        now = after[folder]
        out += [f"{folder}/{n}" for n in sorted(set(entries) ^ set(now))]
        out += [f"{folder}/{n} (changed)" for n in sorted(set(entries) & set(now)) if entries[n] != now[n]]
    return out


GIT = shutil.which("git") or "git"
"""git, found before any test empties PATH."""


def _git_status() -> str:
    folders = sorted({str(c.parent.relative_to(REPO)) for c in CONFIGS})
    proc = subprocess.run(
        [GIT, "status", "--porcelain", "--untracked-files=all", "--", *folders],
        cwd=REPO,
        capture_output=True,
        text=True,
        check=False,
    )
    return proc.stdout if proc.returncode == 0 else f"git status failed: {proc.stderr}"


@pytest.fixture
def scratch(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, arena: Arena) -> Iterator[Path]:
    """``tmp_path`` as the working folder, holding copies of the run and the sweep; the config
    folders' ``git status`` is the same at the end as at the start."""
    shutil.copytree(arena.root / "run", tmp_path / "run")
    shutil.copytree(arena.root / "sweep", tmp_path / "sweep")
    shutil.copytree(arena.root / "sweep", tmp_path / "runs" / "tiny")  # the sweep's default --out
    (tmp_path / "bundle").mkdir()  # an empty results bundle
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv(cli.DEBUG_ENV, raising=False)
    monkeypatch.delenv(cli.MEMORY_ENV_VAR, raising=False)
    before = _git_status()
    yield tmp_path
    assert _git_status() == before, "a fuzzed command changed the committed files beside the configs"


def fuzz_one(capsys: pytest.CaptureFixture[str], argv: list[str], watched: list[Path]) -> tuple[int, str, str]:
    """Run ``argv`` in-process, check the invariants and that nothing outside ``tmp_path`` changed."""
    before = snapshot(watched)
    capsys.readouterr()
    rc = main(argv)
    out, err = capsys.readouterr()
    check_outcome(argv, rc, out, err)
    event(f"exit {rc}")
    if os.environ.get("CAMPAIGN_LOG"):
        with open(os.environ["CAMPAIGN_LOG"], "a") as log:
            log.write(json.dumps([rc, argv[2:], err[:200]]) + "\n")
    assert not changed(before, snapshot(watched)), (argv, changed(before, snapshot(watched)))
    return rc, out, err


FUZZ_HEALTH = [HealthCheck.function_scoped_fixture, HealthCheck.too_slow, HealthCheck.data_too_large]


def test_the_parser_walk_finds_every_verb() -> None:
    """The walk reaches every verb and report action the CLI documents (a new one joins by itself)."""
    ids = {c.id for c in COMMANDS}
    for words in (
        "build",
        "validate",
        "run",
        "bench",
        "render",
        "export",
        "sweep",
        "report collect",
        "report render",
        "report update",
        "report sweep",
        "scaling magnetorquer",
        "scaling loops",
        "torque coil",
        "report <action left out>",
    ):
        assert words in ids, sorted(ids)
    assert DOCUMENTED_EXITS == {0, 1, 2, 3, 130}


@pytest.mark.parametrize("command", COMMANDS, ids=[c.id for c in COMMANDS])
@settings(max_examples=DEFAULT_EXAMPLES, deadline=None, derandomize=True, suppress_health_check=FUZZ_HEALTH)
@given(data=st.data())
def test_fuzz_every_command(
    command: Command,
    data: st.DataObject,
    scratch: Path,
    arena: Arena,
    capsys: pytest.CaptureFixture[str],
    tmp_path_factory: pytest.TempPathFactory,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Hostile command lines of every command keep the invariants (default budget, no Dask)."""
    monkeypatch.setattr(sweep_module, "_run_dask", _no_dask)
    argv = data.draw(command_lines(command, Pools(arena, scratch, slow=False)), label="argv")
    fuzz_one(capsys, argv, watched_folders(tmp_path_factory))


@pytest.mark.slow
@pytest.mark.parametrize("command", COMMANDS, ids=[c.id for c in COMMANDS])
@settings(max_examples=SLOW_EXAMPLES, deadline=None, suppress_health_check=FUZZ_HEALTH)
@given(data=st.data())
def test_fuzz_every_command_long_campaign(
    command: Command,
    data: st.DataObject,
    scratch: Path,
    arena: Arena,
    capsys: pytest.CaptureFixture[str],
    tmp_path_factory: pytest.TempPathFactory,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The long campaign: a larger random budget, figures, videos, overwritten and fresh sweeps."""
    monkeypatch.setattr(run_module, "_outputs", _REAL_OUTPUTS)
    argv = data.draw(command_lines(command, Pools(arena, scratch, slow=True)), label="argv")
    fuzz_one(capsys, argv, watched_folders(tmp_path_factory))


# --------------------------------------------------------------------------- the reproducers


def _call(capsys: pytest.CaptureFixture[str], argv: list[str]) -> tuple[int, str, str]:
    capsys.readouterr()
    rc = main(argv)
    out, err = capsys.readouterr()
    check_outcome(argv, rc, out, err)
    return rc, out, err


@pytest.mark.parametrize(
    "name, extra, phrase",
    [
        ("manifest.json", [], "--out"),
        ("summary.json", [], "--out"),
        ("model.xml", [], "--out"),
        ("timeseries.zarr/x.npz", [], "--out"),
        ("../e.npz", ["--format", "netcdf"], "--format netcdf"),
        ("../e.nc", ["--format", "npz"], "--format npz"),
    ],
)
def test_export_reproducers_through_the_cli(
    scratch: Path, capsys: pytest.CaptureFixture[str], name: str, extra: list[str], phrase: str
) -> None:
    """``export --out`` onto the run's own files, and a netCDF file under a ``.npz`` name (or the
    reverse): exit 2, one line naming ``--out`` (and the format), the run folder unchanged."""
    run = scratch / "run"
    before = {p: p.read_bytes() for p in run.rglob("*") if p.is_file()}
    rc, out, err = _call(capsys, ["export", str(run), "--out", str(run / name), *extra])
    assert rc == 2 and err.startswith("error: --out") and phrase in err and out == "", err
    assert {p: p.read_bytes() for p in run.rglob("*") if p.is_file()} == before
    assert not (scratch / "e.npz").exists() and not (scratch / "e.nc").exists()


@pytest.mark.parametrize("kind, command", [("slurm", "sbatch"), ("pbs", "qsub")])
def test_cluster_without_submit_command_through_the_cli(
    scratch: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, kind: str, command: str
) -> None:
    """``sweep ... --cluster slurm|pbs`` on a machine without ``sbatch``/``qsub``: exit 2 at once,
    one line naming the option and the missing command, no Dask started."""
    pytest.importorskip("dask_jobqueue")
    empty = scratch / "empty_path"
    empty.mkdir()
    monkeypatch.setenv("PATH", str(empty))
    monkeypatch.setattr(sweep_module, "_run_dask", _no_dask)
    sweep_file = scratch / "sweep.toml"
    sweep_file.write_text(tiny_sweep_text())
    rc, out, err = _call(capsys, ["sweep", str(sweep_file), "--out", str(scratch / "fresh"), "--cluster", kind])
    assert rc == 2 and err.startswith(f"error: --cluster {kind}") and f"'{command}' is not on PATH" in err, err
    assert out == ""


# --------------------------------------------------------------------------- what the campaign found


@pytest.mark.parametrize(
    "argv, phrase",
    [
        # build -o into a folder where no file can be made named the temporary file beside the
        # output ('/proc/.x.xml.v32_t7zs.xml: No such file or directory')
        (["build", str(LATTICE_CONFIG), "-o", "/proc/x.xml", *forced_overrides(LATTICE_CONFIG)], "/proc/x.xml:"),
        # render -o there rendered into ffmpeg's failure: 'internal error: RuntimeError: Error
        # writing /proc/.x.4d80eb20.tmp.mp4' (exit 1; access() says yes to root everywhere)
        (["render", "run", "-o", "/proc/x.mp4"], "--output: folder '/proc' is not writable"),
        # a run folder named past the file-name limit was an output failure (exit 1), not an input
        (["report", "x" * 300, "sweep", "runs/tiny"], "File name too long"),
    ],
    ids=["build-o-proc", "render-o-proc", "report-long-name"],
)
def test_campaign_findings(scratch: Path, capsys: pytest.CaptureFixture[str], argv: list[str], phrase: str) -> None:
    """Command lines the campaign found ending in an internal error, exit 1 or a temporary file's
    name: each is refused with exit 2 and one line naming what the user gave."""
    rc, out, err = _call(capsys, argv)
    assert rc == 2 and phrase in err and ".tmp" not in err and out == "", err
