"""The runner and run folders: outputs, resume, divergence, no silent overwrite."""

from __future__ import annotations

import json

import numpy as np
import pytest

from magsail_mj.checkpoint import read_checkpoint
from magsail_mj.concepts.truss_magnetorquer import metrics as truss_metrics
from magsail_mj.config import apply_overrides, parse_config
from magsail_mj.export import read_timeseries
from magsail_mj.io import RunDirError
from magsail_mj.records import STORE_NAME, StoreRecords
from magsail_mj.run import run_scenario
from magsail_mj.scenario import build_scenario


def _cfg(tree, *overrides):
    return parse_config(apply_overrides(tree, list(overrides)))


def test_run_folder_contents(tmp_path, small_truss_tree):
    out = run_scenario(_cfg(small_truss_tree), tmp_path / "run")
    files = {p.name for p in (tmp_path / "run").iterdir()}
    assert {
        "model.xml",
        STORE_NAME,
        "summary.json",
        "manifest.json",
        "euler_angles.png",
        "body_rates.png",
        "surface_sd.png",
    } <= files
    assert not [f for f in files if f.startswith(".")], "temporary files left behind"
    manifest = json.loads((tmp_path / "run/manifest.json").read_text())
    assert manifest["config_hash"] and manifest["versions"]["mujoco"].startswith("4.")
    pngs = {name for name in files if name.endswith(".png")}
    assert set(manifest["files"]) == {"model.xml", STORE_NAME, "summary.json", *pngs}
    assert not files & {"timeseries.npz", "timeseries.nc"}, "the records are kept in the store only"
    summary = json.loads((tmp_path / "run/summary.json").read_text())
    for key in ("rotation_x1_final_rad", "off_axis_rotation_max_rad", "surface_sd_max_m", "strain_energy_max_J"):
        assert np.isfinite(summary[key]), key
    ts = read_timeseries(tmp_path / "run")
    # record_every = 5 steps of 0.1 s over 20 s: 41 samples including t = 0 and t = 20 s
    assert ts["t"].shape == (41,) and ts["qpos"].shape == (41, 96)
    assert out.status == "completed"


def test_earlier_run_is_not_overwritten(tmp_path, small_truss_tree):
    cfg = _cfg(small_truss_tree, "sim.duration_s=1.0")
    run_scenario(cfg, tmp_path / "run")
    before = (tmp_path / "run/manifest.json").read_text()
    with pytest.raises(RunDirError, match="--overwrite"):
        run_scenario(cfg, tmp_path / "run")
    assert (tmp_path / "run/manifest.json").read_text() == before
    run_scenario(cfg, tmp_path / "run", overwrite=True)


def test_resume_equals_uninterrupted(tmp_path, small_truss_tree):
    cfg = _cfg(small_truss_tree, "sim.checkpoint_every_s=4.0")
    full = run_scenario(cfg, tmp_path / "full")
    run_scenario(cfg, tmp_path / "cut", stop_after_s=9.0)
    cut = read_timeseries(tmp_path / "cut")
    assert cut["t"][-1] < 9.0
    resumed = run_scenario(cfg, tmp_path / "cut", resume=True)
    a = read_timeseries(tmp_path / "full")
    b = read_timeseries(tmp_path / "cut")
    assert np.array_equal(a["t"], b["t"])
    assert np.array_equal(a["qpos"], b["qpos"]), "resumed run differs from the uninterrupted one"
    assert resumed["phi_final_rad"] == full["phi_final_rad"]


def test_resumed_wall_time_counts_every_segment(tmp_path, small_truss_tree):
    """A resumed run reports the wall time of all its segments, not only the last one: the
    first segment (80 % of the steps) is stored in the checkpoint and added to the second."""
    cfg = _cfg(small_truss_tree, "sim.duration_s=10.0")
    ckpt = tmp_path / "ckpt.npz"
    build_scenario(cfg).simulation().run(checkpoint_path=ckpt, stop_after_s=8.0)
    first = read_checkpoint(ckpt)[0]["wall_s"]
    resumed = build_scenario(cfg).simulation().run(checkpoint_path=ckpt, resume=True)
    assert first > 0.0
    assert resumed.status == "completed"
    assert resumed.wall_time_s > first


def test_same_config_same_numbers(tmp_path, small_truss_tree):
    cfg = _cfg(small_truss_tree, "sim.duration_s=3.0")
    run_scenario(cfg, tmp_path / "a")
    run_scenario(cfg, tmp_path / "b")
    assert np.array_equal(read_timeseries(tmp_path / "a")["qpos"], read_timeseries(tmp_path / "b")["qpos"])


