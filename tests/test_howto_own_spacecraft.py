"""The how-to ``docs/howto-own-spacecraft.md``, run as written, in a fresh folder.

The page is read in order:

* a MyST ``{code-block}`` with a ``:caption:`` is a file: its text is written under the caption's
  name;
* a ```` ```console ```` block is a shell session: each ``$ command`` line runs, and the lines
  below it, up to the next ``$`` line, are what it prints (its standard output, or its standard
  error when it fails).

Commands: ``magsail ARGS`` runs :func:`magsail_mj.cli.main` in this process (what the ``magsail``
console script calls, without a new interpreter's start-up for each command); ``python SCRIPT
ARGS`` runs the script in this process; these two may be joined by ``|`` and end in ``> FILE``;
``echo $?`` prints the previous command's exit status; any other line runs in ``bash``. Every
command must exit 0 unless an ``echo $?`` after it quotes another status.

Quoted output matches when, line by line, its text equals the output's with runs of blanks taken
as one, ``…`` on a line of its own stands for any number of lines and ``…`` within a line for any
text; whole numbers (no point, no exponent) must be equal, other numbers within 1 % or one unit of
their last written digit, whichever is larger (the page may round what a command prints).

Besides the quoted output the test checks what the page states: the misspelt node is the only
problem reported, naming the element, the key and the value, and the refused run writes nothing;
every ``magsail modes`` lists its frequencies in ascending order, its zero modes first; the
detumble and mast runs end with status ``completed`` (the too-long time step is refused and
writes nothing), the detumble run folder holds the video and the plots, and
``magsail_mj.load`` and ``magsail_mj.envs.load``, which the page names, take the page's config.

Run time: the page's runs are short (30 s of simulated time for the spacecraft, 10 s for the
mast): about 30 s of CPU time in all, most of it the runs'
steps, plots and video.
"""

from __future__ import annotations

import contextlib
import io
import json
import re
import runpy
import shlex
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import magsail_mj
from magsail_mj import envs
from magsail_mj.cli import main as magsail

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "howto-own-spacecraft.md"
ELLIPSIS = "…"
REL_TOL = 1e-2
_FENCE = re.compile(r"^(`{3,})\s*(\S*)\s*(.*)$")
_OPTION = re.compile(r"^:(\w[\w-]*):\s*(.*)$")
_NUMBER = r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?"


@dataclass
class Command:
    """One ``$`` line of a console block and the output quoted below it."""

    line: str
    expected: list[str] = field(default_factory=list)


@dataclass
class File:
    """A code block with a ``:caption:`` naming a file."""

    name: str
    text: str


def page_steps(text: str) -> list[File | Command]:
    """The files and commands of the page, in order."""
    steps: list[File | Command] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        m = _FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        fence, info, argument = m.groups()
        end = next((k for k in range(i + 1, len(lines)) if lines[k].strip() == fence), None)
        assert end is not None, f"{PAGE.name}:{i + 1}: a code block that is not closed"
        body = lines[i + 1 : end]
        if info == "{code-block}":
            options = {}
            while body and _OPTION.match(body[0]):
                key, value = _OPTION.match(body.pop(0)).groups()
                options[key] = value.strip()
            if "caption" in options:
                while body and not body[0].strip():
                    body.pop(0)
                steps.append(File(options["caption"], "\n".join(body) + "\n"))
        elif info == "console":
            for row in body:
                if row.startswith("$ "):
                    steps.append(Command(row[2:].strip()))
                else:
                    assert steps and isinstance(steps[-1], Command), f"output before any command: {row!r}"
                    steps[-1].expected.append(row)
        i = end + 1
    return steps


# ----------------------------------------------------------------------------- output matching


