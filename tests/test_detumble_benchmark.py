"""The detumble benchmark (``magsail_mj/concepts/cnusail/configs/detumble_benchmark.toml``): a grid of
the four detumble laws crossed with a Monte Carlo of initial conditions, and its report per law.

Every law must see the same draws (sample i's values depend on the seed, i and the key only), and
the report's per-law numbers must be those of the runs' own single-run summaries: a CI-sized
example (4 conditions × 4 laws, 300 s, batched as the sweep batches it) is checked against single
runs of the same configs, figure by figure, with the report's percentile rule (the inverted CDF,
``x_k`` with ``k = ⌈p n / 100⌉``) applied by hand.
"""

from __future__ import annotations

import csv
import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pytest

import magsail_mj
from magsail_mj.config import load_config, read_toml
from magsail_mj.sweep import load_sweep, run_sweep
from magsail_mj.sweep.design import design_points
from magsail_mj.sweep.report import write_report

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "magsail_mj" / "concepts" / "cnusail" / "configs"
BENCH = CONFIGS / "detumble_benchmark.toml"
BENCH_DEPLOYED = CONFIGS / "detumble_benchmark_deployed.toml"
SHIPPED_MC = CONFIGS / "monte_carlo_detumble.toml"
LAWS = ["proportional", "bang_bang", "b_cross", "non_monotonic"]
FIGURES = ["detumble_time_below_1p0dps_s", "detumble_time_below_0p3dps_s", "mtq_dipole_effort_Am2s"]


@pytest.mark.parametrize("path", [BENCH, BENCH_DEPLOYED])
def test_every_law_sees_the_same_conditions(path):
    tree = read_toml(path)
    points = design_points(tree)
    assert len(points) == 4 * 1000
    by_law: dict[str, dict[str, dict]] = {}
    for p in points:
        law, sample = p.id.split("/")
        assert law == f"bdot_law={p.params['control.bdot_law']}"
        by_law.setdefault(p.params["control.bdot_law"], {})[sample] = {
            k: v for k, v in p.params.items() if k != "control.bdot_law"
        }
    assert list(by_law) == LAWS
    for law in LAWS[1:]:
        assert by_law[law] == by_law[LAWS[0]], law
    # the shipped 200-sample Monte Carlo's draws are the first 200 conditions (same seed and keys)
    shipped = design_points(read_toml(SHIPPED_MC))
    assert [p.params for p in shipped] == [by_law["b_cross"][f"s{i:03d}"] for i in range(200)]
    rates = np.array([np.linalg.norm(c["initial.omega0_deg_s"]) for c in by_law["proportional"].values()])
    assert 2.0 <= rates.min() and rates.max() <= 10.0
    # every point's config loads (one per law: the others differ only in the drawn values)
    for p in points[::1000]:
        cfg = load_config(path.parent / tree["config"], [*tree["set"], *p.overrides])
        assert (cfg.sim.stop_rate_deg_s, cfg.sim.stop_hold_s, cfg.sim.duration_s) == (0.3, 600.0, 17347.5)


def _kth(values: list[float], p: float) -> float:
    """The report's p % percentile of ``values`` (None as +inf): x_k, k = ⌈p n / 100⌉."""
    xs = sorted(math.inf if v is None else v for v in values)
    return xs[max(1, math.ceil(p * len(xs) / 100)) - 1]


