"""Sweeps that run their runs as the worlds of batches (``--batch-size``).

A small CNUSAIL B-dot Monte Carlo run with ``--batch-size 1`` (every run alone, as before) and with
``--batch-size 3`` (two batches: three worlds and two) must give the same ``sweep_summary.json``
records and the same record stores bit for bit: the batch computes each world as its single run
does (docs/batch.md), so nothing is compared to a tolerance. Only the fields that time the
process differ, listed in :data:`TIMING`. A world that diverges is reported alone; a batch
process killed by a signal has its runs retried one by one; a later sweep into the folder reruns
only the missing runs, batched again; runs no batch takes go alone.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import threading
from pathlib import Path

import numpy as np
import pytest

from magsail_mj.cli import SWEEP_MAX_BATCH_SIZE, main
from magsail_mj.config import ConfigError, load_config
from magsail_mj.export import read_timeseries
from magsail_mj.sweep import SweepRun, load_sweep, run_sweep
from magsail_mj.sweep.batches import (
    DEFAULT_MAX_WORLDS,
    MAX_BATCH_SIZE,
    check_batch_size,
    default_batch_size,
    plan_batches,
)
from magsail_mj.sweep.runner import _next_attempt, run_one, supervise_batch
from tests.conftest import wait_for

ROOT = Path(__file__).resolve().parents[1]
PRE = ROOT / "magsail_mj" / "concepts" / "cnusail" / "configs" / "detumble_pre.toml"
LOOPS = ROOT / "magsail_mj" / "concepts" / "current_loops" / "configs" / "sweep" / "a_n12_ei1e3.toml"
SHORT = ["sim.duration_s=40", "sim.checkpoint_every_s=20.0", "sim.progress=false"]
TIMING = {
    "record": ("wall_time_s",),  # the sweep record's wall time: the run's process, or its share of the batch's
    "summary": ("wall_time_s", "step_cost_us"),  # the run's own timing of its step loop
}
"""The fields that time the process, the only ones a batched run's record may differ in."""


def _monte_carlo(tmp_path: Path, samples: int, common: list[str]) -> Path:
    path = tmp_path / "mc.toml"
    path.write_text(
        f'name = "mc"\nconfig = "{PRE}"\nset = {json.dumps(common)}\n\n[monte_carlo]\nsamples = {samples}\n'
        "seed = 2016\n"
        '"initial.omega0_deg_s" = { dist = "direction", magnitude = { dist = "uniform", low = 2.0, high = 10.0 } }\n'
        '"orbit.epoch" = { dist = "epoch", start = "2016-01-01T00:00:00Z", end = "2017-01-01T00:00:00Z" }\n'
    )
    return path


def _untimed(record: dict) -> dict:
    out = {k: v for k, v in record.items() if k not in TIMING["record"]}
    out["summary"] = {k: v for k, v in record["summary"].items() if k not in TIMING["summary"]}
    return out


def _assert_same_runs(out_a: Path, out_b: Path, ids: list[str]) -> None:
    """Equal untimed summary records and bit-identical record stores of the runs ``ids``."""
    a, b = ({r["id"]: r for r in json.loads((out / "sweep_summary.json").read_text())} for out in (out_a, out_b))
    for rid in ids:
        assert a[rid]["status"] == "completed" and a[rid]["summary"], rid
        assert _untimed(a[rid]) == _untimed(b[rid]), rid
        got, want = read_timeseries(out_b / rid), read_timeseries(out_a / rid)
        assert sorted(got) == sorted(want), rid
        for key in want:
            assert np.array_equal(got[key], want[key], equal_nan=True), (rid, key)


def test_batched_sweep_equals_single_runs_and_reruns_only_missing_runs(tmp_path):
    sweep = load_sweep(_monte_carlo(tmp_path, 5, SHORT))
    ids = [r.id for r in sweep.runs]
    alone, batched = tmp_path / "alone", tmp_path / "batched"
    records = run_sweep(sweep, alone, log=None, batch_size=1)
    assert [r["status"] for r in records] == ["completed"] * 5
    lines: list[str] = []
    records = run_sweep(sweep, batched, log=lines.append, batch_size=3)
    assert [(r["status"], r["attempts"], r["resumed_from_s"]) for r in records] == [("completed", 1, None)] * 5
    assert "batch size 3: 5 runs in 2 batches, 0 runs alone" in "\n".join(lines)
    manifest = json.loads((batched / "sweep_manifest.json").read_text())
    assert (manifest["batch_size"], manifest["batches"]) == (3, 2)
    _assert_same_runs(alone, batched, ids)
    for rid in ids:  # the same files, but the checkpoint a batch does not write
        files = {p.name for p in (alone / rid).iterdir()} - {"checkpoint.npz"}
        assert files == {p.name for p in (batched / rid).iterdir()}, rid
        assert json.loads((batched / rid / "params.json").read_text())["id"] == rid
    # a later sweep into the folder: the valid runs are reused, the missing ones batched again
    for rid in ("s1", "s4"):
        shutil.rmtree(batched / rid)
    lines.clear()
    records = run_sweep(sweep, batched, log=lines.append, batch_size=3)
    assert [r["id"] for r in records if not r["reused"]] == ["s1", "s4"]
    assert "batch size 3: 2 runs in 1 batches, 0 runs alone" in "\n".join(lines)
    _assert_same_runs(alone, batched, ["s1", "s4"])
    assert [r["attempts"] for r in records if r["reused"]] == [0, 0, 0]  # as any reused run's


