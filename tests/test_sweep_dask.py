"""The sweep engine on dask.distributed: a worker killed mid-run, the run retried elsewhere and resumed
bit-identically from its checkpoint; the SLURM/PBS job scripts; the cluster options of the CLI."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from magsail_mj.cli import main
from magsail_mj.config import load_config
from magsail_mj.export import read_timeseries
from magsail_mj.run import run_scenario
from magsail_mj.sweep import SweepRun, load_sweep, make_cluster, run_sweep
from magsail_mj.sweep.runner import run_one
from tests.conftest import CHECKPOINTING_RUN, wait_for

ROOT = Path(__file__).resolve().parents[1]
CFG_A = ROOT / "magsail_mj" / "concepts" / "current_loops" / "configs" / "sweep" / "a_n12_ei1e3.toml"
DASK = Path(sys.executable).with_name("dask")


def _sweep_file(tmp_path: Path, ids: list[str], common: list[str]) -> Path:
    runs = "".join(f'\n[[run]]\nid = "{rid}"\nconfig = "{CFG_A}"\n' for rid in ids)
    path = tmp_path / "dask.toml"
    path.write_text(f'name = "dask"\nset = {json.dumps(common)}\n{runs}')
    return path


def _parent(pid: int) -> int:
    return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])


def _run_processes_below(nannies) -> dict[int, int]:
    """Run processes (``python -m magsail_mj.sweep``) started by the workers of ``nannies``: pid → nanny."""
    found = {}
    for entry in Path("/proc").iterdir():
        try:
            if entry.name.isdigit() and b"-m\0magsail_mj.sweep\0" in (entry / "cmdline").read_bytes():
                nanny = _parent(_parent(int(entry.name)))  # run process <- worker process <- `dask worker`
                if nanny in nannies:
                    found[int(entry.name)] = nanny
        except (OSError, IndexError, ValueError):
            continue
    return found


def _scheduler_address(info: Path) -> str | None:
    """The address in the scheduler file, or None while the scheduler has not finished writing it
    (the file appears before its JSON is complete)."""
    try:
        return json.loads(info.read_text())["address"]
    except (OSError, ValueError, KeyError):
        return None


@pytest.fixture
def dask_cluster(tmp_path):
    """A scheduler and two single-thread workers on localhost (``dask scheduler`` / ``dask worker``)."""
    if not DASK.exists():
        pytest.skip("the dask command line is not installed")
    info = tmp_path / "scheduler.json"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    common = {
        "cwd": ROOT,
        "env": env,
        "stdout": subprocess.DEVNULL,
        "stderr": subprocess.DEVNULL,
        "start_new_session": True,
    }
    procs = [
        subprocess.Popen(
            [
                str(DASK),
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--no-dashboard",
                "--scheduler-file",
                str(info),
            ],
            **common,
        )
    ]
    try:
        wait_for(lambda: _scheduler_address(info) is not None, 180, "the scheduler")
        address = _scheduler_address(info)
        for name in ("w1", "w2"):
            procs.append(
                subprocess.Popen(
                    [
                        str(DASK),
                        "worker",
                        address,
                        "--nthreads",
                        "1",
                        "--nworkers",
                        "1",
                        "--no-dashboard",
                        "--name",
                        name,
                    ],
                    **common,
                )
            )
        yield address, {p.pid: p for p in procs[1:]}
    finally:
        for proc in procs:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            proc.wait(timeout=10)


def test_killed_worker_is_retried_elsewhere_and_resumes_bit_identically(tmp_path, dask_cluster):
    address, nannies = dask_cluster
    sweep = load_sweep(_sweep_file(tmp_path, ["ck"], CHECKPOINTING_RUN))
    out = tmp_path / "out"
    box = {}
    thread = threading.Thread(target=lambda: box.update(records=run_sweep(sweep, out, scheduler=address, log=None)))
    thread.start()
    try:
        wait_for(lambda: (out / "ck" / "checkpoint.npz").exists(), 300, "the run's first checkpoint")
        ((pid, nanny),) = _run_processes_below(nannies).items()
        os.killpg(nanny, signal.SIGKILL)  # the whole `dask worker`: nanny and worker process
    finally:
        thread.join(timeout=180)
    assert not thread.is_alive(), "the sweep did not finish after its worker was killed"
    (record,) = box["records"]
    assert record["status"] == "completed", record["message"]
    assert record["attempts"] == 2 and record["resumed_from_s"] > 0
    stored = json.loads((out / "sweep_summary.json").read_text())
    assert stored[0]["attempts"] == 2 and stored[0]["resumed_from_s"] == record["resumed_from_s"]
    # the same run uninterrupted, here in this process: records bit-identical
    reference = run_one(sweep.runs[0], tmp_path / "ref", video=False)
    assert reference["status"] == "completed" and reference["resumed_from_s"] is None
    got, want = read_timeseries(out / "ck"), read_timeseries(tmp_path / "ref" / "ck")
    assert sorted(got) == sorted(want)
    for key in want:
        assert np.array_equal(got[key], want[key], equal_nan=True), key
    got, want = (json.loads((d / "ck" / "summary.json").read_text()) for d in (out, tmp_path / "ref"))
    assert {k: v for k, v in got.items() if k != "wall_time_s"} == {k: v for k, v in want.items() if k != "wall_time_s"}
    manifest = json.loads((out / "ck" / "manifest.json").read_text())
    assert manifest["config_hash"] == sweep.runs[0].config_hash


@pytest.mark.parametrize(("kind", "directive"), [("slurm", "#SBATCH"), ("pbs", "#PBS")])
def test_job_scripts_start_single_thread_workers(kind, directive):
    if shutil.which("sbatch") or shutil.which("qsub"):
        pytest.skip("a real queue is here; this test only reads the generated script")
    cluster = make_cluster(
        kind, cores_per_job=4, memory_per_job="8GB", walltime="02:30:00", queue="short", require_submit=False
    )
    try:
        script = cluster.job_script()
    finally:
        cluster.close()
    assert script.count(directive) >= 3 and "02:30:00" in script and "short" in script
    assert "--nthreads 1" in script and "--nworkers 4" in script and sys.executable in script
    assert "export OPENBLAS_NUM_THREADS=1" in script and "export OMP_NUM_THREADS=1" in script


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--cluster", "slurm", "--walltime", "1h"], "--walltime: must be HH:MM:SS"),
        (["--cluster", "pbs", "--memory-per-job", "lots"], "--memory-per-job: must be a memory size"),
        (["--jobs", "3"], "--jobs: only with --cluster"),
        (["--cluster", "slurm", "--scheduler", "tcp://127.0.0.1:8786"], "choose one"),
        (["--cluster", "slurm", "--workers", "4"], "--workers 4: not with --cluster"),
        (["--scheduler", " "], "--scheduler: must be a scheduler address"),
        (["--retries", "-1"], "--retries"),
    ],
)
def test_cluster_options_are_checked_before_anything_runs(tmp_path, capsys, args, message):
    out = tmp_path / "out"
    assert main(["sweep", str(_sweep_file(tmp_path, ["x"], CHECKPOINTING_RUN)), "--out", str(out), *args]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (out / "x").exists()


def test_a_run_resumes_only_from_a_checkpoint_of_its_own_config(tmp_path):
    small = [
        "lattice.units=3",
        "sim.duration_s=3.0",
        "sim.record_every=5",
        "sim.checkpoint_every_s=1.0",
        "sim.progress=false",
    ]
    run = SweepRun(id="r", config=CFG_A, overrides=tuple(small))
    run_scenario(load_config(CFG_A, small), tmp_path / "out" / "r", stop_after_s=2.0, progress=False)
    resumed = run_one(run, tmp_path / "out", video=False, fresh=False)
    assert resumed["status"] == "completed" and resumed["resumed_from_s"] == pytest.approx(2.0)
    whole = run_one(run, tmp_path / "whole", video=False, fresh=False)  # no checkpoint there: from the start
    assert whole["resumed_from_s"] is None
    got, want = read_timeseries(tmp_path / "out" / "r"), read_timeseries(tmp_path / "whole" / "r")
    assert sorted(got) == sorted(want) and all(np.array_equal(got[k], want[k], equal_nan=True) for k in want)
    # a checkpoint of another config (another time step changes the numbers) is never resumed
    other = SweepRun(id="r", config=CFG_A, overrides=(*small, "sim.timestep_s=0.05"))
    rerun = run_one(other, tmp_path / "out", video=False, fresh=False)
    assert rerun["status"] == "completed" and rerun["resumed_from_s"] is None
    # nor one beyond a shortened duration
    shorter = SweepRun(id="r", config=CFG_A, overrides=(*small, "sim.timestep_s=0.05", "sim.duration_s=1.0"))
    assert run_one(shorter, tmp_path / "out", video=False, fresh=False)["resumed_from_s"] is None
