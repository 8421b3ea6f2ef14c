"""Outputs go only where they belong: run --out, build without -o, export --out, sweep cluster
options, report forms. Every case is refused before anything runs (no simulation)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from magsail_mj import cli, export
from magsail_mj.cli import main
from magsail_mj.io import RunDirError, check_output_folder, prepare_run_dir
from magsail_mj.sweep import check_walltime, make_cluster

ROOT = Path(__file__).resolve().parents[1]
CONFIG = str(ROOT / "magsail_mj/concepts/cnusail/configs/detumble_pre.toml")


def _call(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("out", ["/", "/dev", "/proc/self", "/usr"])
def test_run_refuses_system_folders(capsys, out):
    code, _, err = _call(capsys, ["run", CONFIG, "--out", out])
    assert code == 2 and err.startswith("error: --out") and out in err and len(err.splitlines()) == 1, err


def test_run_refuses_a_folder_of_other_files_and_folders_inside_runs(tmp_path, capsys):
    project = tmp_path / "project"
    project.mkdir()
    (project / "notes.txt").write_text("mine")
    code, _, err = _call(capsys, ["run", CONFIG, "--out", str(project)])
    assert code == 2 and "--out" in err and "notes.txt" in err
    assert sorted(p.name for p in project.iterdir()) == ["notes.txt"]
    run = tmp_path / "run"
    (run / "timeseries.zarr").mkdir(parents=True)
    (run / "manifest.json").write_text("{}")
    for inside in (run / "timeseries.zarr", run / "timeseries.zarr" / "x", run / "sub"):
        code, _, err = _call(capsys, ["run", CONFIG, "--out", str(inside)])
        assert code == 2 and err.startswith(f"error: --out {inside}"), err
        assert "record store" in err or "run folder" in err
    assert not (run / "sub").exists() and not (run / "timeseries.zarr" / "x").exists()


def test_prepare_run_dir_accepts_new_empty_and_run_folders(tmp_path):
    assert prepare_run_dir(tmp_path / "new").is_dir()
    (tmp_path / "half").mkdir()
    (tmp_path / "half" / "model.xml").write_text("<mujoco/>")  # a run killed before its checkpoint
    (tmp_path / "half" / ".model.xml.tmp").write_text("")
    assert prepare_run_dir(tmp_path / "half") == tmp_path / "half"
    check_output_folder(tmp_path / "sweep" / "a" / "b")  # below an ordinary folder
    with pytest.raises(RunDirError, match="--out"):
        check_output_folder("/")


def test_build_without_output_keeps_the_model_beside_the_config(tmp_path, capsys):
    config = tmp_path / "c.toml"
    config.write_text(Path(CONFIG).read_text())
    committed = tmp_path / "c.xml"
    committed.write_text("<mujoco/>\n")
    code, _, err = _call(capsys, ["build", str(config), "--set", "sim.duration_s=5"])
    assert code == 2 and err.startswith("error: --output: required with --set"), err
    assert committed.read_text() == "<mujoco/>\n"


def test_report_sweep_dir_with_figure_is_the_sweep_report(tmp_path):
    sweep_dir = str(tmp_path)
    for argv, action in [
        (["report", sweep_dir, "--figure", "KEY"], "sweep"),
        (["report", sweep_dir, "--figure=KEY", "--figure", "K2"], "sweep"),
        (["-v", "report", sweep_dir], "sweep"),
        (["report", sweep_dir, "--bundle", "b"], "update"),
        (["report", sweep_dir, str(tmp_path / "other")], "update"),
    ]:
        i = argv.index("report")
        assert cli._report_argv(argv)[i + 1] == action, argv


def test_report_help_forms_are_accepted(tmp_path, capsys):
    """``magsail report SWEEP_DIR --figure KEY`` as the help prints it reaches the sweep report."""
    code, _, err = _call(capsys, ["report", str(tmp_path), "--figure", "settling_time_s"])
    assert code == 2 and err.startswith("error: SWEEP_DIR") and "sweep_summary.json" in err, err


def _fake_run(folder: Path) -> Path:
    (folder / "timeseries.zarr").mkdir(parents=True)
    (folder / "manifest.json").write_text('{"status": "completed", "files": {}}')
    return folder


@pytest.mark.parametrize("name", ["manifest.json", "summary.json", "model.xml", "timeseries.zarr/x.npz"])
def test_export_refuses_the_run_folders_own_files(tmp_path, name):
    run = _fake_run(tmp_path / "run")
    with pytest.raises(export.ExportError, match="^--out"):
        export.export_run(run, out=run / name)
    assert (run / "manifest.json").read_text() == '{"status": "completed", "files": {}}'


def test_export_format_and_extension_must_agree(tmp_path):
    run = _fake_run(tmp_path / "run")
    with pytest.raises(export.ExportError, match=r"^--out: .*x\.npz.* --format netcdf"):
        export.export_run(run, fmt="netcdf", out=tmp_path / "x.npz")
    with pytest.raises(export.ExportError, match=r"^--out: .*x\.nc.* --format npz"):
        export.export_run(run, fmt="npz", out=tmp_path / "x.nc")
    assert export._format(None, tmp_path / "x.nc") == "netcdf"
    assert export._format(None, tmp_path / "x.npz") == "npz"
    assert export._format(None, None) == "npz"


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_export_to_a_read_only_folder_names_the_option(tmp_path):
    run = _fake_run(tmp_path / "run")
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        with pytest.raises(export.ExportError, match=r"^--out: folder .*locked.* not writable"):
            export.export_run(run, out=locked / "x.npz")
    finally:
        locked.chmod(0o700)


def test_export_write_error_names_the_option(tmp_path, monkeypatch):
    run = _fake_run(tmp_path / "run")
    monkeypatch.setattr(export, "lazy_arrays", lambda folder: {})

    def denied(path, arrays):
        raise PermissionError(13, "Permission denied", str(tmp_path / ".x.npz.abc123.npz"))

    monkeypatch.setattr(export, "write_npz_streamed", denied)
    with pytest.raises(export.ExportError, match=r"^--out: cannot write") as err:
        export.export_run(run, out=tmp_path / "x.npz")
    assert "abc123" not in str(err.value)


@pytest.mark.parametrize("bad", ["25:99:00", "01:60:00", "01:00:60", "1-24:00:00", "1h", ""])
def test_walltime_minutes_and_seconds_below_60(bad):
    with pytest.raises(ValueError, match="^--walltime"):
        check_walltime(bad)
    assert check_walltime("25:59:59") == "25:59:59" and check_walltime("2-23:00:00") == "2-23:00:00"


def test_cluster_without_the_submit_command_fails_at_once(monkeypatch):
    pytest.importorskip("dask_jobqueue")
    monkeypatch.setenv("PATH", "/nonexistent")
    for kind, command in (("slurm", "sbatch"), ("pbs", "qsub")):
        with pytest.raises(ValueError, match=f"^--cluster {kind}: .*'{command}' is not on PATH"):
            make_cluster(kind)


def test_sweep_cli_refuses_walltime_before_loading(tmp_path, capsys):
    sweep = tmp_path / "s.toml"
    sweep.write_text('name = "s"\n')  # never read: the option is refused first
    code, _, err = _call(capsys, ["sweep", str(sweep), "--cluster", "slurm", "--walltime", "25:99:00"])
    assert code == 2 and err.startswith("error: --walltime") and "25:99:00" in err, err


def test_unreachable_scheduler_leaves_nothing_behind(tmp_path, capsys, monkeypatch):
    import magsail_mj.sweep as sweep_mod

    class Unreachable:
        def __init__(self, *args, **kwargs):
            raise OSError("Timed out trying to connect")

    monkeypatch.setattr(sweep_mod, "Client", Unreachable)
    cfg = ROOT / "magsail_mj/concepts/current_loops/configs/sweep/a_n12_ei1e3.toml"
    sweep = tmp_path / "s.toml"
    sweep.write_text(f'name = "s"\n[[run]]\nid = "a"\nconfig = "{cfg}"\n')
    out = tmp_path / "new" / "out"
    code, _, err = _call(capsys, ["sweep", str(sweep), "--out", str(out), "--scheduler", "tcp://127.0.0.1:9"])
    assert code == 2 and err.startswith("error: --scheduler"), err
    assert not (tmp_path / "new").exists()
    kept = tmp_path / "kept"
    kept.mkdir()
    code, _, _ = _call(capsys, ["sweep", str(sweep), "--out", str(kept), "--scheduler", "tcp://127.0.0.1:9"])
    assert code == 2 and kept.is_dir() and list(kept.iterdir()) == []


def test_only_matching_nothing_keeps_the_runs_problems(tmp_path):
    from magsail_mj.config import ConfigError
    from magsail_mj.sweep import load_sweep

    cfg = ROOT / "magsail_mj/concepts/current_loops/configs/sweep/a_n12_ei1e3.toml"
    sweep = tmp_path / "s.toml"
    sweep.write_text(f'name = "s"\n[[run]]\nid = "a"\nconfig = "{cfg}"\nset = ["sim.duration_s=-1"]\n')
    with pytest.raises(ConfigError) as err:
        load_sweep(sweep, only="zzz")
    text = str(err.value)
    assert "only: no run id contains" in text and "sim.duration_s" in text, text
    json.dumps(text)