def test_a_diverging_world_is_reported_alone(tmp_path):
    path = tmp_path / "grid.toml"
    path.write_text(
        f'name = "grid"\nconfig = "{PRE}"\nset = ["sim.duration_s=20", "sim.progress=false"]\n\n[grid]\n'
        '"initial.omega0_deg_s" = [[6.0, -7.0, 3.0], [3e10, 1e10, 0.0], [2.0, 9.0, -4.0]]\n'
    )
    sweep = load_sweep(path)
    records = run_sweep(sweep, tmp_path / "out", log=None, batch_size=3)
    assert [r["status"] for r in records] == ["completed", "diverged", "completed"]
    assert json.loads((tmp_path / "out" / "sweep_manifest.json").read_text())["batches"] == 1
    single = run_one(sweep.runs[1], tmp_path / "single", video=False)  # its single run, here
    assert single["status"] == "diverged", (single["message"], single.get("traceback"))
    assert _untimed(records[1]) == _untimed(single)
    manifest = json.loads((tmp_path / "out" / sweep.runs[1].id / "manifest.json").read_text())
    assert (manifest["status"], manifest["status_message"]) == ("diverged", single["message"])


def _descends_from_here(pid: int) -> bool:
    """Whether process ``pid`` is a descendant of this test process (its parent chain in /proc)."""
    me = os.getpid()
    while pid > 1:
        try:
            stat = Path(f"/proc/{pid}/stat").read_text()
        except OSError:
            return False
        pid = int(stat[stat.rindex(")") + 2 :].split()[1])
        if pid == me:
            return True
    return False


def _batch_processes() -> dict[int, str]:
    """Batch run processes (``python -m magsail_mj.sweep --batch …``) below this test process (never
    those of another test worker or another sweep on the machine, which the tests must not kill)."""
    found = {}
    for entry in Path("/proc").iterdir():
        try:
            cmd = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        if entry.name.isdigit() and "-m magsail_mj.sweep --batch" in cmd and _descends_from_here(int(entry.name)):
            found[int(entry.name)] = cmd
    return found


def test_a_killed_batch_process_retries_its_runs_alone(tmp_path):
    before = set(_batch_processes())
    sweep = load_sweep(_monte_carlo(tmp_path, 3, ["sim.duration_s=1200", "sim.progress=false"]))
    out, box = tmp_path / "out", {}
    thread = threading.Thread(
        target=lambda: box.update(records=run_sweep(sweep, out, log=None, batch_size=3, retries=1))
    )
    thread.start()
    try:
        wait_for(lambda: set(_batch_processes()) - before, 120, "the batch process")
        (pid,) = set(_batch_processes()) - before
        os.kill(pid, signal.SIGKILL)
    finally:
        thread.join(timeout=300)
    assert not thread.is_alive(), "the sweep did not finish after its batch process was killed"
    assert [(r["status"], r["attempts"]) for r in box["records"]] == [("completed", 2)] * 3
    assert json.loads((out / "sweep_manifest.json").read_text())["batches"] == 1
    assert not set(_batch_processes()) - before


def test_a_rescheduled_batch_keeps_the_runs_its_lost_attempt_finished(tmp_path):
    """A batch task started again (its worker died) reruns only the runs without a finished folder."""
    sweep = load_sweep(_monte_carlo(tmp_path, 2, ["sim.duration_s=10", "sim.progress=false"]))
    out, token = tmp_path / "out", "call"
    first = supervise_batch(sweep.runs, str(out), fresh=False, token=token, run_retries=1, grace_s=5.0)
    assert [(r["status"], r["attempts"]) for r in first] == [("completed", 1)] * 2
    kept = (out / "s0" / "manifest.json").read_bytes()
    shutil.rmtree(out / "s1")
    again = supervise_batch(sweep.runs, str(out), fresh=False, token=token, run_retries=1, grace_s=5.0)
    assert [(r["status"], r["attempts"]) for r in again] == [("completed", 2)] * 2
    assert (out / "s0" / "manifest.json").read_bytes() == kept  # not rerun
    assert _untimed(again[1]) == _untimed(first[1] | {"attempts": 2})
    assert _next_attempt(out, token, "s0") == 3