def test_structural_failure_stops_with_time_and_cause_and_keeps_records(tmp_path, small_truss_tree):
    # A torque far beyond what the soft lattice can carry tears it apart within seconds: the
    # configured strain bound reports a failed structure, not a numerical divergence.
    cfg = _cfg(small_truss_tree, "profile.tau_max_Nm=50.0", "sim.max_strain=0.3", "sim.record_every=1")
    out = run_scenario(cfg, tmp_path / "run")
    assert out.status == "structure_failed"
    assert "strain" in out["status_message"] and "t = " in out["status_message"]
    ts = read_timeseries(tmp_path / "run")
    assert 1 < ts["t"].size < 201 and np.isfinite(ts["qpos"]).all()
    manifest = json.loads((tmp_path / "run/manifest.json").read_text())
    assert manifest["status"] == "structure_failed"


def test_cli_reports_bad_config_before_writing(tmp_path, capsys):
    from magsail_mj.cli import main
    from tests.conftest import REPO

    cfg = REPO / "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_c_central_bangbang.toml"
    rc = main(["run", str(cfg), "--out", str(tmp_path / "run"), "--set", "sim.timestep_s=0"])
    assert rc == 2
    err = capsys.readouterr().err
    assert "sim.timestep_s: must be a number" in err and "got 0" in err
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("period, dt, duration", [(0.1, 0.1, 1000.0), (0.3, 0.1, 1000.0), (1.0, 0.05, 500.0)])
def test_controller_sampled_at_every_period_without_drift(period, dt, duration):
    """Zero-order hold: the controller runs at k·period exactly, never skipping a sample."""
    import mujoco

    from magsail_mj.sim import Simulation

    model = mujoco.MjModel.from_xml_string(
        f'<mujoco><option timestep="{dt}" gravity="0 0 0"/><worldbody><body>'
        '<joint type="slide" axis="1 0 0"/><geom size="0.1" mass="1"/></body></worldbody></mujoco>'
    )

    class Counter:
        period_s = period

        def __init__(self):
            self.times = []

        def update(self, state):
            self.times.append(state.t)
            return None

    ctrl = Counter()
    Simulation(model=model, duration_s=duration, controller=ctrl, record_every=10**6).run()
    times = np.asarray(ctrl.times)
    expected = np.arange(0.0, duration + 1e-9, period)
    assert times.size == expected.size
    # each sample falls on the first step at or after k·period
    np.testing.assert_allclose(times, np.ceil(expected / dt - 1e-6) * dt, atol=1e-9)


def test_checkpoints_stream_records_to_store(tmp_path, small_truss_tree):
    """A checkpointed run streams its records to a Zarr store beside the checkpoint; the
    checkpoint holds only their count (the records before it: every 5th step of 0 … 95 at the
    last checkpoint, t = 10 s = the end, whose record follows it); the run's result reads the
    store and equals the run kept in memory bitwise."""
    cfg = _cfg(small_truss_tree, "sim.duration_s=10.0", "sim.checkpoint_every_s=2.0")
    plain = build_scenario(cfg).simulation().run()
    ckpt = tmp_path / "ckpt.npz"
    streamed = build_scenario(cfg).simulation().run(checkpoint_path=ckpt)
    header, arrays, extra = read_checkpoint(ckpt)
    assert header["n_records"] == 20 and header["records_store"] == "ckpt.records.zarr"
    assert "segments" not in header and not list(tmp_path.glob("ckpt.records*.npz"))
    assert (tmp_path / "ckpt.records.zarr").is_dir() and len(streamed.records["t"]) == 21
    assert isinstance(streamed.records, StoreRecords) and isinstance(plain.records, dict)
    assert plain.records.keys() == streamed.records.keys()
    for key in plain.records:
        assert np.array_equal(plain.records[key], streamed.records[key]), key


def test_a_structure_failure_found_by_post_processing_is_the_run_status(tmp_path, small_truss_tree, monkeypatch):
    """Inverted cells seen only by post-processing (the run's strain check saw none) make the run
    ``structure_failed`` in the summary, the manifest and the store: never a completed run with a
    failed structure inside (so no table averages it in)."""
    real = truss_metrics.structural_failure

    def inverted_from_the_third_record(pos, *args, **kwargs):
        check = real(pos, *args, **kwargs)
        failed = np.zeros(np.shape(check.failed), dtype=bool)
        failed[..., 2:] = True
        return check._replace(failed=failed, n_inverted=failed.astype(np.int64))

    monkeypatch.setattr(truss_metrics, "structural_failure", inverted_from_the_third_record)
    out = run_scenario(_cfg(small_truss_tree, "sim.duration_s=2.0", "sim.record_every=5"), tmp_path / "run")
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert out.status == summary["status"] == manifest["status"] == "structure_failed"
    assert summary["failed"] is True and summary["t_failed_s"] == pytest.approx(1.0)
    assert "t = 1.0 s" in summary["status_message"] and "inverted cells" in summary["status_message"]
    assert StoreRecords(tmp_path / "run" / STORE_NAME).attrs["status"] == "structure_failed"
