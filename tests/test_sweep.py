"""`magsail sweep`: validation before writing, parallel runs, failures isolated, valid finished runs reused."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from magsail_mj.cli import main
from magsail_mj.config import ConfigError
from magsail_mj.sweep import load_sweep, run_sweep, sweep_exit_code

MODELS = Path(__file__).resolve().parents[1] / "models" / "current_loops"
SMALL = '["lattice.units=3", "sim.duration_s=4.0", "sim.record_every=10", "sim.progress=false"]'


def _sweep_file(tmp_path: Path, extra: str = "") -> Path:
    cfg = MODELS / "sweep" / "a_n12_ei1e3.toml"
    text = f"""
name = "tiny"
set = {SMALL}

[[run]]
id = "ok/a"
config = "{cfg}"

[[run]]
id = "ok/b"
config = "{MODELS / 'sweep' / 'b_n12_ei1e3.toml'}"

[[run]]
id = "bad/blocked"
config = "{cfg}"
{extra}"""
    path = tmp_path / "tiny.toml"
    path.write_text(text)
    return path


def test_sweep_runs_in_parallel_and_isolates_a_failure(tmp_path):
    sweep = load_sweep(_sweep_file(tmp_path))
    out = tmp_path / "out"
    (out / "bad").mkdir(parents=True)
    (out / "bad" / "blocked").write_text("a file where the run folder should be")
    records = run_sweep(sweep, out, workers=2, log=None)
    status = {r["id"]: r["status"] for r in records}
    # the run whose folder cannot be made fails (its message says why), the others complete
    assert status == {"ok/a": "completed", "ok/b": "completed", "bad/blocked": "failed"}
    assert "bad/blocked" in next(r for r in records if r["id"] == "bad/blocked")["message"]
    for rid in ("ok/a", "ok/b"):
        assert (out / rid / "summary.json").exists() and (out / rid / "manifest.json").exists()
    table = (out / "sweep_summary.csv").read_text().splitlines()
    header = table[0].split(",")
    assert header[:5] == ["id", "status", "reused", "wall_time_s", "message"] and len(table) == 4
    assert len(header) == len(set(header))  # each column once
    manifest = json.loads((out / "sweep_manifest.json").read_text())
    assert manifest["workers"] == 2 and manifest["runs"]["bad/blocked"] == "failed"
    assert manifest["worker_thread_env"]["OPENBLAS_NUM_THREADS"] and manifest["interrupted"] is False
    assert sweep_exit_code(records) == 1
    # a second call reuses what finished (same config hash, files intact) and retries the failure only
    again = run_sweep(sweep, out, workers=1, log=None)
    reused = {r["id"]: r["reused"] for r in again}
    assert reused == {"ok/a": True, "ok/b": True, "bad/blocked": False}
    assert {r["id"]: r["status"] for r in again}["ok/a"] == "completed"


def test_sweep_validates_every_config_before_writing(tmp_path):
    path = _sweep_file(tmp_path, extra='\n[[run]]\nid = "typo"\nconfig = "' + str(MODELS / "slew.toml")
                       + '"\nset = ["control.kp=1.0"]\n')
    with pytest.raises(ConfigError, match="typo: control.kp"):
        load_sweep(path)
    assert not (tmp_path / "out").exists()


def test_sweep_cli_errors(tmp_path, capsys):
    assert main(["sweep", str(_sweep_file(tmp_path)), "--workers", "0"]) == 2
    assert "--workers" in capsys.readouterr().err
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n')
    assert main(["sweep", str(bad)]) == 2
    assert "run: must be a non-empty array" in capsys.readouterr().err
