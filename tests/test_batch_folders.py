"""Each world of a batch writes the run folder its single run writes.

Two worlds are run into folders by :func:`magsail_mj.batch.folders.run_batch_folders`, and the same
configs by :func:`magsail_mj.run.run_scenario`; the folders must hold the same files, summaries
equal in every key but the process's timing (``wall_time_s``, ``step_cost_us``), the same record
stores and derived series bit for bit, and manifests with the same config, hashes and status.
The plots are left out on both sides (the task's ``plots`` returns none): they are drawn by the
same function from the same series, and drawing them is most of a short run's cost.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import magsail_mj
from magsail_mj.batch.folders import run_batch_folders
from magsail_mj.concepts.cnusail.tasks import AttitudeTask
from magsail_mj.config import load_config
from magsail_mj.records import SERIES_GROUP, open_records
from magsail_mj.run import run_scenario
from tests.test_batch_equals_single import PRE

SHARED = ["sim.duration_s=20"]
WORLDS = [[], ["initial.omega0_deg_s=[2.0, 9.0, -4.0]", "control.bdot_gain_Am2s_T=20000.0"]]
TIMING = ("wall_time_s", "step_cost_us")


def test_world_folders_are_single_run_folders(tmp_path, monkeypatch):
    monkeypatch.setattr(AttitudeTask, "plots", lambda self, run_dir, result, series: [])
    sim = magsail_mj.load(PRE, SHARED, world_overrides=WORLDS)
    out = run_batch_folders(sim, [tmp_path / f"world{k}" for k in range(2)])
    assert [o.status for o in out] == ["completed", "completed"]
    for k, extra in enumerate(WORLDS):
        mine, ref = tmp_path / f"world{k}", tmp_path / f"single{k}"
        run_scenario(load_config(PRE, [*SHARED, *extra]), ref, progress=False)
        assert sorted(p.name for p in mine.iterdir()) == sorted(p.name for p in ref.iterdir())
        a, b = (json.loads((d / "summary.json").read_text()) for d in (mine, ref))
        assert {k_: v for k_, v in a.items() if k_ not in TIMING} == {k_: v for k_, v in b.items() if k_ not in TIMING}
        ma, mb = (json.loads((d / "manifest.json").read_text()) for d in (mine, ref))
        for key in ("config", "config_hash", "numbers_hash", "status", "steps", "t_end_s"):
            assert ma[key] == mb[key], key
        assert sorted(ma["files"]) == sorted(mb["files"])
        assert ma["files"]["model.xml"] == mb["files"]["model.xml"]
        for group in (None, SERIES_GROUP):
            ra, rb = open_records(mine, group=group), open_records(ref, group=group)
            assert sorted(ra) == sorted(rb)
            for name in rb:
                assert np.array_equal(np.asarray(ra[name]), np.asarray(rb[name])), (group, name)


def test_folders_are_checked_before_anything_runs(tmp_path):
    sim = magsail_mj.load(PRE, SHARED, world_overrides=WORLDS)
    with pytest.raises(ValueError, match="out_dirs: every world needs its own folder"):
        run_batch_folders(sim, [tmp_path / "a", tmp_path / "a"])
    with pytest.raises(ValueError, match="out_dirs: 1 folders for 2 worlds"):
        run_batch_folders(sim, [tmp_path / "a"])
    sim.step(3)
    with pytest.raises(ValueError, match="sim: run folders are written from the start of a fresh batch"):
        run_batch_folders(sim, [tmp_path / "a", tmp_path / "b"])
    assert not (tmp_path / "a").exists()
