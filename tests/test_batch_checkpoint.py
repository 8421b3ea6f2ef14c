"""Checkpoints of a batch: a stopped, interrupted or killed batch resumes to the folders it would have written.

Four CNUSAIL B-dot worlds (two tumbling, one whose detumble stop rule ends it at t = 8 s, one
that diverges at t = 0.2 s) run 20 s with ``sim.checkpoint_every_s = 5``, with Python and with
compiled loads. A batch stopped (``stop_after_s``), interrupted (Ctrl-C inside the step loop)
or killed (SIGKILL of its process right after its second checkpoint) and then resumed with
``run_batch_folders(..., resume=True)`` must leave every world's folder equal to the
uninterrupted batch's: the same files, every record and derived series bit for bit, the same
summary in every key but the process's timing (``wall_time_s``, ``step_cost_us``), the same
manifest status and step count; and a world's folder equal to its single run's. Nothing is
compared to a tolerance: the resumed batch steps from the checkpoint's exact state.

A checkpoint of another config, of other folders, edited, or forged with state this batch has
not is refused, naming the world, its folder and the config key that differs; a sweep whose batch
process is killed resumes the batch from its checkpoint, not from t = 0.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import numpy as np
import pytest
import zarr

import magsail_mj
from magsail_mj.batch.checkpoint import BATCH_CHECKPOINT_NAME
from magsail_mj.batch.folders import batch_checkpoint_time, run_batch_folders
from magsail_mj.checkpoint import CheckpointError, read_checkpoint, write_checkpoint
from magsail_mj.concepts.cnusail.tasks import AttitudeTask
from magsail_mj.config import load_config
from magsail_mj.export import read_timeseries
from magsail_mj.batch.records import WorldRecords
from magsail_mj.records import SERIES_GROUP, Recorder, open_records
from magsail_mj.run import RunInterrupted, run_scenario
from magsail_mj.sweep import SweepRun, load_sweep, run_sweep
from magsail_mj.sweep.batches import plan_batches
from magsail_mj.sweep.runner import run_one
from tests.conftest import REPO, wait_for
from tests.test_sweep_batch import _batch_processes, _monte_carlo

PRE = str(REPO / "magsail_mj/concepts/cnusail/configs/detumble_pre.toml")
SHARED = ["sim.duration_s=20", "sim.checkpoint_every_s=5.0", "sim.progress=false"]
WORLDS = [
    [],
    ["initial.omega0_deg_s=[2.0, 9.0, -4.0]", "control.bdot_gain_Am2s_T=20000.0"],
    ["initial.omega0_deg_s=[0.3, -0.2, 0.1]", "sim.stop_rate_deg_s=1.0", "sim.stop_hold_s=8.0"],
    ["initial.omega0_deg_s=[3e10, 1e10, 0.0]"],
]
ENDED = ["completed", "completed", "completed", "diverged"]
LOADS = {"python": [], "compiled": ["sim.loads=compiled"]}
TIMING = ("wall_time_s", "step_cost_us")


@pytest.fixture(autouse=True)
def _no_plots(monkeypatch):
    """The plots are drawn by the same function from the same series; drawing them is most of a short run's cost."""
    monkeypatch.setattr(AttitudeTask, "plots", lambda self, run_dir, result, series: [])


SHORT_CHUNKS = """
from magsail_mj.batch.records import WorldRecords
from magsail_mj.records import Recorder
WorldRecords.__init__.__kwdefaults__["chunk_bytes"] = 1024  # 1024 B / 208 B of qpos: 4 records a chunk
Recorder.__init__.__kwdefaults__["min_chunk"] = 4
"""


@pytest.fixture(autouse=True)
def _short_chunks(monkeypatch):
    """Record chunks of 4 records (of 1 260 in a batch's CNUSAIL world), so that every checkpoint
    finds full chunks in the stores and rows after them (:data:`SHORT_CHUNKS` in a subprocess)."""
    monkeypatch.setitem(WorldRecords.__init__.__kwdefaults__, "chunk_bytes", 1024)
    monkeypatch.setitem(Recorder.__init__.__kwdefaults__, "min_chunk", 4)


