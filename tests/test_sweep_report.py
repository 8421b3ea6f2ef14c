"""Sweep reports (``magsail_mj.sweep.report``): Monte Carlo percentiles and CDFs with failed and
never-reached runs counted, grid tables and plots, on tiny real sweeps; progress bar; record keys."""

from __future__ import annotations

import argparse
import csv
import io
import json
import math
from pathlib import Path

import numpy as np
import pytest

from magsail_mj.cli import main as cli_main
from magsail_mj.sweep import RECORD_KEYS, load_sweep, run_sweep
from magsail_mj.sweep.progress import SweepProgress
from magsail_mj.sweep.report import ReportError, add_arguments, figure_stats, main, write_report

ROOT = Path(__file__).resolve().parents[1]
CNUSAIL = ROOT / "magsail_mj" / "concepts" / "cnusail" / "configs" / "detumble_pre.toml"
LOOPS = ROOT / "magsail_mj" / "concepts" / "current_loops" / "configs" / "sweep" / "a_n12_ei1e3.toml"


def _rec(i: int, status: str, value: float | None) -> dict:
    return {"id": f"s{i:03d}", "status": status, "params": {}, "summary": {"t_s": value}}


def test_figure_stats_counts_failed_and_never_runs_and_uses_the_inverted_cdf():
    # 16 runs reach 1..16, 1 completed run never does, 3 failed (one status failed, one studied
    # structure failure, one completed run whose summary says its structure failed): n = 20
    records = [_rec(i, "completed", float(i + 1)) for i in range(16)]
    crushed = _rec(16, "completed", 0.5)
    crushed["summary"]["failed"] = True  # its 0.5 must not enter the percentiles
    records += [crushed, _rec(17, "completed", None), _rec(18, "structure_failed", 0.1), _rec(19, "failed", 3.0)]
    records += [_rec(20, "not_run", None), _rec(21, "interrupted", 2.0)]  # the sweep stopped first: left out
    s = figure_stats(records, "t_s")
    assert (s["n"], s["reached"], s["never"], s["failed"], s["not_run"]) == (20, 16, 1, 3, 2)
    assert s["share_reached"] == pytest.approx(16 / 20, abs=0)
    # k = ceil(p n / 100): p5 -> x_1 = 1, p50 -> x_10 = 10, p95 -> x_19 = +inf (never or failed)
    assert s["percentiles"] == {"p5": 1.0, "p50": 10.0, "p95": None}
    assert (s["min"], s["max"]) == (1.0, 16.0)


def _mc_sweep(tmp_path: Path) -> Path:
    # |omega0| uniform in 0.5-1.5 deg/s over 20 s: the runs starting below 1 deg/s reach 1 deg/s at once,
    # most others never within the run
    path = tmp_path / "mc.toml"
    path.write_text(f'''name = "mc"
config = "{CNUSAIL}"
set = ["sim.duration_s=20.0", "sim.progress=false"]

[monte_carlo]
samples = 4
seed = 3
"initial.omega0_deg_s" = {{ dist = "direction", magnitude = {{ dist = "uniform", low = 0.5, high = 1.5 }} }}

[report]
figures = ["detumble_time_below_1p0dps_s", "detumble_time_below_0p3dps_s"]
''')
    return path


def test_monte_carlo_report_of_a_real_sweep(tmp_path):
    out = tmp_path / "out"
    records = run_sweep(load_sweep(_mc_sweep(tmp_path)), out, workers=2, log=None, progress=False)
    on_disk = json.loads((out / "sweep_summary.json").read_text())
    assert [list(r) for r in on_disk] == [list(RECORD_KEYS)] * 4
    for rec in on_disk:  # the drawn values: in the record, the run's params.json and the CSV
        assert len(rec["params"]["initial.omega0_deg_s"]) == 3
        assert json.loads((out / rec["id"] / "params.json").read_text())["params"] == rec["params"]
    table = list(csv.DictReader(io.StringIO((out / "sweep_summary.csv").read_text())))
    assert [json.loads(r["params.initial.omega0_deg_s"]) for r in table] == [
        r["params"]["initial.omega0_deg_s"] for r in on_disk
    ]
    assert all(
        r["detumble_time_below_1p0dps_s"] == str(s["summary"]["detumble_time_below_1p0dps_s"])
        or (r["detumble_time_below_1p0dps_s"] == "" and s["summary"]["detumble_time_below_1p0dps_s"] is None)
        for r, s in zip(table, on_disk, strict=True)
    )
    paths = write_report(out)
    assert {p.name for p in paths} == {
        "percentiles.csv",
        "report.md",
        "detumble_time_below_1p0dps_s.png",
        "detumble_time_below_0p3dps_s.png",
    }
    assert all(p.stat().st_size > 0 for p in paths)
    rows = {r["figure"]: r for r in csv.DictReader(io.StringIO((out / "report" / "percentiles.csv").read_text()))}
    for figure in ("detumble_time_below_1p0dps_s", "detumble_time_below_0p3dps_s"):
        # an independent computation: numpy's inverted-CDF percentiles over every run, never as +inf
        values = [
            math.inf if r["status"] != "completed" or r["summary"][figure] is None else r["summary"][figure]
            for r in records
        ]
        row = rows[figure]
        assert int(row["n"]) == 4 and int(row["reached"]) == sum(map(math.isfinite, values))
        assert int(row["never"]) + int(row["failed"]) == 4 - int(row["reached"])
        for p in (5, 50, 95):
            expect = float(np.percentile(values, p, method="inverted_cdf"))
            got = row[f"p{p}"]
            assert (got == "never") if math.isinf(expect) else float(got) == pytest.approx(expect, rel=1e-12)
    # the mix the draw gives: some runs start below 1 deg/s (reached at t = 0), none gets below 0.3 in 20 s
    reached_1 = int(rows["detumble_time_below_1p0dps_s"]["reached"])
    assert 0 < reached_1 < 4 and int(rows["detumble_time_below_0p3dps_s"]["never"]) == 4
    assert (
        "| `detumble_time_below_0p3dps_s` | 4 | 0 | 4 | 0 | 0 | 0.0 % | never | never | never |"
        in (out / "report" / "report.md").read_text()
    )


