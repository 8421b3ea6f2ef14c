"""Command-line hygiene: ``python -m magsail_mj``, ``--version``, logging levels, help texts and the
exit statuses stated in every ``--help``.

The verbs' behaviour under hostile input is tested in ``test_hostile_cli.py``; here the parser is
walked as a data structure and the command is started as users start it (a subprocess of
``python -m magsail_mj``). Every test runs in seconds (the cubesat for 1 s of simulated time).
"""

from __future__ import annotations

import argparse
import logging
import re
import subprocess
import sys
import warnings
from importlib import metadata
from pathlib import Path

import numpy as np
import pytest

from magsail_mj import cli
from magsail_mj.cli import EXIT_CODES, LOG, main

ROOT = Path(__file__).resolve().parents[1]
DOCS_EXT = ROOT / "docs" / "_ext"
CONFIG = str(ROOT / "magsail_mj/concepts/cnusail/configs/detumble_pre.toml")
TINY = ["--set", "sim.duration_s=1", "--no-progress"]
EXIT_STATUSES = {0, 1, 2, 3, 130}
sys.path.insert(0, str(DOCS_EXT))
import magsail_refs  # noqa: E402  (lives in docs/_ext, put on the path just above)


def _parsers(parser: argparse.ArgumentParser) -> list[argparse.ArgumentParser]:
    """``parser`` and every sub-command parser below it."""
    found = [parser]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                found += _parsers(sub)
    return found


def _module_command(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "magsail_mj", *args], capture_output=True, text=True, cwd=cwd, timeout=120
    )


def test_every_argument_of_every_verb_has_help_text():
    missing = []
    for parser in _parsers(cli._parser()):
        for action in parser._actions:
            if not (action.help or "").strip() or action.help == argparse.SUPPRESS:
                missing.append(f"{parser.prog}: {'/'.join(action.option_strings) or action.dest}")
        for sub_action in parser._actions:
            if isinstance(sub_action, argparse._SubParsersAction):
                for choice in sub_action._choices_actions:
                    if not (choice.help or "").strip():
                        missing.append(f"{parser.prog} {choice.dest}")
    assert not missing, f"arguments without help text: {missing}"


def test_every_help_states_the_exit_statuses():
    for parser in _parsers(cli._parser()):
        assert parser.epilog == EXIT_CODES, parser.prog
        assert "exit status:" in parser.format_help(), parser.prog


def test_exit_status_list_matches_the_codes_the_command_returns():
    listed = {int(m) for m in re.findall(r"^\s+(\d+)\s", EXIT_CODES, flags=re.MULTILINE)}
    assert listed == EXIT_STATUSES
    assert set(cli._RUN_EXIT.values()) <= EXIT_STATUSES


def test_version_names_package_mujoco_and_numpy(capsys):
    assert main(["--version"]) == 0
    out = capsys.readouterr().out
    for name in ("magsail_mj", "mujoco", "numpy"):
        assert metadata.version(name) in out, (name, out)
    assert out.startswith("magsail ") and "mujoco" in out and "numpy" in out


def test_python_dash_m_is_the_magsail_command(tmp_path):
    version = _module_command("--version", cwd=tmp_path)
    assert version.returncode == 0, version.stderr
    assert version.stdout.strip() == cli.version_text()
    bad = _module_command("validate", str(tmp_path / "missing.toml"), cwd=tmp_path)
    assert bad.returncode == 2
    assert bad.stderr.startswith("error: config: no such file"), bad.stderr
    assert "Traceback" not in bad.stderr