def _batch(loads: str, worlds: list[list[str]] = WORLDS) -> magsail_mj.batch.BatchSimulation:
    return magsail_mj.load(PRE, [*SHARED, *LOADS[loads]], world_overrides=worlds)


def _dirs(root: Path) -> list[Path]:
    return [root / f"w{k}" for k in range(len(WORLDS))]


_REFERENCE: dict[str, Path] = {}


def _reference(loads: str, tmp_path_factory) -> Path:
    """The uninterrupted batch's folders (run once per loads path)."""
    if loads not in _REFERENCE:
        root = tmp_path_factory.mktemp(f"reference-{loads}")
        out = run_batch_folders(_batch(loads), _dirs(root))
        assert [o.status for o in out] == ENDED
        assert not (root / "w0" / BATCH_CHECKPOINT_NAME).exists()  # a finished batch leaves no checkpoint
        _REFERENCE[loads] = root
    return _REFERENCE[loads]


def _assert_same_folder(got: Path, want: Path, *, chunks: bool = True) -> None:
    """The same files, records and series bit for bit, summary and manifest but for the timing
    (``chunks``: the same record chunks' digests too — a single run's chunks are longer)."""
    assert sorted(p.name for p in got.iterdir()) == sorted(p.name for p in want.iterdir()), got
    a, b = (json.loads((d / "summary.json").read_text()) for d in (got, want))
    assert {k: v for k, v in a.items() if k not in TIMING} == {k: v for k, v in b.items() if k not in TIMING}, got
    ma, mb = (json.loads((d / "manifest.json").read_text()) for d in (got, want))
    for key in ("config", "config_hash", "numbers_hash", "status", "status_message", "t_end_s", "steps"):
        assert ma[key] == mb[key], (got, key)
    assert sorted(ma["files"]) == sorted(mb["files"])
    assert ma["records_digests"] == mb["records_digests"] or not chunks
    for group in (None, SERIES_GROUP):
        ra, rb = open_records(got, group=group), open_records(want, group=group)
        assert sorted(ra) == sorted(rb), (got, group)
        for name in rb:
            assert np.array_equal(np.asarray(ra[name]), np.asarray(rb[name]), equal_nan=True), (got, group, name)


@pytest.mark.parametrize("loads", ["python", "compiled"])
def test_a_stopped_batch_resumes_to_the_uninterrupted_folders(tmp_path, tmp_path_factory, loads):
    ref = _reference(loads, tmp_path_factory)
    dirs = _dirs(tmp_path)
    stopped = run_batch_folders(_batch(loads), dirs, stop_after_s=6.4)
    assert [o.status for o in stopped] == ["stopped", "stopped", "stopped", "diverged"]
    header, _, arrays = read_checkpoint(dirs[0] / BATCH_CHECKPOINT_NAME)
    assert (header["step"], [w["folder"] for w in header["worlds"]]) == (32, ["w0", "w1", "w2", "w3"])
    # 7 records at t = 0 … 6 s: one chunk of 4 in the store, 3 rows in the file (1 record of the diverged world)
    counts = [(w["n_records"], w["n_stored"], len(arrays.get(f"r{k}.t", ()))) for k, w in enumerate(header["worlds"])]
    assert counts == [(7, 4, 3), (7, 4, 3), (7, 4, 3), (1, 0, 1)]
    resumed = run_batch_folders(_batch(loads), dirs, resume=True)
    assert [o.status for o in resumed] == ENDED
    assert not (dirs[0] / BATCH_CHECKPOINT_NAME).exists()
    for mine, want in zip(dirs, _dirs(ref)):
        _assert_same_folder(mine, want)
    single = tmp_path / "single1"  # world 1 alone, as magsail run writes it (its own checkpoint aside)
    run_scenario(load_config(PRE, [*SHARED, *LOADS[loads], *WORLDS[1]]), single, progress=False)
    (single / "checkpoint.npz").unlink()
    _assert_same_folder(dirs[1], single, chunks=False)