def test_ci_benchmark_report_per_law_equals_single_runs(tmp_path):
    tree = read_toml(BENCH)
    # the shipped design at CI size: 4 conditions from 0.8–1.4 °/s (so some reach 1 °/s within 300 s),
    # stop at 1 °/s held 60 s
    mc = {k: v for k, v in tree["monte_carlo"].items() if k != "samples"}
    mc["initial.omega0_deg_s"]["magnitude"] = {"dist": "uniform", "low": 0.8, "high": 1.4}
    common = ["sim.duration_s=300", "sim.stop_rate_deg_s=1.0", "sim.stop_hold_s=60", "sim.progress=false"]
    path = tmp_path / "bench.toml"
    path.write_text(
        f'name = "bench_ci"\nconfig = "{BENCH.parent / tree["config"]}"\nset = {json.dumps(common)}\n\n'
        f"[grid]\n{json.dumps('control.bdot_law')} = {json.dumps(LAWS)}\n\n[monte_carlo]\nsamples = 4\n"
        f"seed = {mc.pop('seed')}\n"
        + "".join(f"{json.dumps(k)} = {_inline(v)}\n" for k, v in mc.items())
        + f'\n[report]\nfigures = {json.dumps(FIGURES)}\npercentiles = [10, 50, 90]\nshares = ["detumbled"]\n'
    )
    sweep = load_sweep(path)
    out = tmp_path / "out"
    records = run_sweep(sweep, out, workers=1, log=None, progress=False)
    assert all(r["status"] == "completed" for r in records)
    write_report(out)
    rows = {(r["grid_point"], r["figure"]): r for r in csv.DictReader((out / "report" / "percentiles.csv").open())}
    shares = {r["grid_point"]: r for r in csv.DictReader((out / "report" / "shares.csv").open())}
    assert sorted({g for g, _ in rows}) == sorted(f"bdot_law={law}" for law in LAWS)
    singles: dict[str, list[dict]] = {}
    for run in sweep.runs:
        sim = magsail_mj.load(run.config, list(run.overrides))
        summary = sim.scenario.postprocess(sim.run())[0]
        singles.setdefault(run.id.split("/")[0], []).append(summary)
        folder = json.loads((out / run.id / "summary.json").read_text())
        for key in (*FIGURES, "detumbled", "t_end_s", "ended_by_stop_rule"):
            assert folder[key] == summary[key], (run.id, key)
    stopped = sum(s["ended_by_stop_rule"] for group in singles.values() for s in group)
    assert 0 < stopped < 16  # the CI example has runs that end by the rule and runs that do not
    for group, summaries in singles.items():
        for figure in FIGURES:
            row, values = rows[(group, figure)], [s[figure] for s in summaries]
            reached = [v for v in values if v is not None]
            assert int(row["n"]) == 4 and int(row["reached"]) == len(reached), (group, figure)
            for p in (10, 50, 90):
                want = _kth(values, p)
                assert row[f"p{p}"] == ("never" if want == math.inf else repr(want)), (group, figure, p)
            if reached:
                assert float(row["mean_reached"]) == pytest.approx(np.mean(reached), rel=1e-15)  # summation order
        assert int(shares[group]["true"]) == sum(s["detumbled"] for s in summaries), group


def _inline(value: object) -> str:
    """A TOML inline value of JSON-like data."""
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_inline(v)}" for k, v in value.items()) + " }"
    return json.dumps(value)


def _paired_script():
    spec = importlib.util.spec_from_file_location("paired", ROOT / "scripts" / "detumble_benchmark_paired.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_paired_comparison_counts_by_hand(tmp_path):
    """The per-condition comparison of two laws: only samples completed in both are paired; a run
    that never stays below 0.3 °/s is later than any time; the mean difference is over the pairs
    where both reached it."""
    paired = _paired_script()

    def folder(point: str, runs: dict[str, tuple[str, float | None]]) -> Path:
        for sample, (status, t) in runs.items():
            run = tmp_path / point / sample
            run.mkdir(parents=True)
            (run / "manifest.json").write_text(json.dumps({"status": status}))
            summary = {"detumble_time_below_0p3dps_s": t, "detumbled": t is not None}
            (run / "summary.json").write_text(json.dumps(summary))
        return tmp_path / point

    first = folder("a", {"s000": ("completed", 100.0), "s001": ("completed", 300.0), "s002": ("completed", None),
                         "s003": ("failed", 50.0), "s004": ("completed", 80.0)})  # fmt: skip
    second = folder("b", {"s000": ("completed", 60.0), "s001": ("completed", 400.0), "s002": ("completed", 900.0),
                          "s003": ("completed", 10.0)})  # fmt: skip
    names = ("shipped", "tuned")
    rows = paired.paired_rows(paired.completed_summaries(first), paired.completed_summaries(second), names=names)
    assert [r["sample"] for r in rows] == ["s000", "s001", "s002"]
    got = paired.comparison(rows, names=names)
    assert (got["n"], got["second_sooner"], got["second_later"], got["first_never"]) == (3, 2, 1, 1)
    assert got["mean_difference_s"] == pytest.approx((-40.0 + 100.0) / 2) and got["largest_later_s"] == 100.0
    assert (got["first_median_s"], got["second_median_s"]) == (300.0, 400.0)
    out = tmp_path / "p.csv"
    assert paired.main([str(first), str(second), "--names", *names, "--out", str(out)]) == 0
    header = next(csv.reader(out.open()))
    assert header[:2] == ["sample", "shipped_detumble_time_below_1p0dps_s"] and "tuned_detumbled" in header
