"""The detumble tuning objective (:mod:`magsail_mj.control.tuning`) and its CMA-ES example.

The objective must read each world's figures as the world's single run reports them (its
``summary.json``), must rank a law that clearly does not detumble (the non-monotonic law's tanh
gain 100 times below the shipped one: its dipole about 13 times weaker at the start's momentum) worse
than the shipped law on the same worlds, and must draw its training conditions with the sweep's
own sampler, independent of the benchmark's held-out draws. The example runs at CI size.
"""

from __future__ import annotations

import json
import math

import numpy as np

import magsail_mj
from magsail_mj.config import read_toml
from magsail_mj.control.tuning import FIGURE_KEYS, DetumbleObjective, draw_conditions, world_score_s
from magsail_mj.sweep.design import design_points
from tests.conftest import REPO, load_file_module

BENCH = REPO / "magsail_mj" / "concepts" / "cnusail" / "configs" / "detumble_benchmark.toml"
CONFIG = BENCH.parent / "detumble_pre.toml"
# a short batch: 900 s, stop at 0.3 °/s held 60 s, compiled loads, the non-monotonic law as shipped
SHORT = [
    "sim.duration_s=900",
    "sim.stop_rate_deg_s=0.3",
    "sim.stop_hold_s=60",
    "sim.progress=false",
    'sim.loads="compiled"',
    'control.bdot_law="non_monotonic"',
]
# two slow starts (0.7 °/s; the shipped law detumbles the second within 900 s), two training draws (2–10 °/s)
WORLDS = [
    ["initial.omega0_deg_s=[0.5, -0.4, 0.3]", 'orbit.epoch="2016-03-01T00:00:00Z"'],
    ["initial.omega0_deg_s=[-0.3, 0.6, 0.2]", 'orbit.epoch="2016-08-15T06:00:00Z"'],
    *draw_conditions(BENCH, samples=2, seed=2017),
]
NONMON = ["control.nonmonotonic_gain_per_Nms", "control.nonmonotonic_alpha", "control.nonmonotonic_lookahead_s"]


def _objective(**kw) -> DetumbleObjective:
    return DetumbleObjective(config=CONFIG, overrides=SHORT, conditions=WORLDS, keys=NONMON, penalty_s=900.0, **kw)


def test_gain_100_times_too_small_ranks_worse_than_the_shipped_gain():
    objective = _objective()
    shipped = [math.log10(3.0e3), 2.0, math.log10(600.0)]
    small = [math.log10(3.0e1), 2.0, math.log10(600.0)]
    j_shipped, j_small = objective(shipped), objective(small)
    assert [e.values for e in objective.evaluations] == [
        dict(zip(NONMON, [3.0e3, 100.0, 600.0])),
        dict(zip(NONMON, [30.0, 100.0, 600.0])),
    ]
    ev_shipped, ev_small = objective.evaluations
    # the shipped law detumbles a slow start, the weak one none
    assert ev_shipped.detumbled >= 1 and ev_small.detumbled == 0
    assert j_small > j_shipped
    # a world that has not detumbled scores at least the horizon plus the penalty times ω̄/ω_stop
    figures, _ = objective.figures(small)
    for f in figures:
        assert world_score_s(f, horizon_s=900.0, stop_rate_rad_s=math.radians(0.3), penalty_s=900.0) >= 900.0
    assert j_small > 900.0 + 900.0


def test_world_figures_equal_the_single_runs_summary():
    objective = _objective()
    x = [math.log10(3.0e3), 2.0, math.log10(600.0)]
    figures, cpu_s = objective.figures(x)
    assert cpu_s > 0 and len(figures) == len(WORLDS)
    for k in (1, 3):  # one world that detumbles, one that does not
        sim = magsail_mj.load(CONFIG, [*SHORT, *WORLDS[k]])
        summary = sim.scenario.postprocess(sim.run())[0]
        assert figures[k] == {key: summary[key] for key in FIGURE_KEYS}, k
    assert figures[1]["detumbled"] and not figures[3]["detumbled"]
    # the objective is the mean of the worlds' T_k (no effort weight)
    times = [world_score_s(f, horizon_s=900.0, stop_rate_rad_s=math.radians(0.3), penalty_s=900.0) for f in figures]
    assert objective.score(figures)[0] == float(np.mean(times))
    assert times[1] == figures[1]["detumble_time_below_0p3dps_s"]