def test_an_interrupted_batch_resumes_from_its_last_checkpoint(tmp_path, tmp_path_factory, monkeypatch):
    ref = _reference("python", tmp_path_factory)
    dirs = _dirs(tmp_path)
    sim = _batch("python")
    probes = sim.plant.probes

    def interrupting(step, qpos, qvel):
        if step >= 66:  # the record at t = 14 s, after the checkpoint at 10 s
            raise KeyboardInterrupt
        return probes(step, qpos, qvel)

    monkeypatch.setattr(sim.plant, "probes", interrupting)
    with pytest.raises(RunInterrupted):
        run_batch_folders(sim, dirs)
    assert [json.loads((d / "summary.json").read_text())["status"] for d in dirs] == [
        "interrupted", "interrupted", "completed", "diverged",
    ]  # fmt: skip
    assert len(read_timeseries(dirs[0])["t"]) == 14  # records to t = 13 s: the resume cuts them to the checkpoint's
    assert read_checkpoint(dirs[0] / BATCH_CHECKPOINT_NAME)[0]["t_s"] == 10.0
    assert run_batch_folders(_batch("python"), dirs, resume=True)[0].status == "completed"
    for mine, want in zip(dirs, _dirs(ref)):
        _assert_same_folder(mine, want)


KILLED = (
    SHORT_CHUNKS
    + """
import os, signal, sys
import magsail_mj
from magsail_mj.batch import runner
from magsail_mj.batch.folders import run_batch_folders
written = []
real = runner.write_batch_checkpoint
def write_then_die(sim, path):
    real(sim, path)
    written.append(sim.time)
    if len(written) == 2:
        os.kill(os.getpid(), signal.SIGKILL)
runner.write_batch_checkpoint = write_then_die
sim = magsail_mj.load({pre!r}, {shared!r}, world_overrides={worlds!r})
run_batch_folders(sim, {dirs!r})
"""
)


def test_a_killed_batch_process_resumes(tmp_path, tmp_path_factory):
    ref = _reference("python", tmp_path_factory)
    dirs = _dirs(tmp_path)
    script = KILLED.format(pre=PRE, shared=SHARED, worlds=WORLDS, dirs=[str(d) for d in dirs])
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(script)], cwd=REPO, capture_output=True, timeout=600)
    assert proc.returncode == -signal.SIGKILL, proc.stderr.decode()[-2000:]
    assert not any((d / "manifest.json").exists() for d in dirs)  # killed before any folder was finished
    assert read_checkpoint(dirs[0] / BATCH_CHECKPOINT_NAME)[0]["t_s"] == 10.0
    assert batch_checkpoint_time(_batch("python"), dirs) == 10.0
    assert [o.status for o in run_batch_folders(_batch("python"), dirs, resume=True)] == ENDED
    for mine, want in zip(dirs, _dirs(ref)):
        _assert_same_folder(mine, want)


