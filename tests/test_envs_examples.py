"""The environment examples run (short durations) and do what they say."""

from __future__ import annotations

import json
import math

import numpy as np

from magsail_mj import envs
from magsail_mj.concepts.cnusail import env as cnusail  # noqa: F401  (registers the CNUSAIL and MSAC tasks)
from magsail_mj.concepts.msac import env as msac  # noqa: F401  (registers the CNUSAIL and MSAC tasks)
from tests.conftest import REPO, load_file_module


def _example(name: str):
    return load_file_module("examples", name)


def test_random_policy_runs_episodes(monkeypatch, capsys):
    monkeypatch.chdir(REPO)
    module = _example("random_policy")
    rows = module.main(["cnusail/detumble", "--set", "sim.duration_s=3"])
    rows += module.main(["magsail_mj/concepts/msac/configs/slow_1hz.toml", "--set", "sim.duration_s=2", "--seed", "1"])
    assert [r["steps"] for r in rows] == [3, 2]
    for row in rows:
        assert row["last"] and row["discount"] == 1.0
        assert math.isfinite(row["return"]) and row["wall_per_step_s"] > 0
    printed = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [p["env"] for p in printed] == ["cnusail/detumble", "magsail_mj/concepts/msac/configs/slow_1hz.toml"]


def test_same_law_three_concepts(monkeypatch, capsys):
    """The example runs the law on the three spacecraft and reports the torque delivered against the
    torque requested. Every mean cosine lies in [−1, 1] (1e-12 for round-off). The reflector's coils
    deliver the pitch request as asked (the dipole field of the planar orbit lies in the orbit plane,
    so the request about the pitch axis, the orbit normal, is ⟂ B and the projection leaves it
    unchanged; the cap is not reached): mean cosine 1 and equal mean magnitudes to 1e-9. The cubesat's wheel driver
    delivers along the request: mean cosine ≥ 0.9999. The rods deliver only a part of the
    truss's request (the allocation saturates): mean delivered < mean requested."""
    monkeypatch.chdir(REPO)
    rows = _example("same_law_three_concepts").main(["--duration-s", "10", "--units", "3"])
    assert len(rows) == 3
    assert all(r["status"] == "completed" for r in rows)
    printed = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [p["spacecraft"] for p in printed] == [r["spacecraft"] for r in rows] == ["truss", "cubesat", "reflector"]
    by = {r["spacecraft"]: r for r in rows}
    for r in rows:
        assert abs(r["mean_cos_request_delivered"]) <= 1.0 + 1e-12, r
        assert r["mean_request_Nm"] > 0 and r["mean_delivered_Nm"] > 0, r
    reflector, cubesat, truss = by["reflector"], by["cubesat"], by["truss"]
    assert abs(reflector["mean_cos_request_delivered"] - 1.0) <= 1e-9
    assert math.isclose(reflector["mean_delivered_Nm"], reflector["mean_request_Nm"], rel_tol=1e-9)
    assert cubesat["mean_cos_request_delivered"] >= 0.9999
    assert truss["mean_delivered_Nm"] < truss["mean_request_Nm"]


def test_search_gains_reports_best_against_shipped(monkeypatch, capsys):
    monkeypatch.chdir(REPO)
    out = _example("search_gains").main(
        [
            "--config",
            "magsail_mj/concepts/cnusail/configs/detumble_pre.toml",
            "--duration-s",
            "30",  # noqa: E501
            "--evaluations",
            "3",
        ]
    )
    ev = out["evaluations"]
    assert 2 <= len(ev) <= 4
    assert ev[0]["gain_Am2s_T"] == out["shipped_gain_Am2s_T"] == 3.0e4
    assert out["best_score_s"] == min(e["score_s"] for e in ev) <= ev[0]["score_s"]
    assert all(10**3.5 <= e["gain_Am2s_T"] <= 10**5.5 for e in ev)
    assert json.loads(capsys.readouterr().out)["best_gain_Am2s_T"] == out["best_gain_Am2s_T"]


def test_search_gains_law_with_shipped_gain_is_the_shipped_bdot(monkeypatch):
    """The example's observation-driven B-dot with the config's gain moves the cubesat exactly as
    the flight controller does (same MuJoCo trajectory)."""
    monkeypatch.chdir(REPO)
    module = _example("search_gains")
    env = envs.load("magsail_mj/concepts/cnusail/configs/detumble_pre.toml", ["sim.duration_s=30"], randomize=False)
    trajectories = []
    for policy in (module.BdotPolicy(env, env.physics.cfg.control.bdot_gain_Am2s_T), envs.shipped_policy(env)):
        ts = env.reset()
        while not ts.last():
            ts = env.step(policy(ts))
        trajectories.append(env.physics.sim.records()["qvel"].copy())
    np.testing.assert_array_equal(trajectories[0], trajectories[1])
    assert np.linalg.norm(trajectories[0][-1, 3:6]) < np.linalg.norm(trajectories[0][0, 3:6])
