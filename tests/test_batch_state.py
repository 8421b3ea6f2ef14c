"""A batch's state as plain data: a round trip through get_state/set_state is bit-identical.

A batch stepped to an arbitrary step hands out its state; the run that follows is then repeated
from that state (in the same batch, and in a second batch built from the same configs), and the
records and final states must be equal bit for bit; ``reset`` repeats the first run from t = 0.
"""

from __future__ import annotations

import numpy as np

import magsail_mj
from tests.test_batch_equals_single import PRE, assert_same_records

SHARED = ["sim.duration_s=16"]
WORLDS = [[], ["initial.omega0_deg_s=[2.0, 9.0, -4.0]", 'control.bdot_form="filtered"'], ["spacecraft.mass_kg=4.4"]]


def assert_same_state(a, b) -> None:
    assert a.keys() == b.keys()
    for key in a:
        if isinstance(a[key], dict):
            assert_same_state(a[key], b[key])
        else:
            assert np.array_equal(np.asarray(a[key]), np.asarray(b[key])), key


def test_get_set_state_round_trip_and_reset():
    sim = magsail_mj.load(PRE, SHARED, world_overrides=WORLDS)
    assert sim.step(37) == ["running"] * 3 and sim.time == 37 * 0.2
    state = sim.get_state()
    first = sim.run()
    end = sim.get_state()
    assert first.status == ["completed"] * 3

    sim.set_state(state)
    assert_same_state(sim.get_state(), state)
    again = sim.run()
    assert_same_state(sim.get_state(), end)
    for k in range(3):
        assert_same_records(again.worlds[k].records, first.worlds[k].records, f"world {k}")

    other = magsail_mj.load(PRE, SHARED, world_overrides=WORLDS)
    other.set_state(state)
    elsewhere = other.run()
    assert_same_state(other.get_state(), {**end, "n_records": other.get_state()["n_records"]})
    n = len(first.worlds[0].records["t"])
    for k in range(3):
        m = len(elsewhere.worlds[k].records["t"])
        tail = {name: np.asarray(v)[-m:] for name, v in first.worlds[k].records.items()}
        assert_same_records(elsewhere.worlds[k].records, tail, f"world {k} in another batch")
    assert len(elsewhere.worlds[0].records["t"]) == n - 8  # records 0 … 7 s were made before the state

    sim.reset()
    assert sim.time == 0.0 and sim.status == ["running"] * 3
    fresh = sim.run()
    for k in range(3):
        assert_same_records(fresh.worlds[k].records, first.worlds[k].records, f"world {k} after reset")