def test_checkpoints_of_another_config_other_folders_or_edited_are_refused(tmp_path):
    dirs = _dirs(tmp_path)
    with pytest.raises(ValueError, match=r"stop_after_s: must be at least one time step \(0.2 s\) beyond t = 0 s"):
        run_batch_folders(_batch("python"), dirs, stop_after_s=0.1)
    run_batch_folders(_batch("python"), dirs, stop_after_s=5.0)
    ckpt = dirs[0] / BATCH_CHECKPOINT_NAME
    with pytest.raises(ValueError, match=r"stop_after_s: must be at least one time step \(0.2 s\) beyond t = 5 s"):
        run_batch_folders(_batch("python"), dirs, resume=True, stop_after_s=5.1)
    before = {d: (d / "manifest.json").read_bytes() for d in dirs}
    other = [WORLDS[0], ["initial.omega0_deg_s=[2.0, 9.5, -4.0]", "control.bdot_gain_Am2s_T=20000.0"], *WORLDS[2:]]
    with pytest.raises(CheckpointError, match=r"world 1 \(folder 'w1'\).*initial\.omega0_deg_s"):
        run_batch_folders(_batch("python", other), dirs, resume=True)
    assert batch_checkpoint_time(_batch("python", other), dirs) is None
    with pytest.raises(CheckpointError, match="world 0 ran into the folder 'w0', this batch's world 0 runs into 'x0'"):
        run_batch_folders(_batch("python"), [tmp_path / f"x{k}" for k in range(4)], resume=True, checkpoint_path=ckpt)
    with pytest.raises(CheckpointError, match="world 0 .*versions|world 0 .*mujoco"):
        sim = _batch("python")
        sim.identities[0] = {**sim.identities[0], "versions": {**sim.identities[0]["versions"], "mujoco": "0.0"}}
        run_batch_folders(sim, dirs, resume=True)
    assert {d: (d / "manifest.json").read_bytes() for d in dirs} == before  # nothing touched
    header, _, arrays = read_checkpoint(ckpt)
    # a forged file with a valid digest but a state this batch does not have
    forged = {k: v for k, v in header.items() if k not in ("format", "state_tree", "state_digest")}
    plant = forged["state"]["dict"]["plant"]["dict"]
    forged["state"]["dict"]["plant"]["dict"] = {**plant, "injected": {"value": 1}}
    write_checkpoint(tmp_path / "forged.npz", forged, tree={}, arrays={}, extra_arrays=arrays)
    with pytest.raises(CheckpointError, match=r"batch state \.plant: has the keys \['controller', 'injected'"):
        run_batch_folders(_batch("python"), dirs, resume=True, checkpoint_path=tmp_path / "forged.npz")
    forged["state"]["dict"]["plant"]["dict"] = plant
    name = forged["state"]["dict"]["mj_state"]["array"]
    reshaped = {**arrays, name: arrays[name][:, :-1]}
    write_checkpoint(tmp_path / "reshaped.npz", forged, tree={}, arrays={}, extra_arrays=reshaped)
    with pytest.raises(CheckpointError, match=r"batch state \.mj_state: is float64\[4, \d+\], this batch holds"):
        run_batch_folders(_batch("python"), dirs, resume=True, checkpoint_path=tmp_path / "reshaped.npz")
    retyped = {**arrays, "r2.qvel": arrays["r2.qvel"].astype(np.float32)}  # a record after the store's
    write_checkpoint(tmp_path / "retyped.npz", forged, tree={}, arrays={}, extra_arrays=retyped)
    with pytest.raises(CheckpointError, match=r"world 2: the checkpoint's records of 'qvel' are float32\[21\]"):
        run_batch_folders(_batch("python"), dirs, resume=True, checkpoint_path=tmp_path / "retyped.npz")
    store = zarr.open_group(str(dirs[1] / "timeseries.zarr"), mode="r+", use_consolidated=False)
    store["qvel"][2, 3] = 0.5  # a record the checkpoint counts in the store, edited
    with pytest.raises(CheckpointError, match=r"world 1: .*qvel.*records 0-3"):
        run_batch_folders(_batch("python"), dirs, resume=True)
    # an edited file: one number of the MuJoCo state changed, the digest left as it was
    with np.load(ckpt, allow_pickle=False) as npz:
        raw = {k: npz[k] for k in npz.files}
    raw[f"x_{name}"] = raw[f"x_{name}"].copy()
    raw[f"x_{name}"][1, 3] += 1e-12
    with open(ckpt, "wb") as fh:
        np.savez(fh, **raw)
    with pytest.raises(CheckpointError, match="differs from its state digest"):
        run_batch_folders(_batch("python"), dirs, resume=True)
    # a file with a pickled object inside is never unpickled
    with open(ckpt, "wb") as fh:
        np.savez(fh, **raw, x_payload=np.array([{"a": 1}], dtype=object))
    with pytest.raises(CheckpointError, match="unreadable or truncated .*allow_pickle=False"):
        run_batch_folders(_batch("python"), dirs, resume=True)
    assert {d: (d / "manifest.json").read_bytes() for d in dirs} == before