def test_grid_report_of_a_real_sweep_and_the_report_verb(tmp_path, capsys):
    path = tmp_path / "grid.toml"
    path.write_text(f'''name = "g"
config = "{LOOPS}"
set = ["lattice.units=3", "sim.duration_s=2.0", "sim.record_every=10", "sim.progress=false"]

[grid]
"stiffness.EI_Nm2" = [1e3, 1e4]
"sim.timestep_s" = [0.01, 0.02]
''')
    out = tmp_path / "out"
    records = run_sweep(load_sweep(path), out, workers=2, log=None, progress=True)
    assert [r["status"] for r in records] == ["completed"] * 4
    bar = capsys.readouterr().err  # the sweep-level bar, asked for although stderr is no terminal here
    assert "4/4" in bar and "failed 0" in bar and "dashboard " in bar
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    assert main(parser.parse_args([str(out)])) == 0
    names = {Path(p).name for p in json.loads(capsys.readouterr().out)["report"]}
    assert {"report.csv", "report.md"} <= names
    for key in ("stiffness.EI_Nm2", "sim.timestep_s"):  # one plot per key, or _1, _2, … beyond 12 figures
        assert {f"{key}.png", f"{key}_1.png"} & names, (key, sorted(names))
    table = list(csv.DictReader(io.StringIO((out / "report" / "report.csv").read_text())))
    assert [(float(r["stiffness.EI_Nm2"]), float(r["sim.timestep_s"])) for r in table] == [
        (1e3, 0.01),
        (1e3, 0.02),
        (1e4, 0.01),
        (1e4, 0.02),
    ]
    figures = [c for c in table[0] if c not in ("id", "status", "stiffness.EI_Nm2", "sim.timestep_s")]
    assert figures  # every figure that varies across the runs, with the run's own value
    for row, rec in zip(table, records, strict=True):
        for f in figures:
            assert float(row[f]) == pytest.approx(rec["summary"][f], rel=1e-5)
    # a bad folder or figure: exit 2 with the argument named
    assert main(parser.parse_args([str(tmp_path)])) == 2
    assert "SWEEP_DIR" in capsys.readouterr().err
    with pytest.raises(ReportError, match="figures"):
        write_report(out, figures=["no_such_key"])


def test_progress_bar_counts_runs_and_is_off_unless_asked():
    stream = io.StringIO()
    bar = SweepProgress(total=3, enabled=True, stream=stream)
    bar.set_dashboard("http://127.0.0.1:8787/status")
    bar.set_running(2)
    for status in ("completed", "diverged", "structure_failed"):
        bar.finished(status)
    bar.close()
    text = stream.getvalue()
    assert "3/3" in text and "failed 1" in text and "http://127.0.0.1:8787/status" in text
    assert "running 2" in text
    quiet = io.StringIO()  # not a terminal: no bar by default; --no-progress: never
    for enabled in (None, False):
        p = SweepProgress(total=3, enabled=enabled, stream=quiet)
        p.finished("completed")
        p.close()
        assert not p.enabled
    assert quiet.getvalue() == ""


def test_sweep_command_writes_its_report_with_report_option(tmp_path, capsys):
    """``magsail sweep … --report --no-progress``: the runs, then the report listed in the printed JSON;
    no progress bar on stderr."""
    out = tmp_path / "out"
    rc = cli_main(["sweep", str(_mc_sweep(tmp_path)), "--out", str(out), "--workers", "2", "--report", "--no-progress"])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    printed = json.loads(captured.out)
    assert set(printed["status"].values()) == {"completed"}
    names = {Path(p).name for p in printed["report"]}
    assert "report.md" in names and all(Path(p).is_file() for p in printed["report"])
    assert any(name.startswith("detumble_time_below_1p0dps_s") for name in names)  # its figures
    assert "dashboard" not in captured.err
