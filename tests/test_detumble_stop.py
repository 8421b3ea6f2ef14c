"""The detumble stop rule (``sim.stop_rate_deg_s``, ``sim.stop_hold_s``) and the detumble benchmark's
summary figures (``mtq_dipole_effort_Am2s``, ``detumbled``, ``stop_rule_time_s``,
``ended_by_stop_rule``).

A run with the rule must end at the first record at which its own records, run without the rule,
meet the hold condition, with the same records up to there (bit for bit: stopping changes nothing
before the stop); a batch's worlds stop alone at their single runs' records. The figures are
checked against values worked out by hand on synthetic records.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import magsail_mj
from magsail_mj.concepts.cnusail.metrics import dipole_effort, held_on_integral, time_stays_below
from magsail_mj.config import ConfigError, load_config
from magsail_mj.loads.actuators_cubesat import MagnetorquerCycle, mtq_power
from magsail_mj.sim import HoldBelow, hold_below_time, vector_norm

ROOT = Path(__file__).resolve().parents[1]
PRE = ROOT / "magsail_mj" / "concepts" / "cnusail" / "configs" / "detumble_pre.toml"
LIFETIME = ROOT / "magsail_mj" / "concepts" / "cnusail" / "configs" / "lifetime.toml"
# 600 s from 1.7 °/s: |ω| first falls below 1.64 °/s at 155 s, rises above it at 206 s and falls
# below for good at 235 s, so a 60 s hold must restart once (ends at 295 s, not 215 s)
BASE = ["sim.duration_s=600", "sim.progress=false", "initial.omega0_deg_s=[1.0, -1.2, 0.8]"]
STOP = ["sim.stop_rate_deg_s=1.64", "sim.stop_hold_s=60"]
TOL_S = 1e-6 * 0.2  # the rule's hold comparison tolerance: 1e-6 of the 0.2 s step


def test_hold_below_time_by_hand():
    t = np.arange(10.0)
    # norms 5, 1, 1, 5, 1, 1, 1, 1, 5, 1 (threshold 2): runs below from t = 1 (2 records), t = 4 (4), t = 9 (1)
    norms = np.array([5, 1, 1, 5, 1, 1, 1, 1, 5, 1], dtype=float)
    x = np.stack([norms * 0.6, norms * 0.8, 0 * norms], axis=1)  # ‖(0.6 s, 0.8 s, 0)‖ = s exactly
    assert np.array_equal(vector_norm(x), norms)
    assert hold_below_time(t, x, threshold=2.0, hold_s=0.0) == 1.0
    assert hold_below_time(t, x, threshold=2.0, hold_s=1.0) == 2.0
    assert hold_below_time(t, x, threshold=2.0, hold_s=2.0) == 6.0  # the run from t = 1 ends at 2
    assert hold_below_time(t, x, threshold=2.0, hold_s=3.0) == 7.0
    assert hold_below_time(t, x, threshold=2.0, hold_s=4.0) is None
    assert hold_below_time(t, x, threshold=1.0, hold_s=0.0) is None  # strictly below
    # the paper-style "stays below to the end" of the same record: the last run, from t = 9
    assert time_stays_below(t, norms, 2.0) == 9.0


def test_rule_record_by_record_equals_the_records_function():
    rng = np.random.default_rng(5)
    t = np.arange(400) * 0.5
    x = rng.normal(size=(400, 3)) * np.linspace(3.0, 0.05, 400)[:, None]
    for hold in (0.0, 0.5, 3.0, 10.0):
        want = hold_below_time(t, x, threshold=1.0, hold_s=hold, tolerance_s=1e-9)
        rule = HoldBelow(probe="w", index=slice(0, 3), threshold=1.0, hold_s=hold, tolerance_s=1e-9, describe="w")
        got = next((tk for tk, xk in zip(t, x) if rule.check(float(tk), {"w": xk}) is not None), None)
        assert got == want and want is not None, hold


def test_dipole_effort_by_hand():
    # 0.2 s steps, 2 s cycle with 0.2 s blanking: N_c = 10, N_on = 9; records every 1 s (5 steps)
    cycle = MagnetorquerCycle(cycle_s=2.0, blank_s=0.2, timestep_s=0.2)
    t = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    m = np.array([[0.1, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.03, 0.04], [0.0, 0.03, 0.04], [9.0, 9.0, 9.0]])
    # [0, 1): 5 on-steps (k = 0…4) → 1 s at 0.1; [1, 2): k = 5…8 on, 9 blanked → 0.8 s at 0.1;
    # [2, 3): 1 s at 0.05; [3, 4): 0.8 s at 0.05; the last record closes the integral
    want = 0.1 * 1.0 + 0.1 * 0.8 + 0.05 * 1.0 + 0.05 * 0.8
    assert dipole_effort(t, m, cycle=cycle) == pytest.approx(want, rel=1e-15, abs=0.0)  # float rounding only
    # a run that ends mid-cycle (t = 3) stops the integral there
    assert dipole_effort(t[:4], m[:4], cycle=cycle) == pytest.approx(0.1 * 1.8 + 0.05 * 1.0, rel=1e-15)
    assert dipole_effort(t[:1], m[:1], cycle=cycle) == 0.0


def test_magnetorquer_energy_integrates_the_held_power_over_the_on_time():
    """``mtq_energy_J`` = Σ_{i<n−1} P_i × (on-time from record i to i+1): the last record closes the
    integral (a sum over all n records would count one record interval too many)."""
    cycle = MagnetorquerCycle(cycle_s=2.0, blank_s=0.2, timestep_s=0.2)
    t = np.array([0.0, 1.0, 2.0, 3.0])
    power_W = np.array([0.5, 0.25, 0.125, 99.0])
    want = 0.5 * 1.0 + 0.25 * 0.8 + 0.125 * 1.0  # on-time of [0, 1), [1, 2), [2, 3) as in the effort above
    assert held_on_integral(t, power_W, cycle=cycle) == pytest.approx(want, rel=1e-15, abs=0.0)
    sim = magsail_mj.load(PRE, ["sim.duration_s=20", "sim.progress=false", "initial.omega0_deg_s=[4.0, -6.0, 2.0]"])
    result = sim.run()
    summary = _summary(sim, result)
    cfg = load_config(PRE)
    mtq = cfg.actuators.mtq
    power = mtq_power(np.asarray(result.records["dipole_cmd_Am2"]), mtq.limit_vector, power_max_W=mtq.power_max_W)
    run_cycle = MagnetorquerCycle(cycle_s=mtq.cycle_s, blank_s=mtq.blank_s, timestep_s=cfg.sim.timestep_s)
    t_rec = np.asarray(result.records["t"])
    assert summary["mtq_energy_J"] == held_on_integral(t_rec, power.sum(axis=1), cycle=run_cycle) > 0.0
    all_records = float(power.sum()) * float(np.median(np.diff(t_rec))) * run_cycle.duty
    assert summary["mtq_energy_J"] < all_records  # the last record's power is not counted


def test_config_keys():
    cfg = load_config(PRE, ["sim.stop_rate_deg_s=0.3", "sim.stop_hold_s=600"])
    assert (cfg.sim.stop_rate_deg_s, cfg.sim.stop_hold_s) == (0.3, 600.0)
    assert load_config(PRE).sim.stop_rate_deg_s is None  # off by default
    with pytest.raises(ConfigError, match=r"sim\.stop_hold_s: .*sim\.stop_rate_deg_s"):
        load_config(PRE, ["sim.stop_hold_s=600"])
    for bad in ("0", "-1"):
        with pytest.raises(ConfigError, match="sim.stop_rate_deg_s"):
            load_config(PRE, [f"sim.stop_rate_deg_s={bad}"])
    with pytest.raises(ConfigError, match="sim.stop_hold_s"):
        load_config(PRE, ["sim.stop_rate_deg_s=0.3", "sim.stop_hold_s=-1"])
    with pytest.raises(ConfigError, match="sim.stop_rate_deg_s: the stop rule ends attitude runs"):
        load_config(LIFETIME, ["sim.stop_rate_deg_s=0.3"])


def _summary(sim, result) -> dict:
    return sim.scenario.postprocess(result)[0]


@pytest.fixture(scope="module")
def free_run():
    sim = magsail_mj.load(PRE, BASE)
    return sim, sim.run()


def test_run_ends_when_the_rate_has_been_held_below(free_run):
    free, ref = free_run
    omega = ref.records["qvel"][:, free.scenario.idx.v_ang]
    t_stop = hold_below_time(ref.records["t"], omega, threshold=math.radians(1.64), hold_s=60.0, tolerance_s=TOL_S)
    first_below = hold_below_time(ref.records["t"], omega, threshold=math.radians(1.64), hold_s=0.0)
    assert t_stop is not None and t_stop - first_below > 60.0  # the hold restarted at least once
    sim = magsail_mj.load(PRE, BASE + STOP)
    result = sim.run()
    assert (result.status, result.t_end_s) == ("completed", t_stop)
    assert "sim.stop_hold_s): held from t = 235 s; the run ended at t = 295 s" in result.message
    n = len(result.records["t"])
    assert result.records["t"][-1] == t_stop
    for key in ref.records:
        assert np.array_equal(result.records[key], ref.records[key][:n]), key
    summary = _summary(sim, result)
    assert summary["ended_by_stop_rule"] is True and summary["stop_rule_time_s"] == t_stop
    assert summary["detumbled"] is True and summary["t_end_s"] == t_stop
    # the run without the rule says nothing of it and has not detumbled to 0.3 °/s in 600 s
    free_summary = _summary(free, ref)
    assert free_summary["ended_by_stop_rule"] is None and free_summary["stop_rule_time_s"] is None
    assert free_summary["detumbled"] is False
    # its effort over the stopped run's records equals the stopped run's
    cycle = MagnetorquerCycle(cycle_s=2.0, blank_s=0.2, timestep_s=0.2)
    assert summary["mtq_dipole_effort_Am2s"] == dipole_effort(
        ref.records["t"][:n], ref.records["dipole_cmd_Am2"][:n], cycle=cycle
    )
    assert summary["mtq_dipole_effort_Am2s"] > 0


def test_rule_never_met_runs_to_the_end(free_run):
    sim = magsail_mj.load(PRE, BASE + ["sim.stop_rate_deg_s=0.3", "sim.stop_hold_s=60"])
    result = sim.run()
    assert (result.status, result.t_end_s, result.message) == ("completed", 600.0, "")
    summary = _summary(sim, result)
    assert summary["ended_by_stop_rule"] is False and summary["stop_rule_time_s"] is None
    assert summary["detumbled"] is False
    assert np.array_equal(result.records["qvel"], free_run[1].records["qvel"])


def test_batch_worlds_stop_alone_at_their_single_runs_records():
    worlds = [STOP, ["sim.stop_rate_deg_s=1.7", "sim.stop_hold_s=30"], [], ["sim.stop_rate_deg_s=1.0"]]
    batch = magsail_mj.load(PRE, BASE, world_overrides=worlds)
    result = batch.run()
    ends = [w.t_end_s for w in result.worlds]
    assert ends[0] == 295.0 and ends[1] < ends[0] and ends[2] == ends[3] == 600.0
    for k, overrides in enumerate(worlds):
        single = magsail_mj.load(PRE, BASE + overrides)
        want = single.run()
        got = result.worlds[k]
        assert (got.status, got.message, got.t_end_s, got.steps) == (
            want.status,
            want.message,
            want.t_end_s,
            want.steps,
        )
        for key in want.records:
            assert np.array_equal(got.records[key], want.records[key]), (k, key)
        assert _summary(single, want)["detumbled"] == (k < 2)


def test_compiled_loads_run_ends_at_the_same_rule():
    compiled = ["sim.loads=compiled"]
    free_sim = magsail_mj.load(PRE, BASE + compiled)
    free = free_sim.run()
    omega = free.records["qvel"][:, free_sim.scenario.idx.v_ang]
    t_stop = hold_below_time(free.records["t"], omega, threshold=math.radians(1.64), hold_s=60.0, tolerance_s=TOL_S)
    result = magsail_mj.load(PRE, BASE + compiled + STOP).run()
    assert (result.status, result.t_end_s) == ("completed", t_stop)
    n = len(result.records["t"])
    for key in free.records:
        assert np.array_equal(result.records[key], free.records[key][:n]), key