def test_a_killed_sweep_batch_resumes_from_its_checkpoint(tmp_path):
    """The sweep's retry of a batch process killed after its first checkpoint resumes the batch."""
    sweep = load_sweep(
        _monte_carlo(tmp_path, 3, ["sim.duration_s=600", "sim.checkpoint_every_s=50.0", "sim.progress=false"])
    )
    out, box = tmp_path / "out", {}
    thread = threading.Thread(
        target=lambda: box.update(records=run_sweep(sweep, out, log=None, batch_size=3, retries=1))
    )
    thread.start()
    try:
        wait_for(lambda: (out / "s0" / BATCH_CHECKPOINT_NAME).is_file(), 300, "the batch's first checkpoint")
        (pid,) = set(_batch_processes())
        os.kill(pid, signal.SIGKILL)
    finally:
        thread.join(timeout=600)
    assert not thread.is_alive(), "the sweep did not finish after its batch process was killed"
    records = box["records"]
    assert [(r["status"], r["attempts"]) for r in records] == [("completed", 2)] * 3
    t_from = {r["resumed_from_s"] for r in records}
    assert len(t_from) == 1 and t_from.pop() in (50.0 * k for k in range(1, 12))  # from a checkpoint, not t = 0
    assert not (out / "s0" / BATCH_CHECKPOINT_NAME).exists()
    single = run_one(sweep.runs[1], tmp_path / "single", video=False)  # the resumed world equals its single run
    got, want = read_timeseries(out / "s1"), read_timeseries(tmp_path / "single" / "s1")
    assert single["status"] == "completed" and sorted(got) == sorted(want)
    for key in want:
        assert np.array_equal(got[key], want[key], equal_nan=True), key


def test_a_later_sweep_keeps_the_batch_its_checkpoint_names(tmp_path):
    """The planner keeps together, in the file's order, the runs a batch checkpoint names."""

    def run(rid: str, *extra: str) -> SweepRun:
        return SweepRun(id=rid, config=Path(PRE), overrides=(f"initial.omega0_deg_s=[{rid[1]}.5, 1.0, 1.0]", *extra),
                        concept="cnusail")  # fmt: skip

    runs = [run(f"b{i}") for i in range(6)]

    def checkpoint(first: str, folders: list[str]) -> None:
        header = {"kind": "magsail_mj batch checkpoint 1", "t_s": 5.0, "worlds": [{"folder": f} for f in folders]}
        (tmp_path / first).mkdir(exist_ok=True)
        write_checkpoint(tmp_path / first / BATCH_CHECKPOINT_NAME, header, tree={}, arrays={}, extra_arrays={})

    checkpoint("b4", ["b4", "b1"])
    checkpoint("b2", ["b2", "b9"])  # names a run that is not to run: not kept
    checkpoint("b5", ["b5", "b0", "b3", "b2"])  # four worlds, more than the batch size: not kept
    tasks, _ = plan_batches(runs, tmp_path, batch_size=3, cores=1, memory_per_core_bytes=1e12)
    # b4 and b1 together as the file names them; the other four in two balanced batches
    assert [[r.id for r in t] for t in tasks] == [["b0", "b2"], ["b3", "b5"], ["b4", "b1"]]
    tasks, _ = plan_batches(runs, tmp_path, batch_size=3, cores=1, memory_per_core_bytes=1e12, resume=False)
    assert [[r.id for r in t] for t in tasks] == [["b0", "b1", "b2"], ["b3", "b4", "b5"]]
    (tmp_path / "b4" / BATCH_CHECKPOINT_NAME).write_bytes(b"edited")  # unreadable: the runs are grouped as usual
    tasks, _ = plan_batches(runs, tmp_path, batch_size=3, cores=1, memory_per_core_bytes=1e12)
    assert [[r.id for r in t] for t in tasks] == [["b0", "b1", "b2"], ["b3", "b4", "b5"]]
