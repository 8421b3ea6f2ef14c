"""A world that goes bad stops alone; the others go on and equal their single runs.

In one batch, world 1's config diverges in its first step (an initial rate of 3e10 °/s: MuJoCo
flags the position of the step from t = 0.2 s) and world 2 is forced to diverge mid-run (an
infinite rate written into its state at t = 8 s, into its single run's too). Each bad world must end
as its single run ends — status ``diverged``, the same message and time, the same records (the
record of the flagged state dropped) — its MuJoCo state must stay as it was when it stopped, and
worlds 0 and 3 must complete and equal their single runs bit for bit.
"""

from __future__ import annotations

import numpy as np

import magsail_mj
from tests.test_batch_equals_single import PRE, assert_same_records

SHARED = ["sim.duration_s=20"]
WORLDS = [
    [],
    ["initial.omega0_deg_s=[3e10, 1e10, 0.0]"],
    ["initial.omega0_deg_s=[2.0, 9.0, -4.0]"],
    ['orbit.epoch="2016-09-01T00:00:00Z"'],
]
FORCED, AT_STEP = 2, 40


def test_diverged_worlds_stop_alone():
    sim = magsail_mj.load(PRE, SHARED, world_overrides=WORLDS)
    assert sim.step(AT_STEP) == ["running", "diverged", "running", "running"]
    frozen = sim.get_state()["mj_state"][1].copy()
    sim.batch.bind("qvel")[FORCED, 3] = np.inf
    result = sim.run()
    assert result.status == ["completed", "diverged", "diverged", "completed"]
    assert np.array_equal(sim.get_state()["mj_state"][1], frozen)  # stopped: not stepped again
    for k, extra in enumerate(WORLDS):
        single = magsail_mj.load(PRE, [*SHARED, *extra])
        if k == FORCED:
            single.step(AT_STEP)
            single.data.qvel[3] = np.inf
        ref = single.run()
        mine = result.worlds[k]
        assert (mine.status, mine.message, mine.t_end_s) == (ref.status, ref.message, ref.t_end_s), k
        assert_same_records(mine.records, ref.records, f"world {k}")
    assert "at t = 0.2 s" in result.worlds[1].message and len(result.worlds[1].records["t"]) == 1
    assert result.worlds[FORCED].t_end_s == AT_STEP * 0.2
