"""A run stepped right after :func:`magsail_mj.load` and the same run after ``Simulation.reset()`` are
bitwise equal, for a config of every concept whose runner is a :class:`~magsail_mj.sim.Simulation`
(and for the MSAC runner).

``magsail_mj.load`` configures the load timing (``sim.load_timing``) after the simulation is built,
when ``reset``'s initial state has been taken: the timing is configuration, which a reset keeps
(``sim.load_timing = "midpoint"`` is set for every concept so that the timing matters).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import magsail_mj
from magsail_mj.sim import Simulation
from tests.conftest import REPO

CONCEPTS = REPO / "magsail_mj/concepts"
STEPS = 12

CASES = {
    "cnusail": ("cnusail/configs/detumble_pre.toml", ["sim.duration_s=20"]),
    "current_loops": ("current_loops/configs/slew.toml", ["lattice.units=4", "sim.duration_s=1", "sim.record_every=5"]),
    "reflector": ("reflector/configs/detumble.toml", ["sim.duration_s=2", "sim.record_every=5"]),
    "truss_magnetorquer": (
        "truss_magnetorquer/configs/detumble.toml",
        ["lattice.units=4", "sim.duration_s=2", "sim.record_every=5"],
    ),
}


def _run(sim: Any) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    sim.step(STEPS)
    return sim.data.qpos.copy(), sim.data.qvel.copy(), {k: np.array(v) for k, v in sim.records().items()}


@pytest.mark.parametrize("concept", sorted(CASES))
def test_a_run_after_reset_equals_the_run_after_load(concept):
    config, overrides = CASES[concept]
    sim = magsail_mj.load(CONCEPTS / config, [*overrides, "sim.load_timing=midpoint"])
    assert isinstance(sim, Simulation) and sim.n_steps > STEPS
    qpos, qvel, records = _run(sim)
    sim.reset()
    assert sim.timing.mode == "midpoint"
    again_qpos, again_qvel, again_records = _run(sim)
    np.testing.assert_array_equal(again_qvel, qvel)
    np.testing.assert_array_equal(again_qpos, qpos)
    assert records.keys() == again_records.keys()
    for name, values in records.items():
        np.testing.assert_array_equal(again_records[name], values, err_msg=name)


def test_the_msac_runner_after_reset_equals_the_run_after_load():
    sim = magsail_mj.load(CONCEPTS / "msac/configs/paper_1khz.toml", ["sim.duration_s=0.002"])
    assert sim.n_steps > STEPS
    first = _run(sim)
    sim.reset()
    again = _run(sim)
    np.testing.assert_array_equal(again[1], first[1])
    np.testing.assert_array_equal(again[0], first[0])