def _pattern(expected: str) -> tuple[re.Pattern[str], list[str]]:
    """A regular expression of one quoted line (blanks collapsed, numbers captured, ``…`` any
    text) and the numbers it quotes."""
    parts, numbers = [], []
    for k, chunk in enumerate(" ".join(expected.split()).split(ELLIPSIS)):
        if k:
            parts.append(".*?")
        pos = 0
        for m in re.finditer(_NUMBER, chunk):
            parts += [re.escape(chunk[pos : m.start()]), f"({_NUMBER})"]
            numbers.append(m.group())
            pos = m.end()
        parts.append(re.escape(chunk[pos:]))
    return re.compile("".join(parts)), numbers


def _close(actual: str, quoted: str) -> bool:
    """Whole numbers equal; others within :data:`REL_TOL` or one unit of the last quoted digit."""
    if re.fullmatch(r"[-+]?\d+", quoted):
        return re.fullmatch(r"[-+]?\d+", actual) is not None and int(actual) == int(quoted)
    mantissa, _, exponent = quoted.lower().partition("e")
    decimals = len(mantissa.partition(".")[2])
    unit = 10.0 ** (int(exponent or 0) - decimals)
    return abs(float(actual) - float(quoted)) <= max(REL_TOL * abs(float(quoted)), unit) * (1 + 1e-9)


def line_matches(actual: str, expected: str) -> bool:
    """Whether one output line matches one quoted line."""
    pattern, numbers = _pattern(expected)
    m = pattern.fullmatch(" ".join(actual.split()))
    return m is not None and all(_close(a, q) for a, q in zip(m.groups(), numbers))


def output_matches(actual: list[str], expected: list[str]) -> bool:
    """Whether the output lines match the quoted ones (``…`` lines stand for any lines)."""
    if not expected:
        return not actual
    if expected[0].strip() == ELLIPSIS:
        return any(output_matches(actual[k:], expected[1:]) for k in range(len(actual) + 1))
    return bool(actual) and line_matches(actual[0], expected[0]) and output_matches(actual[1:], expected[1:])


def test_matching_rules():
    assert line_matches("  7    0.6721      1.00", "7 0.6721 1.00")
    assert line_matches('"omega": 0.011258519974797918,', '"omega": 0.01126,')
    assert not line_matches('"omega": 0.0115,', '"omega": 0.01126,')  # 2 % off
    assert line_matches("f = 0.0181 s", "f = 0.018 s") and not line_matches("f = 0.020 s", "f = 0.018 s")
    assert not line_matches("node 81 does not exist", "node 80 does not exist")  # whole numbers: equal
    assert line_matches(
        "structure.file: /tmp/x/sat_typo.toml: members[3]", "structure.file: …/sat_typo.toml: members[3]"
    )
    assert output_matches(["{", "a", "b", "}"], ["{", ELLIPSIS, "}"])
    assert not output_matches(["{", "a", "}"], ["{", "}"])


# ----------------------------------------------------------------------------- running commands


@dataclass
class Shell:
    """Runs the page's commands in the current folder; keeps the last status and what every
    ``magsail`` stage printed."""

    status: int = 0
    magsail_outputs: list[tuple[list[str], str]] = field(default_factory=list)

    def run(self, line: str) -> tuple[int, str, str]:
        """``(status, stdout, stderr)`` of one command line."""
        if line == "echo $?":
            return 0, f"{self.status}\n", ""
        words = shlex.split(line)
        target = None
        if len(words) > 2 and words[-2] == ">":
            words, target = words[:-2], words[-1]
        stages = [list(g) for g in _split(words, "|")]
        if not all(stage and stage[0] in ("magsail", "python") for stage in stages) or ">" in words:
            assert not {"magsail", "python"} & set(words), f"{line}: only the forms of the module docstring"
            done = subprocess.run(["bash", "-c", line], capture_output=True, text=True, timeout=120)
            return done.returncode, done.stdout, done.stderr
        stdin, err_all, code = "", "", 0
        for stage in stages:
            code, out, err = self._stage(stage, stdin)
            err_all += err
            if stage[0] == "magsail":
                self.magsail_outputs.append((stage, out))
            stdin = out
        if target is not None:
            Path(target).write_text(stdin)
            stdin = ""
        return code, stdin, err_all

    @staticmethod
    def _stage(argv: list[str], stdin: str) -> tuple[int, str, str]:
        out, err = io.StringIO(), io.StringIO()
        saved = sys.stdin, sys.argv
        sys.stdin = io.StringIO(stdin)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                if argv[0] == "magsail":
                    code = magsail(argv[1:])
                else:
                    sys.argv = argv[1:]
                    try:
                        runpy.run_path(argv[1], run_name="__main__")
                        code = 0
                    except SystemExit as exit_:
                        code = exit_.code if isinstance(exit_.code, int) else 1
        finally:
            sys.stdin, sys.argv = saved
        return code, out.getvalue(), err.getvalue()


