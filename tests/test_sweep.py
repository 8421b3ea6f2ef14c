"""`magsail sweep`: validation before writing, parallel runs, failures isolated, finished runs skipped."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from magsail_mj.cli import main
from magsail_mj.config import ConfigError
from magsail_mj.sweep import load_sweep, run_sweep

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
id = "bad/beyond_fold"
config = "{cfg}"
set = ["lattice.side_m=5000.0"]
{extra}"""
    path = tmp_path / "tiny.toml"
    path.write_text(text)
    return path


def test_sweep_runs_in_parallel_and_isolates_a_failure(tmp_path):
    sweep = load_sweep(_sweep_file(tmp_path))
    out = tmp_path / "out"
    records = run_sweep(sweep, out, workers=2, log=None)
    status = {r["id"]: r["status"] for r in records}
    # geometry A beyond its fold has no Eq.-9 current: that run fails, the others complete
    assert status == {"ok/a": "completed", "ok/b": "completed", "bad/beyond_fold": "failed"}
    assert "side_m" in next(r for r in records if r["id"] == "bad/beyond_fold")["message"]
    for rid in ("ok/a", "ok/b"):
        assert (out / rid / "summary.json").exists() and (out / rid / "manifest.json").exists()
    table = (out / "sweep_summary.csv").read_text().splitlines()
    assert table[0].startswith("id,status,wall_time_s") and len(table) == 4
    manifest = json.loads((out / "sweep_manifest.json").read_text())
    assert manifest["workers"] == 2 and manifest["runs"]["bad/beyond_fold"] == "failed"
    # a second call skips what finished and retries the failure only
    again = run_sweep(sweep, out, workers=1, log=None)
    assert {r["id"]: r["status"] for r in again}["ok/a"] == "skipped"


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