def test_effort_weight_adds_the_mean_effort():
    objective = _objective(effort_weight_s_per_Am2s=2.0)
    done = {"status": "completed", "detumbled": True}
    figures = [
        {**done, "detumble_time_below_0p3dps_s": 100.0, "mtq_dipole_effort_Am2s": 10.0},
        {**done, "detumble_time_below_0p3dps_s": 300.0, "mtq_dipole_effort_Am2s": 30.0},
    ]
    assert objective.score(figures) == (200.0 + 2.0 * 20.0, 200.0, 20.0)


def test_training_conditions_are_the_sweep_draws_of_another_seed():
    held_out = design_points(read_toml(BENCH))
    mc = [list(p.overrides)[1:] for p in held_out if p.id.startswith("bdot_law=proportional/")]
    assert all(p.overrides[0].startswith("control.bdot_law=") for p in held_out)
    # with the benchmark's own seed the draws are its conditions, in order
    assert draw_conditions(BENCH, samples=5, seed=2016) == mc[:5]
    training = draw_conditions(BENCH, samples=200, seed=2017)
    values = {v for cond in mc for v in cond}
    assert not values & {v for cond in training for v in cond}
    rates = [np.linalg.norm(json.loads(c[0].split("=", 1)[1])) for c in training]
    assert 2.0 <= min(rates) and max(rates) <= 10.0


def test_example_search_at_ci_size(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(REPO)
    out_file = tmp_path / "search.json"
    args = ["--samples", "4", "--generations", "2", "--popsize", "4", "--horizon-s", "600", "--out", str(out_file)]
    out = load_file_module("examples", "tune_detumble_gains").main(args)
    assert json.loads(out_file.read_text()) == json.loads(json.dumps(out))
    assert out["generations"] == 2 and len(out["evaluations"]) == 1 + 2 * 4
    shipped = out["evaluations"][0]
    assert shipped["values"] == dict(zip(NONMON, [3.0e3, 100.0, 600.0]))
    assert out["best"]["score_s"] <= shipped["score_s"]
    assert out["best"]["score_s"] == min(e["score_s"] for e in out["evaluations"])
    for e in out["evaluations"]:
        assert e["worlds"] == 4 and e["cpu_s"] > 0 and math.isfinite(e["score_s"])
        assert 10.0 <= e["values"]["control.nonmonotonic_gain_per_Nms"] <= 1e6
    assert math.isclose(out["cpu_s"], sum(e["cpu_s"] for e in out["evaluations"]))
    assert '"best"' in capsys.readouterr().out


SEARCHES = ("tuned_search.json", "tuned_search_n200.json")  # training sets of 64 and 200 conditions


def test_tuned_benchmark_runs_each_search_result_on_the_benchmarks_draws():
    tuned_file = BENCH.parent / "detumble_benchmark_tuned.toml"
    tree = read_toml(tuned_file)
    static = REPO / "docs" / "_static" / "detumble_benchmark"
    searches = [json.loads((static / name).read_text()) for name in SEARCHES]
    assert [s["training"]["samples"] for s in searches] == [64, 200]
    tuned, held_out = design_points(tree), design_points(read_toml(BENCH))
    shipped = [p for p in held_out if p.params["control.bdot_law"] == "non_monotonic"]
    assert len(shipped) == 1000 and len(tuned) == 1000 * len(searches)
    for row, search in enumerate(searches):
        assert search["best"]["score_s"] < search["shipped"]["score_s"]
        best = search["best"]["values"]
        points = [p for p in tuned if {k: p.params[k] for k in best} == best]
        assert len(points) == 1000, f"no grid row of {tuned_file.name} holds the best point of {SEARCHES[row]}"
        for t, s in zip(points, shipped):
            assert t.id.split("/")[1] == s.id.split("/")[1] and t.id != s.id
            assert {k: v for k, v in t.params.items() if k not in best} == s.params
    assert tree["set"] == read_toml(BENCH)["set"] and tree["report"] == read_toml(BENCH)["report"]
