"""A batch with compiled loads (``sim.loads = "compiled"``): every world equals its single compiled run.

The worlds run on models with the cubesat-loads plugin (each world on a model of its own numbers:
parameter block and environment table, :func:`magsail_mj.concepts.cnusail.batch_compiled.world_models`),
are stepped natively between the controller's samples and the records, and each world's records,
status, message and end time must equal ``magsail_mj.load`` of that world's config with compiled
loads bit for bit (``np.array_equal``): the plugin computes each world's torques in its own MjData
as the single run's does, and the B-dot controller over the world axis rounds as the single run's.
A world that goes bad inside a native chunk stops alone, dated as its single run dates it.
"""

from __future__ import annotations

import numpy as np
import pytest

import magsail_mj
from magsail_mj.bench import bench
from magsail_mj.config import ConfigError
from tests.test_batch_equals_single import POST, PRE, assert_same_records

COMPILED = "sim.loads='compiled'"


def compare(config: str, shared: list[str], worlds: list[list[str]], *, nthread: int = 1):
    sim = magsail_mj.load(config, [*shared, COMPILED], world_overrides=worlds, nthread=nthread)
    result = sim.run()
    for k, extra in enumerate(worlds):
        single = magsail_mj.load(config, [*shared, COMPILED, *extra]).run()
        mine, where = result.worlds[k], f"world {k} {extra}"
        assert (mine.status, mine.message, mine.t_end_s, mine.steps) == (
            single.status,
            single.message,
            single.t_end_s,
            single.steps,
        ), where
        assert_same_records(mine.records, single.records, where)
    return sim, result


def test_stowed_compiled_worlds_equal_their_single_compiled_runs():
    worlds = [
        [],
        ["initial.omega0_deg_s=[2.0, 9.0, -4.0]", "control.bdot_gain_Am2s_T=20000.0"],
        ['orbit.epoch="2016-06-01T12:00:00Z"', "initial.omega0_deg_s=[-3.0, 1.0, 8.0]"],
        ["spacecraft.mass_kg=4.5", "spacecraft.inertia_kgm2=[0.07, 0.06, 0.015]"],
        [
            'control.bdot_form="filtered"',
            'actuators.wheels.model="ideal"',
            "initial.wheel_speed_rpm=[7000.0, -100.0, 3000.0]",
        ],
        [
            'actuators.mtq.limits="half_watt"',
            "spacecraft.residual_dipole_Am2=[0.0, 0.0, 0.0]",
            "drag.drag_coefficient=2.5",
            "gravity.classical_torque=false",
        ],
        ['control.bdot_law="bang_bang"', "initial.omega0_deg_s=[5.0, 5.0, -5.0]"],
    ]
    sim, result = compare(PRE, ["sim.duration_s=30"], worlds, nthread=2)
    assert result.status == ["completed"] * len(worlds)
    # world 1 (a controller gain and an initial rate) and world 6 share world 0's model; the
    # others' numbers (epoch table, inertia and mass, wheel model, dipole and drag) are in their own
    models = sim.batch.models
    assert models[1] is models[0] and models[6] is models[0]
    assert len({id(m) for m in models}) == 5
    bus = sim.model.body("bus").id
    assert models[3].body_mass[bus] != models[0].body_mass[bus]
    assert not np.array_equal(models[2].numeric_data, models[0].numeric_data)
    w0, w3 = result.worlds[0].records["qvel"], result.worlds[3].records["qvel"]
    assert np.array_equal(w0[0], w3[0]) and not np.allclose(w0[-1], w3[-1], rtol=1e-3, atol=0.0)


def test_deployed_compiled_worlds_with_stage_loads_equal_their_single_runs():
    worlds = [
        [],
        ["srp.enabled=false", "initial.omega0_deg_s=[1.0, -2.0, 6.0]"],
        ["spacecraft.r_cp_m=[0.02, 0.0, 0.12]", "spacecraft.sail_area_m2=3.0", 'orbit.epoch="2016-03-20T06:00:00Z"'],
    ]
    _, result = compare(POST, ["sim.duration_s=12", "sim.load_timing='stage'"], worlds)
    assert result.status == ["completed"] * len(worlds)


def test_a_compiled_world_that_goes_bad_stops_alone():
    """World 1 blows up in its first native chunk (3e10 °/s), world 2 gets an infinite rate at step
    41 (inside a chunk of five steps); both end as their single compiled runs, the others complete."""
    shared = ["sim.duration_s=20"]
    worlds = [
        [],
        ["initial.omega0_deg_s=[3e10, 1e10, 0.0]"],
        ["initial.omega0_deg_s=[2.0, 9.0, -4.0]"],
        ['orbit.epoch="2016-09-01T00:00:00Z"'],
    ]
    forced, at_step = 2, 41
    sim = magsail_mj.load(PRE, [*shared, COMPILED], world_overrides=worlds)
    assert sim.step(at_step) == ["running", "diverged", "running", "running"]
    frozen = sim.get_state()["mj_state"][1].copy()
    sim.batch.bind("qvel")[forced, 3] = np.inf
    result = sim.run()
    assert result.status == ["completed", "diverged", "diverged", "completed"]
    assert np.array_equal(sim.get_state()["mj_state"][1], frozen)  # stopped: not stepped again
    for k, extra in enumerate(worlds):
        single = magsail_mj.load(PRE, [*shared, COMPILED, *extra])
        if k == forced:
            single.step(at_step)
            single.data.qvel[3] = np.inf
        ref = single.run()
        mine = result.worlds[k]
        assert (mine.status, mine.message, mine.t_end_s) == (ref.status, ref.message, ref.t_end_s), k
        assert_same_records(mine.records, ref.records, f"world {k}")


def test_compiled_batch_state_continues_bit_for_bit():
    worlds = [[], ["initial.omega0_deg_s=[2.0, 9.0, -4.0]"]]
    sim = magsail_mj.load(PRE, ["sim.duration_s=20", COMPILED], world_overrides=worlds)
    sim.step(37)  # between two controller samples: the next chunk is a part of one
    state = sim.get_state()
    first = sim.run()
    sim.set_state(state)
    again = sim.run()
    for k in range(len(worlds)):
        assert_same_records(again.worlds[k].records, first.worlds[k].records, f"world {k}")
    sim.reset()
    assert len(sim.records(0)["t"]) == 0 and sim.time == 0.0


def test_loads_must_be_one_way_in_every_world():
    with pytest.raises(ConfigError, match=r"world 1: sim\.loads: must be the same in every world of a batch"):
        magsail_mj.load(PRE, ["sim.duration_s=10"], world_overrides=[[], [COMPILED]])


def test_bench_worlds_adds_the_compiled_batch():
    out = bench(PRE, duration_s=2.0, worlds=2)
    assert out["loads"] == "python" and out["us_per_world_step_compiled"] > 0
    assert out["ratio_to_mj_step_compiled"] == pytest.approx(
        out["us_per_world_step_compiled"] / out["mj_step_us_compiled_passes"], rel=1e-12
    )
    assert out["cpu_ratio_to_mj_step_compiled"] == pytest.approx(
        out["cpu_us_per_world_step_compiled"] / out["mj_step_cpu_us_compiled_passes"], rel=1e-12
    )
    own = bench(PRE, overrides=[COMPILED], duration_s=2.0, worlds=2)
    assert own["loads"] == "compiled" and "us_per_world_step_compiled" not in own and own["us_per_world_step"] > 0
