"""``magsail_mj.load`` and the stepping interface: reset, step, get_state/set_state, run."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import magsail_mj
from magsail_mj.cli import main
from magsail_mj.config import ConfigError, load_config
from magsail_mj.export import read_timeseries
from magsail_mj.sim import Simulation
from tests.conftest import REPO

MODELS = REPO / "magsail_mj" / "concepts"
SMALL = ["lattice.units=3"]
# one Python-stepped scenario of every concept that has one
STEPPED = [
    ("cnusail/configs/nadir_pre.toml", ["sim.duration_s=30"]),
    ("current_loops/configs/slew.toml", ["sim.duration_s=8", *SMALL]),
    ("reflector/configs/tracking_10g.toml", ["sim.duration_s=60"]),
    ("truss_magnetorquer/configs/slew_i.toml", ["sim.duration_s=8", *SMALL]),
]


def _records_equal(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)


@pytest.mark.parametrize("name,overrides", STEPPED, ids=[s[0] for s in STEPPED])
def test_set_state_then_step_repeats_the_steps_bitwise(name, overrides):
    sim = magsail_mj.load(MODELS / name, overrides)
    assert isinstance(sim, Simulation) and sim.time == 0.0
    sim.step(23)
    state = sim.get_state()
    assert set(state) == {"step", "n_ctrl", "mj_state", "n_records", "python_tree", "python_arrays"}
    assert all(isinstance(v, np.ndarray) for v in state["python_arrays"].values())
    json.dumps(state["python_tree"])  # plain data
    sim.step(31)
    qpos, records = sim.data.qpos.copy(), sim.records()
    sim.set_state(state)
    assert sim.time == pytest.approx(23 * sim.model.opt.timestep)
    sim.step(31)
    assert np.array_equal(sim.data.qpos, qpos)
    assert _records_equal(sim.records(), records)


@pytest.mark.parametrize("name,overrides", STEPPED[:2], ids=[s[0] for s in STEPPED[:2]])
def test_reset_then_run_equals_a_fresh_run(name, overrides):
    sim = magsail_mj.load(MODELS / name, overrides)
    sim.step(40)
    sim.reset()
    assert sim.time == 0.0 and sim.records()["t"].size == 0
    again = sim.run()
    fresh = magsail_mj.load(MODELS / name, overrides).run()
    assert again.status == fresh.status == "completed"
    assert _records_equal(again.records, fresh.records)


@settings(max_examples=8, deadline=None)
@given(chunks=st.lists(st.integers(1, 60), min_size=1, max_size=6))
def test_stepping_in_any_chunks_equals_one_run(chunks):
    name, overrides = STEPPED[0][0], ["sim.duration_s=12"]
    whole = magsail_mj.load(MODELS / name, overrides).run()
    sim = magsail_mj.load(MODELS / name, overrides)
    for n in chunks:
        sim.step(n)
    rest = sim.run()
    assert rest.status == "completed"
    assert _records_equal(rest.records, whole.records)


def test_step_past_the_end_stops_at_the_duration():
    sim = magsail_mj.load(MODELS / "cnusail/configs/detumble_pre.toml", ["sim.duration_s=2"])
    assert sim.step(5) == "running"
    assert sim.step(10**6) == "completed" and sim.time == pytest.approx(2.0)
    assert sim.step(1) == "completed"
    with pytest.raises(ValueError, match="n: must be an integer >= 1"):
        sim.step(0)


def test_load_takes_a_path_or_a_config_with_overrides():
    cfg = load_config(MODELS / "cnusail/configs/detumble_pre.toml")
    sim = magsail_mj.load(cfg, ["sim.duration_s=3"])
    assert sim.duration_s == 3.0 and sim.cfg.sim.duration_s == 3.0 and sim.scenario.cfg is sim.cfg
    assert len(sim.identity["numbers_hash"]) == 64
    with pytest.raises(ConfigError, match="sim.duration_s"):
        magsail_mj.load(MODELS / "cnusail/configs/detumble_pre.toml", ["sim.duration_s=nan"])


def test_cli_stop_after_then_resume_equals_uninterrupted(tmp_path, capsys):
    config = str(MODELS / "truss_magnetorquer/configs/slew_i.toml")
    common = ["--set", "lattice.units=3", "--set", "sim.duration_s=6", "--no-progress"]
    assert main(["run", config, "--out", str(tmp_path / "full"), *common]) == 0
    assert main(["run", config, "--out", str(tmp_path / "cut"), *common, "--stop-after-s", "2.5"]) == 0
    stopped = json.loads((tmp_path / "cut/manifest.json").read_text())
    assert stopped["status"] == "stopped" and (tmp_path / "cut/checkpoint.npz").is_file()
    assert main(["run", config, "--out", str(tmp_path / "cut"), *common, "--resume"]) == 0
    a, b = read_timeseries(tmp_path / "full"), read_timeseries(tmp_path / "cut")
    assert sorted(a) == sorted(b) and all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)
    assert main(["run", config, "--out", str(tmp_path / "x"), *common, "--stop-after-s", "60"]) == 2
    assert "--stop-after-s" in capsys.readouterr().err


def test_native_msac_runner_has_the_same_interface():
    """The natively rolled-out MSAC cycle: step in any chunks, get/set state, reset — bitwise."""
    overrides = ["sim.duration_s=0.006", "sim.record_every=20"]
    whole = magsail_mj.load(MODELS / "msac/configs/paper_1khz.toml", overrides).run()
    sim = magsail_mj.load(MODELS / "msac/configs/paper_1khz.toml", overrides)
    assert sim.time == 0.0 and sim.step(137) == "running"
    state = sim.get_state()
    sim.step(311)
    ahead = sim.get_state()["mj_state"]
    sim.set_state(state)
    sim.step(311)
    assert np.array_equal(sim.get_state()["mj_state"], ahead)
    rest = sim.run()
    assert rest.status == whole.status == "completed"
    assert _records_equal(rest.records, whole.records)
    sim.reset()
    assert sim.time == 0.0 and _records_equal(sim.run().records, whole.records)


def test_msac_stop_anywhere_then_resume_equals_uninterrupted(tmp_path):
    """A stop between chunk boundaries no longer moves the momentum projection: bitwise resume."""
    from magsail_mj.run import run_scenario

    cfg = load_config(MODELS / "msac/configs/paper_1khz.toml", ["sim.duration_s=0.01", "sim.progress=false"])
    run_scenario(cfg, tmp_path / "full")
    run_scenario(cfg, tmp_path / "cut", stop_after_s=0.0037)
    run_scenario(cfg, tmp_path / "cut", resume=True)
    a, b = read_timeseries(tmp_path / "full"), read_timeseries(tmp_path / "cut")
    assert all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)