def _split(words: list[str], sep: str) -> list[list[str]]:
    groups: list[list[str]] = [[]]
    for w in words:
        if w == sep:
            groups.append([])
        else:
            groups[-1].append(w)
    return groups


# ----------------------------------------------------------------------------- the page


def test_the_page_runs_as_written(tmp_path, monkeypatch):
    steps = page_steps(PAGE.read_text(encoding="utf-8"))
    assert sum(isinstance(s, File) for s in steps) >= 6 and sum(isinstance(s, Command) for s in steps) >= 10
    monkeypatch.chdir(tmp_path)
    shell = Shell()
    outputs: dict[str, tuple[int, str, str]] = {}
    for k, step in enumerate(steps):
        if isinstance(step, File):
            assert "/" not in step.name and not Path(step.name).exists(), f"{step.name}: written twice"
            Path(step.name).write_text(step.text, encoding="utf-8")
            continue
        code, out, err = shell.run(step.line)
        outputs[step.line] = code, out, err
        checked = step.line == "echo $?" or (k + 1 < len(steps) and getattr(steps[k + 1], "line", "") == "echo $?")
        assert checked or code == 0, f"$ {step.line}\nexit {code}\n{err[-3000:]}"
        shown = (out if code == 0 else err).splitlines()
        assert output_matches(shown, step.expected), (
            f"$ {step.line}\nprinted:\n" + "\n".join(shown[:80]) + "\nquoted:\n" + "\n".join(step.expected)
        )
        if step.line != "echo $?":
            shell.status = code

    # the misspelt node: one problem, naming the element, the key and the value; nothing written
    typo = [line for line in outputs if "sat_typo.toml" in line and line.startswith("magsail")]
    assert len(typo) == 2, typo
    for line in typo:
        code, out, err = outputs[line]
        problems = [row for row in err.splitlines() if row.startswith("  ")]
        assert code == 2 and out == "", (line, code, out)
        assert len(problems) == 1 and "members[3].nodes: node 80 does not exist (11 nodes)" in problems[0], err
    assert not (tmp_path / "runs" / "typo").exists()

    # every modes listing: ascending, its zero modes first
    modes = [json.loads(out) for stage, out in shell.magsail_outputs if stage[1] == "modes" and out]
    assert len(modes) >= 5
    for result in modes:
        f = result["frequencies_Hz"]
        assert f == sorted(f) and len(f) == result["count"], result["source"]
        assert all(x == 0.0 for x in f[: result["rigid_body_modes"]]) and f[result["rigid_body_modes"]] > 0

    # the runs completed, the detumble with its video and plots
    assert not (tmp_path / "runs" / "dt_0.02").exists()
    for run, status in (("detumble", "completed"), ("mast", "completed")):
        summary = json.loads((tmp_path / "runs" / run / "summary.json").read_text())
        assert summary["status"] == status, (run, summary["status_message"])
    folder = tmp_path / "runs" / "detumble"
    for name in ("video.mp4", "body_rates.png", "torques.png", "shape.png", "strain.png", "angular_momentum.png"):
        assert (folder / name).stat().st_size > 1000, name

    # the Python entry points the page names take its config
    sim = magsail_mj.load("detumble.toml", ["sim.duration_s=60"])
    assert sim.time == 0.0 and sim.cfg.sim.duration_s == 60.0
    env = envs.load("detumble.toml")
    assert env.reset().first() and env.action_spec().shape == (3,)
