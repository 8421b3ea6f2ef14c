"""The report of a grid crossed with a Monte Carlo (e.g. the detumble benchmark's laws × initial
conditions): the Monte Carlo statistics per grid point (percentiles by the inverted CDF, ``x_k``
with ``k = ⌈p n / 100⌉``, failed and never-reached runs as +inf; the mean over the reached values;
the shares of a true/false summary key), checked against values worked out by hand, and the
``[report]`` options refused by name.
"""

from __future__ import annotations

import csv
import json

import pytest

from magsail_mj.config import ConfigError
from magsail_mj.sweep import load_sweep
from magsail_mj.sweep.report import write_report


def _records(law_values: dict[str, list]) -> list[dict]:
    """Sweep records of a grid × Monte Carlo: per law, one run per value (None: never reached,
    "failed": a failed run)."""
    out = []
    for law, values in law_values.items():
        for i, v in enumerate(values):
            failed = v == "failed"
            summary = {} if failed else {"t_s": v, "detumbled": v is not None}
            out.append(
                {"id": f"bdot_law={law}/s{i}", "status": "failed" if failed else "completed", "summary": summary}
            )
    return out


def _write_sweep(folder, records: list[dict], *, samples: int) -> None:
    """A finished laws × Monte Carlo sweep folder holding ``records``, reporting ``t_s`` and
    ``detumbled``."""
    (folder / "sweep_summary.json").write_text(json.dumps(records))
    sweep = folder / "s.toml"
    sweep.write_text(
        f'name = "g"\nconfig = "x.toml"\n[grid]\n"control.bdot_law" = ["a", "b"]\n[monte_carlo]\nsamples = {samples}\n'
        'seed = 1\n"x" = { dist = "uniform", low = 0, high = 1 }\n'
        '[report]\nfigures = ["t_s"]\npercentiles = [10, 50, 90]\nshares = ["detumbled"]\n'
    )
    (folder / "sweep_manifest.json").write_text(json.dumps({"sweep": str(sweep), "name": "g"}))


def test_grouped_report_by_hand(tmp_path):
    records = _records({"a": [30.0, 10.0, None, 20.0, 40.0], "b": [5.0, "failed", 1.0, 3.0, 2.0]})
    _write_sweep(tmp_path, records, samples=5)
    write_report(tmp_path)
    rows = list(csv.DictReader((tmp_path / "report" / "percentiles.csv").open()))
    # a: sorted 10, 20, 30, 40, inf (n = 5): p10 → k = 1, p50 → k = 3, p90 → k = 5 (never); mean of reached 25
    assert rows[0] == {
        "grid_point": "bdot_law=a",
        "figure": "t_s",
        "n": "5",
        "reached": "4",
        "never": "1",
        "failed": "0",
        "not_run": "0",
        "share_reached": "0.8",
        "p10": "10.0",
        "p50": "30.0",
        "p90": "never",
        "mean_reached": "25.0",
        "min": "10.0",
        "max": "40.0",
    }
    # b: 1, 2, 3, 5, inf (failed): p10 = 1, p50 = 3, p90 = never; mean 2.75
    assert [rows[1][k] for k in ("failed", "never", "p10", "p50", "p90", "mean_reached")] == [
        "1",
        "0",
        "1.0",
        "3.0",
        "never",
        "2.75",
    ]
    shares = list(csv.DictReader((tmp_path / "report" / "shares.csv").open()))
    assert [(r["grid_point"], r["true"], r["false"], r["failed"], r["share_true"]) for r in shares] == [
        ("bdot_law=a", "4", "1", "0", "0.8"),
        ("bdot_law=b", "4", "0", "1", "0.8"),
    ]
    md = (tmp_path / "report" / "report.md").read_text()
    assert "| bdot_law=a | 5 | 4 | 1 | 0 | 80.0 % | 10 | 30 | never | 25 |" in md
    assert (tmp_path / "report" / "t_s_cdf.png").stat().st_size > 0


def test_report_table_refuses_bad_options(tmp_path):
    base = 'name = "g"\nconfig = "x.toml"\n[[run]]\nid = "a"\nconfig = "x.toml"\n'
    for bad in ("percentiles = [0]", "percentiles = [101]", "percentiles = []", 'shares = "detumbled"', "other = 1"):
        path = tmp_path / "bad.toml"
        path.write_text(base + f"[report]\n{bad}\n")
        with pytest.raises(ConfigError, match="report: must be a table"):
            load_sweep(path)


def test_a_grid_point_not_run_reads_as_no_runs_not_as_never(tmp_path):
    """A grid point all of whose runs the sweep did not run (n = 0) has no percentile, share or
    mean: its cells read "—" (the CSV leaves them empty), never "never" or "0.0 %"."""
    records = _records({"a": [30.0, 10.0, 20.0]})
    records += [{"id": f"bdot_law=b/s{i}", "status": "not_run", "summary": {}} for i in range(3)]
    _write_sweep(tmp_path, records, samples=3)
    write_report(tmp_path)
    md = (tmp_path / "report" / "report.md").read_text()
    assert "| bdot_law=b | 0 | 0 | 0 | 0 | — | — | — | — | — |" in md
    assert "| bdot_law=b | 0 | 0 | 0 | 0 | — | — |" in md.split("## `detumbled`")[1]
    assert "| bdot_law=a | 3 | 3 | 0 | 0 | 100.0 % | 10 | 20 | 30 | 20 |" in md
    rows = list(csv.DictReader((tmp_path / "report" / "percentiles.csv").open()))
    b = rows[1]
    assert (b["grid_point"], b["n"], b["not_run"], b["p10"], b["p50"], b["p90"]) == ("bdot_law=b", "0", "3", "", "", "")
