"""``--stop-after-s`` (``run_scenario(stop_after_s=...)``) is refused when it would stop before one
time step, fresh or beyond a resumed checkpoint: exit 2 naming the option, the step and the
checkpoint's time, nothing written.

Before: 0.01 s (below the 0.1 s step) ended "stopped" with ``postprocess_error: IndexError`` and no
checkpoint; ``--resume --stop-after-s 1.0`` on a run checkpointed at 3.5 s rewrote the summary and
manifest as "stopped at 1 s" while the records reached 3.4 s.

The reflector plate (one rigid body, 0.1 s step): a 3.5 s run takes well under a second; its
plots (seconds of Matplotlib, not what is tested here) are left out.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from magsail_mj.cli import main
from magsail_mj.concepts.reflector.tasks import DetumbleTask
from magsail_mj.config import ConfigError, load_config
from magsail_mj.run import run_scenario
from tests.conftest import REPO

CONFIG = REPO / "magsail_mj/concepts/reflector/configs/detumble.toml"
SHORT = ["sim.duration_s=10.0", "sim.progress=false", "plate.side_m=4.0"]


def _cfg():
    return load_config(CONFIG, SHORT)


@pytest.fixture(autouse=True)
def _no_plots(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(DetumbleTask, "plots", lambda self, run_dir, result, series: [])


def test_a_stop_below_one_step_is_refused_before_anything_is_written(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with pytest.raises(ConfigError, match=r"--stop-after-s: .*sim\.timestep_s = 0\.1 s.*got 0\.01"):
        run_scenario(_cfg(), out, stop_after_s=0.01)
    assert not out.exists()


def test_the_cli_exits_2_naming_the_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["run", str(CONFIG), "--out", str(tmp_path / "run"), "--no-progress", "--stop-after-s", "0.01"]
    assert main(argv + [f"--set={s}" for s in SHORT]) == 2
    assert "--stop-after-s" in capsys.readouterr().err


def test_a_stop_at_or_before_the_checkpoint_is_refused_on_resume(tmp_path: Path) -> None:
    out = tmp_path / "run"
    first = run_scenario(_cfg(), out, stop_after_s=3.5)
    summary = (out / "summary.json").read_text()
    manifest = (out / "manifest.json").read_text()
    assert json.loads(summary)["status"] == "stopped"
    for stop in (1.0, 3.5, 3.55):  # before, at, and within one step of the checkpoint's 3.5 s
        with pytest.raises(ConfigError, match=rf"--stop-after-s: .*t = 3\.5 s, got {stop:g} s"):
            run_scenario(_cfg(), out, resume=True, stop_after_s=stop)
        assert (out / "summary.json").read_text() == summary
        assert (out / "manifest.json").read_text() == manifest
    # one step beyond the checkpoint is a valid stop
    assert first is not None and run_scenario(_cfg(), out, resume=True, stop_after_s=3.6) is not None
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "stopped" and "3.6" in summary.get("message", "3.6")
