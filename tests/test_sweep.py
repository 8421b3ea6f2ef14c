"""`magsail sweep`: validation before writing, parallel runs, failures isolated, valid finished runs reused."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from magsail_mj.cli import main
from magsail_mj.config import ConfigError, load_config, read_toml
from magsail_mj.sweep import load_sweep, run_sweep, sweep_exit_code

MODELS = Path(__file__).resolve().parents[1] / "magsail_mj" / "concepts" / "current_loops" / "configs"
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
config = "{MODELS / "sweep" / "b_n12_ei1e3.toml"}"

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
    seen_on_disk = []

    def log(line: str) -> None:  # when a run is logged, the summaries on disk already hold it
        if line.startswith("  "):
            on_disk = {r["id"]: r["status"] for r in json.loads((out / "sweep_summary.json").read_text())}
            finished = json.loads((out / "sweep_manifest.json").read_text())["finished"]
            seen_on_disk.append((line.split(":")[0].strip(), on_disk, finished))

    records = run_sweep(sweep, out, workers=2, log=log)
    assert len(seen_on_disk) == 3 and not any(finished for *_, finished in seen_on_disk)
    for rid, on_disk, _ in seen_on_disk:
        assert on_disk[rid] in ("completed", "failed")
    assert "not_run" in seen_on_disk[0][1].values()  # the first record was written while others still ran
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
    path = _sweep_file(
        tmp_path,
        extra='\n[[run]]\nid = "typo"\nconfig = "' + str(MODELS / "slew.toml") + '"\nset = ["control.kp=1.0"]\n',
    )
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


def _design_file(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "design.toml"
    path.write_text(f'name = "design"\nconfig = "{MODELS / "sweep" / "a_n12_ei1e3.toml"}"\nset = {SMALL}\n{body}')
    return path


def test_grid_is_the_cartesian_product_with_ids_from_the_values(tmp_path):
    sweep = load_sweep(_design_file(tmp_path, '[grid]\n"stiffness.EI_Nm2" = [1e3, 1e4]\nlattice.units = [3, 4]\n'))
    assert [r.id for r in sweep.runs] == [
        "EI_Nm2=1000,units=3",
        "EI_Nm2=1000,units=4",
        "EI_Nm2=10000,units=3",
        "EI_Nm2=10000,units=4",
    ]
    assert sweep.runs[1].params == {"stiffness.EI_Nm2": 1000.0, "lattice.units": 4}
    assert sweep.runs[1].overrides[-2:] == ("stiffness.EI_Nm2=1000.0", "lattice.units=4")
    assert len({r.config_hash for r in sweep.runs}) == 4


def test_monte_carlo_draws_are_reproducible_and_stable_in_the_sample_count(tmp_path):
    body = (
        "[monte_carlo]\nsamples = {n}\nseed = 5\n"
        '"sim.timestep_s" = {{ dist = "uniform", low = 0.05, high = 0.1 }}\n'
        '"field.constant_T" = {{ dist = "direction", magnitude = {{ dist = "log-uniform", low = 1e-5, '
        "high = 1e-4 }} }}\n"
    )
    three = load_sweep(_design_file(tmp_path, body.format(n=3)))
    twelve = load_sweep(_design_file(tmp_path, body.format(n=12)))
    assert [r.id for r in three.runs] == ["s0", "s1", "s2"] and twelve.runs[10].id == "s10"
    assert [r.params for r in three.runs] == [r.params for r in twelve.runs[:3]]
    for run in twelve.runs:
        dt, field = run.params["sim.timestep_s"], run.params["field.constant_T"]
        assert 0.05 <= dt <= 0.1 and 1e-5 <= sum(x * x for x in field) ** 0.5 <= 1e-4 * (1 + 1e-12)
    assert len({r.params["sim.timestep_s"] for r in twelve.runs}) == 12


def test_design_records_carry_their_params_into_summaries(tmp_path):
    body = '[monte_carlo]\nsamples = 2\nseed = 1\n"sim.timestep_s" = { dist = "uniform", low = 0.08, high = 0.1 }\n'
    sweep = load_sweep(_design_file(tmp_path, body))
    out = tmp_path / "out"
    records = run_sweep(sweep, out, workers=2, log=None)
    assert [r["status"] for r in records] == ["completed", "completed"]
    for rec, run in zip(records, sweep.runs):
        assert rec["params"] == run.params and rec["config_hash"] == run.config_hash and rec["attempts"] >= 1
        manifest = json.loads((out / run.id / "manifest.json").read_text())
        assert manifest["config"]["sim"]["timestep_s"] == run.params["sim.timestep_s"]
    stored = json.loads((out / "sweep_summary.json").read_text())
    keys = {"id", "status", "message", "config_hash", "params", "wall_time_s", "attempts", "resumed_from_s", "summary"}
    assert keys <= set(stored[0])
    header = (out / "sweep_summary.csv").read_text().splitlines()[0].split(",")
    assert "params.sim.timestep_s" in header and len(header) == len(set(header))


def test_grid_with_linked_keys_reproduces_the_36_listed_configs():
    grid = load_sweep(MODELS.parents[3] / "models" / "sweeps" / "current_loops_sweep36_grid.toml")
    assert (
        len(grid.runs) == 36
        and grid.runs[0].id == "circuits=A,units=12,EI_Nm2=1000,timestep_s=0.1,record_every=20,form=dense"
    )
    for run in grid.runs:
        p = run.params
        stem = f"{p['loops.circuits'][0].lower().replace('_', '')}_n{p['lattice.units']}_ei{p['stiffness.EI_Nm2']:.0e}"
        listed = load_config(MODELS / "sweep" / f"{stem.replace('e+0', 'e')}.toml").model_dump(mode="json")
        drawn = load_config(run.config, list(run.overrides)).model_dump(mode="json")
        assert {**drawn, "description": ""} == {**listed, "description": ""}, run.id


SWEEPS = MODELS.parents[3] / "models" / "sweeps"


def test_every_sweep_file_loads_and_the_msac_sweep_covers_every_msac_sweep_config():
    for path in sorted(SWEEPS.glob("*.toml")):
        assert load_sweep(path).runs, path.name
    msac = load_sweep(SWEEPS / "msac_sensitivity.toml")
    configs = sorted((MODELS.parents[1] / "msac" / "configs" / "sweeps").glob("*.toml"))
    assert sorted(r.config for r in msac.runs) == [c.resolve() for c in configs]
    assert [r.id for r in msac.runs] == [c.stem for c in configs]


def test_monte_carlo_detumble_file_is_the_issue_design():
    """200 samples; |omega0| uniform in 2-10 deg/s in a uniform direction; epoch uniform over 2016;
    K and the orbit phase as shipped; 3 orbits of T = 2 pi sqrt(a^3 / mu) each."""
    path = MODELS.parents[1] / "cnusail" / "configs" / "monte_carlo_detumble.toml"
    sweep = load_sweep(path)
    shipped = load_config(MODELS.parents[1] / "cnusail" / "configs" / "detumble_pre.toml")
    assert len(sweep.runs) == 200 and {tuple(r.params) for r in sweep.runs} == {("initial.omega0_deg_s", "orbit.epoch")}
    rates = np.array([r.params["initial.omega0_deg_s"] for r in sweep.runs])
    mags = np.linalg.norm(rates, axis=1)
    assert mags.min() >= 2.0 and mags.max() <= 10.0 * (1 + 1e-12)
    # uniform magnitude: mean 6 deg/s, std 8/sqrt(12) = 2.31; mean of 200 within 4 standard errors
    assert abs(mags.mean() - 6.0) < 4 * 2.31 / np.sqrt(200)
    # uniform direction: the mean unit vector of 200 has norm ~ sqrt(1/200) = 0.07 (bound 0.25)
    assert np.linalg.norm((rates / mags[:, None]).mean(axis=0)) < 0.25
    epochs = sorted(r.params["orbit.epoch"] for r in sweep.runs)
    assert epochs[0] >= "2016-01-01T00:00:00Z" and epochs[-1] < "2017-01-01T00:00:00Z"
    one = load_config(sweep.runs[0].config, list(sweep.runs[0].overrides))
    mu_m3_s2 = 3.986004418e14
    period_s = 2 * np.pi * np.sqrt((one.orbit.semi_major_axis_km * 1e3) ** 3 / mu_m3_s2)
    assert one.sim.duration_s == pytest.approx(3 * period_s, abs=1.0)  # 17 347.5 s, E-9 period 5 782.5 s
    assert one.control.bdot_gain_Am2s_T == shipped.control.bdot_gain_Am2s_T == 3.0e4
    assert one.orbit.true_anomaly0_deg == shipped.orbit.true_anomaly0_deg
    assert one.sim.checkpoint_every_s > 0


def test_sweep_command_exits_1_when_a_run_failed(tmp_path, capsys):
    out = tmp_path / "out"
    (out / "bad").mkdir(parents=True)
    (out / "bad" / "blocked").write_text("a file where the run folder should be")
    assert main(["sweep", str(_sweep_file(tmp_path)), "--out", str(out), "--workers", "2"]) == 1
    status = json.loads(capsys.readouterr().out)["status"]
    assert status == {"ok/a": "completed", "ok/b": "completed", "bad/blocked": "failed"}


def test_truss_orbital_sweep_lists_every_orbital_truss_config():
    """The configs the removed generator wrote (orbital detumble, slews, ablation, sensitivity) are all runs."""
    truss = MODELS.parents[1] / "truss_magnetorquer" / "configs"
    tree = read_toml(SWEEPS / "truss_orbital.toml")
    listed = {(SWEEPS / r["config"]).resolve() for r in tree["run"]}
    stems = ("detumble", "slew_i", "slew_ii", "slew_iii", "slew_iv", "gg_ablation_slew_i")
    expected = {(truss / f"{s}.toml").resolve() for s in stems} | set((truss / "sensitivity").glob("*.toml"))
    assert expected and expected <= listed
