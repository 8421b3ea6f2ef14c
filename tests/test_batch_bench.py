"""The benchmark of batched worlds: ``bench(..., worlds=N)`` and the ``bench`` verb with ``worlds``
report the figures per world-step, consistent with each other; bad options are named."""

from __future__ import annotations

import argparse
import json

import pytest

from magsail_mj.bench import bench
from magsail_mj.cli import main
from magsail_mj.verbs.bench import run_bench
from tests.test_batch_equals_single import PRE


def test_bench_worlds_reports_per_world_step_figures():
    out = bench(PRE, duration_s=2.0, worlds=3, nthread=2, repeat=2)
    assert (out["worlds"], out["nthread"], out["steps"], out["repeat"]) == (3, 2, 10, 2)
    assert out["us_per_world_step"] > 0 and out["mj_step_us"] > 0
    assert out["ratio_to_mj_step"] == pytest.approx(out["us_per_world_step"] / out["mj_step_us"], rel=1e-12)
    assert out["cpu_ratio_to_mj_step"] == pytest.approx(out["cpu_us_per_world_step"] / out["mj_step_cpu_us"], rel=1e-12)
    assert len(out["us_per_world_step_runs"]) == 2
    with pytest.raises(ValueError, match="worlds: must be an integer >= 1, got 0"):
        bench(PRE, duration_s=2.0, worlds=0)


def test_bench_verb_with_worlds_prints_them(capsys):
    args = argparse.Namespace(config=PRE, set=[], duration_s=1.0, repeat=1, worlds=2, nthread=1)
    assert run_bench(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["worlds"] == 2 and out["steps"] == 5 and "us_per_world_step" in out and "ratio_to_mj_step" in out


def test_bench_command_line_takes_worlds_and_threads(capsys):
    assert main(["bench", str(PRE), "--duration-s", "1", "--worlds", "2", "--threads", "2"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert (out["worlds"], out["nthread"], out["steps"]) == (2, 2, 5)
    assert main(["bench", str(PRE), "--worlds", "0"]) == 2
    assert "--worlds" in capsys.readouterr().err
    assert main(["bench", str(PRE), "--duration-s", "1", "--worlds", "2", "--threads", "1000000"]) == 2
    assert "--threads" in capsys.readouterr().err