def test_usage_error_is_one_error_line(capsys):
    assert main(["run", CONFIG]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "--out" in err, err
    assert len(err.strip().splitlines()) == 1


@pytest.mark.parametrize(
    "flags, level",
    [([], logging.WARNING), (["-v"], logging.INFO), (["-vv"], logging.DEBUG), (["-v", "-v", "-v"], logging.DEBUG)],
)
def test_verbosity_sets_the_logger_level(monkeypatch, capsys, flags, level):
    seen = {}

    def fake_validate(args):
        seen["level"] = LOG.getEffectiveLevel()
        LOG.info("an info message")
        LOG.debug("a debug message")
        LOG.warning("a warning message")
        return 0

    monkeypatch.setattr(cli, "_cmd_validate", fake_validate)
    assert main([*flags, "validate", CONFIG]) == 0
    err = capsys.readouterr().err
    assert seen["level"] == level
    assert "warning: a warning message" in err
    assert ("an info message" in err) == (level <= logging.INFO)
    assert ("a debug message" in err) == (level <= logging.DEBUG)
    assert LOG.handlers == [] or all(not isinstance(h, cli._StderrHandler) for h in LOG.handlers)


def test_verbose_option_after_the_verb(monkeypatch, capsys):
    seen = {}

    def fake_validate(args):
        seen["level"] = LOG.getEffectiveLevel()
        return 0

    monkeypatch.setattr(cli, "_cmd_validate", fake_validate)
    assert main(["validate", CONFIG, "-v"]) == 0
    assert seen["level"] == logging.INFO


def test_run_is_quiet_by_default_and_names_its_folder_with_v(tmp_path, capsys):
    assert main(["run", CONFIG, "--out", str(tmp_path / "quiet"), *TINY]) == 0
    quiet = capsys.readouterr()
    assert quiet.err == "", quiet.err
    assert '"status": "completed"' in quiet.out
    assert main(["run", CONFIG, "--out", str(tmp_path / "loud"), "-v", *TINY]) == 0
    loud = capsys.readouterr().err
    assert f"run folder: {tmp_path / 'loud'}" in loud


def test_python_warnings_become_one_warning_line(monkeypatch, capsys):
    def warn(args):
        warnings.warn("a physical warning", UserWarning, stacklevel=1)
        return 0

    monkeypatch.setattr(cli, "_cmd_validate", warn)
    assert main(["validate", CONFIG]) == 0
    err = capsys.readouterr().err
    assert err == "warning: a physical warning\n", err


def test_cli_reference_lists_every_verb_and_every_exit_status():
    page = magsail_refs.cli_reference()
    for parser in _parsers(cli._parser()):
        assert f"`{parser.prog}`" in page, parser.prog
    for line in EXIT_CODES.splitlines():
        assert line.strip() in page, line


def test_export_verb_writes_the_records_and_refuses_a_bad_format(tmp_path, capsys):
    run = tmp_path / "run"
    assert main(["run", CONFIG, "--out", str(run), *TINY]) == 0
    capsys.readouterr()
    assert main(["export", str(run), "--format", "npz", "--out", str(tmp_path / "r.npz")]) == 0
    assert capsys.readouterr().out.strip() == str(tmp_path / "r.npz")
    with np.load(tmp_path / "r.npz", allow_pickle=False) as npz:
        t_s = npz["t"]
    assert t_s[0] == 0.0 and t_s[-1] == pytest.approx(1.0)
    assert main(["export", str(run), "--format", "hdf9"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "hdf9" in err


def test_report_verb_refuses_a_folder_that_is_not_a_sweep(tmp_path, capsys):
    assert main(["report", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: SWEEP_DIR") and "sweep_summary.json" in err


def test_guarantees_page_lists_the_same_exit_statuses():
    page = (ROOT / "docs" / "guarantees.md").read_text()
    table = {int(m) for m in re.findall(r"^\| (\d+) \|", page, flags=re.MULTILINE)}
    assert table == EXIT_STATUSES
    assert "1 when any run of the call failed, was interrupted or stopped, else 3 when any" in page
    assert (
        "sweep: non-zero when any run failed, was interrupted or stopped (1), else when any diverged (3)" in EXIT_CODES
    )


def test_getting_started_lists_every_verb_of_the_parser():
    page = (ROOT / "docs" / "getting-started.md").read_text()
    listed = set(re.findall(r"^magsail (\w+)\s", page, flags=re.MULTILINE))
    verbs = {
        name
        for action in cli._parser()._actions
        if isinstance(action, argparse._SubParsersAction)
        for name in action.choices
    }
    assert listed == verbs, f"getting-started lists {sorted(listed)}, the parser has {sorted(verbs)}"