def test_runs_no_batch_takes_go_alone_and_the_default_size(tmp_path):
    def run(rid: str, config: Path, *extra: str) -> SweepRun:
        cfg = load_config(config, list(extra))
        return SweepRun(id=rid, config=config, overrides=tuple(extra), concept=cfg.concept)

    runs = [run(f"b{i}", PRE, f"initial.omega0_deg_s=[{i + 1}.0, 1.0, 1.0]") for i in range(7)]
    runs += [
        run("eigen", PRE, 'control.mode="eigen_axis"'),  # the batch refuses the pointing laws
        run("deployed", PRE, 'spacecraft.configuration="deployed"'),  # another model's sizes: alone here
        run("loops", LOOPS, "lattice.units=3"),  # a concept without a batch
        run("step", PRE, "sim.timestep_s=0.1"),  # a shared key of its own: alone here
        run("resumable", PRE, "initial.omega0_deg_s=[9.0, 1.0, 1.0]"),
    ]
    (tmp_path / "resumable").mkdir()
    (tmp_path / "resumable" / "checkpoint.npz").write_bytes(b"")  # may resume: goes alone
    tasks, size = plan_batches(runs, tmp_path, batch_size=3, cores=1, memory_per_core_bytes=1e12)
    assert size == 3
    assert [[r.id for r in t] for t in tasks] == [
        ["b0", "b1", "b2"],
        ["b3", "b4"],
        ["b5", "b6"],
        ["eigen"],
        ["deployed"],
        ["loops"],
        ["step"],
        ["resumable"],
    ]
    assert plan_batches(runs, tmp_path, batch_size=1, cores=1, memory_per_core_bytes=1e12) == (
        [(r,) for r in runs],
        1,
    )
    tasks, size = plan_batches(runs, tmp_path, batch_size=None, cores=2, memory_per_core_bytes=1e12)
    # ⌈9 / 2⌉ = 5 for the 7 B-dot runs, "deployed" and "step" ("eigen" is refused); 7 runs in 2 batches
    assert size == 5 and [len(t) for t in tasks][:2] == [4, 3]
    cfgs = [load_config(PRE, [])] * 200
    assert default_batch_size(cfgs, cores=2, memory_per_core_bytes=1e12) == DEFAULT_MAX_WORLDS
    assert default_batch_size(cfgs[:32], cores=1, memory_per_core_bytes=1e12) == 32
    assert default_batch_size(cfgs[:32], cores=16, memory_per_core_bytes=1e12) == 1  # 2 worlds a batch: not worth it
    assert default_batch_size(cfgs, cores=1, memory_per_core_bytes=1e6) == 1  # no memory for a second world
    assert default_batch_size([], cores=1, memory_per_core_bytes=1e12) == 1


@pytest.mark.parametrize("value", ["0", "-3", "1e3", "abc", "2.5", "", str(MAX_BATCH_SIZE + 1), "9" * 30])
def test_bad_batch_sizes_exit_2_naming_the_option(tmp_path, capsys, value):
    path = _monte_carlo(tmp_path, 2, ["sim.duration_s=10", "sim.progress=false"])
    assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--batch-size", value]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --batch-size:") and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_batch_size_limits_agree_and_are_checked():
    assert SWEEP_MAX_BATCH_SIZE == MAX_BATCH_SIZE
    assert check_batch_size(None) is None and check_batch_size(MAX_BATCH_SIZE) == MAX_BATCH_SIZE
    for bad in (0, -1, MAX_BATCH_SIZE + 1, 2.0, True, "3"):
        with pytest.raises(ValueError, match="--batch-size: must be an integer from 1 to"):
            check_batch_size(bad)


def test_a_sweep_without_plots_writes_the_same_numbers_and_no_png(tmp_path, capsys):
    """``plots = false`` (the sweep file) or ``--no-plots`` (the command line): the run folders of
    single and batched runs hold no PNG and list none, and everything else equals the plotted
    sweep's; a value that is not a boolean is refused naming the key."""
    path = _monte_carlo(tmp_path, 3, SHORT)
    plotted = tmp_path / "plotted"
    run_sweep(load_sweep(path), plotted, log=None, batch_size=2)
    text = path.read_text()
    path.write_text("plots = false\n" + text)
    for size in (1, 2):
        out = tmp_path / f"bare{size}"
        records = run_sweep(load_sweep(path), out, log=None, batch_size=size)
        assert [r["status"] for r in records] == ["completed"] * 3
        assert json.loads((out / "sweep_manifest.json").read_text())["plots"] is False
        for rid in ("s0", "s1", "s2"):
            files = {p.name for p in (out / rid).iterdir()}
            assert not any(name.endswith(".png") for name in files), (size, rid)
            want = {p.name for p in (plotted / rid).iterdir() if p.suffix != ".png"} - {"checkpoint.npz"}
            assert files - {"checkpoint.npz"} == want, (size, rid)
            listed = json.loads((out / rid / "manifest.json").read_text())["files"]
            assert not any(name.endswith(".png") for name in listed)
        _assert_same_runs(plotted, out, ["s0", "s1", "s2"])
    path.write_text(text)  # the command line's --no-plots does the same for a file without the key
    assert main(["sweep", str(path), "--out", str(tmp_path / "cli"), "--no-plots", "--no-progress"]) == 0
    assert not list((tmp_path / "cli").glob("s*/*.png")) and list((tmp_path / "cli").glob("s*/summary.json"))
    assert all(r.plots for r in load_sweep(path).runs) and not any(r.plots for r in load_sweep(path, plots=False).runs)
    path.write_text('plots = "no"\n' + text)
    with pytest.raises(ConfigError, match=r"plots: must be true or false, got 'no'"):
        load_sweep(path)
